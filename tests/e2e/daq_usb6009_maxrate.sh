# USB-6009 at its maximum, 48 kS/s aggregate (16000 scans/s x 3 channels, 14-bit), for 62 s: zero
# dropped scans, every value within 1 LSB, continuous indices, CPU and latency figures. The
# timestamp bound is loose (5 ms): a loaded 2-core CI host starves the emulator.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6009 --scenario normal --duration 62 --warmup 2 --rate 16000 --decimate 1 \
     --block-scans 50 --max-ts-error-us 5000
summary
echo ok
