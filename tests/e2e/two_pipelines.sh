# Several sensors on one LCM bus: two full pipelines side by side, LEFT_KNEE and
# RIGHT_KNEE, each pof-daqd (sim backend) -> pof-compensatord with its own sensor id, one
# `pof record` for both. No crosstalk: each compensator sees only its own stream (no lost or
# rejected blocks), publishes one angle per scan of its own sensor, on its own suffixed channels,
# and nothing is published on the unsuffixed channels.
source "$(dirname "$0")/lib.sh"
PORT=$((20000 + RANDOM % 30000))
URL="udpm://239.255.76.67:$PORT?ttl=0"
POF="$BIN_DIR/pof"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

"$POF" sim paper -o cal.csv 2>/dev/null
"$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
printf 'schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n' > pot.toml

"$POF" record -o both.lcmlog --lcm-url "$URL" -q 2>record.log &
pids+=($!); recorder=$!
for id in LEFT_KNEE RIGHT_KNEE; do
  "$BIN_DIR/pof-compensatord" --cal cal.toml --pot-cal pot.toml --sensor-id $id --lcm-url "$URL" 2>comp-$id.log &
  pids+=($!)
done
sleep 1
# Different scenarios, so a crossed stream would show as wrong data, not only wrong counts.
"$BIN_DIR/pof-daqd" --device sim:session --sensor-id LEFT_KNEE --lcm-url "$URL" --duration 8 2>daqd-LEFT_KNEE.log &
left=$!; pids+=($left)
"$BIN_DIR/pof-daqd" --device sim:validation --sensor-id RIGHT_KNEE --lcm-url "$URL" --duration 8 2>daqd-RIGHT_KNEE.log &
right=$!; pids+=($right)
wait $left || fail "pof-daqd LEFT_KNEE: $(cat daqd-LEFT_KNEE.log)"
wait $right || fail "pof-daqd RIGHT_KNEE: $(cat daqd-RIGHT_KNEE.log)"
sleep 1.5   # the last status (1 Hz) of each compensator
for p in "${pids[@]:1:2}"; do kill -TERM "$p"; wait "$p" || fail "compensator exit $?"; done
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
/usr/bin/python3 - <<'PY' || fail "crosstalk check failed"
import csv
for sid in ("LEFT_KNEE", "RIGHT_KNEE"):
    raw = list(csv.DictReader(open(f"raw-{sid}.csv")))
    ang = list(csv.DictReader(open(f"angle-{sid}.csv")))
    assert len(raw) > 1000, f"{sid}: only {len(raw)} scans"
    assert len(ang) == len(raw), f"{sid}: {len(ang)} angles for {len(raw)} scans"
    assert [a["scan_index"] for a in ang] == [r["scan_index"] for r in raw], f"{sid}: scan indices differ"
    # The reference angle in each angle stream is that sensor's own potentiometer.
    worst = max(abs(float(a["angle_ref_deg"]) - 22.5 * (float(r["pot"]) - 0.5)) for a, r in zip(ang, raw))
    assert worst < 1e-3, f"{sid}: reference differs from its own pot by {worst} deg"
    print(f"{sid}: {len(ang)} angles for {len(raw)} scans, own reference (max diff {worst:.2e} deg)")
PY
echo ok
