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
every parameter at start), else from --params ROBOT.ini, else Table III."""
import heapq
import os
import sys

from .. import command_t, param_changed_t
from . import core

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


class _Rec:
    """Attribute access for one motors_t row of the log's arrays."""
    __slots__ = ("utime", "seq", "mode", "faults", "wheel_speed", "current")


def _geometry(log, params_path):
    geo = dict(core.TABLE_III)
    if params_path:
        from .. import ini
        cfg = ini.read(params_path)
        for k in geo:
            sec, key = k.split(".")
            try:
                geo[k] = float(cfg.section(sec)[key])
            except (KeyError, TypeError, ValueError):
                pass
    for _t, data in log.unknown.get("OMNI4_PARAM_CHANGED", ()):
        try:
            m = param_changed_t.decode(bytes(data))
        except Exception:
            continue
        for k, v in zip(m.keys, m.values):
            if k in geo:
                geo[k] = float(v)
        break
    return geo


def convert(paths, out, params_path=None):
    """Writes the bag; returns {topic: messages written}."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from .. import read_log

    ts = get_typestore(getattr(Stores, TYPESTORE))
    T = ts.types
    Time = T["builtin_interfaces/msg/Time"]
    Header = T["std_msgs/msg/Header"]
    Vec3 = T["geometry_msgs/msg/Vector3"]
    Point = T["geometry_msgs/msg/Point"]
    Quat = T["geometry_msgs/msg/Quaternion"]
    Pose = T["geometry_msgs/msg/Pose"]
    Twist = T["geometry_msgs/msg/Twist"]
    import numpy as np

    log = read_log(paths)
    geo = _geometry(log, params_path)
    odom = core.WheelOdometry(geo)
    window = core.MotorsWindow()
    gate = core.CmdGate()       # the diagnostics' layout; a log has no /cmd_vel gate
    window_start = None
    counts = {t: 0 for t in TOPICS}

    def stamp(us):
        us = int(us)
        return Time(sec=us // 1000000, nanosec=(us % 1000000) * 1000)

    def header(us, frame):
        return Header(stamp=stamp(us), frame_id=frame)

    def quat(th):
        q = core.yaw_quaternion(th)
        return Quat(x=q[0], y=q[1], z=q[2], w=q[3])

    # Per source, in log order: (log time [us], topic, message); merged by time, each source
    # keeping its own order (a logger's receive times may step back a little).
    motors_ev, cmd_ev, pose_ev = [], [], []
    mo = log.motors
    for i in range(len(mo)):
        m = _Rec()
        m.utime, m.seq = int(mo.utime[i]), int(mo.seq[i])
        m.mode, m.faults = int(mo.mode[i]), int(mo.faults[i])
        m.wheel_speed, m.current = mo.wheel_speed[i], mo.current[i]
        odom.step(m)
        t_us = int(mo.event_utime[i])
        h = header(t_us, "")
        js = T["sensor_msgs/msg/JointState"](
            header=h, name=list(core.JOINT_NAMES),
            position=np.array(odom.wheel_pos, dtype=np.float64),
            velocity=np.array(odom.wheel_vel, dtype=np.float64),
            effort=np.array(odom.effort, dtype=np.float64))
        pose = Pose(position=Point(x=odom.x, y=odom.y, z=0.0), orientation=quat(odom.theta))
        v = odom.vel
        od = T["nav_msgs/msg/Odometry"](
            header=header(t_us, "odom"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=pose, covariance=np.array(odom.pose_covariance(), dtype=np.float64)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=Twist(linear=Vec3(x=v[0], y=v[1], z=0.0), angular=Vec3(x=0.0, y=0.0, z=v[2])),
                covariance=np.array(odom.twist_covariance(), dtype=np.float64)))
        tf = T["tf2_msgs/msg/TFMessage"](transforms=[T["geometry_msgs/msg/TransformStamped"](
            header=header(t_us, "odom"), child_frame_id="base_link",
            transform=T["geometry_msgs/msg/Transform"](
                translation=Vec3(x=odom.x, y=odom.y, z=0.0), rotation=quat(odom.theta)))])
        motors_ev += [(t_us, "/joint_states", js), (t_us, "/odom", od), (t_us, "/tf", tf)]
        # /diagnostics: once per second of log time, over that second's samples
        if window.first is not None and t_us - window_start >= 1000000:
            motors_ev.append((t_us, "/diagnostics", _diag(T, header(t_us, ""), window, gate, geo)))
            window.reset()
        if window.first is None:
            window_start = t_us
        window.take(m)
    cmd = log.cmd
    for i in range(len(cmd)):
        if int(cmd.mode[i]) != command_t.MODE_VELOCITY:
            continue
        vel = cmd.velocity[i]
        cmd_ev.append((int(cmd.event_utime[i]), "/cmd_vel", Twist(
            linear=Vec3(x=float(vel[0]), y=float(vel[1]), z=0.0),
            angular=Vec3(x=0.0, y=0.0, z=float(vel[2])))))
    po = log.pose
    for i in range(len(po)):
        t_us = int(po.event_utime[i])
        pose_ev.append((t_us, "/camera/pose", T["geometry_msgs/msg/PoseStamped"](
            header=header(t_us, "world"),
            pose=Pose(position=Point(x=float(po.x[i]), y=float(po.y[i]), z=0.0),
                      orientation=quat(float(po.theta[i]))))))
    events = heapq.merge(motors_ev, cmd_ev, pose_ev, key=lambda e: e[0])

    writer = Writer(out, version=9, storage_plugin=StoragePlugin.MCAP)
    with writer:
        conns = {t: writer.add_connection(t, typ, typestore=ts) for t, typ in TOPICS.items()}
        for t_us, topic, msg in events:
            writer.write(conns[topic], t_us * 1000, ts.serialize_cdr(msg, TOPICS[topic]))
            counts[topic] += 1
    return counts


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


def _main(argv=None):
    import argparse

    from .._cli import ArgumentParser, usage
    p = ArgumentParser(prog=PROG, description="omni4 LCM event logs -> a ROS 2 bag (MCAP) with "
                       "standard types.", epilog=__doc__.split("\n", 2)[2],
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("logs", nargs="+", metavar="LOG", help="LCM event logs (parts of one log "
                   "in order)")
    p.add_argument("--out", required=True, metavar="DIR", help="the bag to write (a new folder)")
    p.add_argument("--params", default=None, metavar="ROBOT.ini",
                   help="geometry when the log has no OMNI4_PARAM_CHANGED")
    args = p.parse_args(argv)
    if os.path.exists(args.out):
        return usage(PROG, f"{args.out}: exists (the bag is written into a new folder)")
    try:
        import rosbags  # noqa: F401
    except ImportError as e:
        sys.stderr.write(f"{PROG}: needs rosbags ({e}): pip install './python[ros]'\n")
        return 2
    from .. import LogError, ini
    try:
        counts = convert(args.logs if len(args.logs) > 1 else args.logs[0], args.out,
                         args.params)
    except (LogError, OSError, ini.ConfigError) as e:
        sys.stderr.write(f"{PROG}: {e}\n")
        return 1
    print(f"{args.out}: " + ", ".join(f"{t} {n}" for t, n in counts.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
