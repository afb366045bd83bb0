/*
 * save_pause.c - linked into omni4-fw-save-pause only (a test build of omni4-fw): the parameter
 * save pauses OMNI4_TEST_SAVE_PAUSE_MS milliseconds (at most 60 s) between the written, synced
 * temporary and the replacement of the INI file, so a test can kill the process right there.
 * The omni4-fw that is installed has the no-op of config.c and reads no such variable.
 */
#include "omni4/config.h"

#include <stdlib.h>
#include <time.h>

void config_save_before_replace(const char *tmp, const char *path)
{
	const char *s = getenv("OMNI4_TEST_SAVE_PAUSE_MS");
	const long ms = s ? strtol(s, NULL, 10) : 0;

	(void)tmp;
	(void)path;
	if (ms > 0 && ms <= 60000) {
		const struct timespec t = {.tv_sec = ms / 1000, .tv_nsec = (ms % 1000) * 1000000L};

		nanosleep(&t, NULL);
	}
}
