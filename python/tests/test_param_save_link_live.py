"""`omni4-param save` when the robot's INI is a symbolic link (a configuration kept in version
control): omni4-fw (sim backend, its own udpm port) is started with --config LINK; after a save
the link is still the same link, the file it points to is the one omni4-fw wrote (and loads),
the previous file is kept as .bak beside that file, nothing is left beside the link, and the
command names the file written. A restart through the link reads the saved file. (No set
before the save: a set waits for the loop, whose pace depends on the machine's load.)"""
import os
import random
import signal
import subprocess
import sys
import time

import pytest

from omni4.params import ParamClient, ParamError

pytestmark = pytest.mark.live

SCALE = max(1.0, float(os.environ.get("OMNI4_TEST_TIME_SCALE", "1")))
ROBOT_INI = """; a robot kept in a checkout
[hal]
motor = sim
lines = sim
[lcm]
url = {url}
[control]
kp = 25.5
"""


def param_cli():
    exe = os.path.join(os.path.dirname(sys.executable), "omni4-param")
    return [exe] if os.access(exe, os.X_OK) else [sys.executable, "-m", "omni4.params"]


def start_fw(omni4_bin, config, url):
    """omni4-fw on config, answering parameter requests (kp read back) within 10 s."""
    proc = subprocess.Popen([omni4_bin("omni4-fw"), "--config", str(config), "-q"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    client = ParamClient(url, timeout_s=0.5 * SCALE)
    deadline = time.monotonic() + 10 * SCALE
    while True:
        try:
            return proc, client, client.get("control.kp").value
        except ParamError:
            if proc.poll() is not None or time.monotonic() > deadline:
                stop_fw(proc, client)
                pytest.fail(f"omni4-fw did not answer: {proc.stderr.read()}")


def stop_fw(proc, client):
    client.close()
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=10 * SCALE)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=10)


def test_save_through_a_link_replaces_the_target_and_keeps_the_link(omni4_bin, tmp_path):
    url = f"udpm://239.255.76.67:{random.randint(9000, 9999)}?ttl=0"
    checkout = tmp_path / "checkout"
    checkout.mkdir()
    real = checkout / "robot.ini"
    real.write_text(ROBOT_INI.format(url=url))
    original = real.read_text()
    etc = tmp_path / "etc"
    etc.mkdir()
    link = etc / "robot.ini"
    os.symlink("../checkout/robot.ini", link)

    proc, client, kp = start_fw(omni4_bin, link, url)
    try:
        assert kp == 25.5
        r = subprocess.run(param_cli() + ["--lcm", url, "--timeout", str(5 * SCALE), "save"],
                           capture_output=True, text=True, timeout=60)
    finally:
        stop_fw(proc, client)
    assert r.returncode == 0, r.stderr
    written = os.path.realpath(real)
    assert r.stdout.startswith(f"saved {written} (previous kept as {written}.bak)"), r.stdout
    assert os.path.islink(link) and os.readlink(link) == "../checkout/robot.ini"
    saved = real.read_text()
    assert "written by omni4-fw (parameter save)" in saved and "\nkp = 25.5\n" in saved, saved
    assert (checkout / "robot.ini.bak").read_text() == original
    assert sorted(os.listdir(etc)) == ["robot.ini"]
    assert sorted(os.listdir(checkout)) == ["robot.ini", "robot.ini.bak"]

    proc, client, kp = start_fw(omni4_bin, link, url)  # the next start reads the saved file
    stop_fw(proc, client)
    assert kp == 25.5
