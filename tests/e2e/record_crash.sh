# pof record durability: SIGKILL mid-recording (with size rotation, the manifest and an attached
# calibration), a power-loss torn tail that --check finds (exit 65) and --repair removes, lcm-logplayer
# playing the repaired log, disk full (ENOSPC on a 2 MiB tmpfs: exit 74, the log stays clean) and
# the error exits.
source "$(dirname "$0")/lib.sh"
# A random port: other test runs on this host (ttl=0 multicast is host-wide) must not cross in.
PORT=${PORT:-$((20000 + RANDOM % 30000))}
URL="udpm://239.255.76.67:$PORT?ttl=0"
URL2="udpm://239.255.76.67:$((PORT + 1))?ttl=0"
PUB="$BIN_DIR/../tests/pof-testpub"
POF="$BIN_DIR/pof"

# --- error exits ---------------------------------------------------------------------------------
expect_exit 66 "$POF" record --check missing.lcmlog
expect_exit 2 "$POF" record
printf 'schema_version = 1\n[potentiometer]\ndeg_per_volt = 30.0\nzero_v = 0.0\n' >cal.toml
expect_exit 66 "$POF" record -o x.lcmlog --lcm-url "$URL" --manifest-file no-such-cal.toml
grep -q "no-such-cal.toml" <<<"$err" || fail "missing --manifest-file not named: $err"
expect_exit 78 "$POF" record -o x.lcmlog --lcm-url "$URL" --channels '(unclosed'
touch taken.lcmlog
expect_exit 74 "$POF" record -o taken.lcmlog --lcm-url "$URL"
grep -q "never overwrites" <<<"$err" || fail "existing output not refused clearly: $err"

# --- SIGKILL while recording with rotation -------------------------------------------------------
start_ready notify rec.err "$POF" record -q -o run.lcmlog --lcm-url "$URL" --rotate-mb 1 --sync-interval 0.1 --manifest-file cal.toml
rec=$!
"$PUB" --lcm-url "$URL" burst --channel POF_RAW --count 60000 --rate 20000 >pub.out &
pub=$!
# Killed mid-burst (3 s, about 7 files of messages) once three files are full (some 12000 events).
wait_until -- test -e run.0003.lcmlog || fail "no fourth file while recording: $(ls run.*)"
kill -KILL $rec
wait $pub
wait $rec 2>/dev/null || true
ls run.*.lcmlog >files.txt
# The kill may come between a rotation's creating the next file and its first write: that file is
# empty, which is all a SIGKILL can leave there.
if [ ! -s "$(tail -n 1 files.txt)" ]; then
  echo "note: $(tail -n 1 files.txt) is empty (killed just after the rotation created it)"
  sed -i '$d' files.txt
fi
nfiles=$(wc -l <files.txt)
[ "$nfiles" -ge 3 ] || fail "expected size rotation into >= 3 files, got $nfiles"
cmp -s cal.toml run.files/cal.toml || fail "the calibration was not copied next to the log"
"$PY" "$SOURCE_DIR/tests/e2e/record_manifest_check.py" killed run.manifest.json ||
  fail "manifest after SIGKILL is not usable"
# Every file is readable up to its last complete event, and together they hold seq 0..K-1 with no
# gap: nothing acknowledged before the kill was lost.
total=0
expect_seq=0
while read -r f; do
  set +e
  "$POF" record --check "$f" >check.out
  rc=$?
  set -e
  if [ "$f" = "$(tail -n 1 files.txt)" ]; then
    [ $rc -eq 0 ] || [ $rc -eq 65 ] || fail "--check $f exited $rc"  # the kill may tear it (below)
  else
    [ $rc -eq 0 ] || fail "--check $f exited $rc: a file closed by a rotation must be whole: $(cat check.out)"
  fi
  line=$(grep "POF_RAW" check.out) || fail "$f holds no POF_RAW events: $(cat check.out)"
  n=$(awk '{print $3}' <<<"$line")
  first=$(sed -E 's/.*seq ([0-9]+)\.\..*/\1/' <<<"$line")
  last=$(sed -E 's/.*seq [0-9]+\.\.([0-9]+),.*/\1/' <<<"$line")
  grep -q " 0 gaps" <<<"$line" || fail "$f: sequence gaps: $line"
  [ "$first" -eq "$expect_seq" ] || fail "$f starts at seq $first, expected $expect_seq"
  expect_seq=$((last + 1))
  total=$((total + n))
done <files.txt
[ "$total" -ge 10000 ] || fail "only $total events recorded before the kill"
echo "after SIGKILL: $total events in $nfiles files, seq 0..$((expect_seq - 1)) without gaps"
# The killed session's manifest still says `recording`; a reader tells it is over: --check of any
# of its files says INTERRUPTED, and the next recorder in the directory marks it `interrupted`.
grep -q "session INTERRUPTED (run.manifest.json says 'recording', but its recorder (pid $rec) is gone" check.out ||
  fail "--check does not say the session was interrupted: $(cat check.out)"
expect_exit 0 "$POF" record -q -o next.lcmlog --lcm-url "$URL" --duration 0.2
grep -q "run.manifest.json: said 'recording' but its recorder is gone: marked 'interrupted'" <<<"$err" ||
  fail "the next recorder did not mark the interrupted session: $err"
"$PY" -c 'import json, sys; m = json.load(open("run.manifest.json")); sys.exit(m["status"] != "interrupted" or "is gone" not in m["interrupted"]["why"])' ||
  fail "run.manifest.json after the next recorder: $(head -c 300 run.manifest.json)"
"$PY" -c 'import json, sys; sys.exit(json.load(open("next.manifest.json"))["status"] != "stopped")' ||
  fail "the next recorder's own manifest: $(head -c 300 next.manifest.json)"

# --- power loss mid-write: a torn tail -----------------------------------------------------------
last=$(tail -n 1 files.txt)
# The kill itself may have torn the last file: write(2) of a regular file stops at a page (folio)
# boundary when a fatal signal is pending (Linux mm/filemap.c, generic_perform_write), so the
# recorder's last buffer can end mid-event. That tail is what --repair is for; remove it first, so
# the cut below is the only one.
set +e
"$POF" record --check "$last" >before.out
rc=$?
set -e
[ $rc -eq 0 ] || [ $rc -eq 65 ] || fail "--check $last exited $rc: $(cat before.out)"
if [ $rc -eq 65 ]; then
  grep -q "TORN TAIL" before.out || fail "--check $last exited 65 without a torn tail: $(cat before.out)"
  echo "note: the kill tore $last mid-event ($(grep -o 'TORN TAIL: [0-9]* bytes' before.out)); repairing it first"
  expect_exit 0 "$POF" record --repair "$last"
  expect_exit 0 "$POF" record --check "$last"
  printf '%s\n' "$out" >before.out
fi
before_n=$(awk '/complete events/ {print $2; exit}' before.out)
head -c 100 run.0000.lcmlog >>"$last"   # a header and part of an event, as a cut write leaves
expect_exit 65 "$POF" record --check "$last"
grep -q "TORN TAIL: 100 bytes" <<<"$out" || fail "--check did not report the torn tail: $out"
grep -q "repair" <<<"$err" || fail "--check did not say how to repair: $err"
torn_kept() { find . -maxdepth 1 -name "$last.torn-*" | wc -l; }
torn_before=$(torn_kept)
expect_exit 0 "$POF" record --repair "$last"
grep -q "truncated a torn tail of 100 bytes" <<<"$out" || fail "unexpected repair report: $out"
[ "$(torn_kept)" -eq $((torn_before + 1)) ] || fail "repair did not keep the removed bytes"
expect_exit 0 "$POF" record --check "$last"
grep -q "$last: $before_n complete events" <<<"$out" || fail "repair lost events: $out"
expect_exit 0 "$POF" record --repair "$last"
grep -q "nothing to repair" <<<"$out" || fail "second repair was not a no-op: $out"

# --- lcm-logplayer plays the repaired log ---------------------------------------------------------
# (The liblcm receive path is covered by tests/functional/test_record_session.cpp; here the replay
# must not depend on how busy the host is, so the default recvmmsg path listens.)
start_ready notify replay.err "$POF" record -q -o replay.lcmlog --lcm-url "$URL2"
rep=$!
lcm-logplayer -s 1 -l "$URL2" "$last"
wait_until --drained "$((PORT + 1))" || fail "the replay recorder did not read what was played"
kill -INT $rep
wait $rep || fail "replay recorder failed: $(cat replay.err)"
expect_exit 0 "$POF" record --check replay.lcmlog
grep -q "replay.lcmlog: $before_n complete events" <<<"$out" ||
  fail "lcm-logplayer replay of the repaired log: expected $before_n events, got: $out"

# --- time rotation, channel selection, graceful stop ----------------------------------------------
"$PUB" --lcm-url "$URL" session --duration 3 --suffix _RIGHT_KNEE &
pub=$!
"$POF" record -q -o timed.lcmlog --lcm-url "$URL" -c 'POF_(ANGLE|STATS)_.*' --rotate-seconds 0.7 --duration 2.6 2>timed.err ||
  fail "time-rotated recording failed: $(cat timed.err)"
wait $pub
ls timed.*.lcmlog >timed.txt
[ "$(wc -l <timed.txt)" -ge 3 ] || fail "--rotate-seconds 0.7 over 2.6 s made only $(wc -l <timed.txt) files"
"$POF" record --check $(cat timed.txt) >timed.check || fail "time-rotated files are not clean: $(cat timed.check)"
grep -q "POF_ANGLE_RIGHT_KNEE" timed.check || fail "selected channel missing: $(cat timed.check)"
if grep -qE "POF_RAW|POF_DAQ_STATUS|FOREIGN" timed.check; then fail "--channels did not exclude POF_RAW/DAQ_STATUS/FOREIGN"; fi
"$PY" "$SOURCE_DIR/tests/e2e/record_manifest_check.py" rotated timed.manifest.json ||
  fail "manifest of the time-rotated session is wrong"

# --- the first event cannot be written ------------------------------------------------------------
# expect_first_event_failure <log> <its stderr> <recorder pid>: one 12 kB block (1000 scans) is
# published; the recorder must stop by itself with 74 naming the log, leave no empty log behind and
# mark the manifest `failed` with the reason.
expect_first_event_failure() {
  local log=$1 errf=$2 pid=$3 rc
  "$PUB" --lcm-url "$URL" burst --channel POF_RAW --count 1 --scans 1000 --rate 100 >/dev/null
  wait_until --timeout 10 --exited "$pid" || kill -INT "$pid" 2>/dev/null || true
  set +e
  wait "$pid"
  rc=$?
  set -e
  [ $rc -eq 74 ] || fail "$log: first event unwritable: pof record exited $rc, expected 74; $(cat "$errf")"
  grep -q "$log" "$errf" || fail "$log: the failure does not name the log: $(cat "$errf")"
  [ ! -e "$log" ] || fail "$log: an empty log ($(stat -c %s "$log") bytes) was left behind"
  "$PY" "$SOURCE_DIR/tests/e2e/record_manifest_check.py" failed "${log%.lcmlog}.manifest.json" "$log" ||
    fail "$log: the manifest does not say the recording failed"
}
# A file size limit, which any user may set (RLIMIT_FSIZE: write(2) fails with EFBIG as a full disk
# fails with ENOSPC): 8 KiB holds the manifest but not the first block.
start_ready notify fsize.err prlimit --fsize=8192 -- "$POF" record -o fsize.lcmlog --lcm-url "$URL"
expect_first_event_failure fsize.lcmlog fsize.err $!
echo "first event over RLIMIT_FSIZE: exit 74, no empty log, manifest 'failed'"

# --- disk full ----------------------------------------------------------------------------------
mkdir -p full first
if mount -t tmpfs -o size=2m tmpfs full 2>/dev/null; then
  trap 'umount "$WORK_DIR/full" "$WORK_DIR/first" 2>/dev/null || true' EXIT
  # A file system full from the start but for one page, which the manifest takes: the first event
  # gets ENOSPC, and the final manifest cannot be written beside the old one (write-then-rename).
  mount -t tmpfs -o size=1m tmpfs first
  cat /dev/zero >first/filler 2>/dev/null || true
  truncate -s -4096 first/filler
  start_ready notify first.err "$POF" record -o first/x.lcmlog --lcm-url "$URL"
  expect_first_event_failure first/x.lcmlog first.err $!
  echo "first event on a full file system: exit 74, no empty log, manifest 'failed'"
  umount first

  start_ready notify full.err "$POF" record -o full/x.lcmlog --lcm-url "$URL" --sync-interval 0.05 >full.out
  rec=$!
  "$PUB" --lcm-url "$URL" burst --channel POF_RAW --count 20000 --rate 20000 >/dev/null
  # The burst overfills the 2 MiB: pof record stops by itself with 74 (SIGINT only if it did not).
  wait_until --timeout 10 --exited $rec || kill -INT $rec 2>/dev/null || true
  set +e
  wait $rec
  rc=$?
  set -e
  [ $rc -eq 74 ] || fail "disk full: pof record exited $rc, expected 74; $(cat full.err)"
  grep -q "No space left on device" full.err || fail "disk full not reported: $(cat full.err)"
  expect_exit 0 "$POF" record --check full/x.lcmlog
  grep -q " 0 gaps" <<<"$out" || fail "disk full log has gaps: $out"
  n=$(awk '/complete events/ {print $2; exit}' <<<"$out")
  [ "$n" -gt 1000 ] || fail "disk full: only $n events kept"
  echo "disk full: exit 74, $n complete events kept, log clean"
  "$PY" "$SOURCE_DIR/tests/e2e/record_manifest_check.py" full full/x.manifest.json ||
    fail "disk full: a message the recorder received is neither written nor counted"
  umount full
  trap - EXIT
else
  echo "note: cannot mount a tmpfs here (not root?); ENOSPC is covered by the RLIMIT_FSIZE unit test"
fi
echo ok
