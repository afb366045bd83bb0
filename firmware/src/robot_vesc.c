/* robot_vesc.c - the VESC motor backend as the robot opens it (robot.h): its [vesc] settings
 * and the model's drive constants (which follow parameter changes), its counters. Linux only. */
#include "omni4/firmware/drive_consts_for.h"
#include "omni4/firmware/robot.h"

#include <stdio.h>

static int open_vesc(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const struct vesc_settings *vs = spec->vesc;
	struct vesc_motor_config cfg = {.iface = vs->iface,
	                                .pole_pairs = vs->pole_pairs,
	                                .mode = (enum vesc_mode)vs->mode,
	                                .status_timeout_ms = vs->status_timeout_ms,
	                                .consts = drive_consts_for(spec->ctl)};

	for (int j = 0; j < 4; j++)
		cfg.id[j] = (uint8_t)vs->id[j];
	const int rc = vesc_motor_open(&r->vesc, &cfg);

	if (rc == -EINVAL) {
		snprintf(why, n, "[vesc] id_0..id_3 must differ (and not be 255)");
		return -1;
	}
	if (rc) {
		char text[256];

		snprintf(why, n, "[vesc] CAN interface '%s': %s", vs->iface,
		         sc_os_strerror(rc, text, sizeof(text)));
		return -1;
	}
	r->motor = vesc_motor_hal(&r->vesc);
	return 0;
}

/* Loop thread, between two ticks: the drive constants in force. */
static void vesc_consts_apply(void *ctx, const struct ctl_settings *s)
{
	const struct drive_consts c = drive_consts_for(s);

	vesc_motor_set_consts(ctx, &c);
}

static void vesc_started(struct robot *r, const struct robot_spec *spec)
{
	const struct fw_param_hooks hooks = {.apply = vesc_consts_apply, .ctx = &r->vesc};

	(void)spec;
	fw_set_param_hooks(&r->fw, &hooks);
}

static void vesc_summary(const struct robot *r)
{
	const struct vesc_counters *c = &r->vesc.n;

	fprintf(stderr,
	        "omni4-fw: vesc: rx %llu tx %llu tx_dropped %llu other_frames %llu "
	        "error_frames %llu bus_off %llu\n",
	        (unsigned long long)c->rx_frames, (unsigned long long)c->tx_frames,
	        (unsigned long long)c->tx_dropped, (unsigned long long)c->other_frames,
	        (unsigned long long)c->error_frames, (unsigned long long)c->bus_off);
}

const struct robot_backend robot_backend_vesc = {
    .open = open_vesc, .started = vesc_started, .summary = vesc_summary};
