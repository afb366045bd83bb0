"""omni4-status: a one-shot status of the robot on an LCM URL.

Listens to OMNI4_MOTORS for a bounded time (--listen, default 1 s), then prints the controller's
mode, its latching faults and warnings by name, the measured loop rate and overruns, lost
samples (gaps in seq), the last currents, voltages and wheel speeds (one column per wheel of the
robot's latest robot_t on OMNI4_ROBOT, with a line on its layout; the paper's four without
one), and the [model] in force
(a LIST request to the controller's parameter service; "parameters: no answer" if it does not
answer in time), and the adapted motor constants (OMNI4_ADAPT: each R in use against the
identified, the estimates, supply, C in use, flags by name, the last acceptance or revert seen
on OMNI4_PARAM_CHANGED; "adapt: no OMNI4_ADAPT" without one). --watch repeats every second
until Ctrl-C: on a terminal it redraws the block in place (cursor home, clear to the end of
the screen), piped it writes one block after another. When no OMNI4_MOTORS has been heard for
NO_ROBOT_S (1 s) it says so on stderr at once (within the listening window, not at its end),
and says when the robot answers again.

Exit status: 0 done, 1 no OMNI4_MOTORS on the URL within the listening time, 2 usage error,
141 when stdout is closed early (omni4-status | head -1: quiet).
"""
import sys
import time

import lcm

from . import (CHANNEL_ADAPT, CHANNEL_MOTORS, CHANNEL_PARAM_CHANGED, CHANNEL_ROBOT,
               DEFAULT_LCM_URL, __version__, adapt_t, motors_t, param_changed_t, robot_t)
from . import adapt as adapt_words
from ._cli import usage
from ._keys import MODEL_KEYS, MODEL_WHEEL_KEYS

PROG = "omni4-status"
RX_QUEUE_MESSAGES = 100000      # LCM's receive queue for OMNI4_MOTORS (100 s at 1 kHz)
NO_ROBOT_S = 1.0                # no OMNI4_MOTORS this long [s]: "no robot answers"
POLL_MS = 100                   # a listening window looks at the silence this often [ms]
REDRAW = "\x1b[H\x1b[J"          # a terminal's cursor home + clear to the end of the screen
# The names, bits and latching set of every tool: core's vocab.def (omni4/_vocab.py).
from ._vocab import FAULT_BITS, LATCHING, MODE_NAMES, fault_names, mode_name  # noqa: E402,F401


class Window:
    """What one listening window saw on OMNI4_MOTORS."""

    def __init__(self, samples, seconds):
        self.samples = samples
        self.seconds = seconds
        self.n = len(samples)
        self.last = samples[-1] if samples else None

    @property
    def rate_hz(self):
        """Loop rate from the controller's own clock: ticks per second of utime."""
        a, b = self.samples[0], self.samples[-1]
        if self.n < 2 or b.utime <= a.utime or b.seq <= a.seq:
            return float("nan")
        return (b.seq - a.seq) / ((b.utime - a.utime) * 1e-6)

    @property
    def lost(self):
        """Samples missing between the first and the last seen (seq gaps)."""
        if self.n < 2:
            return 0
        return sum(max(0, b.seq - a.seq - 1) for a, b in zip(self.samples, self.samples[1:]))

    @property
    def overruns(self):
        return sum(1 for m in self.samples if m.faults & motors_t.FAULT_OVERRUN)

    @property
    def seen_bits(self):
        bits = 0
        for m in self.samples:
            bits |= m.faults
        return bits


class AdaptSeen:
    """The adapted constants heard so far: the last adapt_t (None before one) and the last
    acceptance or revert (omni4.adapt.Events; kept over --watch's windows)."""

    def __init__(self):
        self.last = None
        self.events = adapt_words.Events()

    def on_adapt(self, _channel, data):
        try:
            self.last = adapt_t.decode(data)
        except ValueError:          # another type on the channel
            pass

    def on_changed(self, _channel, data):
        try:
            self.events.take(param_changed_t.decode(data))
        except ValueError:
            pass


class RobotSeen:
    """The robot's layout heard so far: the Wheels of the latest robot_t (None before one: the
    paper's four; a robot_t that describes no robot is left out, its reason in `refused`)."""

    def __init__(self):
        self.wheels = None
        self.refused = None

    def on_robot(self, _channel, data):
        from .wheels import Wheels
        try:
            wheels, why = Wheels.from_robot(robot_t.decode(data))
        except ValueError:          # another type on the channel
            return
        if wheels is None:
            self.refused = why
        else:
            self.wheels = wheels


def layout_line(wheels):
    """The robot's layout in one line: its wheels' angles [deg] and distances [m]."""
    return (f"wheels: {wheels.count} at " + " ".join(
        f"{round(a * 57.29577951308232, 1):g}" for a in wheels.angle_rad) + " deg, d " +
        " ".join(f"{d:g}" for d in wheels.distance_m) + " m (OMNI4_ROBOT)")


class Silence:
    """Whether a stream is silent: check() returns "lost" once when nothing has been heard for
    timeout_s [s] (since the start, or since the last message), "back" once when a message is
    heard after that, else None. heard() notes a message; clock: monotonic [s]."""

    def __init__(self, timeout_s=NO_ROBOT_S, clock=time.monotonic):
        self.timeout_s = float(timeout_s)
        self.clock = clock
        self.start = clock()
        self.last = None             # clock time of the last message heard
        self.silent = False
        self.lost_at = None          # clock time of the last message (or the start) before
        self.gap_s = 0.0             # the length of the last silence that ended [s]

    def heard(self, t=None):
        self.last = self.clock() if t is None else t

    def check(self):
        ref = self.start if self.last is None else self.last
        quiet = self.clock() - ref >= self.timeout_s
        if quiet == self.silent:
            return None
        self.silent = quiet
        if quiet:
            self.lost_at = ref
            return "lost"
        self.gap_s = self.last - self.lost_at
        return "back"


def silence_line(prog, url, event, silence):
    """The line a tool says for a Silence event ("lost" or "back")."""
    if event == "lost":
        return (f"{prog}: no robot answers on {url}: no {CHANNEL_MOTORS} for "
                f"{silence.timeout_s:g} s (is omni4-fw running on this URL?)")
    return (f"{prog}: the robot on {url} answers again ({CHANNEL_MOTORS} after "
            f"{silence.gap_s:.1f} s of silence)")


def listen(lc, seconds, poll=None, adapt=None, robot=None):
    """The motors_t samples that arrive within `seconds` [s] on lc; poll(count so far) is
    called at least every POLL_MS while it listens; adapt (an AdaptSeen) notes OMNI4_ADAPT and
    the acceptances and reverts on OMNI4_PARAM_CHANGED meanwhile, robot (a RobotSeen) the
    robot_t on OMNI4_ROBOT."""
    got = []

    def on_motors(_channel, data):
        try:
            got.append(motors_t.decode(data))
        except ValueError:          # another type on the channel
            pass

    sub = lc.subscribe(CHANNEL_MOTORS, on_motors)
    sub.set_queue_capacity(RX_QUEUE_MESSAGES)
    subs = [sub]
    if adapt is not None:
        subs += [lc.subscribe(CHANNEL_ADAPT, adapt.on_adapt),
                 lc.subscribe(CHANNEL_PARAM_CHANGED, adapt.on_changed)]
    if robot is not None:
        subs.append(lc.subscribe(CHANNEL_ROBOT, robot.on_robot))
    try:
        end = time.monotonic() + seconds
        while True:
            left = end - time.monotonic()
            if left <= 0:
                break
            lc.handle_timeout(max(1, min(POLL_MS, int(left * 1000))))
            if poll is not None:
                poll(len(got))
    finally:
        for s in subs:
            lc.unsubscribe(s)
    return Window(got, seconds)


def read_model(url, timeout_s):
    """The [model] in force as [(key, text, unit)] of the scalar keys, then each drive's own key
    (R_0, ...; not printed in the model line), or None when the controller did not answer."""
    from .params import ParamClient, ParamError
    try:
        client = ParamClient(url, timeout_s=timeout_s, retries=1)
    except ParamError:
        return None
    try:
        params = client.get_many([f"model.{k}" for k in MODEL_KEYS + MODEL_WHEEL_KEYS])
    except ParamError:
        return None
    finally:
        client.close()
    return [(p.name, p.text, p.unit) for p in params]


def _vec(values, fmt="{:+.3f}"):
    return " ".join(fmt.format(x) for x in values)


def adapt_lines(adapt, model):
    """The adapted constants' lines (omni4.adapt.summary_lines), each R in use against the
    identified R_j of the [model] asked for (none when it did not answer)."""
    if adapt is None:
        return []
    if adapt.last is None:
        return [f"adapt: no {CHANNEL_ADAPT} (an omni4-fw without the online estimation?)"]
    identified = adapt_words.identified_r({k: t for k, t, _ in model}) if model else None
    return adapt_words.summary_lines(adapt.last, identified, adapt.events)


def report(url, w, model, adapt=None, wheels=None):
    """The status as text (lines); adapt: an AdaptSeen (None: no adapt lines); wheels: the
    robot_t's Wheels (the per-wheel lines show its wheels, after a line on its layout; None:
    the paper's four, as before robot_t)."""
    m = w.last
    per_wheel = (lambda a: a) if wheels is None else wheels.take
    latched = m.faults & LATCHING
    warnings = w.seen_bits & ~LATCHING & ~motors_t.FAULT_OVERRUN
    lines = [
        f"robot on {url} ({w.n} samples in {w.seconds:g} s)",
        f"mode: {mode_name(m.mode)}",
        "faults: " + (" ".join(fault_names(latched)) or "none"),
        "warnings: " + (" ".join(fault_names(warnings)) or "none") + " (seen in the window)",
        f"loop: {w.rate_hz:.1f} Hz, overruns {w.overruns}, lost samples {w.lost}",
        *([] if wheels is None or wheels.is_paper_geometry() else [layout_line(wheels)]),
        f"current [A]: {_vec(per_wheel(m.current))}",
        f"voltage [V]: {_vec(per_wheel(m.voltage))}",
        f"wheel speed [rad/s]: {_vec(per_wheel(m.wheel_speed))}",
    ]
    if model is False:
        lines.append("parameters: not asked (the robot fell silent)")
    elif model is None:
        lines.append("parameters: no answer")
    else:
        scalars = [p for p in model if p[0] in MODEL_KEYS]
        lines.append("model: " + " ".join(
            f"{k}={t}" + (f" {u}" if u else "") + ("," if i + 1 < len(scalars) else "")
            for i, (k, t, u) in enumerate(scalars)))
    return lines + adapt_lines(adapt, model or None)


EPILOG = f"""\
Prints: mode; latching faults and (in the window) warnings by name; loop rate [Hz] from the
controller's clock, OVERRUN ticks and lost samples (gaps in seq) in the window; the last
currents [A], voltages [V] and wheel speeds [rad/s] of motors 0-3 (of a robot that describes
another layout on OMNI4_ROBOT: a line "wheels: N at ANGLES deg, d DISTANCES m", then one value
per wheel, the latest robot_t's); the [model] in force
(asked from the controller; "parameters: no answer" if it does not answer); the adapted motor
constants (OMNI4_ADAPT): each R in use [ohm] and its change from the identified [%], the
estimates, supply [V], Coulomb frictions in use, flags by name, the last acceptance or revert.
--watch: redrawn in place on a terminal, one block after another when piped. No OMNI4_MOTORS
for 1 s: "no robot answers" on stderr at once, and a line when it answers again.
Exit status: 0 done, 1 no OMNI4_MOTORS within the listening time (is omni4-fw running?),
2 usage error, 141 when stdout is closed early (omni4-status | head -1).
example: omni4-status --lcm {DEFAULT_LCM_URL} --listen 2"""


def build_parser():
    from ._cli import bus_tool_parser

    p = bus_tool_parser(PROG, "One-shot status of the omni4 robot on an LCM URL.", EPILOG)
    p.add_argument("--listen", type=float, default=1.0, metavar="S",
                   help="listen to OMNI4_MOTORS for S seconds (default 1)")
    p.add_argument("--timeout", type=float, default=0.5, metavar="S",
                   help="wait for the parameter answer [s] per try, 2 tries (default 0.5)")
    p.add_argument("--watch", action="store_true",
                   help="repeat every second until Ctrl-C (in place on a terminal)")
    p.add_argument("--version", action="store_true", help="print the version and exit")
    return p


def _main(argv):
    args = build_parser().parse_args(argv)
    if args.version:
        sys.stdout.write(f"{PROG} {__version__}\n")
        return 0
    if not (0 < args.listen <= 3600):
        return usage(PROG, "--listen must be in (0, 3600] s")
    if not (0 < args.timeout <= 60):
        return usage(PROG, "--timeout must be in (0, 60] s")
    try:
        lc = lcm.LCM(args.lcm)
    except Exception as e:  # lcm raises a bare RuntimeError
        return usage(PROG, f"cannot open LCM URL {args.lcm}: {e}")
    tty = args.watch and sys.stdout.isatty()
    silence = Silence()
    adapt = AdaptSeen()
    robot = RobotSeen()
    seen = [0]

    def poll(n):
        if n > seen[0]:
            silence.heard()
        seen[0] = n
        event = silence.check()
        if event:
            sys.stderr.write(silence_line(PROG, args.lcm, event, silence) + "\n")
            sys.stderr.flush()

    first = True
    while True:
        t0 = time.monotonic()
        seen[0] = 0
        w = listen(lc, args.listen, poll, adapt, robot)
        if robot.refused:
            sys.stderr.write(f"{PROG}: {CHANNEL_ROBOT} ignored: {robot.refused}\n")
            robot.refused = None
        if w.last is None:
            if not args.watch:
                sys.stderr.write(f"{PROG}: no {CHANNEL_MOTORS} on {args.lcm} within "
                                 f"{args.listen:g} s: is omni4-fw running?\n")
                return 1
        else:
            # A robot silent for half the time already is not asked: the unanswered request
            # would hold back the "no robot answers" line by up to 2 x --timeout.
            quiet = silence.clock() - silence.last >= NO_ROBOT_S / 2
            lines = report(args.lcm, w, False if quiet else read_model(args.lcm, args.timeout),
                           adapt, robot.wheels)
            if tty and silence.lost_at is not None:
                lines.append(f"last silence: {silence.gap_s:.1f} s without {CHANNEL_MOTORS}")
            block = time.strftime("%H:%M:%S ") + "\n".join(lines) + "\n"
            sys.stdout.write((REDRAW if tty else "" if first else "\n") + block)
            sys.stdout.flush()
            first = False
        if not args.watch:
            return 0
        rest = 1.0 - (time.monotonic() - t0)
        if rest > 0:
            seen[0] = 0
            listen(lc, rest, poll, adapt, robot)  # the silence is watched in between too


def main(argv=None):
    """The console script: status 0 / 1 / 2; Ctrl-C ends --watch with 0 (130 for a one-shot
    run); --version with the git description (omni4._cli); a closed stdout ends it quietly with
    141."""
    from ._cli import run
    args = sys.argv[1:] if argv is None else list(argv)
    try:
        return run(PROG, _main, args)
    except KeyboardInterrupt:
        return 0 if "--watch" in args else 130


if __name__ == "__main__":
    sys.exit(main())
