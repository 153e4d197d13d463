# Run by tests/e2e/deb_lifecycle.sh as root inside its throwaway root (never on a real host):
#   deb_lifecycle_root.sh <pofkit.deb> <pofkit-dev.deb> <work dir>
# 1. dpkg -i both packages: user and group pof, the sysctl applied (and the old values kept),
#    man pages, copyright; pof-daqd reads /etc/pof/daqd.toml without --config.
# 2. The host has no multicast route: pof-multicast-route.service's command adds one on lo.
# 3. The authenticated mode as docs/deployment.md has it without credentials: root's key
#    (pof keygen), the services' own copy (user pof), POF_LCM_AUTH_KEY_FILE in pof.env.
# 4. pof.target with the shipped configuration, a calibration the lab wrote and pof-daqd on the
#    simulator (the lab's edit of daqd.toml): with --systemd, `systemctl start pof.target` (the
#    multicast route unit, both daemons, pof record, pof dash serving verified angles, timed from
#    the command to the first angle); without, each unit's ExecStart as systemd
#    would run it (user pof, its EnvironmentFile=s). pof record (the shipped record.env) records
#    signed, verified POF_RAW and POF_ANGLE; root's pof spy verifies with root's key.
#    systemd-analyze verify accepts the installed units; units are enabled (the per-sensor ones
#    too), so purge has links to remove.
# 5. dpkg --purge: every file dpkg listed is gone, as are the user, the group, the enablement links,
#    the route and the package's state; the sysctl values are the old ones; systemd has no pofkit
#    unit loaded.
#   deb_lifecycle_root.sh --left <overlay upper dir> <its paths before install>   (outside, after)
# 6. What install and purge left, from the overlay's upper layer against this host's /: only the
#    lab's own files (calibration, keys, recordings) and the package manager's bookkeeping; nothing
#    of the host removed or changed.
set -euo pipefail
fail() { echo "FAIL: $*" >&2; exit 1; }
step() { echo "--- $*"; }

if [ "$1" = --left ]; then
  step "what purge left"
  cd "$2"
  lab='^/etc/pof(/calibration\.toml|/lcm\.key|/lcm-pof\.key)?$|^/var/lib/pof(/recordings(/pof-[0-9TZ]+(\.[0-9]+)?\.(lcmlog|manifest\.json)|/pof-[0-9TZ]+\.files(/.*)?)?)?$'
  # dpkg's database and logs, the shadow utilities' backups, caches: changed by any install. And
  # the empty /root/.ssh of systemd's own tmpfiles provision.conf, when systemd was booted here.
  books='^/var/lib/dpkg(/|$)|^/var/log(/|$)|^/var/cache(/|$)|^/etc/(passwd|group|shadow|gshadow)-$|^/etc/ld\.so\.cache$|^/root/\.ssh$'
  bad=() kept=()
  while IFS= read -r -d '' p; do
    q=${p#.}
    grep -qxF -- "$q" "$3" && continue   # there before dpkg ran
    if [ -c "$p" ] && [ "$(stat -c %t:%T "$p")" = 0:0 ]; then
      grep -qE "$books" <<<"$q" || bad+=("removed:$q")
    elif [ -d "$p" ] && [ ! -L "$p" ]; then
      [ -d "$q" ] && [ ! -L "$q" ] && continue
      grep -qE "$lab|$books" <<<"$q" || bad+=("new-dir:$q")
    elif { [ -e "$q" ] || [ -L "$q" ]; } && cmp -s "$p" "$q"; then
      continue   # copied up, same content (e.g. /etc/passwd after the user went again)
    elif grep -qE "$lab" <<<"$q"; then kept+=("$q")
    else
      grep -qE "$books" <<<"$q" || bad+=("changed:$q")
    fi
  done < <(find . -mindepth 1 -print0)
  [ "${#bad[@]}" -eq 0 ] || fail "install and purge left behind: ${bad[*]}"
  echo "after purge: the lab's own files only: ${kept[*]}"
  exit 0
fi

# --systemd: systemd is PID 1 of this root (deb_lifecycle.sh booted it): the units run for real.
systemd=0
if [ "$1" = --systemd ]; then systemd=1; shift; fi
runtime=$1 dev=$2 work=$3
cd "$work"
GROUP=239.255.76.67
before_passwd=$(grep -c . /etc/passwd)

step "install"
dpkg -i "$runtime" "$dev" >dpkg-install.log 2>&1 || fail "dpkg -i failed: $(tail -n 20 dpkg-install.log)"
dpkg -L pofkit pofkit-dev | LC_ALL=C sort -u >dpkg-files.list
echo "installed: $(wc -l <dpkg-files.list) paths"
getent passwd pof | grep -q ':/var/lib/pof:/usr/sbin/nologin$' || fail "postinst created no system user pof: $(getent passwd pof)"
getent group pof >/dev/null || fail "no group pof"
[ "$(cat /proc/sys/net/core/rmem_max)" = 16777216 ] || fail "postinst did not apply rmem_max: $(cat /proc/sys/net/core/rmem_max)"
[ "$(cat /proc/sys/net/core/rmem_default)" = 2097152 ] || fail "postinst did not apply rmem_default"
for f in /usr/share/doc/pofkit/copyright /usr/share/doc/pofkit-dev/copyright /usr/share/man/man1/pof.1.gz \
  /usr/share/man/man1/pof-daqd.1.gz /usr/share/man/man1/pof-compensatord.1.gz /usr/share/man/man8/pof-setup-multicast.8.gz; do
  [ -s "$f" ] || fail "$f missing after install"
done
# Without --config pof-daqd reads the file the package installed (an unknown key there is refused
# naming it, so the file is what it read).
cp /etc/pof/daqd.toml daqd.toml.orig
printf '[nosuchsection]\n' >>/etc/pof/daqd.toml
rc=0; pof-daqd --print-config >daqd-default.out 2>&1 || rc=$?
cp daqd.toml.orig /etc/pof/daqd.toml
[ "$rc" -eq 78 ] && grep -q '/etc/pof/daqd.toml' daqd-default.out ||
  fail "pof-daqd without --config did not read /etc/pof/daqd.toml (exit $rc): $(cat daqd-default.out)"

step "multicast route"
if ip route get "$GROUP" >/dev/null 2>&1; then fail "this namespace has a multicast route already"; fi
route_cmd=$(sed -n 's/^ExecStart=//p' /usr/lib/systemd/system/pof-multicast-route.service)
if [ "$systemd" = 0 ]; then   # with systemd, pof.target's units pull it in (checked below)
  $route_cmd || fail "pof-multicast-route.service's $route_cmd failed"
  ip route get "$GROUP" | grep -q 'dev lo' || fail "no multicast route on lo after $route_cmd: $(ip route get "$GROUP" 2>&1)"
  $route_cmd | grep -q 'nothing to do' || fail "a second $route_cmd did not leave the route alone"
fi

step "calibration and the authenticated mode (docs/deployment.md, without credentials)"
sed -i 's/^kind = "usb6008"/kind = "sim:paper"/' /etc/pof/daqd.toml   # the lab's DAQ: the simulator
grep -q '^kind = "sim:paper"' /etc/pof/daqd.toml || fail "daqd.toml has no device.kind line to edit"
pof sim paper -o sim.csv 2>/dev/null
pof calibrate sim.csv -o /etc/pof/calibration.toml >calibrate.log 2>&1 || fail "pof calibrate: $(tail -n 5 calibrate.log)"
pof keygen -o /etc/pof/lcm.key >keygen.log || fail "pof keygen: $(cat keygen.log)"
install -o pof -g pof -m 600 /etc/pof/lcm.key /etc/pof/lcm-pof.key
echo POF_LCM_AUTH_KEY_FILE=/etc/pof/lcm-pof.key | tee -a /etc/pof/pof.env >/dev/null

if [ "$systemd" = 1 ]; then
  step "systemctl start pof.target"
  t_start=$(date +%s.%N)
  systemctl start pof.target
  for u in pof-multicast-route.service pof-daqd.service pof-compensatord.service pof-record.service pof-dash.service; do
    for _ in $(seq 100); do systemctl is-active -q "$u" && break; sleep 0.1; done
    systemctl is-active -q "$u" || fail "$u is $(systemctl is-active "$u"): $(journalctl -b -u "$u" --no-pager | tail -n 8)"
  done
  ip route get "$GROUP" | grep -q 'dev lo' || fail "pof-multicast-route.service added no route on lo: $(ip route get "$GROUP" 2>&1)"
  # The live view: pof-dash.service serves the verified angles on localhost:8090 (docs/dashboard.md).
  # The time from the one command to the first angle a browser would draw is the lab's first minute.
  ip link set lo up
  angles=0
  for _ in $(seq 300); do
    angles=$(curl -s --noproxy '*' --max-time 1 http://127.0.0.1:8090/api/state 2>/dev/null |
      python3 -c 'import json, sys; s = json.load(sys.stdin); print(sum(x["angles"] for x in s["sensors"]) if s["bus"]["authenticated"] else -1)' 2>/dev/null || echo 0)
    [ "${angles:-0}" -gt 0 ] && break
    sleep 0.1
  done
  [ "${angles:-0}" -gt 0 ] || fail "pof dash (pof-dash.service) showed no verified angle: $(journalctl -b -u pof-dash.service --no-pager | tail -n 5)"
  awk -v a="$t_start" -v b="$(date +%s.%N)" 'BEGIN { printf "first angle on the dashboard %.2f s after systemctl start pof.target\n", b - a }'
  # Verified angles are flowing (the dashboard counted them): root's spy listens to them now.
  pof spy --auth-key-file /etc/pof/lcm.key --duration 2 >spy.out 2>spy.err || fail "root's pof spy with root's key: $(cat spy.err)"
  systemctl stop pof.target
  for u in pof-daqd.service pof-compensatord.service pof-record.service pof-dash.service pof-multicast-route.service; do
    r=$(systemctl show -p Result --value "$u")
    [ "$r" = success ] || fail "$u ended with $r: $(journalctl -b -u "$u" --no-pager | tail -n 8)"
  done
  if ip route get "$GROUP" >/dev/null 2>&1; then fail "stopping pof-multicast-route.service left its route"; fi
  journalctl -b -u pof-daqd.service --no-pager >daq.err
  journalctl -b -u pof-compensatord.service --no-pager >comp.err
else
  step "pof.target's processes, as their units start them (systemd is not PID 1 here)"
  # systemd's EnvironmentFile=: KEY=VALUE lines, the value the rest of the line.
  unit_env=()
  load_env() { local line; while IFS= read -r line; do
    case "$line" in '' | '#'*) ;; *) unit_env+=("$line") ;; esac; done <"$1"; }
  load_env /etc/pof/pof.env
  load_env /etc/pof/record.env
  exec_start() { sed -n 's/^ExecStart=//p' "/usr/lib/systemd/system/$1"; }
  as_pof() { setpriv --reuid=pof --regid=pof --init-groups env -i PATH=/usr/bin:/bin "${unit_env[@]}" "$@"; }
  mkdir -p /var/lib/pof && install -d -o pof -g pof /var/lib/pof/recordings   # StateDirectory=
  # systemd splits $POF_RECORD_ARGS into words and expands no globs (POF_.*).
  record_args=$(printf '%s\n' "${unit_env[@]}" | sed -n 's/^POF_RECORD_ARGS=//p')
  read -r -a record_cmd <<<"$(exec_start pof-record.service | sed "s|\$POF_RECORD_ARGS|$record_args|")"
  read -r -a comp_cmd <<<"$(exec_start pof-compensatord.service)"
  read -r -a daq_cmd <<<"$(exec_start pof-daqd.service)"
  as_pof "${record_cmd[@]}" --duration 9 >record.out 2>record.err & record_pid=$!
  as_pof "${comp_cmd[@]}" --duration 8 >comp.out 2>comp.err & comp_pid=$!
  sleep 1
  as_pof "${daq_cmd[@]}" --duration 6 >daq.out 2>daq.err & daq_pid=$!
  sleep 3
  pof spy --auth-key-file /etc/pof/lcm.key --duration 2 >spy.out 2>spy.err || fail "root's pof spy with root's key: $(cat spy.err)"
  for p in daq:$daq_pid comp:$comp_pid record:$record_pid; do
    rc=0; wait "${p#*:}" || rc=$?
    [ "$rc" -eq 0 ] || fail "${p%%:*} (as its unit starts it) exited $rc: $(tail -n 5 "${p%%:*}.err")"
  done
fi
grep -q 'authenticated mode' daq.err && grep -q 'authenticated mode' comp.err ||
  fail "the daemons did not take the services' key: $(grep -h -i 'key' daq.err comp.err | head -n 3)"
grep -q '^POF_ANGLE ' spy.out || fail "root's pof spy saw no verified POF_ANGLE: $(head -n 12 spy.out)"
log=$(find /var/lib/pof/recordings -name 'pof-*.lcmlog' | head -n 1)
[ -n "$log" ] || fail "pof record wrote no log into /var/lib/pof/recordings"
pof record --check "$log" >check.out 2>&1 || fail "pof record --check $log: $(cat check.out)"
for ch in POF_RAW POF_ANGLE; do
  grep -qE "^ +$ch +[a-z_]+ +[1-9][0-9]* events" check.out || fail "the recording has no $ch: $(cat check.out)"
done
manifest=$(find /var/lib/pof/recordings -name 'pof-*.manifest.json' | head -n 1)
grep -q 'daqd.toml' "$manifest" || fail "the manifest does not carry /etc/pof/daqd.toml: $(head -c 600 "$manifest")"
echo "recorded: $(grep -E '^ +POF_(RAW|ANGLE) ' check.out | awk '{print $1 " " $3}' | tr '\n' ' ')"

step "units: systemd-analyze verify, enable"
(cd /usr/lib/systemd/system && systemd-analyze verify --man=no pof.target pof-daqd.service \
  pof-compensatord.service pof-record.service pof-multicast-route.service pof-daqd@LEFT_KNEE.service \
  pof-compensatord@LEFT_KNEE.service) >verify.out 2>&1 || fail "systemd-analyze verify: $(cat verify.out)"
[ ! -s verify.out ] || fail "systemd-analyze verify warned: $(cat verify.out)"
systemctl enable pof.target pof-daqd@LEFT_KNEE.service pof-compensatord@LEFT_KNEE.service >enable.log 2>&1 ||
  fail "systemctl enable: $(cat enable.log)"
links=$(find /etc/systemd/system -lname '*/pof*' | wc -l)
[ "$links" -ge 3 ] || fail "systemctl enable made $links links: $(cat enable.log)"

step "purge"
dpkg --purge pofkit-dev pofkit >dpkg-purge.log 2>&1 || fail "dpkg --purge failed: $(tail -n 20 dpkg-purge.log)"
left=()
while IFS= read -r f; do
  [ -L "$f" ] || [ -f "$f" ] || continue   # directories are shared (/usr/bin) or checked below
  left+=("$f")
done <dpkg-files.list
[ "${#left[@]}" -eq 0 ] || fail "purge left packaged files: ${left[*]}"
if getent passwd pof >/dev/null; then fail "purge left the user pof"; fi
if getent group pof >/dev/null; then fail "purge left the group pof"; fi
[ "$(grep -c . /etc/passwd)" -eq "$before_passwd" ] || fail "/etc/passwd has $(grep -c . /etc/passwd) lines, had $before_passwd"
[ -z "$(find /etc/systemd/system -lname '*/pof*')" ] || fail "purge left enablement links: $(find /etc/systemd/system -lname '*/pof*')"
if [ "$systemd" = 1 ]; then
  for u in pof.target pof-daqd.service pof-compensatord.service pof-record.service pof-multicast-route.service \
    pof-daqd@LEFT_KNEE.service; do
    [ "$(systemctl show -p LoadState --value "$u")" = not-found ] ||
      fail "after purge systemd still has $u: $(systemctl show -p LoadState -p ActiveState "$u" | tr '\n' ' ')"
  done
fi
[ "$(cat /proc/sys/net/core/rmem_max)" = 212992 ] && [ "$(cat /proc/sys/net/core/rmem_default)" = 212992 ] ||
  fail "the sysctl values were not put back: rmem_max $(cat /proc/sys/net/core/rmem_max), rmem_default $(cat /proc/sys/net/core/rmem_default)"
if ip route get "$GROUP" >/dev/null 2>&1; then fail "purge left the multicast route: $(ip route get "$GROUP")"; fi
[ ! -e /run/pofkit ] || fail "purge left /run/pofkit"
echo "lifecycle ok"
