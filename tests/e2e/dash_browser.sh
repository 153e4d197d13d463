# `pof dash` end to end: the page in headless Chromium against the messages sent (dash_browser.py),
# then what the server refuses (a foreign page's WebSocket, writes) and the authenticated mode
# (unsigned angles never reach the page).
source "$(dirname "$0")/lib.sh"
POF="$BIN_DIR/pof"
PUB="$BIN_DIR/../tests/pof-testpub"
for f in /usr/bin/chromium /usr/bin/chromedriver /usr/share/javascript/chart.js/chart.min.js; do
  [ -e "$f" ] || fail "$f is missing (chromium, chromium-driver and libjs-chart.js are in ./pofkit's packages)"
done
mkdir -p "$WORK_DIR"
private_bus
"$PY" "$(dirname "$0")/dash_browser.py" "$POF" "$PUB" "$URL" "$WORK_DIR" || fail "the browser test failed"

# A WebSocket from a page of another origin is refused; one from the page's own origin opens; the
# server takes no writes.
private_bus
port=$(( 20000 + RANDOM % 30000 ))
"$POF" dash --lcm-url "$URL" --port "$port" --duration 20 >"$WORK_DIR/refuse.out" 2>&1 &
pids+=($!)
trap kill_started EXIT
wait_until --timeout 10 -- grep -q "http://127.0.0.1:$port/" "$WORK_DIR/refuse.out"
handshake() {  # handshake <origin>: the HTTP status line of a WebSocket upgrade
  "$PY" - "$port" "$1" <<'PYEOF'
import socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])), timeout=5)
s.sendall(("GET /ws HTTP/1.1\r\nHost: 127.0.0.1:%s\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
           "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\nOrigin: %s\r\n\r\n"
           % (sys.argv[1], sys.argv[2])).encode())
print(s.recv(200).decode(errors="replace").split("\r\n")[0])
PYEOF
}
foreign=$(handshake "http://evil.example")
own=$(handshake "http://127.0.0.1:$port")
echo "foreign origin: $foreign; own origin: $own"
case "$foreign" in *" 403 "*) ;; *) fail "a foreign origin's WebSocket got '$foreign', expected 403" ;; esac
case "$own" in *" 101 "*) ;; *) fail "the page's own WebSocket got '$own', expected 101" ;; esac
code=$(curl -s --noproxy '*' -o /dev/null -w '%{http_code}' -X POST "http://127.0.0.1:$port/api/state")
[ "$code" = 405 ] || fail "POST /api/state answered $code, expected 405"
code=$(curl -s --noproxy '*' -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port/../../etc/passwd")
[ "$code" = 404 ] || fail "a path outside the page answered $code, expected 404"

# Authenticated mode: unsigned angles are dropped and counted, never shown.
private_bus
"$POF" keygen -o "$WORK_DIR/bus.key" >/dev/null
aport=$(( 20000 + RANDOM % 30000 ))
"$POF" dash --lcm-url "$URL" --port "$aport" --auth-key-file "$WORK_DIR/bus.key" --duration 20 >"$WORK_DIR/auth.out" 2>&1 &
pids+=($!)
wait_until --timeout 10 -- grep -q "http://127.0.0.1:$aport/" "$WORK_DIR/auth.out"
"$PUB" --lcm-url "$URL" angles --rate 500 --duration 1 --suffix _LEFT_KNEE >/dev/null
# Until the dashboard has judged all 500 (or 10 s): the check below says what it saw.
wait_until --timeout 10 -- sh -c 'curl -s --noproxy "*" "$0" >"$1" && grep -q "\"auth_dropped\":500" "$1"' \
  "http://127.0.0.1:$aport/api/state" "$WORK_DIR/auth.json" || true
"$PY" - "$WORK_DIR/auth.json" <<'PYEOF' || fail "the authenticated dashboard showed unsigned messages"
import json, sys
s = json.load(open(sys.argv[1]))
print("authenticated dashboard: %d sensors shown, %d messages dropped" % (len(s["sensors"]), s["bus"]["auth_dropped"]))
sys.exit(0 if not s["sensors"] and s["bus"]["authenticated"] and s["bus"]["auth_dropped"] >= 500 else 1)
PYEOF
echo "PASS"
