# Several sensors on one LCM bus: two full pipelines side by side, LEFT_KNEE and
# RIGHT_KNEE, each pof-daqd (sim backend) -> pof-compensatord with its own sensor id, one
# `pof record` for both. No crosstalk: each compensator sees only its own stream (no lost or
# rejected blocks), publishes one angle per scan of its own sensor, on its own suffixed channels,
# and nothing is published on the unsuffixed channels.
source "$(dirname "$0")/lib.sh"
private_bus
POF="$BIN_DIR/pof"

"$POF" sim paper -o cal.csv 2>/dev/null
"$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
printf 'schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n' > pot.toml

start_ready notify record.log "$POF" record -o both.lcmlog --lcm-url "$URL" -q
pids+=($!); recorder=$!
compensators=()
for id in LEFT_KNEE RIGHT_KNEE; do
  start_ready notify comp-$id.log "$BIN_DIR/pof-compensatord" --cal cal.toml --pot-cal pot.toml --sensor-id $id --lcm-url "$URL"
  pids+=($!); compensators+=($!)
done
# Each pof-daqd runs under caught_up, which returns once its compensator took every block it
# published. Different scenarios, so a crossed stream would show as wrong data, not only wrong counts.
caught_up --lcm-url "$URL" --sensor-id LEFT_KNEE -- \
  "$BIN_DIR/pof-daqd" --device sim:session --sensor-id LEFT_KNEE --lcm-url "$URL" --duration 8 2>daqd-LEFT_KNEE.log &
left=$!; pids+=($left)
caught_up --lcm-url "$URL" --sensor-id RIGHT_KNEE -- \
  "$BIN_DIR/pof-daqd" --device sim:validation --sensor-id RIGHT_KNEE --lcm-url "$URL" --duration 8 2>daqd-RIGHT_KNEE.log &
right=$!; pids+=($right)
wait $left || fail "pof-daqd LEFT_KNEE: $(cat daqd-LEFT_KNEE.log)"
wait $right || fail "pof-daqd RIGHT_KNEE: $(cat daqd-RIGHT_KNEE.log)"
for p in "${compensators[@]}"; do kill -TERM "$p"; wait "$p" || fail "compensator exit $?"; done
wait_until --drained "$PORT" || fail "pof record did not read what was sent"
kill -INT $recorder; wait $recorder || true

"$POF" record --check both.lcmlog > check.txt || fail "recorded log damaged: $(cat check.txt)"
cat check.txt
for ch in POF_RAW POF_ANGLE POF_STATS POF_DAQ_STATUS POF_COMPENSATOR_STATUS; do
  if grep -qE "^  $ch +" check.txt; then fail "traffic on the unsuffixed channel $ch"; fi
done
for id in LEFT_KNEE RIGHT_KNEE; do
  grep -qE "^  POF_RAW_$id +raw_block_t .* 0 gaps" check.txt || fail "POF_RAW_$id missing or with gaps"
  grep -qE "^  POF_ANGLE_$id +angle_t .* 0 gaps" check.txt || fail "POF_ANGLE_$id missing or with gaps"
  "$POF" export both.lcmlog -c POF_RAW_$id -o raw-$id.csv 2>/dev/null
  "$POF" export both.lcmlog -c POF_ANGLE_$id -o angle-$id.csv 2>/dev/null
  # The status streams export too: one row per message, columns by name; nothing was refused by LCM.
  "$POF" export both.lcmlog -c POF_DAQ_STATUS_$id -o daq-status-$id.csv 2>/dev/null || fail "export of POF_DAQ_STATUS_$id"
  "$POF" export both.lcmlog -c POF_COMPENSATOR_STATUS_$id -o comp-status-$id.csv 2>/dev/null ||
    fail "export of POF_COMPENSATOR_STATUS_$id"
  awk -F, -v id=$id 'NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
    $col["state"] == "streaming" && $col["sensor_id"] == id && $col["scans"] > 0 { ok = 1 }
    $col["publish_failures"] != "0" { bad = 1 }
    END { exit !ok || bad }' daq-status-$id.csv || fail "no streaming row for $id in the exported DAQ status: $(head -3 daq-status-$id.csv)"
  awk -F, -v id=$id 'NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
    $col["sensor_id"] == id && $col["angles"] > 1000 && $col["lost_scans"] == 0 { ok = 1 }
    $col["publish_failures"] != "0" { bad = 1 }
    END { exit !ok || bad }' comp-status-$id.csv || fail "exported compensator status for $id: $(tail -2 comp-status-$id.csv)"
done
"$PY" "$SOURCE_DIR/tests/e2e/two_pipelines_check.py" || fail "crosstalk check failed"
echo ok
