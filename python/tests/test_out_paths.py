"""Output paths that cannot be written, in every tool that writes one (README: 2 for usage and
configuration errors, 1 for run-time errors; docs/design.md "Output files": an output path that
cannot be written, or that the tool refuses, is a run-time error): a directory where a file
goes, a missing parent folder, a file where a folder goes, a non-empty folder for a bag. Each
is one line on stderr naming the path, status 1, no traceback, and nothing at the path.
A folder written into (identify's --csv DIR, the report's OUT_DIR) is made with its parents, so
a missing parent is no error there. (omni4-goto writes no file.)"""
import os
import subprocess
import sys

import pytest
from conftest import lcm_test_url

BIN = os.path.dirname(sys.executable)
REPORT = os.path.join(os.path.dirname(__file__), "..", "..", "host-tools", "plots",
                      "omni4_report.py")
RUN_TIMEOUT_S = 120   # failure bound only


@pytest.fixture(scope="module")
def inputs(tmp_path_factory, omni4_bin):
    """A short simulated log, the paper's experiments (identify gets to its --csv), a base
    INI, Table III's INI and a CSV folder."""
    d = tmp_path_factory.mktemp("in")
    subprocess.run([omni4_bin("omni4-sim"), "--duration", "0.3", "--out", str(d / "short.lcmlog"),
                    "-q"], check=True, capture_output=True, timeout=RUN_TIMEOUT_S)
    subprocess.run([omni4_bin("omni4-sim"), "--experiments", "--speed", "max", "--out",
                    str(d / "full.lcmlog"), "-q"], check=True, capture_output=True,
                   timeout=RUN_TIMEOUT_S)
    (d / "base.ini").write_text("[model]\nd = 0.089\nr = 0.0325\nl = 5\nM = 2.34\n")
    (d / "t3.ini").write_text("; Table III\n")
    (d / "csv").mkdir()
    return d


# tool, argv with {OUT} (and {LOG}, {D} the inputs' folder), the kinds of bad path it is given
TABLE = [
    ("omni4-sim", ["{BIN}/omni4-sim", "--duration", "0.2", "-q", "--out", "{OUT}"],
     ("directory", "missing parent")),
    ("omni4-ident", ["{BIN}/omni4-ident", "identify", "--robot", "{D}/base.ini", "--out", "{OUT}",
                     "{LOG}"], ("directory", "missing parent")),
    ("omni4-ident", ["{BIN}/omni4-ident", "validate", "--params", "{D}/t3.ini", "--json", "{OUT}",
                     "{LOG}"], ("directory", "missing parent")),
    ("omni4-ident", ["{BIN}/omni4-ident", "identify", "--robot", "{D}/base.ini", "--out",
                     "{D}/ok.ini", "--csv", "{OUT}", "{D}/full.lcmlog"], ("file",)),
    ("omni4-record", ["{BIN}/omni4-record", "--duration", "0.2", "-q", "--lcm", "{URL}", "--out",
                      "{OUT}"], ("directory", "missing parent")),
    ("omni4-mcap", ["{VENV}/omni4-mcap", "-q", "{LOG}", "--out", "{OUT}"],
     ("directory", "missing parent")),
    ("omni4-rosbag", ["{VENV}/omni4-rosbag", "-q", "{LOG}", "--out", "{OUT}"],
     ("file", "non-empty folder", "missing parent")),
    ("omni4_report", [sys.executable, REPORT, "{D}/csv", "{OUT}"], ("file",)),
]
CASES = [(tool, argv, kind) for tool, argv, kinds in TABLE for kind in kinds]


def bad_path(tmp_path, kind):
    if kind == "directory":
        (tmp_path / "dir").mkdir()
        return tmp_path / "dir"
    if kind == "file":
        (tmp_path / "file").write_text("keep\n")
        return tmp_path / "file"
    if kind == "non-empty folder":
        (tmp_path / "full").mkdir()
        (tmp_path / "full" / "mine").write_text("keep\n")
        return tmp_path / "full"
    return tmp_path / "missing" / "out"


def case_id(tool, argv, kind):
    option = argv[argv.index("{OUT}") - 1]
    return f"{tool} {option if option.startswith('--') else 'OUT_DIR'}: {kind}"


@pytest.mark.parametrize("tool, argv, kind", CASES, ids=[case_id(*c) for c in CASES])
def test_output_path_that_cannot_be_written_is_status_1_and_one_line(tool, argv, kind, inputs,
                                                                      tmp_path, omni4_bin):
    out = bad_path(tmp_path, kind)
    before = sorted(p.name for p in tmp_path.rglob("*"))
    subs = {"{OUT}": str(out), "{LOG}": str(inputs / "short.lcmlog"), "{D}": str(inputs),
            "{BIN}": os.path.dirname(omni4_bin("omni4-sim")), "{VENV}": BIN,
            "{URL}": lcm_test_url()}
    cmd = []
    for a in argv:
        for k, v in subs.items():
            a = a.replace(k, v)
        cmd.append(a)
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=RUN_TIMEOUT_S)
    ours = [ln for ln in r.stderr.splitlines() if ln.startswith(f"{tool}:")]
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    assert len(ours) == 1 and out.name in ours[0] and "try --help" not in ours[0], r.stderr
    assert sorted(p.name for p in tmp_path.rglob("*")) == before    # nothing made, nothing left
