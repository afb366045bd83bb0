/* vesc_sag_robot.c - test_vesc_sag's controller side (vesc_sag_robot.h). */
#include "vesc_sag_robot.h"

#include <errno.h>
#include <stdbool.h>
#include <string.h>

#include "omni4/config/config.h"
#include "omni4/drivers/sc_os.h"
#include "omni4/firmware/robot.h"

int __wrap_sc_os_open_filters(const char *iface, const struct sc_os_filter *filt, int n_filt,
                              int *fd);
void __wrap_sc_os_close(int fd);
int __wrap_sc_os_send(int fd, const struct omni4_can_frame *f);
int __wrap_sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class);
int64_t __wrap_sc_os_now_us(void);

#define QUEUE 1024

static struct sc_os_filter filters[SC_OS_MAX_FILTERS];
static int n_filters;
static struct omni4_can_frame rxq[QUEUE], txq[QUEUE];
static int rx_head, rx_tail, n_tx, tx_total;
static int64_t clock_us;

const int32_t sag_fault_driver = CTL_FAULT_DRIVER;

static struct robot robot; /* large (the log ring) */
static struct omni4_config cfg;

void sag_bus_reset(int64_t now_us)
{
	n_filters = rx_head = rx_tail = n_tx = tx_total = 0;
	clock_us = now_us;
}

void sag_bus_set_clock(int64_t now_us)
{
	clock_us = now_us;
}

void sag_bus_deliver(const struct omni4_can_frame *f)
{
	bool pass = n_filters == 0;

	for (int i = 0; i < n_filters; i++)
		pass |= (f->id & filters[i].mask) == (filters[i].id & filters[i].mask);
	if (!pass)
		return;
	if (rx_head == rx_tail)
		rx_head = rx_tail = 0;
	if (rx_tail < QUEUE)
		rxq[rx_tail++] = *f;
}

int sag_bus_take_sent(struct omni4_can_frame *out, int max)
{
	const int n = n_tx < max ? n_tx : max;
	const int total = tx_total;

	memcpy(out, txq, (size_t)n * sizeof(*out));
	n_tx = tx_total = 0;
	return n < total ? total : n;
}

int __wrap_sc_os_open_filters(const char *iface, const struct sc_os_filter *filt, int n_filt,
                              int *fd)
{
	(void)iface;
	memcpy(filters, filt, (size_t)n_filt * sizeof(*filt));
	n_filters = n_filt;
	*fd = 3;
	return 0;
}

void __wrap_sc_os_close(int fd)
{
	(void)fd;
}

int __wrap_sc_os_send(int fd, const struct omni4_can_frame *f)
{
	(void)fd;
	if (n_tx < QUEUE)
		txq[n_tx++] = *f;
	tx_total++;
	return 0;
}

int __wrap_sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class)
{
	(void)fd;
	(void)err_class;
	if (rx_head == rx_tail)
		return -EAGAIN;
	*f = rxq[rx_head++];
	return 1;
}

int64_t __wrap_sc_os_now_us(void)
{
	return clock_us;
}

void sag_robot_model(struct model_params *out)
{
	config_defaults(&cfg);
	*out = cfg.ctl.model;
}

int sag_robot_open(char *why, size_t n)
{
	config_defaults(&cfg);
	cfg.fw.motor = OMNI4_MOTOR_VESC;
	cfg.fw.lines = OMNI4_LINES_NONE;
	cfg.vesc.mode = VESC_MODE_DUTY;
	const struct robot_spec spec = {.ctl = &cfg.ctl,
	                                .motor = OMNI4_MOTOR_VESC,
	                                .lines = OMNI4_LINES_NONE,
#define SPEC_SETTINGS(member, settings) .member = &cfg.member,
	                                OMNI4_BACKEND_SETTINGS(SPEC_SETTINGS)
#undef SPEC_SETTINGS
	};
	return robot_open(&robot, &spec, why, n);
}

void sag_robot_tick(int64_t now_us, int64_t seq, const double v[3], int32_t *faults,
                    int *in_velocity)
{
	struct ctl_command cmd = {.utime = now_us, .seq = seq, .mode = CTL_VELOCITY};
	struct log_entry e;

	memcpy(cmd.velocity, v, sizeof(cmd.velocity));
	fw_post_command(&robot.fw, &cmd);
	clock_us = now_us;
	fw_tick(&robot.fw, now_us);
	*faults = 0;
	while (fw_pop_log(&robot.fw, &e))
		if (e.kind == LOG_MOTORS)
			*faults |= e.sample.faults;
	*in_velocity = robot.fw.ctl.mode == CTL_VELOCITY;
}

const char *sag_robot_fault_text(char *buf, size_t n)
{
	return vesc_motor_fault_text(&robot.vesc, buf, n);
}

void sag_robot_close(void)
{
	robot_close(&robot);
}
