/*
 * fw_test_hooks.c - linked into omni4-fw-test-hooks only (omni4-fw's main and libraries with
 * these hooks: a test build). The installed omni4-fw has none of them and reads no OMNI4_TEST_
 * variable (fw_has_no_test_hooks checks the binaries).
 *
 * OMNI4_TEST_SAVE_PAUSE_MS (at most 60 s): the parameter save pauses this long before each
 * rename(2) (linked with -Wl,--wrap=rename): between the written, synced temporary and the
 * replacement of the INI file, so a test can kill the process right there.
 * OMNI4_TEST_CRASH_AFTER_S: SIGSEGV on the main thread this long after start, to check that the
 * crash handler switches the outputs off (the main thread sleeps in its wait for the stop, so
 * the signal interrupts it there, as a crash of that thread would).
 */
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

int __real_rename(const char *from, const char *to);
int __wrap_rename(const char *from, const char *to);

static void sleep_s(double s)
{
	const struct timespec t = {.tv_sec = (time_t)s,
	                           .tv_nsec = (long)((s - (double)(time_t)s) * 1e9)};

	nanosleep(&t, NULL);
}

int __wrap_rename(const char *from, const char *to)
{
	const char *v = getenv("OMNI4_TEST_SAVE_PAUSE_MS");
	const long ms = v ? strtol(v, NULL, 10) : 0;

	if (ms > 0 && ms <= 60000)
		sleep_s((double)ms / 1000.0);
	return __real_rename(from, to);
}

static pthread_t g_main;
static double g_crash_after_s;

static void *crash_timer(void *arg)
{
	(void)arg;
	sleep_s(g_crash_after_s);
	pthread_kill(g_main, SIGSEGV);
	return NULL;
}

__attribute__((constructor)) static void start_crash_timer(void)
{
	const char *v = getenv("OMNI4_TEST_CRASH_AFTER_S");
	pthread_t t;

	g_crash_after_s = v ? strtod(v, NULL) : 0.0;
	if (!(g_crash_after_s > 0.0 && g_crash_after_s < 3600.0))
		return;
	g_main = pthread_self();
	if (pthread_create(&t, NULL, crash_timer, NULL) == 0)
		pthread_detach(t);
	else
		fprintf(stderr, "omni4-fw-test-hooks: cannot start the crash timer\n");
}
