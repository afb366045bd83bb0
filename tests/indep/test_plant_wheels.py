#!/usr/bin/env python3
"""Self-test of the independent plant's per-wheel drives (each motor's R_j, Kv_j = Kt_j, each
wheel's r_j), against computations written out here wheel by wheel from the paper's equations
(eq 2 rim speeds, eq 21 motor, eqs 12-13 wheel force, eqs 9-11 robot forces), not through the
plant's axis model:

* the draws: deterministic, inside the spread, mean radius = r, scalars = the wheels' mean, the
  body untouched, no spread = today's robot;
* steady state of a robot with one odd wheel and of a fully spread one: the 3x3 force balance
  solved here against the plant's integration (the coupled axes: a turn drifts along v, vn);
* a fine-step RK4 of the wheel-level equations against the plant's per-tick solution;
* currents (eq 21 per motor) and wheel angles (rim travel / r_j) at known velocities;
* a log with per-wheel drives: the truth INI holds the wheel keys, the scalars their mean.

Prints the figure behind every check and ends with 'indep_wheels: N passed, M failed'.
"""
import argparse
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import plant        # noqa: E402
import write_logs   # noqa: E402

RESULTS = []
SPREAD = (0.05, 0.05, 0.01)
#: rim-speed directions of the wheels (eq 2 rows), typed in here: v_j = G_ROWS[j] . [v, vn, d w]
G_ROWS = ((0.0, 1.0, 1.0), (-1.0, 0.0, 1.0), (0.0, -1.0, 1.0), (1.0, 0.0, 1.0))


def check(name, ok, figure):
    """Record and print one check: name, pass/fail, the figure it rests on."""
    RESULTS.append(bool(ok))
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {figure}")


def wheels_of(p):
    """(R, Kv, Kt, r) lists of one robot's four wheels, read key by key (scalar if absent)."""
    return tuple([p.get(f"{q}_{j}", p[q]) for j in range(4)] for q in ("R", "Kv", "Kt", "r"))


def wheel_forces(p, x, u):
    """Net force [Fv, Fvn, T] of the four drives at robot velocity x under voltages u: each
    wheel's rim speed, its motor current (eq 21), its force (eqs 12-13), summed (eqs 9-11)."""
    R, Kv, Kt, r = wheels_of(p)
    d, l = p["d"], p["l"]
    F = np.zeros(3)
    for j in range(4):
        gv, gvn, gw = G_ROWS[j]
        vj = gv * x[0] + gvn * x[1] + gw * d * x[2]
        i = (u[j] - Kv[j] * l * vj / r[j]) / R[j]
        f = l * Kt[j] * i / r[j]
        F += np.array([gv * f, gvn * f, gw * d * f])
    return F


def body_accel(p, x, u, driven=True):
    """dx/dt of the body: (drive force - B x - C sgn x) / (M, M, J)."""
    F = wheel_forces(p, x, u) if driven else np.zeros(3)
    B = np.array([p["Bv"], p["Bvn"], p["Bw"]])
    C = np.array([p["Cv"], p["Cvn"], p["Cw"]])
    return (F - B * x - C * np.sign(x)) / np.array([p["M"], p["M"], p["J"]])


def steady_by_hand(p, u):
    """Rest point of the body under constant voltages u, stiction included: for every pattern
    of signs (-1, 0, +1 per axis), the axes with a sign solve the balance (linear in x, its
    matrix read off column by column), the others stay at 0; the pattern holds if the moving
    axes keep their signs and each resting axis's applied force is within its C."""
    C = np.array([p["Cv"], p["Cvn"], p["Cw"]])
    m = np.array([p["M"], p["M"], p["J"]])
    found = []
    for sign in np.array(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1])).reshape(3, -1).T:
        free = sign != 0
        a0 = body_accel_signed(p, np.zeros(3), u, sign)
        A = np.column_stack([body_accel_signed(p, np.eye(3)[c], u, sign) - a0
                             for c in range(3)])
        x = np.zeros(3)
        if free.any():
            x[free] = np.linalg.solve(A[np.ix_(free, free)], -a0[free])
        applied = m * body_accel_signed(p, x, u, np.zeros(3))      # drive - B x, no Coulomb
        if np.all(np.sign(x[free]) == sign[free]) and np.all(np.abs(applied[~free])
                                                              <= C[~free]):
            found.append(x)
    if len(found) != 1:
        raise ValueError(f"{len(found)} rest points")
    return found[0]


def body_accel_signed(p, x, u, sign):
    """body_accel with the Coulomb signs given (sign 0: no Coulomb force)."""
    B = np.array([p["Bv"], p["Bvn"], p["Bw"]])
    C = np.array([p["Cv"], p["Cvn"], p["Cw"]])
    return (wheel_forces(p, x, u) - B * x - C * np.asarray(sign)) / np.array([p["M"], p["M"],
                                                                               p["J"]])


def simulate(p, u, seconds, dt=1e-3, x0=None):
    """The plant under constant voltages u (4,): velocities (T+1,3), displacements (T,3)."""
    model = plant.axis_model(plant.stack_params([p]))
    T = int(round(seconds / dt))
    U = np.repeat(np.asarray(u, np.float32)[None, None], T, 0)
    x, X = plant.integrate(model, U, np.ones((T, 1), bool), np.zeros((T, 1, 3)), dt,
                           None if x0 is None else np.array([x0], float))
    return x[:, 0], X[:, 0]


def test_draws():
    a, b = plant.robot_params(4, 2, SPREAD), plant.robot_params(4, 2, SPREAD)
    u0 = plant.robot_params(4, 2)
    R, Kv, Kt, r = (np.array(w) for w in wheels_of(a))
    eR, eK = R / u0["R"] - 1, Kv / u0["Kv"] - 1
    body = all(a[k] == u0[k] for k in ("M", "J", "Bv", "Bvn", "Bw", "Cv", "Cvn", "Cw", "d", "l"))
    means = (abs(a["R"] - R.mean()) < 1e-15 * a["R"] and abs(a["Kv"] - Kv.mean()) < 1e-17
             and a["Kt"] == a["Kv"] and np.array_equal(Kt, Kv))
    check("spread robots: deterministic, R_j Kv_j within +-5 %, radii within +-1 % with mean r, "
          "scalars = the wheels' mean, body as without spread",
          a == b and body and means and np.max(np.abs(eR)) <= 0.05 and np.max(np.abs(eK)) <= 0.05
          and np.max(np.abs(r / u0["r"] - 1)) <= 0.01 + 1e-15 and abs(r.mean() - u0["r"]) < 1e-17,
          f"R {np.round(100 * eR, 2).tolist()} %, Kv {np.round(100 * eK, 2).tolist()} %, r "
          f"{np.round(100 * (r / u0['r'] - 1), 3).tolist()} %")
    check("no spread: the robot of today, no wheel keys",
          plant.robot_params(4, 2, (0, 0, 0)) == u0 and not plant.has_wheels(u0)
          and plant.ini_keys(u0) == plant.MODEL_KEYS, f"{len(u0)} keys")


def odd_wheel_robots():
    """(label, params): Table III with one odd drive, and a fully spread robot."""
    odd = dict(plant.TABLE_III)
    for q in ("R", "Kv", "Kt", "r"):
        for j in range(4):
            odd[f"{q}_{j}"] = odd[q]
    odd["R_3"] *= 1.05
    odd["Kv_1"] *= 0.95
    odd["Kt_1"] = odd["Kv_1"]
    odd["r_0"] *= 1.01
    return (("one odd wheel each (R_3 +5 %, Kv_1 -5 %, r_0 +1 %)", odd),
            ("spread robot (seed 2, k 5)", plant.robot_params(2, 5, SPREAD)))


def test_steady():
    P = {k: np.array(v) for k, v in plant.PATTERNS.items()}
    for label, p in odd_wheel_robots():
        for name, u in (("turn", 6.0 * P["w"]), ("drive v", 8.0 * P["v"]),
                        ("v + vn + turn", 4.0 * P["v"] - 3.0 * P["vn"] + 5.0 * P["w"])):
            x, _ = simulate(p, u, 6.0)
            want = steady_by_hand(p, u)
            err = np.abs(x[-1] - want)
            check(f"{label}, {name}: steady velocity vs the wheel-by-wheel force balance",
                  np.all(err <= 2e-8 * np.max(np.abs(want))),
                  f"sim {np.round(x[-1], 6).tolist()}, by hand {np.round(want, 6).tolist()}, "
                  f"max err {err.max():.1e}")


def rk4_wheels(p, u, x0, dt, T, sub=20):
    """Fine-step RK4 of body_accel (wheel-level equations), voltages u (T,4) held per tick."""
    xs, x, h = [np.array(x0, float)], np.array(x0, float), dt / sub
    for k in range(T):
        for _ in range(sub):
            k1 = body_accel(p, x, u[k])
            k2 = body_accel(p, x + h / 2 * k1, u[k])
            k3 = body_accel(p, x + h / 2 * k2, u[k])
            k4 = body_accel(p, x + h * k3, u[k])
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        xs.append(x.copy())
    return np.array(xs)


def test_rk4():
    p = plant.robot_params(3, 1, (0.15, 0.15, 0.03))       # wider than the test robots
    dt, T = 1e-3, 1200
    t = np.arange(T) * dt
    P = {k: np.array(v) for k, v in plant.PATTERNS.items()}
    u = ((5 + 2 * np.sin(3 * t))[:, None] * P["v"] - (6 + 2 * np.cos(2 * t))[:, None] * P["vn"]
         + (3 + np.sin(5 * t))[:, None] * P["w"]).astype(np.float32)
    x0 = [0.5, -0.4, 8.0]
    model = plant.axis_model(plant.stack_params([p]))
    x, _ = plant.integrate(model, u[:, None], np.ones((T, 1), bool), np.zeros((T, 1, 3)), dt,
                           np.array([x0]))
    ref = rk4_wheels(p, u.astype(float), x0, dt, T)
    err = np.max(np.abs(x[:, 0] - ref), axis=0)
    scale = np.max(np.abs(ref), axis=0)
    # the same run with the coupling left out misses by far more: the check can tell
    uncoupled = dict(model, coupled=False)
    xu, _ = plant.integrate(uncoupled, u[:, None], np.ones((T, 1), bool), np.zeros((T, 1, 3)),
                            dt, np.array([x0]))
    erru = np.max(np.abs(xu[:, 0] - ref), axis=0)
    check("per-wheel robot (+-15 % drives): per-tick solution with the coupling passes vs fine "
          "RK4 of the wheel-level equations",
          model["coupled"] and np.all(err < 5e-8 * scale) and np.any(erru > 1e-4 * scale),
          f"max err v {err[0]:.1e} m/s, vn {err[1]:.1e} m/s, w {err[2]:.1e} rad/s (at most "
          f"{np.max(err / scale):.1e} of the axis's largest speed); without "
          f"the coupling {erru[0]:.1e}, {erru[1]:.1e}, {erru[2]:.1e}")


class _NoNoise:
    """An rng whose normal() is zero: the currents without their noise."""

    @staticmethod
    def normal(loc, scale, size):
        return np.zeros(size)


def test_sensors():
    _, p = odd_wheel_robots()[1]
    pa = plant.stack_params([p])
    R, Kv, _, r = wheels_of(p)
    x = np.array([[0.3, -0.2, 4.0], [-0.1, 0.5, -2.0]])
    u = np.array([[3.0, -2.0, 5.0, 1.0], [-4.0, 6.0, 0.5, 2.0]])
    cur = plant.motor_currents(pa, u[:, None], np.ones((2, 1), bool), x[:, None], _NoNoise())
    want = np.empty((2, 4))
    for k in range(2):
        for j in range(4):
            vj = np.dot(G_ROWS[j], [x[k, 0], x[k, 1], p["d"] * x[k, 2]])
            want[k, j] = (u[k, j] - Kv[j] * p["l"] * vj / r[j]) / R[j]
    err = np.max(np.abs(cur[:, 0] - want))
    check("currents: (u_j - Kv_j l v_j / r_j) / R_j per motor", err < 1e-12,
          f"max err {err:.1e} A over {want.size} readings")
    X = np.array([[[0.01, 0.02, 0.3]], [[-0.02, 0.01, -0.1]]])
    ang = plant.wheel_angles(pa, X)[-1, 0]
    tot = X[:, 0].sum(axis=0)
    want = [np.dot(G_ROWS[j], [tot[0], tot[1], p["d"] * tot[2]]) / r[j] for j in range(4)]
    err = np.max(np.abs(ang - want))
    check("wheel angles: rim travel / r_j per wheel", err < 1e-12, f"max err {err:.1e} rad")


def test_log(lcm_python):
    with tempfile.TemporaryDirectory() as work:
        try:
            res = write_logs.generate("runner", 1, [0], work, omit=[("motor", None),
                                      ("step", None), ("coast", None)], lcm_python=lcm_python,
                                      progress=None, wheels=SPREAD)
        except write_logs.LogError as e:
            check("log with per-wheel drives", False, str(e))
            return
        truth = write_logs.read_ini(res[0]["truth"])
    keys = [f"{q}_{j}" for q in ("R", "Kv", "Kt", "r") for j in range(4)]
    means = [abs(truth[q] - np.mean([truth[f"{q}_{j}"] for j in range(4)])) / truth[q]
             for q in ("R", "Kv", "Kt", "r")]
    check("truth INI of a per-wheel robot: R_j Kv_j Kt_j r_j, the scalars their mean",
          all(k in truth for k in keys) and max(means) < 1e-14,
          f"{len(truth)} keys, scalar vs mean at most {max(means):.1e} relative")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("lcm_python", nargs="?", default=None,
                    help="folder with the generated package omni4")
    a = ap.parse_args(argv)
    for test in (test_draws, test_steady, test_rk4, test_sensors):
        test()
    test_log(a.lcm_python)
    failed = RESULTS.count(False)
    print(f"indep_wheels: {len(RESULTS) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
