/* Current-sense offset calibration: the block (core/src/ctl_blocks.c) against closed forms,
 * the controller's boundaries pinned from the specification (docs/faults.md: the numbers are
 * written here, not taken from the code's constants), and the announcement the loop puts in
 * its log ring, encoded as the param_changed_t that goes out on OMNI4_PARAM_CHANGED.
 * 1 tick = 1 ms (default loop rate 1 kHz); samples are exact unless noise is added here. */
#include "omni4_test.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "omni4/core/ctl.h"
#include "omni4/core/ctl_blocks.h"
#include "omni4/core/fw.h"
#include "omni4/firmware/lcmio.h"
#include "omni4/model/rng.h"
#include "omni4_motors_t.h"
#include "omni4_param_changed_t.h"

/* docs/faults.md, "current-sense offset" rows */
#define SPEC_SETTLE_MS 50       /* bridges off this long before a reading counts */
#define SPEC_SAMPLES 400        /* readings per channel in one measurement */
#define SPEC_LIMIT_A 0.25       /* an offset beyond it: FAULT CURRENT_SENSOR */
#define SPEC_CHANGE_MIN_A 0.005 /* a new set needs a channel moved by more than 5 mA ... */
#define SPEC_CHANGE_SIGMAS 5.0  /* ... and by more than 5 standard errors */
#define SPEC_CURRENT_MAX_A 5.0  /* over-current: > current_max_a, 5 A */
#define SPEC_SUPPLY_V 12.0
#define TICK_US 1000
/* The first set at start-up: readings from 50 ms on, the 400th at 449 ms. */
#define SPEC_FIRST_SET_MS (SPEC_SETTLE_MS + SPEC_SAMPLES - 1)

static const int32_t CS = OMNI4_MOTORS_T_FAULT_CURRENT_SENSOR;
static const int32_t OC = OMNI4_MOTORS_T_FAULT_OVERCURRENT;

/* ---- the block on its own ------------------------------------------------------------ */

static struct ctl_cal_cfg spec_cfg(void)
{
	return (struct ctl_cal_cfg){.samples = SPEC_SAMPLES,
	                            .settle_us = SPEC_SETTLE_MS * 1000,
	                            .limit_a = (float)SPEC_LIMIT_A,
	                            .change_min_a = (float)SPEC_CHANGE_MIN_A,
	                            .change_sigmas = (float)SPEC_CHANGE_SIGMAS};
}

static void noisy(struct rng *g, const double c[4], double sigma, float out[4])
{
	for (int j = 0; j < 4; j++)
		out[j] = (float)(c[j] + rng_normal(g, sigma));
}

/* Constant offsets plus Gaussian noise: each channel's mean within 3 standard errors
 * (sigma / sqrt(N)) of its constant, the spread within 20 % of sigma; and over 300
 * independent measurements the share outside 3 SE is what a normal mean gives (0.27 %). */
static void test_block_mean_of_constants_plus_noise(void **state)
{
	(void)state;
	static const double c[4] = {0.05, -0.05, 0.03, -0.02};
	const double sigma = 0.02, se = sigma / sqrt(SPEC_SAMPLES);
	const struct ctl_cal_cfg cfg = spec_cfg();
	struct ctl_cal cal;
	struct rng g;
	int outside = 0, n = 0;

	for (int run = 0; run < 300; run++) {
		int64_t t = 0;
		float x[4];
		bool done = false;

		rng_seed(&g, 1000 + (uint64_t)run);
		ctl_cal_init(&cal, &cfg);
		for (int k = 0; !done; k++, t += TICK_US) {
			noisy(&g, c, sigma, x);
			done = ctl_cal_step(&cal, t, true, x);
			assert_true(k <= SPEC_FIRST_SET_MS);
		}
		assert_int_equal(cal.gen, 1);
		for (int j = 0; j < 4; j++, n++) {
			outside += fabs(cal.offset[j] - c[j]) > 3 * se;
			if (run == 0) {
				assert_near(cal.offset[j], c[j], 3 * se);
				assert_near(sqrt(cal.var[j]), sigma, 0.2 * sigma);
			}
		}
	}
	/* Binomial(1200, 0.0027): mean 3.2; more than 12 has p < 1e-4. */
	print_message("block: %d of %d channel means outside 3 SE\n", outside, n);
	assert_true(outside <= 12);
}

/* A reading with the bridges on drops the measurement in progress, and the settle time starts
 * again: 399 readings of 0.2 A, one tick driven, then 0.05 A: the set is exactly 0.05 A, from
 * the 400th reading taken 50 ms after the bridges went off again. */
static void test_block_drive_aborts_the_measurement(void **state)
{
	(void)state;
	const struct ctl_cal_cfg cfg = spec_cfg();
	struct ctl_cal cal;
	const float a[4] = {0.2f, 0.2f, 0.2f, 0.2f}, b[4] = {0.05f, -0.05f, 0.03f, -0.02f};
	int64_t t = 0;

	ctl_cal_init(&cal, &cfg);
	for (int k = 0; k < SPEC_SETTLE_MS + SPEC_SAMPLES - 1; k++, t += TICK_US)
		assert_false(ctl_cal_step(&cal, t, true, a));
	assert_false(ctl_cal_step(&cal, t, false, a)); /* driven */
	t += TICK_US;
	const int64_t off = t;

	for (;; t += TICK_US) {
		const bool done = ctl_cal_step(&cal, t, true, b);

		if (done)
			break;
		assert_true(t - off < (SPEC_SETTLE_MS + SPEC_SAMPLES) * TICK_US);
	}
	assert_int_equal(t - off, (int64_t)SPEC_FIRST_SET_MS * TICK_US);
	for (int j = 0; j < 4; j++)
		assert_true(cal.offset[j] == b[j]);
	assert_int_equal(cal.gen, 1);
	assert_int_equal(cal.fault_mask, 0);
}

/* Ticks without a new reading (NULL) count neither way; a restart drops what was read. */
static void test_block_counts_readings_not_ticks(void **state)
{
	(void)state;
	const struct ctl_cal_cfg cfg = spec_cfg();
	struct ctl_cal cal;
	const float a[4] = {0.1f, 0.1f, 0.1f, 0.1f}, b[4] = {0.02f, 0.02f, 0.02f, 0.02f};
	int64_t t = (int64_t)SPEC_SETTLE_MS * TICK_US;
	int readings = 0;

	ctl_cal_init(&cal, &cfg);
	assert_false(ctl_cal_step(&cal, 0, true, NULL)); /* the bridges are off from t = 0 */
	for (int k = 0; k < 100; k++, t += TICK_US)
		assert_false(ctl_cal_step(&cal, t, true, a));
	ctl_cal_restart(&cal); /* a reading that could not be trusted: the 100 are dropped */
	for (;; t += TICK_US) {
		const bool fresh = (t / TICK_US) % 3 != 0;
		const bool done = ctl_cal_step(&cal, t, true, fresh ? b : NULL);

		readings += fresh;
		if (done)
			break;
		assert_true(readings < SPEC_SAMPLES);
	}
	assert_int_equal(readings, SPEC_SAMPLES);
	for (int j = 0; j < 4; j++)
		assert_true(cal.offset[j] == b[j]);
}

/* ---- the controller: boundaries from the specification -------------------------------- */

static struct ctl c;

static void setup_ctl(void)
{
	struct ctl_settings cfg;

	ctl_settings_defaults(&cfg);
	assert_int_equal(ctl_init(&c, &cfg), 0);
}

static struct motor_sample reading(const double cur[4])
{
	struct motor_sample s;

	memset(&s, 0, sizeof(s));
	s.supply_v = (float)SPEC_SUPPLY_V;
	for (int j = 0; j < 4; j++)
		s.current_a[j] = (float)cur[j];
	return s;
}

static struct ctl_output step_at(int64_t t_us, const double cur[4])
{
	const struct motor_sample s = reading(cur);
	struct ctl_output o;

	ctl_step(&c, t_us, &s, 0, false, &o);
	return o;
}

static int command(int8_t mode, const double volt[4], int64_t t_us)
{
	struct ctl_command cmd = {.utime = t_us, .mode = mode};

	if (volt)
		memcpy(cmd.voltage, volt, sizeof(cmd.voltage));
	return ctl_command(&c, &cmd, t_us);
}

/* An idle controller from t = 0 on readings `cur`: ticks up to and including ms. */
static struct ctl_output idle_until(int ms, const double cur[4])
{
	struct ctl_output o;

	for (int k = 0; k <= ms; k++)
		o = step_at((int64_t)k * TICK_US, cur);
	return o;
}

/* Readings of 0.2 A while the settle time runs, then 0.05 / -0.05 / 0.03 / -0.02 A: after
 * N - 1 readings nothing is subtracted yet, the N-th reading is the first with the offsets
 * subtracted (exactly 0), and the settle-time readings are not in the mean. */
static void test_start_up_set_after_settle_time_and_n_readings(void **state)
{
	(void)state;
	static const double settle[4] = {0.2, 0.2, 0.2, 0.2};
	static const double off[4] = {0.05, -0.05, 0.03, -0.02};
	struct ctl_output o;

	setup_ctl();
	for (int k = 0; k < SPEC_SETTLE_MS; k++)
		step_at((int64_t)k * TICK_US, settle);
	for (int k = SPEC_SETTLE_MS; k < SPEC_FIRST_SET_MS; k++) {
		o = step_at((int64_t)k * TICK_US, off);
		for (int j = 0; j < 4; j++)
			assert_true(o.current[j] == (float)off[j]); /* raw: not calibrated */
	}
	assert_int_equal(c.cal.gen, 0); /* N - 1 readings */
	o = step_at((int64_t)SPEC_FIRST_SET_MS * TICK_US, off);
	assert_int_equal(c.cal.gen, 1); /* N readings */
	for (int j = 0; j < 4; j++) {
		assert_true(o.current[j] == 0.0f);
		assert_true(c.cal.offset[j] == (float)off[j]);
	}
	assert_int_equal(o.faults, 0);
	assert_int_equal(o.mode, CTL_IDLE);
}

/* The same boundary counted in readings: a reading every other tick (the rest -EAGAIN). */
static void test_start_up_set_counts_readings(void **state)
{
	(void)state;
	static const double off[4] = {0.01, 0.02, 0.03, 0.04};
	const struct motor_sample s = reading(off);
	struct ctl_output o;
	int readings = 0;

	setup_ctl();
	for (int k = 0; c.cal.gen == 0; k++) {
		const bool fresh = k % 2 == 0;

		ctl_step(&c, (int64_t)k * TICK_US, &s, fresh ? 0 : -EAGAIN, false, &o);
		readings += fresh && k >= SPEC_SETTLE_MS;
		assert_true(readings <= SPEC_SAMPLES);
	}
	assert_int_equal(readings, SPEC_SAMPLES);
}

/* Commands are taken before the first set (offsets 0 until then); a drive drops the start-up
 * measurement; the set comes 50 ms + 400 readings after the bridges are off again. */
static void test_commands_before_calibration_and_drive_aborts_it(void **state)
{
	(void)state;
	static const double off[4] = {0.05, 0.05, 0.05, 0.05};
	static const double volts[4] = {1, 1, 1, 1};
	struct ctl_output o;
	int k = 0;

	setup_ctl();
	for (; k < 300; k++)
		o = step_at((int64_t)k * TICK_US, off);
	assert_int_equal(command(CTL_VOLTAGE, volts, (int64_t)k * TICK_US), 0);
	for (; k < 1300; k++) {
		if (k % 100 == 0)
			assert_int_equal(command(CTL_VOLTAGE, volts, (int64_t)k * TICK_US), 0);
		o = step_at((int64_t)k * TICK_US, off);
		assert_true(o.enable);
		assert_true(o.current[0] == 0.05f); /* nothing subtracted */
	}
	assert_int_equal(c.cal.gen, 0);
	assert_int_equal(command(CTL_IDLE, NULL, (int64_t)k * TICK_US), 0);
	o = step_at((int64_t)k * TICK_US, off); /* bridges switched off in this tick */
	assert_false(o.enable);
	const int first_off = k + 1; /* the first reading taken with them off */

	for (k++; c.cal.gen == 0; k++) {
		o = step_at((int64_t)k * TICK_US, off);
		assert_true(k <= first_off + SPEC_FIRST_SET_MS);
	}
	assert_int_equal(k - 1, first_off + SPEC_FIRST_SET_MS);
	assert_true(o.current[0] == 0.0f);
}

/* A reading that cannot be trusted (lost: read error; NaN; a driver-side fault) drops the
 * measurement in progress: 200 readings of 0.2 A, the bad one, then 0.05 A: the set is
 * exactly 0.05 A, from the 400th reading after the bad one (the settle time is not repeated:
 * the bridges stayed off). */
static void test_bad_reading_restarts_the_measurement(void **state)
{
	(void)state;
	static const double a[4] = {0.2, 0.2, 0.2, 0.2}, b[4] = {0.05, 0.05, 0.05, 0.05};

	for (int kind = 0; kind < 3; kind++) {
		struct motor_sample bad = reading(b);
		struct ctl_output o;
		int k = 0;

		setup_ctl();
		for (; k < SPEC_SETTLE_MS + 200; k++)
			step_at((int64_t)k * TICK_US, a);
		if (kind == 1)
			bad.current_a[1] = NAN;
		if (kind == 2)
			bad.faults = HAL_FAULT_DRIVER;
		ctl_step(&c, (int64_t)k * TICK_US, &bad, kind == 0 ? -EIO : 0, false, &o);
		const int bad_at = k++;

		for (; c.cal.gen == 0; k++) {
			step_at((int64_t)k * TICK_US, b);
			assert_true(k <= bad_at + SPEC_SAMPLES);
		}
		assert_int_equal(k - 1, bad_at + SPEC_SAMPLES);
		for (int j = 0; j < 4; j++)
			assert_true(c.cal.offset[j] == 0.05f);
	}
}

/* The limit, on every channel and both signs: limit - 1 mA is a set without fault, limit +
 * 1 mA latches FAULT CURRENT_SENSOR with that channel flagged. */
static void test_offset_limit_just_inside_and_just_outside(void **state)
{
	(void)state;
	for (int j = 0; j < 4; j++) {
		for (int sign = -1; sign <= 1; sign += 2) {
			for (int beyond = 0; beyond <= 1; beyond++) {
				double cur[4] = {0, 0, 0, 0};

				cur[j] = sign * (SPEC_LIMIT_A + (beyond ? 0.001 : -0.001));
				setup_ctl();
				const struct ctl_output o = idle_until(SPEC_FIRST_SET_MS, cur);

				assert_int_equal(c.cal.gen, 1);
				if (beyond) {
					assert_int_equal(o.mode, CTL_FAULT);
					assert_int_equal(o.faults, CS);
					assert_int_equal(c.cal.fault_mask, 1u << j);
					assert_false(o.enable);
				} else {
					assert_int_equal(o.mode, CTL_IDLE);
					assert_int_equal(o.faults, 0);
					assert_int_equal(c.cal.fault_mask, 0);
				}
			}
		}
	}
}

/* The over-current check sees the reading minus the offset in force: with 0.2 A calibrated on
 * channel 1, a reading of 5.19 A (4.99 A) is no over-current, 5.21 A (5.01 A) is. */
static void test_overcurrent_check_sees_the_offset_subtracted(void **state)
{
	(void)state;
	static const double off[4] = {0, 0.2, 0, 0};

	for (int above = 0; above <= 1; above++) {
		setup_ctl();
		idle_until(SPEC_FIRST_SET_MS, off);
		assert_int_equal(c.cal.gen, 1);
		const double cur[4] = {0, 0.2 + SPEC_CURRENT_MAX_A + (above ? 0.01 : -0.01), 0, 0};
		const struct ctl_output o = step_at((SPEC_FIRST_SET_MS + 1) * TICK_US, cur);

		assert_near(o.current[1], cur[1] - 0.2, 1e-6);
		if (above) {
			assert_int_equal(o.faults, OC);
			assert_int_equal(o.mode, CTL_FAULT);
		} else {
			assert_int_equal(o.faults, 0);
		}
	}
}

/* While the bridges stay off, measurement follows measurement; a new set comes into force only
 * when a channel moved by more than 5 mA (noise-free readings here: the standard-error term is
 * 0): 4 mA stays, 6 mA is taken, with the previous set kept for the announcement. */
static void test_recalibration_only_past_5_mA(void **state)
{
	(void)state;
	double cur[4] = {0.05, -0.05, 0.03, -0.02};
	int k = 0;

	setup_ctl();
	for (; k <= SPEC_FIRST_SET_MS; k++)
		step_at((int64_t)k * TICK_US, cur);
	assert_int_equal(c.cal.gen, 1);
	cur[2] += SPEC_CHANGE_MIN_A - 0.001;
	for (int m = 0; m < 3 * SPEC_SAMPLES; m++, k++)
		step_at((int64_t)k * TICK_US, cur);
	assert_int_equal(c.cal.gen, 1);
	assert_true(c.cal.offset[2] == 0.03f);
	cur[2] = 0.03 + SPEC_CHANGE_MIN_A + 0.001;
	int taken_at = -1;

	for (int m = 0; m < 2 * SPEC_SAMPLES && taken_at < 0; m++, k++) {
		step_at((int64_t)k * TICK_US, cur);
		if (c.cal.gen == 2)
			taken_at = m;
	}
	/* The measurement running when the reading changed mixes both values: within two. */
	assert_true(taken_at >= 0);
	assert_near(c.cal.offset[2], 0.036, 0.0011);
	assert_true(c.cal.prev[2] == 0.03f);
	assert_true(c.cal.prev[0] == 0.05f);
}

/* With noise (20 mA, the sim's), measurement after measurement of the same offsets for 60 s
 * (150 measurements) brings no new set: the offsets do not jump by noise. */
static void test_recalibration_does_not_follow_noise(void **state)
{
	(void)state;
	static const double off[4] = {0.05, -0.05, 0.03, -0.02};
	struct rng g;
	float x[4];
	double cur[4];

	rng_seed(&g, 7);
	setup_ctl();
	for (int k = 0; k < 60000; k++) {
		noisy(&g, off, 0.02, x);
		for (int j = 0; j < 4; j++)
			cur[j] = x[j];
		step_at((int64_t)k * TICK_US, cur);
	}
	assert_int_equal(c.cal.gen, 1);
	for (int j = 0; j < 4; j++) /* the first set's: 4 SE (p = 6e-5 a channel) */
		assert_near(c.cal.offset[j], off[j], 4 * 0.02 / sqrt(SPEC_SAMPLES));
}

/* An offset beyond the limit is present until a set within it comes into force: a clear is
 * refused while it is, and taken once the sensor reads 0 again and was re-measured. */
static void test_offset_fault_clears_only_after_a_good_set(void **state)
{
	(void)state;
	double cur[4] = {0, 0, 0.3, 0};
	int k = 0;

	setup_ctl();
	for (; k <= SPEC_FIRST_SET_MS; k++)
		step_at((int64_t)k * TICK_US, cur);
	assert_int_equal(c.mode, CTL_FAULT);
	assert_int_equal(command(CTL_CLEAR_FAULT, NULL, (int64_t)k * TICK_US), -EBUSY);
	cur[2] = 0.0;
	for (int m = 0; m < 2 * SPEC_SAMPLES && c.cal.gen < 2; m++, k++)
		step_at((int64_t)k * TICK_US, cur);
	assert_int_equal(c.cal.gen, 2);
	assert_int_equal(c.cal.fault_mask, 0);
	step_at((int64_t)k++ * TICK_US, cur);
	assert_int_equal(command(CTL_CLEAR_FAULT, NULL, (int64_t)k * TICK_US), 0);
	const struct ctl_output o = step_at((int64_t)k * TICK_US, cur);

	assert_int_equal(o.mode, CTL_IDLE);
	assert_int_equal(o.faults, 0);
}

/* ---- the loop: the announcement in the log ring, as sent on OMNI4_PARAM_CHANGED ---------- */

struct fake_motor {
	double cur[4];
	bool enabled;
};

static int fake_enable(void *ctx, bool on)
{
	((struct fake_motor *)ctx)->enabled = on;
	return 0;
}

static int fake_write(void *ctx, const float volts[4])
{
	(void)ctx;
	(void)volts;
	return 0;
}

static int fake_read(void *ctx, struct motor_sample *out)
{
	*out = reading(((struct fake_motor *)ctx)->cur);
	return 0;
}

static const struct motor_hal_ops fake_ops = {
    .enable = fake_enable, .write = fake_write, .read = fake_read};

static struct fw g_fw;
static struct fake_motor g_motor;

struct ring_view {
	int64_t notice_seq, notice_utime;
	struct log_entry notice;
	int notices;
	omni4_motors_t before, at; /* the samples of ticks notice_seq - 1 and notice_seq */
};

/* Tick the loop n times from tick `from` and look at what it logged. */
static struct ring_view run_loop(int from, int n)
{
	struct ring_view v = {.notice_seq = -1};
	struct log_entry e;

	for (int k = from; k < from + n; k++) {
		fw_tick(&g_fw, (int64_t)k * TICK_US);
		while (fw_pop_log(&g_fw, &e)) {
			if (e.kind == LOG_CALIBRATION) {
				assert_int_equal(v.notices, 0);
				v.notices++;
				v.notice = e;
				v.notice_seq = e.seq;
				v.notice_utime = e.utime;
				continue;
			}
			if (e.kind != LOG_MOTORS)
				continue;
			omni4_motors_t m = {.utime = e.utime, .seq = e.seq};

			memcpy(m.current, e.sample.current, sizeof(m.current));
			if (v.notices == 0)
				v.before = m;
			else if (e.seq == v.notice_seq)
				v.at = m;
		}
	}
	return v;
}

/* The notice as omni4-fw publishes it. */
static omni4_param_changed_t encode_decode(const struct log_entry *e)
{
	unsigned char buf[LCMIO_MAX_MSG];
	const char *channel = NULL;
	omni4_param_changed_t m;
	const int len = lcmio_encode_log(e, buf, sizeof(buf), &channel);

	assert_true(len > 0);
	assert_string_equal(channel, "OMNI4_PARAM_CHANGED");
	assert_int_equal(omni4_param_changed_t_decode(buf, 0, len, &m), len);
	return m;
}

static void assert_key(const omni4_param_changed_t *m, int i, const char *key, const char *old,
                       const char *value)
{
	assert_true(i < m->n);
	assert_string_equal(m->keys[i], key);
	assert_string_equal(m->old_values[i], old);
	assert_string_equal(m->values[i], value);
}

static void test_announcement_names_the_first_tick_and_the_values(void **state)
{
	(void)state;
	struct ctl_settings cfg;

	ctl_settings_defaults(&cfg);
	g_motor = (struct fake_motor){.cur = {0.05, -0.05, 0.03, -0.02}};
	assert_int_equal(fw_init(&g_fw, &cfg, (struct motor_hal){.ops = &fake_ops, .ctx = &g_motor},
	                         (struct line_hal){.ops = &line_none_ops}),
	                 0);
	/* Two measurements: the first set at 449 ms, the second (unchanged) dropped at 849 ms. */
	struct ring_view v = run_loop(0, SPEC_SETTLE_MS + 2 * SPEC_SAMPLES);

	/* The tick of the notice is the first sample with the offsets subtracted. */
	assert_int_equal(v.notices, 1);
	assert_int_equal(v.notice_seq, SPEC_FIRST_SET_MS);
	assert_int_equal(v.before.seq, v.notice_seq - 1);
	assert_int_equal(v.at.seq, v.notice_seq);
	assert_int_equal(v.at.utime, v.notice_utime);
	for (int j = 0; j < 4; j++) {
		assert_true(v.before.current[j] == (float)g_motor.cur[j]);
		assert_true(v.at.current[j] == 0.0f);
	}
	omni4_param_changed_t m = encode_decode(&v.notice);

	assert_string_equal(m.source, "calibration");
	assert_string_equal(m.path, "");
	assert_int_equal(m.request_id, 0);
	assert_int_equal(m.seq, v.notice_seq);
	assert_int_equal(m.utime, v.notice_utime);
	assert_int_equal(m.n, 5);
	assert_key(&m, 0, "calibration.current_offset_a0", "0.000000", "0.050000");
	assert_key(&m, 1, "calibration.current_offset_a1", "0.000000", "-0.050000");
	assert_key(&m, 2, "calibration.current_offset_a2", "0.000000", "0.030000");
	assert_key(&m, 3, "calibration.current_offset_a3", "0.000000", "-0.020000");
	assert_key(&m, 4, "calibration.samples", "0", "400");
	omni4_param_changed_t_decode_cleanup(&m);

	/* The offset of channel 0 moves by 10 mA: the next measurement is a new set. */
	g_motor.cur[0] = 0.06;
	v = run_loop(SPEC_SETTLE_MS + 2 * SPEC_SAMPLES, 2 * SPEC_SAMPLES);
	assert_int_equal(v.notice_seq, SPEC_FIRST_SET_MS + 2 * SPEC_SAMPLES);
	assert_int_equal(v.notices, 1);
	for (int j = 0; j < 4; j++)
		assert_true(v.at.current[j] == 0.0f);
	assert_true(v.before.current[0] > 0.009f);
	m = encode_decode(&v.notice);
	assert_int_equal(m.n, 5);
	assert_key(&m, 0, "calibration.current_offset_a0", "0.050000", "0.060000");
	assert_key(&m, 1, "calibration.current_offset_a1", "-0.050000", "-0.050000");
	assert_key(&m, 4, "calibration.samples", "400", "400");
	omni4_param_changed_t_decode_cleanup(&m);
}

/* Beyond the limit: the notice carries the measured values and the channels named. */
static void test_announcement_names_the_channels_beyond_the_limit(void **state)
{
	(void)state;
	struct ctl_settings cfg;

	ctl_settings_defaults(&cfg);
	g_motor = (struct fake_motor){.cur = {-0.4, 0.1, 0, 0.3}};
	assert_int_equal(fw_init(&g_fw, &cfg, (struct motor_hal){.ops = &fake_ops, .ctx = &g_motor},
	                         (struct line_hal){.ops = &line_none_ops}),
	                 0);
	struct ring_view v = run_loop(0, SPEC_SETTLE_MS + 2 * SPEC_SAMPLES);

	assert_int_equal(v.notices, 1);
	assert_int_equal(g_fw.last_out.mode, CTL_FAULT);
	assert_true(g_fw.last_out.faults & CS);
	omni4_param_changed_t m = encode_decode(&v.notice);

	assert_int_equal(m.n, 6);
	assert_key(&m, 0, "calibration.current_offset_a0", "0.000000", "-0.400000");
	assert_key(&m, 3, "calibration.current_offset_a3", "0.000000", "0.300000");
	assert_key(&m, 5, "calibration.fault_channels", "", "0,3");
	omni4_param_changed_t_decode_cleanup(&m);

	/* Channel 0 repaired: a new set with channel 3 alone beyond the limit. */
	g_motor.cur[0] = 0.0;
	v = run_loop(SPEC_SETTLE_MS + 2 * SPEC_SAMPLES, 2 * SPEC_SAMPLES);
	assert_int_equal(v.notices, 1);
	m = encode_decode(&v.notice);
	assert_key(&m, 5, "calibration.fault_channels", "0,3", "3");
	omni4_param_changed_t_decode_cleanup(&m);
	char text[8];

	lcmio_fault_channels(0x4, text);
	assert_string_equal(text, "2");
	lcmio_fault_channels(0, text);
	assert_string_equal(text, "");
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_block_mean_of_constants_plus_noise),
	    cmocka_unit_test(test_block_drive_aborts_the_measurement),
	    cmocka_unit_test(test_block_counts_readings_not_ticks),
	    cmocka_unit_test(test_start_up_set_after_settle_time_and_n_readings),
	    cmocka_unit_test(test_start_up_set_counts_readings),
	    cmocka_unit_test(test_commands_before_calibration_and_drive_aborts_it),
	    cmocka_unit_test(test_bad_reading_restarts_the_measurement),
	    cmocka_unit_test(test_offset_limit_just_inside_and_just_outside),
	    cmocka_unit_test(test_overcurrent_check_sees_the_offset_subtracted),
	    cmocka_unit_test(test_recalibration_only_past_5_mA),
	    cmocka_unit_test(test_recalibration_does_not_follow_noise),
	    cmocka_unit_test(test_offset_fault_clears_only_after_a_good_set),
	    cmocka_unit_test(test_announcement_names_the_first_tick_and_the_values),
	    cmocka_unit_test(test_announcement_names_the_channels_beyond_the_limit),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
