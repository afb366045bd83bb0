"""omni4: LCM message types and channel names of the four-wheeled omni-directional robot.

The message classes are generated from the repository's lcmtypes/*.lcm by lcm-gen when the
package is built; see docs/design.md for what each field means and its unit."""
from .command_t import command_t
from .experiment_t import experiment_t
from .motors_t import motors_t
from .param_changed_t import param_changed_t
from .param_reply_t import param_reply_t
from .param_request_t import param_request_t
from .param_value_t import param_value_t
from .pose_t import pose_t

__version__ = "0.1.0"

# Channel names (docs/design.md).
CHANNEL_MOTORS = "OMNI4_MOTORS"          # motors_t, one per loop tick
CHANNEL_CMD = "OMNI4_CMD"                # command_t, operator / runner -> controller
CHANNEL_POSE = "OMNI4_POSE"              # pose_t, camera / tracker
CHANNEL_EXPERIMENT = "OMNI4_EXPERIMENT"  # experiment_t, segment marks
CHANNEL_PARAM_REQ = "OMNI4_PARAM_REQ"          # param_request_t, omni4-param -> controller
CHANNEL_PARAM_REPLY = "OMNI4_PARAM_REPLY"      # param_reply_t, controller -> omni4-param
CHANNEL_PARAM_CHANGED = "OMNI4_PARAM_CHANGED"  # param_changed_t, every parameter change / save
MARK_END = "end"  # experiment_t.kind of the mark that closes a segment

# Message class per channel, for decoding logs.
TYPES = {
    CHANNEL_MOTORS: motors_t,
    CHANNEL_CMD: command_t,
    CHANNEL_POSE: pose_t,
    CHANNEL_EXPERIMENT: experiment_t,
}
# The parameter channels carry variable-length types (not in TYPES, which read_log decodes into
# fixed-shape arrays): decode them with param_changed_t.decode(...) etc.

# Default LCM URL of the robot (stays on the host: ttl=0).
DEFAULT_LCM_URL = "udpm://239.255.76.67:7667?ttl=0"

# Log reader (numpy arrays per channel); needs the names above.
from .log import Log, LogError, read_log  # noqa: E402
# Client of a running controller (commands with keep-alive, live motors_t).
from .robot import CommandRejected, Robot  # noqa: E402
# The robot's parameters over LCM (omni4-param).
from .params import ParamClient, ParamError, ParamRefused, ParamTimeout  # noqa: E402

__all__ = ["command_t", "experiment_t", "motors_t", "pose_t", "TYPES", "DEFAULT_LCM_URL",
           "CHANNEL_MOTORS", "CHANNEL_CMD", "CHANNEL_POSE", "CHANNEL_EXPERIMENT",
           "read_log", "Log", "LogError", "Robot", "CommandRejected",
           "param_request_t", "param_reply_t", "param_value_t", "param_changed_t",
           "CHANNEL_PARAM_REQ", "CHANNEL_PARAM_REPLY", "CHANNEL_PARAM_CHANGED",
           "ParamClient", "ParamError", "ParamRefused", "ParamTimeout"]
