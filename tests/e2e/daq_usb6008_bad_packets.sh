# Short packets (valid, 2 bytes short every 7th transfer) lose nothing; an odd-length garbage
# packet and a packet with padding bits set are rejected whole (never published), counted, and the
# daemon recovers with the gap flagged.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6008 --scenario short --short-every 7 --duration 4 --rate 2000 --decimate 1 \
     --block-scans 10
summary
for sc in garbage padding; do
  vdaq --model 6008 --scenario $sc --duration 4 --event-at 1.5 --rate 2000 --decimate 1 \
       --block-scans 10 --expect-gap --min-usb-errors 1 --max-dropped 2000 \
       --min-rate-ratio 0
  summary
  report 'r["states_seen"]' | grep -qE "odd-length|padding" || fail "$sc: the fault does not say why"
done
echo ok
