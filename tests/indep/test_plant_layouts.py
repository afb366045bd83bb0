#!/usr/bin/env python3
"""Self-test of the independent plant on wheel layouts of its own (three wheels, an asymmetric
four), against computations written out here from the geometry, not through the plant's rows:

* eq 2's rows: each wheel's contact point at d_j (cos a_j, sin a_j) moves at [v, vn] + w x p_j;
  its rim speed is that velocity along the drive direction (the radius turned by +90 deg); the
  paper's layout gives the paper's rows, bit for bit, and the same logs, byte for byte;
* three wheels at 120 deg under equal voltages: the steady w of the motor equation, no v, vn;
* the least-norm axis patterns: at rest they push along their axis alone (forces and torque
  summed here as vectors and cross products), carry nothing in the force map's null space, and
  the first tick moves no other axis;
* the coupled rest point the runner plans with against a long simulation;
* the coupled per-tick solution against a fine RK4 of the wheel-level equations;
* energy balance over a driven run: electrical energy in = copper losses + friction work +
  kinetic energy gained;
* the runner's experiments on such robots and their logs: slot 3 of a three-wheel robot holds 0
  in every message (real sensors on), the truth INI carries the layout, the options' errors.

Bounds are about 3x the figures measured (round-off where the form is exact: rows 1.2e-16,
patterns 1.3e-15, spin 7.2e-14, rest point 5.9e-14; RK4 3.5e-7 of the speed; energy 4.3e-8).
Prints the figure behind every check and ends with 'indep_layouts: N passed, M failed'.
"""
import argparse
import contextlib
import io
import json
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import layouts      # noqa: E402
import plant        # noqa: E402
import write_logs   # noqa: E402

RESULTS = []
#: The layouts under test: (label, wheels, angles [deg], distances [m] or None = d).
LAYOUTS = (("3 wheels 0/120/240", 3, (0.0, 120.0, 240.0), None),
           ("3 wheels 60/180/300, unequal d", 3, (60.0, 180.0, 300.0), (0.080, 0.089, 0.100)),
           ("RoboCup 60/135/225/300", 4, (60.0, 135.0, 225.0, 300.0), None),
           ("RoboCup 60/135/225/300, unequal d", 4, (60.0, 135.0, 225.0, 300.0),
            (0.082, 0.090, 0.095, 0.085)))
#: The paper's eq 2 rows, typed in: v_j = PAPER_ROWS[j] . [v, vn, d w].
PAPER_ROWS = ((0.0, 1.0, 1.0), (-1.0, 0.0, 1.0), (0.0, -1.0, 1.0), (1.0, 0.0, 1.0))


def check(name, ok, figure):
    """Record and print one check: name, pass/fail, the figure it rests on."""
    RESULTS.append(bool(ok))
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {figure}")


def geometry(entry):
    _, n, ang, dist = entry
    return plant.make_geometry(n, ang, dist)


def wheel_points(p):
    """Contact points p_j (n,2) [m] and drive directions t_j (n,2) of a robot's wheels, from
    its INI keys: p_j = d_j (cos a_j, sin a_j), t_j = p_j turned by +90 deg, unit length."""
    n = int(p["wheels"])
    a = np.radians([p[f"wheel_angle_{j}"] for j in range(n)])
    d = np.array([p.get(f"d_{j}", p["d"]) for j in range(n)])
    pts = d[:, None] * np.column_stack([np.cos(a), np.sin(a)])
    t = np.column_stack([-pts[:, 1], pts[:, 0]]) / d[:, None]
    return pts, t


def rim_speeds(p, x):
    """Rim speed of each wheel [m/s] (...,n) at body velocity x = [v, vn, w] (...,3): the
    contact point's velocity [v, vn] + w z x p_j along t_j."""
    pts, t = wheel_points(p)
    x = np.asarray(x, float)[..., None, :]
    vel = x[..., :2] + x[..., 2:] * np.column_stack([-pts[:, 1], pts[:, 0]])
    return np.sum(vel * t, axis=-1)


def body_force(p, f):
    """[Fv, Fvn, T] of wheel forces f (n,) [N] along t_j: vector sum and z of p_j x f_j t_j."""
    pts, t = wheel_points(p)
    F = np.sum(f[:, None] * t, axis=0)
    T = np.sum(pts[:, 0] * f * t[:, 1] - pts[:, 1] * f * t[:, 0])
    return np.array([F[0], F[1], T])


def drives(p):
    """Per-wheel (R, Kv, Kt, r) arrays (n,) of a robot (its own keys, else the scalars)."""
    n = int(p["wheels"])
    return tuple(np.array([p.get(f"{q}_{j}", p[q]) for j in range(n)])
                 for q in ("R", "Kv", "Kt", "r"))


def currents(p, x, u):
    """Eq 21 per motor (...,n) at body velocity x (...,3), voltages u (...,4):
    (u_j - Kv_j l v_j / r_j) / R_j."""
    R, Kv, _, r = drives(p)
    return (np.asarray(u, float)[..., :len(R)] - Kv * p["l"] * rim_speeds(p, x) / r) / R


def body_accel(p, x, u):
    """dx/dt of the driven body: (wheel forces summed - B x - C sgn x) / (M, M, J)."""
    _, _, Kt, r = drives(p)
    F = body_force(p, p["l"] * Kt * currents(p, x, u) / r)
    B = np.array([p["Bv"], p["Bvn"], p["Bw"]])
    C = np.array([p["Cv"], p["Cvn"], p["Cw"]])
    return (F - B * x - C * np.sign(x)) / np.array([p["M"], p["M"], p["J"]])


def simulate(p, U, dt, x0=None):
    """The plant, driven, under voltages U (T,4): velocities (T+1,3), displacements (T,3)."""
    model = plant.axis_model(plant.stack_params([p]))
    T = len(U)
    x, X = plant.integrate(model, np.asarray(U, np.float32)[:, None], np.ones((T, 1), bool),
                           np.zeros((T, 1, 3)), dt, None if x0 is None else np.array([x0]))
    return x[:, 0], X[:, 0]


def test_rows():
    worst = 0.0
    rng = np.random.default_rng(5)
    cases = [geometry(e) for e in LAYOUTS]
    for _ in range(20):
        n = int(rng.integers(3, 5))
        ang = np.sort(rng.uniform(0, 360, n))
        try:
            cases.append(plant.make_geometry(n, ang, rng.uniform(0.05, 0.15, n)))
        except ValueError:
            pass
    for g in cases:
        p = plant.robot_params(1, 0, None, g)
        ik = plant.robot_ik(plant.stack_params([p]), 0)
        want = np.column_stack([rim_speeds(p, e) for e in np.eye(3)])
        worst = max(worst, float(np.max(np.abs(ik[:g["wheels"]] - want))))
        worst = max(worst, float(np.max(np.abs(ik[g["wheels"]:]), initial=0.0)))
    check("eq 2 rows of any layout vs the contact points' velocities along the drive directions",
          worst < 4e-16, f"{len(cases)} layouts, max |difference| {worst:.1e}")
    d = plant.TABLE_III["d"]
    paper = plant.ik_rows(4, plant.PAPER_ANGLES_DEG, [d] * 4)
    typed = np.array(PAPER_ROWS) * np.array([1.0, 1.0, d])
    check("the paper's layout gives the paper's rows bit for bit (signs of zero too)",
          np.array_equal(paper, typed) and np.array_equal(np.signbit(paper), np.signbit(typed))
          and np.array_equal(paper.T, plant.force_matrix(d)), paper.tolist())


def test_paper_same():
    g = plant.make_geometry(4, plant.PAPER_ANGLES_DEG)
    a, b = plant.robot_params(3, 1, (0.05, 0.05, 0.01)), plant.robot_params(3, 1, (0.05, 0.05,
                                                                                0.01), g)
    ma, mb = (plant.axis_model(plant.stack_params([q])) for q in (a, b))
    same = all(np.array_equal(ma[k], mb[k]) for k in ("m", "B", "C", "K", "Kc", "G", "IK"))
    rng = np.random.default_rng(2)
    U = np.repeat(rng.uniform(-9, 9, (40, 4)), 25, axis=0)
    xa, Xa = simulate(a, U, 1e-3)
    xb, Xb = simulate(b, U, 1e-3)
    check("paper's layout given explicitly (with per-wheel drives): same axis model, same run",
          same and np.array_equal(xa, xb) and np.array_equal(Xa, Xb),
          f"{len(U)} ticks, max |dx| {np.max(np.abs(xa - xb)):.1e}")


def test_three_wheel_spin():
    g = geometry(LAYOUTS[0])
    p = plant.robot_params(4, 2, None, g)
    u = 6.0
    x, _ = simulate(p, np.tile([u, u, u, 0.0], (8000, 1)), 1e-3)
    d, l, r, R, Kt, Kv = (p[k] for k in ("d", "l", "r", "R", "Kt", "Kv"))
    g_w = l * Kt / (r * R)                   # wheel force per volt [N/V]
    w_ss = (3 * d * g_w * u - p["Cw"]) / (p["Bw"] + 3 * d * d * g_w * Kv * l / r)
    err = abs(x[-1, 2] - w_ss) / w_ss
    check("3 wheels at 120 deg, 6 V each: steady w = (3 d g u - Cw) / (Bw + 3 d^2 g Kv l / r), "
          "no v, vn", err < 2e-13 and np.max(np.abs(x[:, :2])) < 1e-12,
          f"w {x[-1, 2]:.9f} rad/s vs {w_ss:.9f} (rel err {err:.1e}), max |v|, |vn| "
          f"{np.max(np.abs(x[:, :2])):.1e}")


def test_patterns():
    worst_f, worst_null, worst_x = 0.0, 0.0, 0.0
    for e in LAYOUTS:
        p = plant.robot_params(2, 3, None, geometry(e))
        model = plant.axis_model(plant.stack_params([p]))
        n = int(p["wheels"])
        _, _, Kt, r = drives(p)
        fmap = np.column_stack([body_force(p, f) for f in np.eye(n)])     # 3 x n
        null = np.linalg.svd(fmap)[2][3:]                                  # (n-3) x n
        for a, ax in enumerate(plant.AXES):
            u = np.array(model["patterns"][0][ax])
            F = body_force(p, p["l"] * Kt * currents(p, np.zeros(3), u) / r)
            scale = np.array([1.0, 1.0, 1.0 / p["d"]])                     # torque as a force
            other = np.delete(np.abs(F * scale), a)
            worst_f = max(worst_f, float(np.max(other) / abs(F[a] * scale[a])))
            if len(null):
                worst_null = max(worst_null, float(np.max(np.abs(null @ u[:n]))))
            x, _ = simulate(p, np.tile(8.0 * u, (1, 1)), 1e-3)
            worst_x = max(worst_x, float(np.max(np.delete(np.abs(x[1] * scale), a))
                                         / abs(x[1, a] * scale[a])))
            if u[n:].any() or abs(np.max(np.abs(u)) - 1.0) > 1e-12:
                worst_f = np.inf
    check("least-norm axis patterns at rest: force along their axis alone, none in the force "
          "map's null space, first tick moves no other axis (4 layouts x 3 axes)",
          worst_f < 4e-15 and worst_null < 4e-15 and worst_x < 1e-15,
          f"other axes / own: force {worst_f:.1e}, first-tick velocity {worst_x:.1e}; "
          f"null-space part {worst_null:.1e} V")


def test_coupled_steady():
    p = plant.robot_params(6, 0, None, geometry(LAYOUTS[3]))
    model = plant.axis_model(plant.stack_params([p]))
    worst, cross = 0.0, 0.0
    for ax, lv in (("v", 7.0), ("vn", 9.0), ("w", 5.0)):
        u = (lv * np.array(model["patterns"][0][ax])).astype(np.float32).astype(float)
        x, _ = simulate(p, np.tile(u, (6000, 1)), 2e-3)
        want = plant.steady_state(model, 0, u)
        worst = max(worst, float(np.max(np.abs(x[-1] - want))))
        cross = max(cross, float(np.max(np.delete(np.abs(x[-1]), plant.AXES.index(ax)))))
    check("asymmetric layout: the runner's planned rest point (coupled balance) vs 12 s of "
          "simulation", model["coupled"] and worst < 2e-13 and cross > 0.05,
          f"max |difference| {worst:.1e}; the pure-axis pushes end with other axes moving "
          f"up to {cross:.2f}")


def rk4(p, U, x0, dt, sub=10):
    """Fine-step RK4 of body_accel, voltages U (T,4) held per tick: velocities (T+1,3)."""
    xs, x, h = [np.array(x0, float)], np.array(x0, float), dt / sub
    for u in U:
        for _ in range(sub):
            k1 = body_accel(p, x, u)
            k2 = body_accel(p, x + h / 2 * k1, u)
            k3 = body_accel(p, x + h / 2 * k2, u)
            k4 = body_accel(p, x + h * k3, u)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        xs.append(x.copy())
    return np.array(xs)


def test_rk4():
    p = plant.robot_params(3, 1, (0.05, 0.05, 0.01), geometry(LAYOUTS[3]))
    model = plant.axis_model(plant.stack_params([p]))
    dt, T = 1e-3, 600
    t = np.arange(T) * dt
    pat = {k: np.array(v) for k, v in model["patterns"][0].items()}
    U = ((5 + 2 * np.sin(3 * t))[:, None] * pat["v"] - (6 + 2 * np.cos(2 * t))[:, None]
         * pat["vn"] + (3 + np.sin(5 * t))[:, None] * pat["w"]).astype(np.float32)
    x0 = [0.5, -0.4, 8.0]
    x, _ = simulate(p, U, dt, x0)
    ref = rk4(p, U.astype(float), x0, dt)
    err = np.max(np.abs(x - ref), axis=0)
    scale = np.max(np.abs(ref), axis=0)
    # the same run with the coupling left out misses by far more: the check can tell
    xu, _ = plant.integrate(dict(model, coupled=False), U[:, None], np.ones((T, 1), bool),
                            np.zeros((T, 1, 3)), dt, np.array([x0]))
    erru = np.max(np.abs(xu[:, 0] - ref) / scale)
    # measured 3.5e-7 of the speed (O(dt^2): the coupling force held over the tick; 8.9e-8 at
    # 0.5 ms); bound 3x
    check("asymmetric layout, unequal drives: per-tick solution with the coupling passes vs fine "
          "RK4 of the wheel-level equations",
          model["coupled"] and np.all(err < 1e-6 * scale) and erru > 1e-4,
          f"max err v {err[0]:.1e} m/s, vn {err[1]:.1e} m/s, w {err[2]:.1e} rad/s (at most "
          f"{np.max(err / scale):.1e} of the axis's largest speed); without the coupling "
          f"{erru:.1e}")


def test_energy():
    p = plant.robot_params(8, 4, (0.05, 0.05, 0.01), geometry(LAYOUTS[3]))
    dt, T = 1e-4, 20000
    t = np.arange(T) * dt
    U = np.column_stack([6 * np.sin(2 * t + j) + 3 * np.cos(5 * t - 2 * j) for j in range(4)])
    x, _ = simulate(p, U, dt)
    U = U.astype(np.float32).astype(float)
    R = drives(p)[0]
    # power at both ends of each tick (the voltage held over the tick), trapezoid
    B = np.array([p["Bv"], p["Bvn"], p["Bw"]])
    C = np.array([p["Cv"], p["Cvn"], p["Cw"]])
    e_in = e_cu = e_fr = 0.0
    for xe in (x[:-1], x[1:]):
        i = currents(p, xe, U)
        e_in += 0.5 * dt * float(np.sum(U * i))
        e_cu += 0.5 * dt * float(np.sum(R * i * i))
        e_fr += 0.5 * dt * float(np.sum(B * xe ** 2 + C * np.abs(xe)))
    kin = 0.5 * (p["M"] * (x[-1, 0] ** 2 + x[-1, 1] ** 2) + p["J"] * x[-1, 2] ** 2)
    res = (e_in - e_cu - e_fr - kin) / e_in
    check("energy balance over 2 s driven (asymmetric layout, unequal drives): electrical in = "
          "copper + friction + kinetic", abs(res) < 1.3e-7,
          f"in {e_in:.4f} J, copper {e_cu:.4f} J, friction {e_fr:.4f} J, kinetic {kin:.4f} J, "
          f"residual {res:.1e} of the input")


def test_experiments():
    bad = []
    for e in LAYOUTS:
        p = plant.robot_params(1, 0, None, geometry(e))
        model = plant.axis_model(plant.stack_params([p]))
        n = int(p["wheels"])
        tl, _, _ = layouts.build("runner", model, 0, 1, 0)
        u, _, _ = tl.arrays()
        runs = layouts.experiment_set(np.random.default_rng(0), layout=(
            model["patterns"][0], n, model["IK"][0].T))
        motor = [r for r in runs if r.kind == "motor"]
        singles = sorted({int(np.argmax(r.pattern)) for r in motor})
        if u[:, n:].any() or singles != list(range(n)) or len(motor) != 6 * n:
            bad.append(f"{e[0]}: motors {singles}, {len(motor)} motor runs")
        for r in runs:
            if r.kind in ("step", "coast", "steady_rotation") and not np.array_equal(
                    r.pattern, model["patterns"][0][r.direction]):
                bad.append(f"{e[0]}: {r.kind} {r.direction} pattern {r.pattern}")
        sub = layouts.experiment_set(np.random.default_rng(0), subset_layout=True, layout=(
            model["patterns"][0], n, model["IK"][0].T))
        if any(r.pattern[n:].any() for r in sub):
            bad.append(f"{e[0]}: subset drives slot {n}")
    check("runner on each layout: one motor at a time over its wheels, steps / coasts / "
          "rotations on its least-norm patterns, nothing in an empty slot", not bad,
          "; ".join(bad) or "4 layouts")


def read_motors(path, lcm_python):
    """Voltage, current, wheel_speed arrays (n,4) of a log's motors_t messages."""
    lcm, omni4 = write_logs.import_types(lcm_python)
    cols = ([], [], [])
    log = lcm.EventLog(path, "r")
    for ev in log:
        if ev.channel == write_logs.CH_MOTORS:
            m = omni4.motors_t.decode(ev.data)
            for c, v in zip(cols, (m.voltage, m.current, m.wheel_speed)):
                c.append(v)
    log.close()
    return [np.array(c) for c in cols]


def test_logs(lcm_python):
    omit = [("coast", None), ("step", None), ("motor", None)]
    with tempfile.TemporaryDirectory() as work:
        g3 = geometry(LAYOUTS[1])
        res = write_logs.generate("runner", 2, [0], work, omit, lcm_python=lcm_python,
                                  progress=None, speed_noise=(0.3, 0.02),
                                  sensors=plant.SENSOR_EFFECTS, geometry=g3)[0]
        V, I, S = read_motors(res["log"], lcm_python)
        truth, base = write_logs.read_ini(res["truth"]), write_logs.read_ini(res["base"])
        with open(res["sensors"]) as f:
            side = json.load(f)
        slot3 = [np.array_equal(np.signbit(a[:, 3]), np.zeros(len(a), bool)) and not a[:, 3].any()
                 for a in (V, I, S)]
        live = [float(np.min(np.max(np.abs(a[:, :3]), axis=0))) for a in (V, I, S)]
        keys = {"wheels": 3.0, "wheel_angle_0": 60.0, "wheel_angle_1": 180.0,
                "wheel_angle_2": 300.0, "d_0": 0.080, "d_1": 0.089, "d_2": 0.100}
        ini_ok = (all(truth.get(k) == v for k, v in keys.items())
                  and "wheel_angle_3" not in truth and "d_3" not in truth
                  and abs(truth["d"] - np.mean([0.080, 0.089, 0.100])) < 1e-15
                  and sorted(base) == ["M", "d", "l", "r"])
        check("3-wheel log with every real-sensor effect and speed noise: slot 3 is +0 in voltage, current and "
              "wheel speed of every message; slots 0-2 live; truth INI holds the layout, the "
              "base INI does not", all(slot3) and min(live) > 0.1 and ini_ok
              and side["current_offset_a"][3] == 0.0,
              f"{len(V)} messages, slot 3 zero {slot3}, smallest peak of slots 0-2 "
              f"{min(live):.2f}; truth layout keys {[k for k in truth if k in keys]}")
        paper = plant.make_geometry(4, plant.PAPER_ANGLES_DEG)
        logs = [write_logs.generate("runner", 2, [1], os.path.join(work, sub), omit,
                                    lcm_python=lcm_python, progress=None, geometry=geo)[0]["log"]
                for sub, geo in (("a", None), ("b", paper))]
        same = open(logs[0], "rb").read() == open(logs[1], "rb").read()
        check("the paper's layout given explicitly writes the same log, byte for byte", same,
              f"{os.path.getsize(logs[0])} bytes")


def test_options():
    cases = (["--wheels", "3"], ["--wheels", "3", "--angles", "0,10,20"],
             ["--angles", "0,90,180"], ["--dist", "0.09,x"], ["--dist", "-0.1"],
             ["--wheels", "3", "--angles", "0,120,240", "--motor-subset", "3"])
    lines = []
    with tempfile.TemporaryDirectory() as work:
        for extra in cases:
            err = io.StringIO()
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                rc = write_logs.main(["--out", work, "--quiet", "--omit", "coast", "--omit",
                                      "step", "--omit", "steady_rotation", "--omit", "motor"]
                                     + extra)
            lines.append((rc, err.getvalue()))
        ini = os.path.join(work, "layout.ini")
        with open(ini, "w") as f:
            f.write("[model]\nwheels = 3\nwheel_angle_0 = 60\nwheel_angle_1 = 180\n"
                    "wheel_angle_2 = 300\nd_0 = 0.08\nd_1 = 0.089\nd_2 = 0.1\n")
        from_ini = write_logs.parse_geometry(ini=ini)
    ok = all(rc == 2 and text.count("\n") == 1 for rc, text in lines)
    check("--geometry INI reads the layout keys", from_ini == geometry(LAYOUTS[1]),
          str(from_ini))
    check("bad layout options: exit 2 with one line each", ok,
          " | ".join(text.strip() for _, text in lines))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("lcm_python", nargs="?", default=None,
                    help="folder with the generated package omni4")
    a = ap.parse_args(argv)
    for test in (test_rows, test_paper_same, test_three_wheel_spin, test_patterns,
                 test_coupled_steady, test_rk4, test_energy, test_experiments, test_options):
        test()
    test_logs(a.lcm_python)
    failed = RESULTS.count(False)
    print(f"indep_layouts: {len(RESULTS) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
