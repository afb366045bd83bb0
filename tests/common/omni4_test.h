/* omni4_test.h - cmocka plus the few helpers every omni4 test uses. */
#ifndef OMNI4_TEST_H
#define OMNI4_TEST_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>

/* |got - want| <= tol, with both values in the failure message (cmocka 1.1.5 has no
 * assert_double_equal). NaN never passes. */
#define assert_near(got, want, tol)                                                                \
	omni4_assert_near((got), (want), (tol), #got, __FILE__, __LINE__)

static inline void omni4_assert_near(double got, double want, double tol, const char *expr,
                                     const char *file, int line)
{
	if (!(fabs(got - want) <= tol)) {
		print_error("%s:%d: %s = %.12g, want %.12g +- %.3g\n", file, line, expr, got, want,
		            tol);
		fail();
	}
}

#endif /* OMNI4_TEST_H */
