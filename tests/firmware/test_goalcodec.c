/* goal_t off the wire (goalcodec.c): a round trip through the generated encoder, a count out of
 * range refused from the header with the goal's id (the sender hears why), and datagrams whose
 * length does not hold the poses they announce refused before any allocation. The wire layout
 * (LCM: an 8-byte fingerprint, then the fields big-endian in order) is written out here: n at
 * 8 + 8 + 8 + 8 + 1 = 33. */
#include "omni4_test.h"

#include <errno.h>
#include <stdint.h>
#include <string.h>

#include "omni4/core/goal.h"
#include "omni4/firmware/goalcodec.h"
#include "omni4_goal_t.h"

#define N_AT 33

static int encode(int32_t n, uint8_t *buf, int cap)
{
	static double poses[64][3];
	static double *rows[64];
	omni4_goal_t m = {.utime = 5,
	                  .seq = 6,
	                  .goal_id = 77,
	                  .action = 1,
	                  .n = n,
	                  .poses = rows,
	                  .blend_m = 0.2,
	                  .speed_max = 1.5};

	for (int i = 0; i < n; i++) {
		poses[i][0] = i, poses[i][1] = -i, poses[i][2] = 0.1 * i;
		rows[i] = poses[i];
	}
	return omni4_goal_t_encode(buf, 0, cap, &m);
}

static void put_be32(uint8_t *p, uint32_t v)
{
	for (int i = 0; i < 4; i++)
		p[i] = (uint8_t)(v >> (24 - 8 * i));
}

static void test_round_trip_and_out_of_range(void **state)
{
	(void)state;
	uint8_t buf[4096];
	struct goal_cmd g;
	int len = encode(2, buf, sizeof(buf));

	assert_int_equal(len, 53 + 24 * 2);
	assert_int_equal(lcmio_decode_goal(buf, (size_t)len, &g), 0);
	assert_int_equal(g.id, 77);
	assert_int_equal(g.n, 2);
	assert_true(g.poses[1][0] == 1.0 && g.poses[1][1] == -1.0 && g.poses[1][2] == 0.1);
	assert_true(g.blend_m == 0.2 && g.speed_max == 1.5);

	len = encode(GOAL_POSES_MAX + 1, buf, sizeof(buf));
	assert_int_equal(lcmio_decode_goal(buf, (size_t)len, &g), -E2BIG);
	assert_int_equal(g.id, 77); /* refused with the goal's id */
	assert_int_equal(g.n, -1);
	len = encode(1, buf, sizeof(buf));
	put_be32(buf + N_AT, 0xffffffffu); /* n = -1 */
	assert_int_equal(lcmio_decode_goal(buf, (size_t)len, &g), -EDOM);
	assert_int_equal(g.id, 77);
	/* a short datagram announcing 2^31 - 1 poses (51 GB to the generated decoder): refused
	 * from its header */
	put_be32(buf + N_AT, 0x7fffffffu);
	assert_int_equal(lcmio_decode_goal(buf, (size_t)len, &g), -E2BIG);
	assert_int_equal(g.id, 77);
}

static void test_lengths_that_do_not_hold_the_poses(void **state)
{
	(void)state;
	uint8_t buf[4096];
	struct goal_cmd g;
	const int len = encode(3, buf, sizeof(buf));

	put_be32(buf + N_AT, 2); /* announces fewer than it carries */
	assert_int_equal(lcmio_decode_goal(buf, (size_t)len, &g), -EINVAL);
	put_be32(buf + N_AT, 3);
	assert_int_equal(lcmio_decode_goal(buf, (size_t)len - 1, &g), -EINVAL); /* truncated */
	assert_int_equal(lcmio_decode_goal(buf, N_AT + 3, &g), -EINVAL);        /* no count */
	buf[0] ^= 1;                                                            /* not a goal_t */
	assert_int_equal(lcmio_decode_goal(buf, (size_t)len, &g), -EINVAL);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_round_trip_and_out_of_range),
	    cmocka_unit_test(test_lengths_that_do_not_hold_the_poses),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
