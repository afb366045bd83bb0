/* config.c - INI parsing (inih) into struct omni4_config, table driven, line-numbered errors. */
#include "omni4/config.h"

#include <errno.h>
#include <ini.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

enum key_type { KEY_DOUBLE, KEY_INT, KEY_BOOL, KEY_STRING };

struct key_desc {
	const char *section;
	const char *name;
	enum key_type type;
	size_t offset;
	double min, max; /* inclusive range for numbers */
	const char *choices; /* for strings: "a|b|c", NULL = any */
};

#define OFF(field) offsetof(struct omni4_config, field)
#define DBL(sec, key, field, lo, hi) {sec, key, KEY_DOUBLE, OFF(field), lo, hi, NULL}
#define INT(sec, key, field, lo, hi) {sec, key, KEY_INT, OFF(field), lo, hi, NULL}
#define BOOL(sec, key, field) {sec, key, KEY_BOOL, OFF(field), 0, 1, NULL}
#define STR(sec, key, field, ch) {sec, key, KEY_STRING, OFF(field), 0, 0, ch}

/* [model] keys come first, in model_params_names order (checked at start-up of the table). */
static const struct key_desc keys[] = {
	DBL("model", "d", model.d, -INFINITY, INFINITY),
	DBL("model", "r", model.r, -INFINITY, INFINITY),
	DBL("model", "l", model.l, -INFINITY, INFINITY),
	DBL("model", "Kv", model.Kv, -INFINITY, INFINITY),
	DBL("model", "Kt", model.Kt, -INFINITY, INFINITY),
	DBL("model", "R", model.R, -INFINITY, INFINITY),
	DBL("model", "M", model.M, -INFINITY, INFINITY),
	DBL("model", "J", model.J, -INFINITY, INFINITY),
	DBL("model", "Bv", model.Bv, -INFINITY, INFINITY),
	DBL("model", "Bvn", model.Bvn, -INFINITY, INFINITY),
	DBL("model", "Bw", model.Bw, -INFINITY, INFINITY),
	DBL("model", "Cv", model.Cv, -INFINITY, INFINITY),
	DBL("model", "Cvn", model.Cvn, -INFINITY, INFINITY),
	DBL("model", "Cw", model.Cw, -INFINITY, INFINITY),
	DBL("loop", "rate_hz", loop.rate_hz, 1.0, 20000.0),
	BOOL("loop", "sched_fifo", loop.sched_fifo),
	INT("loop", "priority", loop.priority, 1, 99),
	BOOL("loop", "mlockall", loop.mlockall),
	INT("loop", "cpu_dma_latency_us", loop.cpu_dma_latency_us, -1, 100000),
	DBL("control", "kp", control.kp, 0.0, 1e4),
	DBL("control", "ki", control.ki, 0.0, 1e6),
	BOOL("control", "feedforward", control.feedforward),
	BOOL("control", "feedback", control.feedback),
	INT("control", "cmd_timeout_ms", control.cmd_timeout_ms, 1, 600000),
	DBL("control", "stop_ramp_s", control.stop_ramp_s, 0.0, 60.0),
	DBL("limits", "supply_v", limits.supply_v, 0.1, 1000.0),
	DBL("limits", "supply_min_v", limits.supply_min_v, 0.0, 1000.0),
	DBL("limits", "vel_lin_max", limits.vel_lin_max, 0.0, 100.0),
	DBL("limits", "vel_rot_max", limits.vel_rot_max, 0.0, 1000.0),
	DBL("limits", "acc_lin_max", limits.acc_lin_max, 1e-3, 1000.0),
	DBL("limits", "acc_rot_max", limits.acc_rot_max, 1e-3, 10000.0),
	DBL("limits", "current_max_a", limits.current_max_a, 0.0, 1000.0),
	DBL("limits", "current_sensor_max_a", limits.current_sensor_max_a, 0.0, 1000.0),
	STR("lcm", "url", lcm.url, NULL),
	STR("hal", "motor", hal.motor, "sim|socketcan"),
	STR("hal", "lines", hal.lines, "none|sim|gpiod"),
	DBL("sim", "current_noise_a", sim.current_noise_a, 0.0, 100.0),
	INT("sim", "encoder_cpr", sim.encoder_cpr, 0, 1 << 24),
	DBL("sim", "camera_rate_hz", sim.camera_rate_hz, 0.1, 10000.0),
	DBL("sim", "camera_pos_noise_m", sim.camera_pos_noise_m, 0.0, 10.0),
	DBL("sim", "camera_theta_noise_rad", sim.camera_theta_noise_rad, 0.0, 10.0),
	INT("sim", "seed", sim.seed, 0, 2147483647),
	STR("can", "iface", can.iface, NULL),
	INT("can", "bitrate", can.bitrate, 10000, 8000000),
	INT("can", "status_timeout_ms", can.status_timeout_ms, 1, 10000),
	STR("gpio", "chip", gpio.chip, NULL),
	INT("gpio", "estop_line", gpio.estop_line, -1, 4095),
	BOOL("gpio", "estop_active_low", gpio.estop_active_low),
	INT("gpio", "enable_line", gpio.enable_line, -1, 4095),
	INT("gpio", "led_line", gpio.led_line, -1, 4095),
};

#define N_KEYS (sizeof(keys) / sizeof(keys[0]))

struct parse_state {
	struct omni4_config *cfg;
	struct config_error *err;
	const char *name;
	bool seen[N_KEYS];
	bool failed;
	bool partial_model; /* [model] may be incomplete; not checked */
	int line; /* current line, counted by the handler from inih's reports */
};

void config_defaults(struct omni4_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	cfg->model = model_params_table3;
	cfg->loop.rate_hz = 1000.0;
	cfg->loop.sched_fifo = false;
	cfg->loop.priority = 80;
	cfg->loop.mlockall = false;
	cfg->loop.cpu_dma_latency_us = -1;
	cfg->control.kp = 20.0;
	cfg->control.ki = 200.0;
	cfg->control.feedforward = true;
	cfg->control.feedback = true;
	cfg->control.cmd_timeout_ms = 200;
	cfg->control.stop_ramp_s = 0.2;
	cfg->limits.supply_v = 12.0;
	cfg->limits.supply_min_v = 9.0;
	cfg->limits.vel_lin_max = 3.0;
	cfg->limits.vel_rot_max = 20.0;
	cfg->limits.acc_lin_max = 3.0;
	cfg->limits.acc_rot_max = 30.0;
	cfg->limits.current_max_a = 5.0;
	cfg->limits.current_sensor_max_a = 10.2; /* the CAN STATUS current range ends at 10.235 A */
	snprintf(cfg->lcm.url, sizeof(cfg->lcm.url), "udpm://239.255.76.67:7667?ttl=0");
	snprintf(cfg->hal.motor, sizeof(cfg->hal.motor), "sim");
	snprintf(cfg->hal.lines, sizeof(cfg->hal.lines), "sim");
	cfg->sim.current_noise_a = 0.02;
	cfg->sim.encoder_cpr = 10240; /* 2048 counts per motor turn x gearbox 5 */
	cfg->sim.camera_rate_hz = 25.0;
	cfg->sim.camera_pos_noise_m = 0.01;
	cfg->sim.camera_theta_noise_rad = 3.0 * M_PI / 180.0;
	cfg->sim.seed = 1;
	snprintf(cfg->can.iface, sizeof(cfg->can.iface), "can0");
	cfg->can.bitrate = 1000000;
	cfg->can.status_timeout_ms = 5;
	snprintf(cfg->gpio.chip, sizeof(cfg->gpio.chip), "gpiochip0");
	cfg->gpio.estop_line = -1;
	cfg->gpio.estop_active_low = true;
	cfg->gpio.enable_line = -1;
	cfg->gpio.led_line = -1;
}

static int fail(struct parse_state *st, int line, const char *what, const char *section,
		const char *name, const char *detail)
{
	if (st->failed)
		return 0;
	st->failed = true;
	st->err->line = line;
	if (line > 0)
		snprintf(st->err->msg, sizeof(st->err->msg), "%s:%d: %s '%s' in [%s]%s%s", st->name,
			 line, what, name, section, detail ? ": " : "", detail ? detail : "");
	else
		snprintf(st->err->msg, sizeof(st->err->msg), "%s: %s '%s' in [%s]%s%s", st->name,
			 what, name, section, detail ? ": " : "", detail ? detail : "");
	return 0;
}

static bool parse_bool(const char *v, bool *out)
{
	static const char *const yes[] = {"1", "true", "yes", "on"};
	static const char *const no[] = {"0", "false", "no", "off"};

	for (size_t i = 0; i < 4; i++) {
		if (!strcasecmp(v, yes[i])) {
			*out = true;
			return true;
		}
		if (!strcasecmp(v, no[i])) {
			*out = false;
			return true;
		}
	}
	return false;
}

static bool in_choices(const char *v, const char *choices)
{
	const size_t n = strlen(v);

	for (const char *c = choices; c && *c;) {
		const char *bar = strchr(c, '|');
		const size_t len = bar ? (size_t)(bar - c) : strlen(c);

		if (len == n && !strncmp(c, v, n))
			return true;
		c = bar ? bar + 1 : NULL;
	}
	return false;
}

static int set_value(struct parse_state *st, const struct key_desc *k, const char *value, int line)
{
	char *base = (char *)st->cfg + k->offset;
	char detail[128];
	char *end;

	switch (k->type) {
	case KEY_DOUBLE: {
		errno = 0;
		const double v = strtod(value, &end);

		if (end == value || *end || errno == ERANGE || !isfinite(v)) {
			snprintf(detail, sizeof(detail), "'%.60s' is not a finite number", value);
			return fail(st, line, "bad value for", k->section, k->name, detail);
		}
		if (v < k->min || v > k->max) {
			snprintf(detail, sizeof(detail), "%g outside [%g, %g]", v, k->min, k->max);
			return fail(st, line, "out of range value for", k->section, k->name, detail);
		}
		memcpy(base, &v, sizeof(v)); /* base: a double field of the struct */
		return 1;
	}
	case KEY_INT: {
		errno = 0;
		const long v = strtol(value, &end, 10);

		if (end == value || *end || errno == ERANGE) {
			snprintf(detail, sizeof(detail), "'%.60s' is not an integer", value);
			return fail(st, line, "bad value for", k->section, k->name, detail);
		}
		if (v < k->min || v > k->max) {
			snprintf(detail, sizeof(detail), "%ld outside [%g, %g]", v, k->min, k->max);
			return fail(st, line, "out of range value for", k->section, k->name, detail);
		}
		const int iv = (int)v;

		memcpy(base, &iv, sizeof(iv));
		return 1;
	}
	case KEY_BOOL:
		if (!parse_bool(value, (bool *)base)) {
			snprintf(detail, sizeof(detail), "'%.60s' is not true/false", value);
			return fail(st, line, "bad value for", k->section, k->name, detail);
		}
		return 1;
	case KEY_STRING:
		if (strlen(value) >= CONFIG_STR_MAX)
			return fail(st, line, "too long value for", k->section, k->name, NULL);
		if (k->choices && !in_choices(value, k->choices)) {
			snprintf(detail, sizeof(detail), "'%.60s' is not one of %s", value, k->choices);
			return fail(st, line, "bad value for", k->section, k->name, detail);
		}
		snprintf(base, CONFIG_STR_MAX, "%s", value);
		return 1;
	}
	return 0;
}

static int on_line(void *user, int line, const char *section, const char *name, const char *value)
{
	struct parse_state *st = user;

	for (size_t i = 0; i < N_KEYS; i++) {
		if (strcmp(keys[i].section, section) || strcmp(keys[i].name, name))
			continue;
		if (st->seen[i])
			return fail(st, line, "duplicate key", section, name, NULL);
		st->seen[i] = true;
		return set_value(st, &keys[i], value, line);
	}
	return fail(st, line, "unknown key", section, name, NULL);
}

static int after_parse(struct parse_state *st, int rc)
{
	if (rc == -1) {
		snprintf(st->err->msg, sizeof(st->err->msg), "%s: cannot open: %s", st->name,
			 strerror(errno));
		return -ENOENT;
	}
	if (rc == -2) {
		snprintf(st->err->msg, sizeof(st->err->msg), "%s: out of memory", st->name);
		return -ENOMEM;
	}
	if (rc > 0 && !st->failed) {
		st->err->line = rc;
		snprintf(st->err->msg, sizeof(st->err->msg),
			 "%s:%d: syntax error (expected [section] or key = value)", st->name, rc);
		return -EINVAL;
	}
	if (st->failed)
		return -EINVAL;

	/* [model]: all or nothing, and physically meaningful. */
	bool any = false;

	for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
		any |= st->seen[i];
	if (st->partial_model)
		return 0;
	for (int i = 0; any && i < MODEL_PARAMS_COUNT; i++)
		if (!st->seen[i]) {
			fail(st, 0, "missing key", "model", model_params_names[i], NULL);
			return -EINVAL;
		}
	int bad = 0;

	if (model_params_check(&st->cfg->model, &bad)) {
		fail(st, 0, "invalid value for", "model", model_params_names[bad],
		     bad < 8 ? "must be > 0" : "must be >= 0");
		return -EINVAL;
	}
	if (st->cfg->limits.supply_min_v >= st->cfg->limits.supply_v) {
		fail(st, 0, "invalid value for", "limits", "supply_min_v", "must be below supply_v");
		return -EINVAL;
	}
	return 0;
}

/*
 * inih reports no line number to the handler in its default build; count lines ourselves by
 * using ini_parse_stream with a reader that tracks them.
 */
struct line_reader {
	const char *text; /* string source, or NULL */
	FILE *f;          /* file source */
	int line;
	bool mid_line; /* the last chunk did not end a line (line longer than inih's buffer) */
};

static char *read_line(char *buf, int size, void *stream)
{
	struct line_reader *r = stream;

	if (r->f) {
		if (!fgets(buf, size, r->f))
			return NULL;
	} else {
		if (!*r->text)
			return NULL;
		int n = 0;

		while (n < size - 1 && r->text[n] && r->text[n] != '\n')
			n++;
		if (r->text[n] == '\n' && n < size - 1)
			n++;
		memcpy(buf, r->text, (size_t)n);
		buf[n] = '\0';
		r->text += n;
	}
	if (!r->mid_line)
		r->line++;
	const size_t len = strlen(buf);

	r->mid_line = len > 0 && buf[len - 1] != '\n';
	return buf;
}

struct handler_ctx {
	struct parse_state *st;
	struct line_reader *reader;
};

static int handler(void *user, const char *section, const char *name, const char *value)
{
	struct handler_ctx *h = user;

	return on_line(h->st, h->reader->line, section, name, value);
}

static int parse(struct line_reader *reader, const char *name, struct omni4_config *cfg,
		 struct config_error *err, uint32_t *model_seen)
{
	struct parse_state st = {.cfg = cfg, .err = err, .name = name,
				 .partial_model = model_seen != NULL};
	struct handler_ctx h = {.st = &st, .reader = reader};
	int rc;

	err->line = 0;
	err->msg[0] = '\0';
	rc = after_parse(&st, ini_parse_stream(read_line, reader, handler, &h));
	if (model_seen) {
		*model_seen = 0;
		for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
			*model_seen |= st.seen[i] ? 1u << i : 0u;
	}
	return rc;
}

static int load_file(const char *path, struct omni4_config *cfg, struct config_error *err,
		     uint32_t *model_seen)
{
	struct line_reader r = {.f = fopen(path, "r")};
	int rc;

	if (!r.f) {
		snprintf(err->msg, sizeof(err->msg), "%s: cannot open: %s", path, strerror(errno));
		err->line = 0;
		return -ENOENT;
	}
	rc = parse(&r, path, cfg, err, model_seen);
	fclose(r.f);
	return rc;
}

int config_load(const char *path, struct omni4_config *cfg, struct config_error *err)
{
	return load_file(path, cfg, err, NULL);
}

int config_load_partial(const char *path, struct omni4_config *cfg, uint32_t *model_seen,
			struct config_error *err)
{
	return load_file(path, cfg, err, model_seen);
}

int config_load_string(const char *text, const char *name, struct omni4_config *cfg,
		       struct config_error *err)
{
	struct line_reader r = {.text = text};

	return parse(&r, name, cfg, err, NULL);
}

int config_write_model(FILE *f, const struct model_params *p)
{
	if (fprintf(f, "[model]\n") < 0)
		return -EIO;
	for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
		if (fprintf(f, "%s = %.17g\n", model_params_names[i], model_params_get(p, i)) < 0)
			return -EIO;
	return 0;
}
