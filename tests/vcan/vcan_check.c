/*
 * vcan_check - the LCM side of the CAN tests inside the VM (omni4-fw with the socketcan
 * backend and omni4-motorsim on vcan0).
 *   vcan_check track S [HZ]  command v = 0.5 m/s for S seconds; check the tracking (the mean v
 *                        from the wheel speeds, eqs 3-5, of the samples from S/2 after VELOCITY
 *                        began by the controller's clock), seq continuity, a sample rate >= HZ
 *                        (default 800), no fault
 *   vcan_check rate S [HZ]   command for S seconds; check only the rate and seq continuity
 *   vcan_check clear     send MODE_CLEAR_FAULT; check the controller leaves FAULT
 *   vcan_check flood N S IFACE TIMEOUT_MS  command v = 0.5 m/s and send N random 8-byte frames on
 * the STATUS IDs (0x020, 0x021 alternately) on IFACE, paced at 40 per OMNI4_MOTORS sample seen (the
 * controller reads 64 frames per tick and gets 2 STATUS per ms: the junk never overflows its socket
 * queue, it examines every frame); at most S seconds. Checks: all N sent (at least N / 5 when
 * the S seconds end it), no sample with a latching fault or FAULT mode; except DRIVER_TIMEOUT
 * when a board's real STATUS frames really stopped for TIMEOUT_MS ([can] status_timeout_ms) or
 * longer. Seq gaps everywhere are this reader's figure (a starved VM's UDP receive buffer
 * overflows); vcan_tests.sh checks the controller's own count of dropped samples vcan_check calm S
 * PID... command until every PID has exited (at most S seconds): check that no sample shows a
 * latching fault or FAULT mode, seq continuity, and that the PIDs (the flood generators) finished
 * in time vcan_check fault S PID  keep commanding, SIGKILL the motor simulator PID after 0.5 s,
 *                        wait up to S seconds for FAULT with DRIVER_TIMEOUT; print the
 *                        detection time and check the outputs are off
 *   vcan_check latency N IFACE  N VOLTAGE commands with distinct values at random phases:
 *                        OMNI4_CMD publish -> the first CMD_VOLTAGE frame on IFACE carrying the
 *                        new value (read on a raw CAN socket of our own); prints p50/p99/max
 *                        (a figure, not asserted); fails only if a command never shows
 *   vcan_check drivestop IFACE vesc|odrive FW_PID S DRIVE_TIMEOUT_MS  the controller killed
 *                        while driving simulated drives: each stops on its own (vcan_drives.c)
 *   vcan_check goal DX DY DTHETA S [MOTORSIM_LOG]  a goal from the simulated truth's pose
 *       (vcan_drives.c)
 *   vcan_check capture IFACE S  read the controller's frames until the marker frame 0x7FF
 *                        (at most S seconds); print their count, how many carry a non-zero
 *                        voltage and the data of the last CMD_VOLTAGE
 * Prints one "ok:" or "FAIL:" line with the figures; exit status 0 on success.
 */
#define _DEFAULT_SOURCE /* SCM_TIMESTAMP, struct timeval */
#include <lcm/lcm.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <math.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "omni4/drivers/can_proto.h"
#include "omni4_command_t.h"
#include "omni4_motors_t.h"
#include "vcan_drives.h"

#define R_WHEEL 0.0325
#define TRACK_JUDGED_HZ 150.0 /* the loop rate from which tracking is held to 10 % */

struct state {
	long n, gaps, faults_seen;
	int64_t next_seq;
	double v_sum;
	long v_n;
	double settle_s;     /* track: v measured from this long after VELOCITY began ... */
	int64_t drive_utime; /* ... by the controller's clock (a starved reader lags), 0: */
	                     /* not yet */
	int8_t mode;
	int32_t faults;
	float volt_abs_max_after_fault;
	int fault_seen;
	long latched; /* samples with a latching fault bit or mode FAULT */
	int32_t latched_bits;
	double first_latched_s; /* when the first one arrived (monotonic) */
};

#define LATCHING                                                                                   \
	(OMNI4_MOTORS_T_FAULT_OVERCURRENT | OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT |                  \
	 OMNI4_MOTORS_T_FAULT_DRIVER | OMNI4_MOTORS_T_FAULT_BUS | OMNI4_MOTORS_T_FAULT_ENCODER |   \
	 OMNI4_MOTORS_T_FAULT_CURRENT_SENSOR | OMNI4_MOTORS_T_FAULT_SUPPLY)

/* A process that exists and is not a zombie (its parent may not have reaped it yet). */
static int running(int pid)
{
	char path[64], buf[256];
	FILE *f;

	if (kill(pid, 0) != 0)
		return 0;
	snprintf(path, sizeof(path), "/proc/%d/stat", pid);
	f = fopen(path, "r");
	if (!f)
		return 0;
	const size_t n = fread(buf, 1, sizeof(buf) - 1, f);

	fclose(f);
	buf[n] = 0;
	const char *p = strrchr(buf, ')');

	return !(p && p[1] == ' ' && p[2] == 'Z');
}

static double now_s(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return t.tv_sec + t.tv_nsec * 1e-9;
}

static void on_motors(const lcm_recv_buf_t *rb, const char *ch, const omni4_motors_t *m, void *u)
{
	struct state *s = u;

	(void)rb;
	(void)ch;
	if (s->n && m->seq != s->next_seq)
		s->gaps++;
	s->next_seq = m->seq + 1;
	s->n++;
	s->mode = m->mode;
	s->faults = m->faults;
	if ((m->faults & LATCHING) || m->mode == OMNI4_MOTORS_T_MODE_FAULT) {
		if (!s->latched++)
			s->first_latched_s = now_s();
		/* the latching bits only: a warning in the same sample (OVERRUN, the emulated loop
		 * late on a loaded host) explains nothing and is no fault */
		s->latched_bits |= m->faults & LATCHING;
	}
	if (s->fault_seen)
		for (int j = 0; j < 4; j++)
			if (fabsf(m->voltage[j]) > s->volt_abs_max_after_fault)
				s->volt_abs_max_after_fault = fabsf(m->voltage[j]);
	if (m->mode == OMNI4_MOTORS_T_MODE_FAULT &&
	    (m->faults & OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT))
		s->fault_seen = 1;
	if (m->mode == OMNI4_MOTORS_T_MODE_VELOCITY && !s->drive_utime)
		s->drive_utime = m->utime;
	if (s->settle_s > 0 && s->drive_utime &&
	    (double)(m->utime - s->drive_utime) >= s->settle_s * 1e6) {
		const double v = 0.5 * (m->wheel_speed[3] - m->wheel_speed[1]) * R_WHEEL;

		s->v_sum += v;
		s->v_n++;
	}
}

static int cmp_double(const void *a, const void *b)
{
	const double x = *(const double *)a, y = *(const double *)b;

	return x < y ? -1 : x > y;
}

/* OMNI4_CMD -> CMD_VOLTAGE on the bus, through omni4-fw's real SocketCAN backend. */
static int cmd_to_can_latency(lcm_t *lcm, int n, const char *iface)
{
	const int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
	struct sockaddr_can addr = {.can_family = AF_CAN,
	                            .can_ifindex = (int)if_nametoindex(iface)};
	const struct can_filter flt = {.can_id = CAN_ID_CMD_VOLTAGE, .can_mask = CAN_SFF_MASK};
	double *lat = calloc((size_t)n, sizeof(double));
	int got = 0;

	if (fd < 0 || !addr.can_ifindex || !lat ||
	    setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, &flt, sizeof(flt)) ||
	    bind(fd, (struct sockaddr *)&addr, sizeof(addr))) {
		printf("FAIL: latency: cannot open a raw CAN socket on %s\n", iface);
		free(lat);
		return 1;
	}
	srand(7);
	for (int k = 0; k < n; k++) {
		/* distinct values on the 40 mV grid of CMD_VOLTAGE */
		const float v = 0.52f + 0.04f * (float)(k % 50); /* 0.52 .. 2.48 V, as before */
		const struct timespec phase = {.tv_sec = 0, .tv_nsec = 2000000 + rand() % 1000000};
		omni4_command_t c = {.seq = 1000000 + k,
		                     .mode = OMNI4_COMMAND_T_MODE_VOLTAGE,
		                     .voltage = {v, v, v, v}};
		struct can_frame cf;

		nanosleep(&phase, NULL);
		/* Drop the frames of earlier ticks: only a frame sent after the publish counts. */
		for (struct pollfd p = {.fd = fd, .events = POLLIN}; poll(&p, 1, 0) > 0;)
			if (read(fd, &cf, sizeof(cf)) <= 0)
				break;
		const double t0 = now_s();

		omni4_command_t_publish(lcm, "OMNI4_CMD", &c);
		while (now_s() - t0 < 2.0) { /* a bound for a starved VM; the latency is a figure */
			struct pollfd p = {.fd = fd, .events = POLLIN};
			struct omni4_can_frame f = {0};
			float volts[4];
			bool en;
			uint8_t ctr;

			if (poll(&p, 1, 50) <= 0 ||
			    read(fd, &cf, sizeof(cf)) != (ssize_t)sizeof(cf))
				continue;
			f.id = cf.can_id & CAN_SFF_MASK;
			f.dlc = cf.can_dlc;
			memcpy(f.data, cf.data, sizeof(f.data));
			if (can_decode_cmd_voltage(&f, volts, &en, &ctr) == 0 &&
			    fabsf(volts[0] - v) < 0.015f) {
				lat[got++] = (now_s() - t0) * 1e6;
				break;
			}
		}
	}
	close(fd);
	qsort(lat, (size_t)got, sizeof(double), cmp_double);
	if (got)
		printf(
		    "%s: OMNI4_CMD -> CMD_VOLTAGE on %s: p50 %.0f p99 %.0f max %.0f us over %d of "
		    "%d commands\n",
		    got == n ? "ok" : "FAIL", iface, lat[got / 2], lat[(int)(0.99 * (got - 1))],
		    lat[got - 1], got, n);
	else
		printf("FAIL: no command reached %s\n", iface);
	free(lat);
	return got == n ? 0 : 1;
}

/* The driver boards' real STATUS frames, told from the junk by their CRC, with the kernel's
 * receive time (SO_TIMESTAMP: when the frame went on the bus, however late we read it): the
 * longest silence of either board. A DRIVER_TIMEOUT during the flood is the right answer when
 * a board really was silent that long (the emulated VM starved: omni4-motorsim did not run),
 * and a false fault when it was not. */
struct status_watch {
	int fd;
	double last[CAN_NODES]; /* receive time of the last valid STATUS per board [s] */
	double max_gap_s;
	long valid, junk;
};

static int watch_open(struct status_watch *w, const char *iface)
{
	struct sockaddr_can addr = {.can_family = AF_CAN,
	                            .can_ifindex = (int)if_nametoindex(iface)};
	const struct can_filter flt[2] = {{CAN_ID_STATUS(0), CAN_SFF_MASK},
	                                  {CAN_ID_STATUS(1), CAN_SFF_MASK}};
	const int one = 1;

	memset(w, 0, sizeof(*w));
	w->fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK, CAN_RAW);
	if (w->fd < 0 || !addr.can_ifindex ||
	    setsockopt(w->fd, SOL_CAN_RAW, CAN_RAW_FILTER, flt, sizeof(flt)) ||
	    setsockopt(w->fd, SOL_SOCKET, SO_TIMESTAMP, &one, sizeof(one)) ||
	    bind(w->fd, (struct sockaddr *)&addr, sizeof(addr)))
		return -1;
	return 0;
}

static void watch_drain(struct status_watch *w)
{
	for (;;) {
		struct can_frame cf;
		char ctl[CMSG_SPACE(sizeof(struct timeval))];
		struct iovec iov = {.iov_base = &cf, .iov_len = sizeof(cf)};
		struct msghdr msg = {.msg_iov = &iov,
		                     .msg_iovlen = 1,
		                     .msg_control = ctl,
		                     .msg_controllen = sizeof(ctl)};

		if (recvmsg(w->fd, &msg, 0) != (ssize_t)sizeof(cf))
			return;
		struct cmsghdr *c = CMSG_FIRSTHDR(&msg);
		struct timeval tv = {0, 0};

		if (c && c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMP)
			memcpy(&tv, CMSG_DATA(c), sizeof(tv));
		const double t = tv.tv_sec + tv.tv_usec * 1e-6;
		struct omni4_can_frame f = {.id = cf.can_id & CAN_SFF_MASK, .dlc = cf.can_dlc};
		struct can_status st;
		int node;

		memcpy(f.data, cf.data, 8);
		if (can_decode_status(&f, &node, &st, NULL) || node < 0 || node >= CAN_NODES) {
			w->junk++;
			continue;
		}
		w->valid++;
		if (w->last[node] > 0 && t - w->last[node] > w->max_gap_s)
			w->max_gap_s = t - w->last[node];
		w->last[node] = t;
	}
}

/* The flood: N random frames on the STATUS IDs, paced by the controller's own tick count. */
static int junk_flood(lcm_t *lcm, long n, double max_s, const char *iface, double timeout_s)
{
	struct status_watch w;

	const int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
	struct sockaddr_can addr = {.can_family = AF_CAN,
	                            .can_ifindex = (int)if_nametoindex(iface)};
	struct state s = {0};
	omni4_command_t cmd = {.mode = OMNI4_COMMAND_T_MODE_VELOCITY, .velocity = {0.5, 0, 0}};
	uint64_t x = 0x2545F4914F6CDD1Dull;
	long sent = 0, busy = 0;

	if (fd < 0 || !addr.can_ifindex || bind(fd, (struct sockaddr *)&addr, sizeof(addr))) {
		printf("FAIL: flood: cannot open a raw CAN socket on %s\n", iface);
		return 1;
	}
	const int zero = 0;

	if (watch_open(&w, iface)) {
		printf("FAIL: flood: cannot open the STATUS watch socket on %s\n", iface);
		close(fd);
		return 1;
	}
	setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, NULL, 0); /* we receive nothing */
	setsockopt(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &zero, sizeof(zero));
	omni4_motors_t_subscription_t *sub =
	    omni4_motors_t_subscribe(lcm, "OMNI4_MOTORS", on_motors, &s);

	omni4_motors_t_subscription_set_queue_capacity(sub, 100000);
	const double t0 = now_s();
	double last_cmd = -1;
	long base = -1;

	while (sent < n && now_s() - t0 < max_s) {
		const double t = now_s() - t0;

		if (t - last_cmd >= 0.05) {
			cmd.seq++;
			omni4_command_t_publish(lcm, "OMNI4_CMD", &cmd);
			last_cmd = t;
		}
		lcm_handle_timeout(lcm, 1);
		watch_drain(&w);
		if (base < 0 && s.n > 0)
			base = s.n; /* count from the first sample seen */
		if (base < 0)
			continue;
		long allowed = 40 * (s.n - base) - sent;

		if (allowed > 48)
			allowed = 48; /* no burst beyond what one tick reads */
		for (long k = 0; k < allowed && sent < n; k++) {
			struct can_frame cf = {.can_id = CAN_ID_STATUS(sent & 1), .can_dlc = 8};

			x ^= x << 13;
			x ^= x >> 7;
			x ^= x << 17;
			memcpy(cf.data, &x, 8);
			if (write(fd, &cf, sizeof(cf)) != (ssize_t)sizeof(cf)) {
				busy++;
				break;
			}
			sent++;
		}
	}
	/* a last look at the controller after the flood */
	for (const double t1 = now_s(); now_s() - t1 < 0.3;) {
		lcm_handle_timeout(lcm, 10);
		watch_drain(&w);
	}
	const double elapsed = now_s() - t0;
	/* Only DRIVER_TIMEOUT (and the rejections of commands in FAULT that follow it) may be
	 * latched, and only if a board really was silent for the status timeout. */
	const int32_t explained =
	    OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT | OMNI4_MOTORS_T_FAULT_CMD_REJECTED;
	const int silent = w.max_gap_s >= timeout_s;
	const int faults_ok = s.latched == 0 || (silent && !(s.latched_bits & ~explained));
	/* All n on a quiet host; the time cap (max_s) may end it sooner on a starved one: then at
	 * least n / 5 (10^5 of the 5 x 10^5: none may latch a fault, p <= 9.5e-7 each). */
	/* seq gaps here are this reader's (a starved VM overflows its UDP receive buffer): a
	 * figure; that the controller dropped no sample is checked from its own count at exit */
	const int ok = sent >= n / 5 && faults_ok && s.n > 0 && w.valid > 0;

	printf("%s: flood: %ld of %ld junk STATUS frames in %.1f s (%.0f frames/s), %ld samples "
	       "(%.0f Hz), %ld with a latching fault (bits 0x%x, first at %.2f s), %ld seq gaps, "
	       "mode %d, %ld full-queue waits; the boards' STATUS: %ld valid, longest silence "
	       "%.0f ms (status timeout %.0f ms)%s\n",
	       ok ? "ok" : "FAIL", sent, n, elapsed, sent / elapsed, s.n, s.n / elapsed, s.latched,
	       s.latched_bits, s.latched ? s.first_latched_s - t0 : 0.0, s.gaps, s.mode, busy,
	       w.valid, w.max_gap_s * 1e3, timeout_s * 1e3,
	       s.latched && ok ? ": the boards were silent (VM starved), DRIVER_TIMEOUT is right"
	                       : "");
	omni4_motors_t_unsubscribe(lcm, sub);
	close(w.fd);
	close(fd);
	return ok ? 0 : 1;
}

/* The controller's frames (CMD_VOLTAGE, CMD_CONTROL) until the marker frame 0x7FF that the
 * test sends once the controller is dead: the socket queue is FIFO, so every frame the
 * controller sent before is read, however starved this process was. Prints "capture: N frames,
 * V with a non-zero voltage, last CMD_VOLTAGE HEX" (HEX: the 8 data bytes). */
#define CAPTURE_MARKER_ID 0x7FF
static int capture(const char *iface, double max_s)
{
	struct sockaddr_can addr = {.can_family = AF_CAN,
	                            .can_ifindex = (int)if_nametoindex(iface)};
	const struct can_filter flt[3] = {{CAN_ID_CMD_VOLTAGE, CAN_SFF_MASK},
	                                  {CAN_ID_CMD_CONTROL, CAN_SFF_MASK},
	                                  {CAPTURE_MARKER_ID, CAN_SFF_MASK}};
	const int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
	const int rcvbuf = 1 << 22;
	long n = 0, driven = 0;
	char last[17] = "none";

	if (fd < 0 || !addr.can_ifindex ||
	    setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, flt, sizeof(flt)) ||
	    bind(fd, (struct sockaddr *)&addr, sizeof(addr))) {
		printf("FAIL: capture: cannot open a raw CAN socket on %s\n", iface);
		return 1;
	}
	setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof(rcvbuf));
	printf("capture: listening\n");
	fflush(stdout);
	const double t0 = now_s();

	while (now_s() - t0 < max_s) {
		struct pollfd pf = {.fd = fd, .events = POLLIN};
		struct can_frame cf;

		if (poll(&pf, 1, 100) <= 0)
			continue;
		if (read(fd, &cf, sizeof(cf)) != (ssize_t)sizeof(cf))
			continue;
		const uint32_t id = cf.can_id & CAN_SFF_MASK;

		if (id == CAPTURE_MARKER_ID) {
			printf("capture: %ld frames, %ld with a non-zero voltage, last CMD_VOLTAGE "
			       "%s\n",
			       n, driven, last);
			close(fd);
			return 0;
		}
		n++;
		if (id != CAN_ID_CMD_VOLTAGE)
			continue;
		for (int b = 0; b < 8; b++)
			snprintf(last + 2 * b, 3, "%02X", cf.data[b]);
		/* voltages in bits 0-39 (little-endian signal layout, docs in drivers/can) */
		if (cf.data[0] | cf.data[1] | cf.data[2] | cf.data[3] | cf.data[4])
			driven++;
	}
	printf("FAIL: capture: no marker frame within %.0f s (%ld frames read)\n", max_s, n);
	close(fd);
	return 1;
}

int main(int argc, char **argv)
{
	if (argc < 2) {
		fprintf(stderr,
		        "usage: vcan_check track|rate SECONDS | clear | fault SECONDS PID | "
		        "latency N IFACE\n");
		return 2;
	}
	const int track = !strcmp(argv[1], "track"), rate = !strcmp(argv[1], "rate");
	const int clear = !strcmp(argv[1], "clear"), fault = !strcmp(argv[1], "fault");
	const int calm = !strcmp(argv[1], "calm");

	if (!strcmp(argv[1], "flood")) {
		const long n = argc > 5 ? atol(argv[2]) : 0;
		const double max_s = argc > 5 ? atof(argv[3]) : 0;
		const double timeout_ms = argc > 5 ? atof(argv[5]) : 0;
		lcm_t *l = n > 0 && max_s > 0 && timeout_ms > 0 ? lcm_create(NULL) : NULL;
		int rc;

		if (n <= 0 || !(max_s > 0) || !(timeout_ms > 0)) {
			fprintf(stderr,
			        "usage: vcan_check flood N SECONDS IFACE STATUS_TIMEOUT_MS\n");
			return 2;
		}
		if (!l) {
			printf("FAIL: no LCM\n");
			return 1;
		}
		rc = junk_flood(l, n, max_s, argv[4], timeout_ms * 1e-3);
		lcm_destroy(l);
		return rc;
	}
	if (!strcmp(argv[1], "drivestop")) {
		const bool proto_ok =
		    argc > 6 && (!strcmp(argv[3], "vesc") || !strcmp(argv[3], "odrive"));
		const int pid = argc > 6 ? atoi(argv[4]) : 0;
		const double max_s = argc > 6 ? atof(argv[5]) : 0,
		             timeout_ms = argc > 6 ? atof(argv[6]) : 0;

		if (!proto_ok || pid <= 0 || !(max_s > 0) || !(timeout_ms > 0)) {
			fprintf(stderr,
			        "usage: vcan_check drivestop IFACE vesc|odrive FW_PID SECONDS "
			        "DRIVE_TIMEOUT_MS\n");
			return 2;
		}
		return vcan_drive_stop(argv[2], !strcmp(argv[3], "odrive"), pid, max_s,
		                       timeout_ms * 1e-3);
	}
	if (!strcmp(argv[1], "goal")) {
		const double off[3] = {argc > 5 ? atof(argv[2]) : 0, argc > 5 ? atof(argv[3]) : 0,
		                       argc > 5 ? atof(argv[4]) : 0};
		const double max_s = argc > 5 ? atof(argv[5]) : 0;

		if (!(max_s > 0)) {
			fprintf(stderr,
			        "usage: vcan_check goal DX DY DTHETA SECONDS [MOTORSIM_LOG]\n");
			return 2;
		}
		return vcan_goal(off, max_s, argc > 6 ? argv[6] : NULL);
	}
	if (!strcmp(argv[1], "capture")) {
		const double max_s = argc > 3 ? atof(argv[3]) : 0;

		if (!(max_s > 0)) {
			fprintf(stderr, "usage: vcan_check capture IFACE SECONDS\n");
			return 2;
		}
		return capture(argv[2], max_s);
	}
	if (!strcmp(argv[1], "latency")) {
		const int n = argc > 3 ? atoi(argv[2]) : 0;
		lcm_t *l = n > 0 ? lcm_create(NULL) : NULL;
		int rc;

		if (n <= 0 || n > 100000) {
			fprintf(stderr, "usage: vcan_check latency N IFACE\n");
			return 2;
		}
		if (!l) {
			printf("FAIL: no LCM\n");
			return 1;
		}
		rc = cmd_to_can_latency(l, n, argv[3]);
		lcm_destroy(l);
		return rc;
	}
	const double dur = clear ? 1.0 : (argc > 2 ? atof(argv[2]) : 0);
	const int victim = fault && argc > 3 ? atoi(argv[3]) : 0;
	const double min_hz = (track || rate) && argc > 3 ? atof(argv[3]) : 800.0;
	int waited[8];
	const int n_waited = calm ? (argc - 3 > 8 ? 8 : argc - 3) : 0;

	for (int k = 0; k < n_waited; k++)
		waited[k] = atoi(argv[3 + k]);
	if (!(track || rate || clear || fault || calm) || !(dur > 0) || (fault && victim <= 0) ||
	    (calm && n_waited < 1)) {
		fprintf(stderr,
		        "usage: vcan_check track|rate SECONDS | clear | fault SECONDS PID | "
		        "calm SECONDS PID... | latency N IFACE\n");
		return 2;
	}
	lcm_t *lcm = lcm_create(NULL);

	if (!lcm) {
		printf("FAIL: no LCM\n");
		return 1;
	}
	struct state s = {0};
	omni4_motors_t_subscription_t *sub =
	    omni4_motors_t_subscribe(lcm, "OMNI4_MOTORS", on_motors, &s);

	omni4_motors_t_subscription_set_queue_capacity(sub, 100000);
	omni4_command_t cmd = {.mode = OMNI4_COMMAND_T_MODE_VELOCITY, .velocity = {0.5, 0, 0}};
	if (clear)
		cmd.mode = OMNI4_COMMAND_T_MODE_CLEAR_FAULT;
	const double t0 = now_s();
	double last_cmd = -1, t_fault = -1, t_kill = -1;

	s.settle_s = track ? dur / 2 : 0.0;

	while (now_s() - t0 < dur) {
		const double t = now_s() - t0;

		if (t - last_cmd >= 0.05 && !(clear && last_cmd >= 0)) {
			cmd.seq++;
			omni4_command_t_publish(lcm, "OMNI4_CMD", &cmd);
			last_cmd = t;
		}
		if (fault && t_kill < 0 && t >= 0.5) {
			kill(victim, SIGKILL);
			t_kill = now_s() - t0;
			s.fault_seen = 0;
		}
		lcm_handle_timeout(lcm, 2);
		if (fault && t_kill >= 0 && s.fault_seen && t_fault < 0)
			t_fault = now_s() - t0;
		if (fault && t_fault >= 0 && t - t_fault > 0.3)
			break;
		if (calm) {
			int alive = 0;

			for (int k = 0; k < n_waited; k++)
				alive += running(waited[k]);
			if (!alive)
				break;
		}
	}
	const double elapsed = now_s() - t0;
	int ok;

	if (calm) {
		int alive = 0;

		for (int k = 0; k < n_waited; k++)
			alive += running(waited[k]);
		ok = !alive && s.latched == 0 && s.n > 0;
		printf("%s: flood over %.1f s%s: %ld samples (%.0f Hz), %ld with a latching fault "
		       "(bits 0x%x, first at %.2f s), %ld seq gaps, mode %d\n",
		       ok ? "ok" : "FAIL", elapsed,
		       alive ? " (generators still running at the time limit)" : "", s.n,
		       s.n / elapsed, s.latched, s.latched_bits,
		       s.latched ? s.first_latched_s - t0 : 0.0, s.gaps, s.mode);
	} else if (clear) {
		ok = s.mode != OMNI4_MOTORS_T_MODE_FAULT && s.n > 0;
		printf("%s: clear fault: mode %d, faults 0x%x\n", ok ? "ok" : "FAIL", s.mode,
		       s.faults);
	} else if (rate) {
		ok = s.n >= min_hz * elapsed;
		printf("%s: %ld samples in %.1f s (%.0f Hz), %ld seq gaps, mode %d, faults 0x%x\n",
		       ok ? "ok" : "FAIL", s.n, elapsed, s.n / elapsed, s.gaps, s.mode, s.faults);
	} else if (track) {
		const double v = s.v_n ? s.v_sum / s.v_n : NAN;

		/* Within 10 % when the emulated loop runs at TRACK_JUDGED_HZ or more (177-990 Hz on
		 * a quiet host); a VM starved below it (41 Hz beside stress-ng and builds) runs a
		 * 1 kHz design at a rate it was never tuned for: then only moving the right way. */
		const bool judged = s.n / elapsed >= TRACK_JUDGED_HZ;

		ok = (judged ? fabs(v - 0.5) < 0.05 : v > 0.25) &&
		     s.mode == OMNI4_MOTORS_T_MODE_VELOCITY && s.n >= min_hz * elapsed;
		printf(
		    "%s: tracking over %.1f s: v %.4f m/s (target 0.5%s), %ld samples (%.0f Hz), "
		    "%ld seq gaps, mode %d, faults 0x%x\n",
		    ok ? "ok" : "FAIL", elapsed, v,
		    judged ? "" : "; loop below 150 Hz: only its direction judged", s.n,
		    s.n / elapsed, s.gaps, s.mode, s.faults);
	} else {
		ok = t_fault >= 0 && s.volt_abs_max_after_fault == 0.0f;
		printf("%s: motor driver killed -> FAULT (DRIVER_TIMEOUT) %s after %.0f ms (status "
		       "timeout + LCM delivery); outputs after the fault max |u| %.3f V\n",
		       ok ? "ok" : "FAIL", t_fault >= 0 ? "seen" : "NOT seen",
		       (t_fault - t_kill) * 1e3, s.volt_abs_max_after_fault);
	}
	lcm_destroy(lcm);
	return ok ? 0 : 1;
}
