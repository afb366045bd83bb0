#!/usr/bin/env python3
"""Self-test of the independent plant: closed forms, stiction, an RK4 cross-check, encoder
quantisation, camera and current noise, message encoding and an LCM event-log round trip; the
real sensors: current offsets, eccentric encoders, late loop ticks, camera latency, losses.

Prints the figure behind every check and ends with 'indep_plant: N passed, M failed'.
"""
import argparse
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
P3 = plant.TABLE_III


def check(name, ok, figure):
    """Record and print one check: name, pass/fail, the figure it rests on."""
    RESULTS.append(bool(ok))
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {figure}")


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


# ---- real sensors ---------------------------------------------------------------------------

def test_sensor_draws():
    a, b = plant.sensor_params(5, 3), plant.sensor_params(5, 3)
    same = all(np.array_equal(a[k], b[k]) for k in a)
    draws = [plant.sensor_params(1, k) for k in range(200)]
    off = np.array([d["current_offset_a"] for d in draws])
    ecc = np.array([d["eccentricity"] for d in draws])
    lat = np.array([(d["camera_latency_s"], d["camera_latency_s"] + d["camera_latency_spread_s"])
                    for d in draws])
    jit = np.array([d["jitter_mean_us"] for d in draws])
    ok = (same and np.all(np.abs(off) <= 0.060) and off.min() < -0.05 and off.max() > 0.05
          and np.all((ecc >= 0.005) & (ecc <= 0.015)) and np.all(lat[:, 0] >= 0.020)
          and np.all(lat[:, 1] <= 0.060) and np.all((jit >= 20) & (jit <= 40)))
    check("sensor values deterministic per (seed, k); offsets in +-60 mA, eccentricity "
          "0.005-0.015, camera latency 20-60 ms, tick lateness mean 20-40 us", ok,
          f"200 robots: offsets {1e3 * off.min():.1f}..{1e3 * off.max():.1f} mA, eccentricity "
          f"{ecc.min():.4f}..{ecc.max():.4f}, latency {1e3 * lat.min():.1f}..{1e3 * lat.max():.1f}"
          f" ms, lateness mean {jit.min():.1f}..{jit.max():.1f} us")


def test_eccentricity():
    """Constant wheel speed: the once-per-MOTOR-revolution harmonic of the encoder speed has the
    relative amplitude eps (times sinc of half a tick's motor angle) and the phase phi0."""
    sp = plant.sensor_params(1, 4)
    eps, phi = sp["eccentricity"], sp["eccentricity_phase_rad"]
    gear, dt, cpr, T = P3["l"], 1e-3, 16384, 40000
    omega = 21.37                                                   # wheel speed [rad/s]
    angle0 = np.array([[0.4, 1.1, 2.9, 5.0]])
    ang = (np.arange(T + 1) * dt * omega)[:, None, None] * np.ones((1, 1, 4))
    speed = plant.encoder_speeds(ang, cpr, dt, angle0, np.array([gear]), eps[None],
                                 phi[None])[1:, 0]                 # ticks 1..T-1
    T = len(speed)
    mid = gear * (angle0[0][None] + (np.arange(1, T + 1) - 0.5)[:, None] * dt * omega)
    half = 0.5 * gear * omega * dt                                  # half a tick's motor angle
    want = eps * np.sin(half) / half
    amp, rel, wheel_h = np.empty(4), np.empty(4), np.empty(4)
    for j in range(4):
        c, s_ = np.cos(mid[:, j] - phi[j]), np.sin(mid[:, j] - phi[j])
        A = np.stack([np.ones(T), c, s_], axis=1)
        coef = np.linalg.lstsq(A, speed[:, j], rcond=None)[0]
        amp[j] = np.hypot(coef[1], coef[2]) / coef[0]
        rel[j] = coef[2] / coef[0]                                 # quadrature: phase error
        wa = mid[:, j] / gear                                        # wheel angle
        Aw = np.stack([np.ones(T), np.cos(wa), np.sin(wa)], axis=1)
        cw = np.linalg.lstsq(Aw, speed[:, j], rcond=None)[0]
        wheel_h[j] = np.hypot(cw[1], cw[2]) / cw[0]
    err = np.abs(amp / want - 1.0)
    check("eccentric encoder at constant speed: once-per-motor-rev ripple = eps (+-10 %), in "
          "phase, none once per wheel rev", np.all(err < 0.10) and np.all(np.abs(rel) < 0.1 * eps)
          and np.all(wheel_h < 0.1 * eps),
          f"eps {np.round(eps, 4).tolist()}, fitted {np.round(amp, 4).tolist()} (rel err max "
          f"{err.max() * 100:.1f} %), per-wheel-rev harmonic max {wheel_h.max():.1e}")
    flat = plant.encoder_speeds(ang, cpr, dt, angle0, np.array([gear]), np.zeros((1, 4)),
                                phi[None])
    ideal = plant.encoder_speeds(ang, cpr, dt, angle0)
    mean_err = np.abs(speed.mean(axis=0) - omega).max()
    check("eccentricity 0 reads as the ideal encoder; the ripple averages out",
          np.max(np.abs(flat - ideal)) <= 2 * np.pi / cpr / dt + 1e-9 and mean_err < 1e-3,
          f"max |ideal - eps 0| {np.max(np.abs(flat - ideal)):.2g} rad/s, mean speed error "
          f"{mean_err:.1e} rad/s")


def test_jitter():
    """A constant-voltage spin-up with late ticks: the plant's velocity at each logged utime is
    the closed-form exponential at that (true) time, not at the due time."""
    dt = 1e-3
    p = plant.robot_params(2, 6)
    model = plant.axis_model(plant.stack_params([p]))
    u = np.array([0.0, -7.0, 0.0, 7.0])
    tl = layouts.Timeline(dt, model, 0)
    tl.idle(0.05)
    k_on = tl.n
    tl.ramp_to(u, dt)                                 # one tick: the full voltage from k_on on
    tl.hold(1.5)
    sim = write_logs.simulate_timelines([tl], [p], dt, jitter=[(np.random.default_rng(3), 30.0,
                                                                0.01)])
    sim.update({"cpr": [10240], "bases": ["runner"]})
    data = write_logs.sensor_data(sim, 0, 6, 2, "runner", effects=("jitter",))
    utime = data["motors"]["utime"] - data["t0"]      # true tick times [us] as logged
    ticks = data["ticks"]
    late = utime - ticks * 1000
    t_on = utime[ticks == k_on][0] * 1e-6
    Beff = model["B"][0, 0] + model["K"][0, 0]
    vss = (model["G"][0, 0] @ u - model["C"][0, 0]) / Beff
    tau = model["m"][0, 0] / Beff
    sel = ticks >= k_on
    v = sim["x"][ticks[sel], 0, 0]
    t_true = utime[sel] * 1e-6 - t_on
    t_due = (ticks[sel] - k_on) * dt
    err_true = np.max(np.abs(v - vss * (1 - np.exp(-t_true / tau))))
    err_due = np.max(np.abs(v - vss * (1 - np.exp(-t_due / tau))))
    check("late ticks: utime late 0-450 us, spikes of 100-200 us, intervals vary",
          late.min() >= 0 and late.max() <= 450 and np.sum(late >= 100) >= 5
          and 20 < late.mean() < 45 and len(set(np.diff(utime).tolist())) > 50,
          f"late mean {late.mean():.1f} us, max {late.max()} us, {np.sum(late >= 100)} of "
          f"{len(late)} >= 100 us")
    check("spin-up on late ticks: velocity at the logged utime = closed form at that time",
          err_true < 1e-9 * vss and err_due > 100 * err_true,
          f"v_ss {vss:.4f} m/s, tau {tau:.4f} s; max err at utime {err_true:.1e} m/s, at the "
          f"due times {err_due:.1e} m/s")


def read_log_arrays(lcm, path):
    """A log as arrays: motors (structured, with event timestamps 'ts'), poses (same), marks
    count; decoded with write_logs' packed layouts (checked against lcm-gen by test_encoding)."""
    raw = {write_logs.CH_MOTORS: [], write_logs.CH_POSE: []}
    ts = {write_logs.CH_MOTORS: [], write_logs.CH_POSE: []}
    order = []
    for ev in lcm.EventLog(path, "r"):
        if ev.channel in raw:
            raw[ev.channel].append(ev.data)
            ts[ev.channel].append(ev.timestamp)
            order.append(ev.channel == write_logs.CH_POSE)
    mot = np.frombuffer(b"".join(raw[write_logs.CH_MOTORS]), write_logs.motors_dtype())
    pos = np.frombuffer(b"".join(raw[write_logs.CH_POSE]), write_logs.pose_dtype())
    return (mot, np.array(ts[write_logs.CH_MOTORS]), pos, np.array(ts[write_logs.CH_POSE]),
            np.array(order))


def test_sensor_logs(lcm_python):
    """Logs of robot 0 (runner) ideal, with offsets only, and in the `sensors` layout (runner
    timeline, every effect): offsets, latency and losses as they reach the log."""
    lcm, _ = write_logs.import_types(lcm_python)
    with tempfile.TemporaryDirectory() as tmp:
        ideal = write_logs.generate("runner", 1, [0], os.path.join(tmp, "i"), progress=None,
                                    lcm_python=lcm_python)[0]
        offs = write_logs.generate("runner", 1, [0], os.path.join(tmp, "o"), progress=None,
                                   lcm_python=lcm_python, sensors=("offsets",))[0]
        full = write_logs.generate("sensors", 1, [0], os.path.join(tmp, "s"), progress=None,
                                   lcm_python=lcm_python)[0]
        mi, _, pi, pti, _ = read_log_arrays(lcm, ideal["log"])
        mo, _, po, _, _ = read_log_arrays(lcm, offs["log"])
        ms, mts, ps, pts, is_pose = read_log_arrays(lcm, full["log"])
        with open(offs["sensors"]) as f:
            side_o = json.load(f)
        with open(full["sensors"]) as f:
            side = json.load(f)
        truth = write_logs.read_ini(full["truth"])
        with open(full["truth"]) as f:
            truth_text = f.read().lower()
    drawn = plant.sensor_params(1, 0)
    off = np.array(side_o["current_offset_a"])
    same = (np.array_equal(mi["utime"], mo["utime"]) and np.array_equal(mi["wheel_speed"],
            mo["wheel_speed"]) and np.array_equal(pi, po))
    diff = (mo["current"].astype(float) - mi["current"].astype(float)) - off[None]
    check("offsets only: currents = ideal currents + the drawn offset per channel, nothing else "
          "changes; the truth INI holds no offset",
          same and np.max(np.abs(diff)) < 1e-6 and np.allclose(off, drawn["current_offset_a"])
          and side["base_layout"] == "runner" and "offset" not in truth_text
          and set(truth) == set(plant.MODEL_KEYS),
          f"offsets {np.round(1e3 * off, 2).tolist()} mA, max |diff - offset| "
          f"{np.max(np.abs(diff)):.1e} A, other fields identical: {same}")
    # bridge-off samples (true current 0) of the full-sensor log: mean = offset within 3 SE
    off_s = np.array(side["current_offset_a"])
    bridges_off = np.isin(ms["mode"], (plant.MODE_IDLE, plant.MODE_COAST))
    cur = ms["current"][bridges_off].astype(float)
    mean, se = cur.mean(axis=0), cur.std(axis=0) / np.sqrt(len(cur))
    z = np.abs(mean - off_s) / se
    check("bridge-off mean current = drawn offset within 3 SE, every channel", np.all(z < 3.0),
          f"{len(cur)} samples: mean {np.round(1e3 * mean, 3).tolist()} mA vs "
          f"{np.round(1e3 * off_s, 3).tolist()} mA, SE {1e3 * se.max():.3f} mA, max "
          f"{z.max():.2f} SE")
    # latency: every pose event is written at capture + latency, inside the drawn range
    lat = (pts - ps["utime"]) * 1e-6
    lo, hi = side["camera_latency_s"]["min"], side["camera_latency_s"]["max"]
    drawn_ok = np.isclose(lo, drawn["camera_latency_s"]) and np.isclose(
        hi - lo, drawn["camera_latency_spread_s"])
    # out of order: motors events written before a pose event although sampled after its capture
    mot_before = np.cumsum(~is_pose)[is_pose] - 1               # index of the last motors event
    later = ms["utime"][np.maximum(mot_before, 0)] > ps["utime"]
    check("camera latency: every pose event's log time - utime inside the drawn range; poses "
          "land after later motors samples",
          drawn_ok and lat.min() >= lo - 1e-6 and lat.max() <= hi + 1e-6
          and np.all(np.diff(pts) >= 0) and np.all(np.diff(mts) >= 0) and later.mean() > 0.99,
          f"{len(lat)} poses: latency {1e3 * lat.min():.2f}-{1e3 * lat.max():.2f} ms, drawn "
          f"{1e3 * lo:.2f}-{1e3 * hi:.2f} ms; {100 * later.mean():.1f} % of the poses after a "
          f"later motors sample; ideal log: at most {np.max(pti - pi['utime'])} us")
    # losses: binomial, 4 sigma (the runner timeline loses nothing of its own)
    lo_ = side["losses"]
    n_m = lo_["motors_ticks"] - 2                                # first and last are kept
    lost_m = int(np.sum(np.diff(ms["seq"]) - 1))
    n_c, lost_c = lo_["camera_frames"], lo_["camera_frames"] - len(ps)
    pm, pc = plant.MOTORS_LOSS, plant.CAMERA_LOSS
    zm = (lost_m - n_m * pm) / np.sqrt(n_m * pm * (1 - pm))
    zc = (lost_c - n_c * pc) / np.sqrt(n_c * pc * (1 - pc))
    ideal_lost = int(np.sum(np.diff(mi["seq"]) - 1))
    check("losses: motors_t seq gaps 0.1 %, camera frames 5 %, within binomial 4 sigma",
          abs(zm) < 4 and abs(zc) < 4 and ideal_lost == 0 and lost_m == n_m + 2 - len(ms),
          f"motors lost {lost_m} of {n_m} ({100 * lost_m / n_m:.3f} %, {zm:+.2f} sigma), camera "
          f"{lost_c} of {n_c} ({100 * lost_c / n_c:.2f} %, {zc:+.2f} sigma)")
    late = np.diff(ms["utime"]) - np.diff(ms["seq"]) * 1000       # lateness differences [us]
    check("sensors log: motors utime = due time + lateness (tick intervals vary, never "
          "reordered)", np.all(np.diff(ms["utime"]) > 0) and np.abs(late).max() <= 450
          and np.std(late) > 10 and side["tick_late_us"]["max"] <= 450,
          f"interval - period: std {np.std(late):.1f} us, max |.| {np.abs(late).max()} us")


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
