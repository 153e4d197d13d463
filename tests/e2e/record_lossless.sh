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

start_ready notify record.err "$BIN_DIR/pof" record -q -o pof.lcmlog --lcm-url "$URL" -c 'POF_BURST'
rec=$!
start_ready "$PORT" logger.err lcm-logger -q -c 'POF_BURST' --lcm-url="$URL" stock.lcmlog
stock=$!
# LIBLCM=1 (BENCHMARKS.md): a third listener, pof record on liblcm's receive path (--liblcm).
lib=
if [ "${LIBLCM:-0}" = 1 ]; then
  start_ready notify liblcm.err "$BIN_DIR/pof" record -q --liblcm -o liblcm.lcmlog --lcm-url "$URL" -c 'POF_BURST'
  lib=$!
fi
trap 'kill $rec $stock $lib 2>/dev/null || true' EXIT
"$PUB" --lcm-url "$URL" burst --channel POF_BURST --count "$COUNT" --rate "$RATE" | tee pub.out
# Every listener read what the kernel queued for it (what overflowed a buffer is lost already).
wait_until --drained "$PORT" || fail "the listeners did not read what was sent"
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
"$PY" "$SOURCE_DIR/tests/e2e/record_manifest_check.py" lossless pof.manifest.json "$COUNT" ||
  fail "manifest counters disagree with the log"

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
