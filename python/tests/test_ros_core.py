"""omni4.ros.core, without ROS: the forward kinematics against eq 2, wheel odometry (a straight
line, a circle, torques l Kt i, lost samples), the /cmd_vel gate (NaN and inf refused, limits
clamped, nothing before the limits are known), the state_t fallback (no omni4.state_t in the
package: odometry from the wheels; a state_t-like message: its fields), the diagnostics'
fault names, the URDF's geometry against Table III and docs/kinematics.md, and the goal
statuses on goal_status (a fake node on memq://: refusals, the node's own and the
controller's, published as REFUSED with their reason)."""
import math
import xml.etree.ElementTree as ET

import pytest

import omni4
from omni4.ros import URDF, core

D, R = 0.089, 0.0325


class Sample:
    def __init__(self, utime, seq, wheel_speed, current=(0.0, 0.0, 0.0, 0.0), faults=0, mode=1):
        self.utime, self.seq, self.wheel_speed, self.current = utime, seq, wheel_speed, current
        self.faults, self.mode = faults, mode


@pytest.mark.parametrize("vel", [(0.3, 0.0, 0.0), (0.0, -0.2, 0.0), (0.0, 0.0, 2.0),
                                 (-0.2, 0.1, -1.0)])
def test_forward_kinematics_inverts_eq2(vel):
    w = core.inverse_kinematics(*vel, D, R)
    assert core.forward_kinematics(w, D, R) == pytest.approx(vel, abs=1e-12)


def test_ik_signs_match_docs_kinematics():
    # v > 0: wheel 3 (right) forward, wheel 1 (left) backward; w > 0: every wheel forward.
    w = core.inverse_kinematics(0.3, 0, 0, D, R)
    assert w[3] > 0 and w[1] < 0 and w[0] == w[2] == 0
    assert all(x > 0 for x in core.inverse_kinematics(0, 0, 1.0, D, R))


def _run(odo, vel, seconds, rate=1000, t0=1_000_000_000, seq0=0, current=(0, 0, 0, 0)):
    w = core.inverse_kinematics(*vel, D, R)
    n = int(seconds * rate)
    for k in range(n + 1):
        odo.step(Sample(t0 + k * 1000000 // rate, seq0 + k, w, current))
    return t0 + n * 1000000 // rate, seq0 + n


def test_odometry_straight_line_and_circle():
    odo = core.WheelOdometry()
    _run(odo, (0.3, 0.0, 0.0), 2.0)
    assert (odo.x, odo.y, odo.theta) == pytest.approx((0.6, 0.0, 0.0), abs=1e-9)
    assert odo.wheel_pos[3] == pytest.approx(0.6 / R) and odo.wheel_pos[1] == pytest.approx(-0.6 / R)
    # A full circle: v = 0.2 m/s, w = 1 rad/s for 2 pi s comes back to the start.
    odo = core.WheelOdometry()
    _run(odo, (0.2, 0.0, 1.0), 2 * math.pi)
    assert math.hypot(odo.x, odo.y) < 1e-3 and abs(core.wrap(odo.theta)) < 1e-3
    # The covariance grows with the distance travelled (~1 % of it as std dev).
    assert math.sqrt(odo.pose_covariance()[0]) == pytest.approx(0.01 * 2 * math.pi * 0.2 /
                                                                 math.sqrt(2 * math.pi * 1000),
                                                                 rel=0.05)


def test_odometry_rolls_each_wheel_on_its_own_radius():
    # One odd wheel (1, left) 4 % larger: a straight line along v at 0.3 m/s, each wheel's
    # angular speed its rim speed (eq 2 by hand: wheel 1 -v, wheel 3 +v) over its own radius.
    r1 = 1.04 * R
    ws = (0.0, -0.3 / r1, 0.0, 0.3 / R)
    assert core.forward_kinematics(ws, D, (R, r1, R, R)) == pytest.approx((0.3, 0, 0), abs=1e-12)
    odo = core.WheelOdometry({"model.r_1": r1})
    assert odo.radii() == (R, r1, R, R)
    for k in range(2001):
        odo.step(Sample(1_000_000_000 + k * 1000, k, ws))
    assert (odo.x, odo.y, odo.theta) == pytest.approx((0.6, 0.0, 0.0), abs=1e-9)
    # The same readings on four equal wheels: wheel 1 reads 4 % slow, the robot seems to turn.
    flat = core.WheelOdometry()
    for k in range(2001):
        flat.step(Sample(1_000_000_000 + k * 1000, k, ws))
    assert abs(flat.theta) > 0.05


def test_odometry_effort_and_lost_samples():
    odo = core.WheelOdometry({"model.l": 5.0, "model.Kt": 0.0259})
    t, s = _run(odo, (0.3, 0, 0), 0.1, current=(1.0, -2.0, 0.5, 0.0))
    assert odo.effort == pytest.approx([5 * 0.0259, -2 * 5 * 0.0259, 0.5 * 5 * 0.0259, 0.0])
    odo.step(Sample(t + 5000, s + 5, core.inverse_kinematics(0.3, 0, 0, D, R)))
    assert odo.lost == 4
    x = odo.x
    odo.step(Sample(t + 5000 + 10 ** 6, s + 6, core.inverse_kinematics(0.3, 0, 0, D, R)))
    assert odo.x == x and odo.gaps == 1, "a gap > 0.1 s restarts the clock"
    assert not odo.step(Sample(t + 10 ** 7, s + 7, (float("nan"), 0, 0, 0)))


def test_gate_refuses_nonfinite_and_clamps():
    g = core.CmdGate()
    assert g.check(0.1, 0, 0) == (None, "refused: the controller's [limits] are not known yet")
    g.limits.update({"limits.vel_lin_max": 3.0, "limits.vel_rot_max": 20.0})
    for bad in ((float("nan"), 0, 0), (0, float("inf"), 0), (0, 0, float("-inf"))):
        cmd, why = g.check(*bad)
        assert cmd is None and "not finite" in why
    assert g.refused_nonfinite == 3
    assert g.check(0.3, -0.1, 1.0) == ((0.3, -0.1, 1.0), None)
    cmd, why = g.check(100.0, -5.0, 30.0)
    assert cmd == (3.0, -3.0, 20.0) and "clamped" in why and g.clamped == 1
    assert g.accepted == 2 and g.received == 6


def test_each_refusal_and_each_clamp_is_said_once_a_second_per_kind():
    """A NaN stream at 50 Hz and a 50 m/s /cmd_vel clamped to 3 m/s in between: each kind is
    said at its first occurrence and again once its own second has passed (an injected clock),
    with the count of those held back; a NaN said never silences a clamp."""
    now = [100.0]
    g = core.CmdGate(clock=lambda: now[0])
    cmd, line = g.take(0.1, 0, 0)
    assert cmd is None and line == "refused: the controller's [limits] are not known yet"
    g.limits.update({"limits.vel_lin_max": 3.0, "limits.vel_rot_max": 20.0})
    said = []
    for k in range(100):                       # 2 s at 50 Hz: NaN, NaN, ..., and a clamp at 0.01 s
        now[0] = 100.0 + k * 0.02
        cmd, line = g.take(float("nan"), 0, 0)
        assert cmd is None
        said.append((round(now[0] - 100.0, 3), line))
        if k in (0, 10, 49, 50, 60):
            now[0] += 0.01
            cmd, line = g.take(50.0, 0, 0)
            assert cmd == (3.0, 0.0, 0.0)
            said.append((round(now[0] - 100.0, 3), line))
    lines = [(t, ln) for t, ln in said if ln]
    assert lines == [
        (0.0, "refused: /cmd_vel not finite (v nan, vn 0.0, w 0.0)"),
        (0.01, "clamped: /cmd_vel (50, 0, 0) to [limits] vel_lin_max 3 m/s, vel_rot_max 20 rad/s"),
        (1.0, "refused: /cmd_vel not finite (v nan, vn 0.0, w 0.0) (and 49 more like it since "
              "the last)"),
        (1.01, "clamped: /cmd_vel (50, 0, 0) to [limits] vel_lin_max 3 m/s, vel_rot_max 20 rad/s"
               " (and 2 more like it since the last)"),
    ]
    assert g.refused_nonfinite == 100 and g.clamped == 5 and g.refused_no_limits == 1


def test_throttle_keeps_a_clock_per_kind():
    now = [0.0]
    t = core.Throttle(1.0, clock=lambda: now[0])
    assert t.say("a", "x") == "x" and t.say("b", "y") == "y"
    now[0] = 0.999
    assert t.say("a", "x") is None and t.say("b", "y") is None
    now[0] = 1.0
    assert t.say("a", "x") == "x (and 1 more like it since the last)"
    assert t.say("a", "x") is None
    assert t.say("b", "y") == "y (and 1 more like it since the last)"


def test_state_fallback_when_the_package_has_no_state_t(monkeypatch):
    monkeypatch.delattr(omni4, "state_t", raising=False)
    import sys
    monkeypatch.setitem(sys.modules, "omni4.state_t", None)   # import of it fails
    assert core.state_type() == (None, None)


def test_state_t_with_est_output_fields():
    class FakeState:
        utime = 123
        pose = (1.0, 2.0, 0.5)
        vel = (0.3, 0.0, 0.1)
        cov = (1e-4, 2e-4, 3e-4, 4e-4, 5e-4, 6e-4)

    monkey = type("M", (), {"state_t": FakeState, "CHANNEL_STATE": "OMNI4_STATE"})
    st = core.StateEstimate()
    assert st.take(FakeState())
    assert (st.x, st.y, st.theta, st.vel) == (1.0, 2.0, 0.5, (0.3, 0.0, 0.1))
    assert st.pose_covariance()[0] == 1e-4 and st.pose_covariance()[35] == 3e-4
    assert st.twist_covariance()[35] == 6e-4
    bad = FakeState()
    bad.pose = (float("nan"), 0, 0)
    assert not st.take(bad) and st.x == 1.0
    assert monkey.CHANNEL_STATE == "OMNI4_STATE"


def test_diagnostics_name_faults_and_levels():
    w = core.MotorsWindow()
    g = core.CmdGate()
    w.take(Sample(0, 1, (0, 0, 0, 0), faults=0, mode=0))
    w.take(Sample(1000, 3, (0, 0, 0, 0), faults=omni4.motors_t.FAULT_CMD_REJECTED, mode=0))
    rows = core.diagnostic_statuses(w, g, {}, {"model.d": "0.089"}, "wheels")
    level, name, msg, values = rows[0]
    assert name == "omni4: controller" and level == 1 and "CMD_REJECTED" in msg
    assert dict(values)["lost samples"] == "1" and w.rejected_edges == 1
    w.reset()
    w.take(Sample(2000, 4, (0, 0, 0, 0), faults=omni4.motors_t.FAULT_OVERCURRENT,
                  mode=omni4.motors_t.MODE_FAULT))
    rows = core.diagnostic_statuses(w, g, {}, {}, "wheels")
    assert rows[0][0] == 2 and "OVERCURRENT" in rows[0][2] and "mode FAULT" in rows[0][2]
    assert rows[2][0] == 1, "an unknown model is a warning"


def _adapt(R, flags, estimate=None):
    a = omni4.adapt_t()
    a.utime, a.seq, a.R = 1_000_000, 1000, list(R)
    a.R_estimate = list(estimate or R)
    a.R_variance = [1e-6] * 4
    a.supply_v, a.Cv, a.Cvn, a.Cw, a.track_rms, a.flags = 12.0, 1.8738, 2.2198, 0.1385, 0.0, flags
    return a


def _changed(source, event, old, new):
    m = omni4.param_changed_t()
    m.utime, m.seq, m.request_id, m.source, m.path = 5, 4321, 0, source, ""
    m.keys = [f"adapt.R_{j}" for j in range(4)] + ["adapt.event"]
    m.old_values = [f"{x:.6f}" for x in old] + [""]
    m.values = [f"{x:.6f}" for x in new] + [event]
    m.n = len(m.keys)
    return m


def test_adapt_diagnostics_levels_values_and_last_event():
    """"omni4: adapt": STALE without an adapt_t in the period; OK with acceptances; WARN when a
    REVERTED or RESTART flag was in any of the period's reports (also one before the last);
    each R in use against the identified R_j (wheel 2 its own 4.5 ohm, the others the scalar
    4.0: R in use 4.4 is +10 %, 4.5 on wheel 2 is 0 %), the last acceptance or revert."""
    w, g = core.MotorsWindow(), core.CmdGate()
    w.take(Sample(0, 1, (0, 0, 0, 0), mode=0))
    model = {"model.R": "4.0", "model.R_2": "4.5"}
    ad = core.AdaptWindow()
    rows = core.diagnostic_statuses(w, g, {}, model, "wheels", adapt=ad)
    assert rows[-1][:2] == (3, "omni4: adapt")
    assert core.diagnostic_statuses(w, g, {}, model, "wheels")[-1][1] == "omni4: odometry"
    F = omni4.adapt_t
    assert not ad.events.take(_changed("set", "accepted", [4.0] * 4, [4.4] * 4))
    assert ad.events.take(_changed("adapt", "accepted", [4.0, 4.0, 4.5, 4.0],
                                   [4.4, 4.4, 4.5, 4.4]))
    ad.take(_adapt([4.4, 4.4, 4.5, 4.4], F.FLAG_ON | F.FLAG_ADAPTED | F.FLAG_ACCEPTED))
    level, name, msg, values = core.diagnostic_statuses(w, g, {}, model, "wheels", adapt=ad)[-1]
    kv = dict(values)
    assert (level, name) == (0, "omni4: adapt") and "adapted" in msg
    assert [float(kv[f"R_{j} vs identified [%]"]) for j in range(4)] == \
        pytest.approx([10.0, 10.0, 0.0, 10.0], abs=1e-9)
    assert float(kv["R_1 in use [ohm]"]) == 4.4 and kv["flags"] == "ON ADAPTED ACCEPTED"
    assert kv["last event"] == ("accepted at tick 4321: R_0 4.0000 -> 4.4000, "
                                "R_1 4.0000 -> 4.4000, R_3 4.0000 -> 4.4000 ohm")
    for bad in (F.FLAG_REVERTED, F.FLAG_RESTART):
        ad.reset()
        ad.take(_adapt([4.0, 4.0, 4.5, 4.0], F.FLAG_ON | bad))
        ad.take(_adapt([4.0, 4.0, 4.5, 4.0], F.FLAG_ON))      # the last one without it
        level, _, msg, values = core.diagnostic_statuses(w, g, {}, model, "wheels",
                                                         adapt=ad)[-1]
        word = "REVERTED" if bad == F.FLAG_REVERTED else "RESTART"
        assert level == 1 and word in msg and word in dict(values)["flags"]
    ad.reset()
    assert core.diagnostic_statuses(w, g, {}, model, "wheels", adapt=ad)[-1][0] == 3
    assert core.diagnostic_statuses(w, g, {}, {}, "wheels", adapt=ad)[-1][0] == 3
    ad.take(_adapt([4.4] * 4, F.FLAG_ON))
    kv = dict(core.diagnostic_statuses(w, g, {}, {}, "wheels", adapt=ad)[-1][3])
    assert kv["R_0 vs identified [%]"] == "unknown"       # the [model] not read yet


def test_adapt_flag_names_follow_the_type():
    F = omni4.adapt_t
    from omni4 import adapt
    assert adapt.flag_names(F.FLAG_ON | F.FLAG_WATCH | F.FLAG_RESTART | 0x400) == \
        ["ON", "WATCH", "RESTART", "UNKNOWN_0x400"]
    assert [n for _, n in adapt.FLAGS] == ["ON", "FED", "FROZEN", "ADAPTED", "WATCH",
                                          "ACCEPTED", "REVERTED", "RESTART"]


def test_urdf_has_the_four_wheels_of_table_iii():
    root = ET.parse(URDF).getroot()
    joints = {j.get("name"): j for j in root.iter("joint")}
    assert sorted(joints) == sorted(core.JOINT_NAMES)
    for j, name in enumerate(core.JOINT_NAMES):
        x, y, z = (float(a) for a in joints[name].find("origin").get("xyz").split())
        a = math.pi / 2 * j
        assert (x, y, z) == pytest.approx((D * math.cos(a), D * math.sin(a), R), abs=1e-6)
        assert joints[name].get("type") == "continuous"
        assert joints[name].find("axis").get("xyz") == "1 0 0"
        assert float(joints[name].find("origin").get("rpy").split()[2]) == pytest.approx(a, abs=1e-6)
    radii = {float(c.get("radius")) for c in root.iter("cylinder")}
    assert R in radii


# ---- the two commands as a shell runs them (as test_cli.py checks the others) --------------

def _tool(name):
    import os
    import sys
    p = os.path.join(os.path.dirname(sys.executable), name)
    assert os.access(p, os.X_OK), f"{p}: not installed (pip install './python[ros]')"
    return p


@pytest.mark.parametrize("name", ["omni4-ros", "omni4-rosbag"])
def test_version_help_and_closed_stdout(name):
    import os
    import subprocess
    r = subprocess.run([_tool(name), "--version"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0 and r.stdout.startswith(f"{name} {omni4.__version__}"), r
    rd, wr = os.pipe()
    os.close(rd)
    try:
        r = subprocess.run([_tool(name), "--help"], stdout=wr, stderr=subprocess.PIPE, text=True,
                           timeout=30)
    finally:
        os.close(wr)
    assert r.returncode == 141 and r.stderr == "", r.stderr


@pytest.mark.parametrize("argv, status, words", [
    (["omni4-ros", "--rate", "0"], 2, "--rate must be in"),
    (["omni4-ros", "--fresh", "100"], 2, "--fresh must be in"),
    (["omni4-ros", "--bogus"], 2, "unrecognized arguments"),
    (["omni4-rosbag", "x.lcmlog"], 2, "--out"),
    (["omni4-rosbag", "/nonexistent/x.lcmlog", "--out", "/tmp/omni4-rosbag-never"], 1,
     "/nonexistent/x.lcmlog"),
])
def test_errors_are_one_line(argv, status, words):
    import subprocess
    r = subprocess.run([_tool(argv[0]), *argv[1:]], capture_output=True, text=True, timeout=30)
    assert r.returncode == status, r
    assert r.stderr.count("\n") == 1 and words in r.stderr and "Traceback" not in r.stderr, \
        r.stderr


# ---- goal statuses (omni4.ros.goals.GoalBridge, with a fake node on memq://) -------------------
class FakeNode:
    """What GoalBridge asks of its node: publishers that keep what they get, subscriptions
    whose callbacks a test calls."""

    def __init__(self):
        self.published, self.subs = {}, {}

    def create_publisher(self, _type, topic, _depth):
        got = self.published.setdefault(topic, [])
        return type("Pub", (), {"publish": lambda self, m: got.append(m)})()

    def create_subscription(self, _type, topic, callback, _depth):
        self.subs[topic] = callback


class FakeOwner:
    """An Omni4Ros as GoalBridge sees it, on memq:// with its receive thread."""

    def __init__(self):
        import threading
        import lcm
        self.lc, self.url = lcm.LCM("memq://"), "memq://"
        self._closed, self._lock = threading.Event(), threading.Lock()
        self.node, self.frame_odom, self._diag_prefix = FakeNode(), "odom", "omni4_ros"
        self._cmd = self._stopping_since = None
        self.warnings = []
        self.log = type("Log", (), {"warn": lambda s, t: self.warnings.append(t),
                                    "info": lambda s, t: None})()
        self.rx = threading.Thread(target=self._rx, daemon=True)
        self.rx.start()

    def _rx(self):
        while not self._closed.is_set():
            self.lc.handle_timeout(20)

    def close(self):
        self._closed.set()
        self.rx.join(2)


@pytest.fixture
def bridge():
    from omni4.ros.goals import GoalBridge       # the ros extra (scripts/setup.sh installs it)
    owner = FakeOwner()
    b = GoalBridge(owner, 0.05)
    yield owner, b
    owner._closed.set()                          # as the node closes: its threads end first
    b.close()
    owner.close()


def pose_stamped(x, y, frame="odom"):
    from geometry_msgs.msg import PoseStamped
    m = PoseStamped()
    m.header.frame_id = frame
    m.pose.position.x, m.pose.position.y, m.pose.orientation.w = x, y, 1.0
    return m


def values(st):
    return {kv.key: kv.value for kv in st.values}


def published(owner, n=1):
    """The goal_status messages, once n have come (bounded wait)."""
    import time
    got = owner.node.published["goal_status"]
    end = time.monotonic() + 10
    while len(got) < n and time.monotonic() < end:
        time.sleep(0.01)
    return got


@pytest.mark.parametrize("msg, reason, words", [
    (lambda: pose_stamped(math.nan, 0.0), omni4.goal_status_t.REASON_NOT_FINITE, "finite"),
    (lambda: pose_stamped(0.5, 0.0, "base_link"), None, "frame 'base_link'"),
])
def test_goal_pose_refused_before_sending_is_published_refused(bridge, msg, reason, words):
    """A /goal_pose the node refuses itself (not finite, a frame not its odom frame) is on
    goal_status as REFUSED with its reason, as the controller's refusals are; nothing sent."""
    from omni4.goal import REASONS
    owner, b = bridge
    sent = []
    owner.lc.subscribe(omni4.CHANNEL_GOAL, lambda c, d: sent.append(d))
    owner.node.subs["goal_pose"](msg())
    got = published(owner)
    assert len(got) == 1
    v = values(got[0])
    assert v["status"] == "REFUSED" and got[0].level == bytes([1]), v
    assert words in got[0].message and words in v["reason"], (got[0].message, v)
    if reason is not None:
        assert REASONS[reason] in v["reason"]
    assert not sent


def test_goal_refused_by_the_controller_is_published_refused(bridge):
    owner, b = bridge
    owner.node.subs["goal_pose"](pose_stamped(0.5, 0.0))
    st = omni4.goal_status_t()
    st.goal_id, st.status = b._goal_id, omni4.goal_status_t.STATUS_REFUSED
    st.reason = omni4.goal_status_t.REASON_UNREACHABLE
    owner.lc.publish(omni4.CHANNEL_GOAL_STATUS, st.encode())
    got = published(owner)
    assert len(got) == 1 and values(got[0])["status"] == "REFUSED"
    assert "unreachable" in values(got[0])["reason"]


def test_goal_replaced_by_another_clients_goal_is_published_and_no_longer_kept_alive(bridge):
    """Once the node's goal is ACTIVE, statuses of another goal id in force (a second client's
    goal took over): goal_status says ABORTED, replaced, naming it, and the node stops keeping
    its goal alive (a keep-alive would start it again)."""
    owner, b = bridge
    owner.node.subs["goal_pose"](pose_stamped(0.5, 0.0))
    ours = b._goal_id
    for seq, gid in ((1, ours), (2, 77), (3, 77)):
        st = omni4.goal_status_t()
        st.seq, st.goal_id, st.distance_m = seq, gid, 1.0
        st.status = omni4.goal_status_t.STATUS_ACTIVE
        owner.lc.publish(omni4.CHANNEL_GOAL_STATUS, st.encode())
    got = published(owner, 2)
    assert len(got) == 2, [g.message for g in got]
    v = values(got[1])
    assert v["status"] == "ABORTED" and v["goal_id"] == str(ours), v
    assert "goal 77" in got[1].message and "replaced" in got[1].message, got[1].message
    assert b._goal_msg is None


# ---- another layout: three wheels (robot_t on OMNI4_ROBOT) ----
THREE_DEG = (0.0, 120.0, 240.0)
THREE_D, THREE_R = 0.1, 0.03


def _robot_t(angles_deg, d=THREE_D, r=THREE_R):
    m = omni4.robot_t()
    n = len(angles_deg)
    m.wheels = n
    m.wheel_angle = [math.radians(a) for a in angles_deg] + [0.0] * (4 - n)
    m.wheel_distance = [d] * n + [0.0] * (4 - n)
    m.wheel_radius = [r] * n + [0.0] * (4 - n)
    m.l = 5.0
    return m


def _three_wheel_speeds(v, vn, w):
    """Eq 2 by hand for wheels at 0/120/240 deg: rim_j = -sin(a_j) v + cos(a_j) vn + d w, over
    r; the fourth slot 0."""
    s3 = math.sqrt(3.0) / 2.0
    rims = (vn + THREE_D * w, -s3 * v - 0.5 * vn + THREE_D * w, s3 * v - 0.5 * vn + THREE_D * w)
    return tuple(x / THREE_R for x in rims) + (0.0,)


@pytest.mark.parametrize("vel", [(0.3, 0.0, 0.0), (0.0, -0.2, 0.0), (0.0, 0.0, 2.0),
                                 (-0.2, 0.1, -1.0)])
def test_three_wheel_odometry_inverts_eq2_and_names_three_joints(vel):
    from omni4.wheels import Wheels
    wheels, why = Wheels.from_robot(_robot_t(THREE_DEG))
    assert why is None and wheels.count == 3
    assert wheels.joint_names() == ("wheel_0_joint", "wheel_1_joint", "wheel_2_joint")
    odo = core.WheelOdometry()
    odo.set_wheels(wheels)
    ws = _three_wheel_speeds(*vel)
    for k in range(1001):          # 1 s at 1 kHz
        odo.step(Sample(1_000_000_000 + k * 1000, k, ws, current=(1.0, 2.0, 3.0, 0.0)))
    assert odo.vel == pytest.approx(vel, abs=1e-12)
    assert odo.joint_names() == wheels.joint_names()
    assert len(odo.wheel_pos) == len(odo.wheel_vel) == len(odo.effort) == 3
    assert odo.wheel_pos == pytest.approx([w * 1.0 for w in ws[:3]], rel=1e-9)
    assert odo.effort == pytest.approx([core.TABLE_III["model.l"] * core.TABLE_III["model.Kt"] * i
                                        for i in (1.0, 2.0, 3.0)])
    # Closed form of the symmetric three-wheel layout (the rows' sum of a_j^T a_j is
    # diag(3/2, 3/2, 3 d^2)): v = -(2/3) sum sin(a_j) rim_j, w = sum rim_j / (3 d).
    rims = [w * THREE_R for w in ws[:3]]
    a = [math.radians(x) for x in THREE_DEG]
    want = (-2 / 3 * sum(math.sin(aj) * u for aj, u in zip(a, rims)),
            2 / 3 * sum(math.cos(aj) * u for aj, u in zip(a, rims)), sum(rims) / (3 * THREE_D))
    assert odo.vel == pytest.approx(want, abs=1e-12)
    if vel == (0.3, 0.0, 0.0):
        assert (odo.x, odo.y, odo.theta) == pytest.approx((0.3, 0.0, 0.0), abs=1e-9)


def test_paper_layout_keeps_its_joint_names_and_odometry():
    from omni4.wheels import Wheels
    odo = core.WheelOdometry()
    assert odo.joint_names() == ("wheel_0_front_joint", "wheel_1_left_joint",
                                 "wheel_2_rear_joint", "wheel_3_right_joint")
    # The paper's layout described by a robot_t: the same names and the same velocity.
    wheels, _ = Wheels.from_robot(_robot_t((0.0, 90.0, 180.0, 270.0), d=D, r=R))
    described = core.WheelOdometry()
    described.set_wheels(wheels)
    assert described.joint_names() == odo.joint_names()
    _run(odo, (-0.2, 0.1, -1.0), 0.5)
    _run(described, (-0.2, 0.1, -1.0), 0.5)
    assert described.vel == pytest.approx(odo.vel, abs=1e-12)
    assert len(described.wheel_pos) == 4


@pytest.mark.parametrize("wheels, angle, why", [(5, 0.0, "5 wheels"), (3, math.nan, "not finite")])
def test_a_robot_t_that_describes_no_robot_is_refused_with_a_reason(wheels, angle, why):
    from omni4.wheels import Wheels
    m = _robot_t(THREE_DEG)
    m.wheels = wheels
    m.wheel_angle = [angle] + list(m.wheel_angle[1:])
    got, reason = Wheels.from_robot(m)
    assert got is None and why in reason
    odo = core.WheelOdometry()
    odo.set_wheels(got)           # nothing to take: the paper's four stay
    assert len(odo.joint_names()) == 4


def _write_log(path, robots, n=300):
    """An LCM event log: the robot_t messages (list of (index, robot_t): written before motors
    sample index), then n motors_t at 1 kHz driving (0.3, 0, 0) on three wheels."""
    import lcm
    log = lcm.EventLog(str(path), "w", overwrite=True)
    ws = _three_wheel_speeds(0.3, 0.0, 0.0)
    t0 = 1_700_000_000_000_000
    for k in range(n):
        for at, r in robots:
            if at == k:
                r.utime = t0 + k * 1000
                log.write_event(t0 + k * 1000, omni4.CHANNEL_ROBOT, r.encode())
        m = omni4.motors_t()
        m.utime, m.seq, m.mode = t0 + k * 1000, k, 1
        m.wheel_speed = list(ws)
        log.write_event(t0 + k * 1000 + 50, omni4.CHANNEL_MOTORS, m.encode())
    log.close()


def _bag_joint_states(out):
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore
    ts = get_typestore(Stores.ROS2_HUMBLE)
    with Reader(out) as bag:
        return [ts.deserialize_cdr(raw, c.msgtype) for c, _t, raw in bag.messages()
                if c.topic == "/joint_states"]


def test_bag_of_a_three_wheel_log_has_three_joints_and_a_paper_log_four(tmp_path):
    from omni4.ros import bag
    three = tmp_path / "three.lcmlog"
    _write_log(three, [(0, _robot_t(THREE_DEG))])
    bag.convert([str(three)], str(tmp_path / "three.bag"))
    js = _bag_joint_states(tmp_path / "three.bag")
    assert len(js) == 300
    assert all(list(m.name) == ["wheel_0_joint", "wheel_1_joint", "wheel_2_joint"] for m in js)
    assert list(js[-1].velocity) == pytest.approx(_three_wheel_speeds(0.3, 0.0, 0.0)[:3])
    # A log without robot_t: the paper's four, named as always.
    paper = tmp_path / "paper.lcmlog"
    _write_log(paper, [])
    bag.convert([str(paper)], str(tmp_path / "paper.bag"))
    js = _bag_joint_states(tmp_path / "paper.bag")
    assert list(js[0].name) == list(core.JOINT_NAMES) and len(js[0].velocity) == 4


def test_bag_takes_the_first_robot_t_even_after_motors_and_a_change_mid_log(tmp_path):
    from omni4.ros import bag
    path = tmp_path / "late.lcmlog"
    # robot_t after the first 5 samples (the logger's order of one tick), then the paper's four
    # from sample 200 on.
    _write_log(path, [(5, _robot_t(THREE_DEG)), (200, _robot_t((0.0, 90.0, 180.0, 270.0), D, R))])
    bag.convert([str(path)], str(tmp_path / "late.bag"))
    names = [len(m.name) for m in _bag_joint_states(tmp_path / "late.bag")]
    assert names == [3] * 200 + [4] * 100


def test_bag_of_a_log_without_robot_t_takes_the_layout_of_params(tmp_path):
    from omni4.ros import bag
    path = tmp_path / "old.lcmlog"
    _write_log(path, [])
    ini = tmp_path / "three.ini"
    ini.write_text("[model]\nwheels = 3\nwheel_angle_0 = 0\nwheel_angle_1 = 120\n"
                   "wheel_angle_2 = 240\nd = 0.1\nr = 0.03\n")
    bag.convert([str(path)], str(tmp_path / "p.bag"), params_path=str(ini))
    js = _bag_joint_states(tmp_path / "p.bag")
    assert list(js[-1].name) == ["wheel_0_joint", "wheel_1_joint", "wheel_2_joint"]
    ini.write_text("[model]\nwheels = 5\n")
    assert bag.main([str(path), "--out", str(tmp_path / "bad.bag"), "--params", str(ini),
                     "-q"]) == 2
    assert not (tmp_path / "bad.bag").exists()


def test_four_wheels_off_the_papers_distances_are_named_by_number():
    """The paper's names say where its wheels are; four wheels at its angles but one at another
    distance are not its robot: wheel_0_joint .. wheel_3_joint."""
    from omni4.wheels import Wheels
    m = _robot_t((0.0, 90.0, 180.0, 270.0), d=D, r=R)
    m.wheel_distance = [D, 0.1, D, D]
    wheels, _ = Wheels.from_robot(m)
    assert wheels.joint_names() == tuple(f"wheel_{j}_joint" for j in range(4))
    assert wheels.positions()[1] == pytest.approx((0.0, 0.1), abs=1e-12)


@pytest.mark.parametrize("angles", [(0.0, 120.0, 240.0), (60.0, 180.0, 300.0)])
def test_urdf_of_a_three_wheel_robot_has_three_joints_at_its_wheels(angles):
    from omni4.ros.urdf import urdf
    from omni4.wheels import Wheels
    wheels, _ = Wheels.from_robot(_robot_t(angles))
    root = ET.fromstring(urdf(wheels))
    joints = list(root.iter("joint"))
    assert [j.get("name") for j in joints] == ["wheel_0_joint", "wheel_1_joint", "wheel_2_joint"]
    for j, deg in zip(joints, angles):
        a = math.radians(deg)
        xyz = [float(v) for v in j.find("origin").get("xyz").split()]
        assert xyz == pytest.approx([THREE_D * math.cos(a), THREE_D * math.sin(a), THREE_R],
                                    abs=1e-6)
        yaw = float(j.find("origin").get("rpy").split()[2])
        assert (math.cos(yaw), math.sin(yaw)) == pytest.approx((math.cos(a), math.sin(a)), abs=1e-6)
        assert j.get("type") == "continuous" and j.find("axis").get("xyz") == "1 0 0"
        assert root.find(f"link[@name='{j.find('child').get('link')}']") is not None


def test_urdf_of_the_papers_layout_has_the_shipped_joints():
    from omni4.ros.urdf import urdf
    shipped = {j.get("name"): j for j in ET.parse(URDF).getroot().iter("joint")}
    made = {j.get("name"): j for j in ET.fromstring(urdf()).iter("joint")}
    assert sorted(made) == sorted(shipped)
    for name, j in made.items():
        for attr in ("xyz", "rpy"):
            got = [float(v) for v in j.find("origin").get(attr).split()]
            want = [float(v) for v in shipped[name].find("origin").get(attr).split()]
            assert got == pytest.approx(want, abs=1e-6), (name, attr)
        assert j.find("child").get("link") == shipped[name].find("child").get("link")
