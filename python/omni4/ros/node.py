"""omni4-ros: the robot on ROS 2, beside omni4-fw on its LCM URL (docs/ros.md).

Subscribes /cmd_vel (geometry_msgs/Twist in base_link: linear.x = v, linear.y = vn,
angular.z = w) and sends VELOCITY commands on OMNI4_CMD while the input is fresh; publishes
/odom (nav_msgs/Odometry, odom -> base_link), /joint_states (the robot's wheels: the layout of
the latest robot_t on OMNI4_ROBOT, else the paper's four), /diagnostics at
1 Hz, and /tf when the installation has tf2_msgs; mirrors the controller's parameters as ROS
parameters (set through omni4.ParamClient); services ~/clear_fault and ~/save (std_srvs/Trigger).
Goals: /goal_pose (RViz's 2D Goal Pose, once) and follow_path (nav_msgs/Path), kept alive on the
bus while the controller works on them; progress on goal_status and in /diagnostics (goals.py).
"""
import math
import os
import sys
import threading
import time

import lcm

from .. import (CHANNEL_ADAPT, CHANNEL_CMD, CHANNEL_MOTORS, CHANNEL_PARAM_CHANGED,
                CHANNEL_ROBOT, adapt_t, command_t, motors_t, param_changed_t, robot_t)
from ..wheels import Wheels
from . import core
from .goals import GoalBridge

PROG = "omni4-ros"
RX_QUEUE_MESSAGES = 10000      # LCM's receive queue for OMNI4_MOTORS: 10 s at 1 kHz
FRESH_S = 0.5                  # a /cmd_vel older than this is stale: the robot is stopped
KEEPALIVE_S = 0.05             # re-send period of the command in force (watchdog 200 ms)
STOP_HOLD_S = 0.5              # after going stale: zero velocity this long, then IDLE
PARAM_RETRY_S = 2.0            # no answer from the parameter service: try again after
EPILOG = """\
topics: /cmd_vel, /goal_pose, follow_path (in), /odom, /joint_states, goal_status,
/diagnostics (1 Hz), /tf (with tf2_msgs)
services: /omni4/clear_fault, /omni4/save (std_srvs/Trigger); parameters: the controller's keys
ROS options go after --ros-args (e.g. --ros-args -r __ns:=/robot1). Discovery: ROS_DOMAIN_ID,
ROS_AUTOMATIC_DISCOVERY_RANGE (docs/ros.md)."""


class Omni4Ros:
    """The node. url: omni4-fw's LCM URL; secret: its [params] secret (or None)."""

    def __init__(self, url, secret=None, rate_hz=50.0, fresh_s=FRESH_S, odom_source="auto",
                 frame_prefix="", stop_hold_s=STOP_HOLD_S):
        import rclpy
        from rclpy.node import Node

        self.url = url
        self.fresh_s = float(fresh_s)
        self.stop_hold_s = float(stop_hold_s)
        self.frame_odom = f"{frame_prefix}odom"
        self.frame_base = f"{frame_prefix}base_link"
        self.odom_source = odom_source
        self.node = Node("omni4")
        self.log = self.node.get_logger()
        # /diagnostics is one topic for every node: the statuses carry the node's name
        # ("omni4: controller"; under a namespace "robot1/omni4: controller").
        self._diag_prefix = self.node.get_fully_qualified_name().lstrip("/")
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._local = threading.local()          # guard: parameter updates from the robot
        self.odom = core.WheelOdometry()
        self.state = core.StateEstimate()
        self._state_arrival = None               # monotonic [s] of the last state_t
        self.window = core.MotorsWindow()
        self.gate = core.CmdGate()
        self.counters = {"commands sent": 0, "stale stops": 0, "state_t received": 0}
        self.model = {}
        self.adapt = core.AdaptWindow()
        self._declared = set()
        self._param_types = {}
        # Commands: (v, vn, w) in force and when the last /cmd_vel for it came.
        self._seq = 0
        self._cmd = None
        self._cmd_at = 0.0
        self._stopping_since = None

        self._open_lcm(url, secret, odom_source)
        self._open_ros(rate_hz)
        self._rclpy = rclpy
        self._threads = [threading.Thread(target=self._rx_loop, name="omni4-ros-lcm", daemon=True),
                         threading.Thread(target=self._keepalive_loop, name="omni4-ros-keepalive",
                                          daemon=True),
                         threading.Thread(target=self._param_loop, name="omni4-ros-params",
                                          daemon=True)]
        for t in self._threads:
            t.start()
        tf = "and /tf" if self._TF else "(no tf2_msgs here: /tf not published, see docs/ros.md)"
        self.log.info(f"on LCM {url}: /cmd_vel -> {CHANNEL_CMD}; /odom, /joint_states {tf}; "
                      f"odometry from {self._odom_source_name()}")

    def _open_lcm(self, url, secret, odom_source):
        """The robot's bus: motors_t, parameter notices, the estimate; the parameter client."""
        from ..params import ParamClient

        try:
            self.lc = lcm.LCM(url)
            self._lc_param = lcm.LCM(url)
        except (RuntimeError, OSError) as e:
            raise RuntimeError(f"cannot open LCM URL {url}: {e}") from None
        self.params = ParamClient(self._lc_param, secret=secret, timeout_s=0.5, retries=2)
        sub = self.lc.subscribe(CHANNEL_MOTORS, self._on_motors)
        sub.set_queue_capacity(RX_QUEUE_MESSAGES)
        self.lc.subscribe(CHANNEL_PARAM_CHANGED, self._on_param_changed)
        self.lc.subscribe(CHANNEL_ADAPT, self._on_adapt)
        self.lc.subscribe(CHANNEL_ROBOT, self._on_robot)
        self.state_cls, state_channel = core.state_type()
        if self.state_cls is not None and odom_source != "wheels":
            self.lc.subscribe(state_channel, self._on_state)


    def _open_ros(self, rate_hz):
        """Publishers, the /cmd_vel subscription, services, parameters and timers."""
        from rclpy.callback_groups import ReentrantCallbackGroup
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import JointState
        from std_srvs.srv import Trigger

        from builtin_interfaces.msg import Time
        self._Odometry, self._JointState, self._DiagnosticArray = Odometry, JointState, DiagnosticArray
        self._Time = Time
        try:   # a full ROS installation has tf2_msgs; the PyPI wheels do not (docs/ros.md)
            from tf2_msgs.msg import TFMessage
            from geometry_msgs.msg import TransformStamped
            self._TF = (TFMessage, TransformStamped)
        except ImportError:
            self._TF = None
        self.pub_odom = self.node.create_publisher(Odometry, "odom", 10)
        self.pub_joints = self.node.create_publisher(JointState, "joint_states", 10)
        self.pub_diag = self.node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.pub_tf = self.node.create_publisher(self._TF[0], "/tf", 100) if self._TF else None
        self.node.create_subscription(Twist, "cmd_vel", self._on_cmd_vel, 10)
        self.goals = GoalBridge(self, KEEPALIVE_S)   # /goal_pose, follow_path, goal_status
        group = ReentrantCallbackGroup()
        self.node.create_service(Trigger, "~/clear_fault", self._srv_clear_fault,
                                 callback_group=group)
        self.node.create_service(Trigger, "~/save", self._srv_save, callback_group=group)
        self.node.add_on_set_parameters_callback(self._on_set_parameters)
        self.node.create_timer(1.0 / rate_hz, self._publish_state)
        self.node.create_timer(1.0, self._publish_diagnostics, callback_group=group)

    # ---- LCM side ----------------------------------------------------------------------------
    def _rx_loop(self):
        while not self._closed.is_set():
            try:
                self.lc.handle_timeout(50)
            except OSError:
                if not self._closed.is_set():
                    time.sleep(0.05)

    def _on_motors(self, _channel, data):
        try:
            m = motors_t.decode(data)
        except ValueError:
            return
        with self._lock:
            self.odom.step(m)
            self.window.take(m)

    def _on_state(self, _channel, data):
        try:
            m = self.state_cls.decode(data)
        except ValueError:
            return
        with self._lock:
            if self.state.take(m):
                self._state_arrival = time.monotonic()
                self.counters["state_t received"] += 1

    def _on_robot(self, _channel, data):
        """The robot's layout: the latest robot_t's wheels (a change mid-stream is taken)."""
        try:
            wheels, why = Wheels.from_robot(robot_t.decode(data))
        except ValueError:
            return
        if wheels is None:
            self.log.warning(f"{CHANNEL_ROBOT} ignored: {why}", throttle_duration_sec=10.0)
            return
        with self._lock:
            self.odom.set_wheels(wheels)

    def _on_adapt(self, _channel, data):
        try:
            m = adapt_t.decode(data)
        except ValueError:
            return
        with self._lock:
            self.adapt.take(m)

    def _on_param_changed(self, _channel, data):
        try:
            m = param_changed_t.decode(data)
        except ValueError:
            return
        with self._lock:
            if self.adapt.events.take(m):       # an acceptance or revert: no parameter of ours
                return
        changed = dict(zip(m.keys, m.values))
        self._apply_robot_values(changed)
        from rclpy.parameter import Parameter
        updates = []
        for k, text in changed.items():
            if k in self._declared:
                updates.append(Parameter(k, value=self._typed(k, text)))
        if updates:
            self._local.from_robot = True
            try:
                self.node.set_parameters(updates)
            finally:
                self._local.from_robot = False

    def _apply_robot_values(self, values):
        """Geometry, limits and model from {key: text} of the controller."""
        with self._lock:
            for k, text in values.items():
                try:
                    x = float(text)
                except ValueError:
                    continue
                if k in core.GEOMETRY_KEYS:
                    self.odom.set_geometry(**{k: x})
                if k in core.LIMIT_KEYS:
                    self.gate.limits[k] = x
                if k.startswith("model."):
                    self.model[k] = text

    def _send(self, mode, velocity=(0.0, 0.0, 0.0)):
        msg = command_t()
        msg.mode = mode
        msg.velocity = list(velocity)
        msg.voltage = [0.0] * 4
        msg.ramp_s = 0.0
        with self._lock:
            self._seq += 1
            msg.seq = self._seq
            self.counters["commands sent"] += 1
        msg.utime = int(time.time() * 1e6)
        self.lc.publish(CHANNEL_CMD, msg.encode())

    def _keepalive_loop(self):
        while not self._closed.wait(KEEPALIVE_S):
            now = time.monotonic()
            with self._lock:
                cmd, at, stopping = self._cmd, self._cmd_at, self._stopping_since
                if cmd is not None and now - at > self.fresh_s:
                    self._cmd, cmd = None, None
                    self._stopping_since = stopping = now
                    self.counters["stale stops"] += 1
            if cmd is not None:
                self._send(command_t.MODE_VELOCITY, cmd)
            elif stopping is not None:
                if now - stopping < self.stop_hold_s:
                    self._send(command_t.MODE_VELOCITY, (0.0, 0.0, 0.0))
                else:
                    with self._lock:
                        self._stopping_since = None
                    self._send(command_t.MODE_IDLE)

    def _param_loop(self):
        """Reads every parameter once the controller answers; then declares them."""
        from ..params import ParamError
        while not self._closed.is_set():
            try:
                plist = self.params.list()
            except ParamError as e:
                self.log.warn(f"parameters: {e}; trying again in {PARAM_RETRY_S:g} s",
                              throttle_duration_sec=30.0)
                self._closed.wait(PARAM_RETRY_S)
                continue
            self._apply_robot_values({p.key: p.text for p in plist})
            self._declare(plist)
            return

    def _declare(self, plist):
        from rcl_interfaces.msg import ParameterDescriptor
        self._local.from_robot = True
        try:
            for p in plist:
                if p.key == "params.secret":
                    continue
                self._param_types[p.key] = p.type
                unit = f" [{p.unit}]" if p.unit else ""
                desc = ParameterDescriptor(
                    description=f"{p.doc}{unit} (change: {p.change}; set goes to omni4-fw)",
                    dynamic_typing=True)
                self.node.declare_parameter(p.key, p.value, desc)
                self._declared.add(p.key)
        finally:
            self._local.from_robot = False

    def _typed(self, key, text):
        from ..params import Param
        t = self._param_types.get(key, 3)
        return Param(key, text, "", t, 0.0, 0.0, "", "", "").value

    def _on_set_parameters(self, params):
        from rcl_interfaces.msg import SetParametersResult
        from ..params import ParamError, ParamRefused, format_value
        if getattr(self._local, "from_robot", False):
            return SetParametersResult(successful=True)
        mapping = {p.name: p.value for p in params if p.name in self._declared}
        if not mapping:
            return SetParametersResult(successful=True)
        for k, v in mapping.items():
            if v is None or isinstance(v, (list, tuple, bytes)):
                return SetParametersResult(successful=False,
                                           reason=f"{k}: a single value is needed")
        try:
            self.params.set({k: format_value(v) if not isinstance(v, str) else v
                             for k, v in mapping.items()})
        except ParamRefused as e:
            return SetParametersResult(successful=False, reason=str(e))
        except ParamError as e:
            return SetParametersResult(successful=False, reason=f"omni4-fw: {e}")
        self._apply_robot_values({k: format_value(v) for k, v in mapping.items()})
        return SetParametersResult(successful=True)

    # ---- ROS side ----------------------------------------------------------------------------
    def _on_cmd_vel(self, msg):
        with self._lock:
            cmd, line = self.gate.take(msg.linear.x, msg.linear.y, msg.angular.z)
        # Throttled per kind by the gate (rclpy's throttle is one per call site: a NaN stream
        # would hide every clamp).
        if line:
            self.log.warn(line)
        if cmd is None:
            return
        self.goals._forget_goal()                  # a /cmd_vel replaces the goal
        with self._lock:
            self._cmd = cmd
            self._cmd_at = time.monotonic()
            self._stopping_since = None
        self._send(command_t.MODE_VELOCITY, cmd)

    def _odom_source_name(self):
        if self.odom_source == "wheels" or self.state_cls is None:
            return "wheels"
        return "state_t (controller's estimate)" if self._use_state() else "wheels (no state_t yet)"

    def _use_state(self):
        return (self.odom_source != "wheels" and self._state_arrival is not None
                and time.monotonic() - self._state_arrival < 0.5)

    def _publish_state(self):
        with self._lock:
            if self.odom.samples == 0:
                return
            src = self.state if self._use_state() else self.odom
            # The measurement's time: the controller's clock (utime, epoch microseconds, the
            # system clock of the robot; docs/ros.md "Time").
            us = (src.utime if src is self.state and src.utime else self.odom.last_utime)
            stamp = self._Time(sec=int(us // 1000000), nanosec=int(us % 1000000) * 1000)
            x, y, th, vel = src.x, src.y, src.theta, src.vel
            pcov, tcov = src.pose_covariance(), src.twist_covariance()
            pos, wvel, eff = list(self.odom.wheel_pos), list(self.odom.wheel_vel), list(self.odom.effort)
            names = list(self.odom.joint_names())
        o = self._Odometry()
        o.header.stamp = stamp
        o.header.frame_id = self.frame_odom
        o.child_frame_id = self.frame_base
        o.pose.pose.position.x, o.pose.pose.position.y = x, y
        q = core.yaw_quaternion(th)
        o.pose.pose.orientation.x, o.pose.pose.orientation.y = q[0], q[1]
        o.pose.pose.orientation.z, o.pose.pose.orientation.w = q[2], q[3]
        o.pose.covariance = pcov
        o.twist.twist.linear.x, o.twist.twist.linear.y = vel[0], vel[1]
        o.twist.twist.angular.z = vel[2]
        o.twist.covariance = tcov
        self.pub_odom.publish(o)
        j = self._JointState()
        j.header.stamp = stamp
        j.name = names
        j.position, j.velocity, j.effort = pos, wvel, eff
        self.pub_joints.publish(j)
        if self.pub_tf is not None:
            TFMessage, TransformStamped = self._TF
            t = TransformStamped()
            t.header = o.header
            t.child_frame_id = self.frame_base
            t.transform.translation.x, t.transform.translation.y = x, y
            t.transform.rotation = o.pose.pose.orientation
            self.pub_tf.publish(TFMessage(transforms=[t]))

    def _publish_diagnostics(self):
        from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
        with self._lock:
            rows = core.diagnostic_statuses(self.window, self.gate, dict(self.counters),
                                             dict(self.model), self._odom_source_name(),
                                             self._diag_prefix, self.adapt)
            self.window.reset()
            self.adapt.reset()
        a = self._DiagnosticArray()
        a.header.stamp = self.node.get_clock().now().to_msg()
        for level, name, message, values in rows:
            s = DiagnosticStatus(level=bytes([level]), name=name, message=message,
                                 hardware_id="omni4")
            s.values = [KeyValue(key=k, value=v) for k, v in values]
            a.status.append(s)
        if self.goals.last is not None:
            a.status.append(self.goals.status_msg(self.goals.last))
        self.pub_diag.publish(a)

    def _srv_clear_fault(self, _req, res):
        with self._lock:
            self._cmd, self._stopping_since = None, None
            seen = self.window.last.seq if self.window.last is not None else -1
        self._send(command_t.MODE_CLEAR_FAULT)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            with self._lock:
                m = self.window.last
            if m is not None and m.seq > seen + 5 and m.mode not in core.FAULTED_MODES \
                    and not m.faults & core.LATCHING:
                res.success, res.message = True, f"mode {core.mode_name(m.mode)}"
                return res
            time.sleep(0.01)
        from ..robot import clear_refusal_reason
        m = self.window.last
        res.success = False
        if m is None:
            res.message = "no OMNI4_MOTORS from omni4-fw"
        elif m.mode in core.FAULTED_MODES or m.faults & core.LATCHING:
            res.message = f"refused after 1 s: {clear_refusal_reason(m)}"   # omni4-param's words
        else:
            res.message = (f"still mode {core.mode_name(m.mode)}, faults "
                           f"{' '.join(core.fault_names(m.faults)) or 'none'} after 1 s")
        return res

    def _srv_save(self, _req, res):
        from ..params import ParamError
        try:
            path = self.params.save()
            res.success, res.message = True, f"saved {path}"
        except ParamError as e:
            res.success, res.message = False, str(e)
        return res

    def close(self):
        """IDLE if a command was in force, then the threads end (bounded)."""
        with self._lock:
            moving = self._cmd is not None or self._stopping_since is not None
            self._cmd, self._stopping_since = None, None
        self._closed.set()
        self.goals.close()                         # an active goal: CANCEL (the stop ramp)
        if moving:
            self._send(command_t.MODE_IDLE)
        for t in self._threads:
            t.join(timeout=2.0)
        self.params.close()
        self.node.destroy_node()


def _parser():
    from .._cli import bus_tool_parser
    p = bus_tool_parser(PROG, "The robot on ROS 2: /cmd_vel in, /odom, /joint_states, "
                        "/diagnostics out, beside omni4-fw on its LCM URL.", EPILOG)
    p.add_argument("--secret", default=None,
                   help="the robot's [params] secret (or $OMNI4_PARAM_SECRET)")
    p.add_argument("--rate", type=float, default=50.0, metavar="HZ",
                   help="/odom and /joint_states rate [Hz] (default 50)")
    p.add_argument("--fresh", type=float, default=FRESH_S, metavar="S",
                   help=f"a /cmd_vel older than this stops the robot [s] (default {FRESH_S:g})")
    p.add_argument("--stop-hold", type=float, default=STOP_HOLD_S, metavar="S",
                   help="after a stale /cmd_vel: zero velocity this long, then IDLE [s] "
                   f"(default {STOP_HOLD_S:g})")
    p.add_argument("--odom-source", choices=["auto", "wheels"], default="auto",
                   help="auto: the controller's state_t when it arrives, else the wheels")
    p.add_argument("--frame-prefix", default="", metavar="P",
                   help="prefix of the frame ids (P + odom, P + base_link), e.g. robot1/")
    return p


def main(argv=None):
    from .._cli import run
    return run(PROG, _main, argv)


def _main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    ros_args = []
    if "--ros-args" in argv:
        i = argv.index("--ros-args")
        argv, ros_args = argv[:i], argv[i:]
    args = _parser().parse_args(argv)
    from .._cli import usage
    if not (0 < args.rate <= 1000):
        return usage(PROG, "--rate must be in (0, 1000] Hz")
    if not (0.05 <= args.fresh <= 10):
        return usage(PROG, "--fresh must be in [0.05, 10] s")
    if not (0 <= args.stop_hold <= 10):
        return usage(PROG, "--stop-hold must be in [0, 10] s")
    try:
        import rclpy
        from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
    except ImportError as e:
        sys.stderr.write(f"{PROG}: needs ROS 2's rclpy ({e}): pip install './python[ros]' "
                         "(or source a ROS 2 installation)\n")
        return 2
    secret = args.secret if args.secret is not None else os.environ.get("OMNI4_PARAM_SECRET")
    rclpy.init(args=[PROG, *ros_args])
    node = None
    try:
        try:
            node = Omni4Ros(args.lcm, secret=secret, rate_hz=args.rate, fresh_s=args.fresh,
                            odom_source=args.odom_source, stop_hold_s=args.stop_hold,
                            frame_prefix=args.frame_prefix)
        except RuntimeError as e:
            sys.stderr.write(f"{PROG}: {e}\n")
            return 1
        ex = MultiThreadedExecutor(num_threads=3)
        ex.add_node(node.node)
        try:
            ex.spin()
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
    finally:
        if node is not None:
            node.close()
        if rclpy.ok():
            rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
