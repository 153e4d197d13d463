# The CLI contract of the brief: --help everywhere, exit 2 on usage errors.
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
for b in pof-daqd pof-compensatord; do
  expect_exit 0 "$BIN_DIR/$b" --version
  [ "$out" = "$want" ] || fail "$b --version printed '$out', pof --version '$want'"
  expect_exit 0 "$BIN_DIR/$b" --help
  expect_exit 2 "$BIN_DIR/$b" --no-such-flag
done
echo "ok"
