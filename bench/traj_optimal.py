#!/usr/bin/env python3
"""Time-optimal bound for the trajectory generator (docs/trajectory.md).

A direct method written from the per-wheel model alone (docs/model.md), not from core/src/planner/traj.c:
the state [x, y, theta, vx, vy, w] (world frame) and the four wheel voltages at N+1 nodes,
trapezoidal collocation of

    body velocity  xb = R(-theta) [vx, vy],  rim speeds v_j = g_j . [xb, w]     (eq 2)
    wheel forces   f_j = b u_j - e v_j                                          (eqs 21, 12-13)
    body forces    [Fv, Fvn, T] = sum_j g_j f_j - B x - C sgn(x)                (eqs 9-11)
    body accel     xb' = [Fv, Fvn] / M (eq 23: the body's axes carry the velocity as they
                   turn), so the world's  R(theta) [Fv, Fvn] / M + w [-vy, vx],  w' = T / J

with |u_j| <= supply - margin, |f_j| <= mu (1 - traction margin) N_j, the wheel's load
N_j = M g / 4 - M h (a . p_j) / (2 d^2) with the centre of mass's acceleration a (world
accel in the body frame; h the com height, p_j the wheel's position: the load transfer of
core/include/omni4/core/traction.h; h = 0: M g / 4), |v_j| <= the motor's
speed limit at the rim; minimise the duration T (SLSQP, Jacobian by coloured finite
differences: a defect touches two neighbouring nodes). sgn is smoothed over 0.02 m/s and
0.2 rad/s (tanh), which lets the optimum start a little cheaper than the real friction: the
bound is, if anything, low.

For each move it runs the C planner (tests/traj/traj_plan_cli.c, `build/bin/traj_plan`) with
the same limits and prints the planner's time, the bound and their ratio.

    python bench/traj_optimal.py build/bin/traj_plan           # the course, ratios
    python bench/traj_optimal.py --check build/bin/traj_plan   # the ctest: three moves,
                                                               # feasible and within 1.15x
    python bench/traj_optimal.py --share feedforward build/bin/traj_plan
        # the bound of this controller: the wheel forces shared as its feedforward shares a
        # body force (least squares: nothing along the null direction of eq 2's rows)
"""
import argparse
import math
import subprocess
import sys

import numpy as np
from scipy.optimize import minimize

# Table III of the paper (model/src/params.c), four equal drives.
D, RW, L, KV, KT, R, M, J = 0.089, 0.0325, 5.0, 0.0259, 0.0259, 4.3111, 2.34, 0.0228
B_FRIC = np.array([0.4978, 0.6763, 0.0141])
C_FRIC = np.array([1.8738, 2.2198, 0.1385])
G_WHEEL = np.array([[0.0, 1.0, D], [-1.0, 0.0, D], [0.0, -1.0, D], [1.0, 0.0, D]])  # eq 2
BAND = np.array([0.02, 0.02, 0.2])

LIMITS = dict(supply=12.0, margin=2.0, mu=0.6, traction_margin=0.1, motor_max=600.0,
              com_height=0.0)
P_WHEEL = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])  # p_j / d
# "free": any voltage on each wheel (the bound of the robot). "feedforward": the wheel forces
# shared as the controller's feedforward shares a body force (least squares, docs/model.md):
# no push along the null direction of eq 2's rows (G^T n = 0), the bound of this controller.
SHARE = "free"


def null_direction():
    """The unit n with G^T n = 0 (eq 2's rows; [1, -1, 1, -1] / 2 for the paper's)."""
    return np.linalg.svd(G_WHEEL.T)[2][-1]

# x0 y0 th0 vx0 vy0 w0 -> x y th
COURSE = [
    ((0, 0, 0, 0, 0, 0), (1.0, 0.0, 0.0)),
    ((0, 0, 0, 0, 0, 0), (0.7, 0.7, 0.0)),
    ((0, 0, 0, 0, 0, 0), (2.0, -1.0, 0.0)),
    ((0, 0, 0, 0, 0, 0), (0.3, 0.1, 0.0)),
    ((0, 0, 0, 0, 0, 0), (0.0, 1.5, 0.0)),
    ((0, 0, 0, 0, 0, 0), (1.5, 0.5, 2.0)),
    ((0, 0, 0, 0, 0, 0), (0.0, 0.0, 3.1)),
    ((0, 0, 0, 1.0, 0, 0), (-1.0, 0.0, 0.0)),
    ((0, 0, 0.7, 0, 0, 0), (-0.5, 3.0, 0.7)),
    ((0, 0, 0, 0, 0, 0), (0.1, 0.0, 0.0)),
    ((0, 0, 0, 0, 0, 0), (3.0, 1.0, 0.0)),
    ((0, 0, 0, 0, 0, 0), (1.0, 1.0, 1.0)),
    ((0, 0, 0, 1.0, 0, 0), (2.0, 0.0, 0.0)),
    ((0, 0, 0, 0.5, 0.5, 0), (1.0, -1.0, 0.0)),
]
CHECK = [0, 1, 6]


def drive():
    b = L * KT / (R * RW)
    e = L * L * KT * KV / (R * RW * RW)
    u_max = LIMITS["supply"] - LIMITS["margin"]
    f_max = LIMITS["mu"] * M * 9.80665 / 4.0 * (1.0 - LIMITS["traction_margin"])
    rim_max = LIMITS["motor_max"] * RW / L
    return b, e, u_max, f_max, rim_max


def wheel_terms(z, u):
    """Rim speeds, wheel forces and body-frame velocity for states z (n, 6), voltages u (n, 4)."""
    b, e, _, _, _ = drive()
    c, s = np.cos(z[:, 2]), np.sin(z[:, 2])
    xb = np.stack([c * z[:, 3] + s * z[:, 4], -s * z[:, 3] + c * z[:, 4], z[:, 5]], axis=1)
    v = xb @ G_WHEEL.T
    f = b * u - e * v
    return v, f, xb, c, s


def rates(z, u):
    v, f, xb, c, s = wheel_terms(z, u)
    F = f @ G_WHEEL - B_FRIC * xb - C_FRIC * np.tanh(xb / BAND)
    ax = (c * F[:, 0] - s * F[:, 1]) / M - z[:, 5] * z[:, 4]
    ay = (s * F[:, 0] + c * F[:, 1]) / M + z[:, 5] * z[:, 3]
    return np.stack([z[:, 3], z[:, 4], z[:, 5], ax, ay, F[:, 2] / J], axis=1)


class Problem:
    def __init__(self, start, goal, n):
        self.n = n
        self.z0 = np.array(start, float)
        self.zf = np.array([goal[0], goal[1], goal[2], 0.0, 0.0, 0.0])
        dth = math.remainder(goal[2] - start[2], 2 * math.pi)
        self.zf[2] = start[2] + dth  # the short way round, as the planner

    def unpack(self, w):
        X = w[:-1].reshape(self.n + 1, 10)
        return X[:, :6], X[:, 6:], w[-1]

    def defects(self, w):
        z, u, T = self.unpack(w)
        f = rates(z, u)
        h = T / self.n
        return (z[1:] - z[:-1] - 0.5 * h * (f[1:] + f[:-1])).ravel()

    def eq(self, w):
        z, u, _ = self.unpack(w)
        parts = [self.defects(w), z[0] - self.z0, z[-1] - self.zf]
        if SHARE == "feedforward":
            parts.append(wheel_terms(z, u)[1] @ null_direction())
        return np.concatenate(parts)

    def ineq(self, w):
        z, u, _ = self.unpack(w)
        v, f, _, c, s = wheel_terms(z, u)
        _, _, _, f_max, rim_max = drive()
        acc = rates(z, u)[:, 3:5]  # world
        a_body = np.stack([c * acc[:, 0] + s * acc[:, 1], -s * acc[:, 0] + c * acc[:, 1]], 1)
        lever = (LIMITS["mu"] * (1.0 - LIMITS["traction_margin"]) * M * LIMITS["com_height"]
                 / (2.0 * D))
        hold = f_max - lever * (a_body @ P_WHEEL.T)
        return np.concatenate([(hold - f).ravel(), (hold + f).ravel(), (rim_max - v).ravel(),
                               (rim_max + v).ravel()])

    def jac(self, fun, w, eps=1e-7):
        """Coloured differences: node k's variables only reach node k's rows and the defects
        on either side, so nodes of one parity (and one variable) are perturbed together."""
        base = fun(w)
        Jm = np.zeros((base.size, w.size))
        for parity in (0, 1):
            for k in range(10):
                idx = np.arange(parity, self.n + 1, 2) * 10 + k
                wp = w.copy()
                wp[idx] += eps
                diff = (fun(wp) - base) / eps
                for col in idx:
                    Jm[:, col] = diff * self.rows_mask(base.size, col // 10, fun)
        wp = w.copy()
        wp[-1] += eps
        Jm[:, -1] = (fun(wp) - base) / eps
        return Jm

    def rows_mask(self, size, node, fun):
        m = np.zeros(size)
        if fun == self.eq:
            nd = 6 * self.n
            for i in (node - 1, node):
                if 0 <= i < self.n:
                    m[6 * i:6 * i + 6] = 1
            if node == 0:
                m[nd:nd + 6] = 1
            if node == self.n:
                m[nd + 6:nd + 12] = 1
            if SHARE == "feedforward":
                m[nd + 12 + node] = 1
        else:
            per = 4 * (self.n + 1)
            for q in range(4):
                m[q * per + 4 * node:q * per + 4 * node + 4] = 1
        return m

    def solve(self, T0, guess=None):
        """guess: states (n+1, 6) to start from (the planner's reference: a warm start only;
        the optimum is the solver's), else a straight line at constant speed."""
        n = self.n
        if guess is None:
            s = np.linspace(0.0, 1.0, n + 1)
            guess = self.z0 + np.outer(s, self.zf - self.z0)
            guess[:, 3:] = (self.zf[:3] - self.z0[:3]) / T0
        w0 = np.concatenate([np.hstack([guess, np.zeros((n + 1, 4))]).ravel(), [T0]])
        _, _, u_max, _, _ = drive()
        bounds = ([(None, None)] * 6 + [(-u_max, u_max)] * 4) * (n + 1) + [(0.05, 30.0)]
        cons = [dict(type="eq", fun=self.eq, jac=lambda w: self.jac(self.eq, w)),
                dict(type="ineq", fun=self.ineq, jac=lambda w: self.jac(self.ineq, w))]
        res = minimize(lambda w: w[-1], w0, jac=lambda w: np.eye(w.size)[-1], bounds=bounds,
                       constraints=cons, method="SLSQP",
                       options=dict(maxiter=300, ftol=1e-8))
        viol = max(np.abs(self.eq(res.x)).max(), -min(self.ineq(res.x).min(), 0.0))
        return res.x[-1], viol, res


def planner(tool, start, goal, n, extra_opts=()):
    """The planner's duration and its reference at n + 1 evenly spaced times."""
    opts = [*extra_opts, f"--mu={LIMITS['mu']}", f"--supply={LIMITS['supply']}",
            f"--margin={LIMITS['margin']}", f"--traction-margin={LIMITS['traction_margin']}",
            f"--motor-max={LIMITS['motor_max']}", f"--com-height={LIMITS['com_height']}"]
    run = lambda extra: subprocess.run([tool, *opts, *extra, *map(str, start), *map(str, goal)],
                                       check=True, capture_output=True, text=True,
                                       timeout=10).stdout.splitlines()
    T = float(run([])[0].split()[1])
    rows = np.array([[float(x) for x in ln.split()] for ln in run([f"--samples={T / n}"])[1:]])
    ref = np.array([[np.interp(t, rows[:, 0], rows[:, 1 + k]) for k in range(6)]
                    for t in np.linspace(0.0, T, n + 1)])
    return T, ref


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("traj_plan", help="the planner's CLI (build/bin/traj_plan)")
    ap.add_argument("--check", action="store_true",
                    help="three moves; exit 1 unless each is feasible and within --bound")
    ap.add_argument("--nodes", type=int, default=20, help="collocation intervals (default 20)")
    ap.add_argument("--bound", type=float, default=1.15, help="largest planner/optimum ratio")
    ap.add_argument("--tol", type=float, default=0.03,
                    help="how much faster than the bound the planner may be (discretisation)")
    ap.add_argument("--share", choices=("free", "feedforward"), default="free",
                    help="the wheel forces: free (the robot's bound) or shared as the "
                    "feedforward shares them (this controller's bound)")
    ap.add_argument("--moves", help="comma-separated indices of the moves to run (default all)")
    ap.add_argument("--plan-arg", action="append", default=[],
                    help="an option for the planner's CLI (repeatable), e.g. --plan-arg=--curve=40")
    args = ap.parse_args()
    global SHARE
    SHARE = args.share
    cases = [COURSE[i] for i in CHECK] if args.check else COURSE
    if args.moves:
        cases = [COURSE[int(i)] for i in args.moves.split(",")]
    bad = 0
    print("move                                  planner_s  optimum_s  ratio  (violation)")
    for start, goal in cases:
        t_c, ref = planner(args.traj_plan, start, goal, args.nodes, args.plan_arg)
        t_o, viol, res = Problem(start, goal, args.nodes).solve(t_c, ref)
        ratio = t_c / t_o
        ok = res.success and viol < 1e-4 and 1.0 - args.tol <= ratio <= args.bound
        bad += not ok
        print(f"{str(start):22s} -> {str(goal):15s} {t_c:8.3f}  {t_o:9.3f}  {ratio:5.3f}  "
              f"({viol:.1e}){'' if ok else '  <-- ' + res.message}")
    sys.exit(1 if args.check and bad else 0)


if __name__ == "__main__":
    main()
