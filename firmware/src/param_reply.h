/* param_reply.h - the parameter service's replies and change notices (param_reply.c); private
 * to the service's sources. */
#ifndef OMNI4_PARAM_REPLY_H
#define OMNI4_PARAM_REPLY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/firmware/param_service.h"

#include "omni4_param_reply_t.h"

/* Hand an encoded message to the service's output (its emit callback, if any). */
void param_emit(struct param_service *ps, const char *channel, const void *data, size_t len);
/* Emit the reply kept for request id, if there is one; true if it was sent again. */
bool param_cache_replay(struct param_service *ps, int64_t id);
/* Encode and emit a reply (its utime stamped now); keep it for a repeated id if cache. */
void param_reply(struct param_service *ps, omni4_param_reply_t *r, bool cache);
/* A reply with a result and a message only. */
void param_simple_reply(struct param_service *ps, int64_t id, int8_t op, int8_t result,
                        const char *message, bool cache);
/* The notice of the changed keys in the scratch (keys, old and new values). */
void param_notice(struct param_service *ps, struct param_scratch *s, int64_t id, const char *source,
                  const char *path, int64_t seq, int64_t utime);

#endif
