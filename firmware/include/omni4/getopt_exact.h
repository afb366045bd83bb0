/*
 * getopt_exact.h - whole long option names only, for the C tools' getopt_long loops.
 *
 * getopt_long takes any unambiguous prefix of a long option (--conf for --config, --dur for
 * --duration): a typo then does something unintended. After getopt_long returned option li
 * (its longindex; -1 for a short option), omni4_getopt_given() is the argument as the user
 * wrote it and omni4_getopt_exact() says whether it names the option whole ("--name" or
 * "--name=value").
 */
#ifndef OMNI4_GETOPT_EXACT_H
#define OMNI4_GETOPT_EXACT_H

#include <getopt.h>
#include <stdbool.h>
#include <string.h>

/* The option's own argument: before its value when the value came as the next argument. */
static inline const char *omni4_getopt_given(char *const argv[], int optind_now,
					     const char *optarg_now)
{
	return optarg_now && optind_now >= 2 && optarg_now == argv[optind_now - 1] ?
		       argv[optind_now - 2] :
		       argv[optind_now - 1];
}

static inline bool omni4_getopt_exact(const char *given, const struct option *opts, int li)
{
	if (li < 0 || !given || strncmp(given, "--", 2) != 0)
		return true;
	const size_t n = strlen(opts[li].name);

	return strncmp(given + 2, opts[li].name, n) == 0 &&
	       (given[2 + n] == '\0' || given[2 + n] == '=');
}

#endif /* OMNI4_GETOPT_EXACT_H */
