"""host-tools/plots/omni4_report.py --log: the raw series of an omni4-sim log through
omni4.read_log, beside its CSV-only form (unchanged)."""
import math
import os
import re
import subprocess
import sys
import types

import numpy as np

import pytest

REPORT = os.path.join(os.path.dirname(__file__), "..", "..", "host-tools", "plots",
                      "omni4_report.py")
RUN_TIMEOUT_S = 120  # the report on a 2 MB log takes ~3 s (matplotlib start-up)


def report(*args):
    return subprocess.run([sys.executable, REPORT, *map(str, args)], capture_output=True,
                          text=True, timeout=RUN_TIMEOUT_S)


def test_log_figure_and_summary(tmp_path, omni4_bin):
    full = tmp_path / "full.lcmlog"
    r = subprocess.run([omni4_bin("omni4-sim"), "--experiments", "--speed", "max", "-q",
                        "--out", str(full)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    log = tmp_path / "sim.lcmlog"
    log.write_bytes(full.read_bytes()[:6_000_000])  # ~25 s (with the truth), cut inside an event
    csv = tmp_path / "csv"
    csv.mkdir()
    r = report(csv, tmp_path / "out", "--log", log)
    assert r.returncode == 0, r.stderr
    assert "wrote 2 figures" in r.stdout
    md = (tmp_path / "out" / "report.md").read_text()
    assert "![log_0_sim_lcmlog.png](log_0_sim_lcmlog.png)" in md
    assert (tmp_path / "out" / "log_0_sim_lcmlog.png").stat().st_size > 20000
    assert "experiment marks" in md and "in a truncated tail" in md
    assert "OMNI4_MOTORS: 2" in md  # ~25000 samples
    # The paths: the estimate, the camera and odometry against the simulator's truth.
    assert "![paths_0_sim_lcmlog.png](paths_0_sim_lcmlog.png)" in md
    assert (tmp_path / "out" / "paths_0_sim_lcmlog.png").stat().st_size > 20000
    rms = {}
    for line in md.splitlines():
        m = re.match(r"- ([a-z ]+?)(?: \(.*\))?: position RMS against the truth ([0-9.]+) mm",
                     line)
        if m:
            rms[m.group(1)] = float(m.group(2))
    # the paper's camera: 1 cm per axis, RMS of the distance 14 mm
    assert 10.0 < rms["camera"] < 18.0, rms
    assert rms["estimate"] < 0.5 * rms["camera"], rms
    assert rms["wheel odometry"] < 20.0, rms  # the simulator's floor is ideal by default


def test_wheel_odometry_closed_form():
    """A circle: all four wheels at w0 turn the robot at w = r w0 / d on the spot; wheel 3 and
    wheel 1 at +-u add v = r u. The pose after T is the circle's (x, y) = (v/w sin wT,
    v/w (1 - cos wT))."""
    sys.path.insert(0, os.path.dirname(REPORT))
    import omni4_report
    d, r, n, dt = 0.089, 0.0325, 20000, 1e-3
    w0, u = 5.0, 20.0
    speeds = np.tile([w0, w0 - u, w0, w0 + u], (n, 1))
    m = types.SimpleNamespace(wheel_speed=speeds, utime=np.arange(n, dtype=np.int64) * 1000)
    pose = omni4_report.wheel_odometry(m, d, r, (0.0, 0.0, 0.0))
    v, w, t = r * u, r * w0 / d, (n - 1) * dt
    assert abs(pose[-1, 0] - v / w * math.sin(w * t)) < 1e-6
    assert abs(pose[-1, 1] - v / w * (1 - math.cos(w * t))) < 1e-6
    assert abs(pose[-1, 2] - w * t) < 1e-9


def test_csv_only_form_still_works(tmp_path):
    csv = tmp_path / "csv"
    csv.mkdir()
    r = report(csv, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    assert "## Logs" not in (tmp_path / "out" / "report.md").read_text()


def test_bad_log_is_one_line_and_status_1(tmp_path):
    csv = tmp_path / "csv"
    csv.mkdir()
    bad = tmp_path / "bad.lcmlog"
    bad.write_bytes(b"not an event log" * 100)
    r = report(csv, tmp_path / "out", "--log", bad)
    assert r.returncode == 1
    assert r.stderr.strip().count("\n") == 0 and "bad.lcmlog: no intact LCM event" in r.stderr


@pytest.mark.parametrize("kind", ["a folder", "not JSON"])
def test_validation_json_that_cannot_be_read_is_one_line(tmp_path, kind):
    """--json (omni4-ident validate's output, read by the report) a folder or not JSON: one
    line naming it, status 1, no traceback."""
    csv = tmp_path / "csv"
    csv.mkdir()
    bad = tmp_path / "v.json"
    if kind == "a folder":
        bad.mkdir()
    else:
        bad.write_text("{not json\n")
    r = report(csv, tmp_path / "out", "--json", bad)
    assert r.returncode == 1, r.stderr
    assert "Traceback" not in r.stderr, r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"omni4_report: {bad}: "), r.stderr
