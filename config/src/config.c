/* config.c - INI parsing (inih) into struct omni4_config, table driven, line-numbered errors. */
#include "omni4/config.h"

#include "omni4/channels.h"
#include "omni4/outfile.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <ini.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define INF INFINITY
#define CONFIG_MAX_SECTIONS 64 /* [section] headers a file may have (each name once) */
#define CONFIG_SECTION_LEN 64  /* > inih's MAX_SECTION (50): names compared whole */
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

/*
 * The one table of keys: the INI parser, the writer and the parameter service (over LCM) all
 * use it, and docs/ini-keys.md is generated from it. [model] keys come first, in
 * model_params_names order (test_config checks it); their real check is on the whole model
 * (ctl_settings_check), after all keys are in.
 */
static const struct config_key keys[] = {
#define OMNI4_KEY(...) ROW(ctl, __VA_ARGS__)
#include "omni4/ctl_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(kind, section, key, field, ...)                                                  \
	ROW(ctl, kind, section, key, est.field, __VA_ARGS__)
#include "omni4/est_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(...) ROW(fw, __VA_ARGS__)
#include "omni4/fw_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(...) ROW(sim, __VA_ARGS__)
#include "omni4/sim_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(...) ROW(can, __VA_ARGS__)
#include "omni4/socketcan_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(...) ROW(gpio, __VA_ARGS__)
#include "omni4/gpiod_keys.def"
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
	sim_settings_defaults(&cfg->sim);
#define OMNI4_KEY(kind, section, key, field, def, ...) DEFAULT_##kind(cfg->fw.field, def);
#include "omni4/fw_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(kind, section, key, field, def, ...) DEFAULT_##kind(cfg->can.field, def);
#include "omni4/socketcan_keys.def"
#undef OMNI4_KEY
#define OMNI4_KEY(kind, section, key, field, def, ...) DEFAULT_##kind(cfg->gpio.field, def);
#include "omni4/gpiod_keys.def"
#undef OMNI4_KEY
}

#define N_KEYS (sizeof(keys) / sizeof(keys[0]))

/* Key k's index 4 q + j in ctl.wheels if it is a per-wheel [model] key (its field lies in
 * ctl.wheels, whose doubles are in CTL_WHEEL_KEY's order), else -1. */
static int wheel_index(const struct config_key *k)
{
	const size_t base = offsetof(struct omni4_config, ctl.wheels);

	if (k->offset < base || k->offset >= base + sizeof(struct model_wheels))
		return -1;
	return (int)((k->offset - base) / sizeof(double));
}

/* Key k's bit in ctl.wheel_keys, 0 if it is not a per-wheel key. */
static uint16_t wheel_bit(const struct config_key *k)
{
	const int i = wheel_index(k);

	return i < 0 ? 0 : (uint16_t)(1u << i);
}

/* After key k took a value: a wheel key is that wheel's own from now on; every wheel without
 * its own key takes its scalar (which may just have changed). */
static void wheel_keys_after(struct omni4_config *cfg, const struct config_key *k)
{
	cfg->ctl.wheel_keys |= wheel_bit(k);
	ctl_settings_wheels_follow(&cfg->ctl);
}

struct parse_state {
	struct omni4_config *cfg;
	struct config_error *err;
	const char *name;
	bool seen[N_KEYS];
	bool failed;
	bool partial_model; /* [model] may be incomplete; not checked */
	/* config_parse_pairs: each known key's value goes here instead of into cfg */
	int (*pairs)(void *ctx, int key, const char *value);
	void *pairs_ctx;
	int key_line[N_KEYS]; /* line of each key given, for the checks across keys */
};

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

/* A number of key k (double, or int when integer): parsed whole, finite, within the key's
 * range. 0, or -EINVAL with what and detail. */
static int parse_number(const struct config_key *k, const char *value, bool integer, double *v,
                        const char **what, char *detail, size_t n)
{
	char *end;

	errno = 0;
	*v = integer ? (double)strtol(value, &end, 10) : strtod(value, &end);
	if (end == value || *end || errno == ERANGE || !isfinite(*v)) {
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
static int key_parse(const struct config_key *k, const char *value, struct omni4_config *cfg,
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

static int set_value(struct parse_state *st, const struct config_key *k, const char *value,
                     int line)
{
	char detail[128];
	const char *what = NULL;

	if (key_parse(k, value, st->cfg, &what, detail, sizeof(detail))) {
		char what_for[64];

		snprintf(what_for, sizeof(what_for), "%s for", what);
		return fail(st, line, what_for, k->section, k->name, detail[0] ? detail : NULL);
	}
	return 1;
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
		st->key_line[i] = line;
		if (st->pairs) {
			if (st->pairs(st->pairs_ctx, (int)i, value))
				return fail(st, line, "cannot take", section, name,
				            "too many keys");
			return 1;
		}
		return set_value(st, &keys[i], value, line);
	}
	return fail(st, line, "unknown key", section, name, NULL);
}

/* Checks across keys; index of the offending key in *bad_key, its reason in why. */
static int check_whole(const struct omni4_config *cfg, int *bad_key, const char **why)
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

/* The line to blame for key bad failing a check across keys: its own, else (a default) the
 * line of supply_v, the other side of the one rule across two keys. */
static int blame_line(const struct parse_state *st, int bad)
{
	const int other = config_key_find("limits.supply_v");

	return st->key_line[bad] ? st->key_line[bad] : st->key_line[other];
}

/* inih's result (rc) and the reader's repeated section (dup_line, dup_name; the reader stops
 * there, so an error inih or the handler met is on an earlier line) as one error. */
static int after_read(struct parse_state *st, int rc, int dup_line, const char *dup_name)
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
	if (rc > 0 && (!st->failed || rc < st->err->line)) { /* the first error in the file */
		st->err->line = rc;
		snprintf(st->err->msg, sizeof(st->err->msg),
		         "%s:%d: syntax error (expected [section] or key = value)", st->name, rc);
		return -EINVAL;
	}
	if (st->failed)
		return -EINVAL;
	if (dup_line > 0) {
		st->failed = true;
		st->err->line = dup_line;
		snprintf(st->err->msg, sizeof(st->err->msg), "%s:%d: %s", st->name, dup_line,
		         dup_name);
		return -EINVAL;
	}
	return 0;
}

/* After a clean read: [model] all or nothing, and the settings physically meaningful. */
static int after_parse(struct parse_state *st, int model_line)
{
	if (st->pairs)
		return 0; /* key = value pairs handed out, nothing checked across keys */

	/* [model]: all or nothing (a wheel key needs the scalars), and physically meaningful. */
	bool any = false;

	for (size_t i = 0; i < N_KEYS; i++) {
		if (st->seen[i])
			st->cfg->ctl.wheel_keys |= wheel_bit(&keys[i]);
		any |= st->seen[i] && (i < MODEL_PARAMS_COUNT || wheel_bit(&keys[i]));
	}
	ctl_settings_wheels_follow(&st->cfg->ctl);
	if (st->partial_model)
		return 0;
	for (int i = 0; any && i < MODEL_PARAMS_COUNT; i++)
		if (!st->seen[i]) {
			fail(st, model_line, "missing key", "model", model_params_names[i], NULL);
			return -EINVAL;
		}
	int bad = 0;
	const char *why = NULL;

	if (check_whole(st->cfg, &bad, &why)) {
		fail(st, blame_line(st, bad), "invalid value for", keys[bad].section,
		     keys[bad].name, why);
		return -EINVAL;
	}
	return 0;
}

/*
 * inih reports no line number to the handler in its default build; count lines ourselves by
 * using ini_parse_stream with a reader that tracks them. The reader also sees each [section]
 * header as inih does (the handler sees only sections that have keys) and stops at the first
 * header of a section met before: no section may come twice, in any position.
 */
struct line_reader {
	struct parse_state *st;
	const char *text; /* string source, or NULL */
	FILE *f;          /* file source */
	int read_errno;   /* the file's read error, 0 if none */
	int line;
	bool mid_line; /* the last chunk did not end a line (line longer than inih's buffer) */
	bool key_met;  /* a key line since the last header: an indented line continues it */
	/* the sections met so far with their header lines; the first repeat, 0 if none */
	char sections[CONFIG_MAX_SECTIONS][CONFIG_SECTION_LEN];
	int section_line[CONFIG_MAX_SECTIONS];
	int n_sections;
	int dup_line;
	char dup[CONFIG_SECTION_LEN + 32];
};

/* inih's find_chars_or_comment: the first of chars, or a ';' after white space, or the end. */
static const char *ini_find(const char *s, const char *chars)
{
	bool was_space = false;

	while (*s && !strchr(chars, *s) && !(was_space && *s == ';')) {
		was_space = *s == ' ' || *s == '\t' || *s == '\r' || *s == '\n';
		s++;
	}
	return s;
}

/* The line of [name] if met, else 0. */
static int section_line(const struct line_reader *r, const char *name)
{
	for (int i = 0; i < r->n_sections; i++)
		if (!strcmp(r->sections[i], name))
			return r->section_line[i];
	return 0;
}

/* One whole line as inih will take it: a [section] header is remembered; false (stop) at a
 * section met before or one too many. */
static bool note_line(struct line_reader *r, const char *buf)
{
	const char *c = buf;

	if (r->line == 1 && !strncmp(c, "\xEF\xBB\xBF", 3))
		c += 3; /* inih skips a UTF-8 BOM */
	const bool indented = *c == ' ' || *c == '\t';

	while (*c == ' ' || *c == '\t')
		c++;
	if (!*c || *c == '\n' || *c == '\r' || *c == ';' || *c == '#' || (indented && r->key_met))
		return true; /* blank, comment, or a value's continuation */
	if (*c != '[') {
		const char *eq = ini_find(c, "=:");

		r->key_met |= *eq == '=' || *eq == ':';
		return true;
	}
	const char *end = ini_find(c + 1, "]");

	if (*end != ']')
		return true; /* malformed: inih says so */
	char name[CONFIG_SECTION_LEN];

	snprintf(name, sizeof(name), "%.*s", (int)(end - c - 1), c + 1);
	r->key_met = false;
	if (section_line(r, name)) {
		r->dup_line = r->line;
		snprintf(r->dup, sizeof(r->dup), "duplicate section [%s]", name);
		return false;
	}
	if (r->n_sections == CONFIG_MAX_SECTIONS) {
		r->dup_line = r->line;
		snprintf(r->dup, sizeof(r->dup), "more than %d sections", CONFIG_MAX_SECTIONS);
		return false;
	}
	r->section_line[r->n_sections] = r->line;
	memcpy(r->sections[r->n_sections++], name, sizeof(name));
	return true;
}

static char *read_line(char *buf, int size, void *stream)
{
	struct line_reader *r = stream;

	if (r->dup_line)
		return NULL;
	if (r->f) {
		if (!fgets(buf, size, r->f)) {
			r->read_errno = ferror(r->f) ? errno : 0;
			return NULL;
		}
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
	if (!r->mid_line) {
		r->line++;
		if (!note_line(r, buf))
			return NULL;
	}
	const size_t len = strlen(buf);

	r->mid_line = len > 0 && buf[len - 1] != '\n';
	return buf;
}

static int handler(void *user, const char *section, const char *name, const char *value)
{
	struct line_reader *r = user;

	return on_line(r->st, r->line, section, name, value);
}
static int parse_ex(struct line_reader *reader, const char *name, struct omni4_config *cfg,
                    struct config_error *err, uint32_t *model_seen,
                    int (*pairs)(void *ctx, int key, const char *value), void *pairs_ctx)
{
	struct parse_state st = {.cfg = cfg,
	                         .err = err,
	                         .name = name,
	                         .partial_model = model_seen != NULL,
	                         .pairs = pairs,
	                         .pairs_ctx = pairs_ctx};
	int rc;

	reader->st = &st;
	err->line = 0;
	err->msg[0] = '\0';
	rc = ini_parse_stream(read_line, reader, handler, reader);
	if (reader->read_errno && rc == 0) {
		snprintf(err->msg, sizeof(err->msg), "%s: cannot read: %s", name,
		         strerror(reader->read_errno));
		rc = -EIO;
	} else {
		rc = after_read(&st, rc, reader->dup_line, reader->dup);
		if (!rc)
			rc = after_parse(&st, section_line(reader, "model"));
	}
	if (model_seen) {
		*model_seen = 0;
		for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
			*model_seen |= st.seen[i] ? 1u << i : 0u;
	}
	return rc;
}

static int parse(struct line_reader *reader, const char *name, struct omni4_config *cfg,
                 struct config_error *err, uint32_t *model_seen)
{
	return parse_ex(reader, name, cfg, err, model_seen, NULL, NULL);
}

/* A directory is refused before it is read: fopen takes one and only its first read fails,
 * which inih would take for an empty file (the defaults). Any other read error is said too. */
static int load_file(const char *path, struct omni4_config *cfg, struct config_error *err,
                     uint32_t *model_seen)
{
	struct line_reader r = {.f = fopen(path, "r")};
	struct stat sb;
	int rc;

	err->line = 0;
	if (!r.f) {
		snprintf(err->msg, sizeof(err->msg), "%s: cannot open: %s", path, strerror(errno));
		return -ENOENT;
	}
	if (fstat(fileno(r.f), &sb) == 0 && S_ISDIR(sb.st_mode)) {
		snprintf(err->msg, sizeof(err->msg), "%s: cannot read: %s", path, strerror(EISDIR));
		fclose(r.f);
		return -EISDIR;
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

int config_write_model(FILE *f, const struct model_params *p)
{
	if (fprintf(f, "[model]\n") < 0)
		return -EIO;
	for (int i = 0; i < MODEL_PARAMS_COUNT; i++) {
		char v[40];

		if (config_format_double(v, sizeof(v), model_params_get(p, i)) < 0 ||
		    fprintf(f, "%s = %s\n", model_params_names[i], v) < 0)
			return -EIO;
	}
	return 0;
}

int config_parse_pairs(const char *text, const char *name,
                       int (*pair)(void *ctx, int key, const char *value), void *ctx,
                       struct config_error *err)
{
	struct line_reader r = {.text = text};
	struct omni4_config scratch; /* untouched: every value goes to pair */

	config_defaults(&scratch);
	return parse_ex(&r, name, &scratch, err, NULL, pair, ctx);
}

int config_key_count(void)
{
	return (int)N_KEYS;
}

const struct config_key *config_key_at(int i)
{
	return i >= 0 && i < (int)N_KEYS ? &keys[i] : NULL;
}

int config_key_find(const char *dotted)
{
	const char *dot = dotted ? strchr(dotted, '.') : NULL;

	if (!dot)
		return -1;
	const size_t slen = (size_t)(dot - dotted);

	for (size_t i = 0; i < N_KEYS; i++)
		if (strlen(keys[i].section) == slen && !strncmp(keys[i].section, dotted, slen) &&
		    !strcmp(keys[i].name, dot + 1))
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

int config_key_format(const struct omni4_config *cfg, int i, char *buf, size_t n)
{
	const struct config_key *k = config_key_at(i);

	if (!k || n == 0)
		return -EINVAL;
	const char *base = (const char *)cfg + k->offset;
	int len = -1;

	switch (k->type) {
	case CONFIG_DOUBLE: {
		double v;

		memcpy(&v, base, sizeof(v));
		if (wheel_index(k) >= 0) { /* the value in force: the scalar without its own key */
			struct model_wheels w;
			double all[CTL_WHEEL_KEYS];

			_Static_assert(sizeof(w) == sizeof(all), "struct model_wheels: 16 doubles");
			ctl_settings_wheels(&cfg->ctl, &w);
			memcpy(all, &w, sizeof(all));
			v = all[wheel_index(k)];
		}
		len = config_format_double(buf, n, v);
		break;
	}
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
	if (key_parse(k, value, cfg, &what, detail, sizeof(detail))) {
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

	if (check_whole(cfg, &bad, &reason)) {
		snprintf(why, n, "%s.%s: invalid value: %s", keys[bad].section, keys[bad].name,
		         reason);
		return -EINVAL;
	}
	return 0;
}

/* true if a key before i has k's section: the section was written with that key's. */
static bool section_written(size_t i)
{
	for (size_t j = 0; j < i; j++)
		if (!strcmp(keys[j].section, keys[i].section))
			return true;
	return false;
}

/* Every key of section i's, in table order, under one [section] line. */
static int write_section(FILE *f, const struct omni4_config *cfg, size_t i)
{
	char value[256];

	if (fprintf(f, "%s[%s]\n", i ? "\n" : "", keys[i].section) < 0)
		return -EIO;
	for (size_t j = i; j < N_KEYS; j++) {
		const struct config_key *k = &keys[j];

		/* a wheel without its own key: it takes the scalar on reading */
		if (strcmp(k->section, keys[i].section) ||
		    (wheel_bit(k) && !(cfg->ctl.wheel_keys & wheel_bit(k))))
			continue;
		if (config_key_format(cfg, (int)j, value, sizeof(value)))
			return -EINVAL;
		if (fprintf(f, "; %s%s%s%s\n%s = %s\n", k->doc, k->unit[0] ? " [" : "", k->unit,
		            k->unit[0] ? "]" : "", k->name, value) < 0)
			return -EIO;
	}
	return 0;
}

int config_write(FILE *f, const struct omni4_config *cfg, const char *header)
{
	if (header && fprintf(f, "; %s\n", header) < 0)
		return -EIO;
	for (size_t i = 0; i < N_KEYS; i++) {
		const int rc = section_written(i) ? 0 : write_section(f, cfg, i);

		if (rc)
			return rc;
	}
	return fflush(f) ? -EIO : 0;
}

/* Copy src to dst through dst.tmp (fsync, rename): for file systems without hard links. */
static int copy_file(const char *src, const char *dst)
{
	char tmp[PATH_MAX + 16];
	char buf[4096];
	int rc = 0;

	if ((size_t)snprintf(tmp, sizeof(tmp), "%s.tmp", dst) >= sizeof(tmp))
		return -ENAMETOOLONG;
	FILE *in = fopen(src, "rb");

	if (!in)
		return -errno;
	FILE *out = fopen(tmp, "wb");

	if (!out) {
		rc = -errno;
		fclose(in);
		return rc;
	}
	for (size_t got; (got = fread(buf, 1, sizeof(buf), in)) > 0;)
		if (fwrite(buf, 1, got, out) != got) {
			rc = -EIO;
			break;
		}
	if (!rc && (ferror(in) || fflush(out) || fsync(fileno(out))))
		rc = -EIO;
	fclose(in);
	if (fclose(out) && !rc)
		rc = -EIO;
	if (!rc && rename(tmp, dst))
		rc = -errno;
	if (rc)
		unlink(tmp);
	return rc;
}

/* The file about to be replaced becomes target.bak (a hard link: the file itself never goes
 * away), beside the file itself when the INI is reached through a symbolic link. */
static int keep_previous(const struct omni4_out *o, char *why, size_t n)
{
	char bak[PATH_MAX + 8];
	int rc;

	if (o->in_place || !o->existed)
		return 0;
	if ((size_t)snprintf(bak, sizeof(bak), "%s.bak", o->target) >= sizeof(bak)) {
		snprintf(why, n, "%s: path too long", o->path);
		return -ENAMETOOLONG;
	}
	if (unlink(bak) && errno != ENOENT) {
		rc = -errno;
		snprintf(why, n, "%s: cannot replace: %s", bak, strerror(-rc));
		return rc;
	}
	if (link(o->target, bak) && errno != ENOENT && (rc = copy_file(o->target, bak))) {
		snprintf(why, n, "%s: cannot keep the previous file: %s", bak, strerror(-rc));
		return rc;
	}
	return 0;
}

int config_save(const char *path, const struct omni4_config *cfg, const char *header, char *why,
                size_t n)
{
	struct omni4_out o;
	int rc = omni4_out_open(&o, path, 0644, 0, why, n);

	if (rc)
		return rc;
	rc = config_write(o.f, cfg, header);
	if (rc == -EINVAL) {
		snprintf(why, n, "a string value cannot be written to an INI file unchanged");
		omni4_out_abort(&o);
		return rc;
	}
	/* -EIO: the commit below finds the stream's error and says which */
	if (!rc && (rc = keep_previous(&o, why, n))) {
		omni4_out_abort(&o);
		return rc;
	}
	return omni4_out_commit(&o, why, n);
}
