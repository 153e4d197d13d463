# The Debian packages (CPack, cmake/PofPackaging.cmake): `pofkit` (binaries, units, udev rules,
# sysusers, sysctl, /etc/pof conffiles, plot scripts) and `pofkit-dev` (the SDK). Built from this
# build tree, their contents and control data checked, unpacked into a scratch root (dpkg-deb -x:
# no container, nothing installed on this host), and the unpacked `pof` run with the source tree
# hidden (a private mount namespace covers it) so it must find its own plot scripts.
source "$(dirname "$0")/lib.sh"
BUILD_DIR=$(readlink -f "$BIN_DIR/..")
command -v dpkg-deb >/dev/null || { echo "SKIP: dpkg-deb missing"; exit 77; }
cpack --config "$BUILD_DIR/CPackConfig.cmake" -B "$WORK_DIR/pkg" >cpack.log 2>&1 || fail "cpack failed: $(tail -20 cpack.log)"
runtime=$(ls pkg/pofkit_*.deb 2>/dev/null | head -1)
dev=$(ls pkg/pofkit-dev_*.deb 2>/dev/null | head -1)
[ -n "$runtime" ] && [ -n "$dev" ] || fail "expected pofkit_*.deb and pofkit-dev_*.deb, got: $(ls pkg)"
echo "packages: $(du -k "$runtime" | cut -f1) KiB $(basename "$runtime"), $(du -k "$dev" | cut -f1) KiB $(basename "$dev")"

has() {  # has <deb> <path>...: every path is in the package
  local deb=$1 listing; shift
  listing=$(dpkg-deb -c "$deb" | awk '{print $6}')
  for p in "$@"; do
    printf '%s\n' "$listing" | awk -v p="./$p" '$0 == p {f=1} END {exit !f}' || fail "$(basename "$deb") lacks $p"
  done
}
has "$runtime" usr/bin/pof usr/bin/pof-daqd usr/bin/pof-compensatord \
  usr/lib/systemd/system/pof-daqd@.service usr/lib/systemd/system/pof-compensatord@.service \
  usr/lib/systemd/system/pof.target usr/lib/sysusers.d/pof.conf usr/lib/sysctl.d/60-pof-lcm.conf \
  etc/pof/pof.env etc/pof/record.env etc/pof/daqd.toml usr/share/pofkit/plot/calibration_report.py \
  usr/share/java/pof_lcmtypes.jar
for r in "$SOURCE_DIR"/deploy/udev/*.rules; do has "$runtime" "usr/lib/udev/rules.d/$(basename "$r")"; done
has "$dev" usr/include/pof/angle_t.hpp usr/include/pof_angle_t.h usr/include/pof/core/compensator.hpp \
  usr/include/pof/bus/auth.hpp usr/include/pof/bus/auth_key.hpp usr/lib/libpof_auth.a \
  usr/lib/libpof_core.a usr/lib/libpof_calibration_io.a usr/lib/libpof_base.a usr/include/pof/io/calibration_file.hpp \
  usr/lib/libpof_lcmtypes_c.a usr/lib/cmake/pofkit/pofkitConfig.cmake \
  usr/lib/pkgconfig/pofkit.pc usr/share/pofkit/lcmtypes/angle_t.lcm
if dpkg-deb -c "$runtime" | awk '$6 ~ /^\.\/usr\/include\// {f=1} END {exit !f}'; then fail "headers in the runtime package"; fi

# Control data: shared-library dependencies found, conffiles and the postinst.
depends=$(dpkg-deb -f "$runtime" Depends)
for lib in libc6 liblcm libusb-1.0 libhidapi libsodium; do
  case "$depends" in *"$lib"*) ;; *) fail "pofkit Depends lacks $lib: $depends" ;; esac
done
[ "$(dpkg-deb -f "$dev" Package)" = pofkit-dev ] || fail "dev package name: $(dpkg-deb -f "$dev" Package)"
# pofkit::auth (libpof_auth.a) links libsodium, pofkit::io (libpof_base.a) toml++: pofkitConfig.cmake
# and pofkit.pc need their -dev packages.
dev_depends=$(dpkg-deb -f "$dev" Depends)
for pkg in liblcm-dev libeigen3-dev libsodium-dev libtomlplusplus-dev pkg-config; do
  case "$dev_depends" in *"$pkg"*) ;; *) fail "pofkit-dev Depends lacks $pkg: $dev_depends" ;; esac
done
mkdir -p ctl && dpkg-deb -e "$runtime" ctl
for c in /etc/pof/pof.env /etc/pof/record.env /etc/pof/daqd.toml; do
  awk -v c="$c" '$0 == c {f=1} END {exit !f}' ctl/conffiles || fail "$c is not a conffile: $(cat ctl/conffiles)"
done
[ -x ctl/postinst ] || fail "no postinst"
sh -n ctl/postinst || fail "postinst is not valid sh"

# Unpacked into a scratch root: the units name /usr/bin, the binaries carry no debug info, the
# pkg-config file names /usr.
root="$WORK_DIR/root"
dpkg-deb -x "$runtime" "$root" && dpkg-deb -x "$dev" "$root"
grep -q '^ExecStart=/usr/bin/pof-daqd ' "$root/usr/lib/systemd/system/pof-daqd@.service" ||
  fail "unit ExecStart: $(grep ExecStart "$root/usr/lib/systemd/system/pof-daqd@.service")"
grep -q '^prefix=/usr$' "$root/usr/lib/pkgconfig/pofkit.pc" || fail "pofkit.pc prefix: $(head -5 "$root/usr/lib/pkgconfig/pofkit.pc")"
if readelf -S "$root/usr/bin/pof" | awk '/\.debug_info/ {f=1} END {exit !f}'; then fail "packaged pof is not stripped"; fi

# The unpacked pof with the source tree out of reach (needs a mount namespace: root or userns).
# The work directory is inside the source tree (build/), so this part runs from a copy in /tmp.
"$root/usr/bin/pof" --version >version.txt || fail "unpacked pof --version failed"
outside=$(mktemp -d /tmp/pofkit-deb.XXXXXX)
trap 'rm -rf "$outside"' EXIT
cp -a "$root" "$outside/root"
cat >run_hidden.sh <<SH
set -e
mount -t tmpfs none "$SOURCE_DIR"
cd "$outside"
root/usr/bin/pof sim paper -o cal.csv 2>/dev/null
root/usr/bin/pof calibrate cal.csv -o cal.toml --report report >calibrate.out 2>calibrate.err
SH
if unshare -m true 2>/dev/null; then ns=(unshare -m); elif unshare -rm true 2>/dev/null; then ns=(unshare -rm); else
  echo "SKIP part: no mount namespace here; the source tree stays visible"; ns=(); fi
env -u POF_PLOT_DIR "${ns[@]}" bash run_hidden.sh ||
  fail "unpacked pof calibrate --report failed: $(cat "$outside/calibrate.err" 2>/dev/null)"
if grep -q "warning" "$outside/calibrate.err"; then fail "pof calibrate warned: $(cat "$outside/calibrate.err")"; fi
ls "$outside"/report/*.png >/dev/null 2>&1 ||
  fail "no PNG plots from the unpacked pof calibrate --report: $(ls "$outside/report") $(cat "$outside/calibrate.err")"
echo "unpacked pof calibrate --report: $(ls "$outside"/report/*.png | wc -l) plots with the source tree hidden"
echo ok
