/*
 * omni4-config-keys - the INI key table as text, generated from the table itself (config.h): a
 * Markdown table for docs/ini-keys.md, or one JSON object per key. The docs' table is this
 * program's output (tests/host/check_ini_doc.py compares and, with --write, rewrites it).
 * usage: omni4-config-keys --markdown | --json
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "omni4/config.h"

static const char *type_name(enum config_key_type t)
{
	static const char *const names[] = {"double", "int", "bool", "string", "choice"};

	return (unsigned)t < sizeof(names) / sizeof(names[0]) ? names[t] : "?";
}

static const char *change_name(enum config_change c)
{
	return c == CONFIG_LIVE ? "live" : c == CONFIG_IDLE ? "idle" : "restart";
}

/* A range bound as the INI would hold it (shortest form that reads back). */
static void bound(char *buf, size_t n, double v)
{
	if (v == floor(v) && fabs(v) < 1e15)
		snprintf(buf, n, "%.0f", v);
	else
		config_format_double(buf, n, v);
}

/* "[lo, hi]", "any", "true / false", "`a` \| `b`", "at most N characters". */
static void range_text(const struct config_key *k, char *buf, size_t n)
{
	char lo[40], hi[40];

	switch (k->type) {
	case CONFIG_BOOL:
		snprintf(buf, n, "true / false");
		return;
	case CONFIG_STRING:
		snprintf(buf, n, "at most %zu characters", k->size - 1);
		return;
	case CONFIG_ENUM: {
		size_t used = 0;

		buf[0] = '\0';
		for (const char *c = k->choices; c && *c && used < n;) {
			const char *bar = strchr(c, '|');
			const int len = (int)(bar ? bar - c : (long)strlen(c));

			used += (size_t)snprintf(buf + used, n - used, "%s`%.*s`",
			                         used ? " \\| " : "", len, c);
			c = bar ? bar + 1 : NULL;
		}
		return;
	}
	default:
		if (isinf(k->min) && isinf(k->max)) {
			snprintf(buf, n, "any");
			return;
		}
		bound(lo, sizeof(lo), k->min);
		bound(hi, sizeof(hi), k->max);
		snprintf(buf, n, "[%s, %s]", lo, hi);
	}
}

/* JSON string body: quotes and backslashes escaped (the table's texts have no control
 * characters). */
static void json_string(const char *s)
{
	putchar('"');
	for (; *s; s++) {
		if (*s == '"' || *s == '\\')
			putchar('\\');
		putchar(*s);
	}
	putchar('"');
}

static void print_key(const struct config_key *k, const char *def, const char *range, bool json)
{
	const bool quoted = k->type == CONFIG_STRING || k->type == CONFIG_ENUM;

	if (!json) {
		printf("| `[%s]` | `%s` | %s | %s | %s | `%s%s%s` | %s | %s |\n", k->section,
		       k->name, type_name(k->type), k->unit[0] ? k->unit : "–", range,
		       quoted ? "\"" : "", def, quoted ? "\"" : "", change_name(k->change), k->doc);
		return;
	}
	printf("{\"section\": ");
	json_string(k->section);
	printf(", \"key\": ");
	json_string(k->name);
	printf(", \"type\": \"%s\", \"unit\": ", type_name(k->type));
	json_string(k->unit);
	printf(", \"range\": ");
	json_string(range);
	printf(", \"default\": ");
	json_string(def);
	printf(", \"change\": \"%s\", \"doc\": ", change_name(k->change));
	json_string(k->doc);
	printf("}\n");
}

int main(int argc, char **argv)
{
	const bool json = argc == 2 && !strcmp(argv[1], "--json");
	struct omni4_config cfg;

	if (argc != 2 || (!json && strcmp(argv[1], "--markdown"))) {
		fprintf(stderr, "usage: omni4-config-keys --markdown | --json\n");
		return 2;
	}
	config_defaults(&cfg);
	if (!json)
		printf("| section | key | type | unit | range / choices | default | change | "
		       "description |\n|---|---|---|---|---|---|---|---|\n");
	for (int i = 0; i < config_key_count(); i++) {
		const struct config_key *k = config_key_at(i);
		char def[CONFIG_VALUE_MAX], range[160];

		if (config_key_format(&cfg, i, def, sizeof(def))) {
			fprintf(stderr, "omni4-config-keys: %s.%s: default cannot be written\n",
			        k->section, k->name);
			return 1;
		}
		range_text(k, range, sizeof(range));
		print_key(k, def, range, json);
	}
	return 0;
}
