"""omni4 on ROS 2: `omni4-ros` (the node beside omni4-fw: /cmd_vel in; /odom, /joint_states,
/diagnostics out; the controller's parameters as ROS parameters) and `omni4-rosbag` (LCM logs
-> a ROS 2 bag). Needs the package's `ros` extra (rclpy and the message packages as PyPI
wheels, rosbags); docs/ros.md. Importing this package imports no ROS module: omni4.ros.core is
plain Python, omni4.ros.node imports rclpy when the node starts."""
import os

URDF = os.path.join(os.path.dirname(os.path.abspath(__file__)), "omni4.urdf")
