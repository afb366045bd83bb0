/*
 * param_service.h - robot parameters over LCM: list / get / set / load / save requests on
 * OMNI4_PARAM_REQ (param_request_t), one param_reply_t each on OMNI4_PARAM_REPLY, and a
 * param_changed_t on OMNI4_PARAM_CHANGED at start (every value) and for every change and save.
 *
 * A request is handled on the service's own thread, never in the loop: values are parsed and
 * range-checked by the INI parser's table (config_key_set), the whole configuration is checked
 * as config_load checks it (config_check: the [model] physically meaningful), the controller's
 * fixed-point gains are precomputed (fw_param_prepare), and the loop takes the whole set between
 * two ticks (fw_param_apply). A set of several keys (or a LOAD) is applied whole or refused
 * whole, with the reason. When each key may change: the table's rule (config_key.change).
 * SAVE writes the robot's INI atomically (config_save). With [params] secret set, SET, LOAD and
 * SAVE must carry it.
 *
 * The protocol is param_service.c; the threads (LCM's receive thread queues, the service thread
 * handles) param_thread.c; the guard in front of lcm-gen's decoder param_wire.c.
 */
#ifndef OMNI4_PARAM_SERVICE_H
#define OMNI4_PARAM_SERVICE_H

#include <lcm/lcm.h>
#include <limits.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/lcmtypes/channels.h"
#include "omni4/config/config.h"
#include "omni4/core/fw.h"
#include "omni4_param_value_t.h"

#define PARAM_MAX_KEYS 256            /* keys in one request or reply (the whole table fits) */
#define PARAM_MAX_TEXT 65536          /* bytes of INI text in one LOAD */
#define PARAM_QUEUE 8                 /* requests waiting for the service thread */
#define PARAM_CACHE 16                /* replies kept for repeated request ids */
#define PARAM_APPLY_TIMEOUT_US 500000 /* the loop takes a change within this (plus 3 periods) */

/* Where replies and change notices go (lcm_publish in the robot; a buffer in the tests). */
struct param_out {
	int (*emit)(void *ctx, const char *channel, const void *data, size_t len);
	void *ctx;
};

struct param_counters {
	_Atomic uint64_t requests;
	_Atomic uint64_t bad;     /* undecodable or malformed */
	_Atomic uint64_t busy;    /* queue full */
	_Atomic uint64_t denied;  /* wrong secret */
	_Atomic uint64_t refused; /* validation, mode rule, restart-only */
	_Atomic uint64_t applied; /* changes the loop took */
	_Atomic uint64_t saved;
};

/* Scratch of one request (service thread only): the key names, values and reply entries. */
struct param_scratch {
	int n;
	int key[PARAM_MAX_KEYS];
	char value[PARAM_MAX_KEYS][CONFIG_VALUE_MAX];
	char dotted[PARAM_MAX_KEYS][64];
	char old_value[PARAM_MAX_KEYS][CONFIG_VALUE_MAX];
	char new_value[PARAM_MAX_KEYS][CONFIG_VALUE_MAX];
	omni4_param_value_t entries[PARAM_MAX_KEYS];
	char *keys_p[PARAM_MAX_KEYS], *old_p[PARAM_MAX_KEYS], *new_p[PARAM_MAX_KEYS];
	bool too_many;
	bool duplicate;
};

struct param_service {
	struct fw *fw;
	struct omni4_config running; /* the robot's INI as in force (service thread only) */
	struct omni4_config next;    /* a change being checked (service thread only) */
	char path[PATH_MAX];         /* the robot's INI: SAVE writes it */
	struct param_out out;
	int64_t apply_timeout_us;
	struct fw_param_update update; /* handed to the loop */
	struct param_scratch scratch;  /* service thread only (and announce, before it starts) */
	struct {
		int64_t id;
		void *data;
		size_t len;
	} cache[PARAM_CACHE];
	int cache_next;
	/* receive thread -> service thread */
	pthread_mutex_t mu;
	pthread_cond_t cv;
	struct {
		void *data;
		size_t len;
	} queue[PARAM_QUEUE];
	int q_head, q_len;
	bool stop;
	pthread_t thread;
	bool started;
	lcm_t *lcm;
	lcm_subscription_t *sub;
	struct param_counters n;
};

/* cfg: the configuration the controller was started with; path: its INI file. */
int param_service_init(struct param_service *ps, struct fw *fw, const struct omni4_config *cfg,
                       const char *path, struct param_out out);
/* Handle one encoded param_request_t now, on the calling thread (the service thread; tests):
 * emits its reply and, for a change or a save, a param_changed_t. */
void param_service_handle(struct param_service *ps, const void *data, size_t len);
/* A request that found the queue full (receive thread): counted, and answered BUSY if it
 * decodes. */
void param_service_busy(struct param_service *ps, const void *data, size_t len);
/* Publish every parameter in force as one param_changed_t with source "start" (request_id 0,
 * old values empty, path = the robot's INI, the secret only as "(set)"): seq is the first tick
 * that runs on them. Not while requests are being handled (it shares their scratch). */
void param_service_announce(struct param_service *ps, int64_t seq, int64_t utime);
/* Subscribe to OMNI4_PARAM_REQ on lcm (handled by whoever runs lcm_handle, e.g. lcmio's
 * receive thread), announce the parameters (param_service_announce; the loop must not have
 * started) and start the service thread; out.emit NULL = lcm_publish on lcm.
 * 0 or a negative errno. */
int param_service_start(struct param_service *ps, lcm_t *lcm);
/* Stop the thread, unsubscribe, free queued requests and cached replies. */
void param_service_stop(struct param_service *ps);

#endif /* OMNI4_PARAM_SERVICE_H */
