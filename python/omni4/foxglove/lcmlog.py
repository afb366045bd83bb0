"""LCM event logs (lcm/eventlog.h), event by event in file order, for omni4-mcap.

Per event a 28-byte big-endian header (sync word 0xEDA1DA01, event number int64, log time
int64 [us], channel length int32, data length int32), the channel name, the payload. An invalid
header skips to the next sync word (the bytes are counted); an event cut by the end of the file
is not returned and its bytes are counted as truncated. Nothing is dropped silently."""
import os
import struct

SYNC = 0xEDA1DA01
SYNC_BYTES = struct.pack(">I", SYNC)
HEADER = struct.Struct(">Iqqii")
MAX_CHANNEL = 256  # LCM's limit on a channel name
MAX_DATA = 1 << 30


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
    """(events, stats): events is a list of (log_time_us, channel str, payload bytes)."""
    try:
        with open(path, "rb") as fh:
            buf = fh.read()
    except IsADirectoryError:
        raise LogError(f"{path}: is a directory") from None
    except OSError as e:
        raise LogError(f"{path}: {e.strerror or e}") from None
    n = len(buf)
    st = LogStats(path, n)
    events = []
    pos = 0
    unpack = HEADER.unpack_from
    hsize = HEADER.size
    while pos < n:
        ok = False
        if pos + hsize <= n:
            sync, _num, t, clen, dlen = unpack(buf, pos)
            ok = sync == SYNC and 0 < clen <= MAX_CHANNEL and 0 <= dlen <= MAX_DATA
        elif buf[pos:pos + 4] == SYNC_BYTES[:min(4, n - pos)]:
            st.truncated_bytes += n - pos  # a header cut short by the end of the file
            break
        if ok:
            end = pos + hsize + clen + dlen
            if end > n:
                st.truncated_bytes += n - pos
                break
            try:
                ch = buf[pos + hsize:pos + hsize + clen].decode("utf-8")
            except UnicodeDecodeError:
                ok = False
            else:
                events.append((t, ch, buf[pos + hsize + clen:end]))
                pos = end
                continue
        nxt = buf.find(SYNC_BYTES, pos + 1)
        if nxt < 0:
            nxt = n
        st.skipped_bytes += nxt - pos
        st.resyncs += 1
        pos = nxt
    st.events = len(events)
    if not events:
        what = "empty file" if n == 0 else "no intact LCM event in the file"
        raise LogError(f"{path}: {what} (not an LCM event log?)")
    return events, st


def file_size_mb(path):
    try:
        return os.path.getsize(path) / 1e6
    except OSError:
        return 0.0
