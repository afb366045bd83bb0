/* param_service.c - the parameter protocol: list, get, set, load and save requests answered, change
 * notices sent (see param_service.h; its threads: param_thread.c; the wire guard: param_wire.c;
 * the replies, their cache and the notices: param_reply.c). */
#include "omni4/firmware/param_service.h"

#include "omni4/firmware/fw_param.h"
#include "omni4/config/outfile.h"
#include "omni4/firmware/param_wire.h"
#include "param_reply.h"
#include "omni4/firmware/rtloop.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "omni4_param_changed_t.h"
#include "omni4_param_reply_t.h"
#include "omni4_param_request_t.h"

#define WHY_MAX 320

/* "IDLE, COAST, FAULT, ESTOP": the modes a robot reports with its bridges not driven. */
static void undriven_modes(char *buf, size_t n)
{
	size_t at = 0;

	buf[0] = '\0';
	for (int m = 0; m < 32 && at < n; m++)
		if (mode_name(m) && vocab_mode_in(CTL_MODES_REPORTED, m) && !mode_drives(m))
			at += (size_t)snprintf(buf + at, n - at, "%s%s", at ? ", " : "",
			                       mode_name(m));
}

int param_service_init(struct param_service *ps, struct fw *fw, const struct omni4_config *cfg,
                       const char *path, struct param_out out)
{
	memset(ps, 0, sizeof(*ps));
	if (!path || strlen(path) >= sizeof(ps->path))
		return -EINVAL;
	ps->fw = fw;
	ps->running = *cfg;
	snprintf(ps->path, sizeof(ps->path), "%s", path);
	ps->out = out;
	ps->apply_timeout_us = PARAM_APPLY_TIMEOUT_US + (int64_t)(3e6 / cfg->ctl.rate_hz);
	pthread_mutex_init(&ps->mu, NULL);
	pthread_cond_init(&ps->cv, NULL);
	return 0;
}

static void dotted_name(int key, char *buf, size_t n)
{
	const struct config_key *k = config_key_at(key);

	snprintf(buf, n, "%s.%s", k->section, k->name);
}

/* One param_value_t of the running configuration. Strings point into the scratch slot i. */
static void fill_entry(struct param_service *ps, struct param_scratch *s, int i, int key)
{
	const struct config_key *k = config_key_at(key);
	omni4_param_value_t *e = &s->entries[i];

	dotted_name(key, s->dotted[i], sizeof(s->dotted[i]));
	if (!strcmp(k->section, "params") && !strcmp(k->name, "secret"))
		snprintf(s->new_value[i], CONFIG_VALUE_MAX, "%s",
		         ps->running.fw.secret[0] ? "(set)" : "");
	else if (config_key_format(&ps->running, key, s->new_value[i], CONFIG_VALUE_MAX))
		snprintf(s->new_value[i], CONFIG_VALUE_MAX, "(unprintable)");
	*e = (omni4_param_value_t){
	    .key = s->dotted[i],
	    .value = s->new_value[i],
	    .unit = (char *)k->unit,
	    .type = (int8_t)k->type,
	    .min = k->type == CONFIG_DOUBLE || k->type == CONFIG_INT ? k->min : 0.0,
	    .max = k->type == CONFIG_DOUBLE || k->type == CONFIG_INT ? k->max : 0.0,
	    .choices = (char *)(k->choices ? k->choices : ""),
	    .change = (int8_t)k->change,
	    .doc = (char *)k->doc,
	};
}

void param_service_announce(struct param_service *ps, int64_t seq, int64_t utime)
{
	struct param_scratch *s = &ps->scratch;
	int n;

	for (n = 0; n < config_key_count() && n < PARAM_MAX_KEYS; n++) {
		fill_entry(ps, s, n, n); /* key n: the INI text; the secret only as "(set)" */
		s->old_value[n][0] = '\0';
		s->keys_p[n] = s->dotted[n];
		s->old_p[n] = s->old_value[n];
		s->new_p[n] = s->new_value[n];
	}
	s->n = n;
	param_notice(ps, s, 0, "start", ps->path, seq, utime);
}

static void do_list(struct param_service *ps, const omni4_param_request_t *q)
{
	struct param_scratch *s = &ps->scratch;
	omni4_param_reply_t r = {.request_id = q->request_id,
	                         .op = q->op,
	                         .result = OMNI4_PARAM_REPLY_T_RESULT_OK,
	                         .seq = -1};
	char why[WHY_MAX];
	int n = 0;

	if (q->op == OMNI4_PARAM_REQUEST_T_OP_GET && q->n > 0) {
		if (q->n > PARAM_MAX_KEYS) {
			snprintf(why, sizeof(why), "%d keys in one request: at most %d", q->n,
			         PARAM_MAX_KEYS);
			atomic_fetch_add(&ps->n.bad, 1);
			param_simple_reply(ps, q->request_id, q->op,
			                   OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST, why, true);
			return;
		}
		for (int i = 0; i < q->n; i++) {
			const int key = config_key_find(q->keys[i]);

			if (key < 0) {
				snprintf(why, sizeof(why), "unknown key '%.80s' (want section.key)",
				         q->keys[i]);
				atomic_fetch_add(&ps->n.bad, 1);
				param_simple_reply(ps, q->request_id, q->op,
				                   OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST, why,
				                   true);
				return;
			}
			fill_entry(ps, s, n++, key);
		}
	} else {
		for (int key = 0; key < config_key_count() && n < PARAM_MAX_KEYS; key++)
			fill_entry(ps, s, n++, key);
	}
	r.n = n;
	r.params = s->entries;
	param_reply(ps, &r, false);
}

/* SET / LOAD: collect key indices and values into the scratch. */
static int add_pair(void *ctx, int key, const char *value)
{
	struct param_scratch *s = ctx;

	if (s->n >= PARAM_MAX_KEYS) {
		s->too_many = true;
		return -1;
	}
	for (int i = 0; i < s->n; i++)
		if (s->key[i] == key)
			s->duplicate = true;
	s->key[s->n] = key;
	snprintf(s->value[s->n], CONFIG_VALUE_MAX, "%s", value);
	s->n++;
	return 0;
}

static void refuse(struct param_service *ps, const omni4_param_request_t *q, const char *why)
{
	atomic_fetch_add(&ps->n.refused, 1);
	param_simple_reply(ps, q->request_id, q->op, OMNI4_PARAM_REPLY_T_RESULT_REFUSED, why, true);
}

/* The keys whose values differ between the running configuration and ps->next,
 * into s's change list; *first_idle = the first that may change only while the bridges are not
 * driven (-1: none). Their count, or -1 with why when one may change only at a restart. */
static int collect_changes(struct param_service *ps, struct param_scratch *s, int *first_idle,
                           char *why, size_t n_why)
{
	char old_v[CONFIG_VALUE_MAX], new_v[CONFIG_VALUE_MAX];
	int changed = 0;

	*first_idle = -1;
	for (int key = 0; key < config_key_count(); key++) {
		const struct config_key *k = config_key_at(key);

		if (config_key_equal(&ps->running, &ps->next, key) ||
		    config_key_format(&ps->running, key, old_v, sizeof(old_v)) ||
		    config_key_format(&ps->next, key, new_v, sizeof(new_v)))
			continue;
		if (k->change == CONFIG_RESTART) {
			snprintf(why, n_why,
			         "%s.%s: restart only (change it in the INI and restart omni4-fw)",
			         k->section, k->name);
			return -1;
		}
		if (k->change == CONFIG_IDLE && *first_idle < 0)
			*first_idle = key;
		if (changed < PARAM_MAX_KEYS) {
			dotted_name(key, s->dotted[changed], sizeof(s->dotted[changed]));
			memcpy(s->old_value[changed], old_v, CONFIG_VALUE_MAX);
			memcpy(s->new_value[changed], new_v, CONFIG_VALUE_MAX);
			s->keys_p[changed] = s->dotted[changed];
			s->old_p[changed] = s->old_value[changed];
			s->new_p[changed] = s->new_value[changed];
			changed++;
		}
	}
	return changed;
}

/* The loop did not take the change (res.rc != 0): say why. */
static void reply_not_taken(struct param_service *ps, const omni4_param_request_t *q,
                            const struct fw_param_result *res, int first_idle)
{
	char why[WHY_MAX];

	if (res->rc == -EBUSY) {
		const struct config_key *k = config_key_at(first_idle);
		const char *mode = mode_name(res->mode);
		char undriven[64];

		undriven_modes(undriven, sizeof(undriven));
		snprintf(why, sizeof(why),
		         "%s.%s: only while the bridges are not driven (%s); "
		         "the robot is in %s: nothing changed",
		         k->section, k->name, undriven, mode ? mode : "?");
		refuse(ps, q, why);
		return;
	}
	snprintf(
	    why, sizeof(why),
	    "the loop did not take the change within %lld ms (is it running?): nothing changed",
	    (long long)(ps->apply_timeout_us / 1000));
	param_simple_reply(ps, q->request_id, q->op, OMNI4_PARAM_REPLY_T_RESULT_FAILED, why, false);
}

/* The change is in force from tick res.seq: the notice, then the reply with the changed keys'
 * new values. */
static void reply_changed(struct param_service *ps, struct param_scratch *s,
                          const omni4_param_request_t *q, const char *source, int changed,
                          const struct fw_param_result *res)
{
	char dotted[PARAM_MAX_KEYS][64];
	char why[WHY_MAX];

	memcpy(dotted, s->dotted, sizeof(dotted));
	s->n = changed;
	param_notice(ps, s, q->request_id, source, q->name ? q->name : "", res->seq, res->utime);
	for (int i = 0; i < changed; i++)
		fill_entry(ps, s, i, config_key_find(dotted[i]));
	snprintf(why, sizeof(why), "%d key%s changed, in force from tick %lld", changed,
	         changed == 1 ? "" : "s", (long long)res->seq);
	omni4_param_reply_t r = {.request_id = q->request_id,
	                         .op = q->op,
	                         .result = OMNI4_PARAM_REPLY_T_RESULT_OK,
	                         .message = why,
	                         .seq = res->seq,
	                         .n = changed,
	                         .params = s->entries};

	param_reply(ps, &r, true);
}

/* Validate s's pairs against the running configuration, have the loop take them, reply. */
static void apply_pairs(struct param_service *ps, struct param_scratch *s,
                        const omni4_param_request_t *q, const char *source)
{
	char why[WHY_MAX];
	int first_idle;

	ps->next = ps->running;
	for (int i = 0; i < s->n; i++)
		if (config_key_set(&ps->next, s->key[i], s->value[i], why, sizeof(why))) {
			refuse(ps, q, why);
			return;
		}
	const int changed = collect_changes(ps, s, &first_idle, why, sizeof(why));

	if (changed < 0 || config_check(&ps->next, why, sizeof(why)) ||
	    fw_param_prepare(ps->fw, &ps->next.ctl, first_idle >= 0, &ps->update, why,
	                     sizeof(why))) {
		refuse(ps, q, why);
		return;
	}
	if (changed == 0) {
		/* a wheel key set to the value it follows: no number changes, but it is that
		 * wheel's own from now on (saved, and no longer following its scalar) */
		ps->running.ctl.wheel_keys = ps->next.ctl.wheel_keys;
		param_simple_reply(ps, q->request_id, q->op, OMNI4_PARAM_REPLY_T_RESULT_OK,
		                   "no change: the values are already in force", true);
		return;
	}
	const struct fw_param_result res =
	    fw_param_apply(ps->fw, &ps->update, ps->apply_timeout_us);

	if (res.rc) {
		reply_not_taken(ps, q, &res, first_idle);
		return;
	}
	ps->running = ps->next;
	atomic_fetch_add(&ps->n.applied, 1);
	reply_changed(ps, s, q, source, changed, &res);
}

static void do_save(struct param_service *ps, const omni4_param_request_t *q)
{
	struct param_scratch *s = &ps->scratch;
	char why[WHY_MAX], header[160];
	const time_t now = time(NULL);
	struct tm tm;

	gmtime_r(&now, &tm);
	strftime(header, sizeof(header), "written by omni4-fw (parameter save) %Y-%m-%dT%H:%M:%SZ",
	         &tm);
	if (config_save(ps->path, &ps->running, header, why, sizeof(why))) {
		param_simple_reply(ps, q->request_id, q->op, OMNI4_PARAM_REPLY_T_RESULT_FAILED, why,
		                   true);
		return;
	}
	atomic_fetch_add(&ps->n.saved, 1);
	s->n = 0;
	param_notice(ps, s, q->request_id, "save", ps->path, -1, rtloop_clock_us());
	/* the file written: a symbolic link's target (its .bak beside it), the link kept */
	char written[PATH_MAX], message[WHY_MAX + 8];

	snprintf(message, sizeof(message), "saved; %s", why);

	if (omni4_out_resolve(ps->path, written, sizeof(written)))
		snprintf(written, sizeof(written), "%s", ps->path);
	omni4_param_reply_t r = {.request_id = q->request_id,
	                         .op = q->op,
	                         .result = OMNI4_PARAM_REPLY_T_RESULT_OK,
	                         .message = message,
	                         .seq = -1,
	                         .path = written};

	param_reply(ps, &r, true);
}

/* SET: the keys by name into s, then applied. 0, or -1 with why (a bad request). */
static int do_set(struct param_service *ps, struct param_scratch *s, const omni4_param_request_t *q,
                  char *why, size_t n_why)
{
	if (q->n < 1 || q->n > PARAM_MAX_KEYS) {
		snprintf(why, n_why, "SET with %d keys: 1 to %d", q->n, PARAM_MAX_KEYS);
		return -1;
	}
	for (int i = 0; i < q->n; i++) {
		const int key = config_key_find(q->keys[i]);

		if (key < 0) {
			snprintf(why, n_why, "unknown key '%.80s' (want section.key)", q->keys[i]);
			return -1;
		}
		add_pair(s, key, q->values[i]);
	}
	if (s->duplicate) {
		snprintf(why, n_why, "a key appears twice in one SET");
		return -1;
	}
	apply_pairs(ps, s, q, "set");
	return 0;
}

/* LOAD: the INI text's keys into s, then applied. 0, or -1 with why (a bad request). */
static int do_load(struct param_service *ps, struct param_scratch *s,
                   const omni4_param_request_t *q, char *why, size_t n_why)
{
	const char *name = q->name[0] ? q->name : "(load)";
	struct config_error err;

	if (strlen(q->text) > PARAM_MAX_TEXT) {
		snprintf(why, n_why, "LOAD text of %zu bytes: at most %d", strlen(q->text),
		         PARAM_MAX_TEXT);
		return -1;
	}
	if (config_parse_pairs(q->text, name, add_pair, s, &err)) {
		snprintf(why, n_why, "%s", err.msg);
		return -1;
	}
	if (s->n == 0) {
		snprintf(why, n_why, "%s: no keys", name);
		return -1;
	}
	apply_pairs(ps, s, q, "load");
	return 0;
}

/* One decoded request, its secret checked. 0, or -1 with why (a bad request). */
static int dispatch(struct param_service *ps, struct param_scratch *s,
                    const omni4_param_request_t *q, char *why, size_t n_why)
{
	switch (q->op) {
	case OMNI4_PARAM_REQUEST_T_OP_LIST:
	case OMNI4_PARAM_REQUEST_T_OP_GET:
		do_list(ps, q);
		return 0;
	case OMNI4_PARAM_REQUEST_T_OP_SET:
		return do_set(ps, s, q, why, n_why);
	case OMNI4_PARAM_REQUEST_T_OP_LOAD:
		return do_load(ps, s, q, why, n_why);
	case OMNI4_PARAM_REQUEST_T_OP_SAVE:
		do_save(ps, q);
		return 0;
	default:
		snprintf(why, n_why, "unknown op %d", q->op);
		return -1;
	}
}

void param_service_handle(struct param_service *ps, const void *data, size_t len)
{
	omni4_param_request_t q;
	struct param_scratch *s = &ps->scratch;
	char why[WHY_MAX];

	atomic_fetch_add(&ps->n.requests, 1);
	char wire[96] = "";

	if (len > INT32_MAX ||
	    !param_request_wire_ok(data, len, 16 * PARAM_MAX_KEYS, wire, sizeof(wire)) ||
	    omni4_param_request_t_decode(data, 0, (int)len, &q) != (int)len) {
		snprintf(why, sizeof(why), "undecodable param_request_t (%zu bytes)%s%s", len,
		         wire[0] ? ": " : "", wire);
		atomic_fetch_add(&ps->n.bad, 1);
		param_simple_reply(ps, 0, 0, OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST, why, false);
		return;
	}
	if (param_cache_replay(ps, q.request_id))
		goto out;
	const bool writes = q.op == OMNI4_PARAM_REQUEST_T_OP_SET ||
	                    q.op == OMNI4_PARAM_REQUEST_T_OP_LOAD ||
	                    q.op == OMNI4_PARAM_REQUEST_T_OP_SAVE;

	if (writes && ps->running.fw.secret[0] && strcmp(q.secret, ps->running.fw.secret)) {
		atomic_fetch_add(&ps->n.denied, 1);
		param_simple_reply(ps, q.request_id, q.op, OMNI4_PARAM_REPLY_T_RESULT_DENIED,
		                   "wrong or missing secret (the robot's INI sets [params] secret)",
		                   false);
		goto out;
	}
	memset(s->key, 0, sizeof(s->key));
	s->n = 0;
	s->too_many = s->duplicate = false;
	if (dispatch(ps, s, &q, why, sizeof(why))) {
		atomic_fetch_add(&ps->n.bad, 1);
		param_simple_reply(ps, q.request_id, q.op, OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST,
		                   why, true);
	}
out:
	omni4_param_request_t_decode_cleanup(&q);
}

void param_service_busy(struct param_service *ps, const void *data, size_t len)
{
	atomic_fetch_add(&ps->n.busy, 1);

	omni4_param_request_t q;

	char wire[96];

	if (len <= INT32_MAX &&
	    param_request_wire_ok(data, len, 16 * PARAM_MAX_KEYS, wire, sizeof(wire)) &&
	    omni4_param_request_t_decode(data, 0, (int)len, &q) == (int)len) {
		omni4_param_reply_t r = {.utime = rtloop_clock_us(),
		                         .request_id = q.request_id,
		                         .op = q.op,
		                         .result = OMNI4_PARAM_REPLY_T_RESULT_BUSY,
		                         .message = "busy: too many requests queued, try again",
		                         .seq = -1,
		                         .path = ""};
		unsigned char buf[256];
		const int n = omni4_param_reply_t_encode(buf, 0, sizeof(buf), &r);

		if (n > 0)
			param_emit(ps, OMNI4_CHANNEL_PARAM_REPLY, buf, (size_t)n);
		omni4_param_request_t_decode_cleanup(&q);
	}
}
