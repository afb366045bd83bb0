/*
 * vcan_drives.c - the checks of vcan_check that watch simulated VESCs or ODrives
 * (omni4-motorsim --protocol vesc|odrive) on a raw CAN socket of their own:
 *   drivestop IFACE vesc|odrive FW_PID S: command v = 0.4, vn = 0.3 m/s; once every drive is seen
 * driving (VESC: a STATUS_1 with a non-zero duty; ODrive: a heartbeat in closed loop), SIGKILL the
 *     controller (no stop frame: the drives are on their own) and wait up to S seconds until
 *     each drive reports it stopped (VESC: STATUS_1 with duty 0 and current 0, the motor
 *     released; ODrive: a heartbeat in IDLE). Prints, by the kernel's receive times, the time
 *     from the controller's last frame to each drive's stop (a figure) and the ODrive axis
 *     errors; fails if a drive never stopped, or stopped before the controller went silent.
 *   goal DX DY DTHETA S [MOTORSIM_LOG]: a goal DX m, DY m, DTHETA rad from the simulated
 *     truth's pose (OMNI4_POSE of omni4-motorsim --camera-hz: the plant's exact pose) sent as
 *     goal_t and repeated until REACHED (at most S seconds); after 0.3 s held there, the truth
 *     within 1 cm and 1 deg of the goal (docs/goal.md's arrival); the controller's estimate and
 *     its difference from the truth printed. A goal during which the simulated world paused
 *     (omni4-motorsim's log says so: its process starved 100 ms or more, while the controller's
 *     odometry ran on) or its truth was silent for STARVED_US (omni4-motorsim 2 ms or more
 *     behind the clock on end: it sends no pose then) is said, not judged.
 * The frames are decoded with the controller's codecs (vesc_proto.h, odrive_proto.h); the
 * simulated drives have their own frame code, written from the same documents.
 */
#define _DEFAULT_SOURCE /* SCM_TIMESTAMP, struct timeval */
#include "vcan_drives.h"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <lcm/lcm.h>
#include <math.h>
#include <net/if.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

#include "omni4/drivers/odrive_proto.h"
#include "omni4/drivers/vesc_proto.h"
#include "omni4_command_t.h"
#include "omni4_goal_status_t.h"
#include "omni4_goal_t.h"
#include "omni4_motors_t.h"
#include "omni4_pose_t.h"
#include "omni4_state_t.h"

static double mono_s(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return t.tv_sec + t.tv_nsec * 1e-9;
}

/* A raw socket on iface receiving every frame with the kernel's receive time; -1 on error. */
static int open_all(const char *iface)
{
	struct sockaddr_can addr = {.can_family = AF_CAN,
	                            .can_ifindex = (int)if_nametoindex(iface)};
	const int one = 1, rcvbuf = 1 << 22;
	const int fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK, CAN_RAW);

	if (fd < 0)
		return -1;
	setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof(rcvbuf));
	if (!addr.can_ifindex || setsockopt(fd, SOL_SOCKET, SO_TIMESTAMP, &one, sizeof(one)) ||
	    bind(fd, (struct sockaddr *)&addr, sizeof(addr))) {
		close(fd);
		return -1;
	}
	return fd;
}

/* One frame and its kernel receive time [s, realtime clock]; 0, or -1 when none is queued. */
static int read_stamped(int fd, struct omni4_can_frame *f, double *t_s)
{
	struct can_frame cf;
	char ctl[CMSG_SPACE(sizeof(struct timeval))];
	struct iovec iov = {.iov_base = &cf, .iov_len = sizeof(cf)};
	struct msghdr msg = {
	    .msg_iov = &iov, .msg_iovlen = 1, .msg_control = ctl, .msg_controllen = sizeof(ctl)};
	struct timeval tv = {0, 0};

	if (recvmsg(fd, &msg, 0) != (ssize_t)sizeof(cf))
		return -1;
	for (struct cmsghdr *c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c))
		if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMP)
			memcpy(&tv, CMSG_DATA(c), sizeof(tv));
	*t_s = tv.tv_sec + tv.tv_usec * 1e-6;
	f->id = cf.can_id & (cf.can_id & CAN_EFF_FLAG ? CAN_EFF_MASK | CAN_EFF_FLAG : CAN_SFF_MASK);
	f->id |= cf.can_id & CAN_RTR_FLAG;
	f->dlc = cf.can_dlc > 8 ? 8 : cf.can_dlc;
	memcpy(f->data, cf.data, 8);
	return 0;
}

struct stop_watch {
	bool odrive;
	int driving[4], stopped[4]; /* drive j (by address order of first sight) */
	int addr[4], n_addr;
	double stop_t[4];
	uint32_t error[4];
	double last_ctl_t; /* kernel time of the controller's last frame */
	bool killed;
};

static int slot(struct stop_watch *w, int addr)
{
	for (int k = 0; k < w->n_addr; k++)
		if (w->addr[k] == addr)
			return k;
	if (w->n_addr == 4)
		return -1;
	w->addr[w->n_addr] = addr;
	return w->n_addr++;
}

/* A frame the controller sends (a command or a remote request), not one of a drive's. */
static bool from_controller(const struct stop_watch *w, const struct omni4_can_frame *f)
{
	if (!w->odrive)
		return (f->id & OMNI4_CAN_EFF_FLAG) && ((f->id >> 8) & 0xFF) <= VESC_CMD_SET_RPM;
	const uint32_t cmd = f->id & 0x1F;

	return !(f->id & OMNI4_CAN_EFF_FLAG) &&
	       ((f->id & OMNI4_CAN_RTR_FLAG) || cmd == ODRIVE_CMD_SET_AXIS_STATE ||
	        cmd == ODRIVE_CMD_SET_CONTROLLER_MODE || cmd == ODRIVE_CMD_SET_INPUT_TORQUE ||
	        cmd == ODRIVE_CMD_SET_INPUT_VEL || cmd == ODRIVE_CMD_CLEAR_ERRORS);
}

/* A drive's report: driving before the kill, its first stop after it. */
static void take_report(struct stop_watch *w, const struct omni4_can_frame *f, double t)
{
	struct vesc_status1 s1;
	struct odrive_heartbeat hb;
	uint8_t a;
	bool drive, stop;
	uint32_t err = 0;

	if (!w->odrive && vesc_decode_status1(f, &a, &s1) == 0) {
		drive = s1.duty != 0.0f;
		stop = s1.duty == 0.0f && s1.current_a == 0.0f;
	} else if (w->odrive && odrive_decode_heartbeat(f, &a, &hb) == 0) {
		drive = hb.axis_state == ODRIVE_AXIS_STATE_CLOSED_LOOP;
		stop = hb.axis_state == ODRIVE_AXIS_STATE_IDLE;
		err = hb.axis_error;
	} else {
		return;
	}
	const int k = slot(w, a);

	if (k < 0)
		return;
	if (!w->killed) {
		w->driving[k] |= drive;
		return;
	}
	if (stop && !w->stopped[k]) {
		w->stopped[k] = 1;
		w->stop_t[k] = t;
		w->error[k] = err;
	}
}

static void drain(struct stop_watch *w, int fd)
{
	struct omni4_can_frame f;
	double t;

	while (read_stamped(fd, &f, &t) == 0) {
		if (from_controller(w, &f))
			w->last_ctl_t = t;
		else
			take_report(w, &f, t);
	}
}

static int count(const int v[4])
{
	return !!v[0] + !!v[1] + !!v[2] + !!v[3];
}

static int stop_report(const struct stop_watch *w, double timeout_hint_s)
{
	double worst = 0;
	bool early = false;

	for (int k = 0; k < 4; k++) {
		const double d = w->stop_t[k] - w->last_ctl_t;

		if (!w->stopped[k])
			continue;
		printf("  %s %d stopped %.0f ms after the controller's last frame",
		       w->odrive ? "node" : "id", w->addr[k], d * 1e3);
		if (w->odrive) {
			printf(", axis error 0x%08X:", w->error[k]);
			for (int b = 0; b < 32; b++)
				if (w->error[k] >> b & 1u)
					printf(" %s", odrive_error_name(1u << b));
		}
		printf("\n");
		early |= d < 0;
		worst = d > worst ? d : worst;
	}
	const bool ok = count(w->stopped) == 4 && count(w->driving) == 4 && !early;

	printf(
	    "%s: controller killed while driving: %d of 4 %s stopped on their own, the last %.0f "
	    "ms after its last frame (the drive's timeout %.0f ms; a figure under emulation)\n",
	    ok ? "ok" : "FAIL", count(w->stopped), w->odrive ? "ODrive axes" : "VESCs", worst * 1e3,
	    timeout_hint_s * 1e3);
	return ok ? 0 : 1;
}

int vcan_drive_stop(const char *iface, bool odrive, int fw_pid, double max_s, double timeout_s)
{
	struct stop_watch w = {.odrive = odrive};
	const int fd = open_all(iface);
	lcm_t *lcm = fd >= 0 ? lcm_create(NULL) : NULL;
	/* along v and vn: every wheel turns (wheels 1, 3 carry v, wheels 0, 2 vn) */
	omni4_command_t cmd = {.mode = OMNI4_COMMAND_T_MODE_VELOCITY, .velocity = {0.4, 0.3, 0}};

	if (!lcm) {
		printf("FAIL: drivestop: no raw CAN socket on %s or no LCM\n", iface);
		if (fd >= 0)
			close(fd);
		return 1;
	}
	const double t0 = mono_s();
	double last_cmd = -1, t_kill = -1;

	while (mono_s() - t0 < max_s) {
		const double t = mono_s() - t0;

		if (!w.killed && t - last_cmd >= 0.05) {
			cmd.seq++;
			omni4_command_t_publish(lcm, "OMNI4_CMD", &cmd);
			last_cmd = t;
		}
		struct pollfd p = {.fd = fd, .events = POLLIN};

		poll(&p, 1, 10);
		drain(&w, fd);
		if (!w.killed && count(w.driving) == 4 && t >= 1.0) {
			kill(fw_pid, SIGKILL);
			t_kill = t;
			w.killed = true;
			drain(&w, fd); /* what the controller sent before it died */
		}
		if (w.killed && count(w.stopped) == 4 && t - t_kill > 0.1)
			break;
	}
	if (!w.killed) {
		printf("FAIL: drivestop: %d of 4 drives seen driving in %.0f s\n", count(w.driving),
		       max_s);
		kill(fw_pid, SIGKILL);
	}
	const int rc = w.killed ? stop_report(&w, timeout_s) : 1;

	lcm_destroy(lcm);
	close(fd);
	return rc;
}

/* ---- goal: a world pose reached through the drives, judged against the simulated truth ---- */

#define STARVED_US 250000 /* a controller silent this long: the VM starved */

struct goal_watch {
	omni4_goal_status_t last;
	bool have_status, have_truth, have_est;
	double truth[3], est[3];
	int64_t last_utime, max_gap_us; /* the controller's samples: its longest silence */
	long samples;
	omni4_state_t state;                             /* the last, for its camera counters */
	double start_off[3], reach_off[3], reach_sd_deg; /* the estimate minus the truth */
	int paused; /* the simulated world's pauses during the goal (omni4-motorsim's log) */
	int64_t last_pose_us, max_pose_gap_us; /* the truth's longest silence during the goal */
};

/* The pauses omni4-motorsim has said in its log so far (0 without a log). */
static int world_pauses(const char *log)
{
	char line[512];
	int n = 0;
	FILE *f = log ? fopen(log, "r") : NULL;

	if (!f)
		return 0;
	while (fgets(line, sizeof(line), f))
		n += strstr(line, "the simulated world paused") != NULL;
	fclose(f);
	return n;
}

/* The estimate minus the truth now: x, y [m], theta [rad]. */
static void est_minus_truth(const struct goal_watch *g, double d[3])
{
	d[0] = g->est[0] - g->truth[0];
	d[1] = g->est[1] - g->truth[1];
	d[2] = remainder(g->est[2] - g->truth[2], 2 * M_PI);
}

static void on_motors(const lcm_recv_buf_t *rb, const char *ch, const omni4_motors_t *m, void *u)
{
	struct goal_watch *g = u;

	(void)rb;
	(void)ch;
	if (g->samples++ && m->utime - g->last_utime > g->max_gap_us)
		g->max_gap_us = m->utime - g->last_utime;
	g->last_utime = m->utime;
}

static void on_status(const lcm_recv_buf_t *rb, const char *ch, const omni4_goal_status_t *m,
                      void *u)
{
	struct goal_watch *g = u;

	(void)rb;
	(void)ch;
	g->last = *m;
	g->have_status = true;
}

static void on_pose(const lcm_recv_buf_t *rb, const char *ch, const omni4_pose_t *m, void *u)
{
	struct goal_watch *g = u;

	(void)rb;
	(void)ch;
	g->truth[0] = m->x;
	g->truth[1] = m->y;
	g->truth[2] = m->theta;
	if (g->have_truth && m->utime - g->last_pose_us > g->max_pose_gap_us)
		g->max_pose_gap_us = m->utime - g->last_pose_us;
	g->last_pose_us = m->utime;
	g->have_truth = true;
}

static void on_state(const lcm_recv_buf_t *rb, const char *ch, const omni4_state_t *m, void *u)
{
	struct goal_watch *g = u;

	(void)rb;
	(void)ch;
	memcpy(g->est, m->pose, sizeof(g->est));
	g->state = *m;
	g->have_est = true;
}

static void send_goal(lcm_t *lcm, int64_t *seq, int64_t id, int8_t action, const double p[3])
{
	double pose[3] = {p[0], p[1], p[2]};
	double *rows[1] = {pose}; /* double poses[n][3] in LCM's C: a row pointer per pose */
	omni4_goal_t g = {.seq = ++*seq, .goal_id = id, .action = action, .n = 1, .poses = rows};

	omni4_goal_t_publish(lcm, "OMNI4_GOAL", &g);
}

/* Pumps LCM for s seconds, repeating the goal every 50 ms (its watchdog). */
static void hold(lcm_t *lcm, double s, int64_t *seq, int64_t id, const double p[3])
{
	const double t0 = mono_s();
	double last = -1;

	while (mono_s() - t0 < s) {
		if (mono_s() - last >= 0.05) {
			send_goal(lcm, seq, id, OMNI4_GOAL_T_ACTION_GO, p);
			last = mono_s();
		}
		lcm_handle_timeout(lcm, 10);
	}
}

static int goal_report(const struct goal_watch *g, const double p[3], double t_s)
{
	const double e = hypot(g->truth[0] - p[0], g->truth[1] - p[1]);
	const double a = fabs(remainder(g->truth[2] - p[2], 2 * M_PI)) * 180 / M_PI;
	const double ee = hypot(g->est[0] - p[0], g->est[1] - p[1]);
	const double ae = fabs(remainder(g->est[2] - p[2], 2 * M_PI)) * 180 / M_PI;
	const bool reached = g->last.status == OMNI4_GOAL_STATUS_T_STATUS_REACHED;
	const bool ok = reached && e < 0.01 && a < 1.0;
	const bool starved = !reached && g->max_gap_us >= STARVED_US;
	/* A world that paused, or fell 2 ms or more behind the clock for STARVED_US on end (its
	 * camera, the truth, is silent meanwhile), while the controller's odometry ran on: the
	 * estimate and the truth part by what the late plant did in a burst, which no controller
	 * can know of (a starved VM). */
	const bool paused = !ok && (g->paused > 0 || g->max_pose_gap_us >= STARVED_US);

	printf("%s: goal (%.3f, %.3f, %.3f) %s after %.1f s: the simulated truth off by %.2f mm, "
	       "%.3f deg (bounds 10 mm, 1 deg); the controller's estimate by %.2f mm, %.3f deg\n",
	       ok                  ? "ok"
	       : starved || paused ? "not judged"
	                           : "FAIL",
	       p[0], p[1], p[2], reached ? "REACHED" : "NOT reached", t_s, e * 1e3, a, ee * 1e3,
	       ae);
	printf(
	    "  %ld controller samples (%.0f Hz), the longest gap %.0f ms; the truth's longest "
	    "silence %.0f ms; camera poses taken %d, gated %d, too old %d, last latency %.0f ms, "
	    "innovation %.1f mm %.1f mm\n",
	    g->samples, g->samples / t_s, g->max_gap_us * 1e-3, g->max_pose_gap_us * 1e-3,
	    g->state.camera_taken, g->state.camera_gated, g->state.camera_too_old,
	    g->state.camera_latency_us * 1e-3, g->state.camera_innovation[0] * 1e3,
	    g->state.camera_innovation[1] * 1e3);
	printf("  the estimate minus the truth: at the start %.2f mm %.2f mm %.3f deg, at REACHED "
	       "%.2f mm %.2f mm %.3f deg (its heading's standard deviation %.3f deg); wheel scales "
	       "%.4f %.4f %.4f %.4f\n",
	       g->start_off[0] * 1e3, g->start_off[1] * 1e3, g->start_off[2] * 180 / M_PI,
	       g->reach_off[0] * 1e3, g->reach_off[1] * 1e3, g->reach_off[2] * 180 / M_PI,
	       g->reach_sd_deg, g->state.wheel_scale[0], g->state.wheel_scale[1],
	       g->state.wheel_scale[2], g->state.wheel_scale[3]);
	if (paused) {
		printf("  the simulated world paused %d time(s) during the goal (omni4-motorsim "
		       "starved, 100 ms or more each), its truth silent for up to %.0f ms (%.0f ms "
		       "or more: late on end): not judged\n",
		       g->paused, g->max_pose_gap_us * 1e-3, STARVED_US * 1e-3);
		return 0;
	}
	if (reached)
		return ok ? 0 : 1;
	printf("  last goal status %d reason %d\n", g->last.status, g->last.reason);
	/* A goal never reached because the emulated controller kept stalling (a starved VM, not
	 * what this tier tests) is said, not failed; one reached is judged unless the world paused.
	 */
	if (starved) {
		printf("  the emulated controller was silent for up to %.0f ms (%.0f ms or more: a "
		       "starved VM)\n",
		       g->max_gap_us * 1e-3, STARVED_US * 1e-3);
		return 0;
	}
	return 1;
}

int vcan_goal(const double offset[3], double max_s, const char *motorsim_log)
{
	struct goal_watch g = {0};
	lcm_t *lcm = lcm_create(NULL);
	int64_t seq = 0, id = 1;
	double p[3];

	if (!lcm) {
		printf("FAIL: goal: no LCM\n");
		return 1;
	}
	omni4_goal_status_t_subscribe(lcm, "OMNI4_GOAL_STATUS", on_status, &g);
	omni4_pose_t_subscribe(lcm, "OMNI4_POSE", on_pose, &g);
	omni4_state_t_subscribe(lcm, "OMNI4_STATE", on_state, &g);
	omni4_motors_t_subscription_set_queue_capacity(
	    omni4_motors_t_subscribe(lcm, "OMNI4_MOTORS", on_motors, &g), 100000);
	const double t0 = mono_s();

	while (!(g.have_truth && g.have_est) && mono_s() - t0 < 10)
		lcm_handle_timeout(lcm, 50);
	for (int k = 0; k < 3; k++)
		p[k] = g.truth[k] + offset[k];
	est_minus_truth(&g, g.start_off);
	const int pauses0 = world_pauses(motorsim_log);

	g.max_pose_gap_us = 0; /* from the goal on */

	while (mono_s() - t0 < max_s &&
	       !(g.last.goal_id == id && g.last.status == OMNI4_GOAL_STATUS_T_STATUS_REACHED)) {
		hold(lcm, 0.1, &seq, id, p);
		if (g.last.goal_id != id || (g.last.status != OMNI4_GOAL_STATUS_T_STATUS_REFUSED &&
		                             g.last.status != OMNI4_GOAL_STATUS_T_STATUS_ABORTED))
			continue;
		/* refused while the estimate has no camera pose yet; aborted when the emulated
		 * controller stalled (the drives kept or dropped their command meanwhile: the
		 * estimator sees a COLLISION): the goal again, from where the robot is */
		if (g.last.status == OMNI4_GOAL_STATUS_T_STATUS_ABORTED)
			printf("  goal %lld aborted (reason %d; the controller's longest silence "
			       "so far "
			       "%.0f ms): sent again\n",
			       (long long)id, g.last.reason, g.max_gap_us * 1e-3);
		id++;
	}
	const double t_reach = mono_s() - t0;

	est_minus_truth(&g, g.reach_off);
	g.reach_sd_deg = sqrt(fmax(g.state.covariance[2], 0.0)) * 180 / M_PI;

	hold(lcm, 0.3, &seq, id, p); /* held at the pose: the truth of a robot at rest */
	g.paused = world_pauses(motorsim_log) - pauses0;
	const int rc = goal_report(&g, p, t_reach);

	send_goal(lcm, &seq, id, OMNI4_GOAL_T_ACTION_CANCEL, p);
	lcm_destroy(lcm);
	return rc;
}
