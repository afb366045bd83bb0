/*
 * goalcodec.h - the goal's messages as LCM bytes (docs/goal.md): goal_t bytes -> goal_cmd,
 * LOG_GOAL entries -> goal_status_t bytes. No threads, no LCM instance: omni4-fw's receive
 * thread and the lockstep simulator both use it.
 */
#ifndef OMNI4_GOALCODEC_H
#define OMNI4_GOALCODEC_H

#include <stddef.h>

#include "omni4/core/fw.h"
#include "omni4/core/goal.h"

/* Decode a goal_t (receive thread: lcm-gen's decoder allocates the poses, freed here). -EINVAL
 * if the bytes are not a complete goal_t; -E2BIG beyond GOAL_POSES_MAX poses, -EDOM for a
 * negative n: out then holds a goal the controller refuses as out of range (n = -1), so the
 * sender hears why. */
int lcmio_decode_goal(const void *data, size_t len, struct goal_cmd *out);

/* A LOG_GOAL entry as a goal_status_t; the length (> 0) or -ENOSPC. */
int lcmio_encode_goal_status(const struct log_entry *e, void *buf, size_t cap);

#endif /* OMNI4_GOALCODEC_H */
