/* config_ini.h - a robot INI given as a string, loaded over the defaults (a test fails with the
 * loader's message if it refuses it). Include after cmocka (omni4_test.h). */
#ifndef OMNI4_TEST_CONFIG_INI_H
#define OMNI4_TEST_CONFIG_INI_H

#include "omni4/config/config.h"

static inline struct omni4_config config_ini(const char *ini)
{
	struct omni4_config cfg;
	struct config_error err;

	config_defaults(&cfg);
	if (config_load_string(ini, "test.ini", &cfg, &err))
		fail_msg("%s", err.msg);
	return cfg;
}

#endif /* OMNI4_TEST_CONFIG_INI_H */
