#!/usr/bin/env python3
"""Write LCM event logs of simulated robots running the paper's experiments in foreign layouts.

For every robot K and layout L: OUT/robotK_L.lcmlog (channels OMNI4_MOTORS, OMNI4_POSE,
OMNI4_EXPERIMENT), OUT/robotK_base.ini ([model] d r l M: what is measured),
OUT/robotK_truth.ini (the full [model] the robot was simulated with) and OUT/robotK_L.sensors.json
(the real-sensor effects of that log and their true values: current offsets, encoder
eccentricities, tick jitter, camera latency, losses; the offsets are not in the truth INI,
identification has to find them). Robots are deterministic per (seed, K): robot 3 is the same
robot whatever --robots says.

Real sensors (--sensors): offsets, eccentricity, jitter, latency, losses, all or none. Default:
all for the `sensors` layout, none for the others.

Wheel layouts (--wheels 3|4, --angles A0,A1,.. [deg], --dist D|D0,D1,.. [m], or --geometry INI):
the robots have that layout (default the paper's, 0/90/180/270 deg at d); the truth INI gets
wheels, wheel_angle_j and d_j, the base INI does not; a three-wheel robot's slot 3 reads 0.

Needs the PyPI `lcm` package (lcm.EventLog) and the lcm-gen Python types of lcmtypes/ (package
omni4, generated at build time into build/lcmtypes/gen/python).
"""
import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import layouts  # noqa: E402
import plant    # noqa: E402
from logio import (CH_EXP, CH_MOTORS, CH_POSE, RECEIVE_DELAY_US, encode_mark,  # noqa: E402,F401
                   encode_motors, encode_poses, motors_dtype, pose_dtype, read_ini, write_ini,
                   write_log, write_sidecar)

DEFAULT_LCM_PYTHON = os.path.join(HERE, "..", "..", "build", "lcmtypes", "gen", "python")


class LogError(RuntimeError):
    """A log could not be generated (bad option, unphysical timeline)."""


def import_types(pythonpath=None):
    """Import lcm and the generated omni4 types; returns (lcm module, omni4 module)."""
    path = os.path.abspath(pythonpath or DEFAULT_LCM_PYTHON)
    if path not in sys.path:
        sys.path.insert(0, path)
    try:
        import lcm
    except ImportError:
        raise LogError("python module 'lcm' missing: run scripts/setup.sh (pip install lcm "
                       "into .venv) and use .venv/bin/python") from None
    try:
        import omni4
        from omni4 import experiment_t, motors_t, pose_t  # noqa: F401
    except ImportError:
        raise LogError(f"lcm-gen types 'omni4' not found under {path} (build the project "
                       "or give --lcm-python)") from None
    return lcm, omni4


# ---- one layout, many robots ------------------------------------------------------------------

def _losses(rng, n_ticks, n_cam, layout):
    """Kept-sample masks: motors (n_ticks,) and camera frames (n_cam,) for the layout (the
    `jitter` layout's own losses; the real-sensor losses come on top, in sensor_data)."""
    keep_m = np.ones(n_ticks, bool)
    keep_c = np.ones(n_cam, bool)
    if layout == "jitter":
        keep_m &= rng.uniform(size=n_ticks) >= 0.005
        for _ in range(int(rng.integers(3, 6))):
            start = int(rng.integers(1, n_ticks - 30))
            keep_m[start:start + int(rng.integers(5, 21))] = False
        keep_c &= rng.uniform(size=n_cam) >= 0.10
    keep_m[0] = keep_m[-1] = True
    return keep_m, keep_c


def parse_sensors(text):
    """'offsets,latency' | 'all' | 'none' -> tuple of effects in plant.SENSOR_EFFECTS order."""
    names = set()
    for name in str(text).split(","):
        name = name.strip()
        if name == "all":
            names.update(plant.SENSOR_EFFECTS)
        elif name in plant.SENSOR_EFFECTS:
            names.add(name)
        elif name not in ("none", ""):
            raise ValueError(f"--sensors {text!r}: unknown effect {name!r} (one of "
                             f"{', '.join(plant.SENSOR_EFFECTS)}, all, none)")
    return tuple(e for e in plant.SENSOR_EFFECTS if e in names)


def effects_for(layout, sensors=None):
    """Real-sensor effects of a layout's logs: `sensors` (a tuple from parse_sensors) if given,
    else all of them for the `sensors` layout and none for the others."""
    if sensors is not None:
        return tuple(sensors)
    return plant.SENSOR_EFFECTS if layout == "sensors" else ()


def _stream(seed, robot, layout, purpose):
    """Random stream of one robot's log in (base) layout for one purpose (an int tag)."""
    return np.random.default_rng([int(seed), int(robot), layouts.LAYOUTS.index(layout), purpose])


#: tags of the random streams: timeline (layouts.py) 11, sensor noise 22, speed noise 33, tick
#: jitter 44, camera latency 45, real-sensor losses 46
JITTER_STREAM, LATENCY_STREAM, LOSS_STREAM = 44, 45, 46


def simulate_timelines(tls, plist, dt, jitter=None):
    """Simulate robots (parameter dicts plist) through their timelines in one vectorised pass.

    dt [s] nominal loop period shared by all; jitter: None, or per robot None or (rng, mean_us,
    spike_prob) for late-waking ticks (plant.tick_times_us), integrated over the true intervals.
    Returns dict: params, p, model, dt, timelines, lengths (ticks per robot), u (T,n,4) [V],
    mode (T,n), driven (T,n), x (T+1,n,3) velocity [m/s, m/s, rad/s] at the ticks, X (T,n,3)
    displacement, tick_us (T+1,n) true start time of each tick from the first due time [us].
    """
    p = plant.stack_params(plist)
    model = plant.axis_model(p)
    arrs = [tl.arrays() for tl in tls]
    lengths = [len(a[1]) for a in arrs]
    T, n = max(lengths), len(tls)
    u = np.zeros((T, n, 4), np.float32)
    mode = np.full((T, n), plant.MODE_IDLE, np.int8)
    fext = np.zeros((T, n, 3))
    for i, (ui, mi, fi) in enumerate(arrs):
        u[:len(mi), i], mode[:len(mi), i], fext[:len(mi), i] = ui, mi, fi
    driven = np.isin(mode, plant.DRIVEN_MODES)
    u = np.where(driven[:, :, None], u, np.float32(0.0))
    dt_us = int(round(dt * 1e6))
    tick_us = np.repeat(np.arange(T + 1, dtype=np.int64)[:, None] * dt_us, n, axis=1)
    jitter = jitter or [None] * n
    for i, jit in enumerate(jitter):
        if jit is not None:
            rng, mean_us, spike_prob = jit
            tick_us[:, i] = plant.tick_times_us(rng, T, dt_us, mean_us, spike_prob)
    if any(j is not None for j in jitter):
        x, X = plant.integrate(model, u, driven, fext, np.diff(tick_us, axis=0) * 1e-6)
    else:
        x, X = plant.integrate(model, u, driven, fext, dt)
    return {"params": plist, "p": p, "model": model, "dt": dt, "timelines": tls,
            "lengths": lengths, "u": u, "mode": mode, "driven": driven, "x": x, "X": X,
            "tick_us": tick_us}


def simulate_layout(layout, seed, robots, omit=(), motor_subset=None, effects=(), wheels=None,
                    geometry=None):
    """Build the timelines of `robots` in `layout` and simulate them in one vectorised pass.

    The robots must share one loop rate (generate() groups the `sensors` layout's robots by
    rate). wheels: the per-wheel spread (R, Kv, r) fractions of plant.robot_params, None = equal;
    geometry: the wheel layout (plant.make_geometry), None = the paper's.
    Returns simulate_timelines' dict plus layout, robots, bases (base layout per robot)
    and cpr (encoder counts per wheel revolution per robot).
    Raises LogError if a layout's "robot at rest here" check fails.
    """
    plist = [plant.robot_params(seed, k, wheels, geometry) for k in robots]
    model = plant.axis_model(plant.stack_params(plist))
    tls, dts, cprs, bases = [], set(), [], []
    for i, k in enumerate(robots):
        tl, dt, cpr = layouts.build(layout, model, i, seed, k, omit, motor_subset)
        tls.append(tl)
        dts.add(dt)
        cprs.append(cpr)
        bases.append(layouts.base_layout(layout, k))
    if len(dts) != 1:
        raise LogError(f"layout {layout}: robots {list(robots)} do not share one loop rate")
    dt = dts.pop()
    jitter = None
    if "jitter" in effects:
        jitter = []
        for k, base in zip(robots, bases):
            sp = plant.sensor_params(seed, k)
            jitter.append((_stream(seed, k, base, JITTER_STREAM), sp["jitter_mean_us"],
                           sp["jitter_spike_prob"]))
    sim = simulate_timelines(tls, plist, dt, jitter)
    x = sim["x"]
    for i, tl in enumerate(tls):
        for tick in tl.rest_checks:
            if np.any(x[tick, i] != 0.0):
                raise LogError(f"layout {layout}, robot {robots[i]}: not at rest at "
                               f"t={tick * dt:.3f} s (x={x[tick, i]}); timeline too short")
    sim.update({"layout": layout, "robots": list(robots), "bases": bases, "cpr": cprs})
    return sim


def colored_noise(rng, shape, sigma, tau, dt):
    """AR(1) noise of standard deviation sigma and correlation time tau [s], along axis 0."""
    a = np.exp(-dt / tau)
    e = rng.normal(0.0, sigma * np.sqrt(1.0 - a * a), shape)
    out = np.empty(shape)
    out[0] = rng.normal(0.0, sigma, shape[1:])
    for k in range(1, shape[0]):
        out[k] = a * out[k - 1] + e[k]
    return out


def sensor_data(sim, i, robot, seed, layout, speed_noise=None, effects=()):
    """Sensor readings and losses of robot i (index) / number `robot` of a simulated layout.

    effects: the real-sensor effects to switch on (plant.SENSOR_EFFECTS). Each has its own
    random stream, so the readings that an effect does not touch are the same with it or
    without it (and robot k of `sensors` reads as robot k of its base layout).
    Returns dict of per-message arrays: motors (utime, seq, mode, voltage, current,
    wheel_speed), poses (utime, pose, recv_us: log time of each pose event, None = utime +
    0-300 us), marks [(utime, kind, direction, level)], t0 [us], sensors (the sidecar's dict).
    """
    base = layouts.base_layout(layout, robot)
    rng = np.random.default_rng([int(seed), int(robot), layouts.LAYOUTS.index(base), 22])
    sp = plant.sensor_params(seed, robot)
    n_t, dt, cpr = sim["lengths"][i], sim["dt"], sim["cpr"][i]
    p = {k: v[i:i + 1] for k, v in sim["p"].items()}
    x = sim["x"][:n_t + 1, i:i + 1]
    X = sim["X"][:n_t, i:i + 1]
    u = sim["u"][:n_t, i:i + 1].astype(float)
    driven = sim["driven"][:n_t, i:i + 1]
    offset = sp["current_offset_a"] if "offsets" in effects else None
    current = plant.motor_currents(p, u, driven, x[:-1], rng,
                                   None if offset is None else offset[None])[:, 0]
    ang = plant.wheel_angles(p, X)
    angle0 = rng.uniform(0, 2 * np.pi, (1, 4))
    if "eccentricity" in effects:
        speed = plant.encoder_speeds(ang, cpr, dt, angle0, p["l"], sp["eccentricity"][None],
                                     sp["eccentricity_phase_rad"][None])[:, 0]
    else:
        speed = plant.encoder_speeds(ang, cpr, dt, angle0)[:, 0]
    if speed_noise:  # an effect the model lacks: correlated wheel-speed measurement noise
        speed = speed + colored_noise(np.random.default_rng([int(seed), int(robot), 33]),
                                      speed.shape, speed_noise[0], speed_noise[1], dt)
    slots = plant.wheel_mask(p)[0]               # a three-wheel robot's slot 3 reads 0
    if not slots.all():
        speed = np.where(slots[None], speed, 0.0)
    pose0 = np.array([[rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-np.pi, np.pi)]])
    pose = plant.world_poses(X, pose0)[:, 0]
    period = int(round(1.0 / (plant.CAMERA_RATE_HZ * dt)))
    cam_ticks = np.arange(int(rng.integers(0, period)), n_t, period)
    cam = plant.camera_measure(pose[cam_ticks], rng)
    keep_m, keep_c = _losses(rng, n_t, len(cam_ticks), base)
    if "losses" in effects:
        lrng = _stream(seed, robot, base, LOSS_STREAM)
        keep_m &= plant.kept(lrng, n_t, sp["motors_loss"])
        keep_m[0] = keep_m[-1] = True
        keep_c &= plant.kept(lrng, len(cam_ticks), sp["camera_loss"])
    dt_us = int(round(dt * 1e6))
    t0 = int(rng.integers(10**9, 10**11))
    seq0 = int(rng.integers(0, 10**6))
    ticks = np.nonzero(keep_m)[0]
    tick_us = sim["tick_us"][:, i]
    cam_utime = t0 + tick_us[cam_ticks]
    recv_us = None
    if "latency" in effects:
        lat = plant.camera_latency_us(_stream(seed, robot, base, LATENCY_STREAM), len(cam_ticks),
                                      sp["camera_latency_s"], sp["camera_latency_spread_s"])
        recv_us = (cam_utime + lat)[keep_c]
    marks = sorted(((t0 + int(round(t * 1e6)), kind, d, lv)
                    for t, kind, d, lv in sim["timelines"][i].marks), key=lambda mk: mk[0])
    late = tick_us[:n_t] - np.arange(n_t) * dt_us
    on = set(effects)
    sensors = {
        "robot": int(robot), "layout": layout, "base_layout": base, "seed": int(seed),
        "effects": list(effects),
        "loop_rate_hz": 1.0 / dt, "encoder_cpr_per_wheel_rev": int(cpr), "gear": float(p["l"][0]),
        # what the log holds (zero / empty where the effect is off)
        "current_offset_a": [float(v) if "offsets" in on and s else 0.0
                             for v, s in zip(sp["current_offset_a"], slots)],
        "encoder_eccentricity": [float(v) if "eccentricity" in on else 0.0
                                 for v in sp["eccentricity"]],
        "encoder_eccentricity_phase_rad": [float(v) for v in sp["eccentricity_phase_rad"]],
        "tick_late_us": {"mean": float(late.mean()), "max": int(late.max()),
                         "drawn_mean": sp["jitter_mean_us"] if "jitter" in on else 0.0,
                         "drawn_spike_prob": sp["jitter_spike_prob"] if "jitter" in on else 0.0},
        "camera_latency_s": {"min": sp["camera_latency_s"] if "latency" in on else 0.0,
                             "max": (sp["camera_latency_s"] + sp["camera_latency_spread_s"])
                             if "latency" in on else 0.0},
        "losses": {"motors_loss": sp["motors_loss"] if "losses" in on else 0.0,
                   "camera_loss": sp["camera_loss"] if "losses" in on else 0.0,
                   "motors_ticks": int(n_t), "motors_kept": int(keep_m.sum()),
                   "camera_frames": int(len(cam_ticks)), "camera_kept": int(keep_c.sum())},
        # every value drawn for this robot, whether the log uses it or not
        "drawn": {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in sp.items()},
    }
    return {"t0": t0, "dt_us": dt_us, "ticks": ticks,
            "motors": {"utime": t0 + tick_us[ticks], "seq": seq0 + ticks,
                       "mode": sim["mode"][ticks, i], "voltage": sim["u"][ticks, i],
                       "current": current[ticks], "wheel_speed": speed[ticks]},
            "poses": {"utime": cam_utime[keep_c], "pose": cam[keep_c], "recv_us": recv_us},
            "marks": marks, "rng": rng, "sensors": sensors}


def rate_groups(layout, robots):
    """Robots of a layout grouped by loop rate (one simulation pass each): list of lists."""
    groups = {}
    for k in robots:
        groups.setdefault(layouts.loop_rate_hz(layout, k), []).append(k)
    return list(groups.values())


def generate(layout, seed, robots, out_dir, omit=(), motor_subset=None, lcm_python=None,
             progress=print, speed_noise=None, sensors=None, wheels=None, geometry=None,
             robot_msg=False):
    """Simulate `robots` in `layout` and write their logs, INI files and sensor sidecars.

    sensors: tuple of real-sensor effects (parse_sensors), None = the layout's default.
    wheels: per-wheel spread (R, Kv, r) fractions (parse_wheels), None = four equal drives.
    geometry: the wheel layout (parse_geometry), None = the paper's; its keys (wheels,
    wheel_angle_j, d_j) go into the truth INI only, and into the log's OMNI4_ROBOT (robot_t, the
    controller's description of its wheels: first tick, then 1 Hz) with robot_msg.
    Returns a list of dicts (robot, log, base, truth, sensors (sidecar path), effects,
    base_layout, seconds, counts) in robot order.
    """
    lcm, omni4 = import_types(lcm_python)
    os.makedirs(out_dir, exist_ok=True)
    effects = effects_for(layout, sensors)
    t_start = time.time()
    t_sim, out, rates, cprs = 0.0, [], set(), set()
    for group in rate_groups(layout, robots):
        t = time.time()
        sim = simulate_layout(layout, seed, group, omit, motor_subset, effects, wheels,
                              geometry)
        t_sim += time.time() - t
        rates.add(1.0 / sim["dt"])
        cprs.update(sim["cpr"])
        for i, k in enumerate(group):
            data = sensor_data(sim, i, k, seed, layout, speed_noise, effects)
            if robot_msg:
                data["robot"] = sim["params"][i]
            log = os.path.join(out_dir, f"robot{k}_{layout}.lcmlog")
            counts = write_log(lcm, omni4, log, data)
            base = os.path.join(out_dir, f"robot{k}_base.ini")
            truth = os.path.join(out_dir, f"robot{k}_truth.ini")
            side = os.path.join(out_dir, f"robot{k}_{layout}.sensors.json")
            write_ini(base, sim["params"][i], ("d", "r", "l", "M"))
            write_ini(truth, sim["params"][i], plant.ini_keys(sim["params"][i]))
            write_sidecar(side, data["sensors"])
            out.append({"robot": k, "log": log, "base": base, "truth": truth, "sensors": side,
                        "effects": effects, "base_layout": sim["bases"][i],
                        "seconds": sim["lengths"][i] * sim["dt"], "counts": counts})
        del sim
    out.sort(key=lambda o: o["robot"])
    if progress:
        secs = [o["seconds"] for o in out]
        rate = "-".join(f"{r:.0f}" for r in sorted(rates))
        cpr = "-".join(str(c) for c in sorted(cprs))
        progress(f"write_logs: {layout}: {len(robots)} robots, {min(secs):.0f}-{max(secs):.0f} s "
                 f"of robot time at {rate} Hz, cpr {cpr}, sensors "
                 f"{','.join(effects) or 'ideal'}; simulated in {t_sim:.1f} s, written in "
                 f"{time.time() - t_start - t_sim:.1f} s")
    return out


def parse_wheels(text):
    """'5,5,1' (per cent: motors' R, motors' Kv, wheel radii) -> (0.05, 0.05, 0.01) or None for
    '0,0,0'; raises ValueError."""
    try:
        v = tuple(float(x) / 100.0 for x in str(text).split(","))
    except ValueError:
        v = ()
    if len(v) != 3 or not all(0.0 <= x <= 0.2 for x in v):
        raise ValueError(f"--wheel-spread {text!r}: expected R,KV,RADIUS in per cent, each "
                         "0-20, e.g. 5,5,1")
    return v if any(v) else None


def parse_geometry(wheels=None, angles=None, dist=None, ini=None):
    """The wheel layout from --wheels N, --angles A0,A1,.. [deg], --dist D or D0,D1,.. [m], or
    an INI's [model] wheels / wheel_angle_j / d_j (--geometry); None if none is given (the
    paper's layout). Raises ValueError with one line."""
    if ini is not None:
        if wheels is not None or angles is not None or dist is not None:
            raise ValueError("--geometry excludes --wheels, --angles and --dist")
        try:
            m = read_ini(ini)
        except (OSError, ValueError) as e:
            raise ValueError(f"--geometry {ini}: {e}") from None
        n = int(m.get("wheels", 4))
        if n not in (3, 4) or m.get("wheels", 4) != n:
            raise ValueError(f"--geometry {ini}: wheels must be 3 or 4")
        angles = [m[plant.angle_key(j)] for j in range(n) if plant.angle_key(j) in m] or None
        dists = [m[plant.dist_key(j)] for j in range(n) if plant.dist_key(j) in m] or None
        return plant.make_geometry(n, angles, dists)
    if wheels is None and angles is None and dist is None:
        return None

    def floats(text, opt):
        try:
            return [float(v) for v in str(text).split(",")]
        except ValueError:
            raise ValueError(f"{opt} {text!r}: expected comma-separated numbers") from None
    n = 4 if wheels is None else wheels
    return plant.make_geometry(n, None if angles is None else floats(angles, "--angles"),
                               None if dist is None else floats(dist, "--dist"))


def parse_subset(text):
    """'0,2' -> (0, 2); raises ValueError on anything but distinct motor numbers 0..3."""
    try:
        s = tuple(sorted({int(v) for v in text.split(",") if v.strip()}))
    except ValueError:
        raise ValueError(f"--motor-subset {text!r}: expected motor numbers like 0,2") from None
    if not s or any(j < 0 or j > 3 for j in s):
        raise ValueError(f"--motor-subset {text!r}: motors are numbered 0..3")
    return s


def parse_layouts(values):
    """['rest', 'hand,jitter', 'all'] -> list of layout names; raises ValueError. 'all' is
    every layout with ideal sensors (all but `sensors`)."""
    names = []
    for v in values or ["all"]:
        for name in v.split(","):
            name = name.strip()
            if name == "all":
                names += [n for n in layouts.IDEAL_LAYOUTS if n not in names]
            elif name not in layouts.LAYOUTS:
                raise ValueError(f"unknown layout {name!r} (one of {', '.join(layouts.LAYOUTS)}"
                                 ", all = all but sensors)")
            elif name not in names:
                names.append(name)
    return names


def main(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="example:\n  .venv/bin/python tests/indep/write_logs.py --robots 3 --seed 1 "
               "--layout rest,hand --omit coast:w --out /tmp/logs\n"
               f"layouts: {', '.join(layouts.LAYOUTS)} (or all: all but sensors)")
    ap.add_argument("--robots", type=int, default=1, help="number of robots (0..N-1), default 1")
    ap.add_argument("--seed", type=int, default=1, help="seed of robots and noise, default 1")
    ap.add_argument("--layout", action="append", metavar="NAME[,NAME]",
                    help="layout(s), repeatable or comma-separated; default all")
    ap.add_argument("--omit", action="append", default=[], metavar="KIND[:DIR]",
                    help="leave out runs: steady_rotation|coast|motor|step, optionally :v|vn|w")
    ap.add_argument("--motor-subset", metavar="J,K", help="motor test drives only these motors")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--lcm-python", help="folder holding the generated package omni4 "
                    "(default: build/lcmtypes/gen/python)")
    ap.add_argument("--quiet", action="store_true", help="no progress lines")
    ap.add_argument("--sensors", metavar="EFFECT[,EFFECT]",
                    help="real-sensor effects for every layout: " + ", ".join(plant.SENSOR_EFFECTS)
                    + ", all or none (default: all for the sensors layout, none otherwise)")
    ap.add_argument("--wheel-spread", metavar="R,KV,RADIUS", default="0,0,0",
                    help="per-wheel drives: each motor's R and Kv off by up to +-R %%, +-KV %%, "
                         "each wheel's radius by up to +-RADIUS %% (mean unchanged); the truth "
                         "INI gets R_j Kv_j Kt_j r_j (default 0,0,0: four equal drives)")
    ap.add_argument("--wheels", type=int, choices=(3, 4),
                    help="wheel layout: number of wheels (default 4, the paper's layout)")
    ap.add_argument("--angles", metavar="A0,A1,..",
                    help="each wheel's position [deg] from the v axis, counter-clockwise "
                         "(e.g. 0,120,240 or 60,135,225,300; default 0,90,180,270)")
    ap.add_argument("--dist", metavar="D|D0,D1,..",
                    help="each wheel's distance from the centre [m] (one value: all; default: "
                         "the robot's d)")
    ap.add_argument("--geometry", metavar="INI",
                    help="the layout from an INI's [model] wheels, wheel_angle_j, d_j")
    ap.add_argument("--robot-msg", action="store_true",
                    help="the log carries OMNI4_ROBOT (robot_t: the layout, radii, gear) as a "
                         "controller writes it (first tick, then 1 Hz)")
    ap.add_argument("--speed-noise", metavar="SIGMA,TAU",
                    help="add correlated (AR(1)) noise to the wheel speeds: SIGMA [rad/s], "
                         "correlation time TAU [s], e.g. 0.3,0.02")
    a = ap.parse_args(argv)
    try:
        names = parse_layouts(a.layout)
        omit = layouts.parse_omit(a.omit)
        subset = parse_subset(a.motor_subset) if a.motor_subset else None
        if a.robots < 1:
            raise ValueError("--robots must be at least 1")
        sensors = None if a.sensors is None else parse_sensors(a.sensors)
        wheels = parse_wheels(a.wheel_spread)
        geometry = parse_geometry(a.wheels, a.angles, a.dist, a.geometry)
        noise = None
        if a.speed_noise:
            try:
                noise = tuple(float(v) for v in a.speed_noise.split(","))
            except ValueError:
                noise = ()
            if len(noise) != 2 or not noise[0] >= 0 or not noise[1] > 0:
                raise ValueError(f"--speed-noise {a.speed_noise!r}: expected SIGMA,TAU with "
                                 "SIGMA >= 0 [rad/s] and TAU > 0 [s]")
        for name in names:
            res = generate(name, a.seed, list(range(a.robots)), a.out, omit, subset,
                           a.lcm_python, None if a.quiet else print, noise, sensors, wheels,
                           geometry, a.robot_msg)
            if not a.quiet:
                for r in res:
                    c = r["counts"]
                    print(f"  {r['log']}: {r['seconds']:.1f} s, {c['motors']} motors, "
                          f"{c['poses']} poses, {c['marks']} marks")
    except (ValueError, LogError) as e:
        print(f"write_logs: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
