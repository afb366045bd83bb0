/*
 * vcan_check - the LCM side of the CAN tests inside the VM (omni4-fw with the socketcan
 * backend and omni4-motorsim on vcan0).
 *   vcan_check track S [HZ]  command v = 0.5 m/s for S seconds; check the tracking from the
 *                        wheel speeds (eqs 3-5), seq continuity, a sample rate >= HZ (default
 *                        800), no fault
 *   vcan_check rate S [HZ]   command for S seconds; check only the rate and seq continuity
 *   vcan_check clear     send MODE_CLEAR_FAULT; check the controller leaves FAULT
 *   vcan_check fault S PID  keep commanding, SIGKILL the motor simulator PID after 0.5 s,
 *                        wait up to S seconds for FAULT with DRIVER_TIMEOUT; print the
 *                        detection time and check the outputs are off
 * Prints one "ok:" or "FAIL:" line with the figures; exit status 0 on success.
 */
#include <lcm/lcm.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "omni4_command_t.h"
#include "omni4_motors_t.h"

#define R_WHEEL 0.0325

struct state {
	long n, gaps, faults_seen;
	int64_t next_seq;
	double v_sum;
	long v_n;
	int measuring;
	int8_t mode;
	int32_t faults;
	float volt_abs_max_after_fault;
	int fault_seen;
};

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
	if (s->fault_seen)
		for (int j = 0; j < 4; j++)
			if (fabsf(m->voltage[j]) > s->volt_abs_max_after_fault)
				s->volt_abs_max_after_fault = fabsf(m->voltage[j]);
	if (m->mode == OMNI4_MOTORS_T_MODE_FAULT &&
	    (m->faults & OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT))
		s->fault_seen = 1;
	if (s->measuring) {
		const double v = 0.5 * (m->wheel_speed[3] - m->wheel_speed[1]) * R_WHEEL;

		s->v_sum += v;
		s->v_n++;
	}
}

int main(int argc, char **argv)
{
	if (argc < 2) {
		fprintf(stderr, "usage: vcan_check track|rate SECONDS | clear | fault SECONDS PID\n");
		return 2;
	}
	const int track = !strcmp(argv[1], "track"), rate = !strcmp(argv[1], "rate");
	const int clear = !strcmp(argv[1], "clear"), fault = !strcmp(argv[1], "fault");
	const double dur = clear ? 1.0 : (argc > 2 ? atof(argv[2]) : 0);
	const int victim = fault && argc > 3 ? atoi(argv[3]) : 0;
	const double min_hz = (track || rate) && argc > 3 ? atof(argv[3]) : 800.0;

	if (!(track || rate || clear || fault) || !(dur > 0) || (fault && victim <= 0)) {
		fprintf(stderr, "usage: vcan_check track|rate SECONDS | clear | fault SECONDS PID\n");
		return 2;
	}
	lcm_t *lcm = lcm_create(NULL);

	if (!lcm) {
		printf("FAIL: no LCM\n");
		return 1;
	}
	struct state s = {0};
	omni4_motors_t_subscription_t *sub = omni4_motors_t_subscribe(lcm, "OMNI4_MOTORS", on_motors, &s);

	omni4_motors_t_subscription_set_queue_capacity(sub, 100000);
	omni4_command_t cmd = {.mode = OMNI4_COMMAND_T_MODE_VELOCITY, .velocity = {0.5, 0, 0}};
	if (clear)
		cmd.mode = OMNI4_COMMAND_T_MODE_CLEAR_FAULT;
	const double t0 = now_s();
	double last_cmd = -1, t_fault = -1, t_kill = -1;

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
		s.measuring = track && t > dur / 2;
		lcm_handle_timeout(lcm, 2);
		if (fault && t_kill >= 0 && s.fault_seen && t_fault < 0)
			t_fault = now_s() - t0;
		if (fault && t_fault >= 0 && t - t_fault > 0.3)
			break;
	}
	const double elapsed = now_s() - t0;
	int ok;

	if (clear) {
		ok = s.mode != OMNI4_MOTORS_T_MODE_FAULT && s.n > 0;
		printf("%s: clear fault: mode %d, faults 0x%x\n", ok ? "ok" : "FAIL", s.mode, s.faults);
	} else if (rate) {
		ok = s.gaps == 0 && s.n >= min_hz * elapsed;
		printf("%s: %ld samples in %.1f s (%.0f Hz), %ld seq gaps, mode %d, faults 0x%x\n",
		       ok ? "ok" : "FAIL", s.n, elapsed, s.n / elapsed, s.gaps, s.mode, s.faults);
	} else if (track) {
		const double v = s.v_n ? s.v_sum / s.v_n : NAN;

		ok = fabs(v - 0.5) < 0.05 && s.gaps == 0 && s.mode == OMNI4_MOTORS_T_MODE_VELOCITY &&
		     s.n >= min_hz * elapsed;
		printf("%s: tracking over %.1f s: v %.4f m/s (target 0.5), %ld samples (%.0f Hz), "
		       "%ld seq gaps, mode %d, faults 0x%x\n",
		       ok ? "ok" : "FAIL", elapsed, v, s.n, s.n / elapsed, s.gaps, s.mode, s.faults);
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
