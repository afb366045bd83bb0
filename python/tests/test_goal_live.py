"""Goals against the real controller: omni4-fw on the sim backend (its simulated camera feeds
the estimator) over udpm on a URL of its own. Robot.go_to() and follow() arrive (the robot's
own estimate within the controller's REACHED tolerance), a refused goal raises GoalFailed with
the reason, a goal no longer kept alive is stopped by the watchdog, velocity commands still
work after a goal, and omni4-goto exits 0 when reached and 1 with one line when refused."""
import math
import os
import subprocess
import sys

import pytest
from test_robot_live import Firmware

import omni4
from omni4.goal import GoalFailed, describe

pytestmark = pytest.mark.live
GOAL_TIMEOUT_S = 30       # failure bound only: the moves below take 1-5 s of robot time


@pytest.fixture(scope="module")
def fw(tmp_path_factory, omni4_bin):
    f = Firmware(omni4_bin("omni4-fw"), tmp_path_factory.mktemp("fw"), duration_s=120)
    with omni4.Robot(f.url) as probe:
        next(probe.motors(timeout_s=10))
        for _ in probe.motors(timeout_s=10, duration_s=1.0):
            pass                  # the first camera poses reach the estimator
    yield f
    f.stop()


def state_near(robot, pose, tol_m):
    """The controller's estimate (OMNI4_STATE) within tol_m of pose."""
    import lcm
    lc = lcm.LCM(robot.url)
    got = []
    sub = lc.subscribe(omni4.CHANNEL_STATE, lambda c, d: got.append(omni4.state_t.decode(d)))
    for _ in range(40):
        lc.handle_timeout(50)
        if got:
            break
    lc.unsubscribe(sub)
    assert got, "no OMNI4_STATE"
    s = got[-1]
    return math.hypot(s.pose[0] - pose[0], s.pose[1] - pose[1]) < tol_m


def test_go_to_and_follow_arrive_and_velocity_still_works(fw):
    with omni4.Robot(fw.url) as robot:
        st = robot.go_to(0.5, 0.3, 1.0, timeout_s=GOAL_TIMEOUT_S)
        assert st.status == omni4.goal_status_t.STATUS_REACHED, describe(st)
        assert st.distance_m < 0.005 and abs(st.angle_rad) < math.radians(0.5)
        assert state_near(robot, (0.5, 0.3), 0.02)
        st = robot.follow([(1.0, 0.3, 0.0), (1.0, 0.8, 0.0), (0.5, 0.8, 0.0)],
                          timeout_s=GOAL_TIMEOUT_S)
        assert st.status == omni4.goal_status_t.STATUS_REACHED and st.index == 2
        robot.velocity(0.3, 0.0, 0.0)
        m = robot.wait_motors(lambda m: m.mode == omni4.motors_t.MODE_VELOCITY, 5,
                              "VELOCITY after a goal")
        assert m.mode == omni4.motors_t.MODE_VELOCITY


def test_refused_goal_raises_with_its_reason(fw):
    with omni4.Robot(fw.url) as robot:
        with pytest.raises(GoalFailed, match="REFUSED: unreachable"):
            robot.go_to(3.0, 0.0, 0.0, speed_max=0.01, timeout_s=GOAL_TIMEOUT_S)
        with pytest.raises(ValueError, match="finite"):
            robot.go_to(float("nan"), 0.0, 0.0)


def test_goal_not_kept_alive_is_stopped_by_the_watchdog(fw):
    with omni4.Robot(fw.url) as robot:
        robot.go_to(2.0, 2.0, 0.0, wait=False)
        robot.wait_motors(lambda m: m.mode == omni4.motors_t.MODE_GOAL, 5, "GOAL mode")
        robot._goal_msg = None    # as if the sender died: no more keep-alive
        m = robot.wait_motors(lambda m: m.mode == omni4.motors_t.MODE_IDLE, 10,
                              "IDLE after the watchdog")
        assert m.faults & omni4.motors_t.FAULT_CMD_TIMEOUT
        st = robot.goal_status
        assert st.status == omni4.goal_status_t.STATUS_ABORTED
        assert st.reason == omni4.goal_status_t.REASON_WATCHDOG


def test_omni4_goto_exit_codes(fw, omni4_bin, tmp_path):
    goto = [os.path.join(os.path.dirname(sys.executable), "omni4-goto")]
    ok = subprocess.run(goto + ["0.2", "0.2", "0.0", "--lcm", fw.url, "-q", "--timeout",
                                str(GOAL_TIMEOUT_S)], capture_output=True, text=True,
                        timeout=GOAL_TIMEOUT_S + 10)
    assert ok.returncode == 0, ok.stderr
    assert "reached" in ok.stderr
    path = tmp_path / "p.csv"
    path.write_text("x,y,theta\n0.4,0.2,0\n0.4,0.4,0.5\n")
    ok = subprocess.run(goto + ["--path", str(path), "--lcm", fw.url, "-q"],
                        capture_output=True, text=True, timeout=GOAL_TIMEOUT_S + 10)
    assert ok.returncode == 0, ok.stderr
    bad = subprocess.run(goto + ["1e4", "0", "0", "--lcm", fw.url], capture_output=True,
                         text=True, timeout=GOAL_TIMEOUT_S)
    assert bad.returncode == 1
    assert bad.stderr.count("\n") == 1 and "REFUSED" in bad.stderr, bad.stderr
    usage = subprocess.run(goto + ["1", "2"], capture_output=True, text=True, timeout=20)
    assert usage.returncode == 2 and "X Y THETA" in usage.stderr
