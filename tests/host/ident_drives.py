#!/usr/bin/env python3
"""The paper's experiments and identification through simulated VESCs or ODrives.

usage: ident_drives.py BIN_DIR vesc|odrive [--seed N] [--keep DIR]

drive_lockstep runs the paper's experiment sequence (omni4-sim --experiments's) with the
controller on omni4-fw's vesc (mode duty: a voltage drive) or odrive (mode torque: a current
drive) backend, its CAN socket an in-process queue to omni4-motorsim's simulated drives, the
simulated robot behind them, in simulated time; the drives measure with the simulator's sensors
(current noise, 10240 encoder counts per wheel turn) and the log has its camera (1 cm, 3 deg,
40 ms). omni4-ident identify reads the log unchanged, and recovers:
  vesc:   on a robot of its own body (MODEL, not Table III's) at the simulator's 0.02 A of
          current noise, every parameter (Kv, R, J, Bv, Bvn, Bw, Cv, Cvn, Cw) within TOL; on
          Table III's robot every one but Bw, which STATUS_1's 0.1 A steps bias high there (the
          steady rotations draw 0.17-0.30 A, two or three steps, and 0.02 A of noise does not
          dither them): within BW_COARSE, said in docs/testing.md; with 0.05 A of noise (half a
          step) every one within TOL again;
  odrive: J, Bv..Cw and M from the measured currents within TOL, with the drives' encoder
          estimates and Iq sent every 1 ms (encoder_msg_rate_ms, iq_msg_rate_ms; at the
          defaults, 10 ms and Iq on request only, Bv, Bvn, Bw and Cw miss 1 %: docs/testing.md);
          R and Kv the robot file's, said to be the drive's.
Exit status 0 when every check passes, 1 otherwise.
"""
import argparse
import os
import sys

from script_checks import check, failures, run, read_ini, workdir, write  # (this script's folder)

# The simulated robots: Table III's geometry and motors, a body of its own (as
# ident_current.py's); and Table III's (model/src/params.c).
MODEL = {"d": 0.089, "r": 0.0325, "l": 5, "Kv": 0.0259, "Kt": 0.0259, "R": 4.3111, "M": 3.1,
         "J": 0.031, "Bv": 0.62, "Bvn": 0.81, "Bw": 0.019, "Cv": 2.3, "Cvn": 2.6, "Cw": 0.17}
TABLE3 = {"d": 0.089, "r": 0.0325, "l": 5, "Kv": 0.0259, "Kt": 0.0259, "R": 4.3111, "M": 2.34,
          "J": 0.0228, "Bv": 0.4978, "Bvn": 0.6763, "Bw": 0.0141, "Cv": 1.8738, "Cvn": 2.2198,
          "Cw": 0.1385}
# Relative bounds: 2-3x the worst of seeds 1-6 on that robot, never above the 1 % asked for.
# Worst [%]: vesc, MODEL at 0.02 A: Kv 0.05, R 0.13, J 0.02, Bv 0.14, Bvn 0.15, Bw 0.43, Cv 0.10,
# Cvn 0.09, Cw 0.08; Table III at 0.02 A: Kv 0.45, R 0.12, J 0.01, Bv 0.05, Bvn 0.01, Cv 0.14,
# Cvn 0.13, Cw 0.02 (Bw +3.19..+3.60); at 0.05 A: Kv 0.09, R 0.06, J 0.05, Bv 0.24, Bvn 0.25,
# Bw 0.81, Cv 0.14, Cvn 0.13, Cw 0.45; odrive, MODEL, seeds 1-14: M 0.10, J 0.11, Bv 0.17,
# Bvn 0.13, Bw 0.72, Cv 0.20, Cvn 0.16, Cw 0.95 (seed 1, the one run here).
TOL = {
    "vesc": {"Kv": 0.01, "R": 0.0035, "J": 0.001, "Bv": 0.005, "Bvn": 0.005, "Bw": 0.01,
             "Cv": 0.004, "Cvn": 0.004, "Cw": 0.01},
    "odrive": {"M": 0.003, "J": 0.003, "Bv": 0.005, "Bvn": 0.004, "Bw": 0.01, "Cv": 0.005,
               "Cvn": 0.004, "Cw": 0.01},
}
BW_COARSE = 0.08  # Table III's Bw through STATUS_1's 0.1 A steps at 0.02 A of noise
SECTION = {"vesc": "[vesc]\nmode = duty\n", "odrive": "[odrive]\nmode = torque\n"}




def robot_ini(proto, robot, seed, current_noise_a):
    model = "".join(f"{k} = {v}\n" for k, v in robot.items())
    return (f"[hal]\nmotor = {proto}\n{SECTION[proto]}[model]\n{model}"
            f"[sim]\nseed = {seed}\ncurrent_noise_a = {current_noise_a}\n")


def experiments_and_identify(bin_dir, d, proto, robot, seed, noise_a, lockstep_args,
                             ident_args):
    """The sequence through the drives, then identify: the identified [model] and the report."""
    name = f"{proto}_{robot['M']}_{noise_a}"
    write(d, f"{name}.ini", robot_ini(proto, robot, seed, noise_a))
    write(d, f"{name}.base.ini", "[model]\n" + "".join(
        f"{k} = {robot[k]}\n" for k in ("d", "r", "l", "M")))
    out = run([os.path.join(bin_dir, "drive_lockstep"), "--params", f"{name}.ini", "--out",
               f"{name}.lcmlog", *lockstep_args], d)
    print(out.strip())
    text = run([os.path.join(bin_dir, "omni4-ident"), "identify", "--robot", f"{name}.base.ini",
                "--out", f"{name}.params.ini", *ident_args, f"{name}.lcmlog"], d)
    return read_ini(os.path.join(d, f"{name}.params.ini"), "model"), text


def check_params(what, robot, got, tol):
    for p, bound in tol.items():
        err = got[p] / robot[p] - 1
        check(abs(err) <= bound, f"{what}: {p} {got[p]:.6g} against the robot's {robot[p]:g}: "
              f"{100 * err:+.3f} % (bound {100 * bound:g} %)")


def vesc(bin_dir, d, seed):
    tol = TOL["vesc"]
    got, _ = experiments_and_identify(bin_dir, d, "vesc", MODEL, seed, 0.02, [], [])
    check_params("vesc duty, its own body, 0.02 A", MODEL, got, tol)
    got, _ = experiments_and_identify(bin_dir, d, "vesc", TABLE3, seed, 0.02, [], [])
    check_params("vesc duty, Table III, 0.02 A", TABLE3, got,
                 {p: t for p, t in tol.items() if p != "Bw"})
    check_params("vesc duty, Table III, 0.02 A (STATUS_1's 0.1 A steps)", TABLE3, got,
                 {"Bw": BW_COARSE})
    got, _ = experiments_and_identify(bin_dir, d, "vesc", TABLE3, seed, 0.05, [], [])
    check_params("vesc duty, Table III, 0.05 A", TABLE3, got, tol)


def odrive(bin_dir, d, seed):
    got, text = experiments_and_identify(bin_dir, d, "odrive", MODEL, seed, 0.02,
                                         ["--encoder-ms", "1", "--iq-ms", "1"],
                                         ["--drive", "current"])
    check_params("odrive torque, its own body, 1 ms messages", MODEL, got, TOL["odrive"])
    for p in ("R", "Kv", "Kt"):
        check(got[p] == MODEL[p], f"odrive torque: {p} = {got[p]:g} is the robot file's")
    check(f"R = {MODEL['R']:g} ohm and Kv = {MODEL['Kv']:g} V s/rad are the drive's" in text,
          "odrive torque: the report says R and Kv are the drive's")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bin_dir")
    ap.add_argument("protocol", choices=["vesc", "odrive"])
    ap.add_argument("--seed", type=int, default=1, help="the simulator's noise seed")
    ap.add_argument("--keep", help="work in this folder and keep it")
    a = ap.parse_args()
    bin_dir = os.path.abspath(a.bin_dir)
    with workdir(a.keep) as d:
        (vesc if a.protocol == "vesc" else odrive)(bin_dir, d, a.seed)
    print(f"ident_drives {a.protocol}: {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
