/*
 * channels.h - the LCM channel names of omni4 (docs/design.md) and the default LCM URL: the one
 * place they are written. C and C++ include it; python/setup.py generates the Python package's
 * omni4.CHANNEL_*, MARK_* and DEFAULT_LCM_URL from it (omni4/_channels.py) when the package is
 * built, so every line here is `#define OMNI4_NAME "text"` with an optional comment (the
 * generator refuses any other #define).
 */
#ifndef OMNI4_CHANNELS_H
#define OMNI4_CHANNELS_H

#define OMNI4_CHANNEL_CMD "OMNI4_CMD"               /* command_t: operator / runner -> controller */
#define OMNI4_CHANNEL_MOTORS "OMNI4_MOTORS"         /* motors_t: one per loop tick */
#define OMNI4_CHANNEL_POSE "OMNI4_POSE"             /* pose_t: camera / tracker */
#define OMNI4_CHANNEL_EXPERIMENT "OMNI4_EXPERIMENT" /* experiment_t: segment marks */
#define OMNI4_CHANNEL_PARAM_REQ "OMNI4_PARAM_REQ"   /* param_request_t: client -> robot */
#define OMNI4_CHANNEL_PARAM_REPLY "OMNI4_PARAM_REPLY"     /* param_reply_t: robot -> client */
#define OMNI4_CHANNEL_STATE "OMNI4_STATE"                 /* state_t: the controller's estimate */
#define OMNI4_CHANNEL_PARAM_CHANGED "OMNI4_PARAM_CHANGED" /* param_changed_t: every change */
#define OMNI4_CHANNEL_SIM_TRUTH "OMNI4_SIM_TRUTH" /* sim_truth_t: the simulated plant, per tick */
#define OMNI4_CHANNEL_GOAL "OMNI4_GOAL"           /* goal_t: client -> controller */
#define OMNI4_CHANNEL_GOAL_STATUS "OMNI4_GOAL_STATUS" /* goal_status_t: the goal's progress */
#define OMNI4_CHANNEL_SIM_PLANT "OMNI4_SIM_PLANT"     /* sim_plant_t: the plant's R, heat, supply */
#define OMNI4_CHANNEL_ADAPT "OMNI4_ADAPT"             /* adapt_t: the motor constants in use */
#define OMNI4_CHANNEL_ROBOT "OMNI4_ROBOT"             /* robot_t: the wheels' layout, 1 Hz */

/* The robot's LCM URL unless its INI says otherwise: multicast that stays on the host (ttl=0). */
#define OMNI4_DEFAULT_LCM_URL "udpm://239.255.76.67:7667?ttl=0"

/* experiment_t.kind of the mark that closes a segment (docs/log-contract.md). */
#define OMNI4_MARK_END "end"

#endif /* OMNI4_CHANNELS_H */
