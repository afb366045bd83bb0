/* param_thread.c - the parameter service's threads (see param_service.h): LCM's receive thread
 * queues each request, the service thread handles them one by one, away from the loop. */
#include "omni4/firmware/param_service.h"

#include "omni4/firmware/rtloop.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int lcm_emit(void *ctx, const char *channel, const void *data, size_t len)
{
	return lcm_publish(ctx, channel, data, (unsigned int)len);
}

/* Receive thread (LCM handler): queue a copy; a full queue is answered BUSY right here. */
static void on_request(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct param_service *ps = user;
	void *copy = malloc(rbuf->data_size ? rbuf->data_size : 1);

	(void)channel;
	pthread_mutex_lock(&ps->mu);
	if (copy && ps->q_len < PARAM_QUEUE) {
		const int i = (ps->q_head + ps->q_len) % PARAM_QUEUE;

		memcpy(copy, rbuf->data, rbuf->data_size);
		ps->queue[i].data = copy;
		ps->queue[i].len = rbuf->data_size;
		ps->q_len++;
		pthread_cond_signal(&ps->cv);
		pthread_mutex_unlock(&ps->mu);
		return;
	}
	pthread_mutex_unlock(&ps->mu);
	free(copy);
	param_service_busy(ps, rbuf->data, rbuf->data_size);
}

static void *service_main(void *arg)
{
	struct param_service *ps = arg;

	pthread_mutex_lock(&ps->mu);
	while (!ps->stop) {
		if (ps->q_len == 0) {
			struct timespec until;

			clock_gettime(CLOCK_REALTIME, &until);
			until.tv_nsec += 100000000; /* wake up to look at stop */
			if (until.tv_nsec >= 1000000000) {
				until.tv_sec++;
				until.tv_nsec -= 1000000000;
			}
			pthread_cond_timedwait(&ps->cv, &ps->mu, &until);
			continue;
		}
		void *data = ps->queue[ps->q_head].data;
		const size_t len = ps->queue[ps->q_head].len;

		ps->q_head = (ps->q_head + 1) % PARAM_QUEUE;
		ps->q_len--;
		pthread_mutex_unlock(&ps->mu);
		param_service_handle(ps, data, len);
		free(data);
		pthread_mutex_lock(&ps->mu);
	}
	pthread_mutex_unlock(&ps->mu);
	return NULL;
}

int param_service_start(struct param_service *ps, lcm_t *lcm)
{
	ps->lcm = lcm;
	if (!ps->out.emit)
		ps->out = (struct param_out){.emit = lcm_emit, .ctx = lcm};
	ps->sub = lcm_subscribe(lcm, OMNI4_CHANNEL_PARAM_REQ, on_request, ps);
	if (!ps->sub)
		return -EIO;
	/* Before the service thread exists and before the loop's first tick (fw->seq). */
	param_service_announce(ps, ps->fw->seq, rtloop_clock_us());
	pthread_attr_t attr;

	pthread_attr_init(&attr);
	pthread_attr_setstacksize(&attr, RTLOOP_STACK_BYTES);
	const int rc = pthread_create(&ps->thread, &attr, service_main, ps);

	pthread_attr_destroy(&attr);
	if (rc) {
		lcm_unsubscribe(lcm, ps->sub);
		ps->sub = NULL;
		return -rc;
	}
	ps->started = true;
	return 0;
}

void param_service_stop(struct param_service *ps)
{
	if (ps->started) {
		pthread_mutex_lock(&ps->mu);
		ps->stop = true;
		pthread_cond_signal(&ps->cv);
		pthread_mutex_unlock(&ps->mu);
		pthread_join(ps->thread, NULL);
		ps->started = false;
	}
	if (ps->sub) {
		lcm_unsubscribe(ps->lcm, ps->sub);
		ps->sub = NULL;
	}
	for (int i = 0; i < ps->q_len; i++)
		free(ps->queue[(ps->q_head + i) % PARAM_QUEUE].data);
	ps->q_len = 0;
	for (int i = 0; i < PARAM_CACHE; i++) {
		free(ps->cache[i].data);
		ps->cache[i].data = NULL;
	}
}
