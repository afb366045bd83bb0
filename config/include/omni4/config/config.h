/*
 * config.h - the one INI file of a robot (inih): every layer's settings in one struct, read,
 * checked and written through one key table.
 *
 * The layers own their settings and the rows of the table that fill them (key, default, range,
 * unit, when it may change, one line of doc): the controller (core: ctl_keys.def), omni4-fw
 * (fw_keys.def), each backend its own (backends.def's keys column: sim_keys.def,
 * socketcan_keys.def, gpiod_keys.def). This file puts them together; docs/ini-keys.md is generated
 * from the table (omni4-config-keys). Unknown sections or keys, duplicate keys, malformed or
 * out-of-range values are errors; [model] holds all 14 keys or none, and may add a wheel's own r_j,
 * Kv_j, Kt_j, R_j (docs/configuration.md: ctl.wheel_keys records which; config_write writes only
 * those, config_key_set makes a wheel key the wheel's own, and a wheel without its own key
 * follows its scalar).
 */
#ifndef OMNI4_CONFIG_H
#define OMNI4_CONFIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "omni4/drivers/backend_settings.h"
#include "omni4/core/ctl_settings.h"
#include "omni4/config/fw_settings.h"
#include "omni4/model/params.h"

/* A robot's whole INI. */
struct omni4_config {
	struct ctl_settings ctl; /* [model] [loop] rate_hz [control] [limits] */
	struct fw_settings fw;   /* [loop] real-time, [lcm] [hal] [params] */
	/* each backend's settings by its member (backends.def): sim [sim], can [can], gpio [gpio]
	 */
#define OMNI4_CONFIG_PART(member, settings) struct settings member;
	OMNI4_BACKEND_SETTINGS(OMNI4_CONFIG_PART)
#undef OMNI4_CONFIG_PART
};

/* Every key's default (the tables' default column): the paper's Table III robot at 1 kHz on the
 * sim backend. */
void config_defaults(struct omni4_config *cfg);

/* Room for any key's value as INI text, with its NUL (the longest string field is 128 bytes;
 * test_config checks every key's default and limits fit). */
#define CONFIG_VALUE_MAX 160

struct config_error {
	int line;      /* 0 when the error is not tied to a line */
	char msg[256]; /* "PATH:LINE: what is wrong" */
};

/*
 * Load PATH over the defaults. 0 on success; -ENOENT if the file cannot be opened; -EINVAL on
 * any error in it, described in err (first error only).
 */
int config_load(const char *path, struct omni4_config *cfg, struct config_error *err);
/* Same, from a string in memory; name is used in messages. */
int config_load_string(const char *text, const char *name, struct omni4_config *cfg,
                       struct config_error *err);

/*
 * Like config_load, but [model] may hold any subset of its keys (e.g. a BASE.ini with only the
 * measured d r l M) and is not checked for physical sense. *model_seen gets bit i set for each
 * model_params_names[i] present.
 */
int config_load_partial(const char *path, struct omni4_config *cfg, uint32_t *model_seen,
                        struct config_error *err);

/* Write a [model] section that config_load reads back exactly (config_format_double). Returns 0
 * or -EIO. */
int config_write_model(FILE *f, const struct model_params *p);
/* v as the shortest of %.15g .. %.17g that reads back to the same double (0.089, not
 * 0.088999999999999996); snprintf's return value. */
int config_format_double(char *buf, size_t n, double v);

/* ---- the key table ------------------------------------------------------------------------ */

enum config_key_type {
	CONFIG_DOUBLE,
	CONFIG_INT,
	CONFIG_BOOL,
	CONFIG_STRING, /* a char array of `size` bytes */
	CONFIG_ENUM,   /* an int: the index of the value in choices */
};

/* When a key may change while omni4-fw runs (param_value_t CHANGE_* has the same numbers). */
enum config_change {
	CONFIG_LIVE = 0,    /* in any mode, between two ticks */
	CONFIG_IDLE = 1,    /* only while the bridges are not driven (not VELOCITY / VOLTAGE) */
	CONFIG_RESTART = 2, /* only in the INI, read at start-up */
};

struct config_key {
	const char *section;
	const char *name;
	enum config_key_type type;
	size_t offset;       /* in struct omni4_config */
	size_t size;         /* of the field [bytes] */
	double min, max;     /* inclusive range for numbers */
	const char *choices; /* ENUM: "a|b|c", the enum's order */
	const char *unit;    /* SI unit, "" for none */
	enum config_change change;
	const char *doc; /* one line; names any check beyond the range */
};

int config_key_count(void);
/* Key i (0 .. config_key_count()-1), NULL outside. [model] keys are 0..13 in
 * model_params_names order. */
const struct config_key *config_key_at(int i);
/* Index of "section.key", or -1. */
int config_key_find(const char *dotted);
/* Key i of cfg as the INI holds it (doubles %.17g, bools true/false): 0, -EINVAL for a string
 * that an INI file cannot hold unchanged, -ENOSPC if buf is too small. */
int config_key_format(const struct omni4_config *cfg, int i, char *buf, size_t n);
/* True if key i has the same value in force in a and b (compared as values, not as text). */
bool config_key_equal(const struct omni4_config *a, const struct omni4_config *b, int i);
/* Parse and range-check value into key i of cfg, exactly as the INI parser does. 0, or -EINVAL
 * with why = "section.key: what: detail" (cfg untouched). */
int config_key_set(struct omni4_config *cfg, int i, const char *value, char *why, size_t n);
/* The checks across keys that config_load makes after reading a file ([model] physically
 * meaningful, supply_min_v < supply_v). 0, or -EINVAL with why. */
int config_check(const struct omni4_config *cfg, char *why, size_t n);
/* Read INI text and hand every key = value to pair(ctx, key index, value) (values are not
 * parsed; unknown and duplicate keys and syntax errors are errors as in config_load). pair
 * returns non-zero to stop ("too many keys"). 0 or -EINVAL with err. */
int config_parse_pairs(const char *text, const char *name,
                       int (*pair)(void *ctx, int key, const char *value), void *ctx,
                       struct config_error *err);

/* Write every key of cfg, all sections, so that config_load reads back the same values; a
 * comment line with each key's doc and unit; header (may be NULL) as the first comment.
 * 0, -EINVAL (a string that cannot be written), -EIO. */
int config_write(FILE *f, const struct omni4_config *cfg, const char *header);
/*
 * Replace the INI file at path by cfg so that a crash or power cut at any instant leaves either
 * the old or the new complete file: write a temporary in the same directory, fsync it, keep the
 * previous file as path.bak (hard link, or a synced copy), rename the temporary over path, fsync
 * the directory (omni4/outfile.h). The file keeps its permissions. A symbolic link is kept and
 * the file it points to is replaced (its .bak beside it); a device or FIFO is written in place.
 * 0 with what became of the previous file in why ("previous kept as X.bak", "written in place
 * ...: no .bak", "a new file ..."), or a negative errno with why.
 */
int config_save(const char *path, const struct omni4_config *cfg, const char *header, char *why,
                size_t n);

#endif /* OMNI4_CONFIG_H */
