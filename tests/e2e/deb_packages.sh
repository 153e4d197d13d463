# The Debian packages (CPack, cmake/PofPackaging.cmake): `pofkit` (binaries, units, udev rules,
# sysusers, sysctl, /etc/pof conffiles, plot scripts) and `pofkit-dev` (the SDK). Built from this
# build tree, their contents and control data checked, unpacked into a scratch root (dpkg-deb -x:
# no container, nothing installed on this host), and the unpacked `pof` run with the source tree
# hidden (a private mount namespace covers it) so it must find its own plot scripts. Both packages
# pass lintian with no error; pofkit-dev's libraries are in the multiarch directory without debug
# info and it pins pofkit's version; man pages, copyright, changelog and the maintainer scripts are
# there. tests/e2e/deb_lifecycle.sh installs, runs and purges them.
source "$(dirname "$0")/lib.sh"
BUILD_DIR=$(readlink -f "$BIN_DIR/..")
command -v dpkg-deb >/dev/null || { echo "SKIP: dpkg-deb missing"; exit 77; }
cpack --config "$BUILD_DIR/CPackConfig.cmake" -B "$WORK_DIR/pkg" >cpack.log 2>&1 || fail "cpack failed: $(tail -20 cpack.log)"
runtime=$(ls pkg/pofkit_*.deb 2>/dev/null | head -1)
dev=$(ls pkg/pofkit-dev_*.deb 2>/dev/null | head -1)
[ -n "$runtime" ] && [ -n "$dev" ] || fail "expected pofkit_*.deb and pofkit-dev_*.deb, got: $(ls pkg)"
echo "packages: $(du -k "$runtime" | cut -f1) KiB $(basename "$runtime"), $(du -k "$dev" | cut -f1) KiB $(basename "$dev")"

# lintian: no error; its warnings are printed, not failed on. lintian is a test package of
# ./pofkit setup.
command -v lintian >/dev/null || fail "lintian missing: ./pofkit setup installs it"
lintian --no-tag-display-limit "$runtime" "$dev" >lintian.out 2>&1 || true
n_err=$(grep -c '^E: ' lintian.out || true)
echo "lintian: $n_err errors, $(grep -c '^W: ' lintian.out || true) warnings$(grep '^W: ' lintian.out | sed 's/^/\n  /' | tr -d '\n' || true)"
[ "$n_err" -eq 0 ] || fail "lintian errors: $(grep '^E: ' lintian.out)"

has() {  # has <deb> <path>...: every path is in the package
  local deb=$1 listing; shift
  listing=$(dpkg-deb -c "$deb" | awk '{print $6}')
  for p in "$@"; do
    printf '%s\n' "$listing" | awk -v p="./$p" '$0 == p {f=1} END {exit !f}' || fail "$(basename "$deb") lacks $p"
  done
}
has "$runtime" usr/bin/pof usr/bin/pof-gap usr/bin/pof-daqd usr/bin/pof-compensatord usr/bin/pof-gen-udev-rules \
  usr/sbin/pof-setup-multicast usr/lib/systemd/system/pof-multicast-route.service \
  usr/lib/systemd/system/pof-daqd@.service usr/lib/systemd/system/pof-compensatord@.service \
  usr/lib/systemd/system/pof.target usr/lib/sysusers.d/pof.conf usr/lib/sysctl.d/60-pof-lcm.conf \
  etc/pof/pof.env etc/pof/record.env etc/pof/daqd.toml usr/share/pofkit/plot/calibration_report.py \
  usr/share/java/pof_lcmtypes.jar usr/share/doc/pofkit/copyright usr/share/doc/pofkit/changelog.gz \
  usr/share/doc/pofkit/README.md usr/share/man/man1/pof.1.gz usr/share/man/man1/pof-gap.1.gz usr/share/man/man1/pof-daqd.1.gz \
  usr/share/man/man1/pof-compensatord.1.gz usr/share/man/man1/pof-gen-udev-rules.1.gz \
  usr/share/man/man8/pof-setup-multicast.8.gz
for r in "$SOURCE_DIR"/deploy/udev/*.rules; do has "$runtime" "usr/lib/udev/rules.d/$(basename "$r")"; done
# The SDK's libraries, CMake package and pkg-config file in Debian's multiarch directory.
multiarch=$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || gcc -print-multiarch)
[ -n "$multiarch" ] || fail "cannot tell the multiarch triplet"
ml="usr/lib/$multiarch"
has "$dev" usr/include/pof/angle_t.hpp usr/include/pof_angle_t.h usr/include/pof/core/compensator.hpp \
  usr/include/pof/bus/auth.hpp usr/include/pof/bus/auth_key.hpp "$ml/libpof_auth.a" \
  "$ml/libpof_core.a" "$ml/libpof_calibration_io.a" "$ml/libpof_base.a" usr/include/pof/io/calibration_file.hpp "$ml/libpof_lcmtypes_c.a" "$ml/cmake/pofkit/pofkitConfig.cmake" \
  "$ml/pkgconfig/pofkit.pc" usr/share/pofkit/lcmtypes/angle_t.lcm usr/share/doc/pofkit-dev/copyright \
  usr/share/doc/pofkit-dev/changelog.gz
if dpkg-deb -c "$dev" | awk '$6 ~ /^\.\/usr\/lib\/[^\/]*\.a$/ || $6 ~ /^\.\/usr\/lib\/(cmake|pkgconfig)\// {f=1} END {exit !f}'; then
  fail "pofkit-dev puts libraries in /usr/lib, not /$ml: $(dpkg-deb -c "$dev" | awk '{print $6}' | grep '^\./usr/lib/[^/]*$')"
fi
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
# The SDK pins the runtime of its own version; the Python package's NumPy is declared.
version=$(dpkg-deb -f "$runtime" Version)
case ", $dev_depends," in *", pofkit (= $version),"*) ;; *) fail "pofkit-dev does not depend on pofkit (= $version): $dev_depends" ;; esac
for pkg in python3 python3-numpy; do
  case ", $depends," in *", $pkg,"*) ;; *) fail "pofkit Depends lacks $pkg: $depends" ;; esac
done
mkdir -p ctl && dpkg-deb -e "$runtime" ctl
for c in /etc/pof/pof.env /etc/pof/record.env /etc/pof/daqd.toml; do
  awk -v c="$c" '$0 == c {f=1} END {exit !f}' ctl/conffiles || fail "$c is not a conffile: $(cat ctl/conffiles)"
done
for script in postinst prerm postrm; do
  [ -x "ctl/$script" ] || fail "no $script"
  sh -n "ctl/$script" || fail "$script is not valid sh"
done

# Unpacked into a scratch root: the units name /usr/bin, the binaries carry no debug info, the
# pkg-config file names /usr.
root="$WORK_DIR/root"
dpkg-deb -x "$runtime" "$root" && dpkg-deb -x "$dev" "$root"
grep -q '^ExecStart=/usr/bin/pof-daqd ' "$root/usr/lib/systemd/system/pof-daqd@.service" ||
  fail "unit ExecStart: $(grep ExecStart "$root/usr/lib/systemd/system/pof-daqd@.service")"
grep -q '^prefix=/usr$' "$root/$ml/pkgconfig/pofkit.pc" || fail "pofkit.pc prefix: $(head -5 "$root/$ml/pkgconfig/pofkit.pc")"
grep -q "^libdir=\${prefix}/lib/$multiarch\$" "$root/$ml/pkgconfig/pofkit.pc" || fail "pofkit.pc libdir: $(grep libdir= "$root/$ml/pkgconfig/pofkit.pc")"
if readelf -S "$root/usr/bin/pof" | awk '/\.debug_info/ {f=1} END {exit !f}'; then fail "packaged pof is not stripped"; fi
for lib in "$root/$ml"/libpof*.a; do
  if readelf -S "$lib" | awk '/\.debug_(info|line)/ {f=1} END {exit !f}'; then fail "$(basename "$lib") in pofkit-dev carries debug info"; fi
done
# Each man page is a help2man page of its program (not an empty shell).
for m in "$root"/usr/share/man/man*/*.gz; do
  zcat "$m" | grep -q '^\.SH DESCRIPTION' || zcat "$m" | grep -q '^\.SH SYNOPSIS' || fail "$(basename "$m") is not a man page"
done
grep -q '^Files: \*' "$root/usr/share/doc/pofkit/copyright" || fail "copyright is not in the machine-readable format"

# One name for pof-daqd's configuration: the default its --help names is the file the package
# installs and the single-sensor unit reads.
help_cfg=$("$root/usr/bin/pof-daqd" --help | grep -o '/etc/pof/[A-Za-z_-]*\.toml' | head -n 1)
[ "$help_cfg" = /etc/pof/daqd.toml ] || fail "pof-daqd --help names '$help_cfg' as its default configuration"
has "$runtime" "${help_cfg#/}"
grep -q "^ExecStart=/usr/bin/pof-daqd --config $help_cfg\$" "$root/usr/lib/systemd/system/pof-daqd.service" ||
  fail "pof-daqd.service does not read $help_cfg: $(grep ExecStart "$root/usr/lib/systemd/system/pof-daqd.service")"

# The shipped defaults suit a single-sensor host as installed: every --manifest-file of record.env
# is a file the package installs (a missing one makes pof record exit 66 and pof-record.service
# fail before any calibration exists), and pof.env's bus is the built-in host-only default
# (ttl=0) that the threat model assumes.
args=$(sed -n 's/^POF_RECORD_ARGS=//p' "$root/etc/pof/record.env")
[ -n "$args" ] || fail "record.env sets no POF_RECORD_ARGS"
for f in $(grep -o -- '--manifest-file[= ][^ ]*' <<<"$args" | sed 's/^--manifest-file[= ]//'); do
  [ -f "$root$f" ] || fail "record.env names --manifest-file $f, which the package does not install"
done
default_url=$(sed -n 's/.*kHostOnlyUrl = "\([^"]*\)".*/\1/p' "$SOURCE_DIR/common/bus/include/pof/bus/url.hpp")
[ -n "$default_url" ] || fail "no kHostOnlyUrl in url.hpp"
shipped_url=$(sed -n 's/^LCM_DEFAULT_URL=//p' "$root/etc/pof/pof.env")
[ "$shipped_url" = "$default_url" ] || fail "pof.env ships LCM_DEFAULT_URL=$shipped_url, the built-in default is $default_url"
grep -q 'With `ttl=0` (the default URL)' "$SOURCE_DIR/docs/deployment.md" ||
  fail "docs/deployment.md's threat model no longer calls ttl=0 the default: check pof.env against it"

# The unpacked pof with the source tree out of reach (needs a mount namespace: root or userns).
# The work directory is inside the source tree (build/), so this part runs from a copy in /tmp.
"$root/usr/bin/pof" --version >version.txt || fail "unpacked pof --version failed"
# `pof gap` runs the pof-gap beside the unpacked pof, not the build's.
"$root/usr/bin/pof" gap --help >gap_help.txt || fail "unpacked pof gap --help failed"
grep -q "min-reduction" gap_help.txt || fail "unpacked pof gap --help is not pof-gap's help: $(head -3 gap_help.txt)"
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
