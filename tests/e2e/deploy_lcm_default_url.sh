# The deployment's bus contract (docs/deployment.md, "Multi-host: the LCM URL"): every pofkit
# process takes the bus from LCM_DEFAULT_URL (the units' /etc/pof/pof.env) when no --lcm-url is
# given. pof-daqd (sim backend) and pof-compensatord run with only LCM_DEFAULT_URL set to a private
# port; a pofkit Python subscriber, also given no URL, must receive POF_RAW and POF_ANGLE there
# (it waits for the messages, at most 30 s). pof-daqd's precedence: --lcm-url, then lcm.url of its
# configuration file, then LCM_DEFAULT_URL (--print-config shows the URL it resolved to).
source "$(dirname "$0")/lib.sh"
private_bus
POF="$BIN_DIR/pof"
unset LCM_DEFAULT_URL

# Precedence, without a bus: the environment, then the file's lcm.url, then --lcm-url.
daqd() { "$BIN_DIR/pof-daqd" --config "$WORK_DIR/daqd.toml" --device sim:session "$@" --print-config; }
printf 'schema_version = 1\n' >daqd.toml
out=$(LCM_DEFAULT_URL="$URL" daqd) || fail "pof-daqd --print-config failed"
grep -qF "url = '$URL&recv_buf_size=" <<<"$out" || fail "pof-daqd ignores LCM_DEFAULT_URL: $(grep url <<<"$out")"
out=$(daqd) || fail "pof-daqd --print-config failed"
grep -qF "url = 'udpm://239.255.76.67:7667?ttl=0&recv_buf_size=" <<<"$out" || fail "default URL: $(grep url <<<"$out")"
printf 'schema_version = 1\n[lcm]\nurl = "udpm://239.255.76.68:%s?ttl=0"\n' "$PORT" >daqd.toml
out=$(LCM_DEFAULT_URL="$URL" daqd) || fail "pof-daqd --print-config failed"
grep -qF "url = 'udpm://239.255.76.68:$PORT?ttl=0&" <<<"$out" || fail "lcm.url of the file must win over the environment: $(grep url <<<"$out")"
out=$(LCM_DEFAULT_URL="$URL" daqd --lcm-url "udpm://239.255.76.69:$PORT") || fail "pof-daqd --print-config failed"
grep -qF "url = 'udpm://239.255.76.69:$PORT?recv_buf_size=" <<<"$out" || fail "--lcm-url must win: $(grep url <<<"$out")"
printf 'schema_version = 1\n' >daqd.toml

# Live: nothing but LCM_DEFAULT_URL tells the three processes where the bus is.
"$POF" sim paper -o cal.csv 2>/dev/null
"$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
printf 'schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n' >pot.toml
export LCM_DEFAULT_URL="$URL"
PYTHONPATH="$BIN_DIR/../python:$SOURCE_DIR/lcmtypes/python" /usr/bin/python3 - >rx.out 2>&1 <<'PY' &
import time
import pofkit
want = {"POF_RAW", "POF_ANGLE"}
seen = {}
deadline = time.monotonic() + 30
# Every channel, so that the deadline is checked on every message (the statuses keep coming).
with pofkit.Subscriber() as sub:  # no URL: $LCM_DEFAULT_URL, as the C++ processes
    print("listening on", sub.url, flush=True)
    while set(seen) != want and time.monotonic() < deadline:
        for channel, _, msg in sub.messages(timeout_s=1):
            if channel in want:
                seen.setdefault(channel, msg)
            if set(seen) == want or time.monotonic() > deadline:
                break
raw, angle = seen.get("POF_RAW"), seen.get("POF_ANGLE")
assert raw is not None and raw.n_scans > 0, f"no raw block from pof-daqd on {sub.url}: {sorted(seen)}"
assert angle is not None, f"no angle from pof-compensatord on {sub.url}: {sorted(seen)}"
print(f"POF_RAW: {raw.n_scans} scans, {raw.n_channels} channels; POF_ANGLE: seq {angle.seq}")
PY
rx=$!; pids+=($rx)
"$BIN_DIR/pof-compensatord" --cal cal.toml --pot-cal pot.toml 2>comp.log &
pids+=($!)
"$BIN_DIR/pof-daqd" --config "$WORK_DIR/daqd.toml" --device sim:session 2>daqd.log &
pids+=($!)
wait $rx || fail "the subscriber on LCM_DEFAULT_URL got nothing: $(cat rx.out) / pof-daqd: $(tail -3 daqd.log) / pof-compensatord: $(tail -3 comp.log)"
cat rx.out
grep -qF "$URL" daqd.log || fail "pof-daqd does not name the URL it publishes on: $(cat daqd.log)"
grep -qF "$URL" comp.log || fail "pof-compensatord does not name the URL it uses: $(cat comp.log)"
echo ok
