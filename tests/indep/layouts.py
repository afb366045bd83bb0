"""A "foreign" experiment runner: timelines of the paper's experiments in many layouts.

Each layout renders a COMPLETE set of experiments (steady rotation along w, coast-downs along
v, vn, w, the constant-voltage motor test, ramped steps along v, vn, w), so each layout alone can
be identified. What differs is where, inside a segment, the drive is: marks before the drive at
rest, ramps down in VOLTAGE mode, pushes by hand with the bridges off, several levels per segment,
subsets of motors, jittered marks and lost samples, other loop rates.

The motor test is the runner's (docs/identification.md): one motor at a time, the other three at
0 V with the bridges driven, each motor at three levels forwards then backwards. `subset` (and
--motor-subset) keep motor tests that drive two motors at once or axis patterns, as logs
recorded before the runner drove one motor at a time do.

A timeline is open loop (voltages, bridge state and external push per tick, plus the marks). Waits
that a person or a careful runner would time by watching the robot (hold until steady, wait until
it stopped) are planned here from the robot's true parameters with closed forms, with margins;
write_logs.py checks after the simulation that the robot is really at rest where a layout says so.

Units: s, V, N, N m; ticks of length dt.
"""
import numpy as np

import plant

LAYOUTS = ("runner", "rest", "rampdown", "hand", "multilevel", "subset", "jitter",
           "rate500", "rate2k", "sensors")
#: The layouts with ideal sensors: what `all` means (`sensors` is asked for by name).
IDEAL_LAYOUTS = LAYOUTS[:-1]
KINDS = ("steady_rotation", "coast", "motor", "step")
#: The `sensors` layout renders robot k as SENSORS_BASES[k % 9] (same timeline and noise as
#: robot k of that layout) and switches every real-sensor effect on (write_logs.py).
SENSORS_BASES = ("runner", "rest", "rampdown", "hand", "multilevel", "jitter", "subset",
                 "rate500", "rate2k")

#: loop rate [Hz] and encoder counts per wheel revolution of each layout.
LAYOUT_RATE_HZ = {"rate500": 500.0, "rate2k": 2000.0}
LAYOUT_CPR = {"runner": 10240, "rest": 8192, "rampdown": 16384, "hand": 4096,
              "multilevel": 12000, "subset": 10240, "jitter": 5000, "rate500": 16384,
              "rate2k": 8192}


def base_layout(layout, robot):
    """The layout whose timeline robot number `robot` runs in `layout` (itself, except in
    `sensors`, which cycles through SENSORS_BASES)."""
    if layout == "sensors":
        return SENSORS_BASES[int(robot) % len(SENSORS_BASES)]
    return layout


def loop_rate_hz(layout, robot=0):
    """Nominal loop rate [Hz] of robot number `robot` in `layout`."""
    return LAYOUT_RATE_HZ.get(base_layout(layout, robot), 1000.0)


class Run:
    """One experiment run: kind, direction label, voltage pattern (4,) per volt, levels [V]."""

    def __init__(self, kind, direction, pattern, levels, ramp=0.4):
        self.kind, self.direction = kind, direction
        self.pattern = np.asarray(pattern, float)
        self.levels = list(levels)
        self.ramp = ramp

    def __repr__(self):
        return f"Run({self.kind},{self.direction},{self.pattern.tolist()},{self.levels})"


class Timeline:
    """Per-tick inputs of one robot and its experiment marks, built front to back.

    Arrays per tick: u (4,) [V] (float32, what the log reports), mode, fext (3,) [N, N, N m].
    Marks: (time [s], kind, direction, level [V]). rest_checks: tick indices where the robot
    must be at rest (verified after the simulation).
    """

    def __init__(self, dt, model, i):
        self.dt, self.model, self.i = dt, model, i
        self._u, self._mode, self._fext = [], [], []
        self.u_now = np.zeros(4)
        self.marks, self.rest_checks = [], []
        self.n = 0
        self.speed_bound = np.zeros(3)   # upper bound of |velocity| per axis right now

    @property
    def t(self):
        """Time of the next tick [s]."""
        return self.n * self.dt

    def _ticks(self, seconds):
        return max(1, int(round(seconds / self.dt)))

    def _append(self, u, mode, fext):
        k = len(mode)
        self._u.append(np.asarray(u, np.float32).reshape(k, 4))
        self._mode.append(np.asarray(mode, np.int8))
        self._fext.append(np.asarray(fext, float).reshape(k, 3))
        self.n += k

    def mark(self, kind, direction="", level=0.0, offset=0.0):
        """Experiment mark at the next tick's time plus offset [s]."""
        self.marks.append((self.t + offset, kind, direction, float(level)))

    def check_rest(self):
        """Ask the writer to verify that the robot is at rest at the next tick."""
        self.rest_checks.append(self.n)

    def idle(self, seconds, mode=plant.MODE_IDLE):
        """Bridges off, no push, for `seconds` [s] (the robot coasts if it moves)."""
        k = self._ticks(seconds)
        self._append(np.zeros((k, 4)), np.full(k, mode), np.zeros((k, 3)))
        self.u_now = np.zeros(4)
        self._decay(seconds)

    def coast_to_rest(self, mode=plant.MODE_COAST, margin=0.3):
        """Bridges off until the robot has surely stopped (planned), plus margin [s]."""
        wait = float(np.max(plant.stop_time(self.model, self.i, self.speed_bound))) + margin
        self.idle(wait, mode)
        self.speed_bound = np.zeros(3)

    def ramp_to(self, u_target, seconds):
        """VOLTAGE mode, linear ramp from the present voltages to u_target (4,) [V]."""
        u_target = np.clip(np.asarray(u_target, float), -plant.SUPPLY_V, plant.SUPPLY_V)
        k = self._ticks(seconds)
        frac = (np.arange(1, k + 1) / k)[:, None]
        u = self.u_now[None] + (u_target - self.u_now)[None] * frac
        self._append(u, np.full(k, plant.MODE_VOLTAGE), np.zeros((k, 3)))
        self.u_now = u_target
        self._drive_bound(u_target)

    def hold(self, seconds):
        """VOLTAGE mode, present voltages held for `seconds` [s]."""
        k = self._ticks(seconds)
        self._append(np.repeat(self.u_now[None], k, 0), np.full(k, plant.MODE_VOLTAGE),
                     np.zeros((k, 3)))

    def push(self, axis, peak, width, leak, mode=plant.MODE_COAST):
        """Hand push with the bridges off: half-sine force along `axis` (0 v, 1 vn, 2 w).

        peak [N or N m], width [s]; leak (3,) fraction of the peak reaching each axis (a force
        becomes a torque through the lever d, a torque a force through 1/d).
        """
        k = self._ticks(width)
        tm = (np.arange(k) + 0.5) * self.dt
        shape = np.sin(np.pi * tm / (k * self.dt))
        d = plant.TABLE_III["d"]
        f = np.zeros(3)
        f[axis] = peak
        for ax in range(3):
            if ax != axis:
                conv = d if ax == 2 else (1.0 / d if axis == 2 else 1.0)
                f[ax] = peak * leak[ax] * conv
        self._append(np.zeros((k, 4)), np.full(k, mode), shape[:, None] * f[None])
        self.u_now = np.zeros(4)
        m = self.model["m"][self.i]
        self.speed_bound = self.speed_bound + np.abs(f) * width * 2.0 / np.pi / m

    def _drive_bound(self, u):
        ss = np.abs(plant.steady_state(self.model, self.i, u))
        self.speed_bound = np.maximum(self.speed_bound, ss)

    def _decay(self, seconds):
        stop = plant.stop_time(self.model, self.i, self.speed_bound)
        self.speed_bound = np.where(stop <= seconds, 0.0, self.speed_bound)

    def settle_time(self, u, factor, minimum):
        """Hold time [s] to settle under u: max(minimum, factor x slowest moving axis's tau)."""
        ss = plant.steady_state(self.model, self.i, u)
        tau = plant.time_constant(self.model, self.i, driven=True)
        moving = np.abs(ss) > 0
        return max(minimum, factor * float(np.max(np.where(moving, tau, 0.0))))

    def arrays(self):
        """(u (T,4) float32 [V], mode (T,) int8, fext (T,3) [N, N, N m])."""
        return (np.concatenate(self._u), np.concatenate(self._mode), np.concatenate(self._fext))


# ---- the experiment set ---------------------------------------------------------------------

def pattern_direction(pattern, d=plant.TABLE_III["d"], fm=None):
    """Direction label of a voltage pattern: the single robot axis it drives, else "".
    fm: the layout's force map (3x4, eqs 9-11), default the paper's at distance d."""
    F = (plant.force_matrix(d) if fm is None else fm) @ np.asarray(pattern, float)
    nz = np.abs(F) > 1e-9 * max(1.0, float(np.max(np.abs(F))))
    return plant.AXES[int(np.argmax(nz))] if nz.sum() == 1 else ""


def subset_motor_runs(subset, levels, patterns=plant.PATTERNS, fm=None):
    """Motor-test runs that drive only the motors in `subset`: masked axis patterns (the
    layout's, force map fm), then single motors, as many runs as there are levels [V]."""
    mask = np.array([1.0 if j in subset else 0.0 for j in range(4)])
    cands = []
    for name in ("v", "vn", "w"):
        pat = np.array(patterns[name]) * mask
        if np.any(pat) and not any(np.array_equal(pat, c) for c in cands):
            cands.append(pat)
    for j in sorted(subset):
        single = np.eye(4)[j]
        if not any(np.array_equal(single, c) for c in cands):
            cands.append(single)
    runs = []
    for k, level in enumerate(levels):
        pat = cands[k % len(cands)]
        runs.append(Run("motor", pattern_direction(pat, fm=fm), pat, [level]))
    return runs


#: Motor-test levels [V] of the one-motor-at-a-time runs (each jittered per run).
ONE_MOTOR_LEVELS = (4.2, 8.3, 10.8)


def one_motor_runs(jit, multilevel=False, n_wheels=4):
    """The runner's motor test: each motor alone (the other three at 0 V, bridges driven), at
    each level forwards then backwards, one run each; with `multilevel` one segment per motor
    and sign holding the levels one after the other. Direction "" (one wheel drives no single
    robot axis); the level is the motor's signed voltage [V]. n_wheels motors (3 or 4)."""
    runs = []
    for j in range(n_wheels):
        single = np.eye(4)[j]
        if multilevel:
            runs += [Run("motor", "", single, [sign * jit(lv) for lv in ONE_MOTOR_LEVELS])
                     for sign in (1.0, -1.0)]
        else:
            runs += [Run("motor", "", single, [sign * jit(lv)])
                     for lv in ONE_MOTOR_LEVELS for sign in (1.0, -1.0)]
    return runs


#: The `subset` layout's motor test on the paper's layout: (pattern, level [V]).
SUBSET_PAPER = (((1, 0, -1, 0), 5.0), ((0, -1, 0, 1), 9.0), ((1, 0, 1, 0), 6.5),
                ((0, 1, 0, 1), 10.0), ((1, 0, 0, 0), 7.0), ((0, 0, 0, 1), 4.5))


def subset_patterns(n_wheels):
    """The `subset` layout's motor test on a layout of its own: pairs of motors against each
    other and together, then single motors; (pattern, level [V])."""
    e = np.eye(4)
    last = n_wheels - 1
    pats = (e[0] - e[1], e[1] - e[last], e[0] + e[2], e[1] + e[last] if n_wheels == 4
            else e[0] + e[1], e[0], e[last])
    return tuple((tuple(p), lv) for p, (_, lv) in zip(pats, SUBSET_PAPER))


def experiment_set(rng, multilevel=False, subset_layout=False, motor_subset=None,
                   layout=None):
    """The runs of one complete experiment set, levels jittered per robot by rng.

    layout: None (the paper's) or (axis patterns (plant.axis_patterns), n_wheels, force map
    3x4) of a robot with its own layout: its least-norm patterns drive the experiments along
    v, vn and w, its n_wheels motors the motor test."""
    patterns, n_wheels, fm = (plant.PATTERNS, 4, None) if layout is None else layout

    def jit(x):
        return round(float(x + rng.uniform(-0.15, 0.15)), 2)

    def ramp():
        return float(rng.uniform(0.3, 0.8))

    runs = []
    steady = [3.3, 4.6, 5.9, 7.2, 8.5, 9.6] if multilevel else [3.3, 4.6, 5.9, 7.2, 8.5]
    if multilevel:
        for a, b in ((0, 2), (1, 4), (3, 5)):
            runs.append(Run("steady_rotation", "w", patterns["w"],
                            [jit(steady[a]), jit(steady[b])]))
    else:
        for lv in steady:
            runs.append(Run("steady_rotation", "w", patterns["w"], [jit(lv)]))
    coast = {"v": (6.0, 10.5), "vn": (6.5, 11.0), "w": (4.5, 9.5)}
    for ax, lvls in coast.items():
        if multilevel:
            runs.append(Run("coast", ax, patterns[ax], [jit(x) for x in lvls]))
        else:
            runs += [Run("coast", ax, patterns[ax], [jit(x)]) for x in lvls]
    motor = [("v", 5.2), ("v", 10.2), ("vn", 8.3), ("w", 4.2), ("w", 10.8)]
    if subset_layout:
        runs += [Run("motor", pattern_direction(p, fm=fm), p, [jit(lv)]) for p, lv in (
            SUBSET_PAPER if layout is None else subset_patterns(n_wheels))]
    elif motor_subset:
        if max(motor_subset) >= n_wheels:
            named = ",".join(map(str, motor_subset))
            raise ValueError(f"--motor-subset {named}: the robot has motors 0..{n_wheels - 1}")
        runs += subset_motor_runs(motor_subset, [jit(lv) for _, lv in motor], patterns, fm)
    else:
        runs += one_motor_runs(jit, multilevel, n_wheels)
    step = {"v": (4.8, 9.2), "vn": (5.6, 10.1), "w": (3.9, 7.7)}
    for ax, lvls in step.items():
        if multilevel:
            runs.append(Run("step", ax, patterns[ax], [jit(x) for x in lvls], ramp()))
        else:
            runs += [Run("step", ax, patterns[ax], [jit(x)], ramp()) for x in lvls]
    return runs


def parse_omit(items):
    """['coast', 'coast:w', ...] -> set of (kind, direction or None); raises ValueError."""
    out = set()
    for item in items or ():
        kind, _, direction = item.partition(":")
        if kind not in KINDS:
            raise ValueError(f"--omit {item}: kind must be one of {', '.join(KINDS)}")
        if direction and direction not in plant.AXES:
            raise ValueError(f"--omit {item}: direction must be one of {', '.join(plant.AXES)}")
        out.add((kind, direction or None))
    return out


def omitted(run, omit):
    """True if the run matches an --omit entry."""
    return (run.kind, None) in omit or (run.kind, run.direction) in omit


# ---- rendering --------------------------------------------------------------------------------

def _drive(tl, run, level, ramp):
    """Ramp up to pattern x level [V], then hold in VOLTAGE mode: steady rotation until steady
    (8 time constants, >= 2.5 s), motor test 6 (>= 2 s), step 4 (>= 2 s); before a coast-down
    just long enough to be near speed (2.5, >= 1.2 s)."""
    u = run.pattern * level
    tl.ramp_to(u, ramp)
    factor, minimum = {"steady_rotation": (8.0, 2.5), "motor": (6.0, 2.0),
                       "step": (4.0, 2.0)}.get(run.kind, (2.5, 1.2))
    tl.hold(tl.settle_time(u, factor, minimum))


def _ramp(run, rng):
    """Ramp-up time [s]: the step's own (0.3-0.8 s), else 0.3-0.5 s."""
    return run.ramp if run.kind == "step" else float(rng.uniform(0.3, 0.5))


def render_runner(tl, run, rng, jitter=0.0):
    """Plain runner: mark, ramp, hold, end + COAST to rest; coast: drive, mark at COAST, end.

    jitter [s]: marks land up to this far off the mode changes (uniform, either side).
    """
    def off():
        return float(rng.uniform(-jitter, jitter)) if jitter else 0.0

    for level in run.levels:
        if run.kind == "coast":
            _drive(tl, run, level, _ramp(run, rng))
            tl.mark("coast", run.direction, level, off())
            tl.coast_to_rest(margin=float(rng.uniform(0.2, 0.4)))
            tl.mark("end", offset=off())
        else:
            tl.mark(run.kind, run.direction, level, off())
            _drive(tl, run, level, _ramp(run, rng))
            tl.mark("end", offset=off())
            tl.coast_to_rest(margin=0.2)
        tl.idle(float(rng.uniform(0.2, 0.4)))


def render_rest(tl, run, rng):
    """Mark 0.5-1.5 s before the drive (robot at rest, IDLE), drive, COAST to a stop, rest in
    IDLE 0.5-1.2 s, end. Several levels: steady rotation and motor test ramp from one level to
    the next while driving; steps and coast-downs stop and rest 1 s in IDLE in between."""
    tl.mark(run.kind, run.direction, run.levels[0])
    tl.check_rest()
    tl.idle(float(rng.uniform(0.5, 1.5)))
    if run.kind in ("steady_rotation", "motor"):
        for n, level in enumerate(run.levels):
            if n == 0:
                _drive(tl, run, level, _ramp(run, rng))
            else:
                tl.ramp_to(run.pattern * level, 0.3)
                tl.hold(tl.settle_time(run.pattern * level, 8.0, 2.5))
        tl.coast_to_rest(margin=0.1)
    else:
        for n, level in enumerate(run.levels):
            if n:
                tl.idle(1.0)
                tl.check_rest()
            _drive(tl, run, level, _ramp(run, rng))
            tl.coast_to_rest(margin=0.1)
    tl.idle(float(rng.uniform(0.5, 1.2)))
    tl.check_rest()
    tl.mark("end")
    tl.idle(float(rng.uniform(0.1, 0.3)))


def render_rampdown(tl, run, rng):
    """As the runner, but every drive ends with a 0.3-0.5 s ramp down in VOLTAGE mode: to 0 V
    before the end mark; before a coast-down the coast mark comes first and the segment opens
    with the ramp down to 30-50 % of the level, then COAST."""
    for level in run.levels:
        down = float(rng.uniform(0.3, 0.5))
        if run.kind == "coast":
            _drive(tl, run, level, _ramp(run, rng))
            tl.mark("coast", run.direction, level)
            tl.ramp_to(run.pattern * level * rng.uniform(0.3, 0.5), down)
            tl.coast_to_rest(margin=float(rng.uniform(0.2, 0.4)))
            tl.mark("end")
        else:
            tl.mark(run.kind, run.direction, level)
            _drive(tl, run, level, _ramp(run, rng))
            tl.ramp_to(np.zeros(4), down)
            tl.mark("end")
            tl.coast_to_rest(margin=0.2)
        tl.idle(float(rng.uniform(0.2, 0.4)))


def render_hand(tl, run, rng):
    """Coast-downs pushed by hand, bridges off (COAST or IDLE) for the whole segment; the
    other experiments as in `rest`."""
    if run.kind != "coast":
        return render_rest(tl, run, rng)
    axis = plant.AXES.index(run.direction)
    mode = plant.MODE_COAST if rng.uniform() < 0.5 else plant.MODE_IDLE
    for level in run.levels:
        strong = level > 8.0
        tl.mark("coast", run.direction, 0.0)
        tl.check_rest()
        tl.idle(float(rng.uniform(0.5, 1.2)), mode)
        width = float(rng.uniform(0.2, 0.6))
        m = tl.model["m"][tl.i][axis]
        C = tl.model["C"][tl.i][axis]
        target = rng.uniform(1.2, 1.8) if strong else rng.uniform(0.6, 1.0)   # m/s
        if axis == 2:
            target *= 8.0                                                    # rad/s
        peak = (target * m + C * width) * np.pi / (2.0 * width)
        lo, hi = (0.5, 1.5) if axis == 2 else (8.0, 20.0)
        peak = float(np.clip(peak, lo, hi))
        leak = rng.uniform(0.01, 0.04, size=3)
        tl.push(axis, peak, width, leak, mode)
        tl.coast_to_rest(mode=mode, margin=0.1)
        tl.idle(float(rng.uniform(0.5, 1.0)), mode)
        tl.check_rest()
        tl.mark("end")
        tl.idle(0.2)


def render(layout, tl, runs, rng):
    """Render all runs of one robot in `layout` onto tl (with leading and trailing rest)."""
    tl.idle(float(rng.uniform(0.8, 1.5)))
    for run in runs:
        if layout in ("runner",):
            render_runner(tl, run, rng)
        elif layout == "jitter":
            render_runner(tl, run, rng, jitter=0.05)
        elif layout == "rampdown":
            render_rampdown(tl, run, rng)
        elif layout == "hand":
            render_hand(tl, run, rng)
        else:   # rest, multilevel, subset, rate500, rate2k
            render_rest(tl, run, rng)
    tl.idle(1.0)


def build(layout, model, i, seed, robot, omit=(), motor_subset=None):
    """Timeline of robot i (index into model) / robot number `robot` in `layout`.

    Returns (Timeline, dt [s], cpr). Deterministic per (seed, robot, base layout): in `sensors`
    the timeline is the one robot `robot` runs in its base layout.
    """
    if layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r} (one of {', '.join(LAYOUTS)})")
    layout = base_layout(layout, robot)
    rng = np.random.default_rng([int(seed), int(robot), LAYOUTS.index(layout), 11])
    dt = 1.0 / loop_rate_hz(layout)
    own = None
    if model.get("has_layout") is not None and model["has_layout"][i]:
        own = (model["patterns"][i], int(model["n_wheels"][i]), model["IK"][i].T)
    runs = experiment_set(rng, multilevel=layout == "multilevel",
                          subset_layout=layout == "subset", motor_subset=motor_subset,
                          layout=own)
    runs = [r for r in runs if not omitted(r, omit)]
    tl = Timeline(dt, model, i)
    render(layout, tl, runs, rng)
    return tl, dt, LAYOUT_CPR[layout]
