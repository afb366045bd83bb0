"""The online resistance estimation ([adapt]) on docs/hard-drive.csv with omni4-sim: the R in use
(adapt_t.R) against the plant's (sim_plant_t.R) after the first minute with [sim] thermal; the
wheels' speed tracking RMS (adapt_t.track_rms) over the last minute with [adapt] on and off; and
with [sim] thermal off, every R in use against the identified for the whole run.

usage: .venv/bin/python bench/adapt_drive.py [BIN_DIR]   (default build/bin; ~3 s)"""
import math
import os
import subprocess
import sys
import tempfile

import lcm
import omni4

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
RUNS = {"on": "[sim]\nthermal = true\n",
        "off": "[sim]\nthermal = true\n[adapt]\nenable = false\n",
        "cold": "[sim]\nthermal = false\n"}


def simulate(bin_dir, ini_text, folder, name):
    """omni4-sim on the hard drive with this INI: the log's path."""
    ini = os.path.join(folder, name + ".ini")
    out = os.path.join(folder, name + ".lcmlog")
    with open(ini, "w", encoding="utf-8") as f:
        f.write(ini_text)
    subprocess.run([os.path.join(bin_dir, "omni4-sim"), "--params", ini, "--drive",
                    os.path.join(ROOT, "docs", "hard-drive.csv"), "--out", out, "-q"],
                   check=True, stdout=subprocess.DEVNULL)
    return out


def read(path):
    """(adapt_t messages, {utime: plant R}) of a log."""
    adapt, plant = [], {}
    for ev in lcm.EventLog(path, "r"):
        if ev.channel == omni4.CHANNEL_ADAPT:
            adapt.append(omni4.adapt_t.decode(ev.data))
        elif ev.channel == omni4.CHANNEL_SIM_PLANT:
            m = omni4.sim_plant_t.decode(ev.data)
            plant[m.utime] = list(m.R)
    return adapt, plant


def worst_against_plant(adapt, plant, after_us):
    """Largest |R in use / plant's - 1| from after_us on (the same ticks)."""
    t0 = adapt[0].utime
    return max(abs(m.R[j] / plant[m.utime][j] - 1.0) for m in adapt
               if m.utime - t0 >= after_us and m.utime in plant for j in range(4))


def tracking_rms(adapt, last_us):
    """RMS of track_rms over the last last_us (reports that tracked)."""
    end = adapt[-1].utime
    xs = [m.track_rms for m in adapt if m.utime > end - last_us and m.track_rms > 0]
    return math.sqrt(sum(x * x for x in xs) / len(xs))


def main():
    bin_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build", "bin")
    with tempfile.TemporaryDirectory() as folder:
        logs = {k: read(simulate(bin_dir, v, folder, k)) for k, v in RUNS.items()}
    on, off, cold = logs["on"][0], logs["off"][0], logs["cold"][0]
    worst = worst_against_plant(on, logs["on"][1], 60e6)
    rms_on, rms_off = tracking_rms(on, 60e6), tracking_rms(off, 60e6)
    ident = list(cold[0].R)
    cold_worst = max(abs(m.R[j] / ident[j] - 1.0) for m in cold for j in range(4))
    print(f"R in use vs the plant's after the first minute, worst: {100 * worst:.2f} % "
          "(asked: within 3 %)")
    print(f"wheel speed tracking RMS, last minute: on {rms_on:.5f} m/s, off {rms_off:.5f} m/s, "
          f"ratio {rms_on / rms_off:.3f} (asked: <= 0.5)")
    print(f"thermal off: R in use vs the identified, worst over the run: {100 * cold_worst:.3f} % "
          "(asked: within 1 %)")


if __name__ == "__main__":
    main()
