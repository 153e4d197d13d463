#!/usr/bin/env bash
# Fault soak (`./pofkit soak`): what the daemons do over many faults and a long run, beyond what the
# e2e tests check once. Not part of `./pofkit test` (the full run takes about 70 minutes).
#
#   1. unplug: N unplug/replug cycles of the virtual USB-6008 (pof-vdaq --scenario unplug
#      --unplug-every) under pof-daqd: every cycle reconnected, its gap flagged (FLAG_GAP), and no
#      more scans lost than docs/daq.md ("States") says an unplug costs: (unplugged time + reconnect
#      time) x rate; no index jump without a flag.
#   2. kill: N SIGKILL/restart cycles each of pof-daqd (sim backend, 16000 scans/s), pof-compensatord
#      (every scan of a 1000 scans/s stream) and `pof record` (recording pof-daqd at 16000 scans/s):
#      after each kill the process is restarted and waited for (READY=1); a bus listener checks that
#      the stream resumes with the restart visible (seq restarting at 0) and that what was lost fits
#      in the kill -> READY time; the killed recordings pass `pof record --check` (after --repair, as
#      tests/e2e/record_crash.sh allows) and the last one without.
#   3. rss: VmRSS of pof-daqd (16000 scans/s x 3 channels, the USB-6009's maximum, on the sim
#      backend) and pof-compensatord (every scan) sampled every few seconds; growth after the
#      warm-up must stay below 1 MB/h (slope).
#
# Usage: tools/soak/soak.sh [--cycles N] [--kills N] [--minutes M] [--out DIR] [--parts LIST]
#   --cycles N     unplug cycles (100)             --kills N     SIGKILL cycles per process (= --cycles)
#   --minutes M    RSS run length (60)             --interval S  RSS sampling period (5)
#   --warmup S     RSS warm-up left out (60)       --out DIR     results (build/soak; recreated)
#   --parts LIST   comma-separated: unplug,kill,rss (all)
# Prints and writes DIR/summary.md and DIR/summary.json; exit 1 when any target is missed.
set -euo pipefail
SOURCE_DIR=$(cd "$(dirname "$(readlink -f "$0")")/../.." && pwd)
BIN_DIR=${BIN_DIR:-$SOURCE_DIR/build/bin}
cycles=100 kills="" minutes=60 interval=5 warmup=60 out=$SOURCE_DIR/build/soak parts=unplug,kill,rss
command_line="./pofkit soak $*"
usage() { sed -n '19,24p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
number() { case "$2" in '' | *[!0-9.]* | *.*.*) echo "soak: $1 takes a number, got '$2'" >&2; usage ;; esac; }
while [ $# -gt 0 ]; do
  [ $# -ge 2 ] || usage
  case "$1" in
    --cycles) number "$1" "$2"; cycles=$2 ;;
    --kills) number "$1" "$2"; kills=$2 ;;
    --minutes) number "$1" "$2"; minutes=$2 ;;
    --interval) number "$1" "$2"; interval=$2 ;;
    --warmup) number "$1" "$2"; warmup=$2 ;;
    --out) out=$2 ;;
    --parts) parts=$2 ;;
    *) echo "soak: unknown option '$1'" >&2; usage ;;
  esac
  shift 2
done
kills=${kills:-$cycles}
for p in ${parts//,/ }; do case "$p" in unplug | kill | rss) ;; *) echo "soak: unknown part '$p'" >&2; usage ;; esac; done
has() { case ",$parts," in *",$1,"*) return 0 ;; *) return 1 ;; esac; }
# tests/e2e/lib.sh empties WORK_DIR: only ever a directory a soak made (or a new one).
if [ -e "$out" ] && ! [ -e "$out/.pof-soak" ]; then
  echo "soak: $out exists and is not a soak's output directory; give another --out" >&2
  exit 2
fi
export BIN_DIR SOURCE_DIR WORK_DIR=$out
# start_ready (READY=1 / a bound LCM socket), wait_until, fail: the e2e tests' helpers.
source "$SOURCE_DIR/tests/e2e/lib.sh"
touch .pof-soak
CHECK="$SOURCE_DIR/tools/soak/soak_check.py"
export PYTHONPATH="$BIN_DIR/../python:$SOURCE_DIR/lcmtypes/python"
POF="$BIN_DIR/pof"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT
results=()
say() { printf '\033[1msoak:\033[0m %s\n' "$*" >&2; }
# A random LCM port: ttl=0 multicast is host-wide, other runs on this host must not cross in.
PORT=$((20000 + RANDOM % 30000))
URL="udpm://239.255.76.67:$PORT?ttl=0"

# --- 1. unplug/replug cycles -----------------------------------------------------------------------
# A cycle: 1 s unplugged, 2 s plugged (pof-daqd polls an absent device every daemon.retry_ms = 500).
if has unplug; then
  command -v umockdev-wrapper >/dev/null 2>&1 || fail "umockdev-wrapper not installed (./pofkit setup)"
  every=3 off=1
  say "1/3 unplug: $cycles cycles of ${off} s unplugged every ${every} s ($((cycles * every / 60 + 1)) min)"
  # The run ends 1.5 s after the last replug, before another cycle would start.
  umockdev-wrapper "$BIN_DIR/pof-vdaq" --daemon "$BIN_DIR/pof-daqd" --report unplug-vdaq.json \
    --model 6008 --scenario unplug --event-at 2 --unplug-every $every --unplug-for $off \
    --duration "$(awk -v n="$cycles" -v e=$every 'BEGIN { print 2 + n * e - 0.5 }')" \
    --rate 2000 --decimate 10 --expect-gap --expect-state 2 --min-reconnects "$cycles" \
    --max-dropped 1000000000 --min-rate-ratio 0 >unplug-vdaq.out 2>unplug-vdaq.err || true
  [ -s unplug-vdaq.json ] || fail "pof-vdaq wrote no report: $(tail -n 20 unplug-vdaq.err)"
  # Slack 0.05 s: the scans in the USB transfers in flight when the cable goes (4 transfers of a
  # few ms at 200 published scans/s) and the first block's publish latency.
  "$PY" "$CHECK" unplug unplug-vdaq.json --cycles "$cycles" --slack-s 0.05 --out unplug.json || true
  results+=(unplug.json)
fi

# kill_cycles <name> <progress file> <stderr prefix> <command...>: starts the command and waits for
# READY=1, lets the listener hear 100 of its messages, SIGKILLs it and starts it again, $kills times;
# the last one is stopped with SIGTERM. Writes "<cycle> <kill time> <ready time>" to <name>.kills.
kill_cycles() {
  local name=$1 progress=$2 what=$3 i pid t_kill=0
  shift 3
  : >"$name.kills"
  for ((i = 0; i <= kills; i++)); do
    start_ready notify "$what.$i.err" "$@"
    pid=$!
    [ "$i" -eq 0 ] || echo "$i $t_kill $EPOCHREALTIME" >>"$name.kills"
    wait_until --timeout 30 -- awk -v i=$((i + 1)) '$1 == i && $2 >= 100 { ok = 1 } END { exit !ok }' "$progress" ||
      fail "$name instance $i: the listener did not hear 100 messages: $(cat "$progress")"
    if [ "$i" -lt "$kills" ]; then
      t_kill=$EPOCHREALTIME
      kill -KILL "$pid"
    else
      kill -TERM "$pid"
    fi
    wait "$pid" 2>/dev/null || true
  done
}

# listen <channel> <name>: a soak_listen.py on the bus, ready once its socket is bound.
listen() {
  start_ready "$PORT" "$2.listen.err" "$PY" "$SOURCE_DIR/tools/soak/soak_listen.py" --lcm-url "$URL" \
    --channel "$1" --out "$2.csv" --progress "$2.progress"
  pids+=($!)
}
stop_listener() { kill -TERM "${pids[-1]}"; wait "${pids[-1]}" || fail "listener: $(cat "$1.listen.err")"; unset 'pids[-1]'; }

DAQ_MAX=(--rate 16000 --decimate 1 --block-scans 50)   # the USB-6009's maximum (docs/daq.md)
if has kill; then
  # Slack 0.1 s: the block being filled when the process died (3 ms at 16000 scans/s in blocks of
  # 50) and the time from READY=1 to the first message (pof-daqd is ready once it publishes,
  # before its first scans; pof-compensatord once subscribed, before the next block).
  slack=0.1
  say "2/3 kill: $kills SIGKILL/restart cycles each of pof-daqd, pof-compensatord, pof record"
  # pof-daqd on the sim backend.
  listen POF_RAW daqd
  kill_cycles daqd daqd.progress daqd "$BIN_DIR/pof-daqd" -d sim:synthetic "${DAQ_MAX[@]}" --lcm-url "$URL"
  stop_listener daqd
  "$PY" "$CHECK" restarts daqd.csv daqd.kills --what pof-daqd --cycles "$kills" --rate 16000 \
    --slack-s $slack --out kill-daqd.json || true
  results+=(kill-daqd.json)

  # pof-compensatord, fed by one pof-daqd that runs throughout; it publishes an angle per scan.
  "$POF" sim paper -o cal.csv --seed 11 2>/dev/null || fail "pof sim paper failed"
  "$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
  start_ready notify feed.err "$BIN_DIR/pof-daqd" -d sim:paper --rate 1000 --decimate 1 --block-scans 10 --lcm-url "$URL"
  pids+=($!); feed=$!
  listen POF_ANGLE comp
  kill_cycles comp comp.progress comp "$BIN_DIR/pof-compensatord" --cal cal.toml --lcm-url "$URL"
  stop_listener comp
  kill -TERM $feed; wait $feed || fail "pof-daqd feeding pof-compensatord: $(tail -n 5 feed.err)"
  "$PY" "$CHECK" restarts comp.csv comp.kills --what pof-compensatord --cycles "$kills" --rate 1000 \
    --slack-s $slack --out kill-compensatord.json || true
  results+=(kill-compensatord.json)

  # pof record under pof-daqd's maximum rate: a new log per restart; the listener only paces the
  # cycles (100 blocks heard = the recorder had them on its socket too).
  start_ready notify load.err "$BIN_DIR/pof-daqd" -d sim:synthetic "${DAQ_MAX[@]}" --lcm-url "$URL"
  pids+=($!); load=$!
  listen POF_RAW pace
  : >rec.kills
  for ((i = 0; i <= kills; i++)); do
    start_ready notify "rec.$i.err" "$POF" record -q -o "rec.$i.lcmlog" --lcm-url "$URL" -c POF_RAW --sync-interval 0.1
    rec=$!
    [ "$i" -eq 0 ] || echo "$i $t_kill $EPOCHREALTIME" >>rec.kills
    heard=$(awk '{ print $2 }' pace.progress)
    wait_until --timeout 30 -- awk -v h=$((heard + 100)) '$2 >= h { ok = 1 } END { exit !ok }' pace.progress ||
      fail "pof-daqd stopped publishing while pof record ran"
    if [ "$i" -lt "$kills" ]; then
      t_kill=$EPOCHREALTIME
      kill -KILL $rec
    else
      kill -INT $rec
    fi
    wait $rec 2>/dev/null || true
  done
  stop_listener pace
  kill -TERM $load; wait $load || fail "pof-daqd under pof record: $(tail -n 5 load.err)"
  for ((i = 0; i <= kills; i++)); do
    set +e
    "$POF" record --check "rec.$i.lcmlog" >"rec.$i.check" 2>&1
    rc=$?
    if [ $rc -eq 65 ]; then
      "$POF" record --repair "rec.$i.lcmlog" >"rec.$i.repair" 2>&1
      rr=$?
      "$POF" record --check "rec.$i.lcmlog" >"rec.$i.check" 2>&1
      rc="$rc $rr $?"
    fi
    set -e
    echo "$rc" >"rec.$i.rc"
  done
  "$PY" "$CHECK" record . rec.kills --cycles "$kills" --block-s "$(awk 'BEGIN { print 50 / 16000 }')" \
    --slack-s $slack --out kill-record.json || true
  results+=(kill-record.json)
fi

# --- 3. RSS at the maximum rate ---------------------------------------------------------------------
if has rss; then
  say "3/3 rss: pof-daqd and pof-compensatord at 16000 scans/s for $minutes min, sampled every $interval s"
  [ -e cal.toml ] || { "$POF" sim paper -o cal.csv --seed 11 2>/dev/null && "$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1; } ||
    fail "calibration for pof-compensatord failed"
  start_ready notify rss-comp.err "$BIN_DIR/pof-compensatord" --cal cal.toml --lcm-url "$URL"
  pids+=($!); comp=$!
  start_ready notify rss-daqd.err "$BIN_DIR/pof-daqd" -d sim:synthetic "${DAQ_MAX[@]}" --lcm-url "$URL"
  pids+=($!); daqd=$!
  "$PY" "$CHECK" rss-sample --pid pof-daqd=$daqd --pid pof-compensatord=$comp --interval "$interval" \
    --duration "$(awk -v m="$minutes" 'BEGIN { print m * 60 }')" --out rss.csv
  kill -TERM $daqd $comp
  wait $daqd || fail "pof-daqd exited $? on SIGTERM after the RSS run: $(tail -n 5 rss-daqd.err)"
  wait $comp || fail "pof-compensatord exited $? on SIGTERM after the RSS run: $(tail -n 5 rss-comp.err)"
  "$PY" "$CHECK" rss rss.csv --warmup "$warmup" --max-mb-per-h 1 --out rss.json || true
  results+=(rss.json)
fi

[ "${#results[@]}" -gt 0 ] || fail "no part ran"
"$PY" "$CHECK" summary "${results[@]}" --command "$command_line" --out-dir .
