"""Self-test of the independent plant, its real sensors: the drawn values, eccentric encoders,
late loop ticks, and logs with current offsets, camera latency and losses (test_plant.py runs
them)."""
import json
import os
import tempfile

import numpy as np

import layouts
import plant
import write_logs
from plant_checks import check

P3 = plant.TABLE_III


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
