"""omni4-rosbag: omni4 LCM event logs -> one ROS 2 bag (MCAP storage) with standard types,
written with rosbags (pure Python; no ROS installation needed).

Per source event, in log order, bag time = the event's log time (the logger's receive time):
  OMNI4_MOTORS  -> /joint_states (sensor_msgs/JointState), /odom (nav_msgs/Odometry, wheel
                   odometry integrated as omni4-ros does), /tf (tf2_msgs/TFMessage, odom ->
                   base_link)
  OMNI4_CMD     -> /cmd_vel (geometry_msgs/Twist) for each VELOCITY command
  OMNI4_POSE    -> /camera/pose (geometry_msgs/PoseStamped, frame "world")
  each second of OMNI4_MOTORS log time -> /diagnostics (diagnostic_msgs/DiagnosticArray)
The geometry (d, r, l, Kt) comes from the log's OMNI4_PARAM_CHANGED (the controller announces
every parameter at start), else from --params ROBOT.ini, else Table III. The wheels (how many,
where; /joint_states' names) come from the log's first OMNI4_ROBOT (robot_t, within the log's
first ROBOT_SCAN_US of log time), else from --params' [model] (wheels, wheel_angle_j, d_j), else
the paper's four; a later robot_t with another layout is taken from its event on.
The logs are read a piece at a time and every message is written as its event is read, in log
order: memory does not grow with the log. The share of the input read goes to stderr (in place
on a terminal, else a line at most once a second; -q: none). The bag is written beside --out
and renamed to it once complete; exit status 0 done, 1 unreadable or not an event log, or an
--out that cannot be written (one that exists and is not an empty folder is refused, untouched;
a missing parent folder), 2 usage."""
import os
import shutil
import sys

from .. import (CHANNEL_CMD, CHANNEL_MOTORS, CHANNEL_POSE, CHANNEL_ROBOT, command_t, motors_t,
                param_changed_t, pose_t, robot_t)
from ..wheels import Wheels
from . import core

ROBOT_SCAN_US = 2_000_000     # robot_t comes at the controller's first tick, then at 1 Hz

PROG = "omni4-rosbag"
TYPESTORE = "ROS2_HUMBLE"     # the messages' definitions; the same in Jazzy and Kilted
TOPICS = {
    "/joint_states": "sensor_msgs/msg/JointState",
    "/odom": "nav_msgs/msg/Odometry",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/cmd_vel": "geometry_msgs/msg/Twist",
    "/camera/pose": "geometry_msgs/msg/PoseStamped",
    "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
}


def _geometry(paths, params_path):
    """d, r, l, Kt and each wheel's radius: Table III, then --params, then the log's first OMNI4_PARAM_CHANGED (found
    by reading the log up to it: the controller announces its parameters at start)."""
    geo = dict(core.TABLE_III)
    if params_path:
        from .. import ini
        cfg = ini.read(params_path)
        for k in core.GEOMETRY_KEYS:
            sec, key = k.split(".")
            try:
                geo[k] = float(cfg.section(sec)[key])
            except (KeyError, TypeError, ValueError):
                pass
    for path in paths:
        for _t, channel, data in _events(path, lambda n: None, set()):
            if channel != "OMNI4_PARAM_CHANGED":
                continue
            try:
                m = param_changed_t.decode(data)
            except Exception:
                continue
            for k, v in zip(m.keys, m.values):
                if k in core.GEOMETRY_KEYS:
                    geo[k] = float(v)
            return geo
    return geo


def _first_wheels(paths):
    """The wheels of the log's first robot_t (looked for in its first ROBOT_SCAN_US of log
    time), or None (a log before robot_t: the paper's layout)."""
    for path in paths:
        t0 = None
        for t_us, channel, data in _events(path, lambda n: None, set()):
            t0 = t_us if t0 is None else t0
            if t_us - t0 > ROBOT_SCAN_US:
                return None
            if channel == CHANNEL_ROBOT:
                try:
                    wheels, _why = Wheels.from_robot(robot_t.decode(data))
                except Exception:
                    continue
                if wheels is not None:
                    return wheels
    return None


class _Messages:
    """The ROS 2 messages of the bag, built with rosbags' type store."""

    def __init__(self, ts):
        self.T = ts.types

    def stamp(self, us):
        us = int(us)
        return self.T["builtin_interfaces/msg/Time"](sec=us // 1000000,
                                                     nanosec=(us % 1000000) * 1000)

    def header(self, us, frame):
        return self.T["std_msgs/msg/Header"](stamp=self.stamp(us), frame_id=frame)

    def vec3(self, x, y, z):
        return self.T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    def pose(self, x, y, th):
        q = core.yaw_quaternion(th)
        T = self.T
        return T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
            orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]))

    def twist(self, v, vn, w):
        return self.T["geometry_msgs/msg/Twist"](linear=self.vec3(v, vn, 0.0),
                                                 angular=self.vec3(0.0, 0.0, w))

    def joint_states(self, t_us, odom):
        import numpy as np
        return self.T["sensor_msgs/msg/JointState"](
            header=self.header(t_us, ""), name=list(odom.joint_names()),
            position=np.array(odom.wheel_pos, dtype=np.float64),
            velocity=np.array(odom.wheel_vel, dtype=np.float64),
            effort=np.array(odom.effort, dtype=np.float64))

    def odometry(self, t_us, odom):
        import numpy as np
        T, v = self.T, odom.vel
        return T["nav_msgs/msg/Odometry"](
            header=self.header(t_us, "odom"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=self.pose(odom.x, odom.y, odom.theta),
                covariance=np.array(odom.pose_covariance(), dtype=np.float64)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=self.twist(v[0], v[1], v[2]),
                covariance=np.array(odom.twist_covariance(), dtype=np.float64)))

    def tf(self, t_us, odom):
        T = self.T
        p = self.pose(odom.x, odom.y, odom.theta)
        return T["tf2_msgs/msg/TFMessage"](transforms=[T["geometry_msgs/msg/TransformStamped"](
            header=self.header(t_us, "odom"), child_frame_id="base_link",
            transform=T["geometry_msgs/msg/Transform"](
                translation=self.vec3(odom.x, odom.y, 0.0), rotation=p.orientation))])


class _Stream:
    """The bag's messages from the log's events, one event at a time, in log order: /joint_states,
    /odom and /tf per motors sample, /diagnostics once per second of log time (over that
    second's samples), /cmd_vel per VELOCITY command, /camera/pose per camera pose."""

    def __init__(self, msgs, geo):
        self.msgs, self.geo = msgs, geo
        self.odom, self.window, self.gate = core.WheelOdometry(geo), core.MotorsWindow(), \
            core.CmdGate()
        self.window_start = None
        self.last_seq = self.last_utime = None
        self.backwards = 0           # motors samples whose seq steps back (log.seq_backwards)
        self.undecodable = 0

    def motors(self, t_us, m):
        if self.last_seq is not None and (m.seq < self.last_seq or
                                          (m.seq == self.last_seq and m.utime != self.last_utime)):
            self.backwards += 1
        self.last_seq, self.last_utime = m.seq, m.utime
        msgs, odom, window = self.msgs, self.odom, self.window
        odom.step(m)
        yield "/joint_states", msgs.joint_states(t_us, odom)
        yield "/odom", msgs.odometry(t_us, odom)
        yield "/tf", msgs.tf(t_us, odom)
        if window.first is not None and t_us - self.window_start >= 1000000:
            yield "/diagnostics", _diag(msgs.T, msgs.header(t_us, ""), window, self.gate, self.geo)
            window.reset()
        if window.first is None:
            self.window_start = t_us
        window.take(m)

    def event(self, t_us, channel, data):
        """(topic, message) of one LCM event (none for other channels or a payload that does
        not decode, counted)."""
        cls = {CHANNEL_MOTORS: motors_t, CHANNEL_CMD: command_t, CHANNEL_POSE: pose_t,
               CHANNEL_ROBOT: robot_t}.get(channel)
        if cls is None:
            return ()
        try:
            m = cls.decode(data)
        except Exception:  # another type's fingerprint, a short payload
            self.undecodable += 1
            return ()
        if cls is motors_t:
            return self.motors(t_us, m)
        if cls is robot_t:          # a layout change mid-log: taken from here on
            self.odom.set_wheels(Wheels.from_robot(m)[0])
            return ()
        if cls is command_t:
            return (("/cmd_vel", self.msgs.twist(*(float(x) for x in m.velocity))),) \
                if m.mode == command_t.MODE_VELOCITY else ()
        return (("/camera/pose", self.msgs.T["geometry_msgs/msg/PoseStamped"](
            header=self.msgs.header(t_us, "world"),
            pose=self.msgs.pose(float(m.x), float(m.y), float(m.theta)))),)


def _events(path, progress, seen):
    """The intact events of one LCM event log, read a piece at a time (bounded memory), as
    omni4.log walks them: a valid header (sync word, 0 < channel length <= 256, data length
    >= 0, the whole event inside the file) is taken and the walk goes on after it; anything
    else moves to the next sync word. Yields (log time [us], channel, payload); progress(n)
    is told the bytes consumed so far. seen collects the file's "events" count."""
    import struct

    from ..log import HEADER_BYTES, MAX_CHANNEL_BYTES, SYNC
    sync = SYNC.to_bytes(4, "big")
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        buf, base, eof = bytearray(), 0, False   # base: file offset of buf[0]
        while not eof:
            piece = f.read(READ_BYTES)
            eof = not piece
            buf += piece
            i = 0
            while len(buf) - i >= HEADER_BYTES:
                if buf[i:i + 4] != sync:
                    j = buf.find(sync, i + 1)
                    i = j if j >= 0 else len(buf) - 3
                    continue
                _n, utime, clen, dlen = struct.unpack_from(">qqii", buf, i + 4)
                end = i + HEADER_BYTES + clen + dlen
                if not (0 < clen <= MAX_CHANNEL_BYTES and dlen >= 0 and base + end <= size):
                    i += 1                # not a header: on to the next sync word
                    continue
                if end > len(buf):
                    if eof:
                        i += 1            # the file shrank while read
                        continue
                    break                 # the rest of this event is in the next piece
                try:
                    channel = buf[i + HEADER_BYTES:i + HEADER_BYTES + clen].decode("utf-8")
                except UnicodeDecodeError:
                    i += 1
                    continue
                seen.add(1)
                yield utime, channel, bytes(buf[i + HEADER_BYTES + clen:end])
                i = end
            if eof:
                i = len(buf)
            del buf[:i]
            base += i
            progress(base)


READ_BYTES = 1 << 20


class _Progress:
    """The share of the input bytes read, on stderr: in place on a terminal, else a line at
    most once a second."""

    def __init__(self, sizes, quiet):
        import time
        self.total, self.done, self.quiet = max(1, sum(sizes)), 0, quiet
        self.tty = sys.stderr.isatty()
        self.clock = time.monotonic
        self.next = self.clock() + 1.0
        self.shown = False

    def __call__(self, file_bytes):
        now = self.clock()
        if self.quiet or now < self.next:
            return
        self.next = now + 1.0
        pct = 100.0 * (self.done + file_bytes) / self.total
        start, end = ("\r", "") if self.tty else ("", "\n")
        sys.stderr.write(f"{start}{PROG}: {pct:5.1f} % of the input read{end}")
        sys.stderr.flush()
        self.shown = True

    def file_done(self, size):
        self.done += size

    def end(self):
        if self.shown and self.tty:
            sys.stderr.write("\n")


def _log_paths(paths):
    """The files to read (FILE when only FILE.00, FILE.01, ... exist: those), each checked
    readable: LogError "cannot read LOG: reason" otherwise."""
    from ..log import LogError, split_parts
    out = []
    for p in ([paths] if isinstance(paths, (str, os.PathLike)) else paths):
        p = os.fspath(p)
        parts = split_parts(p) if not os.path.exists(p) else []
        for q in parts or [p]:
            try:
                with open(q, "rb"):
                    pass
            except OSError as e:
                raise LogError(f"cannot read {q}: {e.strerror or e}") from None
            out.append(q)
    return out


def convert(paths, out, params_path=None, quiet=True):
    """Writes the bag into the new folder out, message by message as the logs are read (bounded
    memory); returns {topic: messages written}. Raises LogError (an unreadable log, no intact
    event, two controllers interleaved) and OSError; the folder is then not left behind."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from ..log import LogError, interleaved_error

    paths = _log_paths(paths)
    ts = get_typestore(getattr(Stores, TYPESTORE))
    stream = _Stream(_Messages(ts), _geometry(paths, params_path))
    stream.odom.set_wheels(_first_wheels(paths) or
                           (Wheels.from_ini(params_path) if params_path else None))
    progress = _Progress([os.path.getsize(p) for p in paths], quiet)
    counts = {t: 0 for t in TOPICS}
    seen = _Count()
    with Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {t: writer.add_connection(t, typ, typestore=ts) for t, typ in TOPICS.items()}
        for path in paths:
            for t_us, channel, data in _events(path, progress, seen):
                for topic, msg in stream.event(t_us, channel, data):
                    writer.write(conns[topic], t_us * 1000, ts.serialize_cdr(msg, TOPICS[topic]))
                    counts[topic] += 1
            progress.file_done(os.path.getsize(path))
    progress.end()
    if not seen.n:
        raise LogError(f"{', '.join(paths)}: no intact LCM event (not an LCM event log?)")
    err = interleaved_error(", ".join(paths), stream.backwards)
    if err:
        raise LogError(err)
    return counts


class _Count:
    def __init__(self):
        self.n = 0

    def add(self, k):
        self.n += k


def _diag(T, header, window, gate, geo):
    Status = T["diagnostic_msgs/msg/DiagnosticStatus"]
    KV = T["diagnostic_msgs/msg/KeyValue"]
    rows = core.diagnostic_statuses(window, gate, {}, {k: repr(v) for k, v in geo.items()},
                                    "wheels (log)")
    return T["diagnostic_msgs/msg/DiagnosticArray"](header=header, status=[
        Status(level=lv, name=name, message=msg, hardware_id="omni4",
               values=[KV(key=k, value=v) for k, v in values])
        for lv, name, msg, values in rows])


def main(argv=None):
    from .._cli import run
    return run(PROG, _main, argv)


def _out_folder(out):
    """The folder the bag goes to (a symbolic link followed), and None or why it is refused
    (status 1): the bag is a new folder, or goes into an existing empty one; anything else is
    refused, untouched."""
    real = os.path.realpath(out)
    if not os.path.exists(real):
        return real, None
    if not os.path.isdir(real):
        return real, f"{out}: exists and is not a folder (the bag is a folder; nothing replaced)"
    if os.listdir(real):
        return real, f"{out}: exists and is not empty (the bag goes into a new or empty " \
            "folder; nothing there is touched)"
    return real, None


def _write_bag(logs, real, params, quiet):
    """The bag written beside real (in .NAME.tmpPID/NAME), synced, then renamed to real: a
    failure or an interrupt leaves no half bag, and removes only what it made."""
    parent, name = os.path.split(real)
    work = os.path.join(parent, f".{name}.tmp{os.getpid()}")
    os.mkdir(work)
    try:
        counts = convert(logs, os.path.join(work, name), params, quiet)
        for f in os.listdir(os.path.join(work, name)):
            with open(os.path.join(work, name, f), "rb") as fh:
                os.fsync(fh.fileno())
        os.rename(os.path.join(work, name), real)  # over an empty folder, or none
    finally:
        shutil.rmtree(work, ignore_errors=True)
    fd = os.open(parent or ".", os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    return counts


def _main(argv=None):
    import argparse

    from .._cli import ArgumentParser
    p = ArgumentParser(prog=PROG, description="omni4 LCM event logs -> a ROS 2 bag (MCAP) with "
                       "standard types.", epilog=__doc__.split("\n", 2)[2],
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("logs", nargs="+", metavar="LOG", help="LCM event logs (parts of one log "
                   "in order)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="the bag to write: a new folder, or an existing empty one (a "
                   "symbolic link is followed); written beside it first, renamed when complete; "
                   "an existing file or non-empty folder is refused and left untouched")
    p.add_argument("--params", default=None, metavar="ROBOT.ini",
                   help="geometry when the log has no OMNI4_PARAM_CHANGED, the wheels' layout "
                   "when it has no OMNI4_ROBOT")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress (else the share of the input read, on stderr, at most "
                   "once a second)")
    args = p.parse_args(argv)
    real, refused = _out_folder(args.out)
    if refused:                    # an output path that cannot be written: a run-time error
        sys.stderr.write(f"{PROG}: {refused}\n")
        return 1
    try:
        import rosbags  # noqa: F401
    except ImportError as e:
        sys.stderr.write(f"{PROG}: needs rosbags ({e}): pip install './python[ros]'\n")
        return 2
    from .. import LogError, ini
    try:
        counts = _write_bag(args.logs, real, args.params, args.quiet)
    except ini.ConfigError as e:
        sys.stderr.write(f"{PROG}: {e}\n")
        return 2
    except LogError as e:
        sys.stderr.write(f"{PROG}: {e}\n")
        return 1
    except OSError as e:
        where = f"{e.filename}: " if e.filename else ""
        sys.stderr.write(f"{PROG}: {where}{e.strerror or e}\n")
        return 1
    print(f"{args.out}: " + ", ".join(f"{t} {n}" for t, n in counts.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
