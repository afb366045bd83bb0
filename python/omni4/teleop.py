"""omni4-teleop: drive the robot by hand from a terminal (keys) or a gamepad (Linux joystick).

Keys (no Enter needed): w / s  v +/- one step, a / d  vn +/- one step (vn is to the left),
q / e  w +/- one step (counter-clockwise positive), space  stop (all zero, VELOCITY mode holds
the robot), + / -  double / halve the steps, x or Ctrl-C  quit (sends IDLE).

The command goes out as VELOCITY on OMNI4_CMD through omni4.Robot, re-sent at --rate (20 Hz),
well inside the controller's 200 ms command watchdog: if this program dies, the watchdog stops
the robot. Quitting, or stdin closing, sends IDLE first. When no OMNI4_MOTORS has come for 1 s
it says "no robot answers" (the commands go nowhere), and says when the robot answers again. The terminal's settings are restored on
every way out.

Gamepad: the Linux joystick interface (/dev/input/js0, or --joystick PATH): 8-byte js_event
records (u32 time [ms], s16 value, u8 type, u8 number; type 1 button, 2 axis, 0x80 init). The
axes of --axes (default 1,0,3: left stick up/down, left/right, right stick left/right) set
v, vn, w (stick up / left = positive) at full scale --joy-lin [m/s] and --joy-rot [rad/s];
button 0 stops. A regular file of recorded events is replayed at its recorded times.
"""
import errno
import glob
import os
import select
import signal
import stat
import struct
import sys
import time

from . import __version__
from ._cli import usage

PROG = "omni4-teleop"
JS_EVENT = struct.Struct("<IhBB")     # struct js_event (linux/joystick.h), little-endian hosts
JS_BUTTON, JS_AXIS, JS_INIT = 0x01, 0x02, 0x80
AXIS_FULL = 32767.0
DEADZONE = 0.08                       # of full scale: a resting stick reads a little off zero
# docs/ini-keys.md: the controller's [limits] defaults, shown when it does not answer.
DEFAULT_LIMITS = {"limits.vel_lin_max": 3.0, "limits.vel_rot_max": 20.0}


class Joystick:
    """Events of a Linux joystick device, or of a file of recorded js_event records replayed at
    their recorded times. fileno() for select(); events() returns what is due now."""

    def __init__(self, path):
        self.path = path
        self.fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        self.replay = stat.S_ISREG(os.fstat(self.fd).st_mode)
        self._buf = b""
        self._pending = []                # replay: (due monotonic, event)
        self._t0 = None
        self.ended = False
        if self.replay:
            with os.fdopen(self.fd, "rb") as f:
                data = f.read()
            self.fd = None
            n = len(data) // JS_EVENT.size
            evs = [JS_EVENT.unpack_from(data, i * JS_EVENT.size) for i in range(n)]
            start = time.monotonic()
            t_first = evs[0][0] if evs else 0
            self._pending = [(start + (e[0] - t_first) / 1000.0, e) for e in evs]

    def fileno(self):
        return self.fd

    def next_due(self):
        """Seconds until the next recorded event (None: not a replay or nothing left)."""
        if not self._pending:
            return None
        return max(0.0, self._pending[0][0] - time.monotonic())

    def events(self):
        """(time_ms, value, type, number) of the events available now."""
        if self.replay:
            now = time.monotonic()
            out = []
            while self._pending and self._pending[0][0] <= now:
                out.append(self._pending.pop(0)[1])
            if not self._pending:
                self.ended = True
            return out
        try:
            data = os.read(self.fd, 64 * JS_EVENT.size)
        except BlockingIOError:
            return []
        except OSError as e:          # ENODEV: unplugged
            self.ended = True
            if e.errno not in (errno.ENODEV, errno.EIO):
                raise
            return []
        if not data:
            self.ended = True
            return []
        self._buf += data
        n = len(self._buf) // JS_EVENT.size
        out = [JS_EVENT.unpack_from(self._buf, i * JS_EVENT.size) for i in range(n)]
        self._buf = self._buf[n * JS_EVENT.size:]
        return out

    def close(self):
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


class Terminal:
    """stdin in cbreak mode without echo and signals (Ctrl-C arrives as a key); restore() puts
    the saved settings back. A stdin that is not a terminal is left alone."""

    def __init__(self, fd):
        self.fd = fd
        self.saved = None
        try:
            import termios
            self.saved = termios.tcgetattr(fd)
        except Exception:  # not a terminal (termios.error), or no termios
            return
        new = termios.tcgetattr(fd)
        new[3] &= ~(termios.ICANON | termios.ECHO | termios.ISIG)
        new[6][termios.VMIN] = 1
        new[6][termios.VTIME] = 0
        termios.tcsetattr(fd, termios.TCSADRAIN, new)

    def restore(self):
        if self.saved is not None:
            import termios
            termios.tcsetattr(self.fd, termios.TCSADRAIN, self.saved)
            self.saved = None


def _clamp(x, top):
    return max(-top, min(top, x))


class Teleop:
    """The commanded velocity and what changes it (keys, joystick events)."""

    def __init__(self, lin_max, rot_max, step_lin, step_rot, joy_lin, joy_rot, axes):
        self.lin_max, self.rot_max = lin_max, rot_max
        self.step_lin, self.step_rot = step_lin, step_rot
        self.joy_lin, self.joy_rot = min(joy_lin, lin_max), min(joy_rot, rot_max)
        self.axes = axes
        self.v = [0.0, 0.0, 0.0]
        self.quit = False

    def key(self, ch):
        """Applies one key; returns True if the command changed."""
        old = list(self.v)
        steps = {"w": (0, 1), "s": (0, -1), "a": (1, 1), "d": (1, -1), "q": (2, 1), "e": (2, -1)}
        if ch.lower() in steps:
            i, sign = steps[ch.lower()]
            step, top = (self.step_rot, self.rot_max) if i == 2 else (self.step_lin, self.lin_max)
            self.v[i] = round(_clamp(self.v[i] + sign * step, top), 9)
        elif ch == " ":
            self.v = [0.0, 0.0, 0.0]
        elif ch in "+=":
            self.step_lin, self.step_rot = self.step_lin * 2, self.step_rot * 2
        elif ch in "-_":
            self.step_lin, self.step_rot = self.step_lin / 2, self.step_rot / 2
        elif ch in ("x", "X", "\x03", "\x04"):
            self.quit = True
        return self.v != old

    def js_event(self, ev):
        """Applies one js_event; returns True if the command changed."""
        _t, value, typ, number = ev
        typ &= ~JS_INIT
        old = list(self.v)
        if typ == JS_AXIS and number in self.axes:
            i = self.axes.index(number)
            x = -value / AXIS_FULL            # stick up / left reads negative
            x = 0.0 if abs(x) < DEADZONE else max(-1.0, min(1.0, x))
            self.v[i] = round(x * (self.joy_rot if i == 2 else self.joy_lin), 9)
        elif typ == JS_BUTTON and number == 0 and value:
            self.v = [0.0, 0.0, 0.0]
        return self.v != old

    def line(self):
        return (f"v {self.v[0]:+.2f} m/s  vn {self.v[1]:+.2f} m/s  w {self.v[2]:+.2f} rad/s  "
                f"(step {self.step_lin:g} m/s, {self.step_rot:g} rad/s)")


EPILOG = """\
keys: w/s v +/-, a/d vn +/- (left positive), q/e w +/- (counter-clockwise positive),
      space stop (zero velocity), +/- double/halve the steps, x or Ctrl-C quit (IDLE)
The command is re-sent at --rate; if this program dies, the controller's command watchdog
([control] cmd_timeout_ms, 200 ms by default) stops the robot. Quitting or the end of stdin sends
IDLE. No OMNI4_MOTORS for 1 s: "no robot answers" is said (and when it answers again).
Commands are clamped to the controller's [limits] (vel_lin_max, vel_rot_max, read over
LCM; 3 m/s and 20 rad/s, the defaults, if it does not answer).
gamepad: /dev/input/js0 if present, or --joystick PATH (a device, or a file of recorded 8-byte
js_event records, replayed at their times); --axes V,VN,W axis numbers; button 0 stops.
Exit status: 0 quit, 1 run-time error (e.g. the robot refused a command), 2 usage error."""


def build_parser():
    from ._cli import bus_tool_parser

    p = bus_tool_parser(PROG, "Drive the omni4 robot by hand: keys or a gamepad.", EPILOG)
    p.add_argument("--rate", type=float, default=20.0, metavar="HZ",
                   help="command re-send rate [Hz] (default 20; at least 10)")
    p.add_argument("--step-lin", type=float, default=0.1, metavar="M_S",
                   help="v, vn change per key [m/s] (default 0.1)")
    p.add_argument("--step-rot", type=float, default=0.5, metavar="RAD_S",
                   help="w change per key [rad/s] (default 0.5)")
    p.add_argument("--joystick", metavar="PATH",
                   help="joystick device or recorded js_event file (default /dev/input/js0 "
                        "if present)")
    p.add_argument("--no-joystick", action="store_true", help="keys only")
    p.add_argument("--axes", default="1,0,3", metavar="V,VN,W",
                   help="joystick axis numbers for v, vn, w (default 1,0,3)")
    p.add_argument("--joy-lin", type=float, default=0.5, metavar="M_S",
                   help="v, vn at full stick [m/s] (default 0.5)")
    p.add_argument("--joy-rot", type=float, default=2.0, metavar="RAD_S",
                   help="w at full stick [rad/s] (default 2)")
    p.add_argument("--version", action="store_true", help="print the version and exit")
    return p


def _on_terminal():
    """stdout is a terminal: status lines are drawn over each other; else (a pipe, a file)
    every line is written plain, without escape sequences or carriage returns."""
    try:
        return sys.stdout.isatty()
    except (AttributeError, ValueError):
        return False


def _say(text):
    """One status line: on a terminal drawn over the previous one (\\r\\n-safe in any
    terminal mode); elsewhere a plain line ending in a newline."""
    if _on_terminal():
        out = "\r\x1b[K" + text
    else:
        out = text.replace("\r", "")
        out += "" if out.endswith("\n") else "\n"
    try:
        sys.stdout.write(out)
        sys.stdout.flush()
    except (BrokenPipeError, OSError):
        pass


def _parse(argv):
    """(args, axes, None) or (None, None, usage error message)."""
    args = build_parser().parse_args(argv)
    if args.version:
        return args, None, None
    if not 10 <= args.rate <= 1000:
        return None, None, "--rate must be in [10, 1000] Hz (the watchdog is 200 ms)"
    for name in ("step_lin", "step_rot", "joy_lin", "joy_rot"):
        if not getattr(args, name) > 0:
            return None, None, f"--{name.replace('_', '-')} must be > 0"
    try:
        axes = [int(a) for a in args.axes.split(",")]
        if len(axes) != 3 or not all(0 <= a < 256 for a in axes):
            raise ValueError
    except ValueError:
        return None, None, f"--axes {args.axes}: three axis numbers V,VN,W expected"
    return args, axes, None


def _open_joystick(args):
    """(Joystick or None, its path); OSError only for a --joystick named on the command line
    (the default /dev/input/js* is optional)."""
    if args.no_joystick:
        return None, None
    js_path = args.joystick
    if js_path is None:
        found = sorted(glob.glob("/dev/input/js*"))
        js_path = found[0] if found else None
    if js_path is None:
        return None, None
    try:
        return Joystick(js_path), js_path
    except OSError:
        if args.joystick:
            raise
        return None, js_path


def _limits(robot):
    """(|v|, |vn| limit [m/s], |w| limit [rad/s], where they come from)."""
    limits = dict(DEFAULT_LIMITS)
    known = robot.limits                     # the controller's, if it answers
    source = "controller's [limits]" if known else "defaults; the controller did not answer"
    limits.update({k: v for k, v in known.items() if k in limits})
    return limits["limits.vel_lin_max"], limits["limits.vel_rot_max"], source


def _watch_robot(robot, silence, url, t):
    """Says (on its own line, the command line redrawn below it) when no OMNI4_MOTORS has come
    for 1 s (the commands go nowhere) and when the robot answers again."""
    from .status import silence_line
    age = robot.latest_age_s
    if age != float("inf"):
        silence.heard(silence.clock() - age)
    event = silence.check()
    if event:
        _say(silence_line(PROG, url, event, silence) + "\r\n")
        _say(t.line())


def _drive(robot, t, stdin_fd, joystick, js_path, silence=None):
    """Keys and joystick events into commands until quit, stdin closes or the replay ends;
    silence (status.Silence): said when no robot answers."""
    while not t.quit:
        live_js = joystick is not None and not joystick.ended
        fds = [stdin_fd]
        if live_js and joystick.fileno() is not None:
            fds.append(joystick.fileno())
        timeout = 0.1
        if live_js and joystick.replay:
            timeout = min(timeout, joystick.next_due() or 0.0)
        ready, _, _ = select.select(fds, [], [], timeout)
        changed = False
        if stdin_fd in ready:
            data = os.read(stdin_fd, 64)
            if not data:                      # stdin closed: stop and leave
                break
            for ch in data.decode("latin-1"):
                changed |= t.key(ch)
                if t.quit:
                    break
        if live_js:
            for ev in joystick.events():
                changed |= t.js_event(ev)
            if joystick.ended and not joystick.replay:
                t.v = [0.0, 0.0, 0.0]         # unplugged: stop
                changed = True
                _say(f"joystick {js_path} gone: stopped\r\n")
        if changed and not t.quit:
            robot.velocity(*t.v)
            _say(t.line())
        robot.check()
        if silence is not None:
            _watch_robot(robot, silence, robot.url, t)


def _main(argv):
    args, axes, error = _parse(argv)
    if error:
        return usage(PROG, error)
    if args.version:
        sys.stdout.write(f"{PROG} {__version__}\n")
        return 0
    try:
        joystick, js_path = _open_joystick(args)
    except OSError as e:
        return usage(PROG, f"--joystick {args.joystick}: {e.strerror}")
    from .robot import CommandRejected, Robot
    from .status import Silence
    silence = Silence()
    try:
        robot = Robot(args.lcm, keepalive_s=1.0 / args.rate)
    except (RuntimeError, ValueError) as e:
        return usage(PROG, str(e))
    term, status, old_handlers = None, 0, {}

    def on_signal(signum, _frame):
        raise KeyboardInterrupt

    try:
        for sig in (signal.SIGTERM, signal.SIGHUP):
            old_handlers[sig] = signal.signal(sig, on_signal)
        lin_max, rot_max, source = _limits(robot)
        t = Teleop(lin_max, rot_max, args.step_lin, args.step_rot, args.joy_lin, args.joy_rot,
                   axes)
        _say(f"{PROG} on {args.lcm}: limits |v|, |vn| <= {lin_max:g} m/s, "
             f"|w| <= {rot_max:g} rad/s ({source})\r\n")
        _say("w/s v  a/d vn  q/e w  space stop  +/- step  x quit"
             + (f"  joystick {js_path}" if joystick else "") + "\r\n")
        term = Terminal(sys.stdin.fileno())
        robot.velocity(0.0, 0.0, 0.0)
        _say(t.line())
        _drive(robot, t, sys.stdin.fileno(), joystick, js_path, silence)
    except KeyboardInterrupt:
        pass
    except CommandRejected as e:
        _say(f"{PROG}: {e}\r\n")
        status = 1
    finally:
        try:
            robot.close()                          # sends IDLE
        finally:
            if term is not None:
                term.restore()
            if joystick is not None:
                joystick.close()
            for sig, h in old_handlers.items():
                signal.signal(sig, h)
    _say("stopped (IDLE sent)\n")
    return status


def main(argv=None):
    """The console script: 0 quit, 1 run-time error, 2 usage; 141 quietly on a closed stdout."""
    from ._cli import run
    try:
        return run(PROG, _main, argv)
    except KeyboardInterrupt:
        return 0


if __name__ == "__main__":
    sys.exit(main())
