/*
 * fw_param.h - the Linux side of a parameter change: offer a prepared update to the loop
 * (core/fw.h) and wait for it, polling, with a bound.
 */
#ifndef OMNI4_FW_PARAM_H
#define OMNI4_FW_PARAM_H

#include <stdint.h>

#include "omni4/core/fw.h"

/* Parameter thread (one at a time). Offer u to the loop and wait (bounded, polling every
 * 0.1 ms) until it is taken between two ticks; u must stay valid until this returns. After
 * timeout_us the update is withdrawn (rc -ETIMEDOUT, nothing changed) unless the loop took it
 * meanwhile, in which case its answer is awaited. */
struct fw_param_result fw_param_apply(struct fw *fw, struct fw_param_update *u, int64_t timeout_us);

#endif /* OMNI4_FW_PARAM_H */
