#!/usr/bin/env python3
"""omni4-compare (docs/compare.md) on the paper's robot, a three-wheel robot and an asymmetric
four (docs/examples/), each figure against a hand computation written here from the INI files
alone (configparser and numpy; none of the tool's code):

usage: compare_check.py BIN_DIR

  - the layout's rows [-sin a_j, cos a_j, d_j] (eq 2 with the angles), the wheel forces the
    least-norm solution of G^T f = F (numpy's pseudo-inverse) and the loads the least-norm
    solution of sum N_j = M g, sum N_j p_j = -M h a_c;
  - top steady speed: the largest s at which the motor equation u_j = R_j i_j + Kv_j l v_j / r_j
    (eq 21, i_j from eqs 12, 13) with the forces of the body friction B s e + C sgn(e) stays
    within supply_v, by bisection on s; for the paper's robot also the closed form along v,
    (U - R r Cv / (2 l Kt)) / (R r Bv / (2 l Kt) + Kv l / r);
  - the envelope from rest: the largest a with every |u_j| <= supply_v and |f_j| <= mu N_j for
    the body force a (M, M, J) e + C sgn(e), by bisection on a, at every heading the tool gives
    (and the paper's along v in closed form, (mu M g / 2 - Cv) / M: traction of wheels 1 and 3);
    the tool's weakest heading the least of them;
  - energy per metre at 1 m/s: sum u_j i_j with i_j = (u_j - Kv_j w_mj) / R_j (eq 21 solved);
  - each wheel's traction margin 1 - |f_j| / (mu N_j) at the tool's weakest heading;
  - the planner's move times above the lower bound max(distance / the fastest heading's top
    speed, the bang-bang time speeding up at the envelope's largest point and slowing down at
    the most the floor can give, mu g plus the body friction at top speed over M; the same
    about w with the envelope about w and mu sum N_j d_j) and below UPPER times it;
  - the layout reaches the planner: the asymmetric four's 1 m along vn takes longer than its
    drives on the paper's layout, by at least half the ratio the hand envelopes give;
  - the table on stdout is compare.md, one column per robot; compare_plots.py writes both
    figures and links them.
A floor too slippery to start (mu 0.01): the figures, acceleration 0, no move planned.
Bad input: a missing robot file or a bad INI value is one line, exit status 2, no table;
--out naming a file: one line, status 1, the file untouched.
Prints one line per check; exit status 0 when all pass, 1 otherwise.
"""
import argparse
import configparser
import csv
import os
import stat
import subprocess
import sys
import tempfile

import numpy as np

from script_checks import check, failures  # (this script's folder)

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
ROBOTS = [os.path.join(ROOT, "docs", "examples", n + ".ini")
          for n in ("paper", "three", "robocup")]
PLOTS = os.path.join(ROOT, "host-tools", "plots", "compare_plots.py")
G_M_S2 = 9.80665
REL = 8e-12         # tool against hand, relative: both double (measured 2.8e-12)
MARGIN_ABS = 5e-12  # traction margins [-] (measured 1.7e-12)
UPPER = 2.5         # the planner's time over its lower bound at most (measured 1.08 .. 1.67)
MOVES = {"1 m along v": (1.0, 0.0, 0.0), "1 m along vn": (0.0, 1.0, 0.0),
         "1 m diagonal": (0.5 ** 0.5, 0.5 ** 0.5, 0.0), "90 deg turn": (0.0, 0.0, np.pi / 2),
         "1 m along v with a 90 deg turn": (1.0, 0.0, np.pi / 2)}


class Robot:
    """The hand model of one INI: everything from its keys."""

    def __init__(self, path):
        ini = configparser.ConfigParser()
        ini.optionxform = str  # r and R are two keys
        ini.read(path)
        m, lim = ini["model"], ini["limits"]
        self.name = os.path.basename(path)[:-4]
        get = lambda k: float(m[k])  # noqa: E731
        for k in ("d", "r", "l", "Kv", "Kt", "R", "M", "J", "Bv", "Bvn", "Bw", "Cv", "Cvn",
                  "Cw"):
            setattr(self, k, get(k))
        self.n = int(m.get("wheels", "4"))
        for k in ("r", "Kv", "Kt", "R"):  # each drive's own value, else the scalar
            setattr(self, k, np.array([float(m.get(f"{k}_{j}", m[k])) for j in range(self.n)]))
        deg = [float(m.get(f"wheel_angle_{j}", str(90 * j))) for j in range(self.n)]
        dist = [float(m.get(f"d_{j}", m["d"])) for j in range(self.n)]
        a = np.radians(deg)
        self.deg, self.dist = np.array(deg), np.array(dist)
        self.G = np.column_stack([-np.sin(a), np.cos(a), dist])  # eq 2's rows
        self.pos = np.column_stack([dist * np.cos(a), dist * np.sin(a)])
        self.U, self.mu, self.h = (float(lim["supply_v"]), float(lim["traction_mu"]),
                                   float(lim["com_height"]))
        self.I = np.array([self.M, self.M, self.J])
        self.B = np.array([self.Bv, self.Bvn, self.Bw])
        self.C = np.array([self.Cv, self.Cvn, self.Cw])

    def forces(self, F):
        """Wheel forces [N] of body forces F (rows): least norm, G^T f = F."""
        return np.atleast_2d(F) @ np.linalg.pinv(self.G.T).T

    def loads(self, ac):
        """Loads [N] at centre-of-mass accelerations ac (rows (a_v, a_vn)): least norm."""
        ac = np.atleast_2d(ac)
        A = np.vstack([np.ones(self.n), self.pos.T])
        rhs = np.column_stack([np.full(len(ac), self.M * G_M_S2), -self.M * self.h * ac[:, 0],
                               -self.M * self.h * ac[:, 1]])
        return rhs @ np.linalg.pinv(A).T

    def volts(self, f, x):
        """eq 21: u_j = R i_j + Kv w_m, i_j = r f_j / (l Kt), w_m = l v_j / r (rows)."""
        i = f * self.r / (self.l * self.Kt)
        return self.R * i + self.Kv * self.l * (np.atleast_2d(x) @ self.G.T) / self.r, i


def sgn(e):
    return np.where(np.abs(e) < 1e-12, 0.0, np.sign(e))


def bisect(ok, n, hi=1e3):
    """The largest x in [0, hi] with ok(x) true, for n problems at once (ok: x[n] -> bool[n])."""
    lo, hi = np.zeros(n), np.full(n, hi)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        good = ok(mid)
        lo, hi = np.where(good, mid, lo), np.where(good, hi, mid)
    return lo


def top_speed(rb, E):
    """Top steady speed along each row of E (directions (v, vn, w))."""
    E = np.atleast_2d(E)

    def ok(s):
        X = s[:, None] * E
        u, _ = rb.volts(rb.forces(rb.B * X + rb.C * sgn(E)), X)
        return np.all(np.abs(u) <= rb.U, axis=1)
    return bisect(ok, len(E))


def envelope(rb, E):
    """The largest acceleration from rest along each row of E."""
    E = np.atleast_2d(E)

    def ok(a):
        f = rb.forces(rb.I * a[:, None] * E + rb.C * sgn(E))
        u, _ = rb.volts(f, np.zeros_like(E))
        N = np.maximum(0.0, rb.loads(a[:, None] * E[:, :2]))
        return np.all(np.abs(u) <= rb.U, axis=1) & np.all(np.abs(f) <= rb.mu * N, axis=1)
    return bisect(ok, len(E))


def energy(rb, e):
    x = 1.0 * np.atleast_2d(e)
    u, _ = rb.volts(rb.forces(rb.B * x + rb.C * sgn(x)), x)
    wm = rb.l * (x @ rb.G.T) / rb.r
    i = (u - rb.Kv * wm) / rb.R  # eq 21 solved for the current
    return float(np.sum(u * i)) / 1.0


def heading(deg):
    """Unit directions (v, vn, 0) of the headings deg (rows)."""
    a = np.radians(np.atleast_1d(deg))
    return np.column_stack([np.cos(a), np.sin(a), np.zeros(len(a))])


def rows(dir_, name):
    with open(os.path.join(dir_, name), newline="") as f:
        return list(csv.DictReader(f))


def close(a, b, rel=REL):
    return abs(a - b) <= rel * max(abs(b), 1e-9)


def bang_bang(dist, a_up, a_dn, v_max):
    v_peak = np.sqrt(2.0 * dist * a_up * a_dn / (a_up + a_dn))
    if v_peak <= v_max:
        return v_peak / a_up + v_peak / a_dn
    return dist / v_max + v_max / (2.0 * a_up) + v_max / (2.0 * a_dn)


def check_robot(rb, out, worst):
    s = {r["robot"]: r for r in rows(out, "summary.csv")}[rb.name]
    ax = np.eye(3)
    for k, key in enumerate(("top_v_m_s", "top_vn_m_s", "top_w_rad_s")):
        hand = top_speed(rb, ax[k])[0]
        check(close(float(s[key]), hand), f"{rb.name}: {key} {float(s[key]):.6g} = hand "
              f"{hand:.6g} (motor equation, bisection)")
        worst.append(abs(float(s[key]) / hand - 1))
    env_w = envelope(rb, ax[2])[0]
    check(close(float(s["acc_w_rad_s2"]), env_w),
          f"{rb.name}: acceleration about w {float(s['acc_w_rad_s2']):.6g} = hand {env_w:.6g}")
    for k, key in enumerate(("energy_v_j_m", "energy_vn_j_m")):
        hand = energy(rb, ax[k])
        check(close(float(s[key]), hand), f"{rb.name}: {key} {float(s[key]):.6g} = hand "
              f"{hand:.6g} (sum u_j i_j at 1 m/s)")
    def sweep(name, col, fn):
        rs = [r for r in rows(out, name) if r["robot"] == rb.name]
        deg = np.array([float(r["heading_deg"]) for r in rs])
        return list(zip(deg, [float(r[col]) for r in rs], fn(rb, heading(deg))))
    for name, col, fn, least in (("speed.csv", "top_speed_m_s", top_speed, "slowest"),
                                 ("envelope.csv", "acc_max_m_s2", envelope, "weakest")):
        pts = sweep(name, col, fn)
        bad = [p for p in pts if not close(p[1], p[2])]
        worst.extend(abs(p[1] / p[2] - 1) for p in pts)
        check(len(pts) == 360 and not bad, f"{rb.name}: {name}: {len(pts)} headings, each = "
              f"hand within {REL:g} relative ({len(bad)} not{': ' + str(bad[:2]) if bad else ''})")
        h_min = min(pts, key=lambda p: p[2])
        key = "slowest_speed_m_s" if least == "slowest" else "weakest_acc_m_s2"
        check(close(float(s[key]), h_min[2]),
              f"{rb.name}: {least} heading {s[least + '_heading_deg']} deg: {float(s[key]):.6g} "
              f"= the least of the hand's sweep {h_min[2]:.6g} (at {h_min[0]:g} deg)")
    return s


def check_margins(rb, out, s):
    e = heading(float(s["weakest_heading_deg"]))[0]
    a = float(s["weakest_acc_m_s2"])
    f = rb.forces(rb.I * a * e + rb.C * sgn(e))[0]
    N = rb.loads(a * e[:2])[0]
    hand = 1.0 - np.abs(f) / (rb.mu * N)
    tool = [float(r["traction_margin"]) for r in rows(out, "wheels.csv") if r["robot"] == rb.name]
    diff = max(abs(t - h) for t, h in zip(tool, hand))
    check(len(tool) == rb.n and diff <= MARGIN_ABS, f"{rb.name}: traction margins at the weakest "
          f"heading {np.round(tool, 4)} = hand {np.round(hand, 4)} (within {diff:.1g})")
    return diff


def check_moves(rb, out):
    """The planner's times between the physical lower bound and UPPER times it."""
    env = envelope(rb, heading(np.arange(0.0, 360.0, 1.0)))
    v_top = max(top_speed(rb, heading(np.arange(0.0, 360.0, 1.0))))
    w_top = top_speed(rb, np.eye(3)[2])[0]
    a_dn = rb.mu * G_M_S2 + (max(rb.Cv, rb.Cvn) + max(rb.Bv, rb.Bvn) * v_top) / rb.M
    al_dn = (rb.mu * np.sum(rb.loads([0.0, 0.0])[0] * rb.dist) + rb.Cw + rb.Bw * w_top) / rb.J
    al_up = envelope(rb, np.eye(3)[2])[0]
    ratios = []
    for r in rows(out, "moves.csv"):
        if r["robot"] != rb.name:
            continue
        x, y, th = MOVES[r["move"]]
        dist, t = np.hypot(x, y), float(r["time_s"])
        lo = max(bang_bang(dist, max(env), a_dn, v_top) if dist else 0.0,
                 bang_bang(th, al_up, al_dn, w_top) if th else 0.0)
        ratios.append(t / lo)
        check(lo <= t <= UPPER * lo, f"{rb.name}: {r['move']}: {t:.3f} s within "
              f"[{lo:.3f}, {UPPER * lo:.3f}] s (lower bound: top speed {v_top:.2f} m/s, "
              f"bang-bang {max(env):.2f} up / {a_dn:.2f} down m/s^2)")
    check(len(ratios) == len(MOVES), f"{rb.name}: {len(ratios)} moves timed")
    return ratios


def check_paper_closed_form(out):
    """The paper's robot along v by hand in closed form (Table III from its INI): wheels 1 and
    3 carry (Bv v + Cv) / 2 each."""
    rb = Robot(ROBOTS[0])
    s = {r["robot"]: r for r in rows(out, "summary.csv")}["paper"]
    R, r, Kv, Kt = rb.R[0], rb.r[0], rb.Kv[0], rb.Kt[0]  # four equal drives
    vpn, kemf = R * r / (rb.l * Kt), Kv * rb.l / r
    v_top = (rb.U - vpn * rb.Cv / 2) / (vpn * rb.Bv / 2 + kemf)
    check(close(float(s["top_v_m_s"]), v_top),
          f"paper: top speed along v {float(s['top_v_m_s']):.6f} = closed form {v_top:.6f} m/s")
    acc = (rb.mu * rb.M * G_M_S2 / 2 - rb.Cv) / rb.M
    tool = [float(r["acc_max_m_s2"]) for r in rows(out, "envelope.csv")
            if r["robot"] == "paper" and float(r["heading_deg"]) == 0.0]
    check(tool and close(tool[0], acc),
          f"paper: acceleration along v {tool[0] if tool else None} = closed form {acc:.6f} "
          "m/s^2 (wheels 1 and 3 at mu M g / 4)")


def check_layout_reaches_planner(tool, out, tmp):
    """The asymmetric four's drives on the paper's layout (its layout keys dropped) against the
    asymmetric four: weaker sideways (hand envelope along vn), it must take longer for 1 m along
    vn, by at least half of what an acceleration-bound move gives (time ~ a^-1/2)."""
    with open(ROBOTS[2]) as f:
        text = "".join(ln for ln in f if not ln.startswith(("wheel_angle_", "d_")))
    square = os.path.join(tmp, "square.ini")
    with open(square, "w") as f:
        f.write(text)
    p = subprocess.run([tool, square, "--out", os.path.join(tmp, "sq")], capture_output=True,
                       text=True, timeout=60)
    t = lambda d, robot: [float(r["time_s"]) for r in rows(d, "moves.csv")  # noqa: E731
                          if r["robot"] == robot and r["move"] == "1 m along vn"][0]
    vn = np.array([[0.0, 1.0, 0.0]])
    expect = np.sqrt(envelope(Robot(square), vn)[0] / envelope(Robot(ROBOTS[2]), vn)[0])
    ratio = t(out, "robocup") / t(os.path.join(tmp, "sq"), "square") if not p.returncode else 0
    check(ratio >= 1.0 + 0.5 * (expect - 1.0), f"the layout reaches the planner: 1 m along vn "
          f"takes {ratio:.3f} times as long on the asymmetric four as with its drives on the "
          f"paper's layout (the envelopes' a^-1/2: {expect:.3f})")


def check_outputs(tool, out, tmp):
    """The table (stdout and compare.md, one column per robot, the summary's figures), the
    figures and --out naming a file (refused, untouched)."""
    p = subprocess.run([tool, *ROBOTS], capture_output=True, text=True, timeout=60)
    with open(os.path.join(out, "compare.md")) as f:
        md = f.read()
    head = md.splitlines()[0].split("|")[1:-1]
    check(p.returncode == 0 and p.stdout == md and [c.strip() for c in head] ==
          ["quantity", "paper", "three", "robocup"],
          "without --out: the same table on stdout; one column per robot in the given order")
    top = [r for r in md.splitlines() if r.startswith("| top speed along v [m/s]")]
    s = rows(out, "summary.csv")
    check(len(top) == 1 and all(f"{float(r['top_v_m_s']):.3f} (" in top[0] for r in s),
          f"the table's top speeds along v are the summary's ({top[:1]})")
    p = subprocess.run([sys.executable, PLOTS, out], capture_output=True, text=True, timeout=60)
    with open(os.path.join(out, "compare.md")) as f:
        md = f.read()
    sizes = [os.path.getsize(os.path.join(out, n)) if os.path.exists(os.path.join(out, n))
             else 0 for n in ("envelope.png", "layouts.png")]
    check(p.returncode == 0 and min(sizes) > 10000 and "](envelope.png)" in md and
          "](layouts.png)" in md, f"figures written ({sizes} bytes) and linked from compare.md "
          f"{p.stderr.strip()}")
    afile = os.path.join(tmp, "a_file")
    with open(afile, "w") as f:
        f.write("kept\n")
    p = subprocess.run([tool, ROBOTS[0], "--out", afile], capture_output=True, text=True)
    with open(afile) as f:
        kept = f.read() == "kept\n"
    check(p.returncode == 1 and p.stderr.count("\n") == 1 and kept,
          f"--out naming a file: status 1, one line, the file untouched ({p.stderr.strip()})")
    fifo = os.path.join(tmp, "a_fifo")
    os.mkfifo(fifo)
    p = subprocess.run([tool, ROBOTS[0], "--out", fifo], capture_output=True, text=True,
                       timeout=60)
    check(p.returncode == 1 and p.stderr.count("\n") == 1 and stat.S_ISFIFO(os.stat(fifo).st_mode),
          f"--out naming a FIFO: status 1, one line, the FIFO kept ({p.stderr.strip()})")
    real, link = os.path.join(tmp, "real"), os.path.join(tmp, "link")
    os.makedirs(real)
    os.symlink(real, link)
    with open(os.path.join(real, "kept.md"), "w") as f:
        f.write("old\n")
    os.symlink("kept.md", os.path.join(real, "compare.md"))
    p = subprocess.run([tool, ROBOTS[0], "--out", link], capture_output=True, text=True,
                       timeout=60)
    with open(os.path.join(real, "kept.md")) as f:
        replaced = f.read().startswith("| quantity | paper |")
    check(p.returncode == 0 and os.path.islink(link) and
          os.path.islink(os.path.join(real, "compare.md")) and replaced and
          os.path.exists(os.path.join(real, "summary.csv")),
          "--out a link to a folder, compare.md a link there: both links kept, the table in "
          "the linked file")


def check_no_grip(tool, tmp):
    """A floor that cannot overcome the Coulomb friction (mu 0.01): figures, no plans."""
    with open(ROBOTS[0]) as f:
        text = f.read().replace("traction_mu = 0.8", "traction_mu = 0.01")
    ice = os.path.join(tmp, "ice.ini")
    with open(ice, "w") as f:
        f.write(text)
    p = subprocess.run([tool, ice], capture_output=True, text=True, timeout=60)
    times = [r for r in p.stdout.splitlines() if r.startswith("| time: ")]
    weakest = [r for r in p.stdout.splitlines() if r.startswith("| weakest heading")]
    check(p.returncode == 0 and len(times) == len(MOVES) and
          all("none: no acceleration at rest" in r for r in times) and weakest and
          ": 0.000 (traction" in weakest[0], "a floor of mu 0.01: no acceleration (traction), "
          "every move 'none: no acceleration at rest', status 0")


def check_errors(tool, tmp):
    p = subprocess.run([tool, os.path.join(tmp, "absent.ini")], capture_output=True, text=True)
    check(p.returncode == 2 and p.stderr.count("\n") == 1 and "absent.ini" in p.stderr
          and not p.stdout, f"a missing file: status 2, one line ({p.stderr.strip()})")
    bad = os.path.join(tmp, "bad.ini")
    with open(bad, "w") as f:
        f.write("[limits]\nsupply_v = twelve\n")
    p = subprocess.run([tool, bad], capture_output=True, text=True)
    check(p.returncode == 2 and p.stderr.count("\n") == 1 and "supply_v" in p.stderr,
          f"a bad value: status 2, one line ({p.stderr.strip()})")


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("bin_dir")
    a = ap.parse_args()
    tool = os.path.join(a.bin_dir, "omni4-compare")
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out")
        p = subprocess.run([tool, *ROBOTS, "--out", out], capture_output=True, text=True,
                           timeout=60)
        check(p.returncode == 0, f"omni4-compare on three robots: status {p.returncode} "
              f"{p.stderr.strip()}")
        if p.returncode:
            return 1
        worst, ratios, worst_margin = [], [], 0.0
        for path in ROBOTS:
            rb = Robot(path)
            s = check_robot(rb, out, worst)
            worst_margin = max(worst_margin, check_margins(rb, out, s))
            ratios += check_moves(rb, out)
        check_paper_closed_form(out)
        print(f"     worst relative difference to the hand: {max(worst):.2g}, margins "
              f"{worst_margin:.2g}; planner time "
              f"over its lower bound {min(ratios):.2f} .. {max(ratios):.2f}")
        check_layout_reaches_planner(tool, out, tmp)
        check_outputs(tool, out, tmp)
        check_no_grip(tool, tmp)
        check_errors(tool, tmp)
    print("compare_check: " + ("all passed" if not failures else f"{len(failures)} FAILED"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
