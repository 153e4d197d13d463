# The checked-in udev rule is generated from daq/include/pof/daq/device_ids.hpp: fail when it is stale, when a
# device of the table has no rule, or when any rule would make the device world-writable.
source "$(dirname "$0")/lib.sh"
rules="$SOURCE_DIR/deploy/udev/60-pof-daq.rules"
[ -f "$rules" ] || fail "$rules missing"
"$BIN_DIR/pof-gen-udev-rules" >"$WORK_DIR/generated.rules"
diff -u "$rules" "$WORK_DIR/generated.rules" >&2 ||
  fail "deploy/udev/60-pof-daq.rules is stale: cmake --build --preset release --target pof_udev_rules"
grep -Eq 'MODE="0?666"' "$rules" && fail "world-writable rule in $rules"
for id in 3923:717a 3923:717b 09db:007a; do
  grep -q "ATTR{idVendor}==\"${id%:*}\", ATTR{idProduct}==\"${id#*:}\"" "$rules" || fail "no rule for $id"
done
grep -q 'TAG+="uaccess"' "$rules" || fail "no uaccess tag"
# The group that owns the device nodes must be one the daemon's units run with, and one that
# sysusers creates (a rule for plugdev beside User=pof/Group=pof left the service without access).
groups=$(grep -o 'GROUP="[^"]*"' "$rules" | sort -u | sed 's/GROUP="\(.*\)"/\1/')
[ "$(echo "$groups" | wc -l)" -eq 1 ] || fail "rules name more than one group: $groups"
for unit in pof-daqd.service pof-daqd@.service; do
  f="$SOURCE_DIR/deploy/systemd/$unit"
  grep -Eq "^(Group=$groups|SupplementaryGroups=.*\b$groups\b)" "$f" || fail "$unit does not run with group $groups"
done
grep -Eq "^g $groups " "$SOURCE_DIR/deploy/sysusers.d/pof.conf" || fail "sysusers.d does not create group $groups"
# --help is usage, not the rules; an unknown argument is a usage error.
"$BIN_DIR/pof-gen-udev-rules" --help | grep -q '^Usage: pof-gen-udev-rules' || fail "--help is not usage"
"$BIN_DIR/pof-gen-udev-rules" --help | grep -q 'SUBSYSTEM' && fail "--help prints the rules"
rc=0; "$BIN_DIR/pof-gen-udev-rules" --bogus >/dev/null 2>&1 || rc=$?
[ "$rc" -eq 2 ] || fail "unknown argument exits $rc, expected 2"
echo ok
