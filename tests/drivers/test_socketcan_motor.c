/* Tests for drivers/socketcan/socketcan_motor.c with the OS adapter (sc_os) mocked at link
 * time: frame handling, counter policy, timeouts, bus-off. The real-socket tests run in the
 * vcan VM tier. */
#include "omni4_test.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <string.h>
#include <time.h>

#include "omni4/firmware/can_limits.h"
#include "omni4/drivers/sc_os.h"
#include "omni4/drivers/socketcan_motor.h"

int __wrap_sc_os_open(const char *iface, const uint32_t *ids, int n_ids, int *fd);
void __wrap_sc_os_close(int fd);
int __wrap_sc_os_send(int fd, const struct omni4_can_frame *f);
int __wrap_sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class);
int64_t __wrap_sc_os_now_us(void);

/* A queue of frames the "kernel" hands out, and the clock. */
static struct omni4_can_frame rxq[128];
static uint32_t rxerr[128];
static int rx_head, rx_tail;
static int64_t clock_us;
static struct omni4_can_frame last_sent;
static int sent;
/* Every frame sent, in bus order (the crash-race test sends from two threads). */
static pthread_mutex_t sent_lock = PTHREAD_MUTEX_INITIALIZER;
static struct omni4_can_frame sent_log[4096];
static int sent_n;
static int eagain_left; /* the next sends that find the TX queue full */
/* Crash-race test: the send of this thread stalls (preempted between encoding and sending). */
static pthread_t stall_thread; /* set by the race test's loop thread */
static atomic_int stall_armed, stalled;
static long stall_ns = 5000000; /* how long that send is preempted [ns] */

int __wrap_sc_os_open(const char *iface, const uint32_t *ids, int n_ids, int *fd)
{
	assert_string_equal(iface, "vcan0");
	assert_int_equal(n_ids, 4);
	assert_int_equal(ids[0], 0x020);
	*fd = 42;
	return 0;
}

void __wrap_sc_os_close(int fd)
{
	assert_int_equal(fd, 42);
}

int __wrap_sc_os_send(int fd, const struct omni4_can_frame *f)
{
	(void)fd;
	if (atomic_load(&stall_armed) && pthread_equal(pthread_self(), stall_thread)) {
		const struct timespec stall = {0, stall_ns};

		atomic_store(&stall_armed, 0);
		atomic_store(&stalled, 1);
		nanosleep(&stall, NULL); /* the crash handler runs meanwhile on another thread */
	}
	pthread_mutex_lock(&sent_lock);
	if (eagain_left > 0 && !pthread_equal(pthread_self(), stall_thread)) {
		eagain_left--;
		pthread_mutex_unlock(&sent_lock);
		return -EAGAIN;
	}
	last_sent = *f;
	sent++;
	if (sent_n < (int)(sizeof(sent_log) / sizeof(sent_log[0])))
		sent_log[sent_n++] = *f;
	pthread_mutex_unlock(&sent_lock);
	return 0;
}

int __wrap_sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class)
{
	(void)fd;
	if (rx_head == rx_tail)
		return -EAGAIN;
	if (rxerr[rx_head]) {
		*err_class = rxerr[rx_head++];
		return 2;
	}
	*f = rxq[rx_head++];
	return 1;
}

int64_t __wrap_sc_os_now_us(void)
{
	return clock_us;
}

static void push_status(int node, float i0, float w0, uint8_t counter)
{
	const struct can_status s = {{i0, i0}, {w0, w0}};

	rxerr[rx_tail] = 0;
	assert_int_equal(can_encode_status(node, &s, counter & 0xF, &rxq[rx_tail++]), 0);
}

static void push_both(float i0, float w0, uint8_t counter)
{
	push_status(0, i0, w0, counter);
	push_status(1, i0, w0, counter);
}

/* The Table III robot's plausibility limits at 1 kHz, as the adapter computes them. */
static struct sc_limits table3;

static int reset(void **state)
{
	(void)state;
	table3 = can_limits_default();
	rx_head = rx_tail = 0;
	clock_us = 1000000;
	sent = 0;
	sent_n = 0;
	eagain_left = 0;
	atomic_store(&stall_armed, 0);
	atomic_store(&stalled, 0);
	return 0;
}

static void test_status_frames_become_a_motor_sample(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	assert_int_equal(hal_motor_read(&h, &s), -EAGAIN); /* nothing yet, within the timeout */
	push_both(1.5f, 30.0f, 0);
	clock_us += 1000;
	assert_int_equal(hal_motor_read(&h, &s), 0);
	for (int j = 0; j < 4; j++) {
		assert_near(s.current_a[j], 1.5, 0.003);
		assert_near(s.wheel_rad_s[j], 30.0, 0.03);
	}
	assert_int_equal(s.faults, 0);

	/* write: one CMD_VOLTAGE with the enable flag and an incrementing counter */
	const float u[4] = {1, -2, 3, -4};
	float back[4];
	bool en;
	uint8_t c0, c1;

	assert_int_equal(hal_motor_enable(&h, true), 0);
	assert_int_equal(hal_motor_write(&h, u), 0);
	assert_int_equal(can_decode_cmd_voltage(&last_sent, back, &en, &c0), 0);
	assert_true(en);
	assert_near(back[3], -4, 0.006);
	assert_int_equal(hal_motor_write(&h, u), 0);
	can_decode_cmd_voltage(&last_sent, back, &en, &c1);
	assert_int_equal(c1, (c0 + 1) & 15);
	hal_motor_close(&h);
}

static void test_replayed_and_corrupt_frames_are_rejected_and_counted(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(1.0f, 10.0f, 3);
	hal_motor_read(&h, &s);
	push_status(0, 1.5f, 10.5f, 3);  /* replay: same counter */
	push_status(0, 1.5f, 10.5f, 12); /* far off: stale */
	push_status(0, 2.0f, 11.0f, 5);  /* 1 lost: accepted */
	rxerr[rx_tail] = 0;
	push_status(1, 1.5f, 10.5f, 4);
	rxq[rx_tail - 1].data[1] ^= 0x40; /* corrupt */
	hal_motor_read(&h, &s);
	assert_int_equal(m.n.replayed, 2);
	assert_int_equal(m.n.lost, 1);
	assert_int_equal(m.n.crc_errors, 1);
	assert_near(s.current_a[0], 2.0, 0.003);
	assert_near(s.current_a[2], 1.0, 0.003); /* node 1 kept its last good value */

	/* After an outage the sender's counter is anywhere: two in a row resynchronise. */
	push_status(0, 3.0f, 11.5f, 14);
	push_status(0, 4.0f, 12.0f, 15);
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 4.0, 0.003);
	hal_motor_close(&h);
}

static void test_silent_node_times_out_and_bus_off_faults(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(0.5f, 5.0f, 0);
	hal_motor_read(&h, &s);
	assert_int_equal(s.faults, 0);
	clock_us += 4000;
	push_status(0, 0.5f, 5.0f, 1); /* node 1 goes silent */
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, 0);
	clock_us += 2000; /* 6 ms since node 1's last status */
	push_status(0, 0.5f, 5.0f, 2);
	hal_motor_read(&h, &s);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER_TIMEOUT);

	rxerr[rx_tail++] = SC_ERR_BUSOFF;
	hal_motor_read(&h, &s);
	assert_true(s.faults & HAL_FAULT_BUS);
	assert_int_equal(m.n.bus_off, 1);
	assert_int_equal(hal_motor_clear_faults(&h), 0);
	hal_motor_close(&h);
}

static void test_a_flood_is_cut_at_the_per_tick_bound(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	for (int k = 0; k < 64; k++)
		push_status(0, 0.1f, 1.0f, (uint8_t)k);
	hal_motor_read(&h, &s);
	assert_int_equal(m.n.rx_frames, SC_MAX_FRAMES_PER_READ);
	assert_int_equal(m.n.flood_cut, 1);
	hal_motor_close(&h);
}

/* Counter gaps, from the protocol specification (can_proto.h, socketcan_motor.h), not from the
 * code's constants: a counter 1, 2 or 3 ahead of the last accepted one is accepted (0, 1, 2
 * frames lost); 4 or more ahead, the same value again, or behind (15 ahead = one behind) is
 * rejected as stale/replayed. "step" below is the counter difference now - last (mod 16). */
struct gap_result {
	bool accepted;
	uint64_t lost, replayed;
};

static struct gap_result counter_step(int step)
{
	struct socketcan_motor m;
	struct motor_sample s;
	struct gap_result r;

	reset(NULL);
	assert_int_equal(socketcan_motor_open(&m, "vcan0", 50, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(1.0f, 10.0f, 5);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	push_status(0, 1.2f, 10.25f, (uint8_t)(5 + step)); /* a plausible change */
	assert_int_equal(hal_motor_read(&h, &s), 0);
	r.accepted = s.current_a[0] > 1.1f;
	r.lost = m.n.lost;
	r.replayed = m.n.replayed;
	hal_motor_close(&h);
	return r;
}

/* Frames that arrive while the loop is stalled queue up: a read 10 ms late takes up to 4 x 64
 * frames (the cap: 4 ms' worth), so both nodes' STATUS behind 100 junk frames are seen (no
 * DRIVER_TIMEOUT with a 5 ms status timeout), while a read on time still stops at 64. */
static void push_junk_status(int n)
{
	for (int k = 0; k < n; k++) {
		struct omni4_can_frame *f = &rxq[rx_tail];

		memset(f, 0, sizeof(*f));
		f->id = CAN_ID_STATUS(0);
		f->dlc = 8;
		for (int b = 0; b < 8; b++)
			f->data[b] = (uint8_t)(0xA5 ^ (k * 7 + b * 13));
		rxerr[rx_tail++] = 0;
	}
}

static void test_a_late_read_catches_up_with_the_queue(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(0.5f, 5.0f, 0);
	clock_us += 1000;
	assert_int_equal(hal_motor_read(&h, &s), 0);
	clock_us += 10000; /* the loop was stalled for 10 ms */
	push_junk_status(100);
	push_both(0.5f, 5.0f, 1);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, 0);
	assert_int_equal(m.n.rx_frames, 104);
	assert_int_equal(m.n.flood_cut, 0);
	assert_int_equal(m.n.crc_errors, 100);

	clock_us += 1000; /* on time again: the 64-frame bound */
	push_junk_status(20);
	push_both(0.5f, 5.0f, 2);
	hal_motor_read(&h, &s);
	assert_int_equal(m.n.rx_frames, 104 + 22);
	rx_head = rx_tail = 0;
	push_junk_status(70);
	clock_us += 1000;
	hal_motor_read(&h, &s);
	assert_int_equal(m.n.rx_frames, 104 + 22 + 64);
	assert_int_equal(m.n.flood_cut, 1);
	hal_motor_close(&h);
}

static void test_counter_gap_boundaries_from_the_specification(void **state)
{
	(void)state;
	static const struct {
		int step;
		bool accepted;
		uint64_t lost, replayed;
	} spec[] = {
	    {1, true, 0, 0},                     /* the next frame */
	    {2, true, 1, 0},                     /* one lost */
	    {3, true, 2, 0},                     /* two lost: the edge of the window */
	    {4, false, 0, 1},                    /* three lost: outside the window */
	    {5, false, 0, 1},  {8, false, 0, 1}, /* half way round */
	    {15, false, 0, 1},                   /* one behind: an old frame */
	    {16, false, 0, 1},                   /* the same counter again: a replay */
	};

	for (unsigned k = 0; k < sizeof(spec) / sizeof(spec[0]); k++) {
		const struct gap_result r = counter_step(spec[k].step);

		print_message("counter step %2d: %s, lost %llu, rejected %llu\n", spec[k].step,
		              r.accepted ? "accepted" : "rejected", (unsigned long long)r.lost,
		              (unsigned long long)r.replayed);
		assert_int_equal(r.accepted, spec[k].accepted);
		assert_int_equal(r.lost, spec[k].lost);
		assert_int_equal(r.replayed, spec[k].replayed);
	}
}

static void test_a_rejected_counter_resynchronises_on_the_next_consecutive_frame(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 50, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(1.0f, 10.0f, 5);
	hal_motor_read(&h, &s);
	push_status(0, 1.2f, 10.0f, 9);  /* 4 ahead: rejected */
	push_status(0, 1.4f, 10.0f, 11); /* 2 after the rejected one: not consecutive, rejected */
	push_status(0, 1.6f, 10.0f, 12); /* continues from 11: resync, accepted */
	hal_motor_read(&h, &s);
	assert_int_equal(m.n.replayed, 2);
	assert_near(s.current_a[0], 1.6, 0.011);
	push_status(0, 1.8f, 10.0f, 13);
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 1.8, 0.011);
	assert_int_equal(m.n.lost, 0);
	hal_motor_close(&h);
}

/* Limits that are no limits are refused at open, before any socket is opened. */
static void test_open_refuses_invalid_limits(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct sc_limits bad = table3;

	bad.confirm_frames = 9;
	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5, &bad), -EINVAL);
	bad = table3;
	bad.speed_step_rad_s = 0.0f;
	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5, &bad), -EINVAL);
	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5, &table3), 0);
	assert_int_equal(socketcan_motor_set_limits(&m, &bad), -EINVAL);
	const struct motor_hal h = socketcan_motor_hal(&m);

	hal_motor_close(&h);
}

static void test_an_implausible_jump_is_held_not_acted_on(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 50, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(1.0f, 10.0f, 0);
	hal_motor_read(&h, &s);
	push_status(0, 1.0f, 14.0f, 1); /* +4 rad/s in 1 ms: 4000 rad/s^2, beyond the physics */
	hal_motor_read(&h, &s);
	assert_near(s.wheel_rad_s[0], 10.0, 0.07);
	push_status(0, 7.5f, 10.0f, 2); /* +6.5 A in one frame: beyond 2 x 12 V / R */
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 1.0, 0.011);
	assert_int_equal(m.n.implausible, 2);
	push_status(0, 1.1f, 10.1f, 3); /* an ordinary frame is taken again */
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 1.1, 0.011);
	assert_int_equal(s.faults, 0);
	/* A real step that persists is confirmed by the third consecutive agreeing frame. */
	for (int k = 0; k < 3; k++) {
		push_status(0, 1.1f, 16.0f, (uint8_t)(4 + k));
		hal_motor_read(&h, &s);
		assert_near(s.wheel_rad_s[0], k < 2 ? 10.1 : 16.0, 0.07);
	}
	assert_int_equal(m.n.confirmed, 1);
	hal_motor_close(&h);
}

static void test_an_over_limit_current_needs_three_consecutive_frames(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 50, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(4.8f, 10.0f, 0);
	hal_motor_read(&h, &s);
	/* 5.4 A: a plausible step, but above the 5 A limit. One or two such frames do nothing. */
	push_status(0, 5.4f, 10.0f, 1);
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 4.8, 0.011);
	push_status(0, 5.4f, 10.0f, 2);
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 4.8, 0.011);
	/* A frame in range breaks the run: the count starts again. */
	push_status(0, 4.8f, 10.0f, 3);
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 4.8, 0.011);
	push_status(0, 5.4f, 10.0f, 4);
	hal_motor_read(&h, &s);
	push_status(0, 5.4f, 10.0f, 5);
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 4.8, 0.011);
	/* The third consecutive received frame (one lost before it, within the counter window):
	 * taken, the controller may trip. */
	push_status(0, 5.4f, 10.0f, 7);
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 5.4, 0.011);
	/* Alternating in and out of range never confirms. */
	push_both(4.8f, 10.0f, 8);
	hal_motor_read(&h, &s);
	for (int k = 0; k < 8; k++) {
		push_status(0, k % 2 ? 4.8f : 5.4f, 10.0f, (uint8_t)(9 + k));
		hal_motor_read(&h, &s);
		assert_true(s.current_a[0] < 5.0f);
	}
	hal_motor_close(&h);
}

static void test_a_fault_report_in_health_needs_three_consecutive_frames(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;
	struct can_health ok = {0, 12.0f, 30, CAN_STATE_ENABLED}, bad = ok;

	bad.faults = CAN_DRV_OVERCURRENT;
	bad.state = CAN_STATE_FAULT;
	assert_int_equal(socketcan_motor_open(&m, "vcan0", 50, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(1.0f, 10.0f, 0);
	can_encode_health(0, &ok, 0, &rxq[rx_tail++]);
	hal_motor_read(&h, &s);
	for (int k = 1; k <= 3; k++) {
		push_both(1.0f, 10.0f, (uint8_t)k);
		can_encode_health(0, &bad, (uint8_t)k, &rxq[rx_tail++]);
		hal_motor_read(&h, &s);
		assert_int_equal(s.faults, k < 3 ? 0 : HAL_FAULT_DRIVER);
	}
	hal_motor_close(&h);
}

static uint64_t rng_state = 0x9E3779B97F4A7C15ull;

static uint64_t xorshift(void)
{
	rng_state ^= rng_state << 13;
	rng_state ^= rng_state >> 7;
	rng_state ^= rng_state << 17;
	return rng_state;
}

/* 10^6 random frames on the STATUS IDs, 63 per read with one genuine frame of each node per
 * read: no sample ever carries an over-limit current, a speed step the controller would call
 * an encoder jump, or a fault. Prints how many junk frames passed CRC and counter. */
static void test_a_million_junk_status_frames_latch_nothing(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;
	const long n_junk = 1000000;
	long junk = 0, crc_valid = 0, reads = 0;
	float prev_w[4] = {10, 10, 10, 10};
	uint8_t ctr = 0;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 50, &table3), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(1.0f, 10.0f, ctr++);
	hal_motor_read(&h, &s);
	while (junk < n_junk) {
		rx_head = rx_tail = 0;
		push_both(1.0f, 10.0f, ctr++);
		while (rx_tail < SC_MAX_FRAMES_PER_READ && junk < n_junk) {
			struct omni4_can_frame *f = &rxq[rx_tail];
			const uint64_t r = xorshift();
			struct can_status st;
			int node;
			uint8_t c;

			f->id = CAN_ID_STATUS(xorshift() & 1);
			f->dlc = 8;
			memcpy(f->data, &r, 8);
			rxerr[rx_tail++] = 0;
			crc_valid += can_decode_status(f, &node, &st, &c) == 0;
			junk++;
		}
		clock_us += 1000;
		assert_int_equal(hal_motor_read(&h, &s), 0);
		reads++;
		assert_int_equal(s.faults, 0);
		for (int j = 0; j < 4; j++) {
			assert_true(fabsf(s.current_a[j]) <= 5.0f);
			assert_true(fabsf(s.wheel_rad_s[j] - prev_w[j]) <= 5.0f);
			prev_w[j] = s.wheel_rad_s[j];
		}
	}
	print_message("%ld junk STATUS frames in %ld reads: %ld passed CRC-16 + reserved bits "
	              "(expected %.1f), %llu rejected by CRC, %llu by counter, %llu held as "
	              "implausible, 0 faults\n",
	              junk, reads, crc_valid, n_junk / 262144.0, (unsigned long long)m.n.crc_errors,
	              (unsigned long long)m.n.replayed, (unsigned long long)m.n.implausible);
	/* 2^-18 per frame: 3.8 expected; a CRC-8 format would pass ~3900. */
	assert_true(crc_valid <= 12);
	hal_motor_close(&h);
}

/* The crash race: the loop thread is inside a CMD_VOLTAGE send (encoded with the old, non-zero
 * voltages) when the crash handler runs on another thread. The handler's DISABLE + 0 V frames
 * must be the last frames on the bus. */
struct race {
	struct socketcan_motor *m;
	atomic_int stop;
	int writes;
};

static void *loop_thread(void *arg)
{
	struct race *r = arg;
	struct motor_hal h = socketcan_motor_hal(r->m);
	const float u[4] = {3.0f, -3.0f, 3.0f, -3.0f};

	stall_thread = pthread_self();
	hal_motor_enable(&h, true);
	while (!atomic_load(&r->stop)) {
		if (r->writes == 10)
			atomic_store(&stall_armed, 1);
		hal_motor_write(&h, u);
		r->writes++;
		const struct timespec us200 = {0, 200000};

		nanosleep(&us200, NULL);
	}
	return NULL;
}

/* The crash handler runs while the loop thread is preempted inside a send for stall_ms: the
 * halt frames must be the last on the bus, whatever the stall (5 ms: inside the handler's
 * 20 ms wait; 60 ms: beyond it, so the handler sends them again once the write is out). */
static void crash_race(long stall_ms, int want_sent)
{
	struct socketcan_motor m;
	struct race r = {.m = &m};
	pthread_t t;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 50, &table3), 0);
	assert_int_equal(pthread_create(&t, NULL, loop_thread, &r), 0);
	while (!atomic_load(&stalled)) {
		const struct timespec us50 = {0, 50000};

		nanosleep(&us50, NULL);
	}
	pthread_mutex_lock(&sent_lock);
	eagain_left = 2; /* and the TX queue is full for a moment */
	pthread_mutex_unlock(&sent_lock);
	assert_int_equal(socketcan_motor_halt(&m), want_sent);
	const int after_halt = sent_n;
	const struct timespec ms3 = {0, 3000000};

	nanosleep(&ms3, NULL); /* the loop keeps ticking until the process dies */
	atomic_store(&r.stop, 1);
	pthread_join(t, NULL);

	float v[4];
	bool en;
	uint8_t c, c_prev = 0;
	int n_volt = 0;

	assert_int_equal(sent_n, after_halt); /* nothing sent after the halt */
	assert_true(sent_n >= 4);
	enum can_control cmd;

	assert_int_equal(can_decode_control(&sent_log[sent_n - 3], &cmd, &c), 0);
	assert_int_equal(cmd, CAN_CTL_DISABLE);
	/* After a long preemption the loop's write lands between the two halt sequences: enabled,
	 * non-zero, and with a counter from before the first one, so the driver's counter window
	 * rejects it as stale (CAN_COUNTER_WINDOW: 1..3 steps ahead) even before the second. */
	const int late = want_sent == 6 ? sent_n - 4 : -1;
	int c_late = -1; /* its counter: the slot it took before the first halt sequence */

	if (late >= 0) {
		uint8_t c_halt;

		assert_int_equal(sent_log[late].id, CAN_ID_CMD_VOLTAGE);
		assert_int_equal(can_decode_cmd_voltage(&sent_log[late], v, &en, &c), 0);
		assert_true(en && v[0] != 0.0f);
		assert_int_equal(can_decode_cmd_voltage(&sent_log[late - 1], v, &en, &c_halt), 0);
		const int gap = can_counter_gap(c_halt, c);

		assert_true(gap == -EALREADY || gap > CAN_COUNTER_WINDOW - 1);
		c_late = c;
	}
	for (int k = 0; k < sent_n; k++) {
		if (sent_log[k].id != CAN_ID_CMD_VOLTAGE || k == late)
			continue;
		assert_int_equal(can_decode_cmd_voltage(&sent_log[k], v, &en, &c), 0);
		if (n_volt++ && c_late == ((c_prev + 1) & 15))
			c_prev = (uint8_t)c_late; /* the late frame's slot */
		if (n_volt > 1)
			assert_int_equal(c, (c_prev + 1) & 15); /* one sender at a time */
		c_prev = c;
	}
	for (int k = sent_n - 2; k < sent_n; k++) {
		assert_int_equal(can_decode_cmd_voltage(&sent_log[k], v, &en, &c), 0);
		assert_false(en);
		for (int j = 0; j < 4; j++)
			assert_true(v[j] == 0.0f);
	}
	print_message("crash race, send preempted %ld ms: %d loop writes, halt frames last (%d "
	              "frames on the bus)\n",
	              stall_ms, r.writes, sent_n);
	const struct motor_hal h = socketcan_motor_hal(&m);

	hal_motor_close(&h);
}

static void test_crash_halt_frames_are_the_last_on_the_bus(void **state)
{
	(void)state;
	stall_ns = 5000000;
	crash_race(5, 3);
}

static void test_crash_halt_frames_are_last_after_a_long_preemption(void **state)
{
	(void)state;
	stall_ns = 60000000;
	crash_race(60, 6);
	stall_ns = 5000000;
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test_setup(test_status_frames_become_a_motor_sample, reset),
	    cmocka_unit_test_setup(test_replayed_and_corrupt_frames_are_rejected_and_counted,
	                           reset),
	    cmocka_unit_test_setup(test_silent_node_times_out_and_bus_off_faults, reset),
	    cmocka_unit_test_setup(test_a_flood_is_cut_at_the_per_tick_bound, reset),
	    cmocka_unit_test_setup(test_a_late_read_catches_up_with_the_queue, reset),
	    cmocka_unit_test_setup(test_counter_gap_boundaries_from_the_specification, reset),
	    cmocka_unit_test_setup(
	        test_a_rejected_counter_resynchronises_on_the_next_consecutive_frame, reset),
	    cmocka_unit_test_setup(test_open_refuses_invalid_limits, reset),
	    cmocka_unit_test_setup(test_an_implausible_jump_is_held_not_acted_on, reset),
	    cmocka_unit_test_setup(test_an_over_limit_current_needs_three_consecutive_frames,
	                           reset),
	    cmocka_unit_test_setup(test_a_fault_report_in_health_needs_three_consecutive_frames,
	                           reset),
	    cmocka_unit_test_setup(test_a_million_junk_status_frames_latch_nothing, reset),
	    cmocka_unit_test_setup(test_crash_halt_frames_are_the_last_on_the_bus, reset),
	    cmocka_unit_test_setup(test_crash_halt_frames_are_last_after_a_long_preemption, reset),
	};

	return cmocka_run_group_tests_name("socketcan_motor", tests, NULL, NULL);
}
