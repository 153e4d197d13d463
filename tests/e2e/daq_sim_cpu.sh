# pof-daqd's own cost without any USB emulation: the sim:synthetic backend at the USB-6009's
# 48 kS/s (16000 scans/s x 3 channels) for 10 s. Checks indices continuous, FLAG_SIMULATED set,
# nothing dropped, clean stop; prints the CPU figure (BENCHMARKS.md holds the measured ones: speed
# is measured there, in same-run comparisons, not asserted on a shared CI host).
source "$(dirname "$0")/daq_lib.sh"
vdaq --model sim --duration 12 --warmup 2 --rate 16000 --decimate 1 --block-scans 50
summary
[ "$(report status.dropped_scans)" = 0 ] || fail "dropped scans"
echo ok
