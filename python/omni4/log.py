"""Reads omni4 LCM event logs into numpy arrays, one array per message field.

    log = omni4.read_log("sim.lcmlog")            # or ["rec.lcmlog.00", "rec.lcmlog.01"]
    log.motors.wheel_speed                        # (N, 4) float32 [rad/s]
    log.motors.utime                              # (N,) int64, controller clock [us]
    log.experiment.kind                           # (K,) str: "step", "coast", ...
    print(log.summary())                          # what was read, skipped and why

The log format is LCM's (lcm/eventlog.h): per event a 28-byte big-endian header (sync word
0xEDA1DA01, event number int64, log time int64 [us], channel length int32, data length int32),
the channel name, the payload. The reader loads each file once, walks the header chain the
way host-tools/common/logdata.cpp does (an invalid header or a truncated event: skip to the next
sync word, count the bytes; in C, _logwalk.c, which also names each event's channel and gathers
the payloads; the same in numpy where that library is not built), and decodes the fixed-size
types (motors_t, pose_t, command_t, state_t, sim_truth_t, sim_plant_t, goal_status_t,
adapt_t) with
one structured big-endian view over the gathered payloads (the dtype omni4._layout reads from
the generated classes): no Python loop per message. Variable-size types (experiment_t) and
any other type in omni4.TYPES go through the lcm-gen decoder, message by message. The
parameter channels (NAMED_RAW: param_changed_t, param_reply_t, param_request_t) are kept raw;
the summary names their type.

Nothing is dropped silently: a payload of the wrong size, with another type's fingerprint or
that the decoder refuses is counted per channel (`Channel.skipped`), bytes between intact
events and a truncated tail are counted per file (`Log.files`), and channels without an omni4
type are kept as raw payloads (`Log.unknown`) or only counted (`keep_unknown=False`).
Values are not filtered: a NaN current in the log is a NaN here. Messages stay in log order.
"""
import ctypes
import glob
import io
import os

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from . import (CHANNEL_CMD, CHANNEL_EXPERIMENT, CHANNEL_MOTORS, CHANNEL_PARAM_CHANGED,
               CHANNEL_PARAM_REPLY, CHANNEL_PARAM_REQ, CHANNEL_POSE, CHANNEL_STATE, TYPES,
               _layout, param_changed_t, param_reply_t, param_request_t)
from ._layout import FINGERPRINT_BYTES

SYNC = 0xEDA1DA01
HEADER_BYTES = 28       # sync (4), event number (8), log time (8), channel length (4), data length (4)
MAX_CHANNEL_BYTES = 256  # a longer channel length is a corrupt header (as logdata.cpp)

_HEADER = np.dtype([("sync", ">u4"), ("eventnum", ">i8"), ("utime", ">i8"),
                    ("clen", ">i4"), ("dlen", ">i4")])
assert _HEADER.itemsize == HEADER_BYTES

# The fixed-size types of TYPES and their wire dtypes (omni4._layout, read from the generated
# classes): these are decoded with one structured view, the others message by message.
_FAST = {cls: _layout.wire_dtype(cls) for cls in TYPES.values()
         if _layout.wire_dtype(cls) is not None}


# Channels whose omni4 type read_log does not decode into arrays (variable-length types: their
# events are kept raw in Log.unknown, as any channel outside TYPES; decode them with the class's
# decode()). The summary names their type.
NAMED_RAW = {CHANNEL_PARAM_CHANGED: param_changed_t, CHANNEL_PARAM_REPLY: param_reply_t,
             CHANNEL_PARAM_REQ: param_request_t}


class LogError(ValueError):
    """A log that holds no intact LCM event (not an event log, empty, or all corrupt)."""


class Channel:
    """The messages of one channel: one numpy array per field of the LCM type, first axis the
    message (log order), plus `event_utime` (int64 [us], the logger's receive time of each
    event). Fixed-size arrays are 2-D: motors.voltage is (N, 4). Integers keep their LCM width
    (int64 utime/seq, int8 mode, int32 faults); float fields their precision (float32 in
    motors_t, float64 elsewhere); strings are numpy str arrays.

    `skipped` counts the channel's events that were not decoded, by reason: `wrong_size` (the
    payload is not the type's fixed size), `wrong_fingerprint` (another type or a changed
    .lcm), `undecodable` (the generated decoder refused it or left bytes over)."""

    def __init__(self, name, lcm_type, fields, event_utime, skipped=None):
        self.name = name
        self.type = lcm_type
        self.fields = tuple(fields)
        self.event_utime = event_utime
        self.skipped = dict(skipped or {})
        for k, v in fields.items():
            setattr(self, k, v)

    def __len__(self):
        return len(self.event_utime)

    def __repr__(self):
        t = self.type.__name__ if self.type else "?"
        bad = sum(self.skipped.values())
        return f"<Channel {self.name} ({t}): {len(self)} messages, {bad} skipped>"


class FileStats:
    """What one file of the stream held: size [bytes], intact events, bytes outside intact
    events (corruption and a truncated tail), of which after the last intact event."""

    def __init__(self, path, size, events, bytes_skipped, tail_bytes):
        self.path, self.size, self.events = path, size, events
        self.bytes_skipped, self.tail_bytes = bytes_skipped, tail_bytes

    def __repr__(self):
        return (f"<FileStats {self.path}: {self.size} bytes, {self.events} events, "
                f"{self.bytes_skipped} bytes skipped ({self.tail_bytes} at the end)>")


class Log:
    """An event log (or the parts of a split log, one stream) read into numpy arrays.

    Attributes: `motors`, `pose`, `cmd`, `experiment`, `state` (the controller's estimate)
    (Channel; empty if the log has none),
    `channels` (every decoded channel by name), `unknown` (channel -> list of (event_utime,
    payload bytes) for channels without an omni4 type; empty lists with keep_unknown=False),
    `unknown_counts` (channel -> events), `files` (FileStats per file), `events` (intact events),
    `bytes_total`, `bytes_skipped`, `seq_gaps` / `seq_duplicates` (motors_t samples missing /
    repeated or out of order, counted in log order as tests/hil/log_check.c does)."""

    def __init__(self, files, channels, unknown, unknown_counts):
        self.files = files
        self.paths = [f.path for f in files]
        self.channels = channels
        self.unknown = unknown
        self.unknown_counts = unknown_counts
        self.events = sum(f.events for f in files)
        self.bytes_total = sum(f.size for f in files)
        self.bytes_skipped = sum(f.bytes_skipped for f in files)
        self.motors = channels[CHANNEL_MOTORS]
        self.pose = channels[CHANNEL_POSE]
        self.cmd = channels[CHANNEL_CMD]
        self.experiment = channels[CHANNEL_EXPERIMENT]
        self.state = channels[CHANNEL_STATE]
        seq = self.motors.seq if hasattr(self.motors, "seq") else np.zeros(0, np.int64)
        d = np.diff(seq)
        self.seq_gaps = int((d[d > 1] - 1).sum())
        self.seq_duplicates = int((d <= 0).sum())
        ut = self.motors.utime if hasattr(self.motors, "utime") else np.zeros(0, np.int64)
        self.seq_backwards = seq_backwards(seq, ut)

    @property
    def skipped(self):
        """Events on omni4 channels that were not decoded, by reason (all channels)."""
        out = {}
        for ch in self.channels.values():
            for k, v in ch.skipped.items():
                out[k] = out.get(k, 0) + v
        return out

    def summary(self):
        """A few lines: what was read, and everything skipped with its reason."""
        lines = [f"{len(self.files)} file(s), {self.bytes_total} bytes, {self.events} events"]
        for name, ch in self.channels.items():
            if len(ch) or any(ch.skipped.values()):
                bad = ", ".join(f"{v} {k}" for k, v in sorted(ch.skipped.items()) if v)
                lines.append(f"  {name}: {len(ch)}" + (f" (skipped: {bad})" if bad else ""))
        for name, n in sorted(self.unknown_counts.items()):
            cls = NAMED_RAW.get(name)
            what = f"{cls.__name__}, kept raw" if cls else "no omni4 type"
            lines.append(f"  {name}: {n} ({what})")
        if len(self.motors):
            lines.append(f"  motors_t seq gaps {self.seq_gaps}, duplicates {self.seq_duplicates}")
        for f in self.files:
            if f.bytes_skipped:
                lines.append(f"  {f.path}: {f.bytes_skipped} bytes skipped "
                             f"({f.tail_bytes} in a truncated tail)")
        return "\n".join(lines)

    def __repr__(self):
        return f"<Log {self.paths}: {self.events} events, motors {len(self.motors)}>"


# More motors_t samples than this going backwards in one log: two controllers' streams
# interleaved (docs/log-contract.md); read_log refuses the log, as omni4-ident does.
INTERLEAVED_BACKWARDS_MAX = 50


def seq_backwards(seq, utime):
    """motors_t samples (in log order) whose seq is at or below the previous one's; an exact
    repeat (same seq and utime: a duplicated datagram) is not counted."""
    seq = np.asarray(seq, np.int64)
    utime = np.asarray(utime, np.int64)
    ds, dt = np.diff(seq), np.diff(utime)
    return int(((ds < 0) | ((ds == 0) & (dt != 0))).sum())


def interleaved_error(where, n):
    """The one-line refusal of a log with n backward steps, or None below the threshold."""
    if n <= INTERLEAVED_BACKWARDS_MAX:
        return None
    return (f"{where}: OMNI4_MOTORS from two controllers interleaved ({n} samples whose seq goes "
            "backwards): record one controller per bus")


def split_parts(path):
    """The parts of a split log FILE.00, FILE.01, ... (what `omni4-record --split-mb` writes),
    in order, stopping at the first missing number; [] if FILE.00 does not exist."""
    parts = []
    while os.path.exists(f"{path}.{len(parts):02d}"):
        parts.append(f"{path}.{len(parts):02d}")
    return parts


def _resolve(path_or_paths):
    if isinstance(path_or_paths, (str, os.PathLike)):
        p = os.fspath(path_or_paths)
        if not os.path.exists(p) and split_parts(p):
            return split_parts(p)
        return [p]
    paths = [os.fspath(p) for p in path_or_paths]
    if not paths:
        raise LogError("read_log: no log given")
    return paths


def _load(paths):
    """All files into one uint8 buffer; returns it and each file's [start, end) in it."""
    sizes = []
    for p in paths:
        if os.path.isdir(p):
            raise IsADirectoryError(f"{p}: is a directory, not an event log")
        sizes.append(os.path.getsize(p))  # FileNotFoundError names the path
    buf = np.empty(sum(sizes), np.uint8)
    spans, at = [], 0
    for p, size in zip(paths, sizes):
        with open(p, "rb") as f:
            got = f.readinto(memoryview(buf)[at:at + size]) or 0
        spans.append((at, at + got))  # a file that shrank while read: what was there
        at += size
    return buf, spans


def _sync_positions(buf, lo, hi):
    """Offsets (relative to lo) of every 4-byte big-endian sync word in buf[lo:hi]."""
    seg = buf[lo:hi]
    if len(seg) < 4:
        return np.zeros(0, np.int64)
    first = np.flatnonzero(seg[:-3] == (SYNC >> 24))
    sync = SYNC.to_bytes(4, "big")
    hit = (seg[first + 1] == sync[1]) & (seg[first + 2] == sync[2]) & (seg[first + 3] == sync[3])
    return first[hit].astype(np.int64)


_LIB = []  # [the ctypes library of _logwalk.c, or None where it is not built]


def _walk_lib():
    """omni4_log_walk of the package's _omni4log library (python/setup.py builds it), or None."""
    if not _LIB:
        here = os.path.dirname(os.path.abspath(__file__))
        found = sorted(glob.glob(os.path.join(here, "_omni4log*.so")))
        L = None
        if found:
            L = ctypes.CDLL(found[0])
            L.omni4_log_walk.restype = ctypes.c_size_t
            L.omni4_log_walk.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int64,
                                         ctypes.c_size_t] + [ctypes.c_void_p] * 6
            L.omni4_log_gather.restype = None
            L.omni4_log_gather.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p,
                                           ctypes.c_size_t, ctypes.c_void_p]
            L.omni4_log_channel_ids.restype = None
            L.omni4_log_channel_ids.argtypes = [ctypes.c_void_p, ctypes.c_size_t] + \
                [ctypes.c_void_p] * 5 + [ctypes.c_size_t, ctypes.c_void_p]
        _LIB.append(L)
    return _LIB[0]


def _walk(buf, lo, hi):
    """The intact events of one file buf[lo:hi] (see _walk_numpy), with _logwalk.c's one pass
    from event to event; _walk_numpy where the library is not built. Same results."""
    L = _walk_lib()
    if L is None:
        return _walk_numpy(buf, lo, hi)
    seg = buf[lo:hi]
    cap = (hi - lo) // (HEADER_BYTES + 1) + 1  # no event is shorter than 29 bytes
    out = np.empty((4, cap), np.int64)
    used, tail = ctypes.c_int64(), ctypes.c_int64()
    k = L.omni4_log_walk(seg.ctypes.data, hi - lo, MAX_CHANNEL_BYTES, cap,
                         *(out[i].ctypes.data for i in range(4)), ctypes.byref(used),
                         ctypes.byref(tail))
    off, clen, dlen, utime = (out[i, :k] for i in range(4))
    return off + lo, clen, dlen, utime, (hi - lo) - used.value, tail.value


def _walk_numpy(buf, lo, hi):
    """The intact events of one file buf[lo:hi], as logdata.cpp finds them: from the start,
    an event whose header is valid (sync, 0 < channel length <= 256, data length >= 0, the
    whole event inside the file) is taken and the walk continues after it; otherwise the walk
    moves to the next sync word. Returns absolute offsets, channel and data lengths, log times
    (all int64) and the bytes not inside a taken event (total, after the last one)."""
    n = hi - lo
    cand = _sync_positions(buf, lo, hi)
    cand = cand[cand + HEADER_BYTES <= n]
    empty = np.zeros(0, np.int64)
    if len(cand) == 0:
        return empty, empty, empty, empty, n, n
    hdr = sliding_window_view(buf[lo:hi], HEADER_BYTES)[cand].view(_HEADER).ravel()
    clen = hdr["clen"].astype(np.int64)
    dlen = hdr["dlen"].astype(np.int64)
    end = cand + HEADER_BYTES + clen + dlen
    valid = (clen > 0) & (clen <= MAX_CHANNEL_BYTES) & (dlen >= 0) & (end <= n)
    k = len(cand)
    idx = np.arange(k)
    # Next candidate the walk reaches from each one: after a valid event, the first sync word
    # at or after its end; after an invalid header, the next sync word.
    nxt = np.where(valid, np.searchsorted(cand, end, "left"), idx + 1)
    # Runs where nxt[i] == i + 1 are walked in one step; only breaks (a sync word inside a
    # payload, corrupt bytes) cost a Python iteration.
    breaks = np.flatnonzero(nxt != idx + 1)
    visited = np.zeros(k, bool)
    i = 0
    while i < k:
        j = np.searchsorted(breaks, i, "left")
        if j == len(breaks):
            visited[i:] = True
            break
        b = breaks[j]
        visited[i:b + 1] = True
        i = nxt[b]
    take = visited & valid
    off = cand[take]
    clen, dlen, end = clen[take], dlen[take], end[take]
    used = int((end - off).sum())
    tail = n - int(end[-1]) if len(end) else n
    return off + lo, clen, dlen, hdr["utime"][take].astype(np.int64), n - used, tail


def _known_ids(buf, off, clen, names):
    """Index into `names` of every event whose channel is one of them, else -1 (_logwalk.c's
    byte comparison; None where the library is not built)."""
    L = _walk_lib()
    if L is None:
        return None
    enc = [nm.encode() for nm in names]
    blob = np.frombuffer(b"".join(enc) or b"\0", np.uint8)
    nlen = np.array([len(b) for b in enc], np.int64)
    noff = np.concatenate([[0], np.cumsum(nlen)[:-1]]).astype(np.int64)
    off = np.ascontiguousarray(off, np.int64)
    clen = np.ascontiguousarray(clen, np.int64)
    ids = np.empty(len(off), np.int64)
    L.omni4_log_channel_ids(buf.ctypes.data, len(off), off.ctypes.data, clen.ctypes.data,
                            blob.ctypes.data, noff.ctypes.data, nlen.ctypes.data, len(names),
                            ids.ctypes.data)
    return ids


def _channel_ids(buf, off, clen, names):
    """Channel index of every event (into `names`, which grows with the unknown channels)."""
    known = _known_ids(buf, off, clen, names)
    if known is not None:  # only the other channels are left to name below
        ids = known
        todo = np.flatnonzero(ids < 0)
        sub = _channel_ids_numpy(buf, off[todo], clen[todo], names)
        ids[todo] = sub
        return ids
    return _channel_ids_numpy(buf, off, clen, names)


def _channel_ids_numpy(buf, off, clen, names):
    """_channel_ids with numpy alone: per channel length, the names compared as byte strings."""
    ids = np.full(len(off), -1, np.int64)
    index = {nm: i for i, nm in enumerate(names)}
    if len(off) == 0:
        return ids
    for L in np.flatnonzero(np.bincount(clen)):
        sel = np.flatnonzero(clen == L)
        raw = np.ascontiguousarray(sliding_window_view(buf, int(L))[off[sel] + HEADER_BYTES])
        as_bytes = raw.view(f"S{L}").ravel()  # (a name ending in NUL bytes compares short)
        rest = np.ones(len(sel), bool)
        for nm, i in index.items():
            b = nm.encode()
            if len(b) == L and not b.endswith(b"\0"):
                hit = as_bytes == b
                ids[sel[hit]] = i
                rest &= ~hit
        if rest.any():
            uniq, inv = np.unique(raw[rest].view(f"V{L}").ravel(), return_inverse=True)
            for u, raw_name in enumerate(uniq):
                nm = raw_name.tobytes().decode("utf-8", "replace")
                if nm not in index:
                    index[nm] = len(names)
                    names.append(nm)
                ids[sel[rest][inv.ravel() == u]] = index[nm]
    return ids


def _empty_fields(cls):
    if cls in _FAST:
        return _layout.empty_fields(cls)
    out = {}
    for name in cls.__slots__:
        v = getattr(cls(), name)
        if isinstance(v, (list, tuple)) and v and isinstance(v[0], (bool, int, float)):
            out[name] = np.zeros((0, len(v)), type(v[0]))  # fixed-size array of numbers
        elif isinstance(v, str):
            out[name] = np.zeros(0, str)
        elif isinstance(v, (bool, int, float)):
            out[name] = np.zeros(0, type(v))
        else:  # variable-length array, nested type, array of strings or of types
            out[name] = np.zeros(0, object)
    return out


def _column(vals, like):
    """vals as an array of `like`'s dtype and rank, or a 1-D object array when they do not fit
    one (ragged variable-length arrays, nested types)."""
    if like.dtype != object:
        try:
            arr = np.asarray(vals, dtype=str if like.dtype.kind == "U" else like.dtype)
            if arr.ndim == like.ndim:
                return arr
        except (TypeError, ValueError):
            pass
    out = np.empty(len(vals), object)
    for k, v in enumerate(vals):
        out[k] = v
    return out


def _gather(buf, doff, size):
    """The payloads at doff (each `size` bytes, inside buf) as a contiguous (len, size) array."""
    L = _walk_lib()
    if L is None:
        return np.ascontiguousarray(sliding_window_view(buf, size)[doff])
    doff = np.ascontiguousarray(doff, np.int64)
    rows = np.empty((len(doff), size), np.uint8)
    L.omni4_log_gather(buf.ctypes.data, len(doff), doff.ctypes.data, size, rows.ctypes.data)
    return rows


def _decode_fast(buf, cls, doff, dlen):
    """Fixed-size type: one gather of the payloads and a big-endian structured view."""
    dt = _FAST[cls]
    size_ok = dlen == dt.itemsize
    if not size_ok.any():  # also keeps a log shorter than one payload out of the window view
        return _empty_fields(cls), np.zeros(0, np.int64), {"wrong_size": len(dlen)}
    rows = _gather(buf, doff[size_ok], dt.itemsize)
    rec = rows.view(dt).ravel()
    fp_ok = rec["fingerprint"] == _layout.fingerprint(cls)
    if not fp_ok.all():  # (a boolean index copies every record: only when needed)
        rec = rec[fp_ok]
    fields = _layout.fields_of(rec)
    keep = np.flatnonzero(size_ok)[fp_ok]
    skipped = {"wrong_size": int((~size_ok).sum()), "wrong_fingerprint": int((~fp_ok).sum())}
    return fields, keep, skipped


def _decode_each(buf, cls, doff, dlen):
    """Any type: the lcm-gen decoder per message; the whole payload must be consumed."""
    fp = cls._get_packed_fingerprint()
    msgs, keep = [], []
    skipped = {"wrong_fingerprint": 0, "undecodable": 0}
    for k, (a, n) in enumerate(zip(doff.tolist(), dlen.tolist())):
        data = buf[a:a + n].tobytes()
        if data[:FINGERPRINT_BYTES] != fp:
            skipped["wrong_fingerprint"] += 1
            continue
        bio = io.BytesIO(data)
        bio.seek(FINGERPRINT_BYTES)
        try:
            m = cls._decode_one(bio)
        except Exception:  # lcm-gen decoders raise struct.error, ValueError, ...
            m = None
        if m is None or bio.tell() != n:
            skipped["undecodable"] += 1
            continue
        msgs.append(m)
        keep.append(k)
    fields = _empty_fields(cls)
    if msgs:
        for name in cls.__slots__:
            fields[name] = _column([getattr(m, name) for m in msgs], fields[name])
    return fields, np.asarray(keep, np.int64), skipped


def read_log(path_or_paths, keep_unknown=True):
    """Reads an LCM event log into numpy arrays (see the module docstring).

    path_or_paths: one log, a list of files read as one stream in the order given (the parts
    of a split log), or FILE when only FILE.00, FILE.01, ... exist. keep_unknown: keep the
    raw payloads of channels without an omni4 type (else only count them).

    Raises OSError (missing or unreadable file, with its path) and LogError when the files
    hold no intact event at all (empty, not an event log, or corrupt throughout), or two
    controllers' OMNI4_MOTORS interleaved (more than INTERLEAVED_BACKWARDS_MAX samples whose
    seq goes backwards)."""
    paths = _resolve(path_or_paths)
    buf, spans = _load(paths)
    parts, files = [], []
    for p, (lo, hi) in zip(paths, spans):
        off, clen, dlen, utime, skipped, tail = _walk(buf, lo, hi)
        files.append(FileStats(p, hi - lo, len(off), skipped, tail))
        parts.append((off, clen, dlen, utime))
    if not any(f.events for f in files):
        what = "empty" if not sum(f.size for f in files) else "no LCM sync word 0xEDA1DA01 " \
            "starts a valid event"
        raise LogError(f"{', '.join(paths)}: no intact LCM event ({what})")
    off, clen, dlen, utime = (np.concatenate(x) for x in zip(*parts))
    names = list(TYPES)
    ids = _channel_ids(buf, off, clen, names)
    doff = off + HEADER_BYTES + clen
    channels, unknown, unknown_counts = {}, {}, {}
    for i, name in enumerate(names):
        sel = np.flatnonzero(ids == i)
        cls = TYPES.get(name)
        if cls is None:
            unknown_counts[name] = len(sel)
            unknown[name] = ([(int(t), buf[a:a + n].tobytes()) for t, a, n in
                              zip(utime[sel], doff[sel], dlen[sel])] if keep_unknown else [])
            continue
        decode = _decode_fast if cls in _FAST else _decode_each
        fields, keep, skipped = decode(buf, cls, doff[sel], dlen[sel])
        channels[name] = Channel(name, cls, fields, utime[sel][keep], skipped)
    log = Log(files, channels, unknown, unknown_counts)
    err = interleaved_error(", ".join(paths), log.seq_backwards)
    if err:
        raise LogError(err)
    return log


class RawEvents:
    """The events of one event log in file order, as read_events gives them."""

    def __init__(self, path, size, events, offsets, skipped, tail, tail_is_event):
        self.path = path
        self.size = size                    # [bytes]
        self.events = events                # [(log time [us], channel str, payload bytes)]
        self.offsets = offsets              # file offset of each event's header
        self.skipped = skipped              # bytes outside every intact event
        self.tail = tail                    # of which after the last one
        self.tail_is_event = tail_is_event  # the tail starts a header (an event cut short)


def read_events(path):
    """Every intact event of one LCM event log, in file order, with the payloads as bytes (the
    same walk as read_log: corrupt bytes are skipped to the next sync word and counted; a
    channel name that is not UTF-8 makes its event corrupt). Raises OSError for a missing or
    unreadable file."""
    p = os.fspath(path)
    if os.path.isdir(p):
        raise IsADirectoryError(f"{p}: is a directory, not an event log")
    buf, [(lo, hi)] = _load([p])
    off, clen, dlen, utime, skipped, tail = _walk(buf, lo, hi)
    events, offsets = [], []
    for a, c, d, t in zip(off.tolist(), clen.tolist(), dlen.tolist(), utime.tolist()):
        try:
            ch = buf[a + HEADER_BYTES:a + HEADER_BYTES + c].tobytes().decode("utf-8")
        except UnicodeDecodeError:
            skipped += HEADER_BYTES + c + d
            continue
        start = a + HEADER_BYTES + c
        events.append((t, ch, buf[start:start + d].tobytes()))
        offsets.append(a - lo)
    sync = SYNC.to_bytes(4, "big")
    head = buf[hi - tail:min(hi, hi - tail + 4)].tobytes() if tail else b""
    return RawEvents(p, hi - lo, events, offsets, skipped, tail,
                     bool(tail) and sync.startswith(head))


__all__ = ["read_log", "read_events", "RawEvents", "split_parts", "Log", "Channel", "FileStats", "LogError", "SYNC",
           "HEADER_BYTES"]
