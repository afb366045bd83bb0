/* est_replay.c - late measurements replayed from their tick (est_replay.h). */
#include "omni4/core/est_replay.h"

#include <errno.h>
#include <string.h>

#include "est_priv.h"

#define NSNAP (EST_HISTORY / EST_SNAP_EVERY)

_Static_assert(EST_HISTORY % EST_SNAP_EVERY == 0, "EST_HISTORY: a multiple of EST_SNAP_EVERY");

static void put_snap(struct est *e, uint32_t n)
{
	int m = 0;

	memcpy(e->snap[(n / EST_SNAP_EVERY) % NSNAP].s, e->s, sizeof(e->s));
	for (int i = 0; i < 6; i++)
		for (int j = i; j < 6; j++)
			e->snap[(n / EST_SNAP_EVERY) % NSNAP].P[m++] = e->P[i][j];
}

static void get_snap(struct est *e, uint32_t n)
{
	int m = 0;

	memcpy(e->s, e->snap[(n / EST_SNAP_EVERY) % NSNAP].s, sizeof(e->s));
	for (int i = 0; i < 6; i++)
		for (int j = i; j < 6; j++)
			e->P[i][j] = e->snap[(n / EST_SNAP_EVERY) % NSNAP].P[m++];
	est_symmetrise(e);
}

void est_replay_snap(struct est *e, uint32_t n)
{
	if (n % EST_SNAP_EVERY == 0) {
		est_flush_tiny(e); /* often enough: a term decays by phi, a little, per tick */
		put_snap(e, n);
	}
}

/* Ticks n .. to-1 re-run from the ring (snapshots re-taken on the way). */
static void rerun(struct est *e, uint32_t n, uint32_t to)
{
	for (; n < to; n++) {
		est_replay_snap(e, n);
		est_run_tick(e, &e->hist[n % EST_HISTORY], false);
	}
}

int est_replay_find(const struct est *e, int64_t capture_us, uint32_t *tick)
{
	const uint32_t n = e->seq;
	const uint32_t oldest = n > EST_HISTORY ? n - EST_HISTORY : 0;
	uint32_t k = n;

	while (k > oldest && e->hist[(k - 1) % EST_HISTORY].utime > capture_us)
		k--;
	if (k == oldest)
		return -ERANGE;
	k--;
	if (k - k % EST_SNAP_EVERY < oldest) /* its snapshot is gone */
		return -ERANGE;
	*tick = k;
	return 0;
}

/* Exchanges the live state with the re-run's. */
static void swap_job(struct est *e)
{
	float s[6], P[6][6];

	memcpy(s, e->s, sizeof(s));
	memcpy(P, e->P, sizeof(P));
	memcpy(e->s, e->job.s, sizeof(s));
	memcpy(e->P, e->job.P, sizeof(P));
	memcpy(e->job.s, s, sizeof(s));
	memcpy(e->job.P, P, sizeof(P));
}

void est_replay_advance(struct est *e, uint32_t max_ticks)
{
	if (!e->job.on)
		return;
	const uint32_t left = e->seq - e->job.n;
	const uint32_t to = e->job.n + (max_ticks == 0 || max_ticks > left ? left : max_ticks);

	swap_job(e);
	rerun(e, e->job.n, to);
	e->job.n = to;
	if (to == e->seq)
		e->job.on = false; /* caught up: the corrected state is the live one */
	else
		swap_job(e);
}

int est_replay_at(struct est *e, uint32_t tick, uint8_t kind, const float z[3], est_late_fn apply)
{
	est_replay_advance(e, 0); /* a re-run under way first: its snapshots are needed */
	const uint32_t n = e->seq, n0 = tick - tick % EST_SNAP_EVERY;
	struct est_tick *tk = &e->hist[tick % EST_HISTORY];
	const uint8_t had = tk->late;
	float s_now[6], P_now[6][6];

	/* The state at the tick without its old late measurement (this one replaces it) ... */
	memcpy(s_now, e->s, sizeof(s_now));
	memcpy(P_now, e->P, sizeof(P_now));
	get_snap(e, n0);
	tk->late = EST_LATE_NONE;
	rerun(e, n0, tick + 1);
	const int rc = apply(e, z);

	if (rc) {
		tk->late = had;
		memcpy(e->s, s_now, sizeof(s_now));
		memcpy(e->P, P_now, sizeof(P_now));
		return rc;
	}
	/* ... updated, kept for later replays, and the ticks since re-run: spread over the next
	 * live ticks (est_replay_advance), the live state going on meanwhile. */
	tk->late = kind;
	memcpy(tk->late_z, z, sizeof(tk->late_z));
	e->job.on = true;
	e->job.n = tick + 1;
	swap_job(e);
	memcpy(e->s, s_now, sizeof(s_now));
	memcpy(e->P, P_now, sizeof(P_now));
	if (e->replay_per_tick == 0 || e->job.n == n)
		est_replay_advance(e, 0);
	return 0;
}

void est_replay_from(struct est *e, uint32_t n0)
{
	est_replay_advance(e, 0);
	get_snap(e, n0);
	rerun(e, n0, e->seq);
}
