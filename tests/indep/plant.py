"""Independent plant of the four-wheeled omni-directional robot (Oliveira et al.).

Written from the paper's equations only (no code shared with the project's model):

* kinematics (eq 2): wheel linear speeds v_j = IK x, x = [v, vn, w] in the robot frame;
* DC motors (eq 21, inductance neglected): i_j = (u_j - Kv l v_j / r) / R while the bridges are
  driven (modes VOLTAGE, VELOCITY); i_j = 0 with the bridges disabled (IDLE, COAST, FAULT, ESTOP);
* wheel forces f_j = l Kt i_j / r (eqs 12-13), robot forces Fv = f3 - f1, Fvn = f0 - f2,
  T = d (f0 + f1 + f2 + f3) (eqs 9-11);
* dynamics (eqs 6-8) with viscous (B) and Coulomb (C) friction and stiction, plus an external
  force / torque (a hand push);
* any wheel layout ([model] wheels 3 or 4, wheel_angle_j [deg], d_j [m]; ik_rows): eq 2's row j
  is [-sin a_j, cos a_j, d_j], the force map its transpose; a three-wheel robot's slot 3 holds
  no wheel (0 V, 0 A, 0 rad/s). An asymmetric layout couples the axes through the back-EMF.

Integration: within one loop tick the voltage is held (zero-order hold, as the controller applies
it) and the external force is taken at the tick's midpoint, so every axis obeys the linear ODE
m dx/dt = F - Beff x - C s with constant coefficients and the sign s of the motion. That ODE is
solved exactly (exponential); a zero crossing inside a tick is located exactly, and from rest the
axis breaks away only if the applied force exceeds C. Arrays carry a leading robot axis, so any
number of robots advance in one pass.

Real sensors (drawn per robot by sensor_params, each switched on by the caller): a constant
current-sense offset per motor channel, an eccentric encoder disc on each motor shaft, loop ticks
that wake late (the plant integrates over the true intervals), camera frames that reach the log
20-60 ms after capture, and lost messages.

Units: SI throughout (m, s, rad, V, A, N, N m, kg, kg m^2); utime in microseconds.
"""
import itertools

import numpy as np

MODE_IDLE, MODE_VELOCITY, MODE_VOLTAGE, MODE_COAST = 0, 1, 2, 3
DRIVEN_MODES = (MODE_VELOCITY, MODE_VOLTAGE)
AXES = ("v", "vn", "w")
SUPPLY_V = 12.0

#: The paper's Table III robot.
TABLE_III = {
    "d": 0.089, "r": 0.0325, "l": 5.0, "Kv": 0.0259, "Kt": 0.0259, "R": 4.3111,
    "M": 2.34, "J": 0.0228, "Bv": 0.4978, "Bvn": 0.6763, "Bw": 0.0141,
    "Cv": 1.8738, "Cvn": 2.2198, "Cw": 0.1385,
}
#: Parameters drawn per robot as Table III times an independent U(0.7, 1.3) factor (Kt = Kv).
SCALED = ("J", "Bv", "Bvn", "Bw", "Cv", "Cvn", "Cw", "R", "Kv", "M")
MODEL_KEYS = ("d", "r", "l", "Kv", "Kt", "R", "M", "J", "Bv", "Bvn", "Bw", "Cv", "Cvn", "Cw")

#: Voltage per volt of drive along each axis (motor order 0..3).
PATTERNS = {"v": (0.0, -1.0, 0.0, 1.0), "vn": (1.0, 0.0, -1.0, 0.0), "w": (1.0, 1.0, 1.0, 1.0)}

CURRENT_NOISE_A = 0.02
CAMERA_XY_NOISE_M = 0.01
CAMERA_THETA_NOISE_RAD = 0.052
CAMERA_RATE_HZ = 25.0


#: Each drive's own constants (INI keys R_0..R_3 etc.); absent = the scalar for every wheel.
WHEEL_QUANTITIES = ("R", "Kv", "Kt", "r")


def wheel_key(q, j):
    """INI key of wheel j's value of quantity q ('R_2')."""
    return f"{q}_{j}"


def robot_params(seed, k, spread=None, geometry=None):
    """Parameters of robot k for a seed: dict of floats (SI units), deterministic per (seed, k).

    geometry (make_geometry; None = the paper's layout): the robot gets the keys wheels,
    wheel_angle_j [deg] and d_j [m] (j < wheels; d_j only if the geometry gives distances, and
    then d is their mean). With three wheels the per-wheel draws below are those of wheels 0-2
    and the scalars their mean.

    spread (R, Kv, r) fractions, e.g. (0.05, 0.05, 0.01): each motor's R_j and Kv_j (= Kt_j)
    is the robot's value times its own U(1 - s, 1 + s) factor, each wheel's radius r_j the
    measured r times 1 + e_j with e_j ~ U(-s, s) made zero-mean (then scaled back inside +-s),
    so the mean radius is r. The scalars R, Kv, Kt then hold the wheels' mean (as the INI
    contract says). Drawn on a stream of their own: the body and the scalars' draws do not move.
    """
    rng = np.random.default_rng([int(seed), int(k), 7001])
    factors = rng.uniform(0.7, 1.3, size=len(SCALED))
    p = dict(TABLE_III)
    for name, f in zip(SCALED, factors):
        p[name] = TABLE_III[name] * float(f)
    p["Kt"] = p["Kv"]
    nw = 4
    if geometry is not None:
        nw = geometry["wheels"]
        p["wheels"] = nw
        for j in range(nw):
            p[angle_key(j)] = float(geometry["angles_deg"][j])
        if geometry.get("dists_m") is not None:
            for j in range(nw):
                p[dist_key(j)] = float(geometry["dists_m"][j])
            p["d"] = float(np.mean(geometry["dists_m"]))
    if spread is None or not any(spread):
        return p
    sR, sK, sr = (float(s) for s in spread)
    wr = np.random.default_rng([int(seed), int(k), 7003])
    eR, eK, er = wr.uniform(-1.0, 1.0, 4) * sR, wr.uniform(-1.0, 1.0, 4) * sK, wr.uniform(-1, 1, 4)
    er = er[:nw] - er[:nw].mean()
    er *= sr / max(1.0, np.max(np.abs(er)))
    for j in range(nw):
        p[wheel_key("R", j)] = p["R"] * (1.0 + float(eR[j]))
        p[wheel_key("Kv", j)] = p["Kv"] * (1.0 + float(eK[j]))
        p[wheel_key("Kt", j)] = p[wheel_key("Kv", j)]
        p[wheel_key("r", j)] = p["r"] * (1.0 + float(er[j]))
    for q in WHEEL_QUANTITIES:
        p[q] = float(np.mean([p[wheel_key(q, j)] for j in range(nw)]))
    return p


def wheel_values(p, q):
    """Wheel values (4,) of quantity q of one robot's parameter dict: its keys, else the scalar."""
    return np.array([p.get(wheel_key(q, j), p[q]) for j in range(4)], dtype=float)


def has_wheels(p):
    """True if a parameter dict carries per-wheel keys."""
    return any(wheel_key(q, 0) in p for q in WHEEL_QUANTITIES)


def ini_keys(p):
    """The [model] keys of a robot's truth INI: the 14 scalars, the wheel keys it has, then its
    layout keys (wheels, wheel_angle_j, d_j) if it has them."""
    return MODEL_KEYS + tuple(wheel_key(q, j) for q in WHEEL_QUANTITIES for j in range(4)
                              if wheel_key(q, j) in p) + layout_keys(p)


def stack_params(plist):
    """List of parameter dicts -> dict of arrays with a leading robot axis; the per-wheel values
    as (n,4) arrays under 'R_w', 'Kv_w', 'Kt_w', 'r_w' (the scalar where a robot has none)."""
    out = {key: np.array([p[key] for p in plist], dtype=float) for key in MODEL_KEYS}
    for q in WHEEL_QUANTITIES:
        out[q + "_w"] = np.array([wheel_values(p, q) for p in plist])
    lay = [layout_of(p) for p in plist]
    out["n_wheels"] = np.array([n for n, _, _ in lay], dtype=int)
    out["angle_w"] = np.array([a for _, a, _ in lay])
    out["dist_w"] = np.array([dd for _, _, dd in lay])
    out["has_layout"] = np.array([has_layout(p) for p in plist], dtype=bool)
    return out


def ik_matrix(d):
    """Inverse kinematics (eq 2): 4x3 matrix, wheel linear speeds [m/s] = IK @ [v, vn, w]."""
    return np.array([[0.0, 1.0, d], [-1.0, 0.0, d], [0.0, -1.0, d], [1.0, 0.0, d]])


def force_matrix(d):
    """Eqs 9-11: 3x4 matrix, [Fv, Fvn, T] = FM @ wheel forces [N]."""
    return np.array([[0.0, -1.0, 0.0, 1.0], [1.0, 0.0, -1.0, 0.0], [d, d, d, d]])


# ---- wheel layouts ([model] wheels, wheel_angle_j [deg], d_j [m]) ----------------------------

#: The paper's layout: wheel j at j x 90 deg from the v axis, counter-clockwise (eq 2's rows).
PAPER_ANGLES_DEG = (0.0, 90.0, 180.0, 270.0)
_EXACT_SIN_COS = {0.0: (0.0, 1.0), 90.0: (1.0, 0.0), 180.0: (0.0, -1.0), 270.0: (-1.0, 0.0)}


def angle_key(j):
    """INI key of wheel j's position angle [deg] ('wheel_angle_2')."""
    return f"wheel_angle_{j}"


def dist_key(j):
    """INI key of wheel j's distance from the centre [m] ('d_2')."""
    return f"d_{j}"


def has_layout(p):
    """True if a parameter dict carries layout keys (else it has the paper's layout)."""
    return "wheels" in p or any(angle_key(j) in p or dist_key(j) in p for j in range(4))


def layout_keys(p):
    """The layout keys a parameter dict has, in INI order: wheels, wheel_angle_j, d_j."""
    keys = ("wheels",) + tuple(angle_key(j) for j in range(4)) + tuple(dist_key(j)
                                                                      for j in range(4))
    return tuple(k for k in keys if k in p)


def make_geometry(wheels=4, angles_deg=None, dists_m=None):
    """A wheel layout: dict wheels (3 or 4), angles_deg (wheels,) [deg, from the v axis,
    counter-clockwise], dists_m (wheels,) [m] or None (every wheel at the robot's d).
    Raises ValueError (one line) for a layout that cannot drive v, vn and w independently."""
    n = int(wheels)
    if n not in (3, 4):
        raise ValueError(f"wheels {wheels!r}: 3 or 4")
    if angles_deg is None:
        if n != 4:
            raise ValueError("3 wheels need their angles (e.g. 0,120,240)")
        angles_deg = PAPER_ANGLES_DEG
    ang = [float(a) for a in angles_deg]
    if len(ang) != n or not all(np.isfinite(ang)):
        raise ValueError(f"angles {list(angles_deg)}: expected {n} finite angles [deg]")
    norm = sorted(a % 360.0 for a in ang)
    if any(b - a < 1.0 for a, b in zip(norm, norm[1:] + [norm[0] + 360.0])):
        raise ValueError(f"angles {ang}: wheels closer than 1 deg")
    dist = None
    if dists_m is not None:
        dist = [float(v) for v in dists_m]
        if len(dist) == 1:
            dist *= n
        if len(dist) != n or not all(0.01 <= v <= 1.0 for v in dist):
            raise ValueError(f"distances {list(dists_m)}: expected 1 or {n} values in "
                             "0.01-1 m")
    IK = ik_rows(n, ang + [0.0] * (4 - n), (dist or [TABLE_III["d"]] * n) + [0.0] * (4 - n))
    sv = np.linalg.svd(IK, compute_uv=False)
    if sv[-1] < 0.05 * sv[0]:
        raise ValueError(f"angles {ang}: the wheels cannot drive v, vn and w independently")
    return {"wheels": n, "angles_deg": tuple(ang), "dists_m": None if dist is None else
            tuple(dist)}


def sin_cos_deg(angle_deg):
    """(sin, cos) of an angle [deg]; exact at multiples of 90 deg (the paper's rows, bit for
    bit)."""
    a = float(angle_deg) % 360.0
    if a in _EXACT_SIN_COS:
        return _EXACT_SIN_COS[a]
    rad = np.deg2rad(a)
    return float(np.sin(rad)), float(np.cos(rad))


def ik_rows(n, angles_deg, dists_m):
    """Eq 2 for any layout: 4x3, wheel j's rim speed [m/s] = row j @ [v, vn, w].

    Wheel j sits at distance d_j, angle a_j from the v axis (counter-clockwise), at
    d_j (cos a_j, sin a_j); it drives perpendicular to its radius, counter-clockwise positive,
    along t_j = (-sin a_j, cos a_j). Its contact point moves at [v, vn] + w x (its position), whose
    component along t_j is -sin a_j v + cos a_j vn + d_j w. Rows >= n (no wheel) are zero.
    The force map (eqs 9-11) is the transpose: a wheel force f along t_j pushes the body by
    f t_j and turns it by d_j f.
    """
    IK = np.zeros((4, 3))
    for j in range(int(n)):
        s, c = sin_cos_deg(angles_deg[j])
        IK[j] = (-s if s else 0.0, c, dists_m[j])
    return IK


def layout_of(p):
    """(wheels, angles [deg] (4,), distances [m] (4,)) of one robot's parameter dict: absent
    keys = the paper's layout at distance d; slots without a wheel hold 0."""
    n = int(p.get("wheels", 4))
    ang, dist = np.zeros(4), np.zeros(4)
    for j in range(n):
        ang[j] = p.get(angle_key(j), PAPER_ANGLES_DEG[j])
        dist[j] = p.get(dist_key(j), p["d"])
    return n, ang, dist


def robot_ik(p, i):
    """Robot i's eq 2 rows (4x3) from stacked arrays (the paper's if they carry no layout)."""
    if "n_wheels" not in p:
        return ik_matrix(p["d"][i])
    return ik_rows(p["n_wheels"][i], p["angle_w"][i], p["dist_w"][i])


def wheel_mask(p):
    """(n,4) bool: the slots that hold a wheel (slot 3 of a three-wheel robot does not)."""
    n = len(p["d"])
    if "n_wheels" not in p:
        return np.ones((n, 4), bool)
    return np.arange(4)[None, :] < np.asarray(p["n_wheels"])[:, None]


def axis_patterns(IK):
    """Voltage per volt of drive along each axis (4,) for the layout of eq 2 rows IK (4x3):
    the least-norm wheel forces that push along that axis alone (pinv(IK^T) e_a; with equal
    drives the voltages are proportional to the forces), scaled to a largest |entry| of 1
    (a run's level is then its largest wheel voltage). The paper's layout: PATTERNS, exactly."""
    if np.array_equal(IK[:, :2], ik_matrix(1.0)[:, :2]) and np.all(IK[:, 2] == IK[0, 2]):
        return dict(PATTERNS)
    P = np.linalg.pinv(IK.T)
    out = {}
    for a, ax in enumerate(AXES):
        col = P[:, a] / np.max(np.abs(P[:, a]))
        col[np.abs(col) < 1e-12] = 0.0
        out[ax] = tuple(float(v) for v in col)
    return out


def axis_model(p):
    """Per-axis coefficients of the robot-frame dynamics, arrays with a leading robot axis.

    Returns dict: m (n,3) mass / inertia [kg, kg, kg m^2]; B (n,3) viscous friction; C (n,3)
    Coulomb friction [N, N, N m]; K (n,3) back-EMF damping added while driven (same units as B);
    Kc (n,3,3) the back-EMF coupling between axes while driven (zero diagonal); G (n,3,4) drive
    gain [N/V, N/V, N m/V]; coupled (bool) any robot has a non-zero Kc; patterns (list of n
    dicts) each robot's axis voltage patterns (axis_patterns); has_layout (n,) bool robots with
    their own layout; n_wheels (n,) int; IK (n,4,3) eq 2's rows.
    Driven: F = G u - (diag(K) + Kc) x. Wheel j gives the force f_j = gain_j u_j - emf_j v_j
    (eq 21 in eqs 12-13, v_j = IK_j x), and FM sums them: the back-EMF matrix is
    FM diag(emf) IK (FM = IK^T, eq 2's rows of the robot's layout). With four equal wheels on
    the paper's layout it is FM IK emf, diagonal (checked), and each axis is solved on its own;
    with unequal wheels or an asymmetric layout the off-diagonal part couples the axes.
    """
    n = len(p["d"])
    m = np.stack([p["M"], p["M"], p["J"]], axis=1)
    B = np.stack([p["Bv"], p["Bvn"], p["Bw"]], axis=1)
    C = np.stack([p["Cv"], p["Cvn"], p["Cw"]], axis=1)
    K = np.empty((n, 3))
    Kc = np.zeros((n, 3, 3))
    G = np.empty((n, 3, 4))
    patterns = []
    for i in range(n):
        l = p["l"][i]
        r, R, Kt, Kv = p["r_w"][i], p["R_w"][i], p["Kt_w"][i], p["Kv_w"][i]
        IK = robot_ik(p, i)
        FM = IK.T
        gain = l * Kt / (r * R)                 # wheel force per volt [N/V], per wheel
        emf = gain * Kv * l / r                 # wheel force per wheel speed [N s/m], per wheel
        if np.all(emf == emf[0]) and np.all(gain == gain[0]):
            D = FM @ IK * emf[0]
            off = D - np.diag(np.diag(D))
            if np.max(np.abs(off)) > 1e-12 * np.max(np.abs(D)):
                if "has_layout" not in p or not p["has_layout"][i]:
                    raise ValueError("robot-frame dynamics do not decouple")
                # an asymmetric layout: eq 23's term couples (round-off left out)
                Kc[i] = np.where(np.abs(off) > 1e-12 * np.max(np.abs(D)), off, 0.0)
        else:
            D = (FM * emf[None, :]) @ IK
            Kc[i] = D - np.diag(np.diag(D))
        K[i] = np.diag(D)
        G[i] = FM * gain[None, :]
        patterns.append(axis_patterns(IK))
    lay = np.asarray(p.get("has_layout", np.zeros(n, bool)), bool)
    nw = np.asarray(p.get("n_wheels", np.full(n, 4)), int)
    return {"m": m, "B": B, "C": C, "K": K, "Kc": Kc, "G": G, "coupled": bool(np.any(Kc)),
            "patterns": patterns, "has_layout": lay, "n_wheels": nw,
            "IK": np.array([robot_ik(p, i) for i in range(n)])}


# ---- closed forms (planning the experiments and the self-test) ------------------------------

def _layout_coupled(model, i):
    """True if robot i has its own layout and its axes couple while driven."""
    return bool(model.get("has_layout", np.zeros(i + 1, bool))[i]) and bool(
        np.any(model["Kc"][i]))


def steady_state(model, i, u):
    """Steady robot velocity [v, vn, w] of robot i under constant voltages u (4,) [V].

    A robot with its own layout whose axes couple: the rest point of the coupled balance
    (coupled_steady_state); otherwise each axis on its own (the coupling of unequal drives on
    the paper's layout is left out: a few per cent, planning only)."""
    F = model["G"][i] @ np.asarray(u, float)
    C, Beff = model["C"][i], model["B"][i] + model["K"][i]
    if _layout_coupled(model, i):
        return coupled_steady_state(np.diag(Beff) + model["Kc"][i], F, C)
    return np.where(np.abs(F) > C, (F - C * np.sign(F)) / Beff, 0.0)


def coupled_steady_state(A, F, C):
    """Rest point x (3,) of A x = F - C sgn(x) with stiction: an axis with a sign solves its
    row, an axis at 0 needs |F - A x| <= C on its row. Tries the 27 sign patterns, the fewest
    moving axes last; returns the first consistent one (zeros if none)."""
    pats = sorted(itertools.product((-1, 0, 1), repeat=3), key=lambda s: -np.count_nonzero(s))
    for sign in pats:
        s = np.array(sign, float)
        free = s != 0
        x = np.zeros(3)
        if free.any():
            x[free] = np.linalg.solve(A[np.ix_(free, free)], (F - C * s)[free])
        if np.all(np.sign(x[free]) == s[free]) and np.all(
                np.abs((F - A @ x)[~free]) <= C[~free]):
            return x
    return np.zeros(3)


def time_constant(model, i, driven):
    """Time constants per axis (3,) [s] of robot i, driven (back-EMF damping) or coasting.

    Driven, with its own layout whose axes couple: each axis's own or the coupled system's
    slowest (1 / the smallest eigenvalue of m^-1 (B + K + Kc)), whichever is longer."""
    tau = model["m"][i] / (model["B"][i] + (model["K"][i] if driven else 0.0))
    if driven and _layout_coupled(model, i):
        A = (np.diag(model["B"][i] + model["K"][i]) + model["Kc"][i]) / model["m"][i][:, None]
        tau = np.maximum(tau, 1.0 / float(np.min(np.linalg.eigvals(A).real)))
    return tau


def stop_time(model, i, x0):
    """Coast-down time [s] per axis from speeds x0 (3,), bridges off: (m/B) ln(1 + B|x0|/C)."""
    m, B, C = model["m"][i], model["B"][i], model["C"][i]
    return (m / B) * np.log1p(B * np.abs(np.asarray(x0, float)) / C)


# ---- integration ------------------------------------------------------------------------------

def _cross_tick(x, F, C, m, Beff, dt):
    """One axis, one tick, motion that reaches zero inside the tick: exact, scalar.

    Returns (velocity at the tick's end, its integral over the tick). After the stop the axis
    stays at rest unless |F| > C, in which case it restarts in the direction of F.
    """
    a = Beff / m
    s = np.sign(x)
    xss = (F - C * s) / Beff
    tstar = -np.log(xss / (xss - x)) / a
    tstar = min(max(tstar, 0.0), dt)
    integ = xss * tstar + (x - xss) * (1.0 - np.exp(-a * tstar)) / a
    rem = dt - tstar
    if abs(F) > C and rem > 0.0:
        xss2 = (F - C * np.sign(F)) / Beff
        e = np.exp(-a * rem)
        return xss2 * (1.0 - e), integ + xss2 * rem - xss2 * (1.0 - e) / a
    return 0.0, integ


def _tick(x, Fk, Bk, C, m, Ek, Qk, dtk, dt_each):
    """All robots and axes, one tick: each axis's linear ODE under the force Fk (n,3) solved
    exactly, stiction and zero crossings handled. Ek = exp(-Bk dt / m), Qk = (1 - Ek) m / Bk;
    dtk the tick's length (a float or (n,1)), dt_each(i) that of robot i.
    Returns (velocity at the tick's end (n,3), its integral over the tick (n,3))."""
    s = np.sign(x)
    s_eff = np.where(s == 0.0, np.where(np.abs(Fk) > C, np.sign(Fk), 0.0), s)
    xss = (Fk - C * s_eff) / Bk
    dx = x - xss
    xn = xss + dx * Ek
    Xk = xss * dtk + dx * Qk
    still = s_eff == 0.0
    if still.any():
        xn[still] = 0.0
        Xk[still] = 0.0
    cross = xn * s < 0.0
    if cross.any():
        for i, ax in zip(*np.nonzero(cross)):
            xn[i, ax], Xk[i, ax] = _cross_tick(x[i, ax], Fk[i, ax], C[i, ax], m[i, ax],
                                               Bk[i, ax], dt_each(i))
    return xn, Xk


#: Passes per tick over the back-EMF coupling of unequal wheels (see integrate).
COUPLING_PASSES = 2


def integrate(model, u, driven, fext, dt, x0=None):
    """Advance n robots through T ticks; dt [s] is the length of every tick (a float) or of
    each tick of each robot ((T,n) array: the true, jittered intervals between loop ticks).

    u (T,n,4) [V] applied during each tick (held from one tick to the next, already clamped);
    driven (T,n) bool bridges on; fext (T,n,3) external [N, N, N m] at each tick's midpoint;
    x0 (n,3) initial velocity.
    Unequal wheels (model["coupled"]): while driven, axis a also feels -sum_b Kc[a,b] x_b. That
    force is held over the tick at the other axes' velocity: first at the tick's start, then at
    their mean over the tick (displacement / dt) from the previous pass, COUPLING_PASSES in all
    (a fixed point; each pass shrinks the error by about Kc dt / m, 1.5e-3 or less at 1 kHz).
    Equal wheels: one pass, exact.
    Returns x (T+1,n,3) velocity at the tick boundaries and X (T,n,3) its integral over each tick
    (displacement [m, m, rad] in the robot frame).
    """
    T, n = driven.shape
    m, B, C, K = model["m"], model["B"], model["C"], model["K"]
    F = np.einsum("nak,tnk->tna", model["G"], u.astype(float))
    F = np.where(driven[:, :, None], F, 0.0) + fext
    Beff = B[None] + driven[:, :, None] * K[None]
    a = Beff / m[None]
    per_tick = np.ndim(dt) > 0
    if per_tick:
        dt = np.asarray(dt, float)
        if dt.shape != (T, n) or not np.all(dt > 0.0):
            raise ValueError(f"tick lengths: expected positive (T,n) = {(T, n)}, got {dt.shape}")
        dt3 = dt[:, :, None]
    else:
        dt3 = dt
    E = np.exp(-a * dt3)
    Q = (1.0 - E) / a
    x_all = np.empty((T + 1, n, 3))
    X_all = np.empty((T, n, 3))
    x = np.zeros((n, 3)) if x0 is None else np.array(x0, float)
    x_all[0] = x
    Kc = model.get("Kc") if model.get("coupled") else None
    for k in range(T):
        dtk = dt3[k] if per_tick else dt

        def dt_each(i, k=k):
            return dt[k, i] if per_tick else dt
        if Kc is None or not driven[k].any():
            xn, Xk = _tick(x, F[k], Beff[k], C, m, E[k], Q[k], dtk, dt_each)
        else:
            on, xbar = driven[k][:, None], x
            for _ in range(COUPLING_PASSES):
                Fc = F[k] - on * np.einsum("nab,nb->na", Kc, xbar)
                xn, Xk = _tick(x, Fc, Beff[k], C, m, E[k], Q[k], dtk, dt_each)
                xbar = Xk / dtk
        x = xn
        x_all[k + 1] = x
        X_all[k] = Xk
    return x_all, X_all


# ---- sensors ----------------------------------------------------------------------------------

def _wheels(p, q, i):
    """Robot i's four wheel values (4,) of quantity q from stacked arrays (the scalar if the
    arrays carry no per-wheel values)."""
    w = p.get(q + "_w")
    return np.full(4, p[q][i]) if w is None else w[i]


def motor_currents(p, u, driven, x, rng, offset_a=None):
    """Measured currents (T,n,4) [A]: eq 21 with each motor's own R_j, Kv_j and wheel radius
    r_j while driven, 0 otherwise, + N(0, 0.02 A) noise; 0 exactly in a slot without a wheel.

    u (T,n,4) [V], driven (T,n), x (T,n,3) robot velocity at the tick start (when sampled).
    offset_a (n,4) [A]: the current sense's constant offset per motor channel, added to every
    reading, with the bridges off too (there the reading is offset + noise).
    """
    T, n = driven.shape
    i_true = np.empty((T, n, 4))
    for i in range(n):
        l = p["l"][i]
        wm = l * (x[:, i, :] @ robot_ik(p, i).T) / _wheels(p, "r", i)    # motor speed [rad/s]
        i_true[:, i, :] = (u[:, i, :] - _wheels(p, "Kv", i) * wm) / _wheels(p, "R", i)
    i_true *= driven[:, :, None]
    reading = i_true + rng.normal(0.0, CURRENT_NOISE_A, size=i_true.shape)
    if offset_a is not None:
        reading += np.asarray(offset_a, float)[None]
    mask = wheel_mask(p)
    if not mask.all():                          # no motor in the slot: the channel reads 0
        reading = np.where(mask[None], reading, 0.0)
    return reading


def wheel_angles(p, X):
    """Wheel angles (T+1,n,4) [rad] at the tick boundaries from robot displacements X (T,n,3):
    each wheel's rim travel (eq 2) over its own radius r_j."""
    T, n, _ = X.shape
    ang = np.zeros((T + 1, n, 4))
    for i in range(n):
        dang = X[:, i, :] @ robot_ik(p, i).T / _wheels(p, "r", i)
        ang[1:, i, :] = np.cumsum(dang, axis=0)
    return ang


def encoder_speeds(angles, cpr, dt, angle0=None, gear=None, eccentricity=None, phase=None):
    """Quantised encoder wheel speeds (T,n,4) [rad/s] reported at the start of each tick.

    angles (T+1,n,4) [rad] wheel angles at the ticks (read when the tick runs); counts =
    floor((angle0 + angle) cpr / 2pi), cpr counts per WHEEL revolution; the speed of tick k is
    (counts_k - counts_{k-1}) 2pi/cpr/dt (0 for the first tick), dt [s] the loop's nominal
    period (the firmware does not know that a tick woke late). angle0 (n,4): the angle at
    which each wheel starts [rad] (a random phase against the encoder's count edges).

    Eccentric disc (eccentricity (n,4) given): the encoder sits on the motor shaft, motor angle
    th_m = gear (n,) x wheel angle, and reads th_m + eps sin(th_m - phase) (eps = eccentricity,
    phase (n,4) [rad]); that reading, as a wheel angle (/ gear), is quantised as above (cpr/gear
    counts per motor revolution). The speed then ripples by eps once per motor revolution.
    """
    a = angles if angle0 is None else angles + angle0[None]
    if eccentricity is not None:
        g = np.asarray(gear, float)[None, :, None]
        motor = g * a                                             # motor shaft angle [rad]
        read = motor + np.asarray(eccentricity, float)[None] * np.sin(
            motor - np.asarray(phase, float)[None])
        a = read / g
    counts = np.floor(a * (cpr / (2.0 * np.pi))).astype(np.int64)
    speed = np.zeros(angles[:-1].shape)
    speed[1:] = np.diff(counts[:-1], axis=0) * (2.0 * np.pi / cpr / dt)
    return speed


def world_poses(X, pose0):
    """World poses (T+1,n,3) [m, m, rad] from robot-frame displacements X (T,n,3) (eq 1).

    Each tick's displacement is rotated by the heading at the tick's midpoint; theta unwrapped.
    """
    T, n, _ = X.shape
    pose = np.empty((T + 1, n, 3))
    pose[0] = pose0
    theta = pose0[:, 2][None] + np.concatenate([np.zeros((1, n)), np.cumsum(X[:, :, 2], axis=0)])
    mid = 0.5 * (theta[:-1] + theta[1:])
    c, s = np.cos(mid), np.sin(mid)
    dxw = c * X[:, :, 0] - s * X[:, :, 1]
    dyw = s * X[:, :, 0] + c * X[:, :, 1]
    pose[1:, :, 0] = pose0[:, 0][None] + np.cumsum(dxw, axis=0)
    pose[1:, :, 1] = pose0[:, 1][None] + np.cumsum(dyw, axis=0)
    pose[:, :, 2] = theta
    return pose


def wrap_angle(a):
    """Wrap angles [rad] to (-pi, pi]."""
    w = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    return np.where(w <= -np.pi, w + 2.0 * np.pi, w)


def camera_measure(pose, rng):
    """Camera poses [m, m, rad] from true poses (...,3): 1 cm and 3 deg Gaussian noise, wrapped."""
    noisy = pose + rng.normal(0.0, 1.0, size=pose.shape) * np.array(
        [CAMERA_XY_NOISE_M, CAMERA_XY_NOISE_M, CAMERA_THETA_NOISE_RAD])
    noisy[..., 2] = wrap_angle(noisy[..., 2])
    return noisy


# ---- real sensors: offsets, eccentric encoders, loop-tick jitter, camera latency, losses -----

#: The real-sensor effects, each switched on separately (write_logs.py --sensors).
SENSOR_EFFECTS = ("offsets", "eccentricity", "jitter", "latency", "losses")
CURRENT_OFFSET_MAX_A = 0.060            # offset per motor channel ~ U(-60, +60) mA
ECCENTRICITY_RANGE = (0.005, 0.015)     # relative once-per-motor-revolution speed ripple
JITTER_MEAN_US_RANGE = (20.0, 40.0)     # mean late wake-up of a loop tick [us] (exponential)
JITTER_SPIKE_PROB_RANGE = (0.002, 0.01)  # fraction of ticks that wake a further 100-200 us late
JITTER_SPIKE_US = (100.0, 200.0)
JITTER_CAP_FRACTION = 0.45              # no tick wakes later than 0.45 periods: ticks keep order
CAMERA_LATENCY_S_RANGE = (0.020, 0.055)  # capture-to-log latency per robot [s]
CAMERA_LATENCY_SPREAD_S_RANGE = (0.001, 0.005)  # + U(0, spread) per frame: 20-60 ms in all
MOTORS_LOSS = 0.001                     # fraction of motors_t samples lost
CAMERA_LOSS = 0.05                      # fraction of camera frames lost


def sensor_params(seed, k):
    """Real-sensor values of robot k for a seed, deterministic per (seed, k) (as robot_params).

    Returns dict: current_offset_a (4,) [A]; eccentricity (4,) and eccentricity_phase_rad (4,) of
    each motor's encoder disc; jitter_mean_us, jitter_spike_prob; camera_latency_s,
    camera_latency_spread_s [s]; motors_loss, camera_loss (fractions). All are drawn whatever
    effects a log switches on, so switching one effect does not change another's values.
    """
    rng = np.random.default_rng([int(seed), int(k), 7002])
    return {
        "current_offset_a": rng.uniform(-CURRENT_OFFSET_MAX_A, CURRENT_OFFSET_MAX_A, 4),
        "eccentricity": rng.uniform(*ECCENTRICITY_RANGE, 4),
        "eccentricity_phase_rad": rng.uniform(0.0, 2.0 * np.pi, 4),
        "jitter_mean_us": float(rng.uniform(*JITTER_MEAN_US_RANGE)),
        "jitter_spike_prob": float(rng.uniform(*JITTER_SPIKE_PROB_RANGE)),
        "camera_latency_s": float(rng.uniform(*CAMERA_LATENCY_S_RANGE)),
        "camera_latency_spread_s": float(rng.uniform(*CAMERA_LATENCY_SPREAD_S_RANGE)),
        "motors_loss": MOTORS_LOSS,
        "camera_loss": CAMERA_LOSS,
    }


def tick_times_us(rng, n_ticks, period_us, mean_us, spike_prob):
    """True start times [us] of ticks 0..n_ticks (n_ticks + 1 values) from the loop's start.

    Tick k is due at k period_us and wakes late by delta_k = Exp(mean_us), plus U(100, 200) us on
    a fraction spike_prob of the ticks, rounded to whole us and capped at 0.45 periods (absolute
    deadlines: the lateness does not accumulate). The voltage a tick sets is held until the next
    tick really runs, so tick k lasts t_{k+1} - t_k.
    """
    n = int(n_ticks) + 1
    late = rng.exponential(mean_us, n)
    late += np.where(rng.uniform(size=n) < spike_prob, rng.uniform(*JITTER_SPIKE_US, n), 0.0)
    cap = np.floor(JITTER_CAP_FRACTION * period_us)
    return np.arange(n, dtype=np.int64) * int(period_us) + np.minimum(np.round(late),
                                                                    cap).astype(np.int64)


def camera_latency_us(rng, n_frames, latency_s, spread_s):
    """Capture-to-arrival latency [us] of n_frames frames: latency_s + U(0, spread_s), whole us."""
    return np.round(1e6 * (latency_s + rng.uniform(0.0, spread_s, int(n_frames)))).astype(np.int64)


def kept(rng, n, loss):
    """Mask (n,) of the messages that arrive: each is lost with probability `loss`."""
    return rng.uniform(size=int(n)) >= loss
