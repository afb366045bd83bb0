"""omni4-mcap: LCM event logs -> one MCAP file for Foxglove (and any MCAP reader).

Every LCM event becomes one MCAP message with the event's log time, on a channel named as the
LCM channel (JSON, schema "omni4.<type>"), plus the derived topics of the bridge
(/omni4/velocity: encoders, model prediction, difference, of the same layout as the scene;
/omni4/health; /tf, /omni4/pose,
/omni4/scene with Foxglove's schemas; the scene draws the wheels of the log's first OMNI4_ROBOT,
a later robot_t with another layout from its event on; in a log without one the layout of
--params' [model], else the paper's four). Chunked and compressed (zstd by default, or lz4) by the
foxglove-sdk MCAP writer. Exit status: 0 done; 1 run-time error (unreadable or non-LCM log, or
data lost in a truncated/corrupt log: the complete events are still converted, see
--partial-ok); 2 usage or configuration error (bad arguments, broken INI)."""
import argparse
import heapq
import os
import sys
import time

import numpy as np

import omni4
from omni4 import _layout
from omni4.outfile import OutError, OutFile

from . import lcmlog, model, topics
from .model import Predictor
from ..wheels import Wheels

PROG = "omni4-mcap"

class Usage(Exception):
    pass


def decode_motors(payloads):
    """List of motors_t payloads -> dict of numpy arrays (utime, seq, mode, faults: (n,);
    voltage, current, wheel_speed: (n, 4) float32)."""
    dt = _layout.wire_dtype(omni4.motors_t)
    if payloads and set(map(len, payloads)) == {dt.itemsize}:
        rec = np.frombuffer(b"".join(payloads), dtype=dt)
        if (rec["fingerprint"] == _layout.fingerprint(omni4.motors_t)).all():
            return _layout.fields_of(rec)
    # anything else: the generated decoder, message by message (raises on a bad payload)
    return _layout.fields_of_messages(omni4.motors_t,
                                      [omni4.motors_t.decode(p) for p in payloads])


def parse_args(argv):
    ap = argparse.ArgumentParser(
        prog=PROG, description="Convert omni4 LCM event logs to one MCAP file for Foxglove: "
        "every event with its log time, one channel per LCM channel, plus the encoder "
        "velocity, the model's prediction, their difference, health, pose and the robot's "
        "3D scene.")
    ap.add_argument("logs", nargs="+", metavar="LOG", help="LCM event log(s): the parts of a "
                    "split recording, or recordings of the same run from several machines "
                    "(merged by log time when out of order or overlapping)")
    ap.add_argument("--out", required=True, metavar="OUT.mcap", help="MCAP file to write "
                    "(a file is replaced through a temporary beside it; a symbolic link's "
                    "target is replaced, the link kept; a FIFO or device gets the finished "
                    "file; a directory is refused)")
    ap.add_argument("--params", metavar="ROBOT.ini", help="robot INI whose [model] the "
                    "prediction runs, on its wheel layout when no robot_t describes one "
                    "(default: the paper's Table III and four wheels)")
    ap.add_argument("--compression", choices=("zstd", "lz4"), default="zstd",
                    help="chunk compression (default zstd)")
    ap.add_argument("--chunk-kib", type=int, default=1024, metavar="KiB",
                    help="uncompressed chunk size [KiB] (default 1024)")
    ap.add_argument("--health-period", type=float, default=1.0, metavar="S",
                    help="health window [s of log time] (default 1)")
    ap.add_argument("--partial-ok", action="store_true", help="exit 0 when a truncated or "
                    "corrupt log lost data (the loss is still reported)")
    ap.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    a = ap.parse_args(argv)
    if a.chunk_kib <= 0 or not a.health_period > 0:
        ap.error("--chunk-kib and --health-period must be positive")
    return a


class Writer(topics.Channels):
    """The channels of one MCAP file (foxglove-sdk's writer), made as topics appear."""

    def __init__(self, path, compression, chunk_bytes):
        import foxglove
        from foxglove.mcap import MCAPCompression, MCAPWriteOptions
        super().__init__(foxglove.Context())
        comp = MCAPCompression.Zstd if compression == "zstd" else MCAPCompression.Lz4
        # Compression in this thread at zstd level 1: the SDK's default (level 3 on a thread
        # pool) took 2x the CPU, and 20x the wall time on a busy 2-core machine.
        self.mcap = foxglove.open_mcap(path, allow_overwrite=True, context=self.ctx,
                                       writer_options=MCAPWriteOptions(
                                           compression=comp, chunk_size=chunk_bytes,
                                           compression_level=1, compression_threads=0,
                                           profile=""))

    def close(self):
        self.mcap.close()


def motors_events(events):
    """(per event: is it a motors_t on OMNI4_MOTORS, the arrays of those, in order). motors_t
    is fixed-size: a payload of another size or fingerprint is not one (it goes through
    topics.event_messages, to OMNI4_MOTORS/undecodable)."""
    fp = omni4.motors_t._get_packed_fingerprint()
    size = _layout.wire_dtype(omni4.motors_t).itemsize
    is_mot = [ch == omni4.CHANNEL_MOTORS and len(d) == size and d[:8] == fp
              for _, ch, d in events]
    return is_mot, decode_motors([d for (_, _, d), m in zip(events, is_mot) if m])


def robot_wheels(data):
    """The Wheels of a robot_t payload, or None (not one, or it describes no robot: not 3 or 4
    wheels, a value not finite or not positive, or a layout that does not drive v, vn, w)."""
    try:
        wheels = Wheels.from_robot(omni4.robot_t.decode(data))[0]
    except Exception:  # another type's payload
        return None
    return wheels if wheels is not None and model.layout_drives(wheels) else None


def predict(events, is_mot, mot, params, wheels):
    """The encoder velocity and the prediction of every motors sample (arrays of n x 3, n x 3,
    n): the layout wheels (the first robot_t's, else --params', else the paper's) from the
    start, each later robot_t of another layout from its event on (the prediction restarts
    there)."""
    starts, layouts, k = [0], [wheels], 0
    for (_t, ch, data), m in zip(events, is_mot):
        if m:
            k += 1
        elif ch == omni4.CHANNEL_ROBOT:
            new = robot_wheels(data)
            if new is not None and not model.same_layout(new, layouts[-1]):
                starts.append(k)
                layouts.append(new)
    out = [np.empty((len(mot["utime"]), 3)), np.empty((len(mot["utime"]), 3)),
           np.empty(len(mot["utime"]), dtype=bool)]
    for a, b, lay in zip(starts, starts[1:] + [len(mot["utime"])], layouts):
        part = Predictor(params, wheels=lay).run(*(mot[f][a:b] for f in (
            "utime", "seq", "mode", "voltage", "wheel_speed")))
        for whole, piece in zip(out, part):
            whole[a:b] = piece
    return out


def first_wheels(events):
    """The wheels of the log's first robot_t that describes a robot; None: the paper's."""
    for _t, ch, data in events:
        if ch == omni4.CHANNEL_ROBOT:
            wheels = robot_wheels(data)
            if wheels is not None:
                return wheels
    return None


def changed(data, wheels):
    """True when the robot_t payload describes a robot other than wheels."""
    new = robot_wheels(data)
    return new is not None and not new.same(wheels)


def convert(events, params, w, health_period_s):
    """Write all events (log order) and the derived topics into the Writer w."""
    classes = topics.lcm_classes()
    is_mot, mot = motors_events(events)
    any_mot = len(mot["utime"]) > 0
    first = first_wheels(events) or params.get("layout")
    meas, predicted, restarted = predict(events, is_mot, mot, params, first)
    pairs = zip(topics.motors_json_blocks(mot),
                topics.velocity_json_blocks(mot, meas, predicted, restarted))
    ch_mot = w.get(omni4.CHANNEL_MOTORS, "omni4.motors_t") if any_mot else None
    ch_vel = w.get(topics.TOPIC_VELOCITY, "omni4.velocity") if any_mot else None
    health = topics.Health()
    period_us = int(health_period_s * 1e6)
    next_health = events[0][0] + period_us
    next_scene, wheels = events[0][0], first
    k = 0
    n = len(events)
    i = 0
    log_m = ch_mot.log if ch_mot else None
    log_v = ch_vel.log if ch_vel else None
    add = health.add
    ut_l, sq_l, md_l, fl_l = (mot[f].tolist() for f in ("utime", "seq", "mode", "faults"))
    while i < n:
        t_us, chname, data = events[i]
        if t_us >= next_scene:  # the robot's body, once a second of log time
            w.log(topics.TOPIC_SCENE, "foxglove.SceneUpdate",
                  topics.scene_json(t_us * 1000, params["d"], params["r"], wheels), t_us * 1000)
            next_scene = t_us + 1_000_000
        if is_mot[i]:
            # a run of motors events (~40 between two camera frames): a tight loop
            while True:
                t_ns = t_us * 1000
                mj, vj = next(pairs)
                log_m(mj, t_ns)
                log_v(vj, t_ns)
                add(ut_l[k], sq_l[k], md_l[k], fl_l[k])
                if t_us >= next_health:
                    w.log(topics.TOPIC_HEALTH, "omni4.health", health.report(health_period_s),
                          t_ns)
                    next_health += period_us * max(1, (t_us - next_health) // period_us + 1)
                k += 1
                i += 1
                if i == n:
                    break
                t_us = events[i][0]
                if not is_mot[i] or t_us >= next_scene:
                    break
            continue
        i += 1
        if chname == omni4.CHANNEL_ROBOT and changed(data, wheels):  # drawn at once
            wheels, next_scene = robot_wheels(data), t_us
        for topic, schema, msg in topics.event_messages(chname, data, t_us * 1000, classes):
            w.log(topic, schema, msg, t_us * 1000)
    if any_mot:
        w.counts[omni4.CHANNEL_MOTORS] = w.counts[topics.TOPIC_VELOCITY] = k
        if health.n:  # the last, partial window
            w.log(topics.TOPIC_HEALTH, "omni4.health", health.report(health_period_s),
                  events[-1][0] * 1000)
    return health


def merge_parts(parts, quiet):
    """The events of several logs in one time order. Parts given in order and not overlapping
    are joined as they are; otherwise they are merged by log time (a stable merge: each file's
    own order is kept, a tie goes to the file named first)."""
    if all(a[-1][0] <= b[0][0] for a, b in zip(parts, parts[1:])):
        return [e for p in parts for e in p]
    if not quiet:
        print(f"{PROG}: the logs are out of order or overlap in time: merged by log time",
              file=sys.stderr)
    return list(heapq.merge(*parts, key=lambda e: e[0]))


def write_mcap(out, events, params, a):
    """The MCAP into out as every output is written (omni4.outfile: a file through a temporary
    and a rename, a symbolic link's target, a FIFO or device in place). The MCAP writer seeks:
    for a FIFO or device the file is made in an unnamed temporary file first, then copied in.
    Returns the Writer (counts, size); raises OutError or what the conversion raised."""
    import shutil
    import tempfile
    out = OutFile(out, binary=True)
    try:
        sink = tempfile.TemporaryFile() if out.in_place else out.file
        w = Writer(sink, a.compression, a.chunk_kib * 1024)
        try:
            convert(events, params, w, a.health_period)
        finally:
            w.close()
        w.size = sink.seek(0, os.SEEK_END)
        if out.in_place:
            sink.seek(0)
            shutil.copyfileobj(sink, out.file)
            sink.close()
    except OSError as e:  # writing the output (the logs were read before)
        out.abort()
        raise OutError(out.path, e) from None
    except BaseException:
        out.abort()
        raise
    out.commit()
    return w


def main(argv=None):
    a = parse_args(sys.argv[1:] if argv is None else argv)
    params = model.params_or_exit(PROG, a.params)
    t0 = time.perf_counter()
    parts, lost = [], []
    try:
        for path in a.logs:
            if not a.quiet:
                print(f"{PROG}: reading {path} ({lcmlog.file_size_mb(path):.1f} MB)",
                      file=sys.stderr)
            ev, st = lcmlog.read_events(path)
            parts.append(ev)
            if st.lost():
                lost.append(f"{path}: {st.lost()}")
    except lcmlog.LogError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 1
    events = merge_parts(parts, a.quiet)
    out_dir = os.path.dirname(os.path.realpath(a.out))
    if not os.path.isdir(out_dir):
        print(f"{PROG}: {a.out}: directory {out_dir} does not exist", file=sys.stderr)
        return 1                   # an output path that cannot be written: a run-time error
    try:
        w = write_mcap(a.out, events, params, a)
    except OutError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 1
    except Exception as e:  # a decoder or the writer refused: one line, no partial OUT
        print(f"{PROG}: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    dt = time.perf_counter() - t0
    n_lcm = len(events)
    if not a.quiet:
        per = ", ".join(f"{t} {n}" for t, n in sorted(w.counts.items()))
        span = (events[-1][0] - events[0][0]) * 1e-6
        print(f"{PROG}: {n_lcm} LCM events ({span:.1f} s of log) -> {a.out} "
              f"({w.size / 1e6:.1f} MB, {a.compression}) in {dt:.2f} s: {per}",
              file=sys.stderr)
    for line in lost:
        print(f"{PROG}: {line}; the {n_lcm} complete events were converted", file=sys.stderr)
    if lost and not a.partial_ok:
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
