# A controller project uses pofkit as a dependency: `cmake --install` gives headers, the
# pure core and the C/C++/Python message types, a CMake package and a pkg-config file;
# examples/cpp_client builds out of tree against that prefix alone (find_package(pofkit)) and its
# embedded compensator, given the cal.toml the installed `pof calibrate` wrote, compensates a
# recording to the very angles of `pof compensate` (pofkit::io + pofkit::core), a C program
# builds with pkg-config, and the installed daemons (sim backend) feed live angles to the C++ client
# and to the Python client (examples/python) running on the installed Python package. Then the
# authenticated mode: the installed daemons sign with a bus key, and the C++ client, given the key
# ($POF_LCM_AUTH_KEY_FILE, as the units give it; --key-file for a key others may read: refused),
# verifies every angle with the installed pofkit::auth and drops what a forger
# injects on POF_ANGLE (tests/e2e/lcm_hostile.py forge), counted per verdict on its summary line.
source "$(dirname "$0")/lib.sh"
BUILD_DIR=$(readlink -f "$BIN_DIR/..")
prefix="$WORK_DIR/prefix"
cmake --install "$BUILD_DIR" --prefix "$prefix" >install.log || fail "cmake --install failed: $(tail -5 install.log)"
# Libraries, the CMake package and pofkit.pc are in the configured LIBDIR (lib/<multiarch> on Debian).
libdir=$(sed -n 's/^CMAKE_INSTALL_LIBDIR:[A-Z]*=//p' "$BUILD_DIR/CMakeCache.txt")
[ -n "$libdir" ] || fail "no CMAKE_INSTALL_LIBDIR in $BUILD_DIR/CMakeCache.txt"

for f in include/pof/angle_t.hpp include/pof/raw_block_t.hpp include/pof_angle_t.h include/pof_raw_block_t.h \
  include/pof/core/compensator.hpp include/pof/core/calibration.hpp include/pof/bus/url.hpp include/pof/bus/channels.hpp \
  include/pof/bus/auth.hpp include/pof/bus/auth_key.hpp include/pof/io/calibration_file.hpp include/pof/base/errors.hpp \
  "$libdir"/libpof_auth.a "$libdir"/libpof_core.a "$libdir"/libpof_calibration_io.a "$libdir"/libpof_base.a "$libdir"/libpof_lcmtypes_c.a \
  "$libdir"/cmake/pofkit/pofkitConfig.cmake "$libdir"/cmake/pofkit/pofkitConfigVersion.cmake \
  "$libdir"/cmake/pofkit/pofkitTargets.cmake "$libdir"/pkgconfig/pofkit.pc \
  share/pofkit/lcmtypes/angle_t.lcm share/pofkit/lcmtypes/raw_block_t.lcm share/pofkit/plot/calibration_report.py \
  etc/pof/pof.env etc/pof/daqd.toml; do
  [ -e "$prefix/$f" ] || fail "the install lacks $f"
done
# No debug sections in the installed binaries (pof is ~80 MB with them): stripped by default.
for b in pof pof-daqd pof-compensatord; do
  if readelf -S "$prefix/bin/$b" | awk '/\.debug_info/ {found=1} END {exit !found}'; then
    fail "bin/$b still carries debug info after cmake --install"
  fi
done
echo "installed pof: $(du -k "$prefix/bin/pof" | cut -f1) KiB (build tree: $(du -k "$BIN_DIR/pof" | cut -f1) KiB)"

# Out of tree, against the prefix only: the example project (C++ client and embedded core).
cmake -S "$SOURCE_DIR/examples/cpp_client" -B client -G Ninja -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release >client-configure.log 2>&1 || fail "find_package(pofkit) failed: $(tail -20 client-configure.log)"
cmake --build client >client-build.log 2>&1 || fail "example client build failed: $(tail -30 client-build.log)"
client/pof-embedded-compensator || fail "the installed pofkit::core compensates wrongly"

# The compensator embedded from a calibration file (pofkit::io): the installed pof calibrates, the
# client loads cal.toml through the SDK and compensates a held-out recording scan by scan; its
# angles must be `pof compensate`'s (the same loader, the same OnlineCompensator), and a damaged
# calibration is refused with pofkit's exit code and the key named.
"$prefix/bin/pof" sim paper -o sdk-cal.csv --seed 21 2>/dev/null
"$prefix/bin/pof" sim paper -o sdk-run.csv --seconds 20 --seed 22 2>/dev/null
"$prefix/bin/pof" calibrate sdk-cal.csv -o sdk-cal.toml --no-plots >/dev/null 2>&1 || fail "installed pof calibrate failed"
"$prefix/bin/pof" compensate sdk-run.csv --cal sdk-cal.toml --csv sdk-pof.csv >/dev/null 2>&1 || fail "pof compensate failed"
client/pof-calibrated-compensator sdk-cal.toml sdk-run.csv sdk-client.csv || fail "the SDK did not compensate from sdk-cal.toml"
"$PY" - sdk-pof.csv sdk-client.csv <<'PY' || fail "the SDK's angles are not pof compensate's"
import csv, math, sys
pof, sdk = (list(csv.DictReader(open(p))) for p in sys.argv[1:])
assert len(pof) == len(sdk) == 4000, f"{len(pof)} and {len(sdk)} scans"
worst = max(abs(float(a["angle_deg"]) - float(b["angle_deg"])) for a, b in zip(pof, sdk))
assert worst < 1e-9 and all(a["quality"] == b["quality"] for a, b in zip(pof, sdk)), f"differ by {worst} deg"
print(f"SDK embedded compensator from cal.toml: {len(sdk)} scans, the angles of pof compensate (max diff {worst:.1e} deg)")
PY
sed 's/^reference_level_v = .*/reference_level_v = "four"/' sdk-cal.toml >bad-cal.toml
expect_exit 78 client/pof-calibrated-compensator bad-cal.toml sdk-run.csv
[[ "$err" == *"bad-cal.toml"*"reference_level_v"* ]] || fail "bad calibration through the SDK: $err"

# A C program through pkg-config: encode and decode an angle with the installed C types.
cat >c_client.c <<'C'
#include <stdio.h>
#include <string.h>
#include "pof_angle_t.h"
int main(void) {
  pof_angle_t a, b;
  memset(&a, 0, sizeof a);
  a.seq = 7; a.angle_deg = 42.5f; a.quality = POF_ANGLE_T_QUALITY_GAP;
  unsigned char buf[256];
  int n = pof_angle_t_encode(buf, 0, sizeof buf, &a);
  if (n <= 0 || pof_angle_t_decode(buf, 0, n, &b) != n) return 1;
  printf("C types: seq %lld angle %.1f quality %d\n", (long long)b.seq, b.angle_deg, b.quality);
  return b.seq == 7 && b.angle_deg == 42.5f && b.quality == POF_ANGLE_T_QUALITY_GAP ? 0 : 1;
}
C
export PKG_CONFIG_PATH="$prefix/$libdir/pkgconfig"
pkg-config --exists pofkit || fail "pkg-config does not find pofkit: $(pkg-config --print-errors pofkit 2>&1)"
# shellcheck disable=SC2046  # pkg-config output is a word list by design
cc -std=c11 -Wall -Werror c_client.c -o c_client $(pkg-config --cflags --libs pofkit) -lstdc++ -lm ||
  fail "C client does not build with pkg-config"
./c_client || fail "C types round trip failed"

# Live: the installed daemons (sim backend) -> the C++ client.
private_bus
"$prefix/bin/pof" sim paper -o cal.csv 2>/dev/null
"$prefix/bin/pof" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "installed pof calibrate failed"
printf 'schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n' >pot.toml
# The clients and the compensator listen before pof-daqd publishes its first scan.
start_ready "$PORT" client.err client/pof-angle-client --lcm-url "$URL" --count 400 --timeout 25 >client.out
client_pid=$!; pids+=($client_pid)
# The Python client from the installed package alone (its types and pofkit beside each other).
PYTHONPATH="$prefix/lib/python3/dist-packages" start_ready "$PORT" pyclient.err \
  /usr/bin/python3 "$SOURCE_DIR/examples/python/angle_client.py" --lcm-url "$URL" --count 400 --timeout 25 >pyclient.out
py_pid=$!; pids+=($py_pid)
# MATLAB/Octave through the Java jars, when GNU Octave is installed (it is not part of ./pofkit
# setup: ~300 MB; `apt install octave` to run this part).
oct_pid=
if command -v octave-cli >/dev/null 2>&1; then
  start_ready "$PORT" octave.err octave-cli --no-gui --quiet --eval "addpath('$SOURCE_DIR/examples/matlab'); \
    s = pof_angle_client('POF_ANGLE', 400, '$URL', '$prefix/share/java'); exit(s.angles < 400)" >octave.out
  oct_pid=$!; pids+=($oct_pid)
else
  echo "note: octave-cli not installed; the MATLAB/Octave client (examples/matlab) was not run"
fi
start_ready notify comp.log "$prefix/bin/pof-compensatord" --cal cal.toml --pot-cal pot.toml --lcm-url "$URL"
pids+=($!)
"$prefix/bin/pof-daqd" --device sim:session --lcm-url "$URL" --duration 6 2>daqd.log &
pids+=($!)
wait $client_pid || fail "the client did not get 400 angles: $(cat client.out client.err) / $(tail -3 comp.log) / $(tail -3 daqd.log)"
wait $py_pid || fail "the Python client did not get 400 angles: $(cat pyclient.out pyclient.err)"
outs=(client.out pyclient.out)
if [ -n "$oct_pid" ]; then
  wait $oct_pid || fail "the Octave client did not get 400 angles: $(cat octave.out octave.err)"
  outs+=(octave.out)
  # It ends without LCM's Java receive thread's SocketException (it unsubscribes, the caller
  # closes), and measures ages in microseconds, not whole ms. (Octave 7's own "ignoring const
  # execution_exception& while preparing to exit" follows any Java use at exit.)
  ! grep -q SocketException octave.err || fail "the Octave client ended with a SocketException: $(cat octave.err)"
  grep -q 'age_p99_ms=' octave.out || fail "the Octave client reports no p99 age: $(cat octave.out)"
fi
for out in "${outs[@]}"; do
  cat $out
  summary=$(awk '/^summary:/' $out)
  [ -n "$summary" ] || fail "no summary from $out"
  case "$summary" in *" undecodable=0 "*) ;; *) fail "$out: angles not decoded: $summary" ;; esac
  case "$summary" in *"age_p50_ms=nan"*) fail "$out: no sample age measured: $summary" ;; esac
done

# The authenticated mode, on a bus of its own: pof-daqd and pof-compensatord sign with the key;
# the forger captures 5 of the signed angles and sends 3 unsigned, 4 with a bad MAC, 3 stale and
# 3 replayed ones (forged.json) right after, long before the client has its 400 angles.
private_bus
"$prefix/bin/pof" keygen -o bus.key 2>/dev/null || fail "installed pof keygen failed"
install -m 0644 bus.key open.key
expect_exit 78 client/pof-angle-client --lcm-url "$URL" --key-file open.key --count 1 --timeout 1
grep -q "bus key file 'open.key': mode 0644" <<<"$err" || fail "the client took a key others may read: $err"
# The key from the environment, as the units give it to pofkit's own processes (--key-file above).
POF_LCM_AUTH_KEY_FILE=bus.key start_ready "$PORT" auth-client.err client/pof-angle-client --lcm-url "$URL" \
  --count 400 --timeout 25 >auth-client.out
auth_client=$!; pids+=($auth_client)
PYTHONPATH="$prefix/lib/python3/dist-packages" start_ready "$PORT" forge.err \
  "$PY" "$SOURCE_DIR/tests/e2e/lcm_hostile.py" forge "$PORT" bus.key forged.json POF_ANGLE
forger=$!; pids+=($forger)
start_ready notify auth-comp.log "$prefix/bin/pof-compensatord" --cal cal.toml --pot-cal pot.toml --lcm-url "$URL" \
  --auth-key-file bus.key
pids+=($!)
"$prefix/bin/pof-daqd" --device sim:session --lcm-url "$URL" --auth-key-file bus.key --duration 6 2>auth-daqd.log &
pids+=($!)
wait $forger || fail "forger: $(cat forge.err)"
wait $auth_client || fail "the verifying client did not get 400 angles: $(cat auth-client.out auth-client.err) / \
$(tail -3 auth-comp.log) / $(tail -3 auth-daqd.log)"
cat auth-client.out
grep -q "verifying with key id" auth-client.out || fail "the client did not say it verifies: $(cat auth-client.out)"
summary=$(awk '/^summary:/' auth-client.out)
# forged.json: what the forger sent per verdict; the client must have dropped exactly that.
want=$("$PY" -c 'import json, sys; d = json.load(open("forged.json"))
print(" ".join("dropped_%s=%d" % (k, d[k]) for k in ("unsigned", "bad_mac", "stale", "replayed")))')
[ "$want" = "dropped_unsigned=3 dropped_bad_mac=4 dropped_stale=3 dropped_replayed=3" ] || fail "forged.json: $want"
case "$summary" in *" $want") ;; *) fail "the client's drops are not the forgeries ($want): $summary" ;; esac
case "$summary" in *" angles=400 "*" undecodable=0 "*) ;; *) fail "verified angles not decoded: $summary" ;; esac
echo ok
