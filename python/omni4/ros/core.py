"""What omni4-ros and omni4-rosbag compute, without ROS: the wheels' forward kinematics and
odometry, the /cmd_vel gate (finite, clamped to the controller's limits, fresh), the state
estimate's adapter, and the diagnostics' contents. Plain Python, so it is tested (and used by
the bag writer) without rclpy.

Signs and numbering: docs/kinematics.md. Robot frame (base_link): x = v forward, y = vn to the
left, z up (REP 103). Wheel j sits at 90*j degrees from the v axis: 0 front, 1 left, 2 rear,
3 right; its positive rim speed points counter-clockwise. A robot that describes another
layout (robot_t on OMNI4_ROBOT: three wheels, other angles or distances) has its own wheels
(omni4.wheels.Wheels): their joints are wheel_0_joint .. wheel_{n-1}_joint."""
import math
import time

from .. import adapt as adapt_words
from .. import motors_t
from ..wheels import PAPER_JOINT_NAMES

JOINT_NAMES = PAPER_JOINT_NAMES
# Table III of the paper (docs/ini-keys.md defaults): used until the robot's own are read.
TABLE_III = {"model.d": 0.089, "model.r": 0.0325, "model.l": 5.0, "model.Kt": 0.0259}
# Each wheel's own radius ([model] r_0 .. r_3, docs/configuration.md "Per-wheel drives"): a
# wheel without its key rolls on model.r.
WHEEL_RADIUS_KEYS = tuple(f"model.r_{j}" for j in range(4))
GEOMETRY_KEYS = tuple(TABLE_III) + WHEEL_RADIUS_KEYS
LIMIT_KEYS = ("limits.vel_lin_max", "limits.vel_rot_max")

# The mode and fault names, the latching bits, the fault states: core's vocab.def (every tool's).
from .._vocab import (FAULT_BITS, FAULTED_MODES, FAULTS, LATCHING, MODE_NAMES,  # noqa: E402,F401
                      fault_names, mode_name)

# The reported bits that are neither latching nor the e-stop's.
WARNINGS = sum(FAULTS.values()) & ~LATCHING & ~motors_t.FAULT_ESTOP

# Odometry noise model (docs/ros.md, "Covariances"): the sim's and the paper's encoders give
# 0.13-0.16 rad/s of noise per 1 kHz wheel-speed sample; wheels slip ~1 % of the distance.
WHEEL_SPEED_SIGMA = 0.15      # [rad/s] per sample
SLIP_FRACTION = 0.01          # pose std dev grows by this fraction of the distance travelled
SLIP_ROT_FRACTION = 0.02      # heading std dev grows by this fraction of the angle turned
                              # (plus the linear slip over d)


def _radii(r):
    """r: one radius for the four wheels, or each wheel's own (four)."""
    return tuple(float(x) for x in r) if hasattr(r, "__len__") else (float(r),) * 4


def forward_kinematics(wheel_rad_s, d, r):
    """Eqs 3-5: (v, vn, w) [m/s, m/s, rad/s] from the four wheel angular speeds [rad/s], each
    wheel's rim speed with its radius (r: one, or four)."""
    v0, v1, v2, v3 = (rj * w for rj, w in zip(_radii(r), wheel_rad_s))
    return (v3 - v1) / 2.0, (v0 - v2) / 2.0, (v0 + v1 + v2 + v3) / (4.0 * d)


def inverse_kinematics(v, vn, w, d, r):
    """Eq 2: the four wheel angular speeds [rad/s] of a robot velocity (r: one, or four)."""
    rims = (vn + d * w, -v + d * w, -vn + d * w, v + d * w)
    return tuple(x / rj for x, rj in zip(rims, _radii(r)))


def yaw_quaternion(theta):
    """(x, y, z, w) of a rotation by theta about z."""
    return 0.0, 0.0, math.sin(theta / 2.0), math.cos(theta / 2.0)


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


class WheelOdometry:
    """Integrates motors_t samples: pose (x, y, theta) in odom, velocity in base_link, wheel
    positions [rad], wheel torques [N m] (l Kt i), and a diagonal covariance.

    The pose integrates eq 1 with the mid-interval heading over each sample's dt (the
    controller's utime); a first sample, a dt <= 0 or a gap longer than max_dt_s only restarts
    the clock (the gap's motion is lost, and counted in `gaps`)."""

    def __init__(self, geometry=None, max_dt_s=0.1):
        self.geometry = dict(TABLE_III)
        if geometry:
            self.geometry.update(geometry)
        self.max_dt_s = max_dt_s
        self.x = self.y = self.theta = 0.0
        self.vel = (0.0, 0.0, 0.0)
        self.wheel_pos = [0.0] * 4
        self.wheel_vel = [0.0] * 4
        self.effort = [0.0] * 4
        self.var_xy = 0.0
        self.var_theta = 0.0
        self.samples = 0
        self.gaps = 0
        self.last_utime = None
        self.last_seq = None
        self.lost = 0            # seq gaps: samples the controller sent that never came
        self.wheels = None       # omni4.wheels.Wheels of a robot_t; None: the paper's four
        self._paper = True       # the wheels sit on the paper's axes (eqs 3-5 apply)

    def set_wheels(self, wheels):
        """The robot's own layout (a Wheels from its robot_t): from the next sample on, its
        wheels' count, positions and radii. Another count restarts the wheel positions."""
        if wheels is None or wheels.same(self.wheels):
            return
        if len(self.wheel_pos) != wheels.count:
            self.wheel_pos = [0.0] * wheels.count
            self.wheel_vel = [0.0] * wheels.count
            self.effort = [0.0] * wheels.count
        self.wheels = wheels
        self._paper = wheels.is_paper_geometry()

    def joint_names(self):
        return JOINT_NAMES if self.wheels is None else self.wheels.joint_names()

    def set_geometry(self, **kv):
        for k, v in kv.items():
            self.geometry[k] = float(v)

    def radii(self):
        """Each wheel's radius in force: its own key, else model.r."""
        r = self.geometry["model.r"]
        return tuple(self.geometry.get(k, r) for k in WHEEL_RADIUS_KEYS)

    def step(self, m):
        """One motors_t (or anything with utime, seq, wheel_speed, current)."""
        d, r = self.geometry["model.d"], self.radii()
        torque_per_a = self.geometry["model.l"] * self.geometry["model.Kt"]
        n = 4 if self.wheels is None else self.wheels.count
        ws = [float(w) for w in m.wheel_speed][:n]
        if not all(math.isfinite(w) for w in ws):
            return False
        if self.last_seq is not None and m.seq > self.last_seq + 1:
            self.lost += m.seq - self.last_seq - 1
        self.last_seq = m.seq
        dt = None if self.last_utime is None else (m.utime - self.last_utime) * 1e-6
        self.last_utime = m.utime
        if self.wheels is None or self._paper:   # the paper's axes: eqs 3-5 as always
            v, vn, w = forward_kinematics(ws, d, r)
        else:
            v, vn, w = self.wheels.forward(ws)
            d = min(self.wheels.distance_m)
        self.vel = (v, vn, w)
        self.wheel_vel = ws
        self.effort = [torque_per_a * float(i) for i in m.current][:n]
        self.samples += 1
        if dt is None or dt <= 0 or dt > self.max_dt_s:
            if dt is not None:
                self.gaps += 1
            return True
        th = self.theta + 0.5 * w * dt
        c, s = math.cos(th), math.sin(th)
        dx, dy = (c * v - s * vn) * dt, (s * v + c * vn) * dt
        self.x += dx
        self.y += dy
        dth = w * dt
        self.theta = wrap(self.theta + dth)
        for j in range(n):
            self.wheel_pos[j] += ws[j] * dt
        ds = math.hypot(dx, dy)
        self.var_xy += (SLIP_FRACTION * ds) ** 2
        self.var_theta += (SLIP_ROT_FRACTION * abs(dth) + SLIP_FRACTION * ds / (2 * d)) ** 2
        return True

    def twist_sigmas(self):
        """Std devs of (v, vn, w) of one sample from the wheel-speed noise through eqs 3-5."""
        d, r = self.geometry["model.d"], sum(self.radii()) / 4.0
        s = r * WHEEL_SPEED_SIGMA
        return s / math.sqrt(2.0), s / math.sqrt(2.0), s / (2.0 * d)

    def pose_covariance(self):
        """6x6 row-major (x, y, z, roll, pitch, yaw); z, roll, pitch fixed (planar): 1e-9."""
        c = [0.0] * 36
        c[0] = c[7] = max(self.var_xy, 1e-9)
        c[14] = c[21] = c[28] = 1e-9
        c[35] = max(self.var_theta, 1e-9)
        return c

    def twist_covariance(self):
        sv, svn, sw = self.twist_sigmas()
        c = [0.0] * 36
        c[0], c[7], c[35] = sv * sv, svn * svn, sw * sw
        c[14] = c[21] = c[28] = 1e-9
        return c


class StateEstimate:
    """The controller's state estimate (omni4.state_t on OMNI4_STATE, when the package has the
    type) as the same fields WheelOdometry offers. state_t follows core/include/omni4/core/est.h's
    est_output: pose[3] (x, y [m], theta [rad], world frame), vel[3] (v, vn [m/s], w [rad/s],
    robot frame), cov[6] (the diagonal of the covariance in state order x, y, theta, v, vn, w).
    Field names differing from these are looked up under the alternatives below."""

    def __init__(self):
        self.x = self.y = self.theta = 0.0
        self.vel = (0.0, 0.0, 0.0)
        self.cov = [1e-9] * 6
        self.samples = 0
        self.utime = None

    @staticmethod
    def _field(m, *names):
        for n in names:
            if hasattr(m, n):
                return getattr(m, n)
        raise AttributeError(f"state_t has none of {names}")

    def take(self, m):
        try:
            pose = self._field(m, "pose")
        except AttributeError:
            pose = (m.x, m.y, m.theta)
        vel = self._field(m, "vel", "velocity")
        try:
            cov = list(self._field(m, "cov", "covariance", "var"))
        except AttributeError:
            cov = [1e-9] * 6
        vals = [float(a) for a in (*pose, *vel)]
        if not all(math.isfinite(a) for a in vals):
            return False
        self.x, self.y, self.theta = vals[:3]
        self.vel = tuple(vals[3:6])
        if len(cov) == 36:      # a full 6x6 matrix: its diagonal
            cov = [cov[7 * i] for i in range(6)]
        self.cov = [max(float(c), 1e-9) if math.isfinite(float(c)) else 1e6 for c in cov[:6]]
        self.samples += 1
        self.utime = getattr(m, "utime", None)
        return True

    def pose_covariance(self):
        c = [0.0] * 36
        c[0], c[7], c[35] = self.cov[0], self.cov[1], self.cov[2]
        c[14] = c[21] = c[28] = 1e-9
        return c

    def twist_covariance(self):
        c = [0.0] * 36
        c[0], c[7], c[35] = self.cov[3], self.cov[4], self.cov[5]
        c[14] = c[21] = c[28] = 1e-9
        return c


def state_type():
    """(omni4.state_t, its channel) when the package has the controller's state estimate, else
    (None, None): omni4-ros then computes odometry from the wheels."""
    import omni4
    cls = getattr(omni4, "state_t", None)
    if cls is None:
        try:
            from .. import state_t as mod  # generated module omni4/state_t.py
            cls = getattr(mod, "state_t", None)
        except ImportError:
            cls = None
    if cls is None:
        return None, None
    return cls, getattr(omni4, "CHANNEL_STATE", "OMNI4_STATE")


class Throttle:
    """Lets a log line of each kind through at most once per period_s [s], each kind on its own
    clock, so a stream of one kind (NaN /cmd_vel) never hides another (a clamp). The lines held
    back are counted and the count said with the next line of that kind. clock: monotonic [s]."""

    def __init__(self, period_s=1.0, clock=time.monotonic):
        self.period_s = float(period_s)
        self.clock = clock
        self._said = {}          # kind -> clock time of the last line said
        self._held = {}          # kind -> lines held back since

    def say(self, kind, text):
        """The line to log now (text, plus the count held back), or None."""
        now = self.clock()
        last = self._said.get(kind)
        if last is not None and now - last < self.period_s:
            self._held[kind] = self._held.get(kind, 0) + 1
            return None
        held = self._held.pop(kind, 0)
        self._said[kind] = now
        return text + (f" (and {held} more like it since the last)" if held else "")


class CmdGate:
    """The /cmd_vel gate: a Twist (v, vn, w) becomes a velocity command only if every value is
    finite (else refused and counted: `refused_nonfinite`) and the controller's limits are
    known (else `refused_no_limits`); values beyond [limits] vel_lin_max / vel_rot_max are
    clamped to them, axis by axis, and counted (`clamped`). take() also says each refusal and
    each clamp, at most once per say_period_s per kind (Throttle on `clock`)."""

    KINDS = ("not finite", "limits unknown", "clamped")

    def __init__(self, limits=None, clock=time.monotonic, say_period_s=1.0):
        self.limits = dict(limits) if limits else {}
        self.received = 0
        self.accepted = 0
        self.clamped = 0
        self.refused_nonfinite = 0
        self.refused_no_limits = 0
        self.kind = None         # the last check's: one of KINDS, or None (taken as it was)
        self.notes = Throttle(say_period_s, clock)

    def known(self):
        return all(k in self.limits for k in LIMIT_KEYS)

    def take(self, v, vn, w):
        """(command or None, the line to log now or None): check() with its reason said
        through the per-kind throttle."""
        cmd, why = self.check(v, vn, w)
        return cmd, (self.notes.say(self.kind, why) if why else None)

    def check(self, v, vn, w):
        """(command, reason): command (v, vn, w) to send, or None with the reason."""
        self.received += 1
        self.kind = None
        vals = (float(v), float(vn), float(w))
        if not all(math.isfinite(a) for a in vals):
            self.refused_nonfinite += 1
            self.kind = "not finite"
            return None, f"refused: /cmd_vel not finite (v {vals[0]}, vn {vals[1]}, w {vals[2]})"
        if not self.known():
            self.refused_no_limits += 1
            self.kind = "limits unknown"
            return None, "refused: the controller's [limits] are not known yet"
        lin, rot = self.limits["limits.vel_lin_max"], self.limits["limits.vel_rot_max"]
        out = (max(-lin, min(lin, vals[0])), max(-lin, min(lin, vals[1])),
               max(-rot, min(rot, vals[2])))
        self.accepted += 1
        if out != vals:
            self.clamped += 1
            self.kind = "clamped"
            return out, (f"clamped: /cmd_vel ({vals[0]:g}, {vals[1]:g}, {vals[2]:g}) to [limits] "
                         f"vel_lin_max {lin:g} m/s, vel_rot_max {rot:g} rad/s")
        return out, None


class MotorsWindow:
    """What the diagnostics report per period: the samples, the OR of their fault bits, the
    loop rate from the controller's clock, and the lost samples (seq gaps)."""

    def __init__(self):
        self.reset()
        self.lost_total = 0
        self.rejected_edges = 0
        self.last = None
        self._prev_seq = None
        self._prev_rejected = False

    def reset(self):
        self.n = 0
        self.bits = 0
        self.first = None
        self.lost = 0

    def take(self, m):
        if self._prev_seq is not None and m.seq > self._prev_seq + 1:
            self.lost += m.seq - self._prev_seq - 1
            self.lost_total += m.seq - self._prev_seq - 1
        self._prev_seq = m.seq
        rej = bool(m.faults & motors_t.FAULT_CMD_REJECTED)
        if rej and not self._prev_rejected:
            self.rejected_edges += 1
        self._prev_rejected = rej
        if self.first is None:
            self.first = m
        self.last = m
        self.n += 1
        self.bits |= m.faults

    def rate_hz(self):
        a, b = self.first, self.last
        if a is None or b is None or b.seq <= a.seq or b.utime <= a.utime:
            return float("nan")
        return (b.seq - a.seq) / ((b.utime - a.utime) * 1e-6)


class AdaptWindow:
    """What the adapt diagnostics report per period: the last adapt_t (kept over periods), the
    OR of the flags of the period's, how many came, and the last acceptance or revert."""

    def __init__(self):
        self.last = None
        self.events = adapt_words.Events()
        self.reset()

    def reset(self):
        self.n = 0
        self.flags = 0

    def take(self, m):
        self.last = m
        self.n += 1
        self.flags |= m.flags

    def status(self, model, prefix):
        """omni4.adapt.diagnostic of the period (STALE without an adapt_t in it), each R in use
        against the identified R_j of model ({"model.R": text, ...})."""
        return adapt_words.diagnostic(self.last if self.n else None,
                                      adapt_words.identified_r(model), self.events, self.flags,
                                      prefix)


def diagnostic_statuses(window, gate, counters, model, odom_source, prefix="omni4", adapt=None):
    """The DiagnosticStatus contents as plain tuples: [(level, name, message, [(key, value)])].
    level: 0 OK, 1 WARN, 2 ERROR, 3 STALE (diagnostic_msgs/DiagnosticStatus). Names are
    "PREFIX: controller", "PREFIX: commands", "PREFIX: model", "PREFIX: odometry", and with
    adapt (an AdaptWindow) "PREFIX: adapt"."""
    out = []
    last = window.last
    if last is None or window.n == 0:
        out.append((3, f"{prefix}: controller", "no OMNI4_MOTORS in the last period", [
            ("samples", "0"), ("lost samples (total)", str(window.lost_total))]))
    else:
        names = fault_names(window.bits)
        mode = mode_name(last.mode)
        if last.mode in FAULTED_MODES or window.bits & LATCHING:
            level = 2
        elif window.bits & WARNINGS or window.lost:
            level = 1
        else:
            level = 0
        msg = f"mode {mode}" + (f", faults {' '.join(names)}" if names else ", no faults")
        out.append((level, f"{prefix}: controller", msg, [
            ("mode", mode),
            ("faults", " ".join(names) or "none"),
            ("faults now", " ".join(fault_names(last.faults)) or "none"),
            ("loop rate [Hz]", f"{window.rate_hz():.1f}"),
            ("samples", str(window.n)),
            ("lost samples", str(window.lost)),
            ("lost samples (total)", str(window.lost_total)),
        ]))
    cmd_level = 1 if (gate.refused_nonfinite or gate.clamped or window.rejected_edges) else 0
    out.append((cmd_level, f"{prefix}: commands",
                f"{gate.accepted} taken, {gate.clamped} clamped, {gate.refused_nonfinite} not "
                f"finite, {window.rejected_edges} rejected by the controller", [
                    ("cmd_vel received", str(gate.received)),
                    ("cmd_vel taken", str(gate.accepted)),
                    ("clamped", str(gate.clamped)),
                    ("refused not finite", str(gate.refused_nonfinite)),
                    ("refused limits unknown", str(gate.refused_no_limits)),
                    ("CMD rejections (controller)", str(window.rejected_edges)),
                    *[(k, str(v)) for k, v in counters.items()],
                ]))
    if model:
        out.append((0, f"{prefix}: model", "the [model] in force",
                    [(k, v) for k, v in model.items()]))
    else:
        out.append((1, f"{prefix}: model", "the [model] in force is not known (no answer)", []))
    out.append((0, f"{prefix}: odometry", f"from {odom_source}", [("source", odom_source)]))
    if adapt is not None:
        out.append(adapt.status(model, prefix))
    return out
