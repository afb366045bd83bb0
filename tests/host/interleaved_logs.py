#!/usr/bin/env python3
"""Logs holding two controllers' OMNI4_MOTORS interleaved are refused by every reader, and a log
with a few reordered, repeated or restarted samples is still read (docs/log-contract.md,
"Two controllers on one bus").

Synthetic LCM event logs (lcm.EventLog), 3000 motors_t samples at 1 kHz each:
  clean        one controller, seq 0..2999;
  few          the same with 12 adjacent pairs swapped, 3 repeated datagrams (same seq and
               utime) and one controller restart (seq back to 0): 13 backward steps;
  at_limit     50 swapped pairs: 50 backward steps, the most a log may hold;
  over_limit   51 swapped pairs: refused;
  interleaved  two controllers (seq 0.. and 700..) publishing at 1 kHz, their samples
               alternating in the log, as omni4-record wrote it on the robot.
Each is read by omni4.read_log, omni4-ident identify (reads the logs first; the synthetic logs
carry no experiment marks, so a log it reads ends at "no experiment segments", one it refuses
at the one-line refusal naming the log, no parameters written) and omni4-mcap.

Usage: interleaved_logs.py BIN_DIR. Prints 'N passed, M failed'; exit 1 on any failure.
"""
import os
import subprocess
import sys
import tempfile

import lcm

import omni4

BIN = sys.argv[1]
MCAP = os.path.join(os.path.dirname(sys.executable), "omni4-mcap")
LIMIT = 50  # docs/log-contract.md
T0 = 1_000_000_000


def motors(seq, utime):
    m = omni4.motors_t()
    m.utime, m.seq, m.mode = utime, seq, 0
    m.voltage = [0.0] * 4
    m.current = [0.0] * 4
    m.wheel_speed = [0.0] * 4
    return m.encode()


def write(path, samples):
    """samples: (seq, utime) in log order."""
    log = lcm.EventLog(path, "w", overwrite=True)
    for seq, ut in samples:
        log.write_event(ut, omni4.CHANNEL_MOTORS, motors(seq, ut))
    log.close()


def one(n=3000, start=0, t0=T0):
    return [(start + k, t0 + 1000 * k) for k in range(n)]


def swapped(samples, pairs):
    s = list(samples)
    for i in range(pairs):
        k = 20 + 50 * i
        s[k], s[k + 1] = s[k + 1], s[k]
    return s


def logs(tmp):
    out = {}
    out["clean"] = (one(), 0)
    few = swapped(one(), 12)
    few[2000:2000] = [few[1999]] * 3  # a datagram recorded 4 times
    few += one(300, 0, T0 + 3_100_000)  # the controller restarted: seq from 0 again
    out["few"] = (few, 13)
    out["at_limit"] = (swapped(one(), LIMIT), LIMIT)
    out["over_limit"] = (swapped(one(), LIMIT + 1), LIMIT + 1)
    a, b = one(), one(3000, 700, T0 + 500)
    inter = [x for pair in zip(a, b) for x in pair]
    out["interleaved"] = (inter, None)
    paths = {}
    for name, (samples, _) in out.items():
        paths[name] = os.path.join(tmp, name + ".lcmlog")
        write(paths[name], samples)
    return paths, {k: v[1] for k, v in out.items()}


def main():
    passed = failed = 0

    def check(ok, what):
        nonlocal passed, failed
        print(("ok: " if ok else "FAIL: ") + what)
        passed += bool(ok)
        failed += not ok

    with tempfile.TemporaryDirectory() as tmp:
        paths, backwards = logs(tmp)
        for name, path in paths.items():
            refuse = name in ("over_limit", "interleaved")
            # omni4.read_log
            try:
                log = omni4.read_log(path)
                check(not refuse, f"{name}: omni4.read_log read it ({len(log.motors)} samples, "
                      f"{log.seq_backwards} backward)")
                if backwards[name] is not None and not refuse:
                    check(log.seq_backwards == backwards[name],
                          f"{name}: {log.seq_backwards} backward steps counted, "
                          f"{backwards[name]} planted")
            except omni4.LogError as e:
                msg = str(e)
                print("   " + msg)
                check(refuse and msg.startswith(path + ": OMNI4_MOTORS from two controllers "
                                                "interleaved") and "record one controller per bus" in msg,
                      f"{name}: omni4.read_log refused it")
            # omni4-ident
            robot = os.path.join(tmp, "robot.ini")
            with open(robot, "w") as f:
                f.write("[model]\nd = 0.1\nr = 0.0355\nl = 19.7\nM = 1.944\n")
            params = os.path.join(tmp, name + ".ini")
            r = subprocess.run([os.path.join(BIN, "omni4-ident"), "identify", "--robot", robot,
                                "--out", params, path], capture_output=True, text=True,
                               timeout=60)
            err = r.stderr.strip().splitlines()
            last = err[-1] if err else ""
            print("   omni4-ident: " + last)
            if refuse:
                check(r.returncode == 1 and len(err) == 1 and last.startswith(
                    f"omni4-ident: {path}: OMNI4_MOTORS from two controllers interleaved (") and
                    last.endswith("samples whose seq goes backwards): record one controller per "
                                  "bus") and "events" not in r.stdout
                    and not os.path.exists(params),
                      f"{name}: omni4-ident refused it (status {r.returncode}, one line)")
            else:
                check("no experiment segments" in last and f"{path}: " in r.stdout,
                      f"{name}: omni4-ident read it (status {r.returncode})")
            # omni4-mcap
            out = os.path.join(tmp, name + ".mcap")
            r = subprocess.run([MCAP, "-q", "--out", out, path], capture_output=True, text=True,
                               timeout=120)
            last = (r.stderr.strip().splitlines() or [""])[-1]
            if refuse:
                print("   omni4-mcap: " + last)
                check(r.returncode == 1 and "OMNI4_MOTORS from two controllers interleaved" in
                      last and not os.path.exists(out), f"{name}: omni4-mcap refused it")
            else:
                check(r.returncode == 0 and os.path.exists(out),
                      f"{name}: omni4-mcap exported it (status {r.returncode}) {last}")
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
