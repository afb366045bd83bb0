/* robot_socketcan.c - the SocketCAN motor backend as the robot opens it (robot.h): the bus's
 * load, the plausibility limits that follow the settings, its counters. Linux only. */
#include "omni4/firmware/can_limits.h"
#include "omni4/firmware/robot.h"

#include <errno.h>
#include <stdio.h>

/* Parameter thread: the CAN plausibility limits that new settings would give must be valid. */
static int can_limits_check(void *ctx, const struct ctl_settings *s, char *why, size_t n)
{
	struct socketcan_motor probe; /* set_limits only validates and copies the limits */
	const struct sc_limits lim = can_limits_for(s);

	(void)ctx;
	if (socketcan_motor_set_limits(&probe, &lim)) {
		snprintf(why, n, "the [model] and [limits] give no valid CAN plausibility limits");
		return -EINVAL;
	}
	return 0;
}

/* Loop thread, between two ticks: the limits follow the settings now in force. */
static void can_limits_apply(void *ctx, const struct ctl_settings *s)
{
	const struct sc_limits lim = can_limits_for(s);

	socketcan_motor_set_limits(ctx, &lim); /* checked by can_limits_check */
}

/* The bus must carry the protocol (its worst-case share at this loop rate at most half of the
 * bit rate), the interface must open, the plausibility limits must follow from the settings. */
static int open_socketcan(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const struct socketcan_settings *cs = spec->can;
	const double load = can_bus_load_1khz(cs->bitrate) * spec->ctl->rate_hz / 1000.0;

	if (load > 0.5) {
		snprintf(
		    why, n,
		    "[can] bitrate %d bit/s is too slow for [loop] rate_hz %g: the motor-driver "
		    "protocol would take %.0f %% of the bus (at most 50 %%)",
		    cs->bitrate, spec->ctl->rate_hz, 100.0 * load);
		return -1;
	}
	if (can_limits_check(NULL, spec->ctl, why, n))
		return -1;
	const struct sc_limits lim = can_limits_for(spec->ctl);
	const int rc = socketcan_motor_open(&r->can, cs->iface, cs->status_timeout_ms, &lim);

	if (rc) {
		char text[256];

		snprintf(why, n, "CAN interface '%s': %s", cs->iface,
		         sc_os_strerror(rc, text, sizeof(text)));
		return -1;
	}
	r->motor = socketcan_motor_hal(&r->can);
	return 0;
}
static void socketcan_started(struct robot *r, const struct robot_spec *spec)
{
	const struct fw_param_hooks hooks = {
	    .check = can_limits_check, .apply = can_limits_apply, .ctx = &r->can};

	(void)spec;
	fw_set_param_hooks(&r->fw, &hooks);
}

static void socketcan_summary(const struct robot *r)
{
	const struct sc_counters *n = &r->can.n;

	fprintf(stderr,
	        "omni4-fw: can: rx %llu tx %llu tx_dropped %llu crc_errors %llu replayed %llu "
	        "lost %llu error_frames %llu bus_off %llu flood_cut %llu implausible %llu "
	        "confirmed %llu\n",
	        (unsigned long long)n->rx_frames, (unsigned long long)n->tx_frames,
	        (unsigned long long)n->tx_dropped, (unsigned long long)n->crc_errors,
	        (unsigned long long)n->replayed, (unsigned long long)n->lost,
	        (unsigned long long)n->error_frames, (unsigned long long)n->bus_off,
	        (unsigned long long)n->flood_cut, (unsigned long long)n->implausible,
	        (unsigned long long)n->confirmed);
}

const struct robot_backend robot_backend_can = {
    .open = open_socketcan, .started = socketcan_started, .summary = socketcan_summary};
