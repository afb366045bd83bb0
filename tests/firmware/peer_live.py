#!/usr/bin/env python3
"""Two controllers on one LCM URL (udpm, ttl=0, a port of its own; docs/faults.md):

A. A second omni4-fw on the URL of a running one refuses to start: exit status 1, one line
   naming the URL ("another controller is publishing OMNI4_MOTORS on URL (...): refusing to
   start"), within its 300 ms listen (bounded here at 5 s), and the first keeps running (its
   samples go on, no FAULT).
B. The running controller, driven (VOLTAGE 3 V, kept alive), hears foreign OMNI4_MOTORS samples
   (this test publishes motors_t with a seq and utime of its own, as a second controller would):
   FAULT with FAULT_BUS, 0 V, its stderr names the problem once; a MODE_CLEAR_FAULT is refused
   while the foreign samples go on and taken 1 s after they stopped; at SIGINT it exits 1 and
   says how many foreign samples it heard.

Usage: peer_live.py BIN_DIR [--port P]. Prints 'N passed, M failed'; exit 1 on any failure.
Every wait is bounded (and named when it runs out).
"""
import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time

import omni4

import livebus
from livebus import check

SCALE = max(1.0, float(os.environ.get("OMNI4_TEST_TIME_SCALE", "1")))
# Waits for an event: failure bounds only, generous so that a loaded machine cannot reach them.
WAIT_S = 20 * SCALE
FAULT_BUS = 0x0008
MODE_IDLE, MODE_VOLTAGE, MODE_CLEAR_FAULT, MODE_FAULT = 0, 2, 4, 5

class Bus(livebus.Bus):
    """The controller's OMNI4_MOTORS (ours excluded: this test's foreign seqs are >= 10^9)."""

    def __init__(self, url):
        super().__init__(url)
        self.last = None  # (seq, mode, faults, voltage)
        self.count = 0
        self.lc.subscribe(omni4.CHANNEL_MOTORS, self._on_motors)
        self.start()

    def _on_motors(self, _channel, data):
        m = omni4.motors_t.decode(data)
        if m.seq >= 10**9:
            return
        with self.lock:
            self.last = (m.seq, m.mode, m.faults, tuple(m.voltage))
            self.count += 1

    def foreign(self, seq):
        m = omni4.motors_t()
        m.utime, m.seq, m.mode, m.faults = int(time.time() * 1e6), seq, MODE_VOLTAGE, 0
        m.voltage, m.current, m.wheel_speed = [1.0] * 4, [0.0] * 4, [0.0] * 4
        self.lc.publish(omni4.CHANNEL_MOTORS, m.encode())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bin")
    ap.add_argument("--port", type=int, help="udpm port (default: one of livebus.TEST_PORTS)")
    a = ap.parse_args()
    url = livebus.test_url(a.port)
    fw = os.path.join(a.bin, "omni4-fw")
    tmp = tempfile.mkdtemp()
    ini = os.path.join(tmp, "robot.ini")
    with open(ini, "w") as f:
        f.write(f"[hal]\nmotor = sim\nlines = none\n[lcm]\nurl = {url}\n"
                "[control]\ncmd_timeout_ms = 300\n")
    bus = Bus(url)
    err_path = os.path.join(tmp, "first.err")
    err = open(err_path, "w")
    first = subprocess.Popen([fw, "--config", ini, "--duration", str(60 * SCALE), "-q"],
                             stderr=err)
    try:
        bus.wait(lambda b: b.count > 100, WAIT_S, "the first controller's samples")

        # A. the second controller refuses to start
        t0 = time.monotonic()
        r = subprocess.run([fw, "--config", ini, "--duration", "5", "-q"], capture_output=True,
                           text=True, timeout=WAIT_S)
        dt = time.monotonic() - t0
        lines = r.stderr.strip().splitlines()
        print(f"   second omni4-fw: status {r.returncode} after {dt:.2f} s: {r.stderr.strip()}")
        check(r.returncode == 1, "A: the second controller exits with status 1")
        check(len(lines) == 1 and lines[0].startswith(
            f"omni4-fw: another controller is publishing OMNI4_MOTORS on {url} (") and
            lines[0].endswith("): refusing to start"), "A: one line naming the URL")
        with bus.lock:
            n0 = bus.count
        # 50 more samples (counted, not timed: a loaded machine only makes them come later)
        bus.wait(lambda b: b.count > n0 + 50, WAIT_S, "the first controller's samples after")
        with bus.lock:
            last1 = bus.last
        check(first.poll() is None and last1[1] != MODE_FAULT,
              f"A: the first controller runs on (50 more samples, mode {last1[1]})")

        # B. the running controller, driven, hears a foreign stream
        keep = lambda: bus.send(MODE_VOLTAGE, (3.0, 3.0, 3.0, 3.0))  # noqa: E731
        bus.wait(lambda b: b.last[1] == MODE_VOLTAGE and b.last[3][0] > 2.9, WAIT_S,
                 "the first controller driving 3 V", each=keep)
        with bus.lock:
            seq_before = bus.last[0]
        check(True, f"B: driving at 3 V (seq {seq_before})")
        k = [10**9]

        def inject():
            keep()
            bus.foreign(k[0])
            k[0] += 1

        t0 = time.monotonic()
        bus.wait(lambda b: b.last[1] == MODE_FAULT and b.last[2] & FAULT_BUS and
                 all(v == 0 for v in b.last[3]), WAIT_S, "FAULT with FAULT_BUS and 0 V",
                 each=inject)
        check(True, f"B: FAULT, FAULT_BUS, 0 V {1e3 * (time.monotonic() - t0):.0f} ms after "
              f"the first foreign sample ({k[0] - 10**9} sent)")
        # a clear while the foreign stream goes on is refused
        for _ in range(30):
            inject()
            bus.send(MODE_CLEAR_FAULT)
            time.sleep(0.01)
        with bus.lock:
            mode = bus.last[1]
        check(mode == MODE_FAULT, f"B: MODE_CLEAR_FAULT refused while foreign samples arrive "
              f"(mode {mode})")
        time.sleep(1.2)  # the hold: 1 s of silence
        bus.wait(lambda b: b.last[1] == MODE_IDLE, WAIT_S, "IDLE after a clear",
                 each=lambda: bus.send(MODE_CLEAR_FAULT))
        check(True, "B: MODE_CLEAR_FAULT taken 1 s after the foreign samples stopped")
    except (TimeoutError, subprocess.TimeoutExpired) as e:
        check(False, str(e))
    finally:
        if first.poll() is None:
            first.send_signal(signal.SIGINT)
        try:
            rc = first.wait(timeout=10 * SCALE)
        except subprocess.TimeoutExpired:
            first.kill()
            rc = first.wait()
        err.close()
        bus.close()
    text = open(err_path).read()
    print("   first omni4-fw stderr:\n" + "".join("     " + ln + "\n"
                                                  for ln in text.strip().splitlines()))
    said = [ln for ln in text.splitlines() if "FAULT_BUS: another controller is publishing "
            f"OMNI4_MOTORS on {url}" in ln]
    check(len(said) == 1, f"B: stderr names the problem once ({len(said)} lines)")
    check(rc == 1 and "OMNI4_MOTORS samples from another controller heard" in text,
          f"B: exit status 1 after SIGINT with the count of foreign samples (status {rc})")
    failed = livebus.failed()
    print(f"{len(livebus.results) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
