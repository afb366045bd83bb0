#!/usr/bin/env python3
"""Self-test of the independent plant: closed forms, stiction, an RK4 cross-check, encoder
quantisation, camera and current noise, message encoding and an LCM event-log round trip; the
real sensors: current offsets, eccentric encoders, late loop ticks, camera latency, losses.

Prints the figure behind every check and ends with 'indep_plant: N passed, M failed'.
"""
import argparse
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import layouts      # noqa: E402
import plant        # noqa: E402
import write_logs   # noqa: E402
from plant_checks import RESULTS, check  # noqa: E402
from test_plant_sensors import (test_eccentricity, test_jitter, test_sensor_draws,  # noqa: E402
                                test_sensor_logs)

P3 = plant.TABLE_III


def one_robot(p=None):
    """(params arrays, axis model) of a single robot (default Table III)."""
    pa = plant.stack_params([p or P3])
    return pa, plant.axis_model(pa)


def run(model, u, seconds, dt=1e-3, driven=True, x0=None, fext=None):
    """Simulate one robot under constant voltages u (4,) [V]; returns (x (T+1,3), X (T,3))."""
    T = int(round(seconds / dt))
    U = np.repeat(np.asarray(u, np.float32)[None, None], T, 0)
    D = np.full((T, 1), driven)
    F = np.zeros((T, 1, 3)) if fext is None else fext
    x, X = plant.integrate(model, U, D, F, dt, None if x0 is None else np.array([x0], float))
    return x[:, 0], X[:, 0]


def test_kinematics():
    FM, IK = plant.force_matrix(P3["d"]), plant.ik_matrix(P3["d"])
    D = FM @ IK
    want = np.diag([2.0, 2.0, 4 * P3["d"] ** 2])
    check("FM IK is diagonal [2, 2, 4d^2] (axes decouple)", np.allclose(D, want, atol=1e-15),
          np.round(np.diag(D), 6).tolist())
    a = plant.robot_params(5, 3)
    b = plant.robot_params(5, 3)
    f = [a[k] / P3[k] for k in plant.SCALED]
    check("robots are deterministic per (seed, k), factors in [0.7, 1.3], Kt = Kv",
          a == b and min(f) >= 0.7 and max(f) <= 1.3 and a["Kt"] == a["Kv"],
          f"factors {min(f):.3f}..{max(f):.3f}")


def test_steady():
    _, model = one_robot()
    d, r, l, Kt, Kv, R = (P3[k] for k in ("d", "r", "l", "Kt", "Kv", "R"))
    u = 7.0
    x, _ = run(model, [0, -u, 0, u], 6.0)
    vss = (2 * l * Kt * u / (r * R) - P3["Cv"]) / (2 * Kt * Kv * l ** 2 / (r ** 2 * R) + P3["Bv"])
    err = abs(x[-1, 0] - vss) / vss
    check("steady v under [0,-u,0,u], u = 7 V vs closed form", err < 1e-6,
          f"v {x[-1, 0]:.6f} m/s, closed form {vss:.6f}, rel err {err:.1e}; vn, w {x[-1, 1:]}")
    x, _ = run(model, [u, 0, -u, 0], 6.0)
    vnss = (2 * l * Kt * u / (r * R) - P3["Cvn"]) / (2 * Kt * Kv * l ** 2 / (r ** 2 * R)
                                                       + P3["Bvn"])
    err = abs(x[-1, 1] - vnss) / vnss
    check("steady vn under [u,0,-u,0] vs closed form", err < 1e-6,
          f"vn {x[-1, 1]:.6f} m/s, closed form {vnss:.6f}, rel err {err:.1e}")
    x, _ = run(model, [u] * 4, 6.0)
    wss = (4 * d * l * Kt * u / (r * R) - P3["Cw"]) / (4 * d * d * Kt * Kv * l ** 2 / (r ** 2 * R)
                                                     + P3["Bw"])
    err = abs(x[-1, 2] - wss) / wss
    check("steady w under [u,u,u,u] vs closed form", err < 1e-6,
          f"w {x[-1, 2]:.6f} rad/s, closed form {wss:.6f}, rel err {err:.1e}")


def test_coast():
    _, model = one_robot()
    for ax, name, x0, B, C, m in ((0, "v", 1.5, P3["Bv"], P3["Cv"], P3["M"]),
                                  (1, "vn", 1.2, P3["Bvn"], P3["Cvn"], P3["M"]),
                                  (2, "w", 15.0, P3["Bw"], P3["Cw"], P3["J"])):
        dt = 1e-3
        start = np.zeros(3)
        start[ax] = x0
        x, X = run(model, [0, 0, 0, 0], 6.0, dt, driven=False, x0=start)
        t = np.arange(len(x)) * dt
        ts = (m / B) * np.log(1 + B * x0 / C)
        closed = np.where(t < ts, (x0 + C / B) * np.exp(-B * t / m) - C / B, 0.0)
        err = np.max(np.abs(x[:, ax] - closed))
        first0 = int(np.argmax(x[:, ax] == 0.0))
        stop_err = abs(first0 * dt - ts)
        after = x[first0:, ax]
        check(f"coast-down along {name} from {x0} vs (x0 + C/B) e^(-Bt/m) - C/B",
              err < 1e-9 * x0 and stop_err <= dt and np.all(after == 0.0),
              f"max err {err:.1e}, stop {ts:.4f} s (sim {first0 * dt:.3f} s), "
              f"stays 0 after: {bool(np.all(after == 0.0))}")
        dist = (m / B) * ((x0 + C / B) * (1 - np.exp(-B * ts / m))) - C / B * ts
        derr = abs(X[:, ax].sum() - dist)
        check(f"coast-down along {name}: travelled distance vs closed form", derr < 1e-9,
              f"{X[:, ax].sum():.9f} vs {dist:.9f}")


def test_stiction():
    _, model = one_robot()
    gain = 2 * P3["l"] * P3["Kt"] / (P3["r"] * P3["R"])       # Fv per volt of the v pattern
    below, above = 0.97 * P3["Cv"] / gain, 1.03 * P3["Cv"] / gain
    x, _ = run(model, [0, -below, 0, below], 2.0)
    check("at rest, drive force 0.97 Cv: stays at rest", np.all(x == 0.0),
          f"max |x| {np.max(np.abs(x)):.1e}")
    x, _ = run(model, [0, -above, 0, above], 2.0)
    check("at rest, drive force 1.03 Cv: breaks away", x[-1, 0] > 0 and np.all(x[:, 1:] == 0),
          f"v after 2 s {x[-1, 0]:.5f} m/s")
    fext = np.zeros((2000, 1, 3))
    fext[:, 0, 2] = 0.99 * P3["Cw"]
    fext[:, 0, 0] = 0.99 * P3["Cv"]
    x, _ = run(model, [0] * 4, 2.0, driven=False, fext=fext)
    check("push just below Cv and Cw with the bridges off: no motion", np.all(x == 0.0),
          f"max |x| {np.max(np.abs(x)):.1e}")
    # reversal: full speed +v, then the opposite voltage: crosses zero once, no chatter
    T1, T2 = 3000, 8000
    U = np.zeros((T1 + T2, 1, 4), np.float32)
    U[:T1, 0] = [0, -8, 0, 8]
    U[T1:, 0] = [0, 8, 0, -8]
    x, _ = plant.integrate(model, U, np.ones((T1 + T2, 1), bool), np.zeros((T1 + T2, 1, 3)), 1e-3)
    sgn = np.sign(x[T1:, 0, 0])
    flips = int(np.count_nonzero(np.diff(sgn[sgn != 0])))
    vss = plant.steady_state(model, 0, [0, 8, 0, -8])[0]
    check("voltage reversal: one zero crossing, reaches -v_ss",
          flips == 1 and abs(x[-1, 0, 0] - vss) < 1e-6 * abs(vss),
          f"sign changes {flips}, v end {x[-1, 0, 0]:.6f} (v_ss {vss:.6f})")


def rk4_reference(model, u, fext_fn, x0, dt, T, sub=20):
    """Fine-step RK4 of one robot whose axes keep their sign (no stiction events): (T+1,3)."""
    m, B, C, K, G = (model[k][0] for k in ("m", "B", "C", "K", "G"))

    def f(t, x, k):
        F = G @ u[k] - K * x + fext_fn(t)
        return (F - B * x - C * np.sign(x)) / m

    xs = [np.array(x0, float)]
    x, h = np.array(x0, float), dt / sub
    for k in range(T):
        for j in range(sub):
            t = k * dt + j * h
            k1 = f(t, x, k)
            k2 = f(t + h / 2, x + h / 2 * k1, k)
            k3 = f(t + h / 2, x + h / 2 * k2, k)
            k4 = f(t + h, x + h * k3, k)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        xs.append(x.copy())
    return np.array(xs)


def test_rk4():
    p = plant.robot_params(3, 1)
    _, model = one_robot(p)
    dt, T = 1e-3, 1500
    t = np.arange(T) * dt
    P = {k: np.array(v) for k, v in plant.PATTERNS.items()}
    u = ((5 + 2 * np.sin(3 * t))[:, None] * P["v"] - (6 + 2 * np.cos(2 * t))[:, None] * P["vn"]
         + (2 + np.sin(5 * t))[:, None] * P["w"]).astype(np.float32)

    def fext_fn(tt):
        return np.array([2.0 * np.sin(4 * tt), -1.5, 0.1 * np.cos(tt)])

    x0 = [0.5, -0.4, 8.0]
    fmid = np.array([fext_fn(tk + dt / 2) for tk in t])[:, None]
    x, _ = plant.integrate(model, u[:, None], np.ones((T, 1), bool), fmid, dt, np.array([x0]))
    ref = rk4_reference(model, u.astype(float), fext_fn, x0, dt, T)
    signs_kept = np.all(np.sign(ref) == np.sign(ref[0]))
    err = np.max(np.abs(x[:, 0] - ref), axis=0)
    scale = np.max(np.abs(ref), axis=0)
    check("exact per-tick solution vs fine RK4 (time-varying push, 1.5 s, no sign change)",
          signs_kept and np.all(err < 1e-6 * scale),
          f"max err v {err[0]:.1e} m/s, vn {err[1]:.1e} m/s, w {err[2]:.1e} rad/s")


def test_encoder():
    dt, cpr, T = 1e-3, 10240, 5000
    omega = 23.456                                                  # wheel rad/s
    ang = (np.arange(T + 1) * dt * omega)[:, None, None] * np.ones((1, 1, 4))
    sp = plant.encoder_speeds(ang, cpr, dt, np.full((1, 4), 0.3))[1:, 0, 0]
    q = 2 * np.pi / cpr / dt
    steps = sp / q
    on_grid = np.allclose(steps, np.round(steps), atol=1e-9)
    err = np.abs(sp - omega)
    mean_err = abs(sp.mean() - omega)
    check(f"encoder cpr {cpr} at 1 kHz: speeds on the {q:.4f} rad/s grid, |err| < 1 count",
          on_grid and err.max() < q and mean_err < 2 * q / len(sp),
          f"values {sorted(set(np.round(steps).astype(int)))} counts/tick, max err "
          f"{err.max():.3f} rad/s, mean err {mean_err:.1e} rad/s")
    ang = np.zeros((101, 1, 4)) + 1e-4
    sp = plant.encoder_speeds(ang, cpr, dt)
    check("encoder at rest reads exactly 0", np.all(sp == 0.0), "max |speed| 0")


def test_noise():
    rng = np.random.default_rng(9)
    true = np.zeros((40000, 3))
    true[:, 2] = 3.1                                         # near the wrap at pi
    meas = plant.camera_measure(true, rng)
    sx, sy = np.std(meas[:, 0]), np.std(meas[:, 1])
    dth = plant.wrap_angle(meas[:, 2] - true[:, 2])
    sth = np.std(dth)
    wrapped = np.all((meas[:, 2] > -np.pi) & (meas[:, 2] <= np.pi))
    check("camera noise 1 cm / 0.052 rad, theta wrapped to (-pi, pi]",
          abs(sx - 0.01) < 3e-4 and abs(sy - 0.01) < 3e-4 and abs(sth - 0.052) < 1.5e-3
          and wrapped and np.any(meas[:, 2] < 0),
          f"std x {sx * 100:.3f} cm, y {sy * 100:.3f} cm, theta {sth:.4f} rad, wrapped {wrapped}")
    pa, _ = one_robot()
    T = 20000
    cur = plant.motor_currents(pa, np.full((T, 1, 4), 6.0), np.zeros((T, 1), bool),
                               np.ones((T, 1, 3)), rng)
    check("current with the bridges off: zero-mean noise, 0.02 A",
          abs(cur.std() - 0.02) < 5e-4 and abs(cur.mean()) < 5e-4,
          f"mean {cur.mean():.1e} A, std {cur.std():.5f} A")
    cur = plant.motor_currents(pa, np.full((T, 1, 4), 6.0), np.ones((T, 1), bool),
                               np.zeros((T, 1, 3)), rng)
    check("stalled motor at 6 V draws u/R", abs(cur.mean() - 6.0 / P3["R"]) < 5e-4,
          f"{cur.mean():.4f} A vs {6.0 / P3['R']:.4f} A")


def test_pose():
    X = np.zeros((1000, 1, 3))
    X[:, 0, 0] = 1e-3                                        # 1 m/s along v for 1 s
    pose = plant.world_poses(X, np.array([[0.2, -0.3, 0.7]]))
    want = [0.2 + np.cos(0.7), -0.3 + np.sin(0.7)]
    e1 = np.hypot(pose[-1, 0, 0] - want[0], pose[-1, 0, 1] - want[1])
    X[:, 0, 0], X[:, 0, 1] = 1e-3, 0.0
    X[:, 0, 2] = 2 * np.pi / 1000                            # one turn while moving 1 m along v
    pose = plant.world_poses(X, np.array([[0.0, 0.0, 0.0]]))
    e2 = np.hypot(pose[-1, 0, 0], pose[-1, 0, 1])            # a circle closes
    check("world pose (eq 1): straight line at theta0, full circle closes",
          e1 < 1e-12 and e2 < 1e-4, f"line err {e1:.1e} m, circle gap {e2:.1e} m")


def test_encoding(lcm_python):
    lcm, omni4 = write_logs.import_types(lcm_python)
    rng = np.random.default_rng(4)
    n = 5
    ut, sq = rng.integers(0, 2**40, n), rng.integers(0, 2**31, n)
    md = rng.integers(0, 4, n).astype(np.int8)
    V, I, S = (rng.normal(0, 5, (n, 4)).astype(np.float32) for _ in range(3))
    enc = write_logs.encode_motors(omni4, ut, sq, md, V, I, S)
    same = True
    for j in range(n):
        m = omni4.motors_t()
        m.utime, m.seq, m.mode, m.faults = int(ut[j]), int(sq[j]), int(md[j]), 0
        m.voltage, m.current, m.wheel_speed = V[j].tolist(), I[j].tolist(), S[j].tolist()
        same &= m.encode() == enc[j]
    P = rng.normal(0, 3, (n, 3))
    encp = write_logs.encode_poses(omni4, ut, P)
    for j in range(n):
        q = omni4.pose_t()
        q.utime, q.x, q.y, q.theta = int(ut[j]), *P[j].tolist()
        same &= q.encode() == encp[j]
    check("vectorised motors_t / pose_t encoding equals the lcm-gen types' encode()", same,
          f"{n} + {n} messages, {len(enc[0])} and {len(encp[0])} bytes")


def read_log(lcm, omni4, path):
    """All events of a log: (timestamps, motors list, poses list, marks list)."""
    ts, mot, pos, mk = [], [], [], []
    for ev in lcm.EventLog(path, "r"):
        ts.append(ev.timestamp)
        if ev.channel == write_logs.CH_MOTORS:
            mot.append(omni4.motors_t.decode(ev.data))
        elif ev.channel == write_logs.CH_POSE:
            pos.append(omni4.pose_t.decode(ev.data))
        elif ev.channel == write_logs.CH_EXP:
            mk.append(omni4.experiment_t.decode(ev.data))
    return ts, mot, pos, mk


def test_roundtrip(lcm_python):
    lcm, omni4 = write_logs.import_types(lcm_python)
    with tempfile.TemporaryDirectory() as tmp:
        for layout in ("jitter", "hand"):
            res = write_logs.generate(layout, 3, [0], tmp, lcm_python=lcm_python, progress=None)[0]
            ts, mot, pos, mk = read_log(lcm, omni4, res["log"])
            c = res["counts"]
            counts_ok = (len(mot), len(pos), len(mk)) == (c["motors"], c["poses"], c["marks"])
            seqs = np.array([m.seq for m in mot])
            ut = np.array([m.utime for m in mot])
            gaps = np.diff(seqs)
            lost = int(np.sum(gaps - 1))
            dt_us = 1000
            ut_ok = np.all(np.diff(ut) == gaps * dt_us)
            mono = np.all(np.diff(ts) >= 0)
            kinds = [m.kind for m in mk]
            alt = all((k == "end") == (j % 2 == 1) for j, k in enumerate(kinds))
            closed = kinds[-1] == "end" and np.all(np.diff([m.utime for m in mk]) > 0)
            cam_dt = np.diff([q.utime for q in pos])
            cam_ok = np.all(cam_dt % 40000 == 0)
            ticks = int((ut[-1] - ut[0]) / dt_us) + 1
            ok = counts_ok and ut_ok and mono and alt and closed and cam_ok
            if layout == "jitter":
                bursts = int(np.sum(gaps > 5))
                ok = ok and bursts >= 3 and 0.004 < lost / ticks < 0.01 + 60 / ticks
                cam_missing = 1 - len(pos) / (ticks / 40)
                ok = ok and 0.05 < cam_missing < 0.15
                extra = (f"lost {lost} of {ticks} samples ({100 * lost / ticks:.2f} %), "
                         f"{bursts} bursts > 5, camera frames missing {100 * cam_missing:.1f} %")
            else:
                modes = {m.mode for m in mot}
                mut = [m.utime for m in mk]
                pushed = all(m.mode in (0, 3) for m in mot for j in range(0, len(mk), 2)
                             if mk[j].kind == "coast" and mut[j] <= m.utime < mut[j + 1])
                extra = f"modes seen {sorted(modes)}, coast segments bridges off: {pushed}"
                ok = ok and lost == 0 and modes == {0, 2, 3} and pushed
            check(f"log round trip ({layout}): counts, seq/utime gaps, time order, marks",
                  ok, f"{len(mot)} motors, {len(pos)} poses, {len(mk)} marks "
                  f"({len(kinds) // 2} segments, alternating with end: {alt}); {extra}")


def main(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="example:\n  .venv/bin/python tests/indep/test_plant.py build/lcmtypes/gen/python")
    ap.add_argument("lcm_python", nargs="?", default=None,
                    help="folder with the generated package omni4 "
                    "(default build/lcmtypes/gen/python)")
    a = ap.parse_args(argv)
    for test in (test_kinematics, test_steady, test_coast, test_stiction, test_rk4, test_encoder,
                 test_noise, test_pose, test_sensor_draws, test_eccentricity, test_jitter):
        test()
    try:
        test_encoding(a.lcm_python)
        test_roundtrip(a.lcm_python)
        test_sensor_logs(a.lcm_python)
    except write_logs.LogError as e:
        check("LCM encoding and log round trip", False, str(e))
    failed = RESULTS.count(False)
    print(f"indep_plant: {len(RESULTS) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
