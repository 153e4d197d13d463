# pof-daqd's own cost without any USB emulation: the sim:synthetic backend at the USB-6009's
# 48 kS/s (16000 scans/s x 3 channels) for 10 s. Indices continuous, FLAG_SIMULATED set, CPU
# below the 5 % target (BENCHMARKS.md).
source "$(dirname "$0")/daq_lib.sh"
vdaq --model sim --duration 12 --warmup 2 --rate 16000 --decimate 1 --block-scans 50
summary
cpu=$(report 'r["daemon_cpu_percent"]')
/usr/bin/python3 -c "import sys; sys.exit(0 if float('$cpu') < 5.0 else 1)" || fail "pof-daqd used $cpu % of a core (target < 5 %)"
echo ok
