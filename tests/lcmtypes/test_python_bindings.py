#!/usr/bin/env python3
"""The lcm-gen Python bindings against the C side, on a log omni4-sim writes.

usage: test_python_bindings.py BIN_DIR PYTHONPATH_OF_GENERATED_TYPES
Every OMNI4_* message decodes in Python and encodes back to the same bytes (fingerprint and
layout agree with the C encoder); the OMNI4_MOTORS count, seq range and the sums of every
voltage, current and wheel speed equal what the C decoder (log_check --sums) reads.
Prints "N passed, M failed".
"""
import math
import os
import struct
import subprocess
import sys
import tempfile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
sys.path.insert(0, sys.argv[2])
sys.path.append(os.path.join(ROOT, "python"))  # after the generated omni4
import gen_channels  # noqa: E402  (the channel names of channels.h, as the package gets them)
from omni4 import experiment_t, motors_t, pose_t  # noqa: E402  (generated at build time)

with open(os.path.join(ROOT, "lcmtypes", "include", "omni4", "lcmtypes", "channels.h")) as _h:
    CHANNELS = {name: value for name, value, _ in gen_channels.constants(_h.read())}
MOTORS = CHANNELS["CHANNEL_MOTORS"]
TYPES = {MOTORS: motors_t, CHANNELS["CHANNEL_POSE"]: pose_t,
         CHANNELS["CHANNEL_EXPERIMENT"]: experiment_t}
EVENT_SYNC = 0xEDA1DA01


def events(path):
    """(channel, payload) of every event of an LCM event log (big-endian header)."""
    with open(path, "rb") as f:
        blob = f.read()
    pos = 0
    while pos < len(blob):
        sync, _eventnum, _utime, chan_len, data_len = struct.unpack_from(">IqqII", blob, pos)
        assert sync == EVENT_SYNC, f"no sync word at byte {pos}"
        pos += 28
        channel = blob[pos:pos + chan_len].decode()
        yield channel, blob[pos + chan_len:pos + chan_len + data_len]
        pos += chan_len + data_len


def main():
    bin_dir = sys.argv[1]
    passed = failed = 0

    def check(ok, what):
        nonlocal passed, failed
        print(("ok: " if ok else "FAIL: ") + what)
        passed, failed = passed + ok, failed + (not ok)

    with tempfile.TemporaryDirectory() as tmp:
        log = os.path.join(tmp, "sim.lcmlog")
        subprocess.run([os.path.join(bin_dir, "omni4-sim"), "--experiments",
                        "--out", log, "-q"], check=True, stdout=subprocess.DEVNULL,
                       timeout=120)  # ~1.5 s; a hang fails, naming the command
        counts, mismatched, seqs = {}, 0, []
        sums = [0.0, 0.0, 0.0]
        finite = True
        for channel, payload in events(log):
            if channel not in TYPES:
                continue
            msg = TYPES[channel].decode(payload)
            counts[channel] = counts.get(channel, 0) + 1
            mismatched += msg.encode() != payload
            if channel == MOTORS:
                seqs.append(msg.seq)
                for k, field in enumerate((msg.voltage, msg.current, msg.wheel_speed)):
                    sums[k] += sum(field)
                    finite &= all(math.isfinite(x) for x in field)
        c_side = subprocess.run([os.path.join(bin_dir, "log_check"), "--sums", log],
                                capture_output=True, text=True, timeout=60).stdout
    check(all(counts.get(c, 0) > 0 for c in TYPES),
          f"every type present in the log: {counts}")
    check(mismatched == 0, f"decode -> encode gives the logged bytes back ({mismatched} differ)")
    check(finite, "every decoded voltage, current and wheel speed is finite")
    n, first, last = (int(x) for x in (c_side.split("motors ")[1].split(",")[0],
                                       c_side.split("first seq ")[1].split(",")[0],
                                       c_side.split("last seq ")[1].split(",")[0]))
    check((n, first, last) == (len(seqs), seqs[0], seqs[-1]),
          f"C and Python agree: {len(seqs)} motors_t, seq {seqs[0]}..{seqs[-1]}")
    c_sums = [float(x) for x in c_side.split("sums: ")[1].split()[1::2]]
    worst = max(abs(a - b) / max(1.0, abs(b)) for a, b in zip(sums, c_sums))
    check(worst < 1e-9, f"sums of voltage/current/wheel_speed agree (relative {worst:.1e}): "
          f"python {', '.join(f'{s:.6g}' for s in sums)}")
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
