"""Goals for the controller (docs/goal.md): omni4.Robot's go_to() / follow(), the progress they
read, and the CLI omni4-goto.

    with omni4.Robot(url) as robot:
        st = robot.go_to(1.0, 0.5, 1.57)          # waits: a goal_status_t REACHED, else raises
        robot.follow([(1, 0, 0), (1, 1, 0), (0, 1, 1.57)], wait=False)
        st = robot.wait_goal(timeout_s=30)

A goal goes out as goal_t on OMNI4_GOAL and is re-sent (same goal_id) every keepalive_s while
this client wants it: the controller's watchdog stops a goal whose sender stops, as it stops
velocity commands. The controller answers on OMNI4_GOAL_STATUS (goal_status_t): ACTIVE with the
distance and time to go, then REACHED, or ABORTED / REFUSED with a reason (REASONS). Once
REACHED, the waiting call sends ACTION_CANCEL: the robot ramps its hold voltages down to IDLE.
Any command (velocity(), stop(), ...) replaces the goal.
"""
import csv
import itertools
import math
import sys
import threading
import time

from . import CHANNEL_GOAL, CHANNEL_GOAL_STATUS
from .goal_status_t import goal_status_t
from .goal_t import goal_t

S = goal_status_t
STATUS_NAMES = {S.STATUS_NONE: "NONE", S.STATUS_ACTIVE: "ACTIVE", S.STATUS_REACHED: "REACHED",
                S.STATUS_ABORTED: "ABORTED", S.STATUS_REFUSED: "REFUSED"}
REASONS = {
    S.REASON_NONE: "",
    S.REASON_NOT_FINITE: "a pose, blend_m or speed_max is NaN or infinite",
    S.REASON_OUT_OF_RANGE: "a pose beyond 100 m (or |theta| beyond 1000 rad), more than "
                           f"{goal_t.MAX_POSES} poses, blend_m outside 0.01 .. 2 m or a negative "
                           "speed_max",
    S.REASON_UNREACHABLE: "unreachable: no plan within the drives' limits gets there in 120 s",
    S.REASON_FAULT: "the robot is in FAULT or ESTOP: clear_fault() (omni4-param clear-fault) "
                    "first",
    S.REASON_NO_ESTIMATE: "no state estimate, or no camera pose for 0.5 s: the robot does not "
                          "know where it is",
    S.REASON_WATCHDOG: "the goal was not kept alive (the watchdog stopped it)",
    S.REASON_COLLISION: "the estimator flagged a collision: stopped with the ramp",
    S.REASON_STALE_ESTIMATE: "no camera pose for 1 s: odometry alone may not carry a goal longer",
    S.REASON_REPLACED: "a command took over",
    S.REASON_CANCELLED: "cancelled",
}
STATUS_TIMEOUT_S = 5.0       # no goal_status_t about the goal for this long: TimeoutError
_ids = itertools.count(1)


class GoalFailed(RuntimeError):
    """A goal the controller refused or aborted; str(e) is one line. status: the goal_status_t."""

    def __init__(self, text, status=None):
        super().__init__(text)
        self.status = status


def describe(st):
    """One line for a goal_status_t."""
    name = STATUS_NAMES.get(st.status, f"status {st.status}")
    if st.status in (S.STATUS_REFUSED, S.STATUS_ABORTED):
        why = REASONS.get(st.reason, f"reason {st.reason}")
        return f"goal {st.goal_id} {name}: {why}"
    return (f"goal {st.goal_id} {name}: pose {st.index + 1} of {st.n}, {st.distance_m:.3f} m "
            f"and {math.degrees(st.angle_rad):.1f} deg to go, {st.time_to_go_s:.2f} s planned")


def _poses(path):
    """The path as a list of [x, y, theta]; ValueError naming what is wrong."""
    poses = [[float(v) for v in p] for p in path]
    if not 1 <= len(poses) <= goal_t.MAX_POSES:
        raise ValueError(f"a goal has 1 to {goal_t.MAX_POSES} poses, not {len(poses)}")
    for i, p in enumerate(poses):
        if len(p) != 3:
            raise ValueError(f"pose {i + 1}: x, y, theta expected, got {len(p)} values")
        if not all(math.isfinite(v) for v in p):
            raise ValueError(f"pose {i + 1} {p}: values must be finite")
    return poses


class GoalMixin:
    """go_to / follow / wait_goal / cancel_goal for omni4.Robot (which provides _lc, url,
    keepalive_s, _closed)."""

    def _goal_setup(self):
        self._goal_cv = threading.Condition()
        self._goal_msg = None          # the goal_t kept alive (None: none)
        self._goal_status = None       # the last goal_status_t about the current goal
        self._goal_status_s = 0.0      # monotonic [s] of its arrival
        self._goal_seq = 0
        self._goal_sub = self._lc.subscribe(CHANNEL_GOAL_STATUS, self._on_goal_status)
        self._goal_ka = threading.Thread(target=self._goal_keepalive, daemon=True,
                                         name="omni4-robot-goal")
        self._goal_ka.start()

    def go_to(self, x, y, theta, wait=True, timeout_s=None, speed_max=0.0):
        """Go to the world pose (x [m], y [m], theta [rad]) and, with wait, wait for the
        verdict: returns the goal_status_t REACHED; GoalFailed (one line) if refused or
        aborted; TimeoutError after timeout_s [s] (None: as long as progress comes) or when
        the progress stops. wait=False returns the goal id at once (wait_goal() later)."""
        return self.follow([(x, y, theta)], wait=wait, timeout_s=timeout_s, speed_max=speed_max)

    def follow(self, path, wait=True, timeout_s=None, blend_m=0.0, speed_max=0.0):
        """Follow a path of world poses [(x, y, theta), ...] without stopping at the
        intermediate ones (passed within blend_m, 0: the controller's default), at rest at
        the last; wait, timeout_s and the result as go_to()."""
        msg = goal_t()
        msg.poses = _poses(path)
        msg.n = len(msg.poses)
        msg.action = goal_t.ACTION_GO
        msg.goal_id = (int(time.time() * 1e3) << 16 | next(_ids) & 0xffff) & (2**63 - 1)
        msg.blend_m = float(blend_m)
        msg.speed_max = float(speed_max)
        with self._goal_cv:
            self._forget_command()
            self._goal_msg = msg
            self._goal_status = None
            self._goal_status_s = time.monotonic()
            self._send_goal_locked(msg)
        if not wait:
            return msg.goal_id
        return self.wait_goal(timeout_s)

    def wait_goal(self, timeout_s=None):
        """Waits for the current goal's end; REACHED: returns its goal_status_t (and sends the
        cancel that lets the robot go IDLE). See go_to()."""
        end = None if timeout_s is None else time.monotonic() + timeout_s
        with self._goal_cv:
            msg = self._goal_msg
            if msg is None:
                raise RuntimeError("omni4.Robot: no goal to wait for")
            while True:
                st = self._goal_status
                if st is not None and st.status != S.STATUS_ACTIVE:
                    break
                now = time.monotonic()
                if now - self._goal_status_s > STATUS_TIMEOUT_S:
                    self._goal_msg = None
                    raise TimeoutError(f"omni4.Robot: no {CHANNEL_GOAL_STATUS} about goal "
                                       f"{msg.goal_id} for {STATUS_TIMEOUT_S} s on {self.url}")
                if end is not None and now >= end:
                    self.cancel_goal_locked()
                    raise TimeoutError(f"omni4.Robot: goal {msg.goal_id} not reached within "
                                       f"{timeout_s} s ({describe(st) if st else 'no progress'})")
                self._goal_cv.wait(0.05)
            if st.status == S.STATUS_REACHED:
                self.cancel_goal_locked()
                return st
            self._goal_msg = None
        raise GoalFailed(describe(st), st)

    @property
    def goal_status(self):
        """The last goal_status_t about the current goal (None: none yet)."""
        return self._goal_status

    def cancel_goal(self):
        """Stops keeping the goal alive and sends ACTION_CANCEL: an active goal ends ABORTED
        (CANCELLED) and the robot stops with the ramp."""
        with self._goal_cv:
            self.cancel_goal_locked()

    def cancel_goal_locked(self):
        msg = self._goal_msg
        self._goal_msg = None
        if msg is not None:
            c = goal_t()
            c.goal_id = msg.goal_id
            c.action = goal_t.ACTION_CANCEL
            self._send_goal_locked(c)

    def _forget_goal(self):
        """A command replaces the goal: no more keep-alive."""
        with self._goal_cv:
            self._goal_msg = None

    def _send_goal_locked(self, msg):
        self._goal_seq += 1
        msg.seq = self._goal_seq
        msg.utime = int(time.time() * 1e6)
        self._lc.publish(CHANNEL_GOAL, msg.encode())

    def _goal_keepalive(self):
        while not self._closed.wait(self.keepalive_s):
            with self._goal_cv:
                if self._goal_msg is not None:
                    self._send_goal_locked(self._goal_msg)

    def _on_goal_status(self, _channel, data):
        try:
            st = goal_status_t.decode(data)
        except Exception:  # another type on the channel
            return
        with self._goal_cv:
            msg = self._goal_msg
            if msg is not None and st.goal_id == msg.goal_id or \
                    self._goal_status is not None and st.goal_id == self._goal_status.goal_id:
                self._goal_status = st
                self._goal_status_s = time.monotonic()
                self._goal_cv.notify_all()

    def _goal_close(self):
        with self._goal_cv:
            self.cancel_goal_locked()
        self._goal_ka.join(2.0)
        try:
            self._lc.unsubscribe(self._goal_sub)
        except Exception:  # already gone
            pass


def read_path(path):
    """x, y, theta rows of a CSV file (a first row that is not numbers is a header)."""
    rows = []
    with open(path, newline="") as f:
        for i, row in enumerate(csv.reader(f)):
            if not row or row[0].lstrip().startswith("#"):
                continue
            try:
                rows.append([float(v) for v in row])
            except ValueError:
                if i == 0:
                    continue
                raise ValueError(f"{path}:{i + 1}: x, y, theta expected: {','.join(row)}")
    return rows


PROG = "omni4-goto"


def main(argv=None):
    """The console script: 0 reached, 1 refused / aborted / no progress (one line), 2 bad
    input; --version; a closed stdout ends it quietly with 141 (omni4._cli)."""
    from ._cli import run
    return run(PROG, _main, sys.argv[1:] if argv is None else list(argv))


def _main(argv):
    from ._cli import bus_tool_parser, usage
    from .robot import Robot
    p = bus_tool_parser(
        PROG, "Go to a world pose [m, m, rad], or follow a path of poses, and wait: exit 0 "
        "when reached, 1 with one line when refused or aborted, 2 on bad input. The goal is "
        "kept alive on the bus while it waits (docs/goal.md).",
        "example: omni4-goto 1.0 0.5 1.57 --lcm 'udpm://239.255.76.67:7667?ttl=0'\n"
        "         omni4-goto --path corners.csv      (rows x,y,theta; a header row is skipped)")
    p.add_argument("pose", nargs="*", type=float, metavar="X Y THETA")
    p.add_argument("--path", metavar="FILE.csv",
                   help="poses x,y,theta to follow without stopping (the last is the goal)")
    p.add_argument("--speed", type=float, default=0.0, help="speed cap [m/s] (0: the model's)")
    p.add_argument("--blend", type=float, default=0.0,
                   help="intermediate poses passed within this [m] (0: the controller's)")
    p.add_argument("--timeout", type=float, default=None, help="give up after this [s]")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    a = p.parse_args(argv)
    try:
        if a.path:
            if a.pose:
                raise ValueError("give X Y THETA or --path, not both")
            path = read_path(a.path)
        elif len(a.pose) == 3:
            path = [a.pose]
        else:
            raise ValueError("X Y THETA expected (or --path FILE.csv)")
        poses = _poses(path)
    except (OSError, ValueError) as e:
        return usage(PROG, str(e))
    return _run(Robot, a, poses)


def _run(robot_type, a, poses):
    try:
        with robot_type(a.lcm, limits=False) as robot:
            robot.follow(poses, wait=False, blend_m=a.blend, speed_max=a.speed)
            stop = threading.Event()
            if not a.quiet:
                threading.Thread(target=_progress, args=(robot, stop), daemon=True).start()
            try:
                st = robot.wait_goal(a.timeout)
            finally:
                stop.set()
            print(f"omni4-goto: reached ({describe(st)})", file=sys.stderr)
            return 0
    except (GoalFailed, TimeoutError, RuntimeError) as e:
        print(f"omni4-goto: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("omni4-goto: interrupted (the goal is no longer kept alive)", file=sys.stderr)
        return 1


def _progress(robot, stop):
    while not stop.wait(0.5):
        st = robot.goal_status
        if st is not None and st.status == S.STATUS_ACTIVE:
            print(f"omni4-goto: {describe(st)}", file=sys.stderr)


__all__ = ["GoalMixin", "GoalFailed", "REASONS", "STATUS_NAMES", "describe", "read_path",
           "main"]

if __name__ == "__main__":
    sys.exit(main())
