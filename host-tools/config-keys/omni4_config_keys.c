/*
 * omni4-config-keys - the INI key table as text, generated from the table itself (config.h): a
 * Markdown table for docs/ini-keys.md, or one JSON object per key. The docs' table is this
 * program's output (tests/host/check_ini_doc.py compares and, with --write, rewrites it).
 * A tool beside omni4-record: the same option loop (omni4/getopt_exact.h) and --version.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "omni4/config/config.h"
#include "omni4/base/getopt_exact.h"
#include "omni4/version.h"

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

static void usage(FILE *f)
{
	fprintf(f, "usage: omni4-config-keys --markdown | --json\n"
	           "Prints the robot INI's key table (section, key, type, unit, range or choices,\n"
	           "default, when a change takes effect, description), generated from the table\n"
	           "omni4-fw's loader reads with: docs/ini-keys.md's table is its output.\n"
	           "  -m, --markdown   a Markdown table\n"
	           "  -j, --json       one JSON object per key, one per line\n"
	           "  -h, --help       this text\n"
	           "      --version    the version and the git description it was built from\n"
	           "example: omni4-config-keys --json | grep '\"section\": \"limits\"'\n");
}

/* The command line: -1 to go on with *json set, else the exit status (0 after --help or
 * --version, 2 for a usage error). */
static int parse_args(int argc, char **argv, bool *json)
{
	static const struct option opts[] = {
	    {"markdown", no_argument, NULL, 'm'},
	    {"json", no_argument, NULL, 'j'},
	    {"help", no_argument, NULL, 'h'},
	    {"version", no_argument, NULL, 'V'},
	    {NULL, 0, NULL, 0},
	};
	int c, formats = 0;

	while ((c = omni4_getopt_long("omni4-config-keys", argc, argv, "mjh", opts)) != -1) {
		switch (c) {
		case 'm':
		case 'j':
			*json = c == 'j';
			formats++;
			break;
		case 'h':
			usage(stdout);
			return 0;
		case 'V':
			printf("omni4-config-keys %s\n", OMNI4_VERSION);
			return 0;
		default: /* '?': omni4_getopt_long said what */
			return 2;
		}
	}
	if (optind != argc) {
		fprintf(stderr,
		        "omni4-config-keys: unexpected argument '%s' (see omni4-config-keys "
		        "--help)\n",
		        argv[optind]);
		return 2;
	}
	if (formats != 1) {
		fprintf(stderr, "omni4-config-keys: give one of --markdown or --json (see "
		                "omni4-config-keys --help)\n");
		return 2;
	}
	return -1;
}

int main(int argc, char **argv)
{
	bool json = false;
	struct omni4_config cfg;
	const int rc = parse_args(argc, argv, &json);

	if (rc >= 0)
		return rc;
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
