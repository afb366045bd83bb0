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
from .state_t import state_t
from .sim_truth_t import sim_truth_t
from .sim_plant_t import sim_plant_t
from .adapt_t import adapt_t
from .robot_t import robot_t
from .goal_t import goal_t
from .goal_status_t import goal_status_t

__version__ = "0.1.0"

# The channel names (CHANNEL_*), MARK_END and DEFAULT_LCM_URL, generated from
# lcmtypes/include/omni4/lcmtypes/channels.h when the package is built.
from ._channels import *  # noqa: E402,F401,F403
from ._channels import __all__ as _CHANNEL_NAMES  # noqa: E402
from ._channels import (CHANNEL_CMD, CHANNEL_EXPERIMENT, CHANNEL_MOTORS,  # noqa: E402
                        CHANNEL_POSE, CHANNEL_STATE)
from ._channels import CHANNEL_SIM_PLANT, CHANNEL_SIM_TRUTH  # noqa: E402
from ._channels import CHANNEL_ADAPT, CHANNEL_ROBOT  # noqa: E402
from ._channels import CHANNEL_GOAL, CHANNEL_GOAL_STATUS  # noqa: E402

# Message class per channel, for decoding logs.
TYPES = {
    CHANNEL_MOTORS: motors_t,
    CHANNEL_CMD: command_t,
    CHANNEL_POSE: pose_t,
    CHANNEL_EXPERIMENT: experiment_t,
    CHANNEL_STATE: state_t,
    CHANNEL_SIM_TRUTH: sim_truth_t,  # the simulated plant's true state (simulators only)
    CHANNEL_SIM_PLANT: sim_plant_t,  # the simulated plant's R, heat, supply (omni4-sim only)
    CHANNEL_GOAL_STATUS: goal_status_t,  # the goal's progress
    CHANNEL_ADAPT: adapt_t,  # the motor constants in use, R_j estimated online ([adapt])
    CHANNEL_ROBOT: robot_t,  # the wheels' layout, 1 Hz (logs before it: the paper's layout)
}
# goal_t (OMNI4_GOAL) has a variable number of poses: goal_t.decode(...).
# The parameter channels carry variable-length types (not in TYPES, which read_log decodes into
# fixed-shape arrays): decode them with param_changed_t.decode(...) etc.

# Log reader (numpy arrays per channel); needs the names above.
from .log import Log, LogError, read_log  # noqa: E402
# Client of a running controller (commands with keep-alive, live motors_t).
from .robot import CommandRejected, Robot  # noqa: E402
from .goal import GoalFailed  # noqa: E402
# The robot's parameters over LCM (omni4-param).
from .params import ParamClient, ParamError, ParamRefused, ParamTimeout  # noqa: E402
# The robot INI reader (omni4.ini.read).
from . import ini  # noqa: E402

__all__ = ["command_t", "experiment_t", "motors_t", "pose_t", "state_t", "sim_truth_t",
           "sim_plant_t", "adapt_t", "robot_t", "TYPES",
           "goal_t", "goal_status_t", "GoalFailed",
           "read_log", "Log", "LogError", "Robot", "CommandRejected",
           "param_request_t", "param_reply_t", "param_value_t", "param_changed_t",
           "ParamClient", "ParamError", "ParamRefused", "ParamTimeout", *_CHANNEL_NAMES]
