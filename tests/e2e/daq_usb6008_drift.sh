# A device crystal 300 ppm fast: without correction the timestamps would be 3 ms off after 10 s;
# the drift estimate keeps them within 1 ms of the device's own clock.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6008 --scenario normal --duration 12 --warmup 4 --rate 2000 --decimate 10 \
     --clock-ppm 300 --max-ts-error-us 1000
summary
echo ok
