# Continuous acquisition as back-to-back finite segments (protocol [10]): with 0.5 s segments the
# daemon re-arms 10 times; the scan index must carry over with no gap and no value error, and the
# seam (device idle between segments) is measured by the virtual device. Throughput is below the
# device rate by seam/segment (the device does not sample during a seam; 4-10 % with 0.5-s
# segments and 20-50-ms seams on a loaded host), hence the loose 0.8 bound.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6008 --scenario normal --duration 6 --rate 2000 --decimate 1 --block-scans 10 \
     --segment-scans 1000 --min-rate-ratio 0.8
summary
[ "$(report segments)" -ge 8 ] || fail "expected >= 8 segments, got $(report segments)"
[ "$(report index_jumps_without_gap_flag)" = 0 ] || fail "index jumps"
echo "seam_us: $(report seam_us)"
# At 200 scans/s (the slow end) with 1-s segments: utime never steps back across the session start
# and the seams (the checker fails on any backstep), values exact.
vdaq --model 6008 --scenario normal --duration 3.5 --rate 200 --decimate 1 --block-scans 1 \
     --segment-scans 200 --min-rate-ratio 0.8
summary
[ "$(report segments)" -ge 3 ] || fail "200 Hz: expected >= 3 segments"
[ "$(report utime_backsteps)" = 0 ] || fail "200 Hz: utime stepped back"
echo ok
