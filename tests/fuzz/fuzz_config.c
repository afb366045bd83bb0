/* libFuzzer target: bytes -> INI text -> config parser.
 * Properties: no crash/UB; an accepted file holds physical model parameters and a message is
 * always set on rejection. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "omni4/config/config.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	char *text = malloc(size + 1);
	struct omni4_config cfg;
	struct config_error err;

	if (!text)
		return 0;
	memcpy(text, data, size);
	text[size] = '\0';
	config_defaults(&cfg);
	const int rc = config_load_string(text, "fuzz.ini", &cfg, &err);

	if (rc == 0 && model_params_check(&cfg.ctl.model, NULL) != 0)
		__builtin_trap();
	if (rc != 0 && err.msg[0] == '\0')
		__builtin_trap();
	free(text);
	return 0;
}
