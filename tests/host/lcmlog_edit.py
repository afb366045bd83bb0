#!/usr/bin/env python3
"""Edit an LCM event log at the byte level (no lcm module needed), for the CLI tests.

  lcmlog_edit.py IN OUT --keep CHANNEL[,CHANNEL]   keep only the events of these channels
  lcmlog_edit.py IN OUT --drop CHANNEL[,CHANNEL]   leave out the events of these channels
  lcmlog_edit.py IN OUT --drop-steps DIR           turn the 'step' marks along DIR into 'hold'
                                                   marks (a kind nothing uses): no steps there

The event log format (lcm/eventlog.h): per event a big-endian header -- sync 0xEDA1DA01, event
number (int64), timestamp (int64), channel length (int32), data length (int32) -- the channel
name and the data."""
import argparse
import struct
import sys

SYNC = 0xEDA1DA01


def events(data):
    pos = 0
    while pos + 28 <= len(data):
        sync, num, ts, clen, dlen = struct.unpack_from(">IqqII", data, pos)
        if sync != SYNC or pos + 28 + clen + dlen > len(data):
            raise SystemExit(f"lcmlog_edit: not an intact event log at byte {pos}")
        channel = data[pos + 28:pos + 28 + clen].decode()
        yield num, ts, channel, data[pos + 28 + clen:pos + 28 + clen + dlen]
        pos += 28 + clen + dlen


def lcm_string(s):
    b = s.encode() + b"\0"
    return struct.pack(">i", len(b)) + b


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--keep")
    ap.add_argument("--drop")
    ap.add_argument("--drop-steps", metavar="DIR")
    a = ap.parse_args()
    with open(a.src, "rb") as f:
        data = f.read()
    keep = set(a.keep.split(",")) if a.keep else None
    drop = set(a.drop.split(",")) if a.drop else set()
    step = lcm_string("step") + lcm_string(a.drop_steps) if a.drop_steps else None
    out = bytearray()
    for num, ts, channel, body in events(data):
        if (keep is not None and channel not in keep) or channel in drop:
            continue
        if step and channel == "OMNI4_EXPERIMENT":  # experiment_t: fingerprint, utime, kind, ...
            if body[16:16 + len(step)] == step:
                body = body[:16] + lcm_string("hold") + body[16 + len(lcm_string("step")):]
        out += struct.pack(">IqqII", SYNC, num, ts, len(channel), len(body))
        out += channel.encode() + body
    with open(a.dst, "wb") as f:
        f.write(out)


if __name__ == "__main__":
    sys.exit(main())
