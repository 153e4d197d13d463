# The checked-in udev rule is generated from daq/device_ids.hpp: fail when it is stale, when a
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
echo ok
