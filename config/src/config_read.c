/* config_read.c - the INI reader: inih with a line-counting reader around it (inih's default
 * build gives its handler no line numbers), every key through the table (config.c), the checks
 * across keys after the whole file is in. */
#include "omni4/config/config.h"
#include "config_table.h"

#include <errno.h>
#include <ini.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#define CONFIG_MAX_SECTIONS 64 /* [section] headers a file may have (each name once) */
#define CONFIG_SECTION_LEN 64  /* > inih's MAX_SECTION (50): names compared whole */

struct parse_state {
	struct omni4_config *cfg;
	struct config_error *err;
	const char *name;
	bool seen[CONFIG_KEYS_MAX];
	bool failed;
	bool partial_model; /* [model] may be incomplete; not checked */
	/* config_parse_pairs: each known key's value goes here instead of into cfg */
	int (*pairs)(void *ctx, int key, const char *value);
	void *pairs_ctx;
	int key_line[CONFIG_KEYS_MAX]; /* line of each key given, for the checks across keys */
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

static int set_value(struct parse_state *st, const struct config_key *k, const char *value,
                     int line)
{
	char detail[128];
	const char *what = NULL;

	if (config_key_parse(k, value, st->cfg, &what, detail, sizeof(detail))) {
		char what_for[64];

		snprintf(what_for, sizeof(what_for), "%s for", what);
		return fail(st, line, what_for, k->section, k->name, detail[0] ? detail : NULL);
	}
	return 1;
}

static int on_line(void *user, int line, const char *section, const char *name, const char *value)
{
	struct parse_state *st = user;

	for (size_t i = 0; i < config_n_keys; i++) {
		if (strcmp(config_keys[i].section, section) || strcmp(config_keys[i].name, name))
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
		return set_value(st, &config_keys[i], value, line);
	}
	return fail(st, line, "unknown key", section, name, NULL);
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

	for (size_t i = 0; i < config_n_keys; i++) {
		if (st->seen[i]) {
			st->cfg->ctl.wheel_keys |= config_wheel_bit(&config_keys[i]);
			st->cfg->ctl.layout_keys |= config_dist_bit(&config_keys[i]);
		}
		any |=
		    st->seen[i] && (i < MODEL_PARAMS_COUNT || config_wheel_bit(&config_keys[i]) ||
		                    config_dist_bit(&config_keys[i]));
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

	if (config_check_whole(st->cfg, &bad, &why)) {
		fail(st, blame_line(st, bad), "invalid value for", config_keys[bad].section,
		     config_keys[bad].name, why);
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

int config_parse_pairs(const char *text, const char *name,
                       int (*pair)(void *ctx, int key, const char *value), void *ctx,
                       struct config_error *err)
{
	struct line_reader r = {.text = text};
	struct omni4_config scratch; /* untouched: every value goes to pair */

	config_defaults(&scratch);
	return parse_ex(&r, name, &scratch, err, NULL, pair, ctx);
}
