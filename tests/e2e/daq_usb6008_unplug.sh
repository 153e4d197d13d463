# Unplug for 1.5 s mid-stream and replug: the daemon publishes `disconnected`, keeps running,
# resumes with the gap flagged by the scan index (FLAG_GAP, first_scan advanced by the outage),
# counts the reconnect, and the volts after the replug are right again.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6008 --scenario unplug --duration 6 --event-at 2 --unplug-for 1.5 --rate 2000 \
     --decimate 10 --expect-gap --expect-state 2 --min-reconnects 1 \
     --max-dropped 100000 --min-rate-ratio 0
summary
gap=$(report gap_scans)
# 1.5 s at 200 published scans/s, plus the time to notice and re-open: 300..500 scans.
[ "$gap" -ge 280 ] && [ "$gap" -le 600 ] || fail "gap of $gap published scans for a 1.5 s outage"
echo ok
