/* config_table.h - inside config/: the key table (config.c) as the reader (config_read.c) and
 * the writer (config_save.c) use it. Not a public header. */
#ifndef OMNI4_CONFIG_TABLE_H
#define OMNI4_CONFIG_TABLE_H

#include <stddef.h>
#include <stdint.h>

#include "omni4/config/config.h"

#define CONFIG_KEYS_MAX 256 /* room in the reader's per-key arrays (checked against the table) */

extern const struct config_key config_keys[];
extern const size_t config_n_keys;

/* Key k's bit in ctl.wheel_keys, 0 if it is not a per-wheel [model] key. */
uint16_t config_wheel_bit(const struct config_key *k);
/* Key k's bit in ctl.layout_keys (d_j: bit j), 0 if it is not a wheel's distance. */
uint8_t config_dist_bit(const struct config_key *k);
/* Parse value into key k of cfg, range-checked. 0, or -EINVAL with what ("bad value", "out of
 * range value", "too long value") and detail ("" or why) filled in. */
int config_key_parse(const struct config_key *k, const char *value, struct omni4_config *cfg,
                     const char **what, char *detail, size_t n);
/* Checks across keys; index of the offending key in *bad_key, its reason in why. */
int config_check_whole(const struct omni4_config *cfg, int *bad_key, const char **why);

#endif /* OMNI4_CONFIG_TABLE_H */
