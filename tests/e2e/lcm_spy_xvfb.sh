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
# Under the X server: lcm-spy starts (listening on the LCM port, its plugins loaded), then decodes 3 s
# of a live angle stream (pof-testpub's own duration), is still up, and the screen is taken.
set +e
POF_LCMTYPES_JAR="$BIN_DIR/../share/java/pof_lcmtypes.jar" LCM_DEFAULT_URL="$URL" \
  timeout 60 xvfb-run -a -s "-screen 0 1024x600x24" bash -c '
    spy_sh=$0 pof_wait=$1 testpub=$2 port=$3
    "$spy_sh" >spy.out 2>&1 & spy=$!
    /usr/bin/python3 "$pof_wait" until --timeout 30 --listening "$port" $spy || { echo "lcm-spy is not listening"; exit 3; }
    /usr/bin/python3 "$pof_wait" until --timeout 30 -- grep -q "^Found [0-9]* plugins" spy.out || { echo "lcm-spy did not start"; exit 3; }
    "$testpub" --lcm-url "$LCM_DEFAULT_URL" session --duration 3 || { echo "pof-testpub failed"; exit 3; }
    kill -0 $spy || { echo "lcm-spy died"; exit 3; }
    xwd -root -silent >spy.xwd
    kill $spy' "$SOURCE_DIR/tools/lcm-spy.sh" "$POF_WAIT" "$BIN_DIR/../tests/pof-testpub" "$PORT"
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
