"""Goals against the real controller: omni4-fw on the sim backend (its simulated camera feeds
the estimator) over udpm on a URL of its own. Robot.go_to() and follow() arrive (the robot's
own estimate within the controller's REACHED tolerance), a refused goal raises GoalFailed with
the reason, a goal no longer kept alive is stopped by the watchdog, velocity commands still
work after a goal, and omni4-goto exits 0 when reached and 1 with one line when refused or
when a second client's goal replaced its own; Ctrl-C (130) and SIGTERM (143) cancel its goal
(ABORTED / CANCELLED, the robot braked) and send no command (no IDLE)."""
import math
import os
import signal
import subprocess
import sys
import threading

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


def test_paths_that_cannot_be_one_plan_are_reached(fw):
    """A turn in place, a pose repeated, 9 and 32 poses (more than one plan takes: docs/goal.md
    "Tracking"): each followed pose by pose to its last, REACHED (once stopped short for good,
    ACTIVE, the motors holding voltage)."""
    nine = [(0.2 + 0.1 * i, 0.1 * (i % 2), 0.1 * i) for i in range(9)]
    spiral = [(0.5 + 0.2 * math.cos(0.2 * i), 0.2 * math.sin(0.2 * i), 0.1 * i) for i in range(32)]
    paths = {"turn in place": [(0.3, 0.0, 0.0), (0.3, 0.0, 1.0), (0.3, 0.2, 1.0)],
             "a pose repeated": [(0.2, 0.2, 0.0), (0.2, 0.2, 0.0), (0.4, 0.3, 0.0)],
             "nine poses": nine, "32 poses": spiral}
    with omni4.Robot(fw.url) as robot:
        for name, path in paths.items():
            st = robot.follow(path, timeout_s=GOAL_TIMEOUT_S)
            assert st.status == omni4.goal_status_t.STATUS_REACHED, f"{name}: {describe(st)}"
            assert st.index == len(path) - 1, f"{name}: {describe(st)}"
            assert state_near(robot, path[-1], 0.02), name


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


class Watch:
    """What the bus carries (a thread): goal_t, goal_status_t and command_t messages."""

    def __init__(self, url):
        import lcm
        self.lc = lcm.LCM(url)
        self.goals, self.statuses, self.commands = [], [], []
        self.lc.subscribe(omni4.CHANNEL_GOAL,
                          lambda c, d: self.goals.append(omni4.goal_t.decode(d)))
        self.lc.subscribe(omni4.CHANNEL_GOAL_STATUS,
                          lambda c, d: self.statuses.append(omni4.goal_status_t.decode(d)))
        self.lc.subscribe(omni4.CHANNEL_CMD,
                          lambda c, d: self.commands.append(omni4.command_t.decode(d)))
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self.done.is_set():
            self.lc.handle_timeout(20)

    def wait(self, predicate, what):
        """Bounded (GOAL_TIMEOUT_S) wait for predicate() to be true."""
        for _ in range(GOAL_TIMEOUT_S * 50):
            if predicate():
                return
            self.done.wait(0.02)
        pytest.fail(f"{what}: not within {GOAL_TIMEOUT_S} s")

    def status_of(self, goal_id, status):
        return [s for s in list(self.statuses) if s.goal_id == goal_id and s.status == status]

    def close(self):
        self.done.set()
        self.thread.join(timeout=2)


def goto_started(fw, watch, pose):
    """omni4-goto to pose, once its goal is ACTIVE: (process, goal id)."""
    goto = [os.path.join(os.path.dirname(sys.executable), "omni4-goto")]
    p = subprocess.Popen(goto + [str(v) for v in pose] + ["--lcm", fw.url, "-q"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    watch.wait(lambda: watch.goals or p.poll() is not None, "omni4-goto's goal_t")
    assert p.poll() is None, p.communicate()
    gid = watch.goals[0].goal_id
    watch.wait(lambda: watch.status_of(gid, omni4.goal_status_t.STATUS_ACTIVE) or
               p.poll() is not None, "omni4-goto's goal ACTIVE")
    assert p.poll() is None, p.communicate()
    return p, gid


@pytest.mark.parametrize("sig, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_omni4_goto_interrupted_cancels_its_goal(fw, sig, status):
    """Ctrl-C (SIGINT) or SIGTERM: ACTION_CANCEL for its goal id, the controller ends it
    ABORTED / CANCELLED and brakes; one line; no command_t (no IDLE) at all."""
    watch = Watch(fw.url)
    p, gid = goto_started(fw, watch, (2.0, -1.0, 0.5))
    try:
        p.send_signal(sig)
        _, err = p.communicate(timeout=GOAL_TIMEOUT_S)
    finally:
        if p.poll() is None:
            p.kill()
        watch.close()
    assert p.returncode == status, err
    assert err == "omni4-goto: cancelled: the robot brakes to rest\n", err
    assert [g.goal_id for g in watch.goals if g.action == omni4.goal_t.ACTION_CANCEL] == [gid]
    st = watch.status_of(gid, omni4.goal_status_t.STATUS_ABORTED)
    assert st and st[0].reason == omni4.goal_status_t.REASON_CANCELLED, describe(st[0])
    assert not watch.commands, [c.mode for c in watch.commands]


def test_omni4_goto_replaced_by_another_clients_goal(fw):
    """A second client's goal replaces omni4-goto's: it says so in one line, exit 1."""
    watch = Watch(fw.url)
    p, gid = goto_started(fw, watch, (0.0, 1.0, 0.0))
    try:
        with omni4.Robot(fw.url) as other:
            other.go_to(1.0, 0.0, 0.0, wait=False)
            _, err = p.communicate(timeout=GOAL_TIMEOUT_S)
            other.cancel_goal()
    finally:
        if p.poll() is None:
            p.kill()
        watch.close()
    assert p.returncode == 1, err
    assert err.count("\n") == 1 and "replaced" in err, err
