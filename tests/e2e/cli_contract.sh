# The command-line contract: --help everywhere, exit 2 on usage errors, the same exit code for
# the same kind of error in every binary, and the daemons' signals.
source "$(dirname "$0")/lib.sh"

expect_exit 0 "$BIN_DIR/pof" --help
grep -q "version" <<<"$out" || fail "pof --help lists no subcommands"
expect_exit 0 "$BIN_DIR/pof" version
grep -q "^pofkit " <<<"$out" || fail "pof version: unexpected output: $out"
expect_exit 2 "$BIN_DIR/pof" --no-such-flag
expect_exit 2 "$BIN_DIR/pof" no-such-command
expect_exit 2 "$BIN_DIR/pof"
# --version on every binary: the project's version, exit 0 (the daemons used to exit 2). And
# --help, and exit 2 on an unknown flag.
expect_exit 0 "$BIN_DIR/pof" --version
want=$out
for b in pof-daqd pof-compensatord pof-gap; do
  expect_exit 0 "$BIN_DIR/$b" --version
  [ "$out" = "$want" ] || fail "$b --version printed '$out', pof --version '$want'"
  expect_exit 0 "$BIN_DIR/$b" --help
  expect_exit 2 "$BIN_DIR/$b" --no-such-flag
done
# Numbers are finite (CLI11's own checks let nan and inf through: `--duration nan` never ended).
for cmd in "pof-daqd --device sim:synthetic" "pof-compensatord --cal none.toml" "pof record -o x.lcmlog" "pof spy"; do
  for v in nan inf -1; do
    expect_exit 2 $BIN_DIR/$cmd --duration "$v"
    grep -q -- "--duration" <<<"$err" || fail "$cmd --duration $v: the error does not name the option: $err"
  done
done
expect_exit 2 "$BIN_DIR/pof-compensatord" --cal none.toml --velocity-window nan
expect_exit 2 "$BIN_DIR/pof" record -o x.lcmlog --sync-interval inf
# A hand-off bound the recorder could never reserve (twice, up front) is a usage error, not a bad_alloc.
expect_exit 2 "$BIN_DIR/pof" record -o x.lcmlog --handoff-mb 1e12
grep -q -- "--handoff-mb: expected at most" <<<"$err" || fail "pof record --handoff-mb 1e12: $err"
# A sensor id whose channels LCM would refuse (over 63 characters) or that is not upper case.
expect_exit 2 "$BIN_DIR/pof-compensatord" --cal none.toml --sensor-id "$(printf 'K%.0s' $(seq 41))"
grep -q -- "--sensor-id: expected at most 40 characters" <<<"$err" || fail "pof-compensatord --sensor-id of 41: $err"
expect_exit 2 "$BIN_DIR/pof" calibrate none.csv -o x.toml --sensor-id left_knee
expect_exit 78 "$BIN_DIR/pof-daqd" --config /dev/null -s schema_version=1 -s "lcm.sensor_id=$(printf 'K%.0s' $(seq 41))" \
  --device sim:synthetic --duration 0.1
grep -q "sensor_id.*at most 40 characters" <<<"$err" || fail "pof-daqd sensor_id of 41: $err"
# A command-line value the configuration could not hold is refused, not replaced by the configured one.
for bad in "--rate -2000" "--rate 0" "--decimate 0" "--block-scans -5"; do
  # shellcheck disable=SC2086  # the option and its value, split on purpose
  expect_exit 2 "$BIN_DIR/pof-daqd" --config /dev/null -s schema_version=1 --device sim:synthetic $bad --duration 0.1
  grep -q -- "${bad%% *}" <<<"$err" || fail "pof-daqd $bad: $err"
done
# A key given by its own option and by -s is refused, never one of them silently taken.
expect_exit 2 "$BIN_DIR/pof-daqd" --config /dev/null -s schema_version=1 --device sim:synthetic -s device.kind=usb6009 --print-config
grep -q -- "device.kind is also given by its own option" <<<"$err" || fail "pof-daqd --device with -s device.kind: $err"
expect_exit 0 "$BIN_DIR/pof-daqd" --config /dev/null -s schema_version=1 -s device.kind=sim:synthetic --rate 500 --print-config
# A FIFO as a file to read is refused at once (opening it waited for a writer, forever).
mkfifo fifo.toml
expect_exit 66 timeout 10 "$BIN_DIR/pof-daqd" --config fifo.toml --device sim:synthetic --duration 0.1
grep -q "fifo.toml: is a FIFO" <<<"$err" || fail "pof-daqd --config FIFO: $err"
expect_exit 66 timeout 10 "$BIN_DIR/pof-compensatord" --cal fifo.toml --duration 0.1
grep -q "fifo.toml: is a FIFO" <<<"$err" || fail "pof-compensatord --cal FIFO: $err"

# One table maps exceptions to exit codes in every binary (pof::service::run_main): the same kind of
# bad configuration gives both daemons the same code, 78, and the line "<program>: error: <what>".
# A value the command line's own check accepts but the configuration rejects: pof-daqd's config
# check (ConfigError) and the compensator's constructor (std::invalid_argument: 78 in
# pof-compensatord but 74 in `pof` before run_main).
"$BIN_DIR/pof" sim paper -o cal.csv --seed 11 2>/dev/null
"$BIN_DIR/pof" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
expect_exit 78 "$BIN_DIR/pof-daqd" --config /dev/null -s schema_version=1 --device sim:synthetic --rate 1e9 --duration 0.1
grep -q "^pof-daqd: error: .*acquisition.scan_rate_hz" <<<"$err" || fail "pof-daqd --rate 1e9: $err"
expect_exit 78 "$BIN_DIR/pof-compensatord" --cal cal.toml --velocity-window 6000 --duration 0.1
grep -q "^pof-compensatord: error: .*velocity window" <<<"$err" || fail "pof-compensatord --velocity-window 6000: $err"
# The same rejection in `pof compensate` (a 10 MHz recording: 0.5 s is 5e6 scans, beyond the
# compensator's bound): 78 too.
{ echo "t_s,sensor_v,reference_v,angle_ref_deg"
  for i in $(seq 0 199); do printf '%d.0e-7,2.0,4.0,%d.0\n' "$i" "$i"; done; } >fast.csv
expect_exit 78 "$BIN_DIR/pof" compensate fast.csv --cal cal.toml --velocity-window 0.5
grep -q "^pof: error: .*velocity window" <<<"$err" || fail "pof compensate on a 10 MHz recording: $err"
# A bad value in the file each daemon reads.
printf 'schema_version = 1\n[acquisition]\nscan_rate_hz = -5\n' >bad_daq.toml
expect_exit 78 "$BIN_DIR/pof-daqd" --config bad_daq.toml --device sim:synthetic --duration 0.1
grep -q "^pof-daqd: error: bad_daq.toml.*acquisition.scan_rate_hz" <<<"$err" || fail "pof-daqd bad_daq.toml: $err"
sed 's/^reference_level_v = .*/reference_level_v = -5/' cal.toml >bad_cal.toml
cmp -s cal.toml bad_cal.toml && fail "cal.toml has no reference_level_v line to spoil"
expect_exit 78 "$BIN_DIR/pof-compensatord" --cal bad_cal.toml --duration 0.1
grep -q "^pof-compensatord: error: bad_cal.toml.*reference_level_v" <<<"$err" || fail "pof-compensatord bad_cal.toml: $err"
# Swapped knees: RIGHT_KNEE's calibration on LEFT_KNEE's compensator is refused (78), unless allowed.
sed 's/^sensor_id = .*/sensor_id = "RIGHT_KNEE"/' cal.toml >right.toml
cmp -s cal.toml right.toml && fail "cal.toml has no sensor_id line to change"
expect_exit 78 "$BIN_DIR/pof-compensatord" --cal right.toml --sensor-id LEFT_KNEE --duration 0.1
grep -q "^pof-compensatord: error: right.toml: sensor_id 'RIGHT_KNEE'.*'LEFT_KNEE'" <<<"$err" ||
  fail "pof-compensatord with another sensor's calibration: $err"
expect_exit 0 "$BIN_DIR/pof-compensatord" --cal right.toml --sensor-id LEFT_KNEE --allow-other-sensor --duration 0.1   --lcm-url "udpm://239.255.76.67:$((20000 + RANDOM % 30000))?ttl=0"

# Signals (pof::service::SignalWaiter): SIGHUP does not stop pof-daqd (it has nothing to reload and
# says so), SIGTERM stops it with exit 0. READY=1 is sent after the signals are blocked.
PORT=$((20000 + RANDOM % 30000))
start_ready notify daqd.log "$BIN_DIR/pof-daqd" --config /dev/null -s schema_version=1 --device sim:synthetic \
  --lcm-url "udpm://239.255.76.67:$PORT?ttl=0"
daqd=$!
trap 'kill "$daqd" 2>/dev/null || true' EXIT
kill -HUP "$daqd"
wait_until -- grep -q "SIGHUP ignored" daqd.log || fail "pof-daqd did not report the SIGHUP: $(cat daqd.log)"
kill -TERM "$daqd" 2>/dev/null || true
rc=0; wait "$daqd" || rc=$?
[ "$rc" -eq 0 ] || fail "pof-daqd exited $rc after SIGHUP then SIGTERM (129 = killed by SIGHUP): $(cat daqd.log)"
echo "ok"
