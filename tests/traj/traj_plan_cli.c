/*
 * traj_plan - the trajectory generator (core/src/planner/traj.c) from the command line, for the
 * comparison with the time-optimal bound (bench/traj_optimal.py) and for a look at a plan.
 * The robot: Table III, four equal drives; the limits the goal mode takes from the INI keys'
 * defaults (goal_limits), without its speed caps, each changed by its option:
 *
 *   traj_plan [--mu=MU] [--supply=V] [--margin=V] [--traction-margin=K]
 *             [--motor-max=RAD_S] [--rot-share=K] [--com-height=M] [--samples=DT]
 *             [--curve=EVALS] X0 Y0 TH0 VX0 VY0 W0 X Y TH
 *
 * --curve=EVALS plans one curve (traj_plan_curve, EVALS timings in its search) instead of the
 * goal mode's plan.
 * Prints "duration_s D"; with --samples=DT also one line per DT seconds:
 * "t x y theta vx vy w ax ay aw" (world frame, SI). Exit 2 with one line on stderr for bad
 * arguments or limits the generator refuses.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "omni4/core/ctl_settings.h"
#include "omni4/core/goal.h"
#include "omni4/core/planner/traj.h"

static const char usage[] =
    "usage: traj_plan [--mu=MU] [--supply=V] [--margin=V] [--traction-margin=K]\n"
    "                 [--motor-max=RAD_S] [--rot-share=K] [--com-height=M]\n"
    "                 [--samples=DT] [--curve=EVALS]\n"
    "                 X0 Y0 TH0 VX0 VY0 W0 X Y TH\n"
    "defaults: the goal mode's limits from the INI keys' defaults ([goal] floor_mu,\n"
    "margin_v, motor_speed_max, rot_share; [limits] supply_v, traction_margin,\n"
    "com_height), no speed caps; --curve=EVALS: one curve searched in EVALS\n"
    "timings (traj_plan_curve) instead of the goal mode's plan\n"
    "example: traj_plan --samples=0.1 0 0 0 0 0 0 1 0.5 1.57\n";

static int number(const char *s, double *out)
{
	char *end;

	errno = 0;
	*out = strtod(s, &end);
	return errno || end == s || *end || !isfinite(*out) ? -1 : 0;
}

static int option(const char *arg, struct traj_limits *l, double *samples, double *curve)
{
	static const char *const names[] = {
	    "--mu=",        "--supply=",    "--margin=",     "--traction-margin=",
	    "--motor-max=", "--rot-share=", "--com-height=", "--samples=",
	    "--curve="};
	double *const fields[] = {&l->mu,
	                          &l->supply_v,
	                          &l->margin_v,
	                          &l->traction_margin,
	                          &l->motor_speed_max_rad_s,
	                          &l->rot_share,
	                          &l->com_height_m,
	                          samples,
	                          curve};

	for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++)
		if (!strncmp(arg, names[i], strlen(names[i])))
			return number(arg + strlen(names[i]), fields[i]);
	return -1;
}

static void print_samples(const struct traj *tr, double dt)
{
	for (double t = 0.0; t < tr->duration_s + dt; t += dt) {
		struct traj_ref r;
		traj_eval(tr, (float)t, &r);
		printf("%.6f %.7g %.7g %.7g %.7g %.7g %.7g %.7g %.7g %.7g\n", t, r.pose[0],
		       r.pose[1], r.pose[2], r.vel[0], r.vel[1], r.vel[2], r.acc[0], r.acc[1],
		       r.acc[2]);
	}
}

int main(int argc, char **argv)
{
	struct ctl_settings s;
	struct traj_limits l;

	ctl_settings_defaults(&s); /* the goal mode's limits ([goal], [limits] defaults), */
	goal_limits(&s, &l);       /* without its speed caps */
	l.speed_cap_m_s = INFINITY;
	l.omega_cap_rad_s = INFINITY;
	double samples = 0.0, curve = 0.0, v[9];
	int n = 0;

	model_wheels_from_params(&l.p, &l.w);
	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
			fputs(usage, stdout);
			return 0;
		}
		const int bad = !strncmp(argv[i], "--", 2) ? option(argv[i], &l, &samples, &curve)
		                : n < 9                    ? number(argv[i], &v[n++])
		                                           : -1;
		if (bad) {
			fprintf(stderr, "traj_plan: bad argument '%s' (--help)\n", argv[i]);
			return 2;
		}
	}
	if (n != 9 || samples < 0.0) {
		fputs(usage, stderr);
		return 2;
	}
	struct traj tr;
	if (traj_init(&tr, &l)) {
		fprintf(stderr, "traj_plan: the limits leave no plan (traj_init: -EINVAL)\n");
		return 2;
	}
	const struct traj_ref from = {.pose = {(float)v[0], (float)v[1], (float)v[2]},
	                              .vel = {(float)v[3], (float)v[4], (float)v[5]}};
	const float goal[3] = {(float)v[6], (float)v[7], (float)v[8]};
	if (curve > 0.0) {
		const int rc = traj_plan_curve(&tr, &from, goal, (int)curve);
		if (rc) {
			fprintf(stderr, "traj_plan: traj_plan_curve: %s\n",
			        rc == -EINVAL ? "-EINVAL (--curve out of range?)"
			                      : "-ERANGE (no curve)");
			return 1;
		}
	} else {
		traj_plan(&tr, &from, goal);
	}
	printf("duration_s %.6f\n", (double)tr.duration_s);
	if (samples > 0.0)
		print_samples(&tr, samples);
	return 0;
}
