"""host-tools/plots/omni4_report.py --log: the raw series of an omni4-sim log through
omni4.read_log, beside its CSV-only form (unchanged)."""
import os
import subprocess
import sys

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
    assert "wrote 1 figures" in r.stdout
    md = (tmp_path / "out" / "report.md").read_text()
    assert "![log_0_sim_lcmlog.png](log_0_sim_lcmlog.png)" in md
    assert (tmp_path / "out" / "log_0_sim_lcmlog.png").stat().st_size > 20000
    assert "experiment marks" in md and "in a truncated tail" in md
    assert "OMNI4_MOTORS: 2" in md  # ~25000 samples


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
