/* fw.c - the loop body: commands -> HAL read -> controller -> HAL write -> log ring. */
#include "omni4/core/fw.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "omni4/model/consts.h"

int fw_init(struct fw *fw, const struct ctl_settings *cfg, struct motor_hal motor,
            struct line_hal lines)
{
	memset(fw, 0, sizeof(*fw));
	if (ctl_init(&fw->ctl, cfg))
		return -EINVAL;
	fw->motor = motor;
	fw->lines = lines;
	fw->late_us = llround(2e6 / cfg->rate_hz); /* [loop] rate_hz: restart only */
	fw->state_every = (int)ceil(cfg->rate_hz / FW_STATE_HZ - 1e-9);
	fw->adapt_every = (int)ceil(cfg->rate_hz / FW_ADAPT_HZ - 1e-9);
	fw->robot_every = (int)ceil(cfg->rate_hz / FW_ROBOT_HZ - 1e-9);
	adapt_init(&fw->adapt, cfg);
	struct est_settings es;
	struct model_wheels w;
	struct wheel_geom g;

	est_settings_from_keys(&cfg->est, &es);
	if (est_init(&fw->est, &es, &cfg->model, cfg->rate_hz))
		return -EINVAL;
	ctl_settings_wheels(cfg, &w);
	est_set_model_wheels(&fw->est, &cfg->model, &w, ctl_settings_geom(cfg, &g) ? NULL : &g);
	spsc_init(&fw->pose_ring, fw->pose_buf, FW_POSE_RING_SLOTS, sizeof(fw->pose_buf[0]));
	spsc_init(&fw->cmd_ring, fw->cmd_buf, FW_CMD_RING_SLOTS, sizeof(fw->cmd_buf[0]));
	spsc_init(&fw->goal_ring, fw->goal_buf, FW_GOAL_RING_SLOTS, sizeof(fw->goal_buf[0]));
	atomic_init(&fw->n.goal_dropped, 0);
	goal_init(&fw->goal, cfg);
	spsc_init(&fw->log_ring, fw->log_buf, FW_LOG_RING_SLOTS, sizeof(fw->log_buf[0]));
	atomic_init(&fw->halted, false);
	atomic_init(&fw->param_pending, NULL);
	atomic_init(&fw->param_done_gen, 0);
	atomic_init(&fw->n.pose_dropped, 0);
	fw_outputs_off(fw);
	return 0;
}

void fw_set_param_hooks(struct fw *fw, const struct fw_param_hooks *hooks)
{
	fw->param_hooks = *hooks;
}

int fw_param_prepare(struct fw *fw, const struct ctl_settings *cfg, bool idle_only,
                     struct fw_param_update *u, char *why, size_t n)
{
	struct ctl
	    scratch; /* precomputed exactly as at start-up, on the model checked at the door */

	if (ctl_init_checked(&scratch, cfg) || scratch.period_us != fw->ctl.period_us) {
		static const char msg[] = "the controller refuses these values";

		if (n) {
			const size_t k = n < sizeof(msg) ? n - 1 : sizeof(msg) - 1;

			memcpy(why, msg, k);
			why[k] = '\0';
		}
		return -EINVAL;
	}
	if (fw->param_hooks.check && fw->param_hooks.check(fw->param_hooks.ctx, cfg, why, n))
		return -EINVAL;
	u->set = *cfg;
	u->ff = scratch.ff;
	u->ff_ohm = scratch.ff_ohm;
	u->lay = scratch.lay;
	adapt_init(&u->adapt, cfg);
	u->idle_only = idle_only;
	return 0;
}

void fw_param_offer(struct fw *fw, struct fw_param_update *u)
{
	u->gen = ++fw->param_gen;
	atomic_store_explicit(&fw->param_pending, u, memory_order_release);
}

bool fw_param_done(struct fw *fw, const struct fw_param_update *u, struct fw_param_result *r)
{
	if (atomic_load_explicit(&fw->param_done_gen, memory_order_acquire) != u->gen)
		return false;
	*r = fw->param_done;
	return true;
}

bool fw_param_withdraw(struct fw *fw, struct fw_param_update *u)
{
	struct fw_param_update *expect = u;

	return atomic_compare_exchange_strong(&fw->param_pending, &expect, NULL);
}

/* The goal's planner under the settings' limits with the motor resistances and the friction in
 * use ([adapt]: the identified ones until an estimate is accepted); between two ticks, after a
 * parameter change (a goal in force is planned again beside the loop, goal_init_limits), and
 * after an acceptance or revert once no goal is active (a goal's plan is not asked again for
 * each small step of an estimate: the next goal's plan has them). */
static void goal_follow(struct fw *fw, const struct ctl_settings *cfg)
{
	const struct adapt *a = &fw->adapt;
	struct traj_limits lim;
	double *B[3], *C[3];

	goal_limits(cfg, &lim);
	B[0] = &lim.p.Bv, B[1] = &lim.p.Bvn, B[2] = &lim.p.Bw;
	C[0] = &lim.p.Cv, C[1] = &lim.p.Cvn, C[2] = &lim.p.Cw;
	/* a value in use other than the identified one (those stay the settings' doubles) */
	for (int j = 0; j < 4; j++)
		if (adapt_r_in_use(a)[j] != a->R_id[j])
			lim.w.R[j] = adapt_r_in_use(a)[j];
	for (int k = 0; k < 3; k++) {
		if (adapt_b_in_use(a)[k] != a->B_id[k])
			*B[k] = adapt_b_in_use(a)[k];
		if (adapt_c_in_use(a)[k] != a->C_id[k])
			*C[k] = adapt_c_in_use(a)[k];
	}
	goal_init_limits(&fw->goal, cfg, &lim);
	fw->goal_stale = false;
}

/* Loop thread, before a tick: take a pending parameter update whole, or refuse it whole. */
static void take_params(struct fw *fw, int64_t now_us)
{
	struct fw_param_update *u =
	    atomic_exchange_explicit(&fw->param_pending, NULL, memory_order_acq_rel);

	if (!u)
		return;
	const bool driving = mode_drives(fw->ctl.mode);
	int rc = 0;

	if (u->idle_only && driving) {
		rc = -EBUSY;
	} else {
		ctl_retune(&fw->ctl, &u->set, &u->ff, &u->ff_ohm, &u->lay);
		struct model_wheels w;
		struct wheel_geom g;
		struct est_settings es;

		ctl_settings_wheels(&u->set, &w);
		est_set_model_wheels(&fw->est, &u->set.model, &w,
		                     ctl_settings_geom(&u->set, &g) ? NULL : &g);
		est_settings_from_keys(&u->set.est, &es);
		est_set_settings(&fw->est, &es);
		const uint32_t adapted = adapt_retune(&fw->adapt, &u->adapt);

		goal_follow(fw, &u->set);

		for (int j = 0; j < 4; j++)
			if (adapted & (1u << j))
				ctl_set_resistance(&fw->ctl, j, adapt_r_in_use(&fw->adapt)[j]);
		if (adapted & ADAPT_CHANGED_FRICTION)
			ctl_set_friction(&fw->ctl, adapt_b_in_use(&fw->adapt),
			                 adapt_c_in_use(&fw->adapt));
		if (fw->param_hooks.apply)
			fw->param_hooks.apply(fw->param_hooks.ctx, &u->set);
	}
	fw->param_done = (struct fw_param_result){
	    .rc = rc, .mode = (int)fw->ctl.mode, .seq = fw->seq, .utime = now_us};
	atomic_store_explicit(&fw->param_done_gen, u->gen, memory_order_release);
}

void fw_outputs_off(struct fw *fw)
{
	static const float zero[4] = {0, 0, 0, 0};

	/* Disable first: the zero-voltage command that follows then also says "disabled". */
	hal_motor_enable(&fw->motor, false);
	hal_motor_write(&fw->motor, zero);
	hal_line_set_enable(&fw->lines, false);
	fw->hw_enabled = false;
}

void fw_emergency_off(struct fw *fw)
{
	atomic_store(&fw->halted, true);
	hal_motor_halt(&fw->motor); /* a backend that has one: its off command is the last */
	fw_outputs_off(fw);
}

bool fw_post_command(struct fw *fw, const struct ctl_command *cmd)
{
	if (spsc_push(&fw->cmd_ring, cmd))
		return true;
	atomic_fetch_add(&fw->n.cmd_dropped, 1);
	return false;
}

bool fw_post_goal(struct fw *fw, const struct goal_cmd *goal)
{
	if (spsc_push(&fw->goal_ring, goal))
		return true;
	atomic_fetch_add(&fw->n.goal_dropped, 1);
	return false;
}

static void log_push(struct fw *fw, const struct log_entry *e)
{
	if (!spsc_push(&fw->log_ring, e)) {
		fw->n.log_dropped++;
		ctl_flag(&fw->ctl, CTL_FAULT_LOG_OVERFLOW);
	}
}

/* A camera pose the motor backend handed in at this tick's read: to the log (pose_t) and, after
 * this tick's estimator step, to the estimator at its capture time. */
static void take_pose(struct fw *fw, const struct hal_pose *p)
{
	struct log_entry e = {.utime = p->utime, .kind = LOG_POSE};

	memcpy(e.camera.pose, p->pose, sizeof(e.camera.pose));
	log_push(fw, &e);
	if (fw->n_tick_poses < FW_POSES_PER_TICK) {
		struct fw_pose *q = &fw->tick_poses[fw->n_tick_poses++];

		q->utime = p->utime;
		memcpy(q->pose, p->pose, sizeof(q->pose));
	} else
		atomic_fetch_add(&fw->n.pose_dropped, 1); /* more than a tick can take: counted */
}

/* A simulated plant's true state after this tick's read: a LOG_TRUTH entry. */
static void take_truth(struct fw *fw, const struct hal_truth *t)
{
	struct log_entry e = {.utime = t->utime, .seq = fw->seq, .kind = LOG_TRUTH};

	e.truth.flags = t->flags;
	memcpy(e.truth.pose, t->pose, sizeof(e.truth.pose));
	for (int k = 0; k < 3; k++)
		e.truth.vel[k] = (float)t->vel[k];
	for (int j = 0; j < 4; j++)
		e.truth.wheel_slip[j] = (float)t->wheel_slip[j];
	log_push(fw, &e);
}

/* Fast loop, right after the motor read: what the backend measured besides the motors (its
 * plant's truth, the camera poses that fell due), polled through the HAL's optional ops. At
 * most FW_POSE_POLLS_PER_TICK poses: a backend that never says -EAGAIN cannot hold the loop. */
static void take_backend_sensors(struct fw *fw)
{
	struct hal_truth t;
	struct hal_pose p;

	if (hal_motor_read_truth(&fw->motor, &t) == 0)
		take_truth(fw, &t);
	for (int k = 0; k < FW_POSE_POLLS_PER_TICK && hal_motor_read_pose(&fw->motor, &p) == 0; k++)
		take_pose(fw, &p);
}

bool fw_post_pose(struct fw *fw, int64_t utime, const double pose[3])
{
	struct fw_pose p = {.utime = utime};

	memcpy(p.pose, pose, sizeof(p.pose));
	if (spsc_push(&fw->pose_ring, &p))
		return true;
	atomic_fetch_add(&fw->n.pose_dropped, 1);
	return false;
}

/* The estimator's tick: the voltages applied since the last tick (bridges as they were), this
 * tick's reading, then the camera poses that came in (each at its capture time). Its state goes
 * to the log every state_every ticks and whenever its flags change. */
static void estimate(struct fw *fw, struct est_input *in)
{
	const int64_t now_us = in->utime;
	struct fw_pose p;

	if (fw->no_estimate) { /* the poses are dropped unseen, as they arrive */
		fw->n_tick_poses = 0;
		while (spsc_pop(&fw->pose_ring, &p))
			;
		return;
	}
	est_step(&fw->est, in);
	for (int i = 0; i < fw->n_tick_poses; i++)
		est_camera(&fw->est, fw->tick_poses[i].utime, fw->tick_poses[i].pose, now_us);
	fw->n_tick_poses = 0;
	while (spsc_pop(&fw->pose_ring, &p))
		est_camera(&fw->est, p.utime, p.pose, now_us);

	const struct est_output *o = est_get(&fw->est);

	if (fw->seq % fw->state_every == 0 || o->flags != fw->state_flags) {
		struct log_entry e = {.utime = now_us, .seq = fw->seq, .kind = LOG_STATE};

		e.state = *o;
		fw->state_flags = o->flags;
		log_push(fw, &e);
	}
}

/* The wheels' layout in force as a log entry (LOG_ROBOT): the first tick, then at FW_ROBOT_HZ. */
static void push_robot(struct fw *fw, int64_t now_us)
{
	const struct ctl_settings *s = &fw->ctl.set;
	struct log_entry e = {.utime = now_us, .seq = fw->seq, .kind = LOG_ROBOT};

	e.robot.wheels = s->layout.wheels;
	e.robot.l = s->model.l;
	for (int j = 0; j < s->layout.wheels && j < 4; j++) {
		e.robot.angle_rad[j] = s->layout.angle_deg[j] * (MODEL_PI / 180.0);
		e.robot.dist_m[j] = ctl_settings_wheel_distance(s, j);
		e.robot.radius_m[j] = s->wheels.r[j];
	}
	log_push(fw, &e);
}

/* The adapted constants as a log entry (LOG_ADAPT, or LOG_ADAPT_CHANGE with R_before). */
static void push_adapt(struct fw *fw, int64_t now_us, uint8_t kind, const float R_before[4])
{
	struct log_entry e = {.utime = now_us, .seq = fw->seq, .kind = kind};
	struct adapt_report r;
	const uint32_t rep_n = fw->adapt.rep_n;

	adapt_report(&fw->adapt, &r);
	memcpy(e.adapt.R, r.R, sizeof(e.adapt.R));
	memcpy(e.adapt.R_est, r.R_est, sizeof(e.adapt.R_est));
	memcpy(e.adapt.R_var, r.var, sizeof(e.adapt.R_var));
	memcpy(e.adapt.R_before, R_before ? R_before : r.R, sizeof(e.adapt.R_before));
	e.adapt.supply_v = r.supply_v;
	e.adapt.track_rms = r.track_rms;
	memcpy(e.adapt.C, r.C, sizeof(e.adapt.C));
	e.adapt.flags = r.flags;
	if (kind == LOG_ADAPT_CHANGE) { /* what is since the last LOG_ADAPT stays for the next */
		fw->adapt.flags =
		    r.flags & ~(ADAPT_FLAG_ON | ADAPT_FLAG_WATCH | ADAPT_FLAG_ADAPTED);
		fw->adapt.rep_e2 = r.track_rms * r.track_rms * 4.0f * (float)rep_n;
		fw->adapt.rep_n = rep_n;
	}
	log_push(fw, &e);
}

/* The resistances' and the friction's estimation on this tick's reading (after the estimator, whose
 * flags it reads); an acceptance or revert goes into the feedforward at once and to the log. */
static void adapt(struct fw *fw, int64_t now_us, const struct est_input *in, const float cur[4],
                  float supply_v)
{
	const struct ctl *c = &fw->ctl;
	struct adapt_input a = {
	    .reading = in->have_wheels,
	    .driven = in->driven,
	    .mode = (int8_t)c->mode,
	    .faulted = c->latched != 0,
	    .est_flags = fw->no_estimate ? 0u : est_get(&fw->est)->flags,
	    .supply_v = supply_v,
	    .tracking = c->tracked,
	    .track_e2 = c->track_e2,
	};
	float before[4];

	memcpy(a.volts, in->volts, sizeof(a.volts));
	memcpy(a.current_a, cur, sizeof(a.current_a));
	memcpy(a.wheel_rad_s, in->wheel_rad_s, sizeof(a.wheel_rad_s));
	memcpy(before, adapt_r_in_use(&fw->adapt), sizeof(before));
	const uint32_t changed = adapt_step(&fw->adapt, &a);

	for (int j = 0; j < 4; j++)
		if (changed & (1u << j))
			ctl_set_resistance(&fw->ctl, j, adapt_r_in_use(&fw->adapt)[j]);
	if (changed & ADAPT_CHANGED_FRICTION)
		ctl_set_friction(&fw->ctl, adapt_b_in_use(&fw->adapt), adapt_c_in_use(&fw->adapt));
	fw->goal_stale = fw->goal_stale || changed;
	if (fw->goal_stale && fw->goal.rep.status != GOAL_ACTIVE)
		goal_follow(fw, &fw->ctl.set);
	if (changed)
		push_adapt(fw, now_us, LOG_ADAPT_CHANGE, before);
	if (fw->seq % fw->adapt_every == 0)
		push_adapt(fw, now_us, LOG_ADAPT, NULL);
}

bool fw_pop_log(struct fw *fw, struct log_entry *e)
{
	return spsc_pop(&fw->log_ring, e);
}

/* The set of current-sense offsets that came into force in this tick (ctl.h), announced
 * ahead of the tick's sample. */
static void push_calibration(struct fw *fw, int64_t now_us)
{
	const struct ctl_cal *cal = &fw->ctl.cal;
	struct log_entry e = {.utime = now_us, .seq = fw->seq, .kind = LOG_CALIBRATION};

	e.cal.prev_over_limit = cal->gen == 1 ? -1 : (int32_t)cal->prev_fault_mask;
	e.cal.samples = (uint16_t)cal->cfg.samples;
	e.cal.over_limit = cal->fault_mask;
	memcpy(e.cal.offset, cal->offset, sizeof(e.cal.offset));
	memcpy(e.cal.prev_offset, cal->prev, sizeof(e.cal.prev_offset));
	fw->cal_gen = cal->gen;
	log_push(fw, &e);
}

/* Commands waiting in the mailbox, in order; a clear that leaves FAULT also clears the drivers'
 * latched faults. */
static void take_commands(struct fw *fw, int64_t now_us)
{
	struct ctl_command cmd;

	while (spsc_pop(&fw->cmd_ring, &cmd)) {
		const bool was_fault = mode_faulted(fw->ctl.mode);

		if (ctl_command(&fw->ctl, &cmd, now_us) == 0 && cmd.mode == CTL_CLEAR_FAULT &&
		    was_fault)
			hal_motor_clear_faults(&fw->motor);
	}
}

static void push_goal(struct fw *fw, int64_t now_us, const struct goal_report *r)
{
	struct log_entry e = {.utime = now_us, .seq = fw->seq, .kind = LOG_GOAL};

	e.goal = *r;
	log_push(fw, &e);
}

/* Goals waiting in the mailbox, in order (each refusal reported), then the goal's tick (a plan
 * made beside the loop handed over or refused; the reference for this tick's controller
 * step). The estimate is the last tick's. */
static void run_goal(struct fw *fw, int64_t now_us)
{
	const struct est_output *est = fw->no_estimate ? NULL : est_get(&fw->est);
	const struct goal_report *r;
	struct goal_cmd g;
	bool changed;

	while (spsc_pop(&fw->goal_ring, &g)) {
		goal_command(&fw->goal, &fw->ctl, &g, est, now_us);
		r = goal_take_refused(&fw->goal);
		if (r)
			push_goal(fw, now_us, r);
	}
	goal_step(&fw->goal, &fw->ctl, est, now_us);
	r = goal_take_refused(&fw->goal); /* a plan made beside the loop: none, or FAULT */
	if (r)
		push_goal(fw, now_us, r);
	r = goal_report(&fw->goal, &changed);
	if (changed || (r->status == GOAL_ACTIVE && fw->seq % fw->state_every == 0))
		push_goal(fw, now_us, r);
}

/* The controller's output to the HAL (nothing but 0 V, bridges off, once halted). */
static void drive(struct fw *fw, struct ctl_output *out)
{
	if (atomic_load_explicit(&fw->halted, memory_order_relaxed)) {
		out->enable = false;
		memset(out->volts, 0, sizeof(out->volts));
	}
	if (out->enable != fw->hw_enabled) {
		hal_motor_enable(&fw->motor, out->enable);
		hal_line_set_enable(&fw->lines, out->enable);
		fw->hw_enabled = out->enable;
	}
	if (hal_motor_write(&fw->motor, out->volts) < 0)
		fw->n.write_errors++;
	hal_line_set_led(&fw->lines, mode_faulted(out->mode));
	fw->last_out = *out;
}

/* This tick's motors_t sample. A tick that starts a whole period or more late (the loop was
 * starved; it re-aligns) is flagged in its own sample only, so a log shows which were late. */
static void push_sample(struct fw *fw, int64_t now_us, const struct ctl_output *out)
{
	struct log_entry e = {.utime = now_us, .seq = fw->seq, .kind = LOG_MOTORS};

	e.sample.mode = out->mode;
	e.sample.faults = out->faults;
	if (fw->n.ticks && now_us - fw->last_tick_us >= fw->late_us) {
		e.sample.faults |= CTL_FAULT_OVERRUN;
		fw->n.overruns++;
	}
	fw->last_tick_us = now_us;
	memcpy(e.sample.voltage, out->volts, sizeof(e.sample.voltage));
	memcpy(e.sample.current, out->current, sizeof(e.sample.current));
	memcpy(e.sample.wheel_speed, fw->last_sample.wheel_rad_s, sizeof(e.sample.wheel_speed));
	log_push(fw, &e);
}

/* The backend's reading, the slots of no motor (slot 3 of a three-wheel robot) read as 0:
 * whatever an unconnected channel reports (noise, an offset, NaN) never reaches the
 * calibration, the controller, the estimator or the motors_t sample. */
static int read_motors(struct fw *fw, struct motor_sample *s)
{
	const int rc = hal_motor_read(&fw->motor, s);

	for (int j = fw->ctl.lay.wheels; j < 4 && rc == 0; j++) {
		s->current_a[j] = 0.0f;
		s->wheel_rad_s[j] = 0.0f;
	}
	return rc;
}

void fw_tick(struct fw *fw, int64_t now_us)
{
	struct motor_sample s;
	struct ctl_output out;
	bool estop = false;

	take_params(fw, now_us); /* between ticks: the whole tick below runs on one set */
	take_commands(fw, now_us);
	run_goal(fw, now_us);
	if (hal_line_read_estop(&fw->lines, &estop) < 0)
		estop = true; /* an unreadable e-stop line is a pressed e-stop */

	const int rc = read_motors(fw, &s);

	take_backend_sensors(fw);
	if (rc == 0)
		fw->last_sample = s;
	else if (rc != -EAGAIN)
		fw->n.read_errors++;
	ctl_step(&fw->ctl, now_us, &fw->last_sample, rc, estop, &out);

	/* What drove the robot up to this reading, for the estimator (it runs after the outputs
	 * are out, so its cost never delays them). */
	struct est_input in = {.utime = now_us, .driven = fw->hw_enabled, .have_wheels = rc == 0};

	memcpy(in.volts, fw->last_out.volts, sizeof(in.volts));
	memcpy(in.wheel_rad_s, fw->last_sample.wheel_rad_s, sizeof(in.wheel_rad_s));
	drive(fw, &out);
	if (fw->ctl.cal.gen != fw->cal_gen) /* new offsets, subtracted from this tick on */
		push_calibration(fw, now_us);
	estimate(fw, &in);
	adapt(fw, now_us, &in, out.current, rc == 0 ? s.supply_v : 0.0f);
	ctl_set_slip(&fw->ctl, !fw->no_estimate && (est_get(&fw->est)->flags & EST_FLAG_SLIP));
	if (fw->seq % fw->robot_every == 0)
		push_robot(fw, now_us);
	push_sample(fw, now_us, &out);
	fw->seq++;
	fw->n.ticks++;
}

bool fw_background(struct fw *fw)
{
	return goal_work(&fw->goal);
}
