#!/usr/bin/env bash
# Stock lcm-spy with pofkit's message types (lcmtypes/*.lcm).
#
#   tools/lcm-spy.sh [--lcm-url URL]          (installed as pof-lcm-spy)
#
# Why not /usr/bin/lcm-spy: LCM 1.3.1's launcher passes -Xincgc, which Java 17 refuses
# ("Unrecognized option: -Xincgc", upstream lcm-proj/lcm#331), and it cannot be given our types
# jar. This starts the same class directly (docs/lcm.md). Needs a display (over SSH:
# ssh -X, or `pof spy` for a terminal view) and Debian's libjchart2d-java.
# The types jar: $POF_LCMTYPES_JAR, else the build tree (build/share/java) or the install tree
# (<prefix>/share/java) next to this script.
set -euo pipefail
here=$(dirname "$(readlink -f "$0")")
jar=${POF_LCMTYPES_JAR:-}
if [ -z "$jar" ]; then
  for cand in "$here/../build/share/java/pof_lcmtypes.jar" "$here/../share/java/pof_lcmtypes.jar"; do
    if [ -f "$cand" ]; then jar=$(readlink -f "$cand"); break; fi
  done
fi
[ -n "$jar" ] && [ -f "$jar" ] ||
  { echo "lcm-spy.sh: pof_lcmtypes.jar not found (build with a JDK: ./pofkit build; or set POF_LCMTYPES_JAR)" >&2; exit 66; }
for j in /usr/share/java/lcm.jar /usr/share/java/jchart2d.jar; do
  [ -f "$j" ] || { echo "lcm-spy.sh: $j missing: apt-get install liblcm-java libjchart2d-java" >&2; exit 66; }
done
command -v java >/dev/null || { echo "lcm-spy.sh: java missing: apt-get install default-jre" >&2; exit 66; }
# lcm-spy takes the URL as -l/--lcm-url; LCM_DEFAULT_URL works too.
exec java -Djava.net.preferIPv4Stack=true -Xmx256m -ea \
  -cp "/usr/share/java/lcm.jar:/usr/share/java/jchart2d.jar:$jar" lcm.spy.Spy "$@"
