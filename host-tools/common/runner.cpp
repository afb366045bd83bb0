// runner.cpp - experiment runner over LCM: the paper's sequence, or experiment 2 by hand.
#include "runner.hpp"
#include "omni4/lcmtypes/channels.h"
#include "omni4/lcmtypes/eventlog.h"
#include "omni4/config/outfile.h"

#include <lcm/eventlog.h>
#include <lcm/lcm.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <deque>
#include <functional>
#include <initializer_list>
#include <memory>
#include <stdexcept>
#include <string>

#include "experiments.hpp"
#include "hand.hpp"
#include "regression.hpp"
#include "traction_exp.hpp"
#include "omni4/command_t.hpp"
#include "omni4/experiment_t.hpp"
#include "omni4/motors_t.hpp"
#include "omni4/robot_t.hpp"
#include "omni4/state_t.hpp"

extern "C" {
}

namespace omni4
{

namespace
{

volatile std::sig_atomic_t g_interrupted = 0;

void on_signal(int)
{
	g_interrupted = 1;
}

int64_t wall_us()
{
	return std::chrono::duration_cast<std::chrono::microseconds>(
	           std::chrono::system_clock::now().time_since_epoch())
	    .count();
}

double steady_s()
{
	return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
	    .count();
}

// A live LCM session: every message on the bus goes to the event log, stamped with its receive
// time; an optional tap sees each one as well.
class Recording
{
      public:
	using Tap = std::function<void(const char *channel, const lcm_recv_buf_t *rbuf)>;

	~Recording()
	{
		close();
	}

	// Opens the bus and the log, installs the SIGINT/SIGTERM handlers. Prints a one-line error
	// and returns false on failure.
	bool open(const RunOptions &opt, Tap tap = nullptr);

	void publish(const char *channel, const std::vector<uint8_t> &msg)
	{
		lcm_publish(lcm_, channel, msg.data(), static_cast<unsigned>(msg.size()));
	}

	void handle(int timeout_ms)
	{
		lcm_handle_timeout(lcm_, timeout_ms);
	}

	// Safe stop: the IDLE command (outputs off), the "end" of an open segment (if given), the
	// last messages collected for 300 ms, the log closed. Returns false on log write errors.
	bool finish(const std::vector<uint8_t> &idle, const std::vector<uint8_t> *end_mark);

	uint64_t written() const
	{
		return written_;
	}

	// After finish(): removes the log if this run created it as a new file (no robot answered,
	// nothing worth keeping); a FIFO, a device or a file that was there stays.
	void discard();

      private:
	static void record(const lcm_recv_buf_t *rbuf, const char *channel, void *user);

	void close();

	lcm_t *lcm_ = nullptr;
	lcm_eventlog_t *log_ = nullptr; // &ev_ while the log is open
	lcm_eventlog_t ev_{};           // liblcm's writer over out_.f
	struct omni4_out out_{};
	bool created_ = false;
	lcm_subscription_t *sub_ = nullptr;
	uint64_t written_ = 0, errors_ = 0;
	Tap tap_;
};

bool Recording::open(const RunOptions &opt, Tap tap)
{
	tap_ = std::move(tap);
	lcm_ = lcm_create(opt.url.c_str());
	if (!lcm_) {
		std::fprintf(stderr, "omni4-ident run: cannot open LCM at '%s'\n", opt.url.c_str());
		return false;
	}
	// As omni4-record: a new file written where it is (a crash keeps what was
	// recorded), a FIFO or device in place, an existing file refused (a recorded run is
	// never lost).
	char why[PATH_MAX + 200];
	if (omni4_out_open(&out_, opt.out.c_str(), 0666, OMNI4_OUT_STREAM, why, sizeof(why))) {
		std::fprintf(stderr, "omni4-ident run: %s\n", why);
		return false;
	}
	ev_ = lcm_eventlog_t{};
	ev_.f = out_.f;
	log_ = &ev_;
	created_ = !out_.existed; // a new file (an existing file is refused above)
	sub_ = lcm_subscribe(lcm_, ".*", record, this);
	lcm_subscription_set_queue_capacity(sub_, 100000);
	std::signal(SIGINT, on_signal);
	std::signal(SIGTERM, on_signal);
	return true;
}

bool Recording::finish(const std::vector<uint8_t> &idle, const std::vector<uint8_t> *end_mark)
{
	publish(OMNI4_CHANNEL_CMD, idle);
	if (end_mark)
		publish(OMNI4_CHANNEL_EXPERIMENT, *end_mark);
	const double until = steady_s() + 0.3;
	while (steady_s() < until)
		handle(20);
	close();
	return errors_ == 0;
}

void Recording::discard()
{
	if (created_)
		std::remove(out_.target);
	created_ = false;
}

void Recording::record(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	auto *self = static_cast<Recording *>(user);
	if (omni4_eventlog_write(self->log_, channel, rbuf->recv_utime, rbuf->data,
	                         rbuf->data_size) == 0)
		++self->written_;
	else
		++self->errors_;
	if (self->tap_)
		self->tap_(channel, rbuf);
}

void Recording::close()
{
	if (sub_)
		lcm_unsubscribe(lcm_, sub_);
	sub_ = nullptr;
	if (log_) {
		char why[PATH_MAX + 200];
		if (omni4_out_commit(&out_, why, sizeof(why))) {
			std::fprintf(stderr, "omni4-ident run: %s\n", why);
			++errors_;
		}
	}
	log_ = nullptr;
	if (lcm_)
		lcm_destroy(lcm_);
	lcm_ = nullptr;
}

std::vector<Phase> filtered(const RunOptions &opt)
{
	std::vector<Phase> seq = selected_sequence(opt.only, opt.hold_s, opt.settle_s, opt.layout);
	limit_ramps(seq, opt.model, opt.traction_hold_n, opt.layout);
	return seq;
}

// Progress on stderr: on a terminal one status line rewritten in place, else only full lines.
class Progress
{
      public:
	Progress() : tty_(isatty(STDERR_FILENO))
	{
	}
	bool tty() const
	{
		return tty_;
	}

	void status(const std::string &text)
	{
		if (!tty_) {
			std::fprintf(stderr, "%s\n", text.c_str());
			return;
		}
		std::fprintf(stderr, "\r%-*s", static_cast<int>(shown_), text.c_str());
		shown_ = text.size();
	}

	// A permanent line (on a terminal: over the status line, which the next status redraws).
	void line(const char *fmt, ...) __attribute__((format(printf, 2, 3)))
	{
		char buf[512];
		va_list ap;
		va_start(ap, fmt);
		std::vsnprintf(buf, sizeof(buf), fmt, ap);
		va_end(ap);
		if (tty_)
			std::fprintf(stderr, "\r%-*s\n", static_cast<int>(shown_), buf);
		else
			std::fprintf(stderr, "%s\n", buf);
		shown_ = 0;
	}

	void end_status()
	{
		if (tty_ && shown_)
			std::fprintf(stderr, "\n");
		shown_ = 0;
	}

      private:
	bool tty_;
	size_t shown_ = 0;
};

// The phases of opt.only (all without it); false after a one-line error (unknown kind).
bool phases_to_run(const RunOptions &opt, std::vector<Phase> &phases)
{
	try {
		phases = filtered(opt);
	} catch (const std::exception &e) {
		std::fprintf(stderr, "omni4-ident run: %s\n", e.what());
		return false;
	}
	return true;
}

// Publishes what the sequence has due at t seconds after the start.
void play_due(SequencePlayer &player, Recording &rec, double t)
{
	const auto out = player.due(t, wall_us());
	for (const auto &m : out.marks)
		rec.publish(OMNI4_CHANNEL_EXPERIMENT, m);
	if (out.has_command)
		rec.publish(OMNI4_CHANNEL_CMD, out.command);
}

// The sequence's progress on stderr: on a terminal one line rewritten at every percent, else a
// line every 10 %.
class PercentLine
{
      public:
	explicit PercentLine(double total_s) : total_s_(total_s), tty_(isatty(STDERR_FILENO))
	{
	}

	void update(double t, const SequencePlayer &player, uint64_t logged)
	{
		const int pct = static_cast<int>(100 * t / total_s_);
		if (pct == last_pct_ || !(tty_ || pct % 10 == 0))
			return;
		std::fprintf(
		    stderr,
		    "%somni4-ident run: %3d%%  %6.1f / %.1f s  phase %zu/%zu  logged %llu%s",
		    tty_ ? "\r" : "", pct, t, total_s_,
		    std::min(player.phase_index() + 1, player.phase_count()), player.phase_count(),
		    static_cast<unsigned long long>(logged), tty_ ? "" : "\n");
		last_pct_ = pct;
	}

      private:
	double total_s_;
	bool tty_;
	int last_pct_ = -1;
};

} // namespace

// A robot answers on the bus when its OMNI4_MOTORS arrive: none within kFirstMotorsS of the
// start means no controller there (a slow start, e.g. under a sanitizer, is allowed for), none
// for kMotorsWaitS during a run means it stopped [s].
constexpr double kFirstMotorsS = 5.0;
constexpr double kMotorsWaitS = 2.0;
// The controller describes its wheels (OMNI4_ROBOT) at its first tick and at 1 Hz: a run waits
// this long after the first OMNI4_MOTORS for one [s] (a controller without it: --robot's).
constexpr double kRobotWaitS = 1.5;

namespace
{

// The estimator's flags of an OMNI4_STATE message (the traction experiment's watch).
// The first OMNI4_ROBOT's layout into *layout (seen set); a description no robot can have is
// left unseen (the run then keeps --robot's).
void take_robot(const char *channel, const lcm_recv_buf_t *rbuf, bool *seen, Layout *layout)
{
	robot_t r;
	if (*seen || std::strcmp(channel, OMNI4_CHANNEL_ROBOT) != 0 ||
	    r.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0)
		return;
	const double a[4] = {r.wheel_angle[0], r.wheel_angle[1], r.wheel_angle[2],
	                     r.wheel_angle[3]};
	const double d[4] = {r.wheel_distance[0], r.wheel_distance[1], r.wheel_distance[2],
	                     r.wheel_distance[3]};
	try {
		*layout = layout_of_description(r.wheels, a, d, "the controller's OMNI4_ROBOT");
		*seen = true;
	} catch (const IdentError &) {
	}
}

// The phases for the layout the controller runs (seen: its OMNI4_ROBOT), else for opt's. A
// --robot layout the controller does not run: one line, false.
bool phases_for_controller(const RunOptions &opt, bool seen, const Layout &ctl,
                           std::vector<Phase> &phases)
{
	if (!seen)
		return true;
	if (opt.layout.source != "paper" && !same_layout(ctl, opt.layout)) {
		std::fprintf(stderr,
		             "omni4-ident run: the controller runs %s; --robot gives %s: give the "
		             "robot file of the robot on this bus\n",
		             ctl.describe().c_str(), opt.layout.describe().c_str());
		return false;
	}
	RunOptions o = opt;
	o.layout = ctl;
	if (!phases_to_run(o, phases))
		return false;
	std::fprintf(stderr, "omni4-ident run: %s\n", ctl.describe().c_str());
	return true;
}

void take_state_flags(const char *channel, const lcm_recv_buf_t *rbuf, int32_t *flags)
{
	state_t st;
	if (std::strcmp(channel, OMNI4_CHANNEL_STATE) == 0 &&
	    st.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) > 0)
		*flags = st.flags;
}

// Safe stop: IDLE (outputs off), close any open segment, collect the last messages. Returns
// false on log write errors.
bool stop_run(Recording &rec)
{
	const auto end = encode_mark(wall_us(), OMNI4_MARK_END);
	return rec.finish(SequencePlayer::stop_command(wall_us(), 1 << 30), &end);
}

// Plays the phases in real time: what is due published, the bus handled, the traction
// experiment's watch told the estimator's flags. true: the robot stopped answering.
bool play_sequence(Recording &rec, const std::vector<Phase> &phases, const double &last_motors_s,
                   const int32_t &est_flags, const Layout &layout)
{
	SequencePlayer player(phases);
	TractionWatch watch(layout);
	PercentLine progress(total_duration_s(phases));
	const auto t0 = std::chrono::steady_clock::now();
	while (!player.done() && !g_interrupted) {
		const double t =
		    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
		play_due(player, rec, t);
		rec.handle(5);
		watch.step(player, est_flags); // a direction stops at its first slip
		progress.update(t, player, rec.written());
		if (steady_s() - last_motors_s > kMotorsWaitS)
			return true;
	}
	return false;
}

} // namespace

int run_experiments(const RunOptions &opt)
{
	std::vector<Phase> phases;
	if (!phases_to_run(opt, phases))
		return 2;
	Recording rec;
	uint64_t motors = 0;
	double last_motors_s = 0;
	int32_t est_flags = 0; // the last OMNI4_STATE's
	bool robot_seen = false;
	Layout ctl_layout;
	if (!rec.open(opt, [&](const char *channel, const lcm_recv_buf_t *rbuf) {
		    if (std::strcmp(channel, OMNI4_CHANNEL_MOTORS) == 0)
			    ++motors, last_motors_s = steady_s();
		    take_state_flags(channel, rbuf, &est_flags);
		    take_robot(channel, rbuf, &robot_seen, &ctl_layout);
	    }))
		return 1;
	// Nothing is driven before a controller answers: no robot, no run and no log.
	const double deadline = steady_s() + kFirstMotorsS;
	while (motors == 0 && !g_interrupted && steady_s() < deadline)
		rec.handle(20);
	if (motors == 0) {
		rec.finish(SequencePlayer::stop_command(wall_us(), 1 << 30), nullptr);
		rec.discard();
		if (g_interrupted)
			return 130;
		std::fprintf(stderr,
		             "omni4-ident run: no OMNI4_MOTORS on %s within %g s: is omni4-fw "
		             "running on that URL?\n",
		             opt.url.c_str(), kFirstMotorsS);
		return 1;
	}
	const double robot_deadline = steady_s() + kRobotWaitS;
	while (!robot_seen && !g_interrupted && steady_s() < robot_deadline)
		rec.handle(20);
	if (!phases_for_controller(opt, robot_seen, ctl_layout, phases)) {
		rec.finish(SequencePlayer::stop_command(wall_us(), 1 << 30), nullptr);
		rec.discard();
		return 2;
	}
	const bool lost = play_sequence(rec, phases, last_motors_s, est_flags,
	                                robot_seen ? ctl_layout : opt.layout);
	const bool ok = stop_run(rec);
	std::fprintf(stderr, "\nomni4-ident run: %s %s: %llu messages logged%s\n",
	             g_interrupted ? "interrupted, robot stopped;"
	             : lost        ? "aborted, the robot stopped answering;"
	                           : "done;",
	             opt.out.c_str(), static_cast<unsigned long long>(rec.written()),
	             ok ? "" : " (write errors!)");
	if (lost) {
		std::fprintf(stderr,
		             "omni4-ident run: no OMNI4_MOTORS for %g s on %s: did omni4-fw stop? "
		             "(the log holds the run up to then)\n",
		             kMotorsWaitS, opt.url.c_str());
		return 1;
	}
	return g_interrupted ? 130 : (ok ? 0 : 1);
}

// ---- experiment 2 by hand ---------------------------------------------------------------------

namespace
{

constexpr double kKeepaliveS = 0.05; // COAST re-sent this often [s]

using Event = HandDetector::Event;

const char *instruction(int axis)
{
	static const char *const say[3] = {
	    "push the robot forward along +v and let go",
	    "push the robot sideways along +vn (to its left) and let go",
	    "turn it counter-clockwise (+w) and let go"};
	return say[axis];
}

const char *unit(int axis)
{
	return axis == 2 ? "rad/s" : "m/s";
}

int axis_of(const std::string &dir)
{
	for (int a = 0; a < 3; ++a)
		if (dir == hand_axis_name(a))
			return a;
	throw std::invalid_argument("unknown direction '" + dir + "' (v, vn or w)");
}

class HandRun
{
      public:
	HandRun(const RunOptions &opt, const HandRunOptions &hand) : opt_(opt), hand_(hand)
	{
	}

	int run();

      private:
	enum class Why { Got, Timeout, Interrupted, MotorsLost };
	struct Waited {
		Why why;
		Event ev;
	};
	struct Sample {
		int64_t utime;
		std::array<double, 3> x;
	};

	void on_message(const char *channel, const lcm_recv_buf_t *rbuf);
	void keepalive();
	int64_t controller_us() const; // now, in the clock of motors_t [us]
	Waited wait_for(std::initializer_list<Event> want, double timeout_s);
	bool wait_first_motors();
	void show_status();
	void open_segment(int axis);
	void close_segment();
	// One push slot along axis: rest, mark and push, coast-down and stop. Returns false when
	// the run must stop (Ctrl-C, motors lost).
	enum class Step { Next, Again, Missed, Quit };
	bool one_push(int axis, int k);
	Step rest_step(int axis, int k);
	Step push_step(int axis, int k);
	Step stop_step(int axis, int k);
	void say(int axis, int k, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
	bool stopped_by(const Waited &w);
	void report(bool ok);

	RunOptions opt_;
	HandRunOptions hand_;
	Recording rec_;
	HandDetector det_;
	Progress progress_;
	std::deque<Sample> pending_;
	int64_t seq_ = 0;
	double last_cmd_s_ = -1e9, last_motors_s_ = -1e9, last_status_s_ = -1e9;
	int64_t clock_offset_us_ = 0; // motors_t utime - wall clock at receipt [us]
	uint64_t motors_ = 0;
	bool warned_driven_ = false, segment_open_ = false, motors_lost_ = false;
	bool robot_seen_ = false; // the controller's OMNI4_ROBOT arrived: ctl_layout_
	Layout ctl_layout_;
	int slots_done_ = 0, slots_total_ = 0, cur_axis_ = 0, cur_k_ = 0, last_pct_ = -1;
	int counted_[3] = {0, 0, 0}, wanted_[3] = {0, 0, 0}, wrong_ = 0, missed_ = 0;
};

void HandRun::on_message(const char *channel, const lcm_recv_buf_t *rbuf)
{
	take_robot(channel, rbuf, &robot_seen_, &ctl_layout_);
	if (std::strcmp(channel, OMNI4_CHANNEL_MOTORS) != 0)
		return;
	motors_t m;
	if (m.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0)
		return;
	++motors_;
	last_motors_s_ = steady_s();
	clock_offset_us_ = m.utime - rbuf->recv_utime;
	double v_wheel[4]; // wheel linear speeds [m/s]
	for (int j = 0; j < 4; ++j)
		v_wheel[j] = hand_.r_m * m.wheel_speed[j];
	Sample s{m.utime, {}};
	// eqs 3-5 of the wheels the controller describes, else --robot's
	(robot_seen_ ? ctl_layout_ : hand_.layout).body_velocity(hand_.d_m, v_wheel, s.x.data());
	pending_.push_back(s);
	if ((m.mode == motors_t::MODE_VOLTAGE || m.mode == motors_t::MODE_VELOCITY) &&
	    !warned_driven_) {
		progress_.line(
		    "omni4-ident run: warning: the controller reports driven bridges (mode %d): "
		    "is another program sending OMNI4_CMD?",
		    m.mode);
		warned_driven_ = true;
	}
}

int64_t HandRun::controller_us() const
{
	return wall_us() + clock_offset_us_;
}

// The controller's watchdog wants a command at least every cmd_timeout_ms: COAST, bridges off.
void HandRun::keepalive()
{
	const double now = steady_s();
	if (now - last_cmd_s_ < kKeepaliveS)
		return;
	rec_.publish(OMNI4_CHANNEL_CMD, encode_command(wall_us(), seq_++, command_t::MODE_COAST));
	last_cmd_s_ = now;
}

// Like the sequence runner: on a terminal a status line ~10 times a second, else a line per
// finished push slot.
void HandRun::show_status()
{
	const double now = steady_s();
	const int pct = 100 * slots_done_ / std::max(1, slots_total_);
	if (progress_.tty() ? now - last_status_s_ < 0.1 : pct == last_pct_)
		return;
	last_status_s_ = now;
	last_pct_ = pct;
	static const char *const what[5] = {"waiting for the robot to rest", "at rest",
	                                    "waiting for the push", "pushed", "coasting"};
	char buf[200];
	std::snprintf(buf, sizeof(buf), "omni4-ident run: %3d%%  %s %d/%d  %s  logged %llu", pct,
	              hand_axis_name(cur_axis_), cur_k_ + 1, hand_.pushes,
	              what[static_cast<int>(det_.state())],
	              static_cast<unsigned long long>(rec_.written()));
	progress_.status(buf);
}

HandRun::Waited HandRun::wait_for(std::initializer_list<Event> want, double timeout_s)
{
	const double deadline = steady_s() + timeout_s;
	for (;;) {
		if (g_interrupted)
			return {Why::Interrupted, Event::None};
		keepalive();
		while (!pending_.empty()) {
			const Sample s = pending_.front();
			pending_.pop_front();
			const Event ev = det_.feed(s.utime, s.x);
			if (std::find(want.begin(), want.end(), ev) != want.end())
				return {Why::Got, ev};
		}
		const double now = steady_s();
		if (now - last_motors_s_ > kMotorsWaitS)
			return {Why::MotorsLost, Event::None};
		if (now >= deadline)
			return {Why::Timeout, Event::None};
		show_status();
		rec_.handle(5);
	}
}

bool HandRun::wait_first_motors()
{
	const double deadline = steady_s() + kMotorsWaitS;
	while (motors_ == 0 && !g_interrupted && steady_s() < deadline) {
		keepalive();
		rec_.handle(5);
	}
	return motors_ > 0;
}

void HandRun::open_segment(int axis)
{
	rec_.publish(OMNI4_CHANNEL_EXPERIMENT,
	             encode_mark(controller_us(), "coast", hand_axis_name(axis), 0));
	segment_open_ = true;
}

void HandRun::close_segment()
{
	rec_.publish(OMNI4_CHANNEL_EXPERIMENT, encode_mark(controller_us(), OMNI4_MARK_END));
	segment_open_ = false;
}

bool HandRun::stopped_by(const Waited &w)
{
	if (w.why == Why::MotorsLost)
		motors_lost_ = true;
	return w.why == Why::Interrupted || w.why == Why::MotorsLost;
}

void HandRun::say(int axis, int k, const char *fmt, ...)
{
	char buf[400];
	va_list ap;
	va_start(ap, fmt);
	std::vsnprintf(buf, sizeof(buf), fmt, ap);
	va_end(ap);
	progress_.line("omni4-ident run: %s %d/%d: %s", hand_axis_name(axis), k + 1, hand_.pushes,
	               buf);
}

HandRun::Step HandRun::rest_step(int axis, int k)
{
	if (det_.state() == HandDetector::State::AtRest)
		return Step::Next;
	const Waited w = wait_for({Event::AtRest}, hand_.push_timeout_s);
	if (stopped_by(w))
		return Step::Quit;
	if (w.why == Why::Got)
		return Step::Next;
	say(axis, k,
	    "the robot did not come to rest within %g s (|v|, |vn| < 0.05 m/s, |w| < 0.5 "
	    "rad/s for 0.5 s); skipped",
	    hand_.push_timeout_s);
	return Step::Missed;
}

HandRun::Step HandRun::push_step(int axis, int k)
{
	open_segment(axis);
	say(axis, k, "%s", instruction(axis));
	det_.expect_push(axis, hand_.push_timeout_s);
	const Waited w = wait_for({Event::PushStarted, Event::WrongAxis, Event::NoPush},
	                          hand_.push_timeout_s + kMotorsWaitS);
	if (stopped_by(w))
		return Step::Quit;
	if (w.why == Why::Got && w.ev == Event::PushStarted)
		return Step::Next;
	close_segment();
	if (w.ev == Event::WrongAxis) {
		const auto &p = det_.push();
		progress_.line(
		    "omni4-ident run: warning: that push went mostly along %s (%+.3f %s), not "
		    "%s: run closed, not counted; once the robot rests, again:",
		    hand_axis_name(p.moved_axis), p.moved_speed, unit(p.moved_axis),
		    hand_axis_name(axis));
		++wrong_;
		return Step::Again;
	}
	say(axis, k, "no push within %g s: run closed, moving on", hand_.push_timeout_s);
	return Step::Missed;
}

HandRun::Step HandRun::stop_step(int axis, int k)
{
	const Waited w =
	    wait_for({Event::Stopped, Event::NotStopped}, hand_.push_timeout_s + kMotorsWaitS);
	if (stopped_by(w))
		return Step::Quit;
	close_segment();
	if (w.why != Why::Got || w.ev != Event::Stopped) {
		say(axis, k, "still moving %g s after the push: run closed, not counted",
		    hand_.push_timeout_s);
		return Step::Missed;
	}
	const auto &p = det_.push();
	say(axis, k, "peak %+.3f %s, coast-down %.2f s (push seen %.2f s before the peak)", p.peak,
	    unit(axis), p.coast_s(), p.push_s());
	++counted_[axis];
	return Step::Next;
}

bool HandRun::one_push(int axis, int k)
{
	for (;;) { // until a counted run, a miss, or the end
		Step step = rest_step(axis, k);
		if (step == Step::Next)
			step = push_step(axis, k);
		if (step == Step::Next)
			step = stop_step(axis, k);
		if (step == Step::Again)
			continue;
		if (step == Step::Missed)
			++missed_;
		return step != Step::Quit;
	}
}

void HandRun::report(bool ok)
{
	progress_.end_status();
	std::string runs;
	for (int a = 0; a < 3; ++a)
		if (wanted_[a])
			runs += std::string(runs.empty() ? "" : ", ") + hand_axis_name(a) + " " +
			        std::to_string(counted_[a]) + "/" + std::to_string(wanted_[a]);
	std::fprintf(stderr,
	             "omni4-ident run: %s %s: %llu messages logged; runs %s (%d along the "
	             "wrong axis, %d missed)%s\n",
	             g_interrupted  ? "interrupted, robot stopped;"
	             : motors_lost_ ? "aborted;"
	                            : "done;",
	             opt_.out.c_str(), static_cast<unsigned long long>(rec_.written()),
	             runs.c_str(), wrong_, missed_, ok ? "" : " (write errors!)");
}

int HandRun::run()
{
	std::vector<int> axes;
	try {
		for (const std::string &dir : hand_.directions)
			axes.push_back(axis_of(dir));
	} catch (const std::exception &e) {
		std::fprintf(stderr, "omni4-ident run: %s\n", e.what());
		return 2;
	}
	if (!rec_.open(opt_,
	               [this](const char *ch, const lcm_recv_buf_t *rb) { on_message(ch, rb); }))
		return 1;
	if (!wait_first_motors() && !g_interrupted) {
		rec_.finish(encode_command(wall_us(), seq_++, command_t::MODE_IDLE), nullptr);
		rec_.discard();
		std::fprintf(stderr,
		             "omni4-ident run: no OMNI4_MOTORS on %s within %g s: is omni4-fw "
		             "running?\n",
		             opt_.url.c_str(), kMotorsWaitS);
		return 1;
	}
	slots_total_ = static_cast<int>(axes.size()) * hand_.pushes;
	for (int a : axes)
		wanted_[a] += hand_.pushes;
	bool going = !g_interrupted;
	for (size_t i = 0; going && i < axes.size(); ++i) {
		cur_axis_ = axes[i];
		for (cur_k_ = 0; going && cur_k_ < hand_.pushes; ++cur_k_, ++slots_done_)
			going = one_push(cur_axis_, cur_k_);
	}
	const auto end = encode_mark(controller_us(), OMNI4_MARK_END);
	const bool ok = rec_.finish(encode_command(wall_us(), seq_++, command_t::MODE_IDLE),
	                            segment_open_ ? &end : nullptr);
	report(ok);
	if (motors_lost_) {
		std::fprintf(
		    stderr, "omni4-ident run: no OMNI4_MOTORS for %g s on %s: did omni4-fw stop?\n",
		    kMotorsWaitS, opt_.url.c_str());
		return 1;
	}
	return g_interrupted ? 130 : (ok ? 0 : 1);
}

} // namespace

int run_hand(const RunOptions &opt, const HandRunOptions &hand)
{
	HandRun run(opt, hand);
	return run.run();
}

} // namespace omni4
