"""omni4.read_log's C walk (_logwalk.c) against its numpy walk and a pure Python walk on
corrupted buffers, the whole read with and without the library, and the summary's channel
lines against lcm.EventLog's own count of a simulator log (every channel named with its type)."""
import random
import struct
import subprocess
from collections import Counter

import lcm
import numpy as np
import pytest

import omni4
from omni4 import log as omni4_log

SYNC = struct.pack(">I", 0xEDA1DA01)


def python_walk(data, max_channel=256):
    """The walk as logdata.cpp states it, one byte at a time: [(offset, clen, dlen, utime)],
    bytes outside the events, bytes after the last one."""
    out, pos, used, end = [], 0, 0, 0
    n = len(data)
    while pos + 28 <= n:
        sync, _num, t, c, d = struct.unpack_from(">Iqqii", data, pos)
        if sync == 0xEDA1DA01 and 0 < c <= max_channel and d >= 0 and pos + 28 + c + d <= n:
            out.append((pos, c, d, t))
            used += 28 + c + d
            pos += 28 + c + d
            end = pos
        else:
            pos += 1
    return out, n - used, n - end


def event(t, channel, payload):
    return SYNC + struct.pack(">qqii", 7, t, len(channel), len(payload)) + channel + payload


def corrupt_log(rng):
    """Events on a few channels, with sync words inside payloads, flipped bytes, garbage between
    events, a header with a negative or huge length and a cut tail."""
    parts = [bytes(rng.randrange(256) for _ in range(rng.randrange(0, 40)))]
    names = [b"OMNI4_MOTORS", b"OMNI4_POSE", b"X", b"OMNI4_MOTORZ", b"OMNI4_STATE\0"]
    for k in range(rng.randrange(1, 120)):
        payload = bytearray(rng.randrange(256) for _ in range(rng.randrange(0, 90)))
        if payload and rng.random() < 0.2:
            at = rng.randrange(len(payload))
            payload[at:at + 4] = SYNC
        ev = bytearray(event(1000 + k, rng.choice(names), bytes(payload)))
        r = rng.random()
        if r < 0.08:
            ev[rng.randrange(len(ev))] ^= 0xFF
        elif r < 0.12:
            ev[20:24] = struct.pack(">i", rng.choice([0, -1, 257, 1 << 30]))
        elif r < 0.16:
            ev[24:28] = struct.pack(">i", rng.choice([-5, 1 << 30]))
        parts.append(bytes(ev))
        if rng.random() < 0.1:
            parts.append(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 30))))
    data = b"".join(parts)
    return data[:len(data) - rng.randrange(0, 20)]


def as_buf(data):
    return np.frombuffer(data, np.uint8).copy()


def test_the_library_is_built_and_used():
    assert omni4_log._walk_lib() is not None, "_omni4log missing: read_log runs its numpy path"


@pytest.mark.parametrize("seed", range(40))
def test_c_walk_equals_numpy_and_python_walks(seed):
    data = corrupt_log(random.Random(seed))
    pad = b"\x00" * 5  # the file inside a larger buffer, as read_log holds split logs
    buf = as_buf(pad + data + pad)
    lo, hi = len(pad), len(pad) + len(data)
    c = omni4_log._walk(buf, lo, hi)
    npy = omni4_log._walk_numpy(buf, lo, hi)
    for a, b in zip(c[:4], npy[:4]):
        assert a.dtype == b.dtype == np.int64 and np.array_equal(a, b)
    assert c[4:] == npy[4:]
    ref, skipped, tail = python_walk(data)
    assert [tuple(int(x) for x in r) for r in zip(c[0] - lo, *c[1:4])] == ref
    assert (c[4], c[5]) == (skipped, tail)


@pytest.mark.parametrize("seed", range(20))
def test_channel_ids_and_gather_equal_numpy(seed):
    data = corrupt_log(random.Random(100 + seed))
    buf = as_buf(data)
    off, clen, dlen, _, _, _ = omni4_log._walk(buf, 0, len(data))
    names_c, names_np = ["OMNI4_MOTORS", "OMNI4_POSE"], ["OMNI4_MOTORS", "OMNI4_POSE"]
    ids_c = omni4_log._channel_ids(buf, off, clen, names_c)
    ids_np = omni4_log._channel_ids_numpy(buf, off, clen, names_np)
    assert names_c == names_np and np.array_equal(ids_c, ids_np)
    for k, i in enumerate(ids_c):  # and each id names the event's channel bytes
        a = int(off[k]) + 28
        assert data[a:a + int(clen[k])] == names_c[i].encode("utf-8", "surrogateescape") or \
            names_c[i] == data[a:a + int(clen[k])].decode("utf-8", "replace")
    doff = off + 28 + clen
    size = 4
    sel = doff[dlen >= size]
    rows = omni4_log._gather(buf, sel, size)
    assert rows.tolist() == [list(data[a:a + size]) for a in sel.tolist()]


@pytest.fixture(scope="module")
def sim_log(tmp_path_factory, omni4_bin):
    path = tmp_path_factory.mktemp("reader") / "sim.lcmlog"
    r = subprocess.run([omni4_bin("omni4-sim"), "--duration", "2", "--out", str(path), "-q"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    return path


def test_read_log_with_and_without_the_library(sim_log, monkeypatch):
    fast = omni4.read_log(str(sim_log))
    monkeypatch.setattr(omni4_log, "_LIB", [None])
    slow = omni4.read_log(str(sim_log))
    assert fast.events == slow.events and fast.bytes_skipped == slow.bytes_skipped
    assert list(fast.channels) == list(slow.channels)
    for name, ca in fast.channels.items():
        cb = slow.channels[name]
        assert ca.skipped == cb.skipped, name
        for f in ("event_utime",) + ca.fields:
            x, y = getattr(ca, f), getattr(cb, f)
            assert x.dtype == y.dtype and np.array_equal(x, y), f"{name}.{f}"
    assert fast.unknown == slow.unknown and fast.unknown_counts == slow.unknown_counts


def test_summary_names_every_type_and_counts_as_eventlog(sim_log):
    counted = Counter(ev.channel for ev in lcm.EventLog(str(sim_log), "r"))
    log = omni4.read_log(str(sim_log))
    lines = log.summary().splitlines()
    assert lines[0].endswith(f"{sum(counted.values())} events")
    assert counted[omni4.CHANNEL_PARAM_CHANGED] >= 1
    for channel, n in counted.items():
        line = next(x for x in lines if x.startswith(f"  {channel}: "))
        assert line.split(": ")[1].split()[0] == str(n), line
        assert "no omni4 type" not in line, line
    line = next(x for x in lines if x.startswith(f"  {omni4.CHANNEL_PARAM_CHANGED}: "))
    assert "param_changed_t" in line
    for channel, cls in omni4_log.NAMED_RAW.items():  # every type the package has a channel for
        assert cls in (omni4.param_changed_t, omni4.param_reply_t, omni4.param_request_t)
