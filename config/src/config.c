/* config.c - the one table of INI keys (section, name, type, field, range, unit, when it may
 * change, doc) built from each layer's key list, the defaults, and each key's value: parsed and
 * range-checked, formatted as the INI holds it, compared; the checks across keys. The reader is
 * config_read.c, the writer and the file save config_save.c. */
#include "omni4/config/config.h"
#include "config_table.h"

#include "omni4/lcmtypes/channels.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define INF INFINITY
#define LIVE CONFIG_LIVE
#define IDLE CONFIG_IDLE
#define RESTART CONFIG_RESTART
#define CONFIG_DBL CONFIG_DOUBLE
#define CONFIG_STR CONFIG_STRING

/* A row of a layer's key list (ctl_keys.def and the others) as a row of the table, its field
 * located in struct omni4_config under member `part`. */
#define ROW(part, kind, section, key, field, def, lo, hi, choices, unit, change, doc)              \
	{section,                                                                                  \
	 key,                                                                                      \
	 CONFIG_##kind,                                                                            \
	 offsetof(struct omni4_config, part.field),                                                \
	 sizeof(((struct omni4_config *)0)->part.field),                                           \
	 lo,                                                                                       \
	 hi,                                                                                       \
	 choices,                                                                                  \
	 unit,                                                                                     \
	 change,                                                                                   \
	 doc},

/* The [hal] choices, "|sim|socketcan" and "|none|sim|gpiod": backends.def's INI words in the
 * enums' order (the table takes each from its first word on). */
static const char motor_words[] =
#define OMNI4_BACKEND(hal, name, word, ...) BACKEND_MOTOR_##hal("|" word)
#include "omni4/drivers/backends.def"
    ;
static const char lines_words[] =
#define OMNI4_BACKEND(hal, name, word, ...) BACKEND_LINES_##hal("|" word)
#include "omni4/drivers/backends.def"
    ;
#define OMNI4_MOTOR_CHOICES (motor_words + 1)
#define OMNI4_LINES_CHOICES (lines_words + 1)

/*
 * The one table of keys: the INI parser, the writer and the parameter service (over LCM) all
 * use it, and docs/ini-keys.md is generated from it. [model] keys come first, in
 * model_params_names order (test_config checks it); their real check is on the whole model
 * (ctl_settings_check), after all keys are in.
 */
const struct config_key config_keys[] = {
#define OMNI4_KEY(...) ROW(ctl, __VA_ARGS__)
#include "omni4/core/ctl_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(kind, section, key, field, ...)                                                  \
	ROW(ctl, kind, section, key, est.field, __VA_ARGS__)
#include "omni4/core/est_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(...) ROW(fw, __VA_ARGS__)
#include "omni4/config/fw_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(...) ROW(OMNI4_BACKEND_MEMBER, __VA_ARGS__)
#include "omni4/drivers/backend_keys.inc"
#undef OMNI4_KEY
};

/* A default as the field takes it: strings copied (they fit: a static check), the rest set. */
#define DEFAULT_DBL(dst, def) (dst) = (def)
#define DEFAULT_INT(dst, def) (dst) = (def)
#define DEFAULT_BOOL(dst, def) (dst) = (def)
#define DEFAULT_ENUM(dst, def) (dst) = (def)
#define DEFAULT_STR(dst, def)                                                                      \
	do {                                                                                       \
		_Static_assert(sizeof(def) <= sizeof(dst), "default too long");                    \
		memcpy((dst), (def), sizeof(def));                                                 \
	} while (0)

void config_defaults(struct omni4_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	ctl_settings_defaults(&cfg->ctl);
#define OMNI4_KEY(kind, section, key, field, def, ...) DEFAULT_##kind(cfg->fw.field, def);
#include "omni4/config/fw_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(kind, section, key, field, def, ...)                                             \
	DEFAULT_##kind(cfg->OMNI4_BACKEND_MEMBER.field, def);
#include "omni4/drivers/backend_keys.inc"
#undef OMNI4_KEY
}

#define N_KEYS (sizeof(config_keys) / sizeof(config_keys[0]))
_Static_assert(N_KEYS <= CONFIG_KEYS_MAX, "CONFIG_KEYS_MAX: room for every key");
const size_t config_n_keys = N_KEYS;

/* Key k's index 4 q + j in ctl.wheels if it is a per-wheel [model] key (its field lies in
 * ctl.wheels, whose doubles are in CTL_WHEEL_KEY's order), else -1. */
static int wheel_index(const struct config_key *k)
{
	const size_t base = offsetof(struct omni4_config, ctl.wheels);

	if (k->offset < base || k->offset >= base + sizeof(struct model_wheels))
		return -1;
	return (int)((k->offset - base) / sizeof(double));
}

/* Key k's wheel in ctl.layout.d (d_j), -1 if it is not one. */
static int dist_index(const struct config_key *k)
{
	const size_t base = offsetof(struct omni4_config, ctl.layout.d);

	if (k->offset < base || k->offset >= base + 4 * sizeof(double))
		return -1;
	return (int)((k->offset - base) / sizeof(double));
}

uint8_t config_dist_bit(const struct config_key *k)
{
	const int i = dist_index(k);

	return i < 0 ? 0 : (uint8_t)(1u << i);
}

/* Key k's bit in ctl.wheel_keys, 0 if it is not a per-wheel key. */
uint16_t config_wheel_bit(const struct config_key *k)
{
	const int i = wheel_index(k);

	return i < 0 ? 0 : (uint16_t)(1u << i);
}

/* After key k took a value: a wheel key is that wheel's own from now on; every wheel without
 * its own key takes its scalar (which may just have changed). */
static void wheel_keys_after(struct omni4_config *cfg, const struct config_key *k)
{
	cfg->ctl.wheel_keys |= config_wheel_bit(k);
	cfg->ctl.layout_keys |= config_dist_bit(k);
	ctl_settings_wheels_follow(&cfg->ctl);
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

/* Index of v in "a|b|c", or -1. */
static int choice_index(const char *v, const char *choices)
{
	const size_t n = strlen(v);
	int i = 0;

	for (const char *c = choices; c && *c; i++) {
		const char *bar = strchr(c, '|');
		const size_t len = bar ? (size_t)(bar - c) : strlen(c);

		if (len == n && !strncmp(c, v, n))
			return i;
		c = bar ? bar + 1 : NULL;
	}
	return -1;
}

/* Choice i of "a|b|c" into buf; snprintf's return, -1 if there is none. */
static int choice_name(const char *choices, int i, char *buf, size_t n)
{
	const char *c = choices;

	for (; c && i > 0; i--) {
		c = strchr(c, '|');
		c = c ? c + 1 : NULL;
	}
	if (!c || i < 0)
		return -1;
	const char *bar = strchr(c, '|');

	return snprintf(buf, n, "%.*s", (int)(bar ? bar - c : (long)strlen(c)), c);
}

/* A decimal number as the INI and every reader of it write one (the Python package takes the
 * same): [+-] digits [. digits] [e [+-] digits], with digits before or after the point; no
 * blanks, no hexadecimal, no inf or nan, no digit separators. */
static bool decimal_syntax(const char *s)
{
	size_t i = (*s == '+' || *s == '-') ? 1 : 0, lead = 0, frac = 0;

	for (; s[i] >= '0' && s[i] <= '9'; i++)
		lead++;
	if (s[i] == '.')
		for (i++; s[i] >= '0' && s[i] <= '9'; i++)
			frac++;
	if (lead + frac == 0)
		return false;
	if (s[i] == 'e' || s[i] == 'E') {
		size_t exp = 0;

		i += (s[i + 1] == '+' || s[i + 1] == '-') ? 2 : 1;
		for (; s[i] >= '0' && s[i] <= '9'; i++)
			exp++;
		if (exp == 0)
			return false;
	}
	return s[i] == '\0';
}

/* A number of key k (double, or int when integer): a decimal number, finite, within the key's
 * range (a value too small for a double, such as 4e-320, is out of range, not malformed).
 * 0, or -EINVAL with what and detail. */
static int parse_number(const struct config_key *k, const char *value, bool integer, double *v,
                        const char **what, char *detail, size_t n)
{
	char *end;

	errno = 0;
	*v = integer ? (double)strtol(value, &end, 10) : strtod(value, &end);
	if (!integer && errno == ERANGE && fabs(*v) < 1.0)
		errno = 0; /* underflow: a tiny but readable number, judged by the range below */
	if (!decimal_syntax(value) || end == value || *end || errno == ERANGE || !isfinite(*v) ||
	    (integer && strpbrk(value, ".eE"))) {
		snprintf(detail, n, "'%.60s' is not %s", value,
		         integer ? "an integer" : "a finite number");
		*what = "bad value";
		return -EINVAL;
	}
	if (*v < k->min || *v > k->max) {
		snprintf(detail, n, integer ? "%.0f outside [%g, %g]" : "%g outside [%g, %g]", *v,
		         k->min, k->max);
		*what = "out of range value";
		return -EINVAL;
	}
	return 0;
}

/* A word of key k's choices, stored as its index. 0, or -EINVAL with what and detail. */
static int parse_choice(const struct config_key *k, const char *value, char *base,
                        const char **what, char *detail, size_t n)
{
	const int iv = choice_index(value, k->choices);

	if (iv < 0) {
		snprintf(detail, n, "'%.60s' is not one of %s", value, k->choices);
		*what = "bad value";
		return -EINVAL;
	}
	memcpy(base, &iv, sizeof(iv));
	return 0;
}

/*
 * Parse value into key k of cfg, range-checked. 0, or -EINVAL with what ("bad value",
 * "out of range value", "too long value") and detail ("" or why) filled in.
 */
int config_key_parse(const struct config_key *k, const char *value, struct omni4_config *cfg,
                     const char **what, char *detail, size_t n)
{
	char *base = (char *)cfg + k->offset;
	double v;

	detail[0] = '\0';
	switch (k->type) {
	case CONFIG_DOUBLE:
		if (parse_number(k, value, false, &v, what, detail, n))
			return -EINVAL;
		memcpy(base, &v, sizeof(v)); /* base: a double field of the struct */
		return 0;
	case CONFIG_INT: {
		if (parse_number(k, value, true, &v, what, detail, n))
			return -EINVAL;
		const int iv = (int)v; /* within the key's range, which is within int's */

		memcpy(base, &iv, sizeof(iv));
		return 0;
	}
	case CONFIG_BOOL:
		if (!parse_bool(value, (bool *)base)) {
			snprintf(detail, n, "'%.60s' is not true/false", value);
			*what = "bad value";
			return -EINVAL;
		}
		return 0;
	case CONFIG_STRING:
		if (strlen(value) >= k->size) {
			snprintf(detail, n, "at most %zu characters", k->size - 1);
			*what = "too long value";
			return -EINVAL;
		}
		snprintf(base, k->size, "%s", value);
		return 0;
	case CONFIG_ENUM:
		return parse_choice(k, value, base, what, detail, n);
	}
	*what = "bad value";
	return -EINVAL;
}

/* Checks across keys; index of the offending key in *bad_key, its reason in why. */
int config_check_whole(const struct omni4_config *cfg, int *bad_key, const char **why)
{
	if (!ctl_settings_check(&cfg->ctl, bad_key, why))
		return 0;
	/* [model] keys are the first MODEL_PARAMS_COUNT of the table; the other rule is on
	 * supply_min_v (rate_hz is range-checked as a key). */
	if (*bad_key < 0) {
		*bad_key = config_key_find("limits.supply_min_v");
		*why = "must be below supply_v";
	}
	return -EINVAL;
}

int config_format_double(char *buf, size_t n, double v)
{
	int len = -1;

	/* The shortest of %.15g .. %.17g that reads back to the same double. */
	for (int digits = 15; digits <= 17; digits++) {
		len = snprintf(buf, n, "%.*g", digits, v);
		if (len < 0 || (size_t)len >= n || strtod(buf, NULL) == v)
			break;
	}
	return len;
}

int config_key_count(void)
{
	return (int)N_KEYS;
}

const struct config_key *config_key_at(int i)
{
	return i >= 0 && i < (int)N_KEYS ? &config_keys[i] : NULL;
}

int config_key_find(const char *dotted)
{
	const char *dot = dotted ? strchr(dotted, '.') : NULL;

	if (!dot)
		return -1;
	const size_t slen = (size_t)(dot - dotted);

	for (size_t i = 0; i < N_KEYS; i++)
		if (strlen(config_keys[i].section) == slen &&
		    !strncmp(config_keys[i].section, dotted, slen) &&
		    !strcmp(config_keys[i].name, dot + 1))
			return (int)i;
	return -1;
}

/* A string that inih reads back unchanged: no comment or line characters, no outer blanks. */
static bool string_writable(const char *v)
{
	const size_t n = strlen(v);

	if (strpbrk(v, ";#\r\n"))
		return false;
	return n == 0 || (v[0] != ' ' && v[0] != '\t' && v[n - 1] != ' ' && v[n - 1] != '\t');
}

/* A double key's value in force: a wheel key without a value of its own follows its scalar. */
static double key_double(const struct omni4_config *cfg, const struct config_key *k)
{
	double v;

	memcpy(&v, (const char *)cfg + k->offset, sizeof(v));
	if (wheel_index(k) >= 0) {
		struct model_wheels w;
		double all[CTL_WHEEL_KEYS];

		_Static_assert(sizeof(w) == sizeof(all), "struct model_wheels: 16 doubles");
		ctl_settings_wheels(&cfg->ctl, &w);
		memcpy(all, &w, sizeof(all));
		v = all[wheel_index(k)];
	}
	if (dist_index(k) >= 0 && !(cfg->ctl.layout_keys & config_dist_bit(k)))
		v = cfg->ctl.model.d;
	return v;
}

bool config_key_equal(const struct omni4_config *a, const struct omni4_config *b, int i)
{
	const struct config_key *k = config_key_at(i);

	if (!k)
		return true;
	const char *pa = (const char *)a + k->offset, *pb = (const char *)b + k->offset;

	switch (k->type) {
	case CONFIG_DOUBLE: {
		const double va = key_double(a, k), vb = key_double(b, k);

		return !memcmp(&va, &vb, sizeof(va)); /* bits: 0.0 and -0.0 are two values */
	}
	case CONFIG_STRING:
		return !strncmp(pa, pb, k->size);
	case CONFIG_BOOL:
		return *(const bool *)pa == *(const bool *)pb;
	case CONFIG_INT:
	case CONFIG_ENUM:
		return !memcmp(pa, pb, sizeof(int));
	}
	return false;
}

int config_key_format(const struct omni4_config *cfg, int i, char *buf, size_t n)
{
	const struct config_key *k = config_key_at(i);

	if (!k || n == 0)
		return -EINVAL;
	const char *base = (const char *)cfg + k->offset;
	int len = -1;

	switch (k->type) {
	case CONFIG_DOUBLE:
		len = config_format_double(buf, n, key_double(cfg, k));
		break;
	case CONFIG_INT: {
		int v;

		memcpy(&v, base, sizeof(v));
		len = snprintf(buf, n, "%d", v);
		break;
	}
	case CONFIG_BOOL:
		len = snprintf(buf, n, "%s", *(const bool *)base ? "true" : "false");
		break;
	case CONFIG_STRING:
		if (!string_writable(base))
			return -EINVAL;
		len = snprintf(buf, n, "%s", base);
		break;
	case CONFIG_ENUM: {
		int v;

		memcpy(&v, base, sizeof(v));
		len = choice_name(k->choices, v, buf, n);
		break;
	}
	}
	return len >= 0 && (size_t)len < n ? 0 : -ENOSPC;
}

int config_key_set(struct omni4_config *cfg, int i, const char *value, char *why, size_t n)
{
	const struct config_key *k = config_key_at(i);
	const char *what = NULL;
	char detail[128];

	if (!k) {
		snprintf(why, n, "no such key");
		return -EINVAL;
	}
	if (config_key_parse(k, value, cfg, &what, detail, sizeof(detail))) {
		snprintf(why, n, "%s.%s: %s%s%s", k->section, k->name, what, detail[0] ? ": " : "",
		         detail);
		return -EINVAL;
	}
	wheel_keys_after(cfg, k);
	return 0;
}

int config_check(const struct omni4_config *cfg, char *why, size_t n)
{
	int bad = 0;
	const char *reason = NULL;

	if (config_check_whole(cfg, &bad, &reason)) {
		snprintf(why, n, "%s.%s: invalid value: %s", config_keys[bad].section,
		         config_keys[bad].name, reason);
		return -EINVAL;
	}
	return 0;
}
