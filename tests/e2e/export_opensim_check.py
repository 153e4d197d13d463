#!/usr/bin/python3
"""The OpenSim Storage export of `pof export --format sto|mot` (export_opensim.sh), checked against
what went into the log, with a reader of its own that follows OpenSim's (docs/export.md,
"OpenSim": header lines up to `endheader`, nRows and nColumns, then a tab-separated label line that
starts with `time`, then tab-separated rows).

  export_opensim_check.py write LOG          a log: 50 angle_t on POF_ANGLE_LEFT_KNEE (200 Hz), 3
                                             cycle_stats_t on POF_STATS_LEFT_KNEE, a daq_status_t on
                                             POF_DAQ_STATUS_LEFT_KNEE, and 3 angle_t on POF_ANGLE_BACK
                                             whose time goes back at the third
  export_opensim_check.py angles FILE        FILE is the export of POF_ANGLE_LEFT_KNEE
  export_opensim_check.py stats FILE         FILE is the export of POF_STATS_LEFT_KNEE
Needs lcm-gen's `pof` classes on PYTHONPATH.
"""
import math
import struct
import sys

from pof import angle_t, cycle_stats_t, daq_status_t

T0 = 1764000000000000  # utime of the first angle [us]
N_ANGLES = 50
SYNC = 0xEDA1DA01


def angle(k):
    a = angle_t()
    a.utime = T0 + 5000 * k
    a.publish_utime = a.utime + 1000
    a.seq = k
    a.scan_index = 10 * k
    a.angle_deg = 10.0 + 0.5 * k
    a.angle_uncomp_deg = a.angle_deg + 2.0
    a.angle_ref_deg = math.nan if k == 3 else a.angle_deg - 0.25
    a.velocity_rad_s = 0.5 if k < 25 else -0.25
    a.phase = angle_t.PHASE_FLEXION if k < 25 else angle_t.PHASE_EXTENSION
    a.quality = angle_t.QUALITY_SETTLING if k < 5 else 0
    a.angle_sigma_deg = math.nan if k % 2 else 0.125
    return a


def stats(k):
    c = cycle_stats_t()
    c.utime = T0 + 1000000 * (k + 1) + 300
    c.seq = k
    c.cycle = k + 1
    c.start_utime = T0 + 1000000 * k
    c.end_utime = T0 + 1000000 * (k + 1)
    c.velocity_rad_s = 1.0
    c.rmse_comp_deg = 1.5
    c.rmse_uncomp_deg = 3.0
    c.hysteresis_comp_pct = 2.0
    c.hysteresis_uncomp_pct = 7.5
    c.max_error_deg = 2.75
    c.n_samples = 200
    return c


def write(path):
    events = [("POF_ANGLE_LEFT_KNEE", angle(k)) for k in range(N_ANGLES)]
    events += [("POF_STATS_LEFT_KNEE", stats(k)) for k in range(3)]
    s = daq_status_t()
    s.utime = T0
    s.sensor_id = "LEFT_KNEE"
    s.device_kind = "sim:test"
    s.state_text = "streaming"
    events.append(("POF_DAQ_STATUS_LEFT_KNEE", s))
    for k, back in enumerate((0, 5000, 2000)):  # the third goes back 3 ms
        a = angle(k)
        a.utime = T0 + back
        events.append(("POF_ANGLE_BACK", a))
    with open(path, "wb") as f:
        for n, (channel, msg) in enumerate(events):
            data = msg.encode()
            f.write(struct.pack(">IqqII", SYNC, n, T0 + n, len(channel), len(data)))
            f.write(channel.encode() + data)


def read_storage(path):
    """(header lines, labels, rows of floats), checking the layout on the way."""
    lines = open(path).read().split("\n")
    assert lines[-1] == "", f"{path}: does not end in a newline"
    lines.pop()
    end = lines.index("endheader")
    header = lines[:end]
    keys = dict(line.split("=", 1) for line in header[1:] if "=" in line)
    labels = lines[end + 1].split("\t")
    body = [line.split("\t") for line in lines[end + 2:]]
    assert labels[0] == "time", f"{path}: first label {labels[0]!r}, expected 'time'"
    assert keys.get("version") == "1", f"{path}: version {keys.get('version')!r}"
    assert keys.get("inDegrees") == "yes", f"{path}: inDegrees {keys.get('inDegrees')!r}"
    assert int(keys["nRows"]) == len(body), f"{path}: nRows={keys['nRows']}, body has {len(body)} rows"
    assert int(keys["nColumns"]) == len(labels), f"{path}: nColumns={keys['nColumns']}, {len(labels)} labels"
    for i, row in enumerate(body):
        assert len(row) == len(labels), f"{path}: row {i + 1} has {len(row)} fields, expected {len(labels)}"
    rows = [[float(v) for v in row] for row in body]  # float() takes "NaN" as OpenSim's std::stod does
    times = [r[0] for r in rows]
    assert times[0] == 0.0, f"{path}: time starts at {times[0]}"
    assert all(b > a for a, b in zip(times, times[1:])), f"{path}: time does not increase"
    return header, keys, labels, rows


def close(a, b, tol=1e-5):
    return (math.isnan(a) and math.isnan(b)) or abs(a - b) <= tol * max(1.0, abs(b))


def check_angles(path):
    header, keys, labels, rows = read_storage(path)
    assert header[0] == "POF_ANGLE_LEFT_KNEE", f"name line {header[0]!r}"
    assert int(keys["time_zero_utime"]) == T0, f"time_zero_utime {keys['time_zero_utime']}"
    want = ["time", "left_knee_angle", "left_knee_angle_uncomp", "left_knee_angle_ref", "left_knee_velocity",
            "left_knee_angle_sigma", "left_knee_phase", "left_knee_quality"]
    assert labels == want, f"labels {labels}, expected {want}"
    assert len(rows) == N_ANGLES, f"{len(rows)} rows"
    col = {name: i for i, name in enumerate(labels)}
    for k, r in enumerate(rows):
        a = angle(k)
        expect = {"time": 0.005 * k, "left_knee_angle": a.angle_deg, "left_knee_angle_uncomp": a.angle_uncomp_deg,
                  "left_knee_angle_ref": a.angle_ref_deg,
                  "left_knee_velocity": a.velocity_rad_s * 180 / math.pi,  # degrees: inDegrees=yes
                  "left_knee_angle_sigma": a.angle_sigma_deg, "left_knee_phase": a.phase,
                  "left_knee_quality": a.quality}
        for name, v in expect.items():
            assert close(r[col[name]], v), f"row {k + 1}: {name} = {r[col[name]]}, expected {v}"
    print(f"{path}: {len(rows)} rows x {len(labels)} columns, header and body agree")


def check_stats(path):
    header, keys, labels, rows = read_storage(path)
    assert labels[:3] == ["time", "left_knee_cycle", "left_knee_velocity"], f"labels {labels}"
    assert len(rows) == 3 and [r[0] for r in rows] == [0.0, 1.0, 2.0], f"times {[r[0] for r in rows]}"
    assert close(rows[0][2], 180 / math.pi), f"cycle velocity {rows[0][2]} deg/s"
    print(f"{path}: {len(rows)} cycles")


def main():
    if len(sys.argv) != 3 or sys.argv[1] not in ("write", "angles", "stats"):
        sys.exit(__doc__)
    try:
        {"write": write, "angles": check_angles, "stats": check_stats}[sys.argv[1]](sys.argv[2])
    except AssertionError as e:
        sys.exit(f"FAIL: {e}")


if __name__ == "__main__":
    main()
