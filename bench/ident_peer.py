#!/usr/bin/env python3
"""Peer for the identification benchmark: a straightforward numpy/scipy script doing the same
regressions as `omni4-ident identify` on the same logs (motor test eq 22, experiment 1 eq 16,
experiment 2 integral form of eqs 17-19 and eq 20, experiment 3 LS eq 32 and IV eq 35).

usage: PYTHONPATH=build/lcmtypes/gen/python ident_peer.py LOG...
The event log format is read with struct (sync word, event number, timestamp, channel, data);
messages are decoded with the lcm-gen Python bindings.
"""
import struct
import sys
import time

import numpy as np
from scipy.signal import savgol_filter

from omni4 import experiment_t, motors_t, pose_t  # noqa: F401  (generated)

SYNC = 0xEDA1DA01
D, R_WHEEL, L, M = 0.089, 0.0325, 5.0, 2.34


def read_log(path):
    motors, marks = [], []
    with open(path, "rb") as f:
        data = f.read()
    pos, n = 0, len(data)
    while pos + 28 <= n:
        sync, _num, _ts, clen, dlen = struct.unpack_from(">IqqII", data, pos)
        if sync != SYNC:
            pos += 1
            continue
        start = pos + 28
        chan = data[start:start + clen].decode()
        payload = data[start + clen:start + clen + dlen]
        pos = start + clen + dlen
        if chan == "OMNI4_MOTORS":
            m = motors_t.decode(payload)
            motors.append((m.utime, m.mode, *m.voltage, *m.current, *m.wheel_speed))
        elif chan == "OMNI4_EXPERIMENT":
            e = experiment_t.decode(payload)
            marks.append((e.utime, e.kind, e.direction, e.level))
    return np.array(motors, dtype=float), marks


def segments(motors, marks):
    t = motors[:, 0]
    out = []
    for k, (t0, kind, direction, level) in enumerate(marks):
        if kind == "end":
            continue
        t1 = marks[k + 1][0] if k + 1 < len(marks) else t[-1] + 1
        a, b = np.searchsorted(t, t0), np.searchsorted(t, t1)
        if b > a:
            out.append((kind, direction, level, motors[a:b]))
    return out


def robot_velocity(seg):
    vw = seg[:, 10:14] * R_WHEEL
    return np.stack([(vw[:, 3] - vw[:, 1]) / 2, (vw[:, 0] - vw[:, 2]) / 2,
                     vw.sum(axis=1) / (4 * D)], axis=1)


def steady(seg, frac=0.4):
    driven = np.nonzero(seg[:, 1] == 2)[0]
    last = driven[-1] + 1 if len(driven) else len(seg)
    return seg[last - int(frac * last):last]


def motor_test(segs):
    """Kv and R (averaged over the motors) from the motor test, eq 22 per motor."""
    pts = [[] for _ in range(4)]
    for kind, _d, _l, s in segs:
        if kind != "motor":
            continue
        w = steady(s)
        for j in range(4):
            u, i, wm = w[:, 2 + j].mean(), w[:, 6 + j].mean(), w[:, 10 + j].mean() * L
            if abs(u) > 1 and abs(i) > 0.05:
                pts[j].append((u, i, wm))
    Rs = []
    allp = np.array([p for ps in pts for p in ps])
    for ps in pts:
        a = np.array(ps)
        Rs.append(np.linalg.lstsq(np.c_[a[:, 2] / a[:, 1], np.ones(len(a))], a[:, 0] / a[:, 1],
                                  rcond=None)[0][1])
    Kv = np.linalg.lstsq(np.c_[allp[:, 2] / allp[:, 1], np.ones(len(allp))],
                         allp[:, 0] / allp[:, 1], rcond=None)[0][0]
    return Kv, float(np.mean(Rs))


def experiment1(segs, Kv):
    """Bw, Cw from the steady rotations, eq 16."""
    rows = []
    for kind, _d, _l, s in segs:
        if kind == "steady_rotation":
            w = steady(s)
            T = D * L * Kv / R_WHEEL * w[:, 6:10].sum(axis=1).mean()
            rows.append((robot_velocity(w)[:, 2].mean(), T))
    a = np.array(rows)
    return np.linalg.lstsq(np.c_[a[:, 0], np.ones(len(a))], a[:, 1], rcond=None)[0]


def experiment2(segs):
    """Per direction, (b, c, the speeds fitted) of the coast-downs: x = x0_s - b int x - c t."""
    res = {}
    for ax, name in enumerate(["v", "vn", "w"]):
        X, y = [], []
        runs = [s for kind, d, _l, s in segs if kind == "coast" and d == name]
        for si, s in enumerate(runs):
            x = savgol_filter(robot_velocity(s)[:, ax], 41, 2)
            t = (s[:, 0] - s[0, 0]) * 1e-6
            sign = 1.0 if x[20] >= 0 else -1.0
            x = sign * x
            stop = 0.5 if ax == 2 else 0.05
            keep = np.nonzero(x < stop)[0]
            end = keep[keep > 50][0] if np.any(keep > 50) else len(x)
            x, t = x[50:end], t[50:end]
            integ = np.concatenate([[0], np.cumsum(0.5 * (x[1:] + x[:-1]) * np.diff(t))])
            cols = np.zeros((len(x), len(runs) + 2))
            cols[:, si] = 1
            cols[:, -2] = -integ
            cols[:, -1] = -(t - t[0])
            X.append(cols)
            y.append(x)
        theta = np.linalg.lstsq(np.vstack(X), np.concatenate(y), rcond=None)[0]
        res[name] = (theta[-2], theta[-1], np.concatenate(y))
    return res


def step_rows(segs, ax, name):
    """Experiment 3's regression rows of one axis: [x, input, sign x] -> dx, and where each
    step starts."""
    Xs, ys, starts = [], [], []
    for kind, d, _l, s in segs:
        if kind != "step" or d != name:
            continue
        x = robot_velocity(s)[:, ax]
        dt = 1e-3
        xs = savgol_filter(x, 41, 2)
        dx = savgol_filter(x, 41, 2, deriv=1, delta=dt)
        u = s[:, 2:6]
        inp = [u[:, 3] - u[:, 1], u[:, 0] - u[:, 2], u.sum(axis=1)][ax]
        inp = savgol_filter(np.concatenate([[inp[0]], inp[:-1]]), 41, 2)
        thr = 0.5 if ax == 2 else 0.05
        driven = s[:, 1] == 2
        idx = np.nonzero((np.abs(xs) >= thr) & driven)[0]
        idx = idx[(idx >= 20) & (idx < len(x) - 20)]
        starts.append(sum(len(v) for v in ys))
        Xs.append(np.c_[xs[idx], inp[idx], np.sign(xs[idx])])
        ys.append(dx[idx])
    return np.vstack(Xs), np.concatenate(ys), starts


def experiment3(segs):
    """Per axis, the steps' LS fit then three IV iterations."""
    th = {}
    for ax, name in enumerate(["v", "vn", "w"]):
        X, y, starts = step_rows(segs, ax, name)
        theta = np.linalg.lstsq(X, y, rcond=None)[0]
        for _ in range(3):
            Z = X.copy()
            bounds = starts + [len(X)]
            for r in range(len(starts)):
                xb = X[bounds[r], 0]
                for k in range(bounds[r], bounds[r + 1]):
                    Z[k, 0], Z[k, 2] = xb, np.sign(xb)
                    xb += 1e-3 * (theta[0] * xb + theta[1] * X[k, 1] + theta[2] * np.sign(xb))
            theta = np.linalg.solve(Z.T @ X, Z.T @ y)
        th[name] = theta
    return th


def main(paths):
    segs = []
    for p in paths:
        motors, marks = read_log(p)
        segs += segments(motors, marks)
    Kv, R = motor_test(segs)
    Bw, Cw = experiment1(segs, Kv)
    res = experiment2(segs)
    Bv, Cv = M * res["v"][0], M * res["v"][1]
    Bvn, Cvn = M * res["vn"][0], M * res["vn"][1]
    bw, cw, wv = res["w"]
    J = np.sum((bw * wv + cw) * (Bw * wv + Cw)) / np.sum((bw * wv + cw) ** 2)
    th = experiment3(segs)
    emf = Kv * Kv * L * L / R_WHEEL ** 2
    R3 = np.mean([L * Kv / (R_WHEEL * M * th[n][1]) for n in ("v", "vn")])
    J3 = L * Kv * D / (R_WHEEL * R3 * th["w"][1])
    out = {
        "Kv": Kv, "R": (R + R3) / 2, "J": (J + J3) / 2,
        "Bv": (Bv - M * th["v"][0] - 2 * emf / R3) / 2,
        "Bvn": (Bvn - M * th["vn"][0] - 2 * emf / R3) / 2,
        "Bw": (Bw - J3 * th["w"][0] - 4 * D * D * emf / R3) / 2,
        "Cv": (Cv - M * th["v"][2]) / 2, "Cvn": (Cvn - M * th["vn"][2]) / 2,
        "Cw": (Cw - J3 * th["w"][2]) / 2,
    }
    return out

if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    t0 = time.perf_counter()
    params = main(sys.argv[1:])
    dt = time.perf_counter() - t0
    print(" ".join(f"{k} {v:.5g}" for k, v in params.items()))
    print(f"peer wall time: {dt:.3f} s")
