#!/usr/bin/env python3
"""omni4-sim's summary against the log it wrote, and its truth and estimate switches.

usage: sim_summary.py BIN_DIR

Runs omni4-sim (an idle run; the paper's experiments with each of --no-truth, --no-estimate, and
[sim] truth / estimate = false in an INI) and counts the events of each log by channel with the
lcm package's own EventLog reader. Checks: the summary's total and every channel's figure equal
that count (every channel the log holds is listed, the parts add up to the total); an idle run
prints no experiment phase; --no-truth leaves OMNI4_SIM_TRUTH out, --no-estimate OMNI4_STATE, and
the [sim] keys do the same; leaving them out changes no OMNI4_MOTORS sample (the estimate only
indicates: the controller's outputs, currents and wheel speeds are byte for byte the same,
utime aside); the event numbers run 0, 1, 2, ... Prints one line per check; exit status 0 when all pass, 1 otherwise.
"""
import collections
import os
import re
import subprocess
import sys
import tempfile

import lcm

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def run_sim(bin_dir, out, *args):
    """omni4-sim's stdout and stderr (status 0 asserted)."""
    p = subprocess.run([os.path.join(bin_dir, "omni4-sim"), "--out", out, *args],
                       capture_output=True, text=True, timeout=120)
    if p.returncode != 0:
        raise SystemExit(f"omni4-sim {' '.join(args)}: status {p.returncode}: {p.stderr}")
    return p.stdout, p.stderr


def summary(stdout):
    """(total, {channel: n}) from the 'wrote LOG: N messages (CH n, CH n, ...)' line."""
    m = re.search(r"wrote .*: (\d+) messages \((.*)\)\n", stdout)
    if not m:
        raise SystemExit(f"no summary line in: {stdout!r}")
    parts = {}
    for item in m.group(2).split(", "):
        name, n = item.rsplit(" ", 1)
        parts[name] = int(n)
    return int(m.group(1)), parts


def log_events(path):
    """{channel: [data, ...]} of every event in the log, read by lcm.EventLog; checks that the
    event numbers run 0, 1, 2, ... as liblcm's writer numbers them."""
    out = collections.defaultdict(list)
    nums = []
    for ev in lcm.EventLog(path, "r"):
        out[ev.channel].append(ev.data)
        nums.append(ev.eventnum)
    check(nums == list(range(len(nums))), f"{os.path.basename(path)}: event numbers 0..N-1")
    return out


def compare(label, stdout, events):
    total, parts = summary(stdout)
    counted = {ch: len(v) for ch, v in events.items()}
    check(total == sum(counted.values()),
          f"{label}: total {total} = events in the log {sum(counted.values())}")
    check(parts == counted, f"{label}: per channel {parts} = the log's {counted}")
    check(sum(parts.values()) == total, f"{label}: the parts add up to the total")


def motors_without_utime(events):
    # motors_t: 8-byte fingerprint, then utime (8 bytes), then the rest.
    return [d[:8] + d[16:] for d in events["OMNI4_MOTORS"]]


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    bin_dir = argv[1]
    with tempfile.TemporaryDirectory(prefix="omni4-sim-summary-") as d:
        idle = os.path.join(d, "idle.lcmlog")
        out, err = run_sim(bin_dir, idle, "--duration", "3")
        ev = log_events(idle)
        compare("idle 3 s", out, ev)
        check("phase" not in err, "idle run: no experiment phase in the progress lines")
        check(len(ev["OMNI4_SIM_TRUTH"]) == 3000 and len(ev["OMNI4_STATE"]) >= 300,
              "idle run: truth every tick and the estimate on by default")

        full = os.path.join(d, "full.lcmlog")
        out, err = run_sim(bin_dir, full, "--experiments", "-q")
        ev_full = log_events(full)
        compare("experiments", out, ev_full)
        check(len(ev_full["OMNI4_EXPERIMENT"]) < 100 < len(ev_full["OMNI4_SIM_TRUTH"]),
              "experiments: the marks and the truth counted apart")

        runs = {"--no-truth": ["--no-truth"], "--no-estimate": ["--no-estimate"],
                "both flags": ["--no-truth", "--no-estimate"]}
        ini = os.path.join(d, "off.ini")
        with open(ini, "w") as f:
            f.write("[sim]\ntruth = false\nestimate = false\n")
        runs["[sim] keys"] = ["--params", ini]
        for label, args in runs.items():
            path = os.path.join(d, "off.lcmlog")
            if os.path.exists(path):
                os.remove(path)
            out, _ = run_sim(bin_dir, path, "--experiments", "-q", *args)
            ev = log_events(path)
            compare(label, out, ev)
            no_truth = "--no-truth" in args or "--params" in args
            no_est = "--no-estimate" in args or "--params" in args
            check(("OMNI4_SIM_TRUTH" in ev) != no_truth, f"{label}: OMNI4_SIM_TRUTH logged: "
                  f"{'OMNI4_SIM_TRUTH' in ev}")
            check(("OMNI4_STATE" in ev) != no_est, f"{label}: OMNI4_STATE logged: "
                  f"{'OMNI4_STATE' in ev}")
            check(motors_without_utime(ev) == motors_without_utime(ev_full),
                  f"{label}: every OMNI4_MOTORS sample as with both on")
            check(len(ev["OMNI4_POSE"]) == len(ev_full["OMNI4_POSE"]),
                  f"{label}: the camera poses logged as with both on")
    print(f"sim_summary: {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
