# `cmake --install` puts binaries, units, sysusers, sysctl, rules and examples in place;
# `systemd-analyze verify` accepts every unit (single-sensor and per-sensor instances) with no
# warning; pof-record.service's command line works as systemd runs it and speaks sd_notify
# (READY=1, WATCHDOG=1 at half WatchdogSec, STATUS=, STOPPING=1) to a notify socket.
source "$(dirname "$0")/lib.sh"
BUILD_DIR=$(readlink -f "$BIN_DIR/..")
prefix="$WORK_DIR/prefix"
cmake --install "$BUILD_DIR" --prefix "$prefix" >install.log

for f in bin/pof bin/pof-lcm-spy lib/sysusers.d/pof.conf lib/sysctl.d/60-pof-lcm.conf \
  share/pofkit/examples/pof.env share/pofkit/examples/record.env share/pofkit/examples/daqd-LEFT_KNEE.toml \
  share/pofkit/examples/lcm-auth.conf share/doc/pofkit/deployment.md lib/systemd/system/pof.target lib/systemd/system/pof-record.service \
  lib/systemd/system/pof-daqd.service lib/systemd/system/pof-daqd@.service \
  lib/systemd/system/pof-compensatord.service lib/systemd/system/pof-compensatord@.service \
  lib/systemd/system/pof-multicast-route.service lib/systemd/system/pof-dash.service \
  share/pofkit/dash/index.html share/pofkit/dash/dash.js share/pofkit/dash/dash.css \
  sbin/pof-setup-multicast bin/pof-gen-udev-rules; do
  [ -e "$prefix/$f" ] || fail "cmake --install did not install $f"
done
for r in "$SOURCE_DIR"/deploy/udev/*.rules; do
  [ -e "$r" ] || continue
  [ -e "$prefix/lib/udev/rules.d/$(basename "$r")" ] || fail "udev rule $(basename "$r") not installed"
done
grep -q "^ExecStart=$prefix/sbin/pof-setup-multicast$" "$prefix/lib/systemd/system/pof-multicast-route.service" ||
  fail "pof-multicast-route.service does not run the installed pof-setup-multicast"
for u in pof-daqd.service pof-daqd@.service pof-compensatord.service pof-compensatord@.service pof-record.service \
  pof-dash.service; do
  grep -q '^Wants=.*pof-multicast-route.service' "$prefix/lib/systemd/system/$u" &&
    grep -q '^After=.*pof-multicast-route.service' "$prefix/lib/systemd/system/$u" ||
    fail "$u does not pull in the multicast route before it starts"
done
grep -q "^ExecStart=$prefix/bin/pof record " "$prefix/lib/systemd/system/pof-record.service" ||
  fail "units do not name the binaries under the install prefix: $(grep ExecStart "$prefix/lib/systemd/system/pof-record.service")"
grep -q "@POF_" "$prefix"/lib/systemd/system/* && fail "unsubstituted @POF_...@ in the installed units"
grep -q '^net.core.rmem_max = ' "$prefix/lib/sysctl.d/60-pof-lcm.conf" || fail "sysctl lacks rmem_max"
# The sysusers entry creates the user and group in a scratch root (never on this host).
if command -v systemd-sysusers >/dev/null; then
  mkdir -p sysroot/etc
  systemd-sysusers --root="$WORK_DIR/sysroot" "$prefix/lib/sysusers.d/pof.conf" >sysusers.out 2>&1 ||
    fail "systemd-sysusers rejected pof.conf: $(cat sysusers.out)"
  grep -q '^pof:x:[0-9]*:[0-9]*:.*:/var/lib/pof:/usr/sbin/nologin$' sysroot/etc/passwd ||
    fail "sysusers did not create the system user pof: $(cat sysroot/etc/passwd)"
fi

# systemd-analyze verify needs every ExecStart binary to exist. Daemons not built in this tree
# (e.g. before pof-compensatord lands) are replaced by /bin/true in a copy, and said so.
command -v systemd-analyze >/dev/null || { echo "SKIP: systemd-analyze missing (package systemd)"; exit 77; }
units="$WORK_DIR/units"
mkdir -p "$units"
cp "$prefix"/lib/systemd/system/* "$units/"
for bin in pof-daqd pof-compensatord; do
  if [ ! -x "$prefix/bin/$bin" ]; then
    echo "note: $bin is not built in this tree; verifying its units with /bin/true in its place"
    sed -i "s|$prefix/bin/$bin|/bin/true|" "$units"/*
  fi
done
cd "$units"
SYSTEMD_UNIT_PATH="$units:" systemd-analyze verify --man=no \
  pof.target pof-daqd.service pof-compensatord.service pof-record.service pof-dash.service pof-multicast-route.service \
  pof-daqd@LEFT_KNEE.service pof-compensatord@LEFT_KNEE.service pof-daqd@RIGHT_KNEE.service \
  >"$WORK_DIR/verify.out" 2>&1 || fail "systemd-analyze verify failed: $(cat "$WORK_DIR/verify.out")"
[ ! -s "$WORK_DIR/verify.out" ] || fail "systemd-analyze verify warned: $(cat "$WORK_DIR/verify.out")"
# The same with the authenticated mode's drop-in where docs/deployment.md installs it: the prefix
# drop-in directory pof-.service.d applies it to every pofkit service.
grep -q "@POF_" "$prefix/share/pofkit/examples/lcm-auth.conf" && fail "unsubstituted @POF_...@ in lcm-auth.conf"
mkdir -p pof-.service.d && cp "$prefix/share/pofkit/examples/lcm-auth.conf" pof-.service.d/
SYSTEMD_UNIT_PATH="$units:" systemd-analyze verify --man=no \
  pof-daqd.service pof-compensatord.service pof-record.service pof-dash.service pof-daqd@LEFT_KNEE.service \
  pof-compensatord@LEFT_KNEE.service >"$WORK_DIR/verify-auth.out" 2>&1 ||
  fail "systemd-analyze verify with lcm-auth.conf failed: $(cat "$WORK_DIR/verify-auth.out")"
[ ! -s "$WORK_DIR/verify-auth.out" ] || fail "systemd-analyze verify warned with lcm-auth.conf: $(cat "$WORK_DIR/verify-auth.out")"
rm -r pof-.service.d
cd "$WORK_DIR"
grep -q '^DeviceAllow=char-usb_device rw' "$units/pof-daqd@.service" || fail "daqd lacks the USB device allowance"
grep -q '^ExecStart=.*--sensor-id %i' "$units/pof-daqd@.service" || fail "daqd template does not pass the sensor id"

# pof-record.service's ExecStart, as systemd would run it (the default POF_RECORD_ARGS, the state
# directory swapped for a temporary one), under a fake notify socket with a 1 s watchdog.
mkdir -p state/recordings
args=$(sed -n 's/^Environment="POF_RECORD_ARGS=\(.*\)"$/\1/p' "$units/pof-record.service")
[ -n "$args" ] || fail "no default POF_RECORD_ARGS in pof-record.service"
# shellcheck disable=SC2086  # POF_RECORD_ARGS is split into words, as systemd does with $VAR
"$PY" "$POF_WAIT" notify-log -- "$prefix/bin/pof" record --output state/recordings/ $args --duration 3 \
  --lcm-url "udpm://239.255.76.67:$((20000 + RANDOM % 30000))?ttl=0" >notify.out
cat notify.out
[ "$(head -n 1 notify.out)" = 0 ] || fail "pof record (service command line) exited $(head -n 1 notify.out)"
grep -q "READY=1" notify.out || fail "no READY=1"
grep -q "STOPPING=1" notify.out || fail "no STOPPING=1"
grep -q "STATUS=recording: " notify.out || fail "no STATUS"
wd=$(grep -c "WATCHDOG=1" notify.out)
[ "$wd" -ge 4 ] && [ "$wd" -le 8 ] || fail "expected ~6 WATCHDOG=1 in 3 s at WatchdogSec=1 s, got $wd"
ls state/recordings/pof-*.lcmlog >/dev/null || fail "no timestamped log in the state directory"
ls state/recordings/pof-*.manifest.json >/dev/null || fail "no manifest in the state directory"

# The two daemons speak the same protocol to systemd (their units are Type=notify, WatchdogSec=5):
# READY=1 once running, the watchdog fed from their working loop, STOPPING=1 on the way out.
check_notify() {  # check_notify <name> <command...>
  local name=$1; shift
  "$PY" "$POF_WAIT" notify-log -- "$@" >"notify-$name.out" 2>"notify-$name.err" || fail "$name: $(tail -n 3 "notify-$name.err")"
  [ "$(head -n 1 "notify-$name.out")" = 0 ] || fail "$name exited $(head -n 1 "notify-$name.out"): $(cat "notify-$name.err")"
  grep -q "READY=1" "notify-$name.out" || fail "$name: no READY=1"
  grep -q "STOPPING=1" "notify-$name.out" || fail "$name: no STOPPING=1"
  local n; n=$(grep -c "WATCHDOG=1" "notify-$name.out")
  [ "$n" -ge 3 ] || fail "$name: expected several WATCHDOG=1 in 3 s at WatchdogSec=1 s, got $n"
}
url="udpm://239.255.76.67:$((20000 + RANDOM % 30000))?ttl=0"
check_notify pof-daqd "$prefix/bin/pof-daqd" --device sim:paper --lcm-url "$url" --duration 3
"$prefix/bin/pof" sim paper -o cal.csv 2>/dev/null && "$prefix/bin/pof" calibrate cal.csv -o cal.toml >/dev/null 2>&1
check_notify pof-compensatord "$prefix/bin/pof-compensatord" --cal "$PWD/cal.toml" --lcm-url "$url" --duration 3
echo ok
