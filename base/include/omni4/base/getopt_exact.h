/*
 * getopt_exact.h - the C tools' getopt_long loop: whole long option names only, and a usage
 * error as one line `prog: ... (see prog --help)`.
 *
 * getopt_long takes any unambiguous prefix of a long option (--conf for --config, --dur for
 * --duration): a typo then does something unintended. omni4_getopt_long() is getopt_long that
 * refuses such a prefix: it returns '?' after printing the error line, as it does for an
 * unknown option or a missing value; the caller returns status 2 on '?'.
 */
#ifndef OMNI4_GETOPT_EXACT_H
#define OMNI4_GETOPT_EXACT_H

#include <getopt.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

/* The option's own argument: before its value when the value came as the next argument. */
static inline const char *omni4_getopt_given(char *const argv[], int optind_now,
                                             const char *optarg_now)
{
	return optarg_now && optind_now >= 2 && optarg_now == argv[optind_now - 1]
	           ? argv[optind_now - 2]
		   : argv[optind_now - 1];
}

static inline bool omni4_getopt_exact(const char *given, const struct option *opts, int li)
{
	if (li < 0 || !given || strncmp(given, "--", 2) != 0)
		return true;
	const size_t n = strlen(opts[li].name);

	return strncmp(given + 2, opts[li].name, n) == 0 &&
	       (given[2 + n] == '\0' || given[2 + n] == '=');
}

/* getopt_long(argc, argv, shortopts, opts) with the checks above; getopt's own messages off. */
static inline int omni4_getopt_long(const char *prog, int argc, char *const argv[],
                                    const char *shortopts, const struct option *opts)
{
	int li = -1;

	opterr = 0;
	const int c = getopt_long(argc, argv, shortopts, opts, &li);

	if (c == -1)
		return c;
	if (c == '?') {
		fprintf(stderr, "%s: '%s' is not an option or lacks its value (see %s --help)\n",
		        prog, argv[optind - 1], prog);
		return '?';
	}
	const char *given = omni4_getopt_given(argv, optind, optarg);

	if (!omni4_getopt_exact(given, opts, li)) {
		fprintf(stderr, "%s: '%s': give the whole option name (see %s --help)\n", prog,
		        given, prog);
		return '?';
	}
	return c;
}

#endif /* OMNI4_GETOPT_EXACT_H */
