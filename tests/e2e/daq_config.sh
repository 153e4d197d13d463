# pof-daqd's command-line and configuration contract: --help, exit 2 on usage errors, 66 for a
# missing --config, 78 naming the key for bad values, unknown keys and bad TOML, and command-line
# overrides on top of the file (--print-config shows the effect).
source "$(dirname "$0")/lib.sh"
d="$BIN_DIR/pof-daqd"
expect_exit 0 "$d" --help
grep -q -- "--config" <<<"$out" || fail "--help does not document --config"
expect_exit 2 "$d" --no-such-flag
expect_exit 66 "$d" --config "$WORK_DIR/missing.toml"
grep -q "missing.toml" <<<"$err" || fail "66 does not name the file: $err"

cp "$SOURCE_DIR/deploy/config/daqd.toml" "$WORK_DIR/daq.toml"
expect_exit 0 "$d" --config "$WORK_DIR/daq.toml" --print-config
grep -q "kind = 'usb6008'" <<<"$out" || fail "example config: $out"
expect_exit 0 "$d" --config "$WORK_DIR/daq.toml" --rate 1000 -s channels.pot=-1 --print-config
grep -q "scan_rate_hz = 1000.0" <<<"$out" || fail "--rate not applied: $out"
grep -q "pot = -1" <<<"$out" || fail "--set not applied: $out"

bad() {  # bad <toml snippet appended> <text the error must contain>
  cp "$SOURCE_DIR/deploy/config/daqd.toml" "$WORK_DIR/bad.toml"
  printf '%s\n' "$1" >>"$WORK_DIR/bad.toml"
  expect_exit 78 "$d" --config "$WORK_DIR/bad.toml" --print-config
  grep -q -- "$2" <<<"$err" || fail "error for '$1' does not mention '$2': $err"
}
bad '[extra]'                                        "bad.toml:$(($(wc -l <"$SOURCE_DIR/deploy/config/daqd.toml") + 1)): unknown key 'extra' at the top level"
# A typo on the command line is refused as in the file, with the key it was meant to be.
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" -s acquisition.decimat=5 --print-config
grep -q "unknown key 'decimat' in \[acquisition\] (did you mean 'decimate'?)" <<<"$err" || fail "$err"
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" -s acquisition.scan_rate_hz=20000 --print-config
grep -q "acquisition.scan_rate_hz" <<<"$err" || fail "$err"
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" -s channels.reference=0 --print-config
grep -q "channels.reference" <<<"$err" || fail "$err"
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" -s 'acquisition.terminal="diff"' --print-config
grep -q "acquisition.terminal" <<<"$err" || fail "$err"
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" -s 'device.kind="usb9999"' --print-config
grep -q "device.kind" <<<"$err" || fail "$err"
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" -s acquisition.transfer_bytes=100 --print-config
grep -q "acquisition.transfer_bytes" <<<"$err" || fail "$err"
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" -s schema_version=7 --print-config
grep -q "schema_version" <<<"$err" || fail "$err"
# USB-1208LS (mcc_usb1208ls.hpp [8]): software-paced reads about 50 S/s, continuous scans at most
# 1.2 kS/s aggregate; 3 channels are scanned as a queue of 4 (1, 2, 4 or 8 allowed).
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" --device usb1208ls --rate 20 -s 'acquisition.mcc_mode="single"' --print-config
grep -q "acquisition.scan_rate_hz" <<<"$err" && grep -q "50 AIn reads/s" <<<"$err" || fail "$err"
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" --device usb1208ls --rate 400 --print-config
grep -q "acquisition.scan_rate_hz" <<<"$err" && grep -q "1, 2, 4 or 8" <<<"$err" && grep -q "at most 300" <<<"$err" || fail "$err"
expect_exit 78 "$d" --config "$WORK_DIR/daq.toml" --device usb1208ls --rate 20 --print-config
grep -q "at least 25" <<<"$err" || fail "$err"
# Its default asks for no more than the device holds: 250 scans/s x 4 inputs = 1000 S/s.
expect_exit 0 "$d" --config /dev/null -s schema_version=1 --device usb1208ls --print-config
grep -q "scan_rate_hz = 250" <<<"$out" || fail "usb1208ls default rate: $out"
expect_exit 0 "$d" --config /dev/null -s schema_version=1 --print-config
grep -Eq "sample_byte_order = .auto." <<<"$out" || fail "default byte order: $out"
printf 'schema_version = 1\n[acquisition\n' >"$WORK_DIR/syntax.toml"
expect_exit 78 "$d" --config "$WORK_DIR/syntax.toml"
grep -q "syntax.toml:2" <<<"$err" || fail "TOML syntax error without file:line: $err"
# A usable configuration with an unusable LCM URL is an I/O error (74), not a crash.
expect_exit 74 "$d" --config "$WORK_DIR/daq.toml" --device sim:synthetic --lcm-url "udpm://999.1.1.1:1" --duration 0.1
echo ok
