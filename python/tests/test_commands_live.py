"""Refused commands and the package's commands against omni4-fw (sim backend) over udpm on a
URL of its own (conftest.lcm_test_url): a command beyond the controller's [limits] raises
CommandRejected naming the limit (checked before sending, the limits read from the controller
and followed when they change); a refusal the client cannot predict comes back from the samples
(wait=True at once, else at the next call) and the refused command is not kept alive; a normal
command returns without waiting; omni4-param list | head -1 ends quietly."""
import os
import signal
import subprocess
import sys
import time

import pytest
from conftest import lcm_test_url

import omni4
from omni4.params import ParamClient

pytestmark = pytest.mark.live

URL = lcm_test_url()
START_TIMEOUT_S = 10
EXIT_TIMEOUT_S = 10
# Waits for an event (the next sample, a verdict, a change): failure bounds only, generous so
# that a loaded machine cannot reach them.
WAIT_S = 10
REJECTED = omni4.motors_t.FAULT_CMD_REJECTED


@pytest.fixture(scope="module")
def fw(tmp_path_factory, omni4_bin):
    ini = tmp_path_factory.mktemp("fw") / "robot.ini"
    ini.write_text(f"[lcm]\nurl = {URL}\n[hal]\nmotor = sim\n")
    proc = subprocess.Popen([omni4_bin("omni4-fw"), "--config", str(ini), "--duration", "60",
                             "-q"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    with omni4.Robot(URL, limits=False) as probe:
        try:
            next(probe.motors(timeout_s=START_TIMEOUT_S))
        except TimeoutError:
            proc.kill()
            pytest.fail(f"omni4-fw sent no OMNI4_MOTORS within {START_TIMEOUT_S} s: "
                        f"{proc.communicate(timeout=EXIT_TIMEOUT_S)[0]}")
    yield proc
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=EXIT_TIMEOUT_S)
    assert proc.returncode == 0, out


def test_out_of_range_commands_raise_naming_the_limit(fw):
    with omni4.Robot(URL, confirm_timeout_s=WAIT_S) as robot:
        next(robot.motors(timeout_s=WAIT_S))
        with pytest.raises(omni4.CommandRejected,
                           match=r"v 100 m/s beyond \[limits\] vel_lin_max 3 m/s"):
            robot.velocity(100, 0, 0)
        with pytest.raises(ValueError, match=r"voltage\[0\] 50 V beyond \[limits\] supply_v 12 V"):
            robot.voltage([50] * 4)
        assert robot.sent == 0
        # Nothing reached the controller: no refusal in its samples, still IDLE.
        m = next(robot.motors(timeout_s=WAIT_S))
        assert m.mode == omni4.motors_t.MODE_IDLE and not m.faults & REJECTED


def test_a_normal_velocity_call_returns_without_waiting(fw):
    with omni4.Robot(URL, confirm_timeout_s=WAIT_S) as robot:
        next(robot.motors(timeout_s=WAIT_S))
        robot.velocity(0.2, 0, 0)                 # the first: limits known by now
        n, spent = 50, 0.0
        for i in range(n):                        # a 50 Hz stream for 1 s
            t = time.perf_counter()
            robot.velocity(0.2, 0, 0.1 * (i % 2))
            spent += time.perf_counter() - t
            time.sleep(0.02)
        print(f"velocity(): {spent / n * 1e6:.0f} us per call (mean of {n}, 50 Hz stream)")
        t = time.perf_counter()
        robot.velocity(0.2, 0, 0, wait=True)
        print(f"velocity(wait=True): {(time.perf_counter() - t) * 1e3:.1f} ms")
        m = next(robot.motors(timeout_s=WAIT_S))
        assert m.mode == omni4.motors_t.MODE_VELOCITY and not m.faults & REJECTED
        robot.check()                             # nothing refused


def test_a_refusal_the_client_did_not_predict_raises(fw):
    # limits=False: no check before sending
    with omni4.Robot(URL, limits=False, confirm_timeout_s=WAIT_S) as robot:
        next(robot.motors(timeout_s=WAIT_S))
        t = time.perf_counter()
        with pytest.raises(omni4.CommandRejected, match=r"velocity\(100, 0, 0\) refused by the "
                                                        r"controller"):
            robot.velocity(100, 0, 0, wait=True)
        print(f"refusal with wait=True after {(time.perf_counter() - t) * 1e3:.1f} ms")
        robot.velocity(0.2, 0, 0, wait=True)      # accepted: clears the controller's bit
        robot.voltage([50] * 4)                   # returns at once ...
        with pytest.raises(omni4.CommandRejected, match=r"voltage\(\[50, 50, 50, 50\]"):
            # ... raised in the iterator
            for _ in robot.motors(timeout_s=WAIT_S, duration_s=WAIT_S):
                pass
        sent = robot.sent                         # the refused command is not re-sent
        time.sleep(0.3)
        assert robot.sent == sent
        robot.velocity(100, 0, 0)
        deadline = time.monotonic() + WAIT_S     # the controller's verdict, from its samples
        while robot.rejected < 3:
            assert time.monotonic() < deadline, "no verdict on velocity(100, 0, 0)"
            time.sleep(0.01)
        with pytest.raises(omni4.CommandRejected, match="refused by the controller"):
            robot.velocity(0.2, 0, 0)             # raised by the next call
        robot.velocity(0.2, 0, 0)                 # raised once: this one goes out
        assert robot.rejected == 3


def test_the_limits_follow_a_change(fw):
    with omni4.Robot(URL, confirm_timeout_s=WAIT_S) as robot, ParamClient(URL) as params:
        next(robot.motors(timeout_s=WAIT_S))
        robot.velocity(2.0, 0, 0)
        robot.stop()
        params.set("limits.vel_lin_max", 1.5)
        try:
            deadline = time.monotonic() + WAIT_S
            while robot.limits.get("limits.vel_lin_max") != 1.5:
                assert time.monotonic() < deadline, robot.limits
                time.sleep(0.01)
            with pytest.raises(omni4.CommandRejected, match=r"vel_lin_max 1.5 m/s"):
                robot.velocity(2.0, 0, 0)
        finally:
            params.set("limits.vel_lin_max", 3)


def test_param_list_into_a_closed_pipe_is_quiet(fw):
    tool = os.path.join(os.path.dirname(sys.executable), "omni4-param")
    # As a shell runs it: 0 when all fitted the pipe before head left, else 141; never a trace.
    r = subprocess.run(["bash", "-c", f"set -o pipefail; '{tool}' --lcm '{URL}' list | head -1"],
                       capture_output=True, text=True, timeout=30)
    print(f"omni4-param list | head -1: status {r.returncode}, stdout {r.stdout!r}")
    assert r.returncode in (0, 141) and r.stderr == "", r.stderr
    assert len(r.stdout.splitlines()) == 1
    # The reader gone before the first write: 141, nothing on stderr.
    p = subprocess.Popen([tool, "--lcm", URL, "list"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    p.stdout.close()
    err = p.stderr.read()
    p.wait(timeout=30)
    assert p.returncode == 141 and err == "", err
