/* drive_bridge.c - drive_lockstep's controller side (drive_bridge.h). */
#include "drive_bridge.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "omni4/config/config.h"
#include "omni4/drivers/odrive_motor.h"
#include "omni4/drivers/sc_os.h"
#include "omni4/drivers/sim_motor.h"
#include "omni4/drivers/vesc_motor.h"
#include "omni4/firmware/drive_consts_for.h"

#include "can_queue.h"

static struct {
	enum omni4_motor_backend kind;
	struct vesc_motor_config vesc_cfg;
	struct odrive_motor_config odrive_cfg;
	struct vesc_motor vesc;
	struct odrive_motor odrive;
	struct motor_hal backend; /* ops NULL: not open */
	struct motor_hal sim;
	struct sim_motor *plant_sim; /* sim's */
	drive_bridge_advance_fn advance;
	void *ctx;
	char error[256];
} b;

/* The controller's clock: the simulated robot's (the tick's time once its plant has stepped). */
int64_t __wrap_sc_os_now_us(void)
{
	return b.plant_sim ? b.plant_sim->utime0 + b.plant_sim->t_us : 0;
}

void drive_bridge_deliver(const struct omni4_can_frame *f)
{
	can_queue_deliver(f);
}

int drive_bridge_setup(const struct omni4_config *cfg, drive_bridge_advance_fn advance, void *ctx,
                       char *why, size_t n)
{
	memset(&b, 0, sizeof(b));
	can_queue_reset();
	b.kind = cfg->fw.motor;
	b.advance = advance;
	b.ctx = ctx;
	switch (b.kind) { /* the openers' configurations (drive_consts_for.h) */
	case OMNI4_MOTOR_VESC:
		b.vesc_cfg = vesc_config_for(&cfg->vesc, &cfg->ctl);
		return 0;
	case OMNI4_MOTOR_ODRIVE:
		b.odrive_cfg = odrive_config_for(&cfg->odrive, &cfg->ctl);
		return 0;
	default:
		snprintf(why, n, "[hal] motor must be vesc or odrive (the drives simulated here)");
		return -1;
	}
}

static int bridge_enable(void *ctx, bool on)
{
	(void)ctx;
	return hal_motor_enable(&b.backend, on);
}

static int bridge_write(void *ctx, const float volts[4])
{
	(void)ctx;
	return hal_motor_write(&b.backend, volts);
}

/* The drives' period (the plant's step, the frames both ways), then the backend's read. */
static int bridge_read(void *ctx, struct motor_sample *out)
{
	const struct sim_motor *s = b.plant_sim;
	int n;
	const struct omni4_can_frame *sent = can_queue_sent(&n);

	(void)ctx;
	b.advance(b.ctx, (double)s->t_us * 1e-6, (double)s->period_us * 1e-6, sent, n);
	can_queue_clear_sent();
	return hal_motor_read(&b.backend, out);
}

static int bridge_clear_faults(void *ctx)
{
	(void)ctx;
	return hal_motor_clear_faults(&b.backend);
}

static int bridge_read_pose(void *ctx, struct hal_pose *out)
{
	(void)ctx;
	return hal_motor_read_pose(&b.sim, out);
}

static int bridge_read_truth(void *ctx, struct hal_truth *out)
{
	(void)ctx;
	return hal_motor_read_truth(&b.sim, out);
}

static void bridge_halt(void *ctx)
{
	(void)ctx;
	hal_motor_halt(&b.backend);
}

static const struct motor_hal_ops bridge_ops = {
    .enable = bridge_enable,
    .write = bridge_write,
    .read = bridge_read,
    .clear_faults = bridge_clear_faults,
    .read_pose = bridge_read_pose,
    .read_truth = bridge_read_truth,
    .halt = bridge_halt,
};

struct motor_hal drive_bridge_wrap(void *ctx, struct motor_hal sim)
{
	int rc = -EINVAL;

	(void)ctx;
	b.sim = sim;
	b.plant_sim = sim.ctx;
	if (b.kind == OMNI4_MOTOR_VESC) {
		rc = vesc_motor_open(&b.vesc, &b.vesc_cfg);
		if (!rc)
			b.backend = vesc_motor_hal(&b.vesc);
	} else if (b.kind == OMNI4_MOTOR_ODRIVE) {
		rc = odrive_motor_open(&b.odrive, &b.odrive_cfg);
		if (!rc)
			b.backend = odrive_motor_hal(&b.odrive);
	}
	if (rc) {
		char text[128];

		snprintf(b.error, sizeof(b.error), "the %s backend does not open: %s",
		         b.kind == OMNI4_MOTOR_VESC ? "vesc" : "odrive",
		         sc_os_strerror(rc, text, sizeof(text)));
		return sim;
	}
	return (struct motor_hal){.ops = &bridge_ops, .ctx = NULL};
}

const char *drive_bridge_error(void)
{
	return b.error;
}

struct plant *drive_bridge_plant(void)
{
	return b.plant_sim ? &b.plant_sim->plant : NULL;
}

void drive_bridge_step_plant(const double u_v[4], bool driven, double current_a[4],
                             double wheel_rad_s[4])
{
	float v[4];
	struct motor_sample m = {0};

	for (int j = 0; j < 4; j++)
		v[j] = (float)u_v[j];
	hal_motor_enable(&b.sim, driven);
	hal_motor_write(&b.sim, v);
	hal_motor_read(&b.sim, &m);
	for (int j = 0; j < 4; j++) {
		current_a[j] = m.current_a[j];
		wheel_rad_s[j] = m.wheel_rad_s[j];
	}
}

const char *drive_bridge_summary(char *buf, size_t n)
{
	char faults[384];

	if (b.kind == OMNI4_MOTOR_VESC)
		snprintf(buf, n, "vesc: rx %llu tx %llu tx_dropped %llu; fault codes: %s",
		         (unsigned long long)b.vesc.n.rx_frames,
		         (unsigned long long)b.vesc.n.tx_frames,
		         (unsigned long long)b.vesc.n.tx_dropped,
		         vesc_motor_fault_text(&b.vesc, faults, sizeof(faults)));
	else
		snprintf(buf, n, "odrive: rx %llu tx %llu tx_dropped %llu; axis errors: %s",
		         (unsigned long long)b.odrive.n.rx_frames,
		         (unsigned long long)b.odrive.n.tx_frames,
		         (unsigned long long)b.odrive.n.tx_dropped,
		         odrive_motor_fault_text(&b.odrive, faults, sizeof(faults)));
	return buf;
}

void drive_bridge_close(void)
{
	b.plant_sim = NULL; /* the robot's, gone with its simulator */
	hal_motor_close(&b.backend);
	b.backend = (struct motor_hal){0};
}
