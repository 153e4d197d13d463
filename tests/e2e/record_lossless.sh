# pof record loses nothing in a burst where stock lcm-logger, listening to the same traffic in the
# same run, loses messages (docs/lcm.md). Publishes raw_block_t with seq 0..N-1 over
# udpm ttl=0 on a private port, then counts what each log holds.
#   RATE (msg/s) and COUNT can be overridden for BENCHMARKS.md runs.
source "$(dirname "$0")/lib.sh"
RATE=${RATE:-50000}
COUNT=${COUNT:-$((RATE * 3))}
# A random port: other test runs on this host (ttl=0 multicast is host-wide) must not cross in.
PORT=${PORT:-$((20000 + RANDOM % 30000))}
URL="udpm://239.255.76.67:$PORT?ttl=0"
PUB="$BIN_DIR/../tests/pof-testpub"

rmem=$(cat /proc/sys/net/core/rmem_max)
[ "$rmem" -ge 2097152 ] || echo "note: net.core.rmem_max=$rmem is below 2 MiB; install deploy/sysctl.d/60-pof-lcm.conf"

"$BIN_DIR/pof" record -q -o pof.lcmlog --lcm-url "$URL" -c 'POF_BURST' 2>record.err &
rec=$!
lcm-logger -q -c 'POF_BURST' --lcm-url="$URL" stock.lcmlog 2>logger.err &
stock=$!
# LIBLCM=1 (BENCHMARKS.md): a third listener, pof record on liblcm's receive path (--liblcm).
lib=
if [ "${LIBLCM:-0}" = 1 ]; then
  "$BIN_DIR/pof" record -q --liblcm -o liblcm.lcmlog --lcm-url "$URL" -c 'POF_BURST' 2>liblcm.err &
  lib=$!
fi
trap 'kill $rec $stock $lib 2>/dev/null || true' EXIT
sleep 1
"$PUB" --lcm-url "$URL" burst --channel POF_BURST --count "$COUNT" --rate "$RATE" | tee pub.out
sleep 1
kill -INT $rec $stock $lib
wait $rec || fail "pof record exited $?: $(cat record.err)"
wait $stock || true
[ -z "$lib" ] || wait $lib || true
trap - EXIT

expect_exit 0 "$BIN_DIR/pof" record --check pof.lcmlog
echo "$out"
pof_n=$(awk '/complete events/ {print $2; exit}' <<<"$out")
if ! grep -q "POF_BURST .* $COUNT events  seq 0..$((COUNT - 1)), 0 gaps (0 missing)" <<<"$out"; then
  echo "RESULT rate_requested=$RATE count=$COUNT pof_record=$pof_n ($(awk -v n="$pof_n" -v c="$COUNT" 'BEGIN { printf "%.2f", 100 * (c - n) / c }') % lost)"
  fail "pof record lost messages at $RATE msg/s: $out"
fi
/usr/bin/python3 - "$COUNT" <<'PY' || fail "manifest counters disagree with the log"
import json, sys
c = json.load(open("pof.manifest.json"))["counters"]
n = int(sys.argv[1])
ok = c["received"] == n and c["written"] == n and c["dropped_handoff"] == 0 and c["udp_kernel_drops"] == 0
print("manifest counters:", c)
sys.exit(0 if ok else 1)
PY

set +e
"$BIN_DIR/pof" record --check stock.lcmlog >stock.check
set -e
stock_n=$(awk '/complete events/ {print $2; exit}' stock.check)
loss=$(awk -v n="$stock_n" -v c="$COUNT" 'BEGIN { printf "%.2f", 100 * (c - n) / c }')
sent_rate=$(awk '{print $(NF-1)}' pub.out | tr -d '(')
lib_result=
if [ -n "$lib" ]; then
  set +e
  "$BIN_DIR/pof" record --check liblcm.lcmlog >liblcm.check
  set -e
  lib_n=$(awk '/complete events/ {print $2; exit}' liblcm.check)
  lib_result=" pof_record_liblcm=$lib_n ($(awk -v n="$lib_n" -v c="$COUNT" 'BEGIN { printf "%.2f", 100 * (c - n) / c }') % lost)"
fi
echo "RESULT rate_requested=$RATE rate_sent=$sent_rate count=$COUNT pof_record=$COUNT (0.00 % lost) lcm_logger=$stock_n ($loss % lost)$lib_result"
