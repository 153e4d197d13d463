# The authenticated mode end to end (docs/deployment.md, "Authenticated mode"), on udpm loopback:
#   - `pof keygen` writes a 0600 key and refuses to overwrite it (exit 2, usage); a key file others may
#     read stops pof-daqd, pof-compensatord and pof spy with exit 78 naming the file and its mode;
#   - the real pof-daqd (sim backend) and pof-compensatord share a key; `pof record` and `pof spy`
#     verify with it; stock lcm-logger listens too; a forger (lcm_hostile.py forge) captures signed
#     POF_RAW messages and injects 3 unsigned blocks, 4 with a bad MAC (another key, altered bytes),
#     3 stale ones (signed with the key, counters 60 s off) and 3 replays while the session runs.
# Then (lcm_auth_check.py): the compensator's angles are exactly the scans of pof-daqd's blocks, one
# each, none of the forged ones; its last status counts 3/4/3/3 per verdict and no duplicate or
# undecodable block; the recorder's manifest counts the same and its log holds the verified blocks;
# lcm-logger's log holds the signed bytes, whose MACs Python's hashlib verifies; the spy shows drops.
source "$(dirname "$0")/lib.sh"
private_bus
POF="$BIN_DIR/pof"
HOSTILE="$SOURCE_DIR/tests/e2e/lcm_hostile.py"
unset POF_LCM_AUTH_KEY_FILE

mkdir -p py && lcm-gen -p --ppath py "$SOURCE_DIR"/lcmtypes/*.lcm || fail "lcm-gen (python)"
"$POF" sim paper -o cal.csv 2>/dev/null
"$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
printf 'schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n' >pot.toml

# The key: 0600, 64 hex digits; never overwritten; a readable copy is refused everywhere.
expect_exit 0 "$POF" keygen -o bus.key
[ "$(stat -c %a bus.key)" = 600 ] || fail "pof keygen wrote mode $(stat -c %a bus.key)"
grep -qE '^[0-9a-f]{64}$' bus.key || fail "pof keygen wrote: $(head -c 80 bus.key | od -c | head -2)"
cp bus.key before.key
expect_exit 2 "$POF" keygen -o bus.key
grep -q "bus.key: exists" <<<"$err" || fail "pof keygen over an existing key: $err"
cmp -s bus.key before.key || fail "pof keygen changed an existing key"
ln -s nowhere.key dangling.key   # a dangling symlink is an existing name too: never followed
expect_exit 2 "$POF" keygen -o dangling.key
[ ! -e nowhere.key ] || fail "pof keygen wrote through a dangling symlink"
install -m 0644 bus.key open.key
expect_exit 78 "$BIN_DIR/pof-compensatord" --cal cal.toml --auth-key-file open.key --lcm-url "$URL" --duration 1
grep -q "bus key file 'open.key': mode 0644 gives group or others access" <<<"$err" || fail "compensatord: $err"
expect_exit 78 "$BIN_DIR/pof-daqd" --device sim:session --lcm-url "$URL" --duration 1 -s lcm.auth_key_file=open.key
grep -q "'open.key': mode 0644" <<<"$err" || fail "pof-daqd: $err"
POF_LCM_AUTH_KEY_FILE=open.key expect_exit 78 "$POF" spy --lcm-url "$URL" --once
grep -q "'open.key': mode 0644" <<<"$err" || fail "pof spy (key from the environment): $err"

# The session: everything listening before pof-daqd starts.
start_ready notify comp.log "$BIN_DIR/pof-compensatord" --cal cal.toml --pot-cal pot.toml --lcm-url "$URL" \
  --auth-key-file bus.key --auth-window 5
comp=$!; pids+=($comp)
start_ready notify record.log "$POF" record -o auth.lcmlog -c 'POF_.*' --lcm-url "$URL" --auth-key-file bus.key \
  --auth-window 5 -q
recorder=$!; pids+=($recorder)
start_ready "$PORT" logger.err lcm-logger -q -c 'POF_.*' --lcm-url="$URL" stock.lcmlog
logger=$!; pids+=($logger)
POF_LCM_AUTH_KEY_FILE=bus.key start_ready "$PORT" spy.err "$POF" spy --lcm-url "$URL" --auth-window 5 --duration 8 >spy.txt
spy=$!; pids+=($spy)
start_ready "$PORT" forge.err "$PY" "$HOSTILE" forge "$PORT" bus.key forged.json
forger=$!; pids+=($forger)
caught_up --lcm-url "$URL" -- "$BIN_DIR/pof-daqd" --device sim:session --lcm-url "$URL" --auth-key-file bus.key \
  --duration 6 2>daqd.log || fail "pof-compensatord did not take every block pof-daqd published: $(tail -3 comp.log)"
wait $forger || fail "forger: $(cat forge.err)"
grep -q "authenticated mode: bus key bus.key (key id" daqd.log || fail "pof-daqd did not say it signs: $(cat daqd.log)"
kill -TERM $comp; wait $comp || fail "pof-compensatord exit $? on SIGTERM: $(tail -3 comp.log)"
wait_until --drained "$PORT" || fail "the listeners did not read what was sent"
kill -INT $recorder; wait $recorder || fail "pof record exit $?: $(cat record.log)"
kill -INT $logger; wait $logger || true
wait $spy || fail "pof spy exit $?: $(cat spy.err)"
grep -q "authentication dropped: 3 unsigned, 4 bad MAC, 3 stale, 3 replayed" comp.log ||
  fail "pof-compensatord's final counts: $(tail -2 comp.log)"

"$POF" record --check auth.lcmlog >check.txt || fail "pof record --check: $(cat check.txt)"
grep -qE "^  POF_RAW +raw_block_t .* 0 gaps" check.txt || fail "recorded POF_RAW: $(cat check.txt)"
"$POF" export auth.lcmlog -c POF_RAW -o raw.csv 2>/dev/null || fail "export POF_RAW"
"$POF" export auth.lcmlog -c POF_ANGLE -o angle.csv 2>/dev/null || fail "export POF_ANGLE"
"$POF" export auth.lcmlog -c POF_COMPENSATOR_STATUS -o status.csv 2>/dev/null || fail "export POF_COMPENSATOR_STATUS"
PYTHONPATH="$BIN_DIR/../python:$SOURCE_DIR/lcmtypes/python" "$PY" "$SOURCE_DIR/tests/e2e/lcm_auth_check.py" ||
  fail "checks failed (compensator log: $(tail -3 comp.log))"
echo ok
