#!/usr/bin/env bash
# End-to-end latency for controller authors (BENCHMARKS.md, "End-to-end latency"):
#
#   scan converted on the virtual USB-6008 (umockdev, fed by the simulator)
#     -> pof-daqd (real libusb) -> POF_RAW -> pof-compensatord -> POF_ANGLE -> the example client
#
# The client (examples/cpp_client/angle_client.cpp) reports the age of every angle: receive time
# minus angle_t.utime, the host time of the scan the angle was computed from (pof-daqd's estimate;
# pof-vdaq reports its error against the device's true scan times). Compared in the same run with:
#   - the raw LCM hop: pof-testpub publishes angle_t stamped at publish time -> the same client;
#   - the device's own packet time: a 64-byte bulk packet holds 32 samples (docs/daq.md), so at
#     R scans/s of 3 channels the first scan of a packet waits 32 / (3 R) s before it can leave;
#   - the decimation's own delay: a published scan is the mean of D device scans stamped at the
#     window's centre (its group delay), which can only be sent (D - 1) / 2 scans later.
# "Added by pofkit" = pipeline p99 - packet time - decimation delay - raw hop p99.
#
#   tools/bench/latency.sh [build-dir] [seconds]      (./pofkit bench runs it)
set -euo pipefail
BUILD=$(readlink -f "${1:-build}")
SECONDS_PER_RUN=${2:-20}
BIN="$BUILD/bin"; TESTS="$BUILD/tests"
command -v umockdev-wrapper >/dev/null || { echo "latency: umockdev-wrapper missing (package umockdev)" >&2; exit 1; }
work=$(mktemp -d /tmp/pof-latency.XXXXXX)
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; rm -rf "$work"; }
trap cleanup EXIT
cd "$work"
"$BIN/pof" sim paper -o cal.csv --seed 11 2>/dev/null
"$BIN/pof" calibrate cal.csv -o cal.toml >/dev/null 2>&1
printf 'schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n' >pot.toml

field() { awk -v k="$1" '/^summary:/ { for (i = 1; i <= NF; ++i) { split($i, kv, "="); if (kv[1] == k) print kv[2] } }' "$2"; }

raw_hop() {  # the same client on pof-testpub's angles, stamped at publish
  local port=$((20000 + RANDOM % 30000)) n=$((SECONDS_PER_RUN * 100))
  local url="udpm://239.255.76.67:$port?ttl=0"
  "$TESTS/pof-angle-client" --lcm-url "$url" --count $n --timeout 10 >raw.out 2>&1 &
  local c=$!
  sleep 0.3
  "$TESTS/pof-testpub" --lcm-url "$url" session --duration $((SECONDS_PER_RUN + 2)) >/dev/null
  wait $c || true
  printf '| raw LCM hop (pof-testpub -> client), 100 Hz | - | %s | %s | %s |\n' \
    "$(field age_p50_ms raw.out)" "$(field age_p99_ms raw.out)" "$(field age_max_ms raw.out)"
}

pipeline() {  # pipeline <scan rate> <decimate> <label>
  local rate=$1 dec=$2 label=$3 port=$((20000 + RANDOM % 30000))
  local url="udpm://239.255.77.67:$port?ttl=0"
  local out_hz; out_hz=$(awk -v r="$rate" -v d="$dec" 'BEGIN { printf "%d", r / d }')
  "$BIN/pof-compensatord" --cal cal.toml --pot-cal pot.toml --lcm-url "$url" 2>comp.log &
  local comp=$!; pids+=($comp)
  "$TESTS/pof-angle-client" --lcm-url "$url" --count $((SECONDS_PER_RUN * out_hz)) --timeout 10 >pipe.out 2>&1 &
  local c=$!
  sleep 0.5
  umockdev-wrapper "$BIN/pof-vdaq" --daemon "$BIN/pof-daqd" --model 6008 --scenario normal \
    --duration $((SECONDS_PER_RUN + 2)) --warmup 1 --rate "$rate" --decimate "$dec" --block-scans 1 \
    --lcm-port "$port" --report vdaq.json >vdaq.out 2>vdaq.err || { tail -5 vdaq.err >&2; }
  wait $c || true
  kill -TERM $comp; wait $comp || true
  local packet_ms; packet_ms=$(awk -v r="$rate" 'BEGIN { printf "%.2f", 32 / (3 * r) * 1000 }')
  local dec_ms; dec_ms=$(awk -v r="$rate" -v d="$dec" 'BEGIN { printf "%.2f", (d - 1) / 2 / r * 1000 }')
  local ts_err; ts_err=$(/usr/bin/python3 -c 'import json; print(json.load(open("vdaq.json"))["timestamp_abs_error_us"]["p99"])')
  printf '| pipeline, %s scans/s decimated by %s (%s Hz angles); timestamp error p99 %s us | %s + %s | %s | %s | %s |\n' \
    "$rate" "$dec" "$out_hz" "$ts_err" "$packet_ms" "$dec_ms" "$(field age_p50_ms pipe.out)" \
    "$(field age_p99_ms pipe.out)" "$(field age_max_ms pipe.out)"
  echo "$label $packet_ms $dec_ms $(field age_p99_ms pipe.out)" >>pipeline.p99
}

echo "| path | packet time + decimation delay [ms] | age p50 [ms] | age p99 [ms] | age max [ms] |"
echo "|---|---|---|---|---|"
raw_hop
pipeline 2000 10 200Hz      # the shipped configuration (deploy/config/daqd.toml)
pipeline 3333 1 maximum      # USB-6008's 10 kS/s aggregate over 3 channels, every scan published
raw_p99=$(field age_p99_ms raw.out)
while read -r label packet dec p99; do
  awk -v l="$label" -v p="$p99" -v k="$packet" -v d="$dec" -v h="$raw_p99" \
    'BEGIN { printf "%s: added by pofkit at p99 (pipeline - packet time - decimation delay - raw hop): %.2f ms\n", l, p - k - d - h }'
done <pipeline.p99
