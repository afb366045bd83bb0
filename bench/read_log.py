#!/usr/bin/env python3
"""omni4.read_log beside its peer, on the same log in the same run: plain lcm.EventLog iteration
with motors_t.decode of every OMNI4_MOTORS event (what a script does without the package).
The peer decodes only OMNI4_MOTORS; read_log decodes every channel.

usage: read_log.py LOG [REPS]   (the project's .venv/bin/python; REPS of each, interleaved)
prints: read_log s min/med/max A/B/C, peer s min/med/max D/E/F, bytes N, events E, motors M,
        peer/read_log R x (the medians' ratio: how many times faster read_log is)
"""
import statistics
import sys
import time

import lcm

import omni4


def peer(path):
    n = 0
    for ev in lcm.EventLog(path, "r"):
        if ev.channel == omni4.CHANNEL_MOTORS:
            omni4.motors_t.decode(ev.data)
            n += 1
    return n


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit("usage: read_log.py LOG [REPS]")
    path, reps = sys.argv[1], int(sys.argv[2]) if len(sys.argv) == 3 else 5
    ours, theirs = [], []
    for _ in range(reps):
        t = time.perf_counter()
        log = omni4.read_log(path)
        ours.append(time.perf_counter() - t)
        t = time.perf_counter()
        n = peer(path)
        theirs.append(time.perf_counter() - t)
        if n != len(log.motors):
            sys.exit(f"read_log.py: {path}: read_log has {len(log.motors)} motors_t, "
                     f"lcm.EventLog {n}")
    fmt = lambda v: f"{min(v):.3f}/{statistics.median(v):.3f}/{max(v):.3f}"  # noqa: E731
    print(f"read_log s min/med/max {fmt(ours)}, peer s min/med/max {fmt(theirs)}, "
          f"bytes {log.bytes_total}, events {log.events}, motors {len(log.motors)}, "
          f"peer/read_log {statistics.median(theirs) / statistics.median(ours):.1f} x")


if __name__ == "__main__":
    main()
