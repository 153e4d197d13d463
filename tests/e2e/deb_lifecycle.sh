# The .deb packages through a host's day one and last day: installed with dpkg, pof.target's
# processes run, the authenticated mode's documented steps, then purged. All of it in a throwaway
# root, never on this host: an overlay of / (writes go to a tmpfs) in a private mount and network
# namespace (only lo, down, no route: the host a new lab's installer meets), with a stand-in for
# /proc/sys/net/core so the sysctl the package applies and takes back is seen without touching the
# kernel's. tests/e2e/deb_lifecycle_root.sh, run there as root, says what is checked.
# Needs root, unshare, overlayfs and dpkg; skipped (77) otherwise, or when pofkit is installed on
# this host already.
source "$(dirname "$0")/lib.sh"
BUILD_DIR=$(readlink -f "$BIN_DIR/..")
[ "$(id -u)" -eq 0 ] || { echo "SKIP: needs root (mount and network namespaces, dpkg)"; exit 77; }
command -v dpkg >/dev/null && command -v unshare >/dev/null || { echo "SKIP: dpkg or unshare missing"; exit 77; }
if dpkg-query -W -f='${Status}\n' pofkit 2>/dev/null | grep -q ' installed$'; then
  echo "SKIP: pofkit is installed on this host; the throwaway root would start from it"; exit 77
fi
unshare -m -n true 2>/dev/null || { echo "SKIP: no mount/network namespaces here"; exit 77; }

cpack --config "$BUILD_DIR/CPackConfig.cmake" -B "$WORK_DIR/pkg" >cpack.log 2>&1 || fail "cpack failed: $(tail -20 cpack.log)"
runtime=$(find "$WORK_DIR/pkg" -maxdepth 1 -name 'pofkit_*.deb' | head -n 1)
dev=$(find "$WORK_DIR/pkg" -maxdepth 1 -name 'pofkit-dev_*.deb' | head -n 1)
[ -n "$runtime" ] && [ -n "$dev" ] || fail "cpack made no pofkit_*.deb and pofkit-dev_*.deb: $(ls pkg)"

# The stand-in for /proc/sys/net/core: the two keys the package sets, at Debian's defaults.
mkdir -p core && echo 212992 >core/rmem_max && echo 212992 >core/rmem_default
mkdir -p ovl
cp "$SOURCE_DIR/tests/e2e/deb_lifecycle_root.sh" "$WORK_DIR/deb_lifecycle_root.sh"
cat >enter.sh <<SH
set -e
mount -t tmpfs -o size=2g pofkit-lifecycle "$WORK_DIR/ovl"
mkdir -p "$WORK_DIR/ovl/upper" "$WORK_DIR/ovl/work" "$WORK_DIR/ovl/root"
mount -t overlay overlay -o "lowerdir=/,upperdir=$WORK_DIR/ovl/upper,workdir=$WORK_DIR/ovl/work" "$WORK_DIR/ovl/root"
r="$WORK_DIR/ovl/root"
mount --rbind /dev "\$r/dev"
mount --rbind /sys "\$r/sys"
mount -t tmpfs tmpfs "\$r/run"
mount -t tmpfs tmpfs "\$r/tmp"
# This test's directory, writable through to the host: the packages in, the logs out. Its mount
# point made first: under /tmp (a clone there) it is not in the fresh tmpfs mounted above.
mkdir -p "\$r$WORK_DIR"
mount --bind "$WORK_DIR" "\$r$WORK_DIR"
inner="$WORK_DIR/deb_lifecycle_root.sh"   # copied in: the source tree may be under /tmp too
clean_env=(env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LANG=C.UTF-8)
# systemd as PID 1 of a pid namespace in that root, booted to a target of its own (journald only:
# nothing this host enables starts); --kill-child: nothing of it outlives this script.
mode=by-hand
if [ -x "\$r/lib/systemd/systemd" ] && [ "\${POF_LIFECYCLE_SYSTEMD:-1}" = 1 ]; then
  mkdir -p "\$r/run/systemd/system"
  printf '[Unit]\nDescription=pofkit lifecycle test\nWants=systemd-journald.service\n' \
    >"\$r/run/systemd/system/pofkit-lifecycle.target"
  unshare --pid --fork --kill-child chroot "\$r" /bin/sh -c \
    "mount -t proc proc /proc && mount --bind $WORK_DIR/core /proc/sys/net/core && exec env -i container=pofkit-lifecycle /lib/systemd/systemd --system --unit=pofkit-lifecycle.target --log-target=journal --show-status=false" \
    >"$WORK_DIR/systemd.log" 2>&1 &
  upid=\$!
  spid=
  for _ in \$(seq 100); do
    spid=\$(awk '{print \$1}' "/proc/\$upid/task/\$upid/children" 2>/dev/null || true)
    [ -n "\$spid" ] && break
    sleep 0.1
  done
  state=none
  # Its private socket first (systemctl's way in as root), then the end of its boot.
  for _ in \$(seq 300); do
    [ -n "\$spid" ] && [ -S "/proc/\$spid/root/run/systemd/private" ] && break
    sleep 0.1
  done
  if [ -n "\$spid" ] && [ -S "/proc/\$spid/root/run/systemd/private" ]; then
    state=\$(timeout 60 nsenter -t "\$spid" -a -r -w systemctl is-system-running --wait 2>&1 || true)
  fi
  case "\$state" in
    running | degraded) mode=systemd ;;
    *) echo "systemd did not boot here (\$state; \$(tail -n 3 "$WORK_DIR/systemd.log")): the units' command lines run by hand"
       # unshare --fork ignores SIGTERM: the namespace's init is killed, which ends it all.
       [ -z "\$spid" ] || kill -KILL "\$spid" 2>/dev/null || true
       wait "\$upid" 2>/dev/null || true ;;
  esac
fi
echo "mode: \$mode"
# What booting systemd there wrote already (e.g. /root/.ssh): not the package's doing.
(cd "$WORK_DIR/ovl/upper" && find . -mindepth 1 | sed 's|^\.||' | LC_ALL=C sort) >"$WORK_DIR/upper-before.list"
rc=0
if [ "\$mode" = systemd ]; then
  nsenter -t "\$spid" -a -r -w "\${clean_env[@]}" bash "\$inner" --systemd "$runtime" "$dev" "$WORK_DIR" || rc=\$?
  kill -s RTMIN+4 "\$spid" 2>/dev/null || true   # a container's systemd powers off on this signal
  for _ in \$(seq 300); do kill -0 "\$spid" 2>/dev/null || break; sleep 0.1; done
  kill -KILL "\$spid" 2>/dev/null || true
  wait "\$upid" 2>/dev/null || true
else
  mount -t proc proc "\$r/proc"
  mount --bind "$WORK_DIR/core" "\$r/proc/sys/net/core"
  chroot "\$r" "\${clean_env[@]}" bash "\$inner" "$runtime" "$dev" "$WORK_DIR" || rc=\$?
fi
[ "\$rc" -eq 0 ] || exit "\$rc"
# Outside the chroot, where both the overlay's upper layer and this host's / are seen.
bash "\$inner" --left "$WORK_DIR/ovl/upper" "$WORK_DIR/upper-before.list"
SH
unshare -m -n bash enter.sh 2>&1 | tee lifecycle.log
rc=${PIPESTATUS[0]}
[ "$rc" -eq 0 ] || fail "the lifecycle in the throwaway root failed (exit $rc): $(grep -m1 '^FAIL' lifecycle.log || tail -n 5 lifecycle.log)"
echo ok
