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
            header=self.header(t_us, ""), name=list(core.JOINT_NAMES),
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


def _motors_events(msgs, log, geo):
    """/joint_states, /odom and /tf per motors sample, /diagnostics once per second of log time
    (over that second's samples): (log time [us], topic, message) in log order."""
    odom, window, gate = core.WheelOdometry(geo), core.MotorsWindow(), core.CmdGate()
    out, window_start, mo = [], None, log.motors
    for i in range(len(mo)):
        m = _Rec()
        m.utime, m.seq = int(mo.utime[i]), int(mo.seq[i])
        m.mode, m.faults = int(mo.mode[i]), int(mo.faults[i])
        m.wheel_speed, m.current = mo.wheel_speed[i], mo.current[i]
        odom.step(m)
        t_us = int(mo.event_utime[i])
        out += [(t_us, "/joint_states", msgs.joint_states(t_us, odom)),
                (t_us, "/odom", msgs.odometry(t_us, odom)), (t_us, "/tf", msgs.tf(t_us, odom))]
        if window.first is not None and t_us - window_start >= 1000000:
            out.append((t_us, "/diagnostics",
                        _diag(msgs.T, msgs.header(t_us, ""), window, gate, geo)))
            window.reset()
        if window.first is None:
            window_start = t_us
        window.take(m)
    return out


def _cmd_events(msgs, log):
    """/cmd_vel from each VELOCITY command."""
    cmd = log.cmd
    return [(int(cmd.event_utime[i]), "/cmd_vel", msgs.twist(*(float(x) for x in cmd.velocity[i])))
            for i in range(len(cmd)) if int(cmd.mode[i]) == command_t.MODE_VELOCITY]


def _pose_events(msgs, log):
    """/camera/pose (PoseStamped in world) from each camera pose."""
    po, out = log.pose, []
    for i in range(len(po)):
        t_us = int(po.event_utime[i])
        out.append((t_us, "/camera/pose", msgs.T["geometry_msgs/msg/PoseStamped"](
            header=msgs.header(t_us, "world"),
            pose=msgs.pose(float(po.x[i]), float(po.y[i]), float(po.theta[i])))))
    return out


def convert(paths, out, params_path=None):
    """Writes the bag; returns {topic: messages written}."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from .. import read_log

    ts = get_typestore(getattr(Stores, TYPESTORE))
    msgs = _Messages(ts)
    log = read_log(paths)
    geo = _geometry(log, params_path)
    # Per source in log order, merged by log time, each source keeping its own order (a
    # logger's receive times may step back a little).
    events = heapq.merge(_motors_events(msgs, log, geo), _cmd_events(msgs, log),
                         _pose_events(msgs, log), key=lambda e: e[0])
    counts = {t: 0 for t in TOPICS}
    with Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
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
