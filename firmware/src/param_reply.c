/* param_reply.c - the parameter service's replies (encoded, emitted and kept for a repeated
 * request id) and its change notices. */
#include "param_reply.h"

#include "omni4/firmware/rtloop.h"

#include <stdlib.h>

#include "omni4_param_changed_t.h"

void param_emit(struct param_service *ps, const char *channel, const void *data, size_t len)
{
	if (ps->out.emit)
		ps->out.emit(ps->out.ctx, channel, data, len);
}

static void cache_put(struct param_service *ps, int64_t id, void *data, size_t len)
{
	const int i = ps->cache_next;

	free(ps->cache[i].data);
	ps->cache[i].id = id;
	ps->cache[i].data = data;
	ps->cache[i].len = len;
	ps->cache_next = (i + 1) % PARAM_CACHE;
}

bool param_cache_replay(struct param_service *ps, int64_t id)
{
	for (int i = 0; id && i < PARAM_CACHE; i++)
		if (ps->cache[i].data && ps->cache[i].id == id) {
			param_emit(ps, OMNI4_CHANNEL_PARAM_REPLY, ps->cache[i].data,
			           ps->cache[i].len);
			return true;
		}
	return false;
}

/* Encode and emit a reply; keep it for a repeated id if cache. */
void param_reply(struct param_service *ps, omni4_param_reply_t *r, bool cache)
{
	r->utime = rtloop_clock_us();
	if (!r->message)
		r->message = "";
	if (!r->path)
		r->path = "";
	const int size = omni4_param_reply_t_encoded_size(r);
	void *buf = size > 0 ? malloc((size_t)size) : NULL;

	if (!buf)
		return;
	if (omni4_param_reply_t_encode(buf, 0, size, r) != size) {
		free(buf);
		return;
	}
	param_emit(ps, OMNI4_CHANNEL_PARAM_REPLY, buf, (size_t)size);
	if (cache && r->request_id)
		cache_put(ps, r->request_id, buf, (size_t)size);
	else
		free(buf);
}

void param_simple_reply(struct param_service *ps, int64_t id, int8_t op, int8_t result,
                        const char *message, bool cache)
{
	omni4_param_reply_t r = {
	    .request_id = id, .op = op, .result = result, .message = (char *)message, .seq = -1};

	param_reply(ps, &r, cache);
}

void param_notice(struct param_service *ps, struct param_scratch *s, int64_t id, const char *source,
                  const char *path, int64_t seq, int64_t utime)
{
	omni4_param_changed_t m = {.utime = utime,
	                           .seq = seq,
	                           .request_id = id,
	                           .source = (char *)source,
	                           .path = (char *)path,
	                           .n = s->n,
	                           .keys = s->keys_p,
	                           .old_values = s->old_p,
	                           .values = s->new_p};
	const int size = omni4_param_changed_t_encoded_size(&m);
	void *buf = size > 0 ? malloc((size_t)size) : NULL;

	if (buf && omni4_param_changed_t_encode(buf, 0, size, &m) == size)
		param_emit(ps, OMNI4_CHANNEL_PARAM_CHANGED, buf, (size_t)size);
	free(buf);
}
