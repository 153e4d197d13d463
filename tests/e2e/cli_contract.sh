# The CLI contract of the brief: --help everywhere, exit 2 on usage errors.
source "$(dirname "$0")/lib.sh"

expect_exit 0 "$BIN_DIR/pof" --help
grep -q "version" <<<"$out" || fail "pof --help lists no subcommands"
expect_exit 0 "$BIN_DIR/pof" version
grep -q "^pofkit " <<<"$out" || fail "pof version: unexpected output: $out"
expect_exit 2 "$BIN_DIR/pof" --no-such-flag
expect_exit 2 "$BIN_DIR/pof" no-such-command
expect_exit 2 "$BIN_DIR/pof"
echo "ok"
