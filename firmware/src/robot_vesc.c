/* robot_vesc.c - the VESC motor backend as the robot opens it (robot.h): its [vesc] settings
 * and the model's drive constants (which follow parameter changes), its counters. Linux only. */
#include "omni4/firmware/drive_consts_for.h"
#include "omni4/firmware/robot.h"

#include <stdio.h>
#include <time.h>

/* Start-up: up to [vesc] status_timeout_ms (1 ms polls) for every controller's first STATUS_1;
 * one line naming the ones that did not report and the ids heard instead. */
static void await_controllers(struct vesc_motor *m, int timeout_ms)
{
	const struct timespec poll = {.tv_sec = 0, .tv_nsec = 1000000};
	char text[512];

	for (int k = 0; k < timeout_ms && vesc_motor_poll_missing(m); k++)
		nanosleep(&poll, NULL);
	if (vesc_motor_poll_missing(m))
		fprintf(stderr, "omni4-fw: vesc: after %d ms at start-up: %s\n", timeout_ms,
		        vesc_motor_missing_text(m, text, sizeof(text)));
}

static int open_vesc(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const struct vesc_settings *vs = spec->vesc;
	const struct vesc_motor_config cfg = vesc_config_for(vs, spec->ctl);
	const int rc = vesc_motor_open(&r->vesc, &cfg);

	if (rc == -EINVAL) {
		snprintf(why, n,
		         "[vesc] id_0..id_3 must differ (and not be 255, or 254: omni4's own id)");
		return -1;
	}
	if (rc) {
		char text[256];

		snprintf(why, n, "[vesc] CAN interface '%s': %s", vs->iface,
		         sc_os_strerror(rc, text, sizeof(text)));
		return -1;
	}
	await_controllers(&r->vesc, vs->status_timeout_ms);
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
	char faults[512];

	fprintf(stderr,
	        "omni4-fw: vesc: rx %llu tx %llu tx_dropped %llu other_frames %llu "
	        "error_frames %llu bus_off %llu; fault codes: %s\n",
	        (unsigned long long)c->rx_frames, (unsigned long long)c->tx_frames,
	        (unsigned long long)c->tx_dropped, (unsigned long long)c->other_frames,
	        (unsigned long long)c->error_frames, (unsigned long long)c->bus_off,
	        vesc_motor_fault_text(&r->vesc, faults, sizeof(faults)));
}

const struct robot_backend robot_backend_vesc = {
    .open = open_vesc, .started = vesc_started, .summary = vesc_summary};
