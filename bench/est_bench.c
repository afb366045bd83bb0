/*
 * est_bench - the controller's state estimate against the simulated robot's true state, beside
 * two peers computed in the same run: the raw camera and wheel odometry alone (the wheels'
 * forward kinematics integrated, written here, apart from the model library), plus the same
 * estimator with the camera replay switched off (frames applied at arrival).
 *
 * The drive (lockstep simulator, sensors from the robot INI's [sim]): the paper's validation
 * steps (velocity steps along v, vn, w and back), then a path with turns at 1-2 m/s.
 * usage: est_bench [--ini ROBOT.ini] [--path-s S] [--csv FILE]
 * Prints one line per estimate: position RMS [mm], heading RMS [deg], and the ratios the
 * estimate achieves against each peer; the wheel scale errors learnt beside the plant's; then
 * the episodes: camera dropouts at three speeds (beside ideal dead reckoning: the wheels with
 * their true radii, started from the true pose at the start of the gap, the best any
 * wheel-based estimate can do), collisions below and beyond the floor's traction, a slip.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "omni4/lcmtypes/channels.h"
#include "omni4/model/consts.h"
#include "omni4/config/config.h"
#include "omni4/core/est.h"
#include "omni4/model/kinematics.h"
#include "omni4/drivers/sim_motor.h"
#include "omni4/sil/simrun.h"
#include "omni4_command_t.h"
#include "omni4_motors_t.h"
#include "omni4_pose_t.h"
#include "omni4_sim_truth_t.h"

#define PI MODEL_PI

struct score {
	double se_pos, se_th; /* sums of squared errors [m^2], [rad^2] */
	long n;
};

struct bench {
	struct simrun *sr;
	double d, r, period_s;
	int64_t utime0;
	long ticks_max;
	double (*truth)[3]; /* world pose per tick */
	/* wheel odometry */
	double odo[3];
	int64_t odo_last;
	/* ideal dead reckoning during a dropout (true radii, from the true pose) */
	double radius_error[4], ideal[3];
	int64_t ideal_last;
	bool ideal_on;
	/* the estimator again, frames at arrival */
	struct est late;
	omni4_motors_t prev;
	bool have_prev;
	struct score est, late_score, cam, odo_score;
	FILE *csv;
	/* episodes: the truth's flags, the estimate's flags and error per tick */
	uint32_t truth_flags, est_flags;
	double err_m;       /* the estimate's position error at the last motors sample [m] */
	double ideal_err_m; /* ideal dead reckoning's, likewise */
	double cruise_ss;   /* the estimate's squared position error summed over a cruise */
	long cruise_n;
	long false_slip, false_collision; /* flag onsets outside any injected episode */
	double innov_max, innov_ss, null_max, null_ss; /* in normal driving */
	long n_flags;
	bool in_episode;
	int64_t last_pose_arrival;
};

static double wrap(double a)
{
	while (a > PI)
		a -= 2 * PI;
	while (a <= -PI)
		a += 2 * PI;
	return a;
}

static void add(struct score *s, const double truth[3], double x, double y, double th)
{
	const double dx = x - truth[0], dy = y - truth[1], dth = wrap(th - truth[2]);

	s->se_pos += dx * dx + dy * dy;
	s->se_th += dth * dth;
	s->n++;
}

static const double *truth_at(const struct bench *b, int64_t utime)
{
	const long k = (long)llround((double)(utime - b->utime0) * 1e-6 / b->period_s);

	return k >= 0 && k < b->ticks_max ? b->truth[k] : NULL;
}

/* Wheel odometry: eqs 3-5 from the four wheel speeds (rows of eq 2: [0 1 d], [-1 0 d],
 * [0 -1 d], [1 0 d]) with the radii r (1 + err_j), the pose integrated at the mid-step
 * heading. */
static void odometry(const struct bench *b, const omni4_motors_t *m, const double err[4],
                     double pose[3], int64_t *last)
{
	double vw[4];

	for (int j = 0; j < 4; j++)
		vw[j] = m->wheel_speed[j] * b->r * (1.0 + err[j]);
	double x[3];

	fk_robot_velocity(b->d, vw, x);
	const double v = x[0], vn = x[1], w = x[2];
	const double dt = *last ? (double)(m->utime - *last) * 1e-6 : 0.0;
	const double th = pose[2] + 0.5 * w * dt;

	pose[0] += dt * (cos(th) * v - sin(th) * vn);
	pose[1] += dt * (sin(th) * v + cos(th) * vn);
	pose[2] = wrap(pose[2] + w * dt);
	*last = m->utime;
}

static void on_motors(struct bench *b, const omni4_motors_t *m)
{
	const double *t = truth_at(b, m->utime);
	/* the frames-at-arrival twin: what drove the robot up to this reading, as the loop has it
	 */
	struct est_input in = {.utime = m->utime, .have_wheels = true};

	if (b->have_prev) {
		in.driven = b->prev.mode == OMNI4_MOTORS_T_MODE_VELOCITY ||
		            b->prev.mode == OMNI4_MOTORS_T_MODE_VOLTAGE;
		memcpy(in.volts, b->prev.voltage, sizeof(in.volts));
	}
	memcpy(in.wheel_rad_s, m->wheel_speed, sizeof(in.wheel_rad_s));
	est_step(&b->late, &in);
	b->prev = *m;
	b->have_prev = true;
	static const double nominal[4];

	odometry(b, m, nominal, b->odo, &b->odo_last);
	if (b->ideal_on)
		odometry(b, m, b->radius_error, b->ideal, &b->ideal_last);
	if (!t)
		return;
	if (b->ideal_on)
		b->ideal_err_m = hypot(b->ideal[0] - t[0], b->ideal[1] - t[1]);
	const struct est_output *o = simrun_estimate(b->sr);
	const struct est_output *l = est_get(&b->late);

	b->err_m = hypot(o->pose[0] - t[0], o->pose[1] - t[1]);
	b->cruise_ss += b->err_m * b->err_m;
	b->cruise_n++;
	if (!b->in_episode) {
		b->false_slip += (o->flags & EST_FLAG_SLIP) && !(b->est_flags & EST_FLAG_SLIP);
		b->false_collision +=
		    (o->flags & EST_FLAG_COLLISION) && !(b->est_flags & EST_FLAG_COLLISION);
	}
	b->est_flags = o->flags;
	if (b->in_episode)
		return; /* the scores are of normal driving */
	b->innov_max = fmax(b->innov_max, o->vel_innov);
	b->innov_ss += (double)o->vel_innov * o->vel_innov;
	b->null_max = fmax(b->null_max, fabs(o->null_residual));
	b->null_ss += (double)o->null_residual * o->null_residual;
	b->n_flags++;
	add(&b->est, t, o->pose[0], o->pose[1], o->pose[2]);
	add(&b->late_score, t, l->pose[0], l->pose[1], l->pose[2]);
	add(&b->odo_score, t, b->odo[0], b->odo[1], b->odo[2]);
	if (b->csv && m->seq % 20 == 0)
		fprintf(b->csv, "%.3f,%.5f,%.5f,%.5f,%.5f,%.5f,%.5f,%.5f,%.5f\n",
		        (double)(m->utime - b->utime0) * 1e-6, t[0], t[1], o->pose[0], o->pose[1],
		        b->odo[0], b->odo[1], l->pose[0], l->pose[1]);
}

static void on_pose(struct bench *b, const omni4_pose_t *p, int64_t arrival)
{
	const double *t = truth_at(b, p->utime);
	const double z[3] = {p->x, p->y, p->theta};

	est_camera(&b->late, p->utime, z, arrival);
	b->last_pose_arrival = arrival;
	if (t && !b->in_episode)
		add(&b->cam, t, p->x, p->y, p->theta);
}

static void tap(void *ctx, const char *channel, int64_t utime, const void *data, size_t len)
{
	struct bench *b = ctx;
	/* The messages of a tick come out after its plant step: the plant is at this tick's time.
	 */
	const long k =
	    (long)llround((double)(simrun_now_us(b->sr) - b->utime0) * 1e-6 / b->period_s);
	double vel[3];

	if (k >= 0 && k < b->ticks_max)
		simrun_truth(b->sr, vel, b->truth[k]);

	if (!strcmp(channel, OMNI4_CHANNEL_MOTORS)) {
		omni4_motors_t m;

		if (omni4_motors_t_decode(data, 0, (int)len, &m) == (int)len)
			on_motors(b, &m);
	} else if (!strcmp(channel, OMNI4_CHANNEL_SIM_TRUTH)) {
		omni4_sim_truth_t tr;

		if (omni4_sim_truth_t_decode(data, 0, (int)len, &tr) == (int)len)
			b->truth_flags = (uint32_t)tr.flags;
	} else if (!strcmp(channel, OMNI4_CHANNEL_POSE)) {
		omni4_pose_t p;

		if (omni4_pose_t_decode(data, 0, (int)len, &p) == (int)len)
			on_pose(b, &p, simrun_now_us(b->sr));
	}
	(void)utime;
}

static void command(struct bench *b, double v, double vn, double w, int64_t *seq)
{
	unsigned char buf[256];
	omni4_command_t c = {.utime = simrun_now_us(b->sr),
	                     .seq = (*seq)++,
	                     .mode = OMNI4_COMMAND_T_MODE_VELOCITY,
	                     .velocity = {v, vn, w}};
	const int n = omni4_command_t_encode(buf, 0, sizeof(buf), &c);

	simrun_command(b->sr, buf, (size_t)n);
}

/* The velocity asked for at time t [s]: validation steps, then the path. */
static void drive_at(double t, double steps_s, double x[3])
{
	static const double steps[][3] = {{1, 0, 0}, {0, 0, 0},  {0, 1, 0}, {0, 0, 0},  {0, 0, 6},
	                                  {0, 0, 0}, {-1, 0, 0}, {0, 0, 0}, {0, -1, 0}, {0, 0, 0}};
	const int n = (int)(sizeof(steps) / sizeof(steps[0]));

	if (t < steps_s) {
		memcpy(x, steps[(int)(t / (steps_s / n)) % n], 3 * sizeof(double));
		return;
	}
	const double s = t - steps_s;

	x[0] = 1.5 + 0.5 * sin(2 * PI * s / 15.0); /* 1-2 m/s */
	x[1] = 0.3 * sin(2 * PI * s / 7.0);
	x[2] = 1.2 * sin(2 * PI * s / 10.0); /* turns */
}

static void drive_for(struct bench *b, double s, const double x[3], int64_t *seq)
{
	const long n = (long)(s / b->period_s);

	for (long k = 0; k < n; k++) {
		if (k % 20 == 0)
			command(b, x[0], x[1], x[2], seq);
		simrun_tick(b->sr);
	}
}

struct gap {
	double end_m, ideal_m, within_ms, ratio; /* worst over the gaps */
	double end_sum, ideal_sum;               /* for the means */
};

/* A 2 s camera dropout while driving at speed [m/s] (and 0.5 rad/s): the error at the end of
 * the gap beside ideal dead reckoning's; when after the first frame back the error is first
 * within 3x its RMS over the 2 s before the gap, and its RMS over 0.5-1.0 s after that frame
 * against the RMS before (1: as before the gap). */
static void dropout(struct bench *b, double speed, int64_t *seq, struct gap *g)
{
	const double cruise[3] = {speed, 0.0, 0.5};
	struct sim_motor_faults *f = simrun_faults(b->sr);

	drive_for(b, 1.0, cruise, seq);
	b->cruise_ss = 0.0;
	b->cruise_n = 0;
	drive_for(b, 2.0, cruise, seq);
	const double rms_before = sqrt(b->cruise_ss / (double)(b->cruise_n ? b->cruise_n : 1));

	f->camera_off = true;
	memcpy(b->ideal, truth_at(b, b->prev.utime), sizeof(b->ideal));
	b->ideal_last = b->prev.utime;
	b->ideal_on = true;
	drive_for(b, 2.0, cruise, seq);
	b->ideal_on = false;
	const double gap_end_m = b->err_m, ideal_m = b->ideal_err_m;

	f->camera_off = false;
	const int64_t back = simrun_now_us(b->sr);
	int64_t first = 0, within = -1;

	for (long k = 0; k < (long)(1.5 / b->period_s); k++) {
		if (k % 20 == 0)
			command(b, cruise[0], cruise[1], cruise[2], seq);
		const int64_t now = simrun_now_us(b->sr);

		if (first && now == first + 500000) {
			b->cruise_ss = 0.0;
			b->cruise_n = 0;
		}
		if (first && now == first + 1000000)
			g->ratio =
			    fmax(g->ratio, sqrt(b->cruise_ss / (double)b->cruise_n) / rms_before);
		simrun_tick(b->sr);
		if (!first && b->last_pose_arrival > back)
			first = b->last_pose_arrival;
		if (first && within < 0 && b->err_m <= 3.0 * rms_before)
			within = simrun_now_us(b->sr) - first;
	}
	g->end_m = fmax(g->end_m, gap_end_m);
	g->ideal_m = fmax(g->ideal_m, ideal_m);
	g->within_ms = fmax(g->within_ms, within < 0 ? 1e3 : (double)within * 1e-3);
	g->end_sum += gap_end_m;
	g->ideal_sum += ideal_m;
}

/* A force against the motion [N] for 0.5 s at 1.5 m/s: the first COLLISION and SLIP. */
static void collision(struct bench *b, double force_n, int64_t *seq)
{
	static const double cruise[3] = {1.5, 0.0, 0.5};
	struct sim_motor_faults *f = simrun_faults(b->sr);
	double coll_ms = -1.0, slip_ms = -1.0;

	drive_for(b, 2.0, cruise, seq);
	f->ext_force[0] = -force_n;
	for (long k = 0; k < (long)(0.5 / b->period_s); k++) {
		if (k % 20 == 0)
			command(b, cruise[0], cruise[1], cruise[2], seq);
		simrun_tick(b->sr);
		if (coll_ms < 0 && (b->est_flags & EST_FLAG_COLLISION))
			coll_ms = (double)(k + 1) * b->period_s * 1e3;
		if (slip_ms < 0 && (b->est_flags & EST_FLAG_SLIP))
			slip_ms = (double)(k + 1) * b->period_s * 1e3;
	}
	f->ext_force[0] = 0.0;
	printf("collision, %.0f N against the motion at 1.5 m/s: COLLISION after %.0f ms, SLIP "
	       "after %.0f ms (-1: never)\n",
	       force_n, coll_ms, slip_ms);
}

/* 12 V on wheel 0 alone (with [sim] traction_mu > 0 it crosses the traction limit). */
static void slip(struct bench *b, int64_t *seq)
{
	drive_for(b, 2.0, (const double[3]){0, 0, 0}, seq);
	unsigned char buf[256];
	omni4_command_t c = {.utime = simrun_now_us(b->sr),
	                     .seq = (*seq)++,
	                     .mode = OMNI4_COMMAND_T_MODE_VOLTAGE,
	                     .voltage = {12, 0, 0, 0}};
	const int n = omni4_command_t_encode(buf, 0, sizeof(buf), &c);

	simrun_command(b->sr, buf, (size_t)n);
	double slip_truth_ms = -1.0, slip_est_ms = -1.0;

	for (long k = 0; k < (long)(0.2 / b->period_s); k++) {
		simrun_tick(b->sr);
		if (slip_truth_ms < 0 && (b->truth_flags & 0x0f))
			slip_truth_ms = (double)(k + 1) * b->period_s * 1e3;
		if (slip_est_ms < 0 && (b->est_flags & EST_FLAG_SLIP))
			slip_est_ms = (double)(k + 1) * b->period_s * 1e3;
	}
	printf(
	    "12 V on wheel 0 alone, 200 ms: a wheel beyond its traction limit after %.0f ms, SLIP "
	    "after %.0f ms (-1: never)\n",
	    slip_truth_ms, slip_est_ms);
}

/* After the path: camera dropouts, collisions (the body pushed back), a slip. */
static void episodes(struct bench *b, int64_t *seq)
{
	enum { GAPS = 5 };

	b->in_episode = true;
	for (int k = 1; k <= 3; k++) {
		struct gap g = {0};

		for (int i = 0; i < GAPS; i++)
			dropout(b, 0.5 * k, seq, &g);
		printf(
		    "camera dropped 2 s at %.1f m/s (%d gaps): position error at the end of the "
		    "gap mean %.1f max %.1f mm (ideal dead reckoning: mean %.1f max %.1f mm); "
		    "within 3x its RMS before the gap at most %.0f ms after the first frame back; "
		    "RMS over 0.5-1 s after it at most %.2f x the RMS before\n",
		    0.5 * k, GAPS, 1e3 * g.end_sum / GAPS, 1e3 * g.end_m, 1e3 * g.ideal_sum / GAPS,
		    1e3 * g.ideal_m, g.within_ms, g.ratio);
	}
	printf("camera frames refused by the gate so far: %u\n",
	       (unsigned)simrun_estimate(b->sr)->cam_gated);
	collision(b, 20.0, seq);
	collision(b, 40.0, seq);
	slip(b, seq);
}

static void report(const char *name, const struct score *s, const struct score *est)
{
	const double pos = sqrt(s->se_pos / (double)s->n), th = sqrt(s->se_th / (double)s->n);
	const double epos = sqrt(est->se_pos / (double)est->n),
	             eth = sqrt(est->se_th / (double)est->n);

	printf("%-34s position RMS %8.2f mm  heading RMS %6.3f deg  (estimate/this: %.3f, %.3f)\n",
	       name, 1e3 * pos, th * 180.0 / PI, epos / pos, eth / th);
}

/* The command line; 0, or 2 after the usage line. */
static int parse_args(int argc, char **argv, const char **ini, const char **csv, double *path_s)
{
	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "--ini") && i + 1 < argc)
			*ini = argv[++i];
		else if (!strcmp(argv[i], "--path-s") && i + 1 < argc)
			*path_s = atof(argv[++i]);
		else if (!strcmp(argv[i], "--csv") && i + 1 < argc)
			*csv = argv[++i];
		else {
			fprintf(stderr,
			        "usage: est_bench [--ini ROBOT.ini] [--path-s S] [--csv FILE]\n");
			return 2;
		}
	}
	return 0;
}

/* The simulated robot, the truth record for the run's run_s (*ticks_run ticks) and the
 * episodes after it, the estimator that takes frames at arrival; 0, or 1 with the reason on
 * stderr. */
static int bench_start(struct bench *b, const struct omni4_config *cfg, double run_s,
                       long *ticks_run)
{
	struct est_settings es;
	char why[256];

	b->sr = simrun_create(cfg, &cfg->ctl.model, true, NULL, why, sizeof(why));
	if (!b->sr) {
		fprintf(stderr, "est_bench: %s\n", why);
		return 1;
	}
	b->d = cfg->ctl.model.d;
	b->r = cfg->ctl.model.r;
	b->period_s = simrun_period_s(b->sr);
	b->utime0 = simrun_now_us(b->sr);
	*ticks_run = (long)(run_s / b->period_s) + 1;
	b->ticks_max =
	    *ticks_run + (long)(120.0 / b->period_s); /* and the episodes after the path */
	for (int j = 0; j < 4; j++)
		b->radius_error[j] = cfg->sim.wheel_radius_error[j];
	b->truth = calloc((size_t)b->ticks_max, sizeof(*b->truth));
	est_settings_defaults(&es);
	es.replay = false;
	if (!b->truth || est_init(&b->late, &es, &cfg->ctl.model, cfg->ctl.rate_hz)) {
		fprintf(stderr, "est_bench: cannot start\n");
		return 1;
	}
	return 0;
}

static void print_summary(const struct bench *b, double steps_s, double path_s, long ticks_run)
{
	printf("est_bench: %.0f s (validation steps %.0f s, path %.0f s at 1-2 m/s with turns), "
	       "%ld ticks\n",
	       steps_s + path_s, steps_s, path_s, ticks_run);
	report("estimate (camera replayed)", &b->est, &b->est);
	report("estimate, frames at arrival", &b->late_score, &b->est);
	report("raw camera (at capture time)", &b->cam, &b->est);
	report("wheel odometry alone", &b->odo_score, &b->est);
	printf("normal driving: %ld SLIP and %ld COLLISION flag onsets in %.0f s; null-space "
	       "residual RMS %.4f max %.4f m/s, velocity innovation (averaged) RMS %.4f max %.4f "
	       "m/s\n",
	       b->false_slip, b->false_collision, steps_s + path_s, sqrt(b->null_ss / b->n_flags),
	       b->null_max, sqrt(b->innov_ss / b->n_flags), b->innov_max);
	const struct est_output *o = simrun_estimate(b->sr);
	const double *re = b->radius_error;
	const double mean = 0.25 * (re[0] + re[1] + re[2] + re[3]);

	printf("wheel scale errors learnt [%%]: %+.2f %+.2f %+.2f %+.2f; the plant's less their "
	       "mean: %+.2f %+.2f %+.2f %+.2f\n",
	       100 * o->wheel_scale[0], 100 * o->wheel_scale[1], 100 * o->wheel_scale[2],
	       100 * o->wheel_scale[3], 100 * (re[0] - mean), 100 * (re[1] - mean),
	       100 * (re[2] - mean), 100 * (re[3] - mean));
}

int main(int argc, char **argv)
{
	const char *ini = NULL, *csv = NULL;
	double path_s = 60.0, steps_s = 20.0;
	struct omni4_config cfg;
	struct config_error err;

	if (parse_args(argc, argv, &ini, &csv, &path_s))
		return 2;
	config_defaults(&cfg);
	if (ini && config_load(ini, &cfg, &err)) {
		fprintf(stderr, "est_bench: %s\n", err.msg);
		return 2;
	}
	static struct bench b;
	long ticks_run;

	if (bench_start(&b, &cfg, steps_s + path_s, &ticks_run))
		return 1;
	b.csv = csv ? fopen(csv, "w") : NULL;
	if (b.csv)
		fprintf(b.csv, "t_s,true_x,true_y,est_x,est_y,odo_x,odo_y,late_x,late_y\n");
	simrun_set_tap(b.sr, tap, &b);
	int64_t seq = 0;

	for (long k = 0; k < ticks_run; k++) {
		const double t = (double)k * b.period_s;
		double x[3];

		if (k % 20 == 0) {
			drive_at(t, steps_s, x);
			command(&b, x[0], x[1], x[2], &seq);
		}
		simrun_tick(b.sr);
	}
	print_summary(&b, steps_s, path_s, ticks_run);
	episodes(&b, &seq);
	if (b.csv)
		fclose(b.csv);
	simrun_destroy(b.sr);
	free(b.truth);
	return 0;
}
