"""The package's commands (every console script of python/pyproject.toml) as a shell runs them:
--version, a closed stdout (quiet, status 141), one-line errors without tracebacks."""
import os
import subprocess
import sys

import pytest

import omni4
from omni4 import _cli

BIN = os.path.dirname(sys.executable)     # the console scripts beside the venv's python
PYPROJECT = os.path.join(os.path.dirname(__file__), "..", "pyproject.toml")
TOOLS = ("omni4-param", "omni4-bridge", "omni4-mcap", "omni4-status", "omni4-teleop", "omni4-ros",
         "omni4-rosbag", "omni4-goto")


def tool(name):
    p = os.path.join(BIN, name)
    if not os.access(p, os.X_OK):
        pytest.skip(f"{p}: not installed (pip install './python[foxglove]')")
    return p


def test_every_console_script_is_checked_here():
    with open(PYPROJECT, encoding="utf-8") as f:
        text = f.read().split("[project.scripts]", 1)[1].split("\n[", 1)[0]
    scripts = {ln.split("=")[0].strip() for ln in text.splitlines() if "=" in ln}
    assert scripts == set(TOOLS)


@pytest.mark.parametrize("name", TOOLS)
def test_version_prints_the_package_version(name):
    r = subprocess.run([tool(name), "--version"], capture_output=True, text=True, timeout=30)
    print(name, r.stdout.strip())
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"{name} {omni4.__version__}"), r.stdout
    assert r.stderr == ""


@pytest.mark.parametrize("name", TOOLS)
def test_closed_stdout_is_quiet_status_141(name):
    # The reader is gone before the tool writes: its first write fails with EPIPE.
    rd, wr = os.pipe()
    os.close(rd)
    try:
        r = subprocess.run([tool(name), "--help"], stdout=wr, stderr=subprocess.PIPE, text=True,
                           timeout=30)
    finally:
        os.close(wr)
    assert r.returncode == _cli.EXIT_BROKEN_PIPE == 141, r.stderr
    assert r.stderr == "", r.stderr


def test_run_answers_version(capsys):
    assert _cli.run("x", lambda argv: 7, ["a"]) == 7
    assert _cli.run("x", lambda argv: 7, ["--version"]) == 0
    assert capsys.readouterr().out.startswith(f"x {omni4.__version__}")
    assert _cli.run("x", lambda argv: 7, ["--", "--version"]) == 7   # an operand, not the option


def test_run_broken_pipe_status(monkeypatch):
    def broken(argv):
        raise BrokenPipeError(32, "Broken pipe")
    monkeypatch.setattr(_cli.os, "dup2", lambda a, b: None)   # keep pytest's stdout
    assert _cli.run("x", broken, []) == 141


@pytest.mark.parametrize("argv, status, text", [
    (["omni4-param", "load", "/nonexistent/p.ini"], 2, "omni4-param: /nonexistent/p.ini: cannot read"),
    (["omni4-param", "--lcm", "bogus://x", "list"], 2, "omni4-param: cannot open LCM"),
    (["omni4-param", "frobnicate"], 2, "omni4-param: "),
    (["omni4-mcap", "/nonexistent/a.lcmlog", "--out", "/nonexistent/a.mcap", "-q"], 1,
     "omni4-mcap: /nonexistent/a.lcmlog: No such file or directory"),
    (["omni4-bridge", "--params", "/nonexistent/r.ini", "--duration", "0.1"], 2,
     "omni4-bridge: /nonexistent/r.ini: cannot read"),
])
def test_bad_input_is_one_line_without_traceback(argv, status, text):
    r = subprocess.run([tool(argv[0])] + argv[1:], capture_output=True, text=True, timeout=30)
    assert r.returncode == status, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    ours = [ln for ln in r.stderr.splitlines() if ln.startswith(argv[0] + ":")]
    assert len(ours) == 1 and ours[0].startswith(text), r.stderr
