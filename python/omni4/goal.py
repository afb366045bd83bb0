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
Any command (velocity(), stop(), ...) replaces the goal. The waiting call judges progress from
the statuses' content (Progress), cancels a goal that makes none for no_progress_s, says when
another client's goal replaced ours, and cancels the goal when interrupted (KeyboardInterrupt).
"""
import argparse
import itertools
import math
import re
import signal
import sys
import textwrap
import threading
import time

from . import CHANNEL_GOAL, CHANNEL_GOAL_STATUS
from .goal_status_t import goal_status_t
from .goal_t import goal_t
from . import _vocab

S = goal_status_t
STATUS_NAMES = dict(_vocab.GOAL_STATUSES)  # the vocabulary's rows (core's vocab.def)
REASONS = {value: meaning.replace("goal_t.MAX_POSES", str(goal_t.MAX_POSES))
           for value, (_, meaning) in _vocab.GOAL_REASONS.items()}
NO_PROGRESS_S = 5.0          # no progress of the goal for this long: cancelled, TimeoutError
STATUS_TIMEOUT_S = NO_PROGRESS_S   # the name before progress was judged (kept for callers)
CANCEL_WAIT_S = 1.0          # after a cancel, the longest wait for the controller's ABORTED [s]
# What counts as progress (wait_goal): the distance or the angle below its least so far by this
# much, the pose aimed at or the status changing, or the time to go falling.
PROGRESS_M = 0.001
PROGRESS_RAD = 0.001
PROGRESS_S = 0.001
_ids = itertools.count(1)


class GoalFailed(RuntimeError):
    """A goal the controller refused or aborted; str(e) is one line. status: the goal_status_t."""

    def __init__(self, text, status=None):
        super().__init__(text)
        self.status = status


def describe(st):
    """One line for a goal_status_t."""
    name = STATUS_NAMES.get(st.status, f"status {st.status}")
    if st.status == S.STATUS_REFUSED and st.reason == S.REASON_REPLACED:
        return f"goal {st.goal_id} {name}: a newer goal replaced it while it waited for its plan"
    if st.status in (S.STATUS_REFUSED, S.STATUS_ABORTED):
        why = REASONS.get(st.reason, f"reason {st.reason}")
        return f"goal {st.goal_id} {name}: {why}"
    if st.status == S.STATUS_ACTIVE and st.reason == S.REASON_SETTLING:
        return (f"goal {st.goal_id} {name}: {REASONS[S.REASON_SETTLING]}, "
                f"{st.distance_m * 1e3:.1f} mm and {math.degrees(st.angle_rad):.2f} deg off")
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


class Progress:
    """Judges a goal's progress from its goal_status_t stream (not from messages arriving): the
    status or the pose aimed at changing, the distance or the angle to go below its least so far
    by PROGRESS_M / PROGRESS_RAD, or the planned time to go falling by PROGRESS_S. A status
    repeated unchanged (a robot held against an obstacle, a plan run out) is no progress."""

    def __init__(self):
        self.key = None
        self.best = None

    def update(self, st):
        """True if st is progress over what was seen before (the first status is)."""
        key = (st.status, st.reason, st.index)  # entering SETTLING is progress too
        now = (st.distance_m, abs(st.angle_rad), st.time_to_go_s)
        if key != self.key or self.best is None:
            self.key, self.best = key, list(now)
            return True
        moved = False
        for i, step in enumerate((PROGRESS_M, PROGRESS_RAD, PROGRESS_S)):
            if now[i] < self.best[i] - step:
                self.best[i] = now[i]
                moved = True
        return moved


class GoalMixin:
    """go_to / follow / wait_goal / cancel_goal for omni4.Robot (which provides _lc, url,
    keepalive_s, _closed)."""

    def _goal_setup(self):
        self._goal_cv = threading.Condition()
        self._goal_msg = None          # the goal_t kept alive (None: none)
        self._goal_id = None           # the id of the last goal sent (kept after it ends)
        self._goal_last = False        # the last thing sent was a goal (not a command)
        self._goal_status = None       # the last goal_status_t about that goal
        self._goal_status_s = 0.0      # monotonic [s] of its arrival
        self._goal_other = None        # a later goal_status_t of another goal in force
        self._goal_seq = 0
        self._goal_sub = self._lc.subscribe(CHANNEL_GOAL_STATUS, self._on_goal_status)
        self._goal_ka = threading.Thread(target=self._goal_keepalive, daemon=True,
                                         name="omni4-robot-goal")
        self._goal_ka.start()

    def go_to(self, x, y, theta, wait=True, timeout_s=None, speed_max=0.0,
              no_progress_s=NO_PROGRESS_S):
        """Go to the world pose (x [m], y [m], theta [rad]) and, with wait, wait for the
        verdict: returns the goal_status_t REACHED; GoalFailed (one line) if refused, aborted
        or replaced by another goal; TimeoutError (the goal cancelled) after timeout_s [s]
        (None: as long as progress comes) or after no_progress_s [s] without progress
        (Progress). wait=False returns the goal id at once (wait_goal() later). A
        KeyboardInterrupt while it waits cancels the goal (the robot brakes to rest), then
        propagates."""
        return self.follow([(x, y, theta)], wait=wait, timeout_s=timeout_s, speed_max=speed_max,
                           no_progress_s=no_progress_s)

    def follow(self, path, wait=True, timeout_s=None, blend_m=0.0, speed_max=0.0,
               no_progress_s=NO_PROGRESS_S):
        """Follow a path of world poses [(x, y, theta), ...] without stopping at the
        intermediate ones (passed within blend_m, 0: the controller's default), at rest at
        the last; wait, timeout_s, no_progress_s and the result as go_to()."""
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
            self._goal_id = msg.goal_id
            self._goal_last = True
            self._goal_status = None
            self._goal_other = None
            self._goal_status_s = time.monotonic()
            self._send_goal_locked(msg)
        if not wait:
            return msg.goal_id
        return self.wait_goal(timeout_s, no_progress_s)

    def wait_goal(self, timeout_s=None, no_progress_s=NO_PROGRESS_S):
        """Waits for the current goal's end; REACHED: returns its goal_status_t (and sends the
        cancel that lets the robot go IDLE). Another goal in force once ours had started (a
        second client's goal replaced it): GoalFailed. See go_to()."""
        start = time.monotonic()
        end = None if timeout_s is None else start + timeout_s
        with self._goal_cv:
            msg = self._goal_msg
            if msg is None:
                raise RuntimeError("omni4.Robot: no goal to wait for")
            progress = Progress()
            seen = None                   # the last status judged
            last_progress_s = start
            try:
                while True:
                    st = self._goal_status
                    if st is not None and st.status != S.STATUS_ACTIVE:
                        break
                    if self._goal_other is not None:
                        other = self._goal_other
                        self._goal_msg = None   # no keep-alive: it would start ours again
                        raise GoalFailed(f"goal {msg.goal_id} replaced: goal {other.goal_id} "
                                         f"(another client's) is in force now", other)
                    now = time.monotonic()
                    if st is not None and st is not seen:
                        seen = st
                        if progress.update(st):
                            last_progress_s = now
                    if now - last_progress_s > no_progress_s:
                        self.cancel_goal_locked()
                        what = f"last: {describe(st)}" if st else \
                            f"no {CHANNEL_GOAL_STATUS} about it on {self.url}"
                        raise TimeoutError(f"omni4.Robot: goal {msg.goal_id} made no progress "
                                           f"for {no_progress_s:g} s ({what}); cancelled")
                    if end is not None and now >= end:
                        self.cancel_goal_locked()
                        last = describe(st) if st else "no progress"
                        raise TimeoutError(f"omni4.Robot: goal {msg.goal_id} not reached within "
                                           f"{timeout_s} s ({last}); cancelled")
                    self._goal_cv.wait(0.05)
            except KeyboardInterrupt:
                self.cancel_goal_locked()       # the controller brakes the robot to rest
                raise
            if st.status == S.STATUS_REACHED:
                self.cancel_goal_locked()
                return st
            self._goal_msg = None
        raise GoalFailed(describe(st), st)

    @property
    def goal_status(self):
        """The last goal_status_t about the current goal (None: none yet)."""
        return self._goal_status

    def cancel_goal(self, wait_s=0.0):
        """Stops keeping the goal alive and sends ACTION_CANCEL: an active goal ends ABORTED
        (CANCELLED) and the robot stops with the ramp. wait_s > 0: waits up to that long for
        the controller's word on it; returns the goal's last goal_status_t (None: none)."""
        end = time.monotonic() + wait_s
        with self._goal_cv:
            self.cancel_goal_locked()
            while True:
                st = self._goal_status
                left = end - time.monotonic()
                if left <= 0 or st is not None and st.status != S.STATUS_ACTIVE:
                    return st
                self._goal_cv.wait(min(left, 0.05))

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
            self._goal_last = False

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
            if self._goal_id is None:
                return
            if st.goal_id == self._goal_id:
                self._goal_status = st
                self._goal_status_s = time.monotonic()
                self._goal_cv.notify_all()
                return
            # Another goal in force (ACTIVE, or REACHED and held) after ours had started: ours
            # was replaced. Before ours starts, the goal in force goes on until ours is handed
            # over (docs/goal.md), which is no replacement.
            mine = self._goal_status
            if self._goal_msg is not None and mine is not None and \
                    mine.status == S.STATUS_ACTIVE and st.seq > mine.seq and \
                    st.status in (S.STATUS_ACTIVE, S.STATUS_REACHED):
                self._goal_other = st
                self._goal_cv.notify_all()

    def _goal_close(self):
        with self._goal_cv:
            self.cancel_goal_locked()
        self._goal_ka.join(2.0)
        try:
            self._lc.unsubscribe(self._goal_sub)
        except Exception:  # already gone
            pass


PATH_SEPARATORS = "commas, semicolons, tabs or spaces"
_FIELD_SPLIT = re.compile(r"[,;\s]+")


def read_path(path):
    """The x, y, theta rows of a CSV file: values separated by PATH_SEPARATORS; blank lines and
    lines starting with # are skipped; the first row is a header (skipped) only when none of its
    fields is a number. Any other row that is not numbers: ValueError naming FILE:LINE."""
    rows = []
    first = True
    with open(path, newline="", encoding="utf-8", errors="replace") as f:
        for i, line in enumerate(f, 1):
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            fields = [v for v in _FIELD_SPLIT.split(text) if v]
            values = []
            for v in fields:
                try:
                    values.append(float(v))
                except ValueError:
                    values.append(None)
            was_first, first = first, False
            if None not in values:
                rows.append(values)
            elif not (was_first and all(v is None for v in values)):
                raise ValueError(f"{path}:{i}: x, y, theta expected (numbers separated by "
                                 f"{PATH_SEPARATORS}): {text}")
    return rows


PROG = "omni4-goto"


def main(argv=None):
    """The console script: 0 reached, 1 refused / aborted / no progress (one line), 2 bad
    input; --version; a closed stdout ends it quietly with 141 (omni4._cli)."""
    from ._cli import run
    return run(PROG, _main, sys.argv[1:] if argv is None else list(argv))


# argparse takes "-1e-3" for an option (its test for a negative number knows no exponent):
# every number float() reads, signed, is a positional here (no option of the tool looks like one).
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$",
                              re.IGNORECASE)
SPEED_RANGE = "a finite number >= 0 m/s, 0: the model's limits alone (goal_t.lcm)"
BLEND_RANGE = "0 (the controller's default, 0.15 m) or 0.01 .. 2 m (goal_t.lcm)"


def _number(text):
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: not a number") from None


def _checked(rule, ok):
    def parse(text):
        x = _number(text)
        if not (math.isfinite(x) and ok(x)):
            raise argparse.ArgumentTypeError(f"{text}: must be {rule}")
        return x
    return parse


class _Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C is (the goal cancelled), with its own exit status."""


def _on_sigterm(_signum, _frame):
    raise _Terminated


def _main(argv):
    from ._cli import bus_tool_parser, usage
    from .robot import Robot
    p = bus_tool_parser(
        PROG, textwrap.fill(
            "Go to a world pose [m, m, rad], or follow a path of poses, and wait: exit 0 "
        "when reached; 1 with one line when refused, aborted, replaced by another client's "
        f"goal, or without progress for --no-progress seconds (default {NO_PROGRESS_S:g}; the "
        "goal is then cancelled); 2 on bad input; 130 on Ctrl-C (143 on SIGTERM), which "
        "cancels the goal: the controller brakes the robot to rest. The goal is kept alive on "
        "the bus while it waits (docs/goal.md); no IDLE is ever sent.", 79),
        "example: omni4-goto 1.0 0.5 1.57 --lcm 'udpm://239.255.76.67:7667?ttl=0'\n"
        "         omni4-goto 0 0 -1e-3          (negative numbers are poses; or -- 0 0 -1)\n"
        f"         omni4-goto --path corners.csv  (rows x,y,theta separated by {PATH_SEPARATORS};\n"
        "                                        a first row of names is a header)")
    p._negative_number_matcher = _NEGATIVE_NUMBER
    p.add_argument("pose", nargs="*", type=_number, metavar="X Y THETA")
    p.add_argument("--path", metavar="FILE.csv",
                   help="poses x,y,theta to follow without stopping (the last is the goal)")
    p.add_argument("--speed", type=_checked(SPEED_RANGE, lambda x: x >= 0), default=0.0,
                   metavar="M_S", help=f"speed cap [m/s]: {SPEED_RANGE}")
    p.add_argument("--blend", type=_checked(BLEND_RANGE, lambda x: x == 0 or 0.01 <= x <= 2),
                   default=0.0, metavar="M",
                   help=f"intermediate poses passed within this [m]: {BLEND_RANGE}")
    p.add_argument("--timeout", type=_checked("a finite number > 0 s", lambda x: x > 0),
                   default=None, metavar="S",
                   help="give up (cancel the goal) after this [s]; default: wait as long as "
                        "the goal progresses")
    p.add_argument("--no-progress", type=_checked("a finite number > 0 s", lambda x: x > 0),
                   default=NO_PROGRESS_S, metavar="S",
                   help="cancel the goal when it has made no progress (distance, heading, pose "
                        "aimed at or time to go falling, or its status changing) for this "
                        f"long [s] (default {NO_PROGRESS_S:g})")
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


def _say(text):
    print(f"{PROG}: {text.removeprefix('omni4.Robot: ')}", file=sys.stderr)


def _run(robot_type, a, poses):
    """The goal sent and waited for; the exit status. The Robot is closed without IDLE: after
    REACHED the cancel ramps the robot to IDLE, after a cancel the controller brakes it to rest
    (an IDLE would cut either short: the robot would coast)."""
    main = threading.current_thread() is threading.main_thread()
    old = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)} if main else {}
    if main:                             # Ctrl-C and SIGTERM cancel the goal (below)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.signal(signal.SIGTERM, _on_sigterm)
    robot = None
    try:
        robot = robot_type(a.lcm, limits=False)
        robot.follow(poses, wait=False, blend_m=a.blend, speed_max=a.speed)
        stop = threading.Event()
        if not a.quiet:
            threading.Thread(target=_progress, args=(robot, stop), daemon=True).start()
        try:
            st = robot.wait_goal(a.timeout, a.no_progress)
        finally:
            stop.set()
        _say(f"reached ({describe(st)})")
        return 0
    except (GoalFailed, TimeoutError, RuntimeError) as e:
        _say(str(e))
        return 1
    except KeyboardInterrupt as e:       # wait_goal has sent ACTION_CANCEL
        status = 143 if isinstance(e, _Terminated) else 130
        for sig in old:                  # the bounded wait below is short: no second signal
            signal.signal(sig, signal.SIG_IGN)
        if robot is None:
            _say("interrupted before the goal was sent")
            return status
        st = robot.cancel_goal(wait_s=CANCEL_WAIT_S)
        if st is not None and st.status != S.STATUS_ACTIVE:
            _say("cancelled: the robot brakes to rest")
        else:
            _say(f"cancel sent, no word from the controller within {CANCEL_WAIT_S:g} s (if it "
                 "is still driving, its watchdog stops it)")
        return status
    finally:
        if robot is not None:
            robot.close(stop=False)
        for sig, handler in old.items():
            signal.signal(sig, handler)


def _progress(robot, stop):
    while not stop.wait(0.5):
        st = robot.goal_status
        if st is not None and st.status == S.STATUS_ACTIVE:
            print(f"omni4-goto: {describe(st)}", file=sys.stderr)


__all__ = ["GoalMixin", "GoalFailed", "REASONS", "STATUS_NAMES", "describe", "read_path",
           "main"]

if __name__ == "__main__":
    sys.exit(main())
