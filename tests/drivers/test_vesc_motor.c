/* Tests for drivers/vesc/vesc_motor.c with the OS adapter (sc_os) mocked at link time: the
 * receive filters, a tick's commands decoded with the codec (duty = voltage / the controller's
 * measured input voltage; current = (u - Kv l w) / R), status frames into the sample, silence,
 * bus-off, stop on close and on halt. Expected numbers are computed here by hand. */
#include "sc_os_mock.h"

#include "omni4/drivers/vesc_motor.h"

#define TWO_PI 6.28318530717958647692

static const uint8_t ids[4] = {7, 3, 12, 200};
#define HOST_ID 254

/* Gear 5; wheel 2 has its own R (a per-wheel constant must be the wheel's). */
static struct vesc_motor_config config(enum vesc_mode mode)
{
	struct vesc_motor_config c = {.iface = "vcan0",
	                              .host_id = HOST_ID,
	                              .pole_pairs = 7,
	                              .mode = mode,
	                              .status_timeout_ms = 20,
	                              .consts = {.gear = 5.0}};

	for (int j = 0; j < 4; j++) {
		c.id[j] = ids[j];
		c.consts.w.r[j] = 0.03;
		c.consts.w.Kv[j] = 0.02;
		c.consts.w.Kt[j] = 0.025;
		c.consts.w.R[j] = j == 2 ? 4.0 : 2.0;
	}
	return c;
}

/* The backend opened as the loop holds it. */
static struct motor_hal open_backend(struct vesc_motor *m, enum vesc_mode mode)
{
	const struct vesc_motor_config c = config(mode);

	assert_int_equal(vesc_motor_open(m, &c), 0);
	return vesc_motor_hal(m);
}

static int reset(void **state)
{
	(void)state;
	mock_reset();
	return 0;
}

static void push_status(int j, int32_t erpm, float current_a, float input_v)
{
	const struct vesc_status1 s1 = {.erpm = erpm, .current_a = current_a, .duty = 0.1f};
	const struct vesc_status5 s5 = {.tacho_steps = 0, .input_v = input_v};
	struct omni4_can_frame f;

	assert_int_equal(vesc_encode_status1(ids[j], &s1, &f), 0);
	mock_push(&f);
	assert_int_equal(vesc_encode_status5(ids[j], &s5, &f), 0);
	mock_push(&f);
}

/* ERPM 7000 x (j + 1), current j + 0.5 A, input voltage 24 V (wheel 3: 23.5 V). */
static void push_all_status(void)
{
	for (int j = 0; j < 4; j++)
		push_status(j, 7000 * (j + 1), (float)j + 0.5f, j == 3 ? 23.5f : 24.0f);
}

/* The wheel speed [rad/s] of push_all_status's ERPM for wheel j: ERPM / 7 pole pairs / gear 5. */
static double speed_of(int j)
{
	return 7000.0 * (j + 1) / 7.0 * TWO_PI / 60.0 / 5.0;
}

/* The command sent to controller ids[j] in the last n frames: its kind and value. */
static float sent_value(int from, int j, enum vesc_cmd *kind)
{
	for (int k = from; k < mock_n_sent; k++) {
		uint8_t id;
		float v;

		for (int c = VESC_CMD_SET_DUTY; c <= VESC_CMD_SET_CURRENT; c++)
			if (vesc_decode_command(&mock_sent[k], (enum vesc_cmd)c, &id, &v) == 0 &&
			    id == ids[j]) {
				*kind = (enum vesc_cmd)c;
				return v;
			}
	}
	fail_msg("no command to controller %u", ids[j]);
	return NAN;
}

static void test_open_filters_admit_each_controllers_frames_only(void **state)
{
	(void)state;
	struct vesc_motor m;
	const struct vesc_motor_config c = config(VESC_MODE_DUTY);

	assert_int_equal(vesc_motor_open(&m, &c), 0);
	assert_string_equal(mock_iface, "vcan0");
	assert_int_equal(mock_n_sent, 0); /* nothing to start */
	for (int j = 0; j < 4; j++) {
		assert_true(mock_filter_passes(VESC_CAN_ID(VESC_CMD_STATUS_1, ids[j])));
		assert_true(mock_filter_passes(VESC_CAN_ID(VESC_CMD_STATUS_5, ids[j])));
	}
	/* another id's STATUS_1 (to name a controller on a wrong id), none of its other frames */
	assert_true(mock_filter_passes(VESC_CAN_ID(VESC_CMD_STATUS_1, 8)));
	assert_false(mock_filter_passes(VESC_CAN_ID(VESC_CMD_STATUS_5, 8)));
	/* the replies addressed to us, not those to another host */
	assert_true(mock_filter_passes(VESC_CAN_ID(VESC_CMD_PROCESS_SHORT_BUFFER, HOST_ID)));
	assert_false(mock_filter_passes(VESC_CAN_ID(VESC_CMD_PROCESS_SHORT_BUFFER, 253)));
	assert_false(mock_filter_passes(VESC_CMD_STATUS_1 << 8 | 7)); /* standard frame */
	assert_false(mock_filter_passes(VESC_CAN_ID(VESC_CMD_STATUS_1, 7) | 0x10000u));
	hal_motor_close(&(struct motor_hal){&vesc_motor_ops, &m});
}

static void test_status_frames_become_the_sample(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct motor_sample s;

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	assert_int_equal(hal_motor_read(&h, &s), -EAGAIN); /* nothing yet, within the timeout */
	push_all_status();
	mock_clock_us += 1000;
	assert_int_equal(hal_motor_read(&h, &s), 0);
	for (int j = 0; j < 4; j++) {
		assert_near(s.wheel_rad_s[j], speed_of(j), 1e-4);
		assert_near(s.current_a[j], j + 0.5, 1e-6);
	}
	assert_near(s.wheel_rad_s[0], 20.943951, 1e-5); /* 1000 motor rpm / 5 */
	/* the lowest input voltage times the duty limit: the most the drives apply (vesc.md) */
	assert_near(s.supply_v, 0.95 * 23.5, 1e-5);
	assert_int_equal(s.faults, 0);
	hal_motor_close(&h);
}

/* A read 4 ms after the last takes the frames of those 4 ms and more (the reports of a late
 * tick): 200 queued frames, the newest STATUS_1 last, reach the sample. */
static void test_a_late_read_reaches_the_newest_reports(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct motor_sample s;
	const struct vesc_motor_config c = config(VESC_MODE_DUTY);

	assert_int_equal(vesc_motor_open(&m, &c), 0);
	const struct motor_hal h = vesc_motor_hal(&m);

	for (int k = 0; k < 24; k++) /* 192 frames of older reports */
		for (int j = 0; j < 4; j++)
			push_status(j, 100 * k, 0.0f, 24.0f);
	push_all_status();
	mock_clock_us += 4000;
	assert_int_equal(hal_motor_read(&h, &s), 0);
	for (int j = 0; j < 4; j++)
		assert_near(s.wheel_rad_s[j], speed_of(j), 1e-4);
	hal_motor_close(&h);
}

static void test_duty_is_the_voltage_over_each_controllers_input_voltage(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct motor_sample s;
	const float volts[4] = {6.0f, -12.0f, 30.0f, 4.7f};
	const double want[4] = {0.25, -0.5, 0.95, 0.2}; /* 30 / 24: clamped; 4.7 / 23.5 */
	enum vesc_cmd kind;

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	assert_int_equal(hal_motor_enable(&h, true), 0);
	assert_int_equal(hal_motor_write(&h, volts), 0); /* no input voltage yet: released */
	for (int j = 0; j < 4; j++) {
		assert_near(sent_value(0, j, &kind), 0.0, 0.0);
		assert_int_equal(kind, VESC_CMD_SET_CURRENT);
	}
	push_all_status();
	assert_int_equal(hal_motor_read(&h, &s), 0);
	int from = mock_n_sent;

	assert_int_equal(hal_motor_write(&h, volts), 0);
	assert_int_equal(mock_n_sent - from, 4);
	for (int j = 0; j < 4; j++) {
		assert_near(sent_value(from, j, &kind), want[j], 1e-5);
		assert_int_equal(kind, VESC_CMD_SET_DUTY);
	}
	from = mock_n_sent;
	assert_int_equal(hal_motor_enable(&h, false), 0);
	assert_int_equal(hal_motor_write(&h, volts), 0); /* disabled: released */
	for (int j = 0; j < 4; j++) {
		assert_near(sent_value(from, j, &kind), 0.0, 0.0);
		assert_int_equal(kind, VESC_CMD_SET_CURRENT);
	}
	hal_motor_close(&h);
}

static void test_current_is_eq21_at_the_measured_speed(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct motor_sample s;
	const float volts[4] = {6.0f, -3.0f, 12.0f, 0.0f};
	enum vesc_cmd kind;

	const struct motor_hal h = open_backend(&m, VESC_MODE_CURRENT);

	push_all_status();
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(hal_motor_enable(&h, true), 0);
	const int from = mock_n_sent;

	assert_int_equal(hal_motor_write(&h, volts), 0);
	for (int j = 0; j < 4; j++) {
		/* motor speed l w = 1000 (j + 1) rpm; i = (u - Kv l w) / R */
		const double wm = 1000.0 * (j + 1) * TWO_PI / 60.0;
		const double want = (volts[j] - 0.02 * wm) / (j == 2 ? 4.0 : 2.0);

		assert_near(sent_value(from, j, &kind), want, 1e-3);
		assert_int_equal(kind, VESC_CMD_SET_CURRENT);
	}
	hal_motor_close(&h);
}

static void test_a_silent_controller_is_a_driver_timeout(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct motor_sample s;

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	push_all_status();
	assert_int_equal(hal_motor_read(&h, &s), 0);
	mock_clock_us += 15000;
	for (int j = 0; j < 3; j++) /* controller 3 falls silent */
		push_status(j, 7000, 1.0f, 24.0f);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, 0);
	mock_clock_us += 10000; /* 25 ms since its last STATUS_1 */
	for (int j = 0; j < 3; j++)
		push_status(j, 7000, 1.0f, 24.0f);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER_TIMEOUT);
	hal_motor_close(&h);
}

static void test_never_reporting_times_out_with_a_full_sample(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct motor_sample s;

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	mock_clock_us += 21000;
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER_TIMEOUT);
	for (int j = 0; j < 4; j++)
		assert_true(isfinite(s.wheel_rad_s[j]) && isfinite(s.current_a[j]));
	hal_motor_close(&h);
}

static void test_bus_off_is_a_bus_fault_until_cleared(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct motor_sample s;

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	push_all_status();
	mock_push_error(SC_ERR_BUSOFF);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_BUS);
	assert_int_equal(hal_motor_clear_faults(&h), 0);
	push_all_status();
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, 0);
	hal_motor_close(&h);
}

/* Close: the mode's zero to every controller (twice), then the socket closed. */
static void test_close_stops_every_controller(void **state)
{
	(void)state;
	struct vesc_motor m;
	enum vesc_cmd kind;

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	hal_motor_close(&h);
	assert_true(mock_closed);
	assert_int_equal(mock_n_sent, 8);
	for (int j = 0; j < 4; j++) {
		assert_near(sent_value(4, j, &kind), 0.0, 0.0);
		assert_int_equal(kind, VESC_CMD_SET_DUTY);
	}
}

/* Halt: the stop frames, and no write after it reaches the bus. */
static void test_halt_stops_and_drops_later_writes(void **state)
{
	(void)state;
	struct vesc_motor m;
	const float volts[4] = {6, 6, 6, 6};
	enum vesc_cmd kind;

	const struct motor_hal h = open_backend(&m, VESC_MODE_CURRENT);

	assert_int_equal(vesc_motor_halt(&m), 8);
	for (int j = 0; j < 4; j++) {
		assert_near(sent_value(0, j, &kind), 0.0, 0.0);
		assert_int_equal(kind, VESC_CMD_SET_CURRENT);
	}
	assert_int_equal(hal_motor_enable(&h, true), 0);
	assert_int_equal(hal_motor_write(&h, volts), 0);
	hal_motor_close(&h);
	assert_int_equal(mock_n_sent, 8);
	assert_true(mock_closed);
}

/* A reply to a fault code request as comm_can.c sends it, written here byte by byte:
 * PROCESS_SHORT_BUFFER (8) to `to`, [sender, 1 (a reply), COMM_GET_VALUES_SELECTIVE (50),
 * mask 0x00008000 (bit 15: the fault code) big-endian, the code]. */
static void push_fault_reply(uint8_t from, uint8_t to, uint8_t code)
{
	const struct omni4_can_frame f = {.id = OMNI4_CAN_EFF_FLAG | 0x0800u | to,
	                                  .dlc = 8,
	                                  .data = {from, 1, 50, 0x00, 0x00, 0x80, 0x00, code}};

	mock_push(&f);
}

/* Every 4th write asks one controller in turn: [host, 0 (process, reply to host), 50, mask
 * 0x00008000], 7 bytes, PROCESS_SHORT_BUFFER to the controller. Each is asked every 16. */
static void test_writes_ask_each_controller_for_its_fault_code_in_turn(void **state)
{
	(void)state;
	struct vesc_motor m;
	const float volts[4] = {0, 0, 0, 0};
	int asked[4] = {0};

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	for (int t = 0; t < 32; t++)
		assert_int_equal(hal_motor_write(&h, volts), 0);
	for (int k = 0; k < mock_n_sent; k++) {
		const struct omni4_can_frame *f = &mock_sent[k];

		if ((f->id & 0x1FFFFF00u) != 0x0800u)
			continue;
		assert_int_equal(f->id & ~0xFFu, OMNI4_CAN_EFF_FLAG | 0x0800u);
		assert_int_equal(f->dlc, 7);
		const uint8_t want[7] = {HOST_ID, 0, 50, 0x00, 0x00, 0x80, 0x00};

		assert_memory_equal(f->data, want, 7);
		for (int j = 0; j < 4; j++)
			asked[j] += (f->id & 0xFFu) == ids[j];
	}
	for (int j = 0; j < 4; j++)
		assert_int_equal(asked[j], 2); /* 32 writes: 8 requests, 2 to each */
	hal_motor_close(&h);
}

/* A fault code in a reply: DRIVER in the next sample, once; the same code again is no news, a
 * clear has it reported again; a code of 0 ends it; a reply to another host or with another
 * mask is not ours. The code is named for the summary. */
static void test_a_fault_code_is_a_driver_fault_reported_once_and_named(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct motor_sample s;
	char text[256];

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	push_all_status();
	push_fault_reply(ids[2], 253, 5); /* to another host */
	struct omni4_can_frame other_mask = {.id = OMNI4_CAN_EFF_FLAG | 0x0800u | HOST_ID,
	                                     .dlc = 8,
	                                     .data = {ids[2], 1, 50, 0x00, 0x00, 0x40, 0x00, 5}};

	mock_push(&other_mask);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, 0);
	assert_string_equal(vesc_motor_fault_text(&m, text, sizeof(text)), "none");
	push_all_status();
	push_fault_reply(ids[2], HOST_ID, 5); /* FAULT_CODE_OVER_TEMP_FET */
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER);
	push_all_status();
	push_fault_reply(ids[2], HOST_ID, 5);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, 0); /* reported once */
	assert_int_equal(hal_motor_clear_faults(&h), 0);
	push_all_status();
	push_fault_reply(ids[2], HOST_ID, 5); /* still there after the clear */
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER);
	push_all_status();
	push_fault_reply(ids[2], HOST_ID, 0);
	push_fault_reply(ids[0], HOST_ID, 2); /* FAULT_CODE_UNDER_VOLTAGE on wheel 0 */
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER);
	assert_string_equal(
	    vesc_motor_fault_text(&m, text, sizeof(text)),
	    "wheel 0 (id 7): under_voltage (2); wheel 2 (id 12): over_temp_fet (5)");
	hal_motor_close(&h);
}

/* A controller that stops reporting: no fault up to the timeout (20 ms), DRIVER_TIMEOUT within
 * 3 ticks (1 ms) after it. */
static void test_driver_timeout_within_three_ticks_of_the_timeout(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct motor_sample s;
	int fault_tick = -1;

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	push_all_status(); /* the last report of controller 1 */
	for (int t = 1; t <= 30 && fault_tick < 0; t++) {
		mock_clock_us += 1000;
		for (int j = 0; j < 4; j++)
			if (j != 1)
				push_status(j, 7000, 1.0f, 24.0f);
		assert_int_equal(hal_motor_read(&h, &s), 0);
		if (s.faults & HAL_FAULT_DRIVER_TIMEOUT)
			fault_tick = t;
	}
	assert_true(fault_tick > 20 && fault_tick <= 23);
	hal_motor_close(&h);
}

/* Start-up with controller 3 on a wrong id (13): one missing, named with the id heard. */
static void test_a_controller_on_a_wrong_id_is_named_with_the_id_heard(void **state)
{
	(void)state;
	struct vesc_motor m;
	char text[256];
	const struct vesc_status1 s1 = {.erpm = 0, .current_a = 0, .duty = 0};
	struct omni4_can_frame f;

	const struct motor_hal h = open_backend(&m, VESC_MODE_DUTY);

	assert_int_equal(vesc_motor_poll_missing(&m), 4);
	assert_string_equal(vesc_motor_missing_text(&m, text, sizeof(text)),
	                    "no STATUS_1 from id 7 (wheel 0), id 3 (wheel 1), id 12 (wheel 2), "
	                    "id 200 (wheel 3); no other VESC heard");
	for (int j = 0; j < 3; j++)
		push_status(j, 0, 0.0f, 24.0f);
	assert_int_equal(vesc_encode_status1(13, &s1, &f), 0);
	mock_push(&f);
	assert_int_equal(vesc_motor_poll_missing(&m), 1);
	assert_string_equal(vesc_motor_missing_text(&m, text, sizeof(text)),
	                    "no STATUS_1 from id 200 (wheel 3); heard instead: id 13");
	push_status(3, 0, 0.0f, 24.0f);
	assert_int_equal(vesc_motor_poll_missing(&m), 0);
	assert_string_equal(vesc_motor_missing_text(&m, text, sizeof(text)), "");
	hal_motor_close(&h);
}

/* host_id must be none of the controllers' ids (their replies would go to a VESC). */
static void test_a_host_id_equal_to_a_controller_id_is_refused(void **state)
{
	(void)state;
	struct vesc_motor m;
	struct vesc_motor_config c = config(VESC_MODE_DUTY);

	c.host_id = ids[1];
	assert_int_equal(vesc_motor_open(&m, &c), -EINVAL);
	c.host_id = 255;
	assert_int_equal(vesc_motor_open(&m, &c), -EINVAL);
	assert_false(mock_open);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test_setup(test_open_filters_admit_each_controllers_frames_only, reset),
	    cmocka_unit_test_setup(test_status_frames_become_the_sample, reset),
	    cmocka_unit_test_setup(test_a_late_read_reaches_the_newest_reports, reset),
	    cmocka_unit_test_setup(test_duty_is_the_voltage_over_each_controllers_input_voltage,
	                           reset),
	    cmocka_unit_test_setup(test_current_is_eq21_at_the_measured_speed, reset),
	    cmocka_unit_test_setup(test_a_silent_controller_is_a_driver_timeout, reset),
	    cmocka_unit_test_setup(test_never_reporting_times_out_with_a_full_sample, reset),
	    cmocka_unit_test_setup(test_bus_off_is_a_bus_fault_until_cleared, reset),
	    cmocka_unit_test_setup(test_close_stops_every_controller, reset),
	    cmocka_unit_test_setup(test_halt_stops_and_drops_later_writes, reset),
	    cmocka_unit_test_setup(test_writes_ask_each_controller_for_its_fault_code_in_turn,
	                           reset),
	    cmocka_unit_test_setup(test_a_fault_code_is_a_driver_fault_reported_once_and_named,
	                           reset),
	    cmocka_unit_test_setup(test_driver_timeout_within_three_ticks_of_the_timeout, reset),
	    cmocka_unit_test_setup(test_a_controller_on_a_wrong_id_is_named_with_the_id_heard,
	                           reset),
	    cmocka_unit_test_setup(test_a_host_id_equal_to_a_controller_id_is_refused, reset),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
