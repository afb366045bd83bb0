/* robot_odrive.c - the ODrive motor backend as the robot opens it (robot.h): its [odrive]
 * settings and the model's drive constants (which follow parameter changes), its counters and
 * the axis errors it saw. Linux only. */
#include "omni4/firmware/drive_consts_for.h"
#include "omni4/firmware/robot.h"

#include <stdio.h>
#include <time.h>

/* Start-up: up to [odrive] status_timeout_ms (1 ms polls) for every axis's first encoder
 * estimate; one line naming the ones that did not report and the nodes heard instead. */
static void await_axes(struct odrive_motor *m, int timeout_ms)
{
	const struct timespec poll = {.tv_sec = 0, .tv_nsec = 1000000};
	char text[512];

	for (int k = 0; k < timeout_ms && odrive_motor_poll_missing(m); k++)
		nanosleep(&poll, NULL);
	if (odrive_motor_poll_missing(m))
		fprintf(stderr, "omni4-fw: odrive: after %d ms at start-up: %s\n", timeout_ms,
		        odrive_motor_missing_text(m, text, sizeof(text)));
}

static int open_odrive(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const struct odrive_settings *os = spec->odrive;
	const struct odrive_motor_config cfg = odrive_config_for(os, spec->ctl);
	const int rc = odrive_motor_open(&r->odrive, &cfg);

	if (rc == -EINVAL) {
		snprintf(why, n, "[odrive] node_0..node_3 must differ");
		return -1;
	}
	if (rc) {
		char text[256];

		snprintf(why, n, "[odrive] CAN interface '%s': %s", os->iface,
		         sc_os_strerror(rc, text, sizeof(text)));
		return -1;
	}
	await_axes(&r->odrive, os->status_timeout_ms);
	r->motor = odrive_motor_hal(&r->odrive);
	return 0;
}

/* Loop thread, between two ticks: the drive constants in force. */
static void odrive_consts_apply(void *ctx, const struct ctl_settings *s)
{
	const struct drive_consts c = drive_consts_for(s);

	odrive_motor_set_consts(ctx, &c);
}

static void odrive_started(struct robot *r, const struct robot_spec *spec)
{
	const struct fw_param_hooks hooks = {.apply = odrive_consts_apply, .ctx = &r->odrive};

	(void)spec;
	fw_set_param_hooks(&r->fw, &hooks);
}

static void odrive_summary(const struct robot *r)
{
	const struct odrive_counters *c = &r->odrive.n;
	char faults[512];

	fprintf(stderr,
	        "omni4-fw: odrive: rx %llu tx %llu tx_dropped %llu other_frames %llu "
	        "error_frames %llu bus_off %llu; axis errors: %s\n",
	        (unsigned long long)c->rx_frames, (unsigned long long)c->tx_frames,
	        (unsigned long long)c->tx_dropped, (unsigned long long)c->other_frames,
	        (unsigned long long)c->error_frames, (unsigned long long)c->bus_off,
	        odrive_motor_fault_text(&r->odrive, faults, sizeof(faults)));
}

const struct robot_backend robot_backend_odrive = {
    .open = open_odrive, .started = odrive_started, .summary = odrive_summary};
