"""LCM event logs (lcm/eventlog.h), event by event in file order, for omni4-mcap: omni4.log's
event walk, with what was lost said in one line.

An invalid header skips to the next sync word (the bytes are counted); an event cut by the end
of the file is not returned and its bytes are counted as truncated. Nothing is dropped
silently."""
import os

import numpy as np

from .. import CHANNEL_MOTORS, _layout, motors_t
from ..log import HEADER_BYTES, SYNC, interleaved_error, read_events as _read_raw, seq_backwards

SYNC_BYTES = SYNC.to_bytes(4, "big")


class LogError(Exception):
    pass


class LogStats:
    def __init__(self, path, size):
        self.path = path
        self.size = size            # [bytes]
        self.events = 0
        self.skipped_bytes = 0      # between intact events (corrupt or foreign bytes)
        self.truncated_bytes = 0    # an incomplete last event
        self.resyncs = 0

    def lost(self):
        """One line on what was not converted, or "" if nothing."""
        parts = []
        if self.truncated_bytes:
            parts.append(f"truncated: the last {self.truncated_bytes} bytes are an incomplete "
                         "event")
        if self.skipped_bytes:
            parts.append(f"{self.skipped_bytes} corrupt bytes skipped at {self.resyncs} "
                         "place(s)")
        return "; ".join(parts)


def read_events(path):
    """(events, stats): events is a list of (log_time_us, channel str, payload bytes), read by
    omni4.log's event walk (the one read_log uses)."""
    try:
        raw = _read_raw(path)
    except IsADirectoryError:
        raise LogError(f"{path}: is a directory") from None
    except OSError as e:
        raise LogError(f"{path}: {e.strerror or e}") from None
    st = LogStats(path, raw.size)
    st.truncated_bytes = raw.tail if raw.tail_is_event else 0
    st.skipped_bytes = raw.skipped - st.truncated_bytes
    # One resync per stretch of corrupt bytes: before an event that does not start where the
    # previous one ended, and a corrupt tail.
    at = 0
    for off, (_t, ch, data) in zip(raw.offsets, raw.events):
        st.resyncs += off > at
        at = off + HEADER_BYTES + len(ch.encode("utf-8")) + len(data)
    st.resyncs += bool(raw.tail) and not raw.tail_is_event
    st.events = len(raw.events)
    if not raw.events:
        what = "empty file" if raw.size == 0 else "no intact LCM event in the file"
        raise LogError(f"{path}: {what} (not an LCM event log?)")
    # Two controllers' OMNI4_MOTORS interleaved: refused as omni4.read_log refuses it, on the
    # payloads that are motors_t (its size and fingerprint), as read_log counts them.
    dt = _layout.wire_dtype(motors_t)
    fp = motors_t._get_packed_fingerprint()
    mot = [d for _t, ch, d in raw.events
           if ch == CHANNEL_MOTORS and len(d) == dt.itemsize and d.startswith(fp)]
    if len(mot) > 1:
        rec = np.frombuffer(b"".join(mot), dt)
        err = interleaved_error(path, seq_backwards(rec["seq"], rec["utime"]))
        if err:
            raise LogError(err)
    return raw.events, st


def file_size_mb(path):
    try:
        return os.path.getsize(path) / 1e6
    except OSError:
        return 0.0
