/* Tests for drivers/socketcan/socketcan_motor.c with the OS adapter (sc_os) mocked at link
 * time: frame handling, counter policy, timeouts, bus-off. The real-socket tests run in the
 * vcan VM tier. */
#include "omni4_test.h"

#include <errno.h>
#include <string.h>

#include "omni4/sc_os.h"
#include "omni4/socketcan_motor.h"
#include "omni4_motors_t.h"

int __wrap_sc_os_open(const char *iface, const uint32_t *ids, int n_ids, int *fd);
void __wrap_sc_os_close(int fd);
int __wrap_sc_os_send(int fd, const struct omni4_can_frame *f);
int __wrap_sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class);
int64_t __wrap_sc_os_now_us(void);

/* A queue of frames the "kernel" hands out, and the clock. */
static struct omni4_can_frame rxq[64];
static uint32_t rxerr[64];
static int rx_head, rx_tail;
static int64_t clock_us;
static struct omni4_can_frame last_sent;
static int sent;

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
	last_sent = *f;
	sent++;
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
	can_encode_status(node, &s, counter, &rxq[rx_tail++]);
}

static void push_both(float i0, float w0, uint8_t counter)
{
	push_status(0, i0, w0, counter);
	push_status(1, i0, w0, counter);
}

static int reset(void **state)
{
	(void)state;
	rx_head = rx_tail = 0;
	clock_us = 1000000;
	sent = 0;
	return 0;
}

static void test_status_frames_become_a_motor_sample(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5), 0);
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

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	push_both(1.0f, 10.0f, 3);
	hal_motor_read(&h, &s);
	push_status(0, 9.0f, 99.0f, 3); /* replay: same counter */
	push_status(0, 9.0f, 99.0f, 12); /* far off: stale */
	push_status(0, 2.0f, 20.0f, 5); /* 1 lost: accepted */
	rxerr[rx_tail] = 0;
	push_status(1, 7.0f, 70.0f, 4);
	rxq[rx_tail - 1].data[1] ^= 0x40; /* corrupt */
	hal_motor_read(&h, &s);
	assert_int_equal(m.n.replayed, 2);
	assert_int_equal(m.n.lost, 1);
	assert_int_equal(m.n.crc_errors, 1);
	assert_near(s.current_a[0], 2.0, 0.003);
	assert_near(s.current_a[2], 1.0, 0.003); /* node 1 kept its last good value */

	/* After an outage the sender's counter is anywhere: two in a row resynchronise. */
	push_status(0, 3.0f, 30.0f, 14);
	push_status(0, 4.0f, 40.0f, 15);
	hal_motor_read(&h, &s);
	assert_near(s.current_a[0], 4.0, 0.003);
	hal_motor_close(&h);
}

static void test_silent_node_times_out_and_bus_off_faults(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5), 0);
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
	assert_int_equal(s.faults, OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT);

	rxerr[rx_tail++] = SC_ERR_BUSOFF;
	hal_motor_read(&h, &s);
	assert_true(s.faults & OMNI4_MOTORS_T_FAULT_BUS);
	assert_int_equal(m.n.bus_off, 1);
	assert_int_equal(hal_motor_clear_faults(&h), 0);
	hal_motor_close(&h);
}

static void test_a_flood_is_cut_at_the_per_tick_bound(void **state)
{
	(void)state;
	struct socketcan_motor m;
	struct motor_sample s;

	assert_int_equal(socketcan_motor_open(&m, "vcan0", 5), 0);
	struct motor_hal h = socketcan_motor_hal(&m);

	for (int k = 0; k < 64; k++)
		push_status(0, 0.1f, 1.0f, (uint8_t)k);
	hal_motor_read(&h, &s);
	assert_int_equal(m.n.rx_frames, SC_MAX_FRAMES_PER_READ);
	assert_int_equal(m.n.flood_cut, 1);
	hal_motor_close(&h);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup(test_status_frames_become_a_motor_sample, reset),
		cmocka_unit_test_setup(test_replayed_and_corrupt_frames_are_rejected_and_counted, reset),
		cmocka_unit_test_setup(test_silent_node_times_out_and_bus_off_faults, reset),
		cmocka_unit_test_setup(test_a_flood_is_cut_at_the_per_tick_bound, reset),
	};

	return cmocka_run_group_tests_name("socketcan_motor", tests, NULL, NULL);
}
