"""host-tools/plots/omni4_report.py --log: the raw series of an omni4-sim log through
omni4.read_log, beside its CSV-only form (unchanged); the drift report of a log with
OMNI4_ADAPT (what the online estimation learned since the identification), and none for a log
without it."""
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
    assert "wrote 3 figures" in r.stdout            # the raw series, the paths, the drift
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


DRIFT_SECONDS = 20               # of docs/hard-drive.csv (R +30 % in it with SIM_INI)
# Table III with motor 1's own R (4.5 ohm), windings that heat fast
R_IDENT = [4.3111, 4.5, 4.3111, 4.3111]   # [ohm] each motor's identified R
SIM_INI = ("[model]\nd = 0.089\nr = 0.0325\nl = 5\nKv = 0.0259\nKt = 0.0259\nR = 4.3111\n"
           "M = 2.34\nJ = 0.0228\nBv = 0.4978\nBvn = 0.6763\nBw = 0.0141\nCv = 1.8738\n"
           "Cvn = 2.2198\nCw = 0.1385\nR_1 = 4.5\n"
           "[sim]\nthermal = true\nthermal_capacity = 0.5\ntruth = false\n")


@pytest.fixture(scope="module")
def drift_logs(tmp_path_factory, omni4_bin):
    return _drift_log(tmp_path_factory.mktemp("drift"), omni4_bin)


def _drift_log(tmp_path, omni4_bin):
    """omni4-sim on the first DRIFT_SECONDS of the hard drive with windings that heat fast: the
    log, and the same log without its OMNI4_ADAPT events (written with LCM's own EventLog)."""
    import lcm
    root = os.path.join(os.path.dirname(REPORT), "..", "..")
    with open(os.path.join(root, "docs", "hard-drive.csv")) as f:
        rows = f.read().splitlines()[:DRIFT_SECONDS + 1]
    drive, ini, log = tmp_path / "drive.csv", tmp_path / "sim.ini", tmp_path / "hot.lcmlog"
    drive.write_text("\n".join(rows) + "\n")
    ini.write_text(SIM_INI)
    r = subprocess.run([omni4_bin("omni4-sim"), "--params", ini, "--drive", drive, "--out", log,
                        "-q"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    bare = tmp_path / "bare.lcmlog"
    out = lcm.EventLog(str(bare), "w", overwrite=True)
    last = None
    for ev in lcm.EventLog(str(log), "r"):
        if ev.channel == "OMNI4_ADAPT":
            last = ev.data
        else:
            out.write_event(ev.timestamp, ev.channel, ev.data)
    out.close()
    return log, bare, last, ini


def test_drift_report_of_a_log_with_omni4_adapt(tmp_path, drift_logs):
    """Per motor: the identified R (of --params, the simulated robot's INI: motor 1 4.5 ohm,
    the others Table III's 4.3111), the last R in use of the log's last adapt_t (decoded here by
    lcm-gen's class), its change in % (computed here), and the figure. The windings heated:
    every R in use moved up by more than 10 %."""
    import omni4
    log, _, last, ini = drift_logs
    csv = tmp_path / "csv"
    csv.mkdir()
    r = report(csv, tmp_path / "out", "--log", log, "--params", ini)
    assert r.returncode == 0, r.stderr
    md = (tmp_path / "out" / "report.md").read_text()
    assert "![drift_0_hot_lcmlog.png](drift_0_hot_lcmlog.png)" in md
    assert (tmp_path / "out" / "drift_0_hot_lcmlog.png").stat().st_size > 20000
    assert f"identified R_j from --params {ini}" in md
    a = omni4.adapt_t.decode(last)
    rows = re.findall(r"^\| (\d) \| ([0-9.]+) \| ([0-9.]+) \| ([+-][0-9.]+) \| ([0-9.]+) \|$",
                      md, re.M)
    assert [int(x[0]) for x in rows] == [0, 1, 2, 3], md
    for j, ident, in_use, pct, est in rows:
        j = int(j)
        assert float(ident) == R_IDENT[j]
        assert abs(float(in_use) - a.R[j]) <= 0.5e-4 and abs(float(est) - a.R_estimate[j]) <= 0.5e-4
        assert abs(float(pct) - 100 * (a.R[j] / R_IDENT[j] - 1)) <= 0.005 + 1e-9
        assert float(pct) > 10.0, md


def test_no_drift_report_without_omni4_adapt(tmp_path, drift_logs):
    """The same log without its OMNI4_ADAPT events: no drift section or figure; the report is
    the one the report makes with the drift step taken out (it adds nothing else)."""
    _, bare, _, ini = drift_logs
    csv = tmp_path / "csv"
    csv.mkdir()
    r = report(csv, tmp_path / "out", "--log", bare, "--params", ini)
    assert r.returncode == 0, r.stderr
    md = (tmp_path / "out" / "report.md").read_text()
    assert "Drift of" not in md and "drift_0" not in md and "OMNI4_ADAPT" not in md
    assert sorted(os.listdir(tmp_path / "out")) == ["log_0_bare_lcmlog.png",
                                                    "paths_0_bare_lcmlog.png", "report.md"]
    sys.path.insert(0, os.path.dirname(REPORT))
    import omni4_report

    def no_drift(*_args):
        raise AssertionError("a drift report of a log without OMNI4_ADAPT")
    args = types.SimpleNamespace(csv_dir=str(csv), out_dir=str(tmp_path / "again"), json=None,
                                 log=[str(bare)], params=str(ini))
    os.makedirs(args.out_dir)
    saved, omni4_report.fig_drift = omni4_report.fig_drift, no_drift
    try:
        omni4_report.write_report(args)
    finally:
        omni4_report.fig_drift = saved
    assert (tmp_path / "again" / "report.md").read_text() == md
