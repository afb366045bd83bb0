#!/usr/bin/env python3
"""End to end: omni4-fw's current-sense offset calibration on the sim plant, over real LCM
(udpm, ttl=0, a port of its own).

A. Offsets injected through [sim] (+50, -50, +30, -20 mA; the sim's 20 mA current noise on):
   - the notice on OMNI4_PARAM_CHANGED has exactly the documented form (source "calibration",
     request_id 0, path "", the five keys, old values 0.000000 / 0) and its values equal the
     injected offsets within 5 mA;
   - its seq is the first OMNI4_MOTORS sample with the offsets subtracted (the sample before
     reads the raw offsets);
   - the mean logged current at rest within 5 mA of 0: in IDLE after the calibration, and with
     the bridges on at 0 V (the robot at rest, noisy readings) for 1 s;
   - omni4-fw's stderr line names the tick; omni4-record (started first) holds the notice,
     omni4.read_log reads the log, omni4-mcap exports it and the MCAP holds the notice.
B. An offset beyond the limit (channel 2 at 0.3 A): FAULT with FAULT_CURRENT_SENSOR, the notice
   carries calibration.fault_channels "2", the stderr line names channel 2, and a clear is
   refused while the offset stays.

Usage: calibration_live.py BIN_DIR [--port P]
Prints the figures and 'N passed, M failed'; exit status 1 on any failure. Every wait is
bounded (and named when it runs out).
"""
import argparse
import json
import os
import re
import select
import signal
import subprocess
import sys
import tempfile
import time

import lcm
import numpy as np

import omni4

import livebus
from livebus import check

SCALE = max(1.0, float(os.environ.get("OMNI4_TEST_TIME_SCALE", "1")))
START_TIMEOUT_S = 10 * SCALE
NOTICE_TIMEOUT_S = 20 * SCALE    # the first set comes 0.45 s after the first tick
# Waits for an event (samples, a notice): failure bounds only, generous so that a loaded
# machine cannot reach them. Samples are counted, never timed.
WAIT_S = 20 * SCALE
EXIT_TIMEOUT_S = 10 * SCALE
TOL_A = 0.005                    # 5 mA
# docs/faults.md
LIMIT_A = 0.25
SAMPLES = 400
FAULT_CURRENT_SENSOR = 0x0020
MODE_FAULT = 5
INJECTED = (0.050, -0.050, 0.030, -0.020)
KEYS = [f"calibration.current_offset_a{j}" for j in range(4)] + ["calibration.samples"]

ROBOT_INI = """; calibration_live
[hal]
motor = sim
lines = sim
[lcm]
url = {url}
[sim]
current_offset_a0 = {a[0]}
current_offset_a1 = {a[1]}
current_offset_a2 = {a[2]}
current_offset_a3 = {a[3]}
"""

class Bus(livebus.Bus):
    """OMNI4_MOTORS by seq and OMNI4_PARAM_CHANGED, on a thread of its own."""

    def __init__(self, url):
        super().__init__(url)
        self.motors = {}
        self.notices = []
        # LCM keeps 30 undelivered messages by default (30 ms at 1 kHz): a busy machine that
        # holds this thread back longer must not lose the samples counted below.
        self.lc.subscribe(omni4.CHANNEL_MOTORS, self._on_motors).set_queue_capacity(100000)
        self.lc.subscribe(omni4.CHANNEL_PARAM_CHANGED, self._on_changed)
        self.start()

    def _on_motors(self, _channel, data):
        m = omni4.motors_t.decode(data)
        with self.lock:
            self.motors[m.seq] = (m.mode, m.faults, tuple(m.current), m.utime)

    def _on_changed(self, _channel, data):
        m = omni4.param_changed_t.decode(data)
        with self.lock:
            self.notices.append(m)

    def calibration(self, k=0):
        c = [n for n in self.notices if n.source == "calibration"]
        return c[k] if len(c) > k else None

    def last_seq(self):
        return max(self.motors) if self.motors else -1


def start_fw(bin_dir, ini, log_path):
    log = open(log_path, "w")
    p = subprocess.Popen([os.path.join(bin_dir, "omni4-fw"), "--config", str(ini)],
                         stdout=log, stderr=subprocess.STDOUT)
    return p, log


def stop(p, log=None):
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
    try:
        p.wait(timeout=EXIT_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait(timeout=EXIT_TIMEOUT_S)
    if log:
        log.close()
    return p.returncode


def mean_current(bus, seqs):
    with bus.lock:
        rows = [bus.motors[s][2] for s in seqs if s in bus.motors]
    return np.array(rows).mean(axis=0), len(rows)


def scenario_a(bin_dir, tmp, url):
    print(f"A. offsets {INJECTED} A injected, omni4-fw on {url}", flush=True)
    ini = os.path.join(tmp, "a.ini")
    with open(ini, "w") as f:
        f.write(ROBOT_INI.format(url=url, a=INJECTED))
    rec_log = os.path.join(tmp, "a.lcmlog")
    rec = subprocess.Popen([os.path.join(bin_dir, "omni4-record"), "--lcm", url, "--out",
                            rec_log], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           text=True)
    ready, _, _ = select.select([rec.stderr], [], [], 5 * SCALE)
    if not check(ready and " <- " in rec.stderr.readline(), "omni4-record subscribed"):
        stop(rec)
        return
    bus = Bus(url)
    fw, fw_log = start_fw(bin_dir, ini, os.path.join(tmp, "a.stderr"))
    try:
        bus.wait(lambda b: b.motors, START_TIMEOUT_S, "the first OMNI4_MOTORS")
        n = bus.wait(lambda b: b.calibration(), NOTICE_TIMEOUT_S, "the calibration notice")
        check((n.source, n.request_id, n.path) == ("calibration", 0, ""),
              f"notice source/request_id/path: {(n.source, n.request_id, n.path)}")
        check(list(n.keys) == KEYS and n.n == 5, f"notice keys: {list(n.keys)}")
        check(list(n.old_values) == ["0.000000"] * 4 + ["0"],
              f"notice old values: {list(n.old_values)}")
        check(n.values[4] == str(SAMPLES), f"notice samples: {n.values[4]}")
        announced = [float(v) for v in n.values[:4]]
        err = [a - b for a, b in zip(announced, INJECTED)]
        print(f"   announced offsets {announced} A, injected {list(INJECTED)} A, "
              f"difference {[round(e * 1e3, 3) for e in err]} mA; seq {n.seq}", flush=True)
        check(all(abs(e) <= TOL_A for e in err), "announced offsets within 5 mA of injected")

        # The notice's tick: the first sample with the offsets subtracted.
        bus.wait(lambda b: b.last_seq() >= n.seq + 1000, WAIT_S, "1 s of IDLE samples")
        with bus.lock:
            before, at = bus.motors.get(n.seq - 1), bus.motors.get(n.seq)
        check(before and at and at[3] == n.utime, "samples seq-1 and seq logged, utime = seq's")
        if before and at:
            print(f"   current at seq-1 {before[2]}, at seq {at[2]}", flush=True)
            check(all(abs(c - i) <= TOL_A for c, i in zip(before[2], INJECTED)),
                  "seq - 1: the raw offsets (not yet subtracted)")
            check(all(abs(c) <= TOL_A for c in at[2]), "seq: the offsets subtracted")
        idle, k = mean_current(bus, range(n.seq, n.seq + 1000))
        print(f"   mean current at rest, IDLE, {k} samples: "
              f"{[round(x * 1e3, 3) for x in idle]} mA", flush=True)
        check(k >= 990 and all(abs(x) <= TOL_A for x in idle),
              "IDLE after calibration: mean current within 5 mA of 0")

        # Bridges on at 0 V, the robot at rest: the noisy readings' mean, over 1000 ticks of
        # VOLTAGE after the first 100 (counted in the controller's ticks, not timed).
        t_end = time.monotonic() + WAIT_S
        s0 = bus.last_seq()
        seq = 0

        def n_driven():
            with bus.lock:
                return sum(1 for s, m in bus.motors.items() if s >= s0 and m[0] == 2)
        while n_driven() < 1100:
            if time.monotonic() > t_end:
                raise TimeoutError(f"waited {WAIT_S:g} s for 1100 ticks of VOLTAGE 0 V")
            bus.send(2, seq=seq)
            seq += 1
            time.sleep(0.05)
        s1 = bus.last_seq()
        bus.send(0, seq=seq)
        with bus.lock:
            driven = [s for s in range(s0, s1 + 1)
                      if s in bus.motors and bus.motors[s][0] == 2]
        driven = driven[-1000:]
        drive, k = mean_current(bus, driven)
        with bus.lock:
            sd = np.array([bus.motors[s][2] for s in driven]).std(axis=0)
        print(f"   mean current at rest, VOLTAGE 0 V (bridges on), {k} samples: "
              f"{[round(x * 1e3, 3) for x in drive]} mA (std {[round(x * 1e3, 1) for x in sd]} "
              f"mA)", flush=True)
        check(k >= 990 and all(abs(x) <= TOL_A for x in drive),
              "bridges on at 0 V: mean current within 5 mA of 0")
        time.sleep(0.2)
    except TimeoutError as e:
        check(False, str(e))
        n = None
    finally:
        rc = stop(fw, fw_log)
        bus.close()
        stop(rec)
    check(rc == 0, f"omni4-fw exit status {rc}")
    text = open(os.path.join(tmp, "a.stderr")).read()
    if n is not None:
        m = re.search(r"current offsets (\S+) (\S+) (\S+) (\S+) A subtracted from tick (\d+)",
                      text)
        check(m and int(m.group(5)) == n.seq and
              [float(x) for x in m.group(1, 2, 3, 4)] == [float(v) for v in n.values[:4]],
              f"omni4-fw stderr names the offsets and tick: {m.group(0) if m else text!r}")

    # The recorder's log, the Python reader and the MCAP export.
    logged = []
    for ev in lcm.EventLog(rec_log, "r"):
        if ev.channel == omni4.CHANNEL_PARAM_CHANGED:
            c = omni4.param_changed_t.decode(ev.data)
            if c.source == "calibration":
                logged.append(c)
    check(n is not None and logged and (logged[0].seq, list(logged[0].values)) ==
          (n.seq, list(n.values)), "omni4-record holds the calibration notice")
    log = omni4.read_log(rec_log)
    check(len(log.motors) > 1000 and log.unknown_counts.get(omni4.CHANNEL_PARAM_CHANGED, 0) >= 2,
          f"omni4.read_log: {len(log.motors)} motors, unknown {log.unknown_counts}")
    mcap_exe = os.path.join(os.path.dirname(sys.executable), "omni4-mcap")
    if not os.access(mcap_exe, os.X_OK):
        print("   (omni4-mcap not installed beside this Python: MCAP export not checked)")
        return
    out = os.path.join(tmp, "a.mcap")
    r = subprocess.run([mcap_exe, rec_log, "--out", out], capture_output=True, text=True,
                       timeout=60 * SCALE)
    check(r.returncode == 0, f"omni4-mcap exit status {r.returncode} {r.stderr.strip()}")
    from mcap.reader import make_reader
    found = []
    with open(out, "rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages():
            if channel.topic == omni4.CHANNEL_PARAM_CHANGED:
                d = json.loads(message.data)
                if d.get("source") == "calibration":
                    found.append(d)
    check(found and found[0]["keys"] == KEYS and found[0]["values"] == list(n.values),
          f"the MCAP holds the notice: {found[:1]}")


def scenario_b(bin_dir, tmp, url):
    off = (0.0, 0.0, 0.3, 0.0)
    print(f"B. offsets {off} A injected (channel 2 beyond {LIMIT_A} A)", flush=True)
    ini = os.path.join(tmp, "b.ini")
    with open(ini, "w") as f:
        f.write(ROBOT_INI.format(url=url, a=off))
    bus = Bus(url)
    fw, fw_log = start_fw(bin_dir, ini, os.path.join(tmp, "b.stderr"))
    try:
        bus.wait(lambda b: b.motors, START_TIMEOUT_S, "the first OMNI4_MOTORS")
        n = bus.wait(lambda b: b.calibration(), NOTICE_TIMEOUT_S, "the calibration notice")
        got = dict(zip(n.keys, n.values))
        print(f"   notice: {got}", flush=True)
        check(list(n.keys) == KEYS + ["calibration.fault_channels"] and
              got["calibration.fault_channels"] == "2", "notice names channel 2")
        check(abs(float(got["calibration.current_offset_a2"]) - 0.3) <= TOL_A,
              "notice carries the measured offset")
        bus.wait(lambda b: b.last_seq() >= n.seq + 50, WAIT_S, "samples after the notice")
        with bus.lock:
            mode, faults = bus.motors[n.seq][:2]
        check(mode == MODE_FAULT and faults & FAULT_CURRENT_SENSOR,
              f"FAULT with FAULT_CURRENT_SENSOR at the notice's tick (mode {mode}, "
              f"faults 0x{faults:04x})")
        bus.send(4)  # MODE_CLEAR_FAULT: refused while the offset stays
        s = bus.last_seq()
        bus.wait(lambda b: b.last_seq() >= s + 100, WAIT_S, "samples after the clear")
        with bus.lock:
            mode = bus.motors[bus.last_seq()][0]
        check(mode == MODE_FAULT, f"a clear is refused while the offset stays (mode {mode})")
    except TimeoutError as e:
        check(False, str(e))
    finally:
        rc = stop(fw, fw_log)
        bus.close()
    text = open(os.path.join(tmp, "b.stderr")).read()
    line = next((x for x in text.splitlines() if "FAULT_CURRENT_SENSOR" in x), "")
    print(f"   stderr: {line}", flush=True)
    check(re.search(r"channel 2: current offset 0\.3\d* A beyond the 0\.25 A limit", line),
          "omni4-fw stderr names channel 2")
    check(rc == 0, f"omni4-fw exit status {rc}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bin_dir")
    ap.add_argument("--port", type=int, help="udpm port (default: one of livebus.TEST_PORTS)")
    a = ap.parse_args()
    url = livebus.test_url(a.port)
    with tempfile.TemporaryDirectory(prefix="calibration_live.") as tmp:
        scenario_a(a.bin_dir, tmp, url)
        scenario_b(a.bin_dir, tmp, url)
    failed = livebus.failed()
    print(f"calibration_live: {len(livebus.results) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
