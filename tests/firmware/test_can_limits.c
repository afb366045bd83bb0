/* The SocketCAN plausibility limits the adapter computes from the controller's settings
 * (firmware can_limits.c), against the motor physics of docs/faults.md worked by hand. */
#include "omni4_test.h"

#include <math.h>
#include <string.h>

#include "omni4/firmware/can_limits.h"

/* The plausibility limits of the default robot (Table III, 12 V, 1 kHz), from the motor
 * physics of docs/faults.md: 2 x 12 V / 4.3111 ohm = 5.567 A per frame (+ noise), and a wheel
 * acceleration of at most 1532 rad/s^2 (1.53 rad/s per ms, + 2 LSB). */
static void test_default_limits_follow_the_motor_physics(void **state)
{
	(void)state;
	const struct sc_limits l = can_limits_default();

	print_message("plausibility: |di| <= %.3f A, |dw| <= %.3f rad/s per frame, over %.1f A "
	              "needs %d consecutive frames\n",
	              l.current_step_a, l.speed_step_rad_s, l.current_limit_a, l.confirm_frames);
	assert_near(l.current_step_a, 5.567 + 0.2 + 0.02, 0.01);
	assert_near(l.speed_step_rad_s, 1.532 + 0.25, 0.01);
	assert_int_equal(l.confirm_frames, 3);
	/* No plausible single step can trip the controller's encoder-jump fault (5 rad/s). */
	assert_true(l.speed_step_rad_s < 5.0f);
}

/* Drives that differ: the worst wheel sets each limit (R_2 10 % low: its current steps by
 * 2 x 12 V / (0.9 x 4.3111 ohm); r_1 5 % small: its rate steps the most). Equal wheel keys
 * give the default limits exactly. */
static void test_limits_follow_the_worst_wheel(void **state)
{
	(void)state;
	struct ctl_settings s;
	const struct sc_limits d = can_limits_default();

	ctl_settings_defaults(&s);
	model_wheels_from_params(&s.model, &s.wheels);
	s.wheel_keys = 0xffff;
	struct sc_limits l = can_limits_for(&s);

	assert_memory_equal(&l, &d, sizeof(l));
	s.wheels.R[2] = 0.9 * s.model.R;
	s.wheels.r[1] = 0.95 * s.model.r;
	l = can_limits_for(&s);
	const double i2 = 2.0 * 12.0 / (0.9 * 4.3111);
	/* wheel 2's force l Kt i2 / r over the default's l Kt i / r, the rate over r_1 */
	const double w_step = (d.speed_step_rad_s - 2.0 * CAN_SPEED_LSB) / 0.9 / 0.95;

	assert_near(l.current_step_a, i2 + 0.2 + CAN_CURR_LSB, 1e-4);
	assert_near(l.speed_step_rad_s, w_step + 2.0 * CAN_SPEED_LSB, 1e-4);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_default_limits_follow_the_motor_physics),
	    cmocka_unit_test(test_limits_follow_the_worst_wheel),
	};

	return cmocka_run_group_tests_name("can_limits", tests, NULL, NULL);
}
