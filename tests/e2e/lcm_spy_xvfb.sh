# Stock lcm-spy starts with our types through tools/lcm-spy.sh (the Java 17 workaround) under a
# virtual X server, finds every pofkit type, decodes a live angle stream, and stays up.
# A screenshot (xwd -> PNG) is left in WORK_DIR/lcm-spy.png for a person to look at.
source "$(dirname "$0")/lib.sh"
# A random port: other test runs on this host (ttl=0 multicast is host-wide) must not cross in.
PORT=${PORT:-$((20000 + RANDOM % 30000))}
URL="udpm://239.255.76.67:$PORT?ttl=0"
for t in xvfb-run java xwd; do
  command -v $t >/dev/null || { echo "SKIP: $t missing (./pofkit setup installs xvfb, x11-apps, default-jdk-headless)"; exit 77; }
done
[ -f "$BIN_DIR/../share/java/pof_lcmtypes.jar" ] || { echo "SKIP: no pof_lcmtypes.jar (no JDK at configure time)"; exit 77; }
"$BIN_DIR/../tests/pof-testpub" --lcm-url "$URL" session --duration 20 &
pub=$!
trap 'kill $pub 2>/dev/null || true' EXIT
set +e
POF_LCMTYPES_JAR="$BIN_DIR/../share/java/pof_lcmtypes.jar" LCM_DEFAULT_URL="$URL" \
  timeout 30 xvfb-run -a -s "-screen 0 1024x600x24" bash -c '
    "$0" >spy.out 2>&1 & spy=$!
    sleep 9
    kill -0 $spy || { echo "lcm-spy died"; exit 3; }
    xwd -root -silent >spy.xwd
    kill $spy' "$SOURCE_DIR/tools/lcm-spy.sh"
rc=$?
set -e
cat spy.out
[ $rc -eq 0 ] || fail "lcm-spy under xvfb-run: exit $rc"
# One per lcmtypes/*.lcm: the jar must carry every type.
want=$(ls "$SOURCE_DIR"/lcmtypes/*.lcm | wc -l)
grep -q "Found $want LCM types" spy.out || fail "lcm-spy did not load the $want pofkit types of the jar"
if grep -q "Unrecognized option" spy.out; then fail "the Java 17 workaround did not apply"; fi
/usr/bin/python3 "$SOURCE_DIR/tests/e2e/xwd2png.py" spy.xwd lcm-spy.png
echo "screenshot: $WORK_DIR/lcm-spy.png"
echo ok
