"""The online estimation ([adapt]) on docs/hard-drive.csv with omni4-sim.

Resistance: the R in use (adapt_t.R) against the plant's (sim_plant_t.R) after the first minute
with [sim] thermal; the wheels' speed tracking RMS (adapt_t.track_rms) over the last minute with
[adapt] on and off; with [sim] thermal off, every R and Coulomb friction in use against the
identified for the whole run.
A changing robot (thermal, a battery sagging >= 15 %, the floor's friction x 1.5 at 180 s) on
docs/changing-drive.csv (+-0.8 m/s on v and vn, +-2 rad/s, 2 s each: the hard drive is beyond
the reach of a hot robot on a sagging battery and a stickier floor, whose bridges then sit at
the supply in half the ticks, [adapt] on and off alike; it is run too and its figures printed):
R in use against the plant's after the first minute, the Coulomb friction in use (adapt_t.Cv,
Cvn, Cw) against the plant's (identified x sim_plant_t.friction_scale), the time after the
floor's change until all three stay within 10 %, the tracking RMS over the last minute, [adapt]
on over off.

usage: .venv/bin/python bench/adapt_drive.py [BIN_DIR]   (default build/bin; ~20 s)"""
import math
import os
import subprocess
import sys
import tempfile

import lcm
import omni4

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
FLOOR_S = 180.0
# 0.25 Ah: the 5-minute hard drive with thermal draws the supply down by >= 15 % (printed
# below); the changing drive draws less: 0.23 Ah, and windings of 3 J/K heat by >= 20 % on it.
CHANGING = ("[sim]\nthermal = true\nbattery = true\nbattery_capacity = 0.25\n"
            f"floor_change_s = {FLOOR_S}\nfloor_friction_scale = 1.5\n")
WITHIN = ("[sim]\nthermal = true\nthermal_capacity = 3\nbattery = true\n"
          f"battery_capacity = 0.23\nfloor_change_s = {FLOOR_S}\nfloor_friction_scale = 1.5\n")
HARD, WITHIN_REACH = "hard-drive.csv", "changing-drive.csv"
DRIVES = {"within_on": WITHIN_REACH, "within_off": WITHIN_REACH}
RUNS = {"within_on": WITHIN,
        "within_off": WITHIN + "[adapt]\nenable = false\n",
        "on": "[sim]\nthermal = true\n",
        "off": "[sim]\nthermal = true\n[adapt]\nenable = false\n",
        "cold": "[sim]\nthermal = false\n",
        "change_on": CHANGING,
        "change_off": CHANGING + "[adapt]\nenable = false\n",
        "floor_on": f"[sim]\nfloor_change_s = {FLOOR_S}\nfloor_friction_scale = 1.5\n",
        "floor_off": (f"[sim]\nfloor_change_s = {FLOOR_S}\nfloor_friction_scale = 1.5\n"
                      "[adapt]\nenable = false\n"),
        "sag_on": "[sim]\nthermal = true\nbattery = true\n",
        "sag_off": "[sim]\nthermal = true\nbattery = true\n[adapt]\nenable = false\n"}


def simulate(bin_dir, ini_text, folder, name):
    """omni4-sim on the run's drive (DRIVES, else the hard drive) with this INI: the log's
    path."""
    ini = os.path.join(folder, name + ".ini")
    out = os.path.join(folder, name + ".lcmlog")
    with open(ini, "w", encoding="utf-8") as f:
        f.write(ini_text)
    subprocess.run([os.path.join(bin_dir, "omni4-sim"), "--params", ini, "--drive",
                    os.path.join(ROOT, "docs", DRIVES.get(name, HARD)), "--out", out, "-q"],
                   check=True, stdout=subprocess.DEVNULL)
    return out


def read(path):
    """(adapt_t messages, {utime: sim_plant_t}, the share of the last minute's motors_t whose
    largest |voltage| is at 99 % of the plant's supply or more) of a log."""
    adapt, plant, motors, supply = [], {}, [], 0.0
    for ev in lcm.EventLog(path, "r"):
        if ev.channel == omni4.CHANNEL_ADAPT:
            adapt.append(omni4.adapt_t.decode(ev.data))
        elif ev.channel == omni4.CHANNEL_SIM_PLANT:
            m = omni4.sim_plant_t.decode(ev.data)
            plant[m.utime] = m
            supply = m.supply_v
        elif ev.channel == omni4.CHANNEL_MOTORS:
            m = omni4.motors_t.decode(ev.data)
            motors.append((m.utime, max(abs(u) for u in m.voltage) >= 0.99 * supply))
    last = [sat for t, sat in motors if t > motors[-1][0] - 60e6]
    return adapt, plant, sum(last) / len(last)


def coulomb(m):
    return (m.Cv, m.Cvn, m.Cw)


def worst_against_plant(adapt, plant, after_us):
    """Largest |R in use / plant's - 1| from after_us on (the same ticks)."""
    t0 = adapt[0].utime
    return max(abs(m.R[j] / plant[m.utime].R[j] - 1.0) for m in adapt
               if m.utime - t0 >= after_us and m.utime in plant for j in range(4))


def coulomb_errors(adapt, plant):
    """[(t [s], largest |C in use / plant's - 1| over the three axes)] (the same ticks); the
    plant's C is the identified (the first report's) times its friction scale."""
    t0, ident = adapt[0].utime, coulomb(adapt[0])
    return [((m.utime - t0) * 1e-6,
             max(abs(c / (i * plant[m.utime].friction_scale) - 1.0)
                 for c, i in zip(coulomb(m), ident)))
            for m in adapt if m.utime in plant]


def settled_after(errors, t_change, bound):
    """Seconds after t_change from which every error stays within bound (None: never)."""
    last_bad = t_change
    for t, e in errors:
        if t >= t_change and e > bound:
            last_bad = t
    return None if last_bad >= errors[-1][0] else last_bad - t_change


def tracking_rms(adapt, last_us):
    """RMS of track_rms over the last last_us (reports that tracked)."""
    end = adapt[-1].utime
    xs = [m.track_rms for m in adapt if m.utime > end - last_us and m.track_rms > 0]
    return math.sqrt(sum(x * x for x in xs) / len(xs))


def report_changing(on, plant, off, title):
    supply = [p.supply_v for p in plant.values()]
    worst = worst_against_plant(on, plant, 60e6)
    errors = coulomb_errors(on, plant)
    settle = settled_after(errors, FLOOR_S, 0.10)
    before = max(e for t, e in errors if t < FLOOR_S)
    end = max(e for t, e in errors if t >= FLOOR_S + 60.0)
    rms_on, rms_off = tracking_rms(on, 60e6), tracking_rms(off, 60e6)
    last = on[-1]
    rise = max(p.R[j] / plant[on[0].utime].R[j] - 1.0 for p in plant.values() for j in range(4)
               if on[0].utime in plant)
    print(f"{title}: windings' R up to +{100 * rise:.1f} % (asked: >= 20 %); supply "
          f"{supply[0]:.2f} V -> lowest {min(supply):.2f} V "
          f"({100 * (1 - min(supply) / supply[0]):.1f} % down; asked: >= 15 %)")
    print(f"  R in use vs the plant's after the first minute, worst: {100 * worst:.2f} % "
          "(asked: within 3 %)")
    print(f"  Coulomb in use vs the plant's: worst before the floor's change {100 * before:.2f} %, "
          f"worst from 60 s after it {100 * end:.2f} %; at the end Cv {last.Cv:.4f} N, "
          f"Cvn {last.Cvn:.4f} N, Cw {last.Cw:.4f} N m (asked: within 10 %)")
    print("  all three within 10 % from "
          + ("never" if settle is None else f"{settle:.1f} s") + " after the change "
          "(asked: within 60 s)")
    print(f"  tracking RMS, last minute: on {rms_on:.5f} m/s, off {rms_off:.5f} m/s, "
          f"ratio {rms_on / rms_off:.3f} (asked: <= 0.5)")


def main():
    bin_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build", "bin")
    with tempfile.TemporaryDirectory() as folder:
        logs = {k: read(simulate(bin_dir, v, folder, k)) for k, v in RUNS.items()}
    on, off, cold = logs["on"][0], logs["off"][0], logs["cold"][0]
    worst = worst_against_plant(on, logs["on"][1], 60e6)
    rms_on, rms_off = tracking_rms(on, 60e6), tracking_rms(off, 60e6)
    ident = list(cold[0].R)
    cold_worst = max(abs(m.R[j] / ident[j] - 1.0) for m in cold for j in range(4))
    cold_c = max(abs(c / i - 1.0) for m in cold for c, i in zip(coulomb(m), coulomb(cold[0])))
    print(f"R in use vs the plant's after the first minute, worst: {100 * worst:.2f} % "
          "(asked: within 3 %)")
    print(f"wheel speed tracking RMS, last minute: on {rms_on:.5f} m/s, off {rms_off:.5f} m/s, "
          f"ratio {rms_on / rms_off:.3f} (asked: <= 0.5)")
    print(f"thermal off: R in use vs the identified, worst over the run: {100 * cold_worst:.3f} % "
          "(asked: within 1 %)")
    print(f"thermal off: Coulomb in use vs the identified, worst over the run: "
          f"{100 * cold_c:.3f} % (asked: within 1 %)")
    report_changing(logs["within_on"][0], logs["within_on"][1], logs["within_off"][0],
                    "changing robot, " + WITHIN_REACH)
    print(f"  bridges at the supply in the last minute: {100 * logs['within_on'][2]:.0f} % of the "
          f"ticks on, {100 * logs['within_off'][2]:.0f} % off")
    report_changing(logs["change_on"][0], logs["change_on"][1], logs["change_off"][0],
                    "changing robot, " + HARD + " (beyond its reach)")
    print(f"  bridges at the supply in the last minute: {100 * logs['change_on'][2]:.0f} % of the "
          f"ticks on, {100 * logs['change_off'][2]:.0f} % off")
    errors = coulomb_errors(logs["floor_on"][0], logs["floor_on"][1])
    settle = settled_after(errors, FLOOR_S, 0.10)
    fl_on, fl_off = tracking_rms(logs["floor_on"][0], 60e6), tracking_rms(logs["floor_off"][0], 60e6)
    print("the floor x 1.5 alone (cold, no battery): all three Coulomb terms within 10 % from "
          + ("never" if settle is None else f"{settle:.1f} s") + " after the change, worst from "
          f"60 s after it {100 * max(e for t, e in errors if t >= FLOOR_S + 60.0):.2f} %; "
          f"tracking RMS, last minute: on {fl_on:.5f} m/s, off {fl_off:.5f} m/s, "
          f"ratio {fl_on / fl_off:.3f}")
    sag_on, sag_off = tracking_rms(logs["sag_on"][0], 60e6), tracking_rms(logs["sag_off"][0], 60e6)
    print(f"thermal and battery, the floor unchanged: tracking RMS, last minute: on {sag_on:.5f} "
          f"m/s, off {sag_off:.5f} m/s, ratio {sag_on / sag_off:.3f}")


if __name__ == "__main__":
    main()
