/* goalcodec.c - goal_t in, goal_status_t out, through the generated types (goalcodec.h). */
#include "omni4/firmware/goalcodec.h"

#include <errno.h>
#include <stdint.h>
#include <string.h>

#include "omni4_goal_status_t.h"
#include "omni4_goal_t.h"

/* The core's goal vocabulary is goal_t's and goal_status_t's, value for value. */
#define SAME(a, b) _Static_assert((a) == (b), #a " != " #b)
SAME(GOAL_POSES_MAX, OMNI4_GOAL_T_MAX_POSES);
SAME(GOAL_CANCEL, OMNI4_GOAL_T_ACTION_CANCEL);
SAME(GOAL_GO, OMNI4_GOAL_T_ACTION_GO);
/* every status and reason row of vocab.def against goal_status_t's constants */
#define OMNI4_GOAL_STATUS(name, ...) SAME(GOAL_##name, OMNI4_GOAL_STATUS_T_STATUS_##name);
#define OMNI4_GOAL_REASON(name, ...) SAME(GOAL_R_##name, OMNI4_GOAL_STATUS_T_REASON_##name);
#include "omni4/core/vocab.def"
#undef SAME

/* goal_t's wire: fingerprint, utime, seq, goal_id (8 bytes each), action (1), n (4), n poses
 * (24 each), blend_m, speed_max (8 each); big-endian. */
#define WIRE_N_AT 33
#define WIRE_SIZE(n) (53 + 24 * (int64_t)(n))

static int64_t be(const uint8_t *p, int bytes)
{
	uint64_t v = 0;

	for (int i = 0; i < bytes; i++)
		v = v << 8 | p[i];
	return bytes == 4 ? (int64_t)(int32_t)(uint32_t)v : (int64_t)v;
}

/* A datagram's own length must hold the poses it announces before the generated decoder
 * allocates them (a short datagram that announces 2^31 poses would ask for gigabytes); an
 * announced count out of range is refused from the header, the poses unread. */
static int precheck(const uint8_t *b, size_t len, struct goal_cmd *out)
{
	if (len < WIRE_N_AT + 4 || be(b, 8) != __omni4_goal_t_get_hash())
		return -EINVAL;
	const int64_t n = be(b + WIRE_N_AT, 4);

	if (n >= 0 && n <= GOAL_POSES_MAX)
		return (int64_t)len == WIRE_SIZE(n) ? 0 : -EINVAL;
	memset(out, 0, sizeof(*out));
	out->utime = be(b + 8, 8);
	out->id = be(b + 24, 8);
	out->action = (int8_t)b[32];
	out->n = -1; /* refused as out of range: the sender hears it */
	return n < 0 ? -EDOM : -E2BIG;
}

int lcmio_decode_goal(const void *data, size_t len, struct goal_cmd *out)
{
	omni4_goal_t m;
	int rc = precheck(data, len, out);

	if (rc)
		return rc;
	if (len > INT32_MAX || omni4_goal_t_decode(data, 0, (int)len, &m) != (int)len)
		return -EINVAL;
	memset(out, 0, sizeof(*out));
	out->utime = m.utime;
	out->id = m.goal_id;
	out->action = m.action;
	out->blend_m = m.blend_m;
	out->speed_max = m.speed_max;
	out->n = m.n; /* 0 .. GOAL_POSES_MAX (precheck) */
	for (int i = 0; i < m.n; i++)
		memcpy(out->poses[i], m.poses[i], sizeof(out->poses[i]));
	omni4_goal_t_decode_cleanup(&m);
	return rc;
}

int lcmio_encode_goal_status(const struct log_entry *e, void *buf, size_t cap)
{
	const struct goal_report *r = &e->goal;
	omni4_goal_status_t m = {.utime = e->utime,
	                         .seq = e->seq,
	                         .goal_id = r->id,
	                         .status = r->status,
	                         .reason = r->reason,
	                         .index = r->index,
	                         .n = r->n,
	                         .distance_m = r->distance_m,
	                         .angle_rad = r->angle_rad,
	                         .time_to_go_s = r->time_to_go_s};

	memcpy(m.reference, r->ref, sizeof(m.reference));
	memcpy(m.reference_velocity, r->ref_vel, sizeof(m.reference_velocity));
	memcpy(m.error, r->error, sizeof(m.error));
	const int n = omni4_goal_status_t_encode(buf, 0, (int)cap, &m);

	return n > 0 ? n : -ENOSPC;
}
