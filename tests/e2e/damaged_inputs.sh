# Hostile recordings through the real `pof`: the readers never crash, never lose data silently and
# never overwrite an input. Damaged LCM logs (data length 0x7fffffff, flipped bytes, truncation),
# /dev/zero, endless CSV lines and outputs that are inputs; checks exit codes, that nothing was
# written, and that stderr stays short.
source "$(dirname "$0")/lib.sh"
POF="$BIN_DIR/pof"
CAL="$SOURCE_DIR/tests/fuzz/corpus/calibration_toml/cal_paper_active.toml"

# stderr of the last expect_exit is bounded: one message, input quoted in ~40 bytes.
short_err() { [ "${#err}" -lt "${1:-1500}" ] || fail "stderr is ${#err} bytes: ${err:0:300}..."; }
# no_file <path...>: none of them exists.
no_file() { local f; for f in "$@"; do [ ! -e "$f" ] || fail "$f was written"; done; }
# poke <file> <offset> <hex bytes>: overwrite bytes in place.
poke() { printf "$(sed 's/\([0-9a-f][0-9a-f]\)/\\x\1/g' <<<"$3")" | dd of="$1" bs=1 seek="$2" conv=notrunc status=none; }
# event_offset <log> <n>: byte offset of event n (0-based), from the headers.
event_offset() { "$PY" "$SOURCE_DIR/tests/e2e/lcmlog_events.py" offset "$1" "$2"; }

"$POF" sim paper -o run.lcmlog --seconds 20 --seed 7 2>/dev/null   # 200 POF_RAW blocks of 20 scans
"$POF" sim paper -o run.csv --seconds 5 --seed 7 2>/dev/null
cp run.lcmlog orig.lcmlog
expect_exit 0 "$POF" export run.lcmlog -c POF_RAW -o all.csv
rows=$(($(wc -l <all.csv) - 1))
[ "$rows" -eq 4000 ] || fail "export of the clean log: $rows rows, expected 4000"

# --- data length 0x7fffffff in event 100 (liblcm's reader crashed here)
at=$(event_offset run.lcmlog 100)
cp orig.lcmlog huge.lcmlog
poke huge.lcmlog $((at + 24)) 7fffffff
want="huge.lcmlog: damaged LCM log: first damage at byte $at: implausible data length 2147483647; 1 damaged region"
expect_exit 65 "$POF" calibrate huge.lcmlog -o cal.toml
[[ "$err" == *"$want"*"at least 1 event lost"*"199 complete events read"* ]] || fail "calibrate: $err"
short_err
no_file cal.toml
expect_exit 65 "$POF" compensate huge.lcmlog --cal "$CAL" --csv comp.csv --json comp.json
[[ "$err" == *"$want"* ]] || fail "compensate: $err"
no_file comp.csv comp.json
expect_exit 65 "$POF" gap huge.lcmlog --out gapdir --no-plots
[[ "$err" == *"$want"* ]] || fail "gap: $err"
no_file gapdir/gap.json
expect_exit 65 "$POF" export huge.lcmlog -c POF_RAW -o huge.csv
[[ "$err" == *"$want"*"nothing written (--salvage writes what is readable)"* ]] || fail "export: $err"
no_file huge.csv
expect_exit 65 "$POF" record --check huge.lcmlog
[[ "$out" == *"DAMAGED at offset $at (implausible data length 2147483647); 99 complete events follow the damage"*"at least 1 event(s) lost"* ]] ||
  fail "record --check: $out"
# --salvage: every readable row, still exit 65 with the counts.
expect_exit 65 "$POF" export huge.lcmlog -c POF_RAW -o salvaged.csv --salvage
[[ "$err" == *"$want"*"salvaged 3980 rows of channel POF_RAW into salvaged.csv"* ]] || fail "salvage: $err"
[ "$(($(wc -l <salvaged.csv) - 1))" -eq 3980 ] || fail "salvaged.csv: $(wc -l <salvaged.csv) lines"

# --- truncated in the middle of the last event
head -c $(($(stat -c %s orig.lcmlog) - 100)) orig.lcmlog >cut.lcmlog
expect_exit 65 "$POF" calibrate cut.lcmlog -o cal.toml
[[ "$err" == *"cut.lcmlog: damaged LCM log: first damage at byte $(event_offset orig.lcmlog 199): event truncated"* ]] || fail "cut: $err"
expect_exit 65 "$POF" export cut.lcmlog -c POF_RAW -o cut.csv
no_file cal.toml cut.csv

# --- flipped bytes: exit 65 with nothing written, or exit 0 with every event of the channel read;
# never a crash. LCM logs carry no checksum: a flip in a sample value, a time or an event number
# reads as valid data, and one in a channel name moves that event to another channel, which
# `pof record --check` lists (docs/deployment.md, "Damaged logs").
size=$(stat -c %s orig.lcmlog)
zero=0 damaged=0
for i in $(seq 1 40); do
  pos=$(((i * 7919 * 13) % size))
  cp orig.lcmlog flip.lcmlog
  byte=$(od -An -tx1 -j "$pos" -N1 flip.lcmlog | tr -d ' ')
  poke flip.lcmlog "$pos" "$(printf '%02x' $((0x$byte ^ (1 << (i % 8)))))"
  rm -f flip.csv
  set +e
  "$POF" export flip.lcmlog -c POF_RAW -o flip.csv >/dev/null 2>flip.err
  rc=$?
  set -e
  case $rc in
    0) zero=$((zero + 1))
       n=$(($(wc -l <flip.csv) - 1))
       if [ "$n" -ne 4000 ]; then
         check=$("$POF" record --check flip.lcmlog)
         [ "$n" -eq 3980 ] && [[ "$check" == *"POF_RAW "*"199 events"* ]] && [ "$(grep -c ' events$' <<<"$check")" -eq 2 ] ||
           fail "flip at $pos: exit 0 with $n rows; --check: $check"
       fi ;;
    65) damaged=$((damaged + 1))
        no_file flip.csv
        grep -q "flip.lcmlog: .*byte [0-9]" flip.err || fail "flip at $pos: $(head -c 300 flip.err)" ;;
    *) fail "flip at $pos: exit $rc: $(head -c 300 flip.err)" ;;
  esac
  [ "$(stat -c %s flip.err)" -lt 1500 ] || fail "flip at $pos: stderr $(stat -c %s flip.err) bytes"
done
echo "flipped bytes: $zero read whole (payload values), $damaged refused"
[ "$damaged" -gt 0 ] && [ "$zero" -gt 0 ] || fail "expected both outcomes among 40 flips ($zero/$damaged)"

# --- endless or foreign input: refused quickly with bounded memory (1 GiB address space is plenty
# for a bounded reader and far too little for one that reads /dev/zero whole). AddressSanitizer
# reserves terabytes of address space for its shadow at start, so against the sanitizer build
# (sanitized.sh) its own hard_rss_limit_mb bounds the resident memory to 1 GiB instead (the
# sanitizers' common flags: a finding, hence a failed test, when it is exceeded).
limit_memory="ulimit -v 1048576"
[ -z "${POF_SANITIZED:-}" ] || limit_memory="export ASAN_OPTIONS=\$ASAN_OPTIONS:hard_rss_limit_mb=1024"
for cmd in "calibrate /dev/zero -o cal.toml" "gap /dev/zero --out gz --no-plots" "export /dev/zero -c POF_RAW -o z.csv"; do
  expect_exit 65 bash -c "$limit_memory; exec timeout 10 $POF $cmd"
  short_err 400
done
[[ "$err" == *"/dev/zero: byte 0: not an LCM log"* ]] || fail "export /dev/zero: $err"
expect_exit 78 bash -c "$limit_memory; exec timeout 10 $POF compensate run.csv --cal /dev/zero"
[[ "$err" == *"/dev/zero: longer than 1024 KiB: not a calibration file"* ]] || fail "--cal /dev/zero: $err"
no_file cal.toml z.csv gz/gap.json

# --- CSV: an 8 MB line is an error naming file and line, quoted in 40 bytes
{ head -3 run.csv; head -c 8000000 /dev/zero | tr '\0' '7'; echo; } >long.csv
expect_exit 65 "$POF" calibrate long.csv -o cal.toml
[[ "$err" == *"long.csv:4: line longer than 65536 bytes (starts '7777777777777777777777777777777777777777…')"* ]] || fail "long line: $err"
short_err 400
{ head -c 8000000 /dev/zero | tr '\0' 'h'; echo; tail -2 run.csv; } >wide.csv
expect_exit 65 "$POF" compensate wide.csv --cal "$CAL"
short_err 400
no_file cal.toml

# --- an output that is an input: usage error before anything is read, the input untouched
sum=$(sha256sum run.csv)
ln -s run.csv link.csv
for args in "calibrate run.csv -o run.csv" "calibrate run.csv -o ./run.csv" "calibrate run.csv -o link.csv" \
  "calibrate link.csv -o $WORK_DIR/run.csv" \
  "compensate run.csv --cal $CAL --csv run.csv" "compensate run.csv --cal $CAL --json ./run.csv" \
  "compensate run.csv --cal $CAL --csv x.csv --json x.csv" "export run.lcmlog -c POF_RAW -o run.lcmlog" \
  "export run.lcmlog -c POF_RAW -o ./run.lcmlog"; do
  # shellcheck disable=SC2086
  expect_exit 2 "$POF" $args
  [[ "$err" == *"is the same file as"* ]] || fail "pof $args: $err"
done
cp run.csv compensated.csv
expect_exit 2 "$POF" calibrate compensated.csv -o cal.toml --report . --no-plots
[ "$(sha256sum run.csv)" == "$sum" ] || fail "run.csv changed"
cmp -s run.lcmlog orig.lcmlog || fail "run.lcmlog changed"
cmp -s run.csv compensated.csv || fail "compensated.csv (an input) changed"
no_file cal.toml x.csv
echo "damaged inputs: all refused as bad input, nothing overwritten"
