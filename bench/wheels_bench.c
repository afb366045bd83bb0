/*
 * wheels_bench - steady velocity error of the controller on a simulated robot whose four
 * drives differ (docs/model.md): the scalar model's feedforward (the paper's averaged R, Kv, Kt,
 * r) beside the per-wheel model's ([model] r_j Kv_j Kt_j R_j set to the robot's own values),
 * both on the very same robot in the same run, PI off ([control] feedback = false: feedforward
 * alone) and on.
 *
 * The robot (the sim backend's plant, exact sensors): motors +-5 % in R and in Kv (Kt with it),
 * wheel radii +-1 % with the mean radius unchanged ([sim] motor_R_error_j, motor_Kv_error_j,
 * wheel_radius_error_j; each set sums to 0, so the scalar model is the wheels' mean, Table III).
 * The drives: a 1 m/s step along v, along vn, and a 5 rad/s turn, each from rest; the steady
 * error is the mean of (true velocity - command) over the last second of 3 s.
 * usage: wheels_bench   (prints one line per axis and PI setting; exit 0, 2 on a setup error)
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "omni4/config/config.h"
#include "omni4/core/ctl.h"
#include "omni4/drivers/sim_motor.h"

#define RUN_S 3.0
#define MEAN_S 1.0

static const double R_ERR[4] = {0.05, -0.05, -0.05, 0.05};
static const double KV_ERR[4] = {-0.05, 0.05, -0.05, 0.05};
static const double RADIUS_ERR[4] = {0.01, -0.01, 0.01, -0.01};

/* The robot's INI: [sim] with the drives' differences, [control] feedback; with per_wheel the
 * controller's [model] also gives each drive its own constants (the scalars: Table III). */
static int robot_config(bool per_wheel, bool pi, struct omni4_config *cfg)
{
	const struct model_params *p = &model_params_table3;
	char text[4096];
	int n = snprintf(text, sizeof(text), "[control]\nfeedback = %s\n[sim]\n",
	                 pi ? "true" : "false");

	for (int j = 0; j < 4; j++)
		n += snprintf(text + n, sizeof(text) - (size_t)n,
		              "motor_R_error_%d = %.17g\nmotor_Kv_error_%d = %.17g\n"
		              "wheel_radius_error_%d = %.17g\n",
		              j, R_ERR[j], j, KV_ERR[j], j, RADIUS_ERR[j]);
	if (per_wheel) {
		n += snprintf(text + n, sizeof(text) - (size_t)n, "[model]\n");
		for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
			n += snprintf(text + n, sizeof(text) - (size_t)n, "%s = %.17g\n",
			              model_params_names[i], model_params_get(p, i));
		for (int j = 0; j < 4; j++)
			n += snprintf(text + n, sizeof(text) - (size_t)n,
			              "r_%d = %.17g\nR_%d = %.17g\nKv_%d = %.17g\nKt_%d = %.17g\n",
			              j, p->r * (1 + RADIUS_ERR[j]), j, p->R * (1 + R_ERR[j]), j,
			              p->Kv * (1 + KV_ERR[j]), j, p->Kt * (1 + KV_ERR[j]));
	}
	struct config_error err;

	config_defaults(cfg);
	if ((size_t)n >= sizeof(text) || config_load_string(text, "wheels_bench.ini", cfg, &err)) {
		fprintf(stderr, "wheels_bench: %s\n", err.msg);
		return -1;
	}
	return 0;
}

/* The steady error [m/s or rad/s] on axis `axis` of a step to `target` from rest. */
static int steady_error(bool per_wheel, bool pi, int axis, double target, double *err)
{
	struct omni4_config cfg;
	struct sim_motor sm;
	struct ctl c;

	if (robot_config(per_wheel, pi, &cfg))
		return -1;
	const double dt = 1.0 / cfg.ctl.rate_hz;
	const struct sim_motor_config sc = sim_motor_config_from(
	    &cfg.sim, false, &model_params_table3, dt, cfg.ctl.limits.supply_v);

	if (sim_motor_init(&sm, &sc) || ctl_init(&c, &cfg.ctl)) {
		fprintf(stderr, "wheels_bench: cannot start the robot\n");
		return -1;
	}
	const struct motor_hal hal = sim_motor_hal(&sm);
	struct ctl_command cmd = {.mode = CTL_VELOCITY};
	const long ticks = lround(RUN_S / dt), from = ticks - lround(MEAN_S / dt);
	double sum = 0.0;

	cmd.velocity[axis] = target;
	for (long i = 0; i < ticks; i++) {
		const int64_t now = (i + 1) * (int64_t)llround(dt * 1e6);
		struct motor_sample s;
		struct ctl_output out;
		struct hal_truth t;

		if (i % 50 == 0) { /* the watchdog wants a command within 200 ms */
			cmd.seq = i;
			cmd.utime = now;
			ctl_command(&c, &cmd, now);
		}
		const int rc = hal.ops->read(hal.ctx, &s);

		ctl_step(&c, now, &s, rc, false, &out);
		hal.ops->enable(hal.ctx, out.enable);
		hal.ops->write(hal.ctx, out.volts);
		sim_motor_truth(&sm, &t);
		if (i >= from)
			sum += t.vel[axis] - target;
	}
	if (c.mode != CTL_VELOCITY) {
		fprintf(stderr, "wheels_bench: the controller left VELOCITY (faults 0x%x)\n",
		        (unsigned)(c.latched | c.warnings));
		return -1;
	}
	*err = sum / (double)(ticks - from);
	return 0;
}

int main(void)
{
	static const char *const name[3] = {"v 1 m/s", "vn 1 m/s", "w 5 rad/s"};
	static const char *const unit[3] = {"mm/s", "mm/s", "mrad/s"};
	static const double target[3] = {1.0, 1.0, 5.0};

	printf("drives: R %+.0f/%+.0f/%+.0f/%+.0f %%, Kv %+.0f/%+.0f/%+.0f/%+.0f %%, radius "
	       "%+.0f/%+.0f/%+.0f/%+.0f %%\n",
	       100 * R_ERR[0], 100 * R_ERR[1], 100 * R_ERR[2], 100 * R_ERR[3], 100 * KV_ERR[0],
	       100 * KV_ERR[1], 100 * KV_ERR[2], 100 * KV_ERR[3], 100 * RADIUS_ERR[0],
	       100 * RADIUS_ERR[1], 100 * RADIUS_ERR[2], 100 * RADIUS_ERR[3]);
	for (int pi = 0; pi < 2; pi++)
		for (int axis = 0; axis < 3; axis++) {
			double e_scalar, e_wheels;

			if (steady_error(false, pi, axis, target[axis], &e_scalar) ||
			    steady_error(true, pi, axis, target[axis], &e_wheels))
				return 2;
			printf("steady error PI %-3s %-10s scalar model %9.3f %s  per-wheel model "
			       "%9.3f "
			       "%s  ratio %.3f\n",
			       pi ? "on" : "off", name[axis], 1e3 * e_scalar, unit[axis],
			       1e3 * e_wheels, unit[axis],
			       fabs(e_wheels) / fmax(fabs(e_scalar), 1e-12));
		}
	return 0;
}
