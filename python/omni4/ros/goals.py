"""Goals on ROS 2 for omni4-ros (docs/goal.md, docs/ros.md).

- goal_pose (/goal_pose without a namespace; geometry_msgs/PoseStamped): one message, as
  RViz's "2D Goal Pose" publishes it, is a goal: the node sends it as goal_t and keeps it alive on the bus (as omni4-goto does while
  it waits) until the controller says REACHED (then CANCEL: the robot ramps to IDLE), ABORTED or
  REFUSED. The pose's frame is the node's odom frame (the controller's world frame); "map" and
  "world" are taken as the same frame, any other is refused with a warning.
- follow_path (nav_msgs/Path): its poses (at most goal_t.MAX_POSES) followed without stopping at
  the intermediate ones, likewise.
- goal_status (diagnostic_msgs/DiagnosticStatus): the feedback, one per goal_status_t (status,
  reason, pose aimed at, distance, heading and time to go); the last one also in /diagnostics.
  A goal the node refuses itself (a pose not finite, more poses than goal_t holds, a frame not
  its odom frame) is published there too, REFUSED with its reason (goal_id 0: nothing sent).
- A /cmd_vel replaces the goal (the node stops keeping it alive; the controller ends it).
- Another client's goal in force once ours had started: ours was replaced; goal_status says
  ABORTED, replaced, naming the other goal, and the node stops keeping ours alive.
"""
import math

from ..goal import REASONS, STATUS_NAMES, GoalMixin, describe
from ..goal_status_t import goal_status_t

FRAMES_SAME_AS_ODOM = ("", "map", "world")


def yaw_of(q):
    """Heading [rad] of a geometry_msgs/Quaternion (rotation about z)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class GoalBridge(GoalMixin):
    """The goal topics of one Omni4Ros node (owner: its lc, url, _closed, _lock, log, node)."""

    def __init__(self, owner, keepalive_s):
        from diagnostic_msgs.msg import DiagnosticStatus
        from geometry_msgs.msg import PoseStamped
        from nav_msgs.msg import Path

        self._owner = owner
        self._lc = owner.lc
        self.url = owner.url
        self.keepalive_s = keepalive_s
        self._closed = owner._closed
        self._Status = DiagnosticStatus
        self.last = None                      # the last goal_status_t (for /diagnostics)
        self.counters = {"goals sent": 0, "goals reached": 0, "goals failed": 0}
        self._goal_setup()
        self.pub = owner.node.create_publisher(DiagnosticStatus, "goal_status", 10)
        owner.node.create_subscription(PoseStamped, "goal_pose", self._on_goal_pose, 10)
        owner.node.create_subscription(Path, "follow_path", self._on_path, 10)

    def _frame_ok(self, frame):
        if frame in FRAMES_SAME_AS_ODOM or frame == self._owner.frame_odom:
            return True
        why = (f"goal in frame '{frame}' refused: give it in '{self._owner.frame_odom}' (or "
               "map / world, taken as the same)")
        self._owner.log.warn(why)
        self._refused(goal_status_t.REASON_OUT_OF_RANGE, why)
        return False

    def _refused(self, reason, why):
        """A goal this node refuses before sending anything: on goal_status as REFUSED with
        its reason (goal_id 0: no goal_t went out), as the controller's refusals are."""
        st = goal_status_t()
        st.status, st.reason = goal_status_t.STATUS_REFUSED, reason
        self.counters["goals failed"] += 1
        self.last = st
        self.pub.publish(self.status_msg(st, why))

    def _on_goal_pose(self, msg):
        if self._frame_ok(msg.header.frame_id):
            p = msg.pose
            self._go([(p.position.x, p.position.y, yaw_of(p.orientation))])

    def _on_path(self, msg):
        poses = [(s.pose.position.x, s.pose.position.y, yaw_of(s.pose.orientation))
                 for s in msg.poses]
        if self._frame_ok(msg.header.frame_id):
            self._go(poses)

    def _go(self, poses):
        try:
            self.follow(poses, wait=False)
        except ValueError as e:
            self._owner.log.warn(f"goal refused before sending: {e}")
            finite = all(math.isfinite(float(v)) for p in poses for v in p)
            self._refused(goal_status_t.REASON_OUT_OF_RANGE if finite else
                          goal_status_t.REASON_NOT_FINITE, f"goal refused before sending: {e}")
            return
        self.counters["goals sent"] += 1
        self._owner.log.info(f"goal: {len(poses)} pose(s), the last {poses[-1]}")

    def _forget_command(self):
        """A goal replaces the /cmd_vel in force (no more VELOCITY keep-alive)."""
        with self._owner._lock:
            self._owner._cmd = None
            self._owner._stopping_since = None

    def _on_goal_status(self, channel, data):
        super()._on_goal_status(channel, data)
        why = None
        with self._goal_cv:
            st, msg, other = self._goal_status, self._goal_msg, self._goal_other
            if st is None or msg is None or st.goal_id != msg.goal_id:
                return
            if other is not None:       # a second client's goal took over once ours had started
                self._goal_msg = None   # no keep-alive: it would start ours again
                why = f"replaced: goal {other.goal_id} (another client's) is in force now"
                st = goal_status_t.decode(st.encode())
                st.status, st.reason = goal_status_t.STATUS_ABORTED, goal_status_t.REASON_REPLACED
            elif st is self.last:       # a status about another goal: nothing new about ours
                return
            self.last = st
            if st.status == goal_status_t.STATUS_REACHED:
                self.counters["goals reached"] += 1
                self.cancel_goal_locked()       # the robot ramps to IDLE
            elif st.status != goal_status_t.STATUS_ACTIVE:
                self.counters["goals failed"] += 1
                self._goal_msg = None
        if st.status != goal_status_t.STATUS_ACTIVE:
            self._owner.log.info(describe(st) if why is None else f"goal {st.goal_id}: {why}")
        self.pub.publish(self.status_msg(st, why))

    def status_msg(self, st, why=None):
        """A goal_status_t as a DiagnosticStatus (level OK / WARN for refused or aborted);
        why: the node's own words for a refusal (else the reason's)."""
        from diagnostic_msgs.msg import KeyValue
        bad = st.status in (goal_status_t.STATUS_ABORTED, goal_status_t.STATUS_REFUSED)
        reason = REASONS.get(st.reason, str(st.reason))
        if why is not None:
            reason = f"{reason}: {why}" if st.reason == goal_status_t.REASON_NOT_FINITE else why
        text = describe(st) if why is None else \
            f"goal {st.goal_id} {STATUS_NAMES.get(st.status, '?')}: {why}"
        s = self._Status(level=bytes([1 if bad else 0]), name=f"{self._owner._diag_prefix}: goal",
                         message=text, hardware_id="omni4")
        s.values = [KeyValue(key=k, value=v) for k, v in (
            ("goal_id", str(st.goal_id)), ("status", STATUS_NAMES.get(st.status, "?")),
            ("reason", reason),
            ("pose aimed at", f"{st.index + 1} of {st.n}"),
            ("distance to go [m]", f"{st.distance_m:.4f}"),
            ("heading to go [rad]", f"{st.angle_rad:.4f}"),
            ("time to go [s]", f"{st.time_to_go_s:.3f}"),
            *((k, str(v)) for k, v in self.counters.items()))]
        return s

    def close(self):
        self._goal_close()
