// scenario.cpp - omni4-sim --goals / --drive: the files read, the scenario played in lockstep
// (scenario.hpp).
#include "scenario.hpp"

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>

#include "omni4/command_t.hpp"
#include "omni4/goal_status_t.hpp"
#include "omni4/goal_t.hpp"

extern "C" {
#include "omni4/model/consts.h"
#include "omni4/lcmtypes/channels.h"
}

namespace omni4
{

namespace
{

constexpr double KEEPALIVE_S = 0.05; // a client's repeat (docs/goal.md: every 50 ms)
constexpr double GOAL_RANGE_M = 100.0;
constexpr int64_t GOAL_ID0 = 1;

// A file's rows as fields, each with its line and 1-based column; blank lines and '#' lines
// skipped. Throws ScenarioError when the file cannot be read.
struct Field {
	std::string text;
	int column;
};
struct Row {
	std::vector<Field> fields;
	int line;
};

std::vector<Row> read_rows(const std::string &path)
{
	std::ifstream in(path);
	if (!in)
		throw ScenarioError(path + ": cannot read: " + std::strerror(errno));
	std::vector<Row> rows;
	std::string text;
	for (int line = 1; std::getline(in, text); ++line) {
		if (!text.empty() && text.back() == '\r')
			text.pop_back();
		const size_t first = text.find_first_not_of(" \t");
		if (first == std::string::npos || text[first] == '#')
			continue;
		Row row{{}, line};
		size_t start = 0;
		for (;;) {
			const size_t comma = text.find(',', start);
			const std::string f = text.substr(
			    start, comma == std::string::npos ? std::string::npos : comma - start);
			const size_t a = f.find_first_not_of(" \t"), b = f.find_last_not_of(" \t");
			row.fields.push_back(
			    {a == std::string::npos ? "" : f.substr(a, b - a + 1),
			     static_cast<int>(start + (a == std::string::npos ? 0 : a)) + 1});
			if (comma == std::string::npos)
				break;
			start = comma + 1;
		}
		rows.push_back(row);
	}
	if (in.bad())
		throw ScenarioError(path + ": cannot read: " + std::strerror(errno));
	return rows;
}

std::string where(const std::string &path, int line, int column)
{
	return path + ":" + std::to_string(line) + ":" + std::to_string(column) + ": ";
}

// Field f as a finite number, else ScenarioError naming where and what it is.
double number(const std::string &path, const Row &row, size_t i, const char *what)
{
	const Field &f = row.fields[i];
	char *end = nullptr;
	errno = 0;
	const double v = std::strtod(f.text.c_str(), &end);
	if (f.text.empty() || *end || errno == ERANGE || !std::isfinite(v))
		throw ScenarioError(where(path, row.line, f.column) + what + " '" + f.text +
		                    "' is not a finite number");
	return v;
}

bool has_number(const Row &row)
{
	for (const Field &f : row.fields) {
		char *end = nullptr;
		std::strtod(f.text.c_str(), &end);
		if (!f.text.empty() && end != f.text.c_str())
			return true;
	}
	return false;
}

// The rows with their header (a first row without a number in it) dropped; each of n_min to
// n_max fields, else ScenarioError.
std::vector<Row> data_rows(const std::string &path, size_t n_min, size_t n_max, const char *form)
{
	std::vector<Row> rows = read_rows(path);
	if (!rows.empty() && !has_number(rows.front()))
		rows.erase(rows.begin());
	if (rows.empty())
		throw ScenarioError(path + ": no rows (" + form + " expected)");
	for (const Row &r : rows)
		if (r.fields.size() < n_min || r.fields.size() > n_max) {
			const Field &last = r.fields.back();
			throw ScenarioError(
			    where(path, r.line, r.fields.size() > n_max ? last.column : 1) +
			    std::to_string(r.fields.size()) + " fields, " + form + " expected");
		}
	return rows;
}

std::vector<uint8_t> encode_goal(int64_t utime, int64_t seq, int64_t id, int8_t action,
                                 const ScenarioGoal *g)
{
	goal_t m{};
	m.utime = utime;
	m.seq = seq;
	m.goal_id = id;
	m.action = action;
	if (g) {
		m.n = 1;
		m.poses = {{g->x, g->y, g->theta}};
		m.speed_max = g->speed_max;
	}
	std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
	m.encode(buf.data(), 0, static_cast<int>(buf.size()));
	return buf;
}

std::vector<uint8_t> encode_velocity(int64_t utime, int64_t seq, const DriveRow &r)
{
	command_t c{};
	c.utime = utime;
	c.seq = seq;
	c.mode = command_t::MODE_VELOCITY;
	c.velocity[0] = r.v;
	c.velocity[1] = r.vn;
	c.velocity[2] = r.w;
	std::vector<uint8_t> buf(static_cast<size_t>(c.getEncodedSize()));
	c.encode(buf.data(), 0, static_cast<int>(buf.size()));
	return buf;
}

using SimPtr = std::unique_ptr<simrun, void (*)(simrun *)>;

SimPtr make_sim(const omni4_config &cfg, const model_params &plant, bool noise,
                const std::string &log_path)
{
	char err[256];
	SimPtr sr(simrun_create(&cfg, &plant, noise, log_path.empty() ? nullptr : log_path.c_str(),
	                        err, sizeof(err)),
	          simrun_destroy);
	if (!sr)
		throw std::runtime_error(err);
	return sr;
}

// The last goal_status_t the controller said about goal id (the simulator's tap).
struct Heard {
	int64_t id = 0;
	int status = 0, reason = 0;
};

void hear(void *ctx, const char *channel, int64_t, const void *data, size_t len)
{
	if (std::strcmp(channel, OMNI4_CHANNEL_GOAL_STATUS))
		return;
	goal_status_t m;
	if (m.decode(data, 0, static_cast<int>(len)) != static_cast<int>(len))
		return;
	auto *h = static_cast<Heard *>(ctx);
	if (m.goal_id == h->id) {
		h->status = m.status;
		h->reason = m.reason;
	}
}

bool ended(int status)
{
	return status == goal_status_t::STATUS_REACHED || status == goal_status_t::STATUS_ABORTED ||
	       status == goal_status_t::STATUS_REFUSED;
}

} // namespace

std::string goal_outcome_text(int status, int reason)
{
	std::string s = std::to_string(status), r = std::to_string(reason);
	switch (status) { // the vocabulary's rows (core's vocab.def)
#define OMNI4_GOAL_STATUS(name, value, ...)                                                        \
	case value:                                                                                \
		s = #name;                                                                         \
		break;
#include "omni4/core/vocab.def"
	}
	switch (reason) {
#define OMNI4_GOAL_REASON(name, value, ...)                                                        \
	case value:                                                                                \
		r = #name;                                                                         \
		break;
#include "omni4/core/vocab.def"
	}
	return reason > 0 ? s + " (" + r + ")" : s;
}

std::vector<ScenarioGoal> read_goals(const std::string &path)
{
	std::vector<ScenarioGoal> goals;
	for (const Row &r : data_rows(path, 3, 4, "x,y,theta[,speed_max]")) {
		ScenarioGoal g;
		g.x = number(path, r, 0, "x");
		g.y = number(path, r, 1, "y");
		g.theta = number(path, r, 2, "theta");
		g.speed_max = r.fields.size() > 3 ? number(path, r, 3, "speed_max") : 0.0;
		g.line = r.line;
		for (int i = 0; i < 2; ++i)
			if (std::fabs(i ? g.y : g.x) > GOAL_RANGE_M)
				throw ScenarioError(where(path, r.line, r.fields[i].column) +
				                    (i ? "y" : "x") +
				                    " beyond 100 m (goal_t's range)");
		if (g.speed_max < 0)
			throw ScenarioError(where(path, r.line, r.fields[3].column) +
			                    "speed_max must be >= 0 (0: the model's limits)");
		goals.push_back(g);
	}
	return goals;
}

std::vector<DriveRow> read_drive(const std::string &path, double lin_max, double rot_max)
{
	std::vector<DriveRow> rows;
	for (const Row &r : data_rows(path, 4, 4, "t_s,v,vn,w")) {
		DriveRow d{number(path, r, 0, "t_s"), number(path, r, 1, "v"),
		           number(path, r, 2, "vn"), number(path, r, 3, "w"), r.line};
		if (d.t_s < 0 || (!rows.empty() && d.t_s < rows.back().t_s))
			throw ScenarioError(where(path, r.line, r.fields[0].column) +
			                    "t_s must be >= 0 and not below the row before");
		const double lim[3] = {lin_max, lin_max, rot_max}, val[3] = {d.v, d.vn, d.w};
		for (int k = 0; k < 3; ++k)
			if (std::fabs(val[k]) > lim[k]) {
				char limit[64];
				std::snprintf(limit, sizeof(limit), "%s %g",
				              k < 2 ? "vel_lin_max" : "vel_rot_max", lim[k]);
				throw ScenarioError(where(path, r.line, r.fields[1 + k].column) +
				                    "beyond [limits] " + limit);
			}
		rows.push_back(d);
	}
	return rows;
}

namespace
{

// The goals played one after the other on sr, tick by tick (run_goals).
struct GoalsPlay {
	simrun *sr;
	const std::vector<ScenarioGoal> &goals;
	const std::function<void(double, size_t, size_t)> &progress;
	double dt;
	long keep_ticks, limit_ticks, rest_ticks; // the keep-alive, a goal's limit, the rests
	Heard heard;
	std::vector<GoalOutcome> out;
	size_t next = 0;
	long sent_at = -1, done_at = -1, seq = 0;

	void send(const ScenarioGoal *g, int8_t action)
	{
		const auto m = encode_goal(simrun_now_us(sr), seq++, heard.id, action, g);
		simrun_goal(sr, m.data(), m.size());
	}

	// The goal in force ended (or ran out of time) at tick k: its outcome, then a cancel.
	void close(long k)
	{
		GoalOutcome o;
		double x[3], pose[3];
		simrun_truth(sr, x, pose);
		const ScenarioGoal &g = goals[next];
		o.goal_id = heard.id;
		o.status = heard.status;
		o.reason = heard.reason;
		o.sent_s = static_cast<double>(sent_at) * dt;
		o.ended_s = static_cast<double>(k) * dt;
		o.truth_off_m = std::hypot(pose[0] - g.x, pose[1] - g.y);
		o.truth_off_rad = std::fabs(std::remainder(pose[2] - g.theta, 2.0 * MODEL_PI));
		out.push_back(o);
		send(nullptr, goal_t::ACTION_CANCEL); // as a client does once it has ended
		++next;
		if (progress)
			progress(static_cast<double>(next) / static_cast<double>(goals.size()),
			         next, goals.size());
		sent_at = -1;
		done_at = next == goals.size() ? k : -1;
	}

	// Ahead of tick k: false once the last goal has ended and the rest after it is over.
	bool before(long k)
	{
		if (done_at >= 0)
			return k - done_at < rest_ticks;
		if (sent_at < 0 && k >= rest_ticks) { // the next goal, a fresh id
			heard = Heard{GOAL_ID0 + static_cast<int64_t>(next)};
			sent_at = k;
		}
		if (sent_at < 0)
			return true;
		if (ended(heard.status) || k - sent_at >= limit_ticks)
			close(k);
		else if ((k - sent_at) % keep_ticks == 0)
			send(&goals[next], goal_t::ACTION_GO);
		return true;
	}
};

} // namespace

ScenarioResult run_goals(const omni4_config &cfg, const model_params &plant, bool noise,
                         const std::string &log_path, const std::vector<ScenarioGoal> &goals,
                         double goal_limit_s, double rtf,
                         const std::function<void(double, size_t, size_t)> &progress,
                         const std::function<bool()> &stop)
{
	SimPtr sr = make_sim(cfg, plant, noise, log_path);
	const double dt = simrun_period_s(sr.get());
	// at rest 1 s at the start (the camera's first poses) and at the end
	GoalsPlay play{sr.get(),
	               goals,
	               progress,
	               dt,
	               std::max(1L, std::lround(KEEPALIVE_S / dt)),
	               std::lround(goal_limit_s / dt),
	               std::lround(1.0 / dt),
	               {},
	               {}};
	simrun_set_tap(sr.get(), hear, &play.heard);
	LockstepClock clock(dt, rtf);
	const long k = lockstep(
	    sr.get(), LONG_MAX, clock, [&](long tick) { return play.before(tick); }, {}, {}, stop);
	ScenarioResult res;
	res.goals = play.out;
	res.run = finish_run(sr.get(), clock, k);
	return res;
}

ScenarioResult run_drive(const omni4_config &cfg, const model_params &plant, bool noise,
                         const std::string &log_path, const std::vector<DriveRow> &rows,
                         double hold_s, double rtf,
                         const std::function<void(double, size_t, size_t)> &progress,
                         const std::function<bool()> &stop)
{
	SimPtr sr = make_sim(cfg, plant, noise, log_path);
	const double dt = simrun_period_s(sr.get());
	const long keep_ticks = std::max(1L, std::lround(KEEPALIVE_S / dt));
	const long ticks = std::lround((rows.back().t_s + hold_s) / dt);
	size_t row = 0; // the next row to start
	long seq = 0, started = -1;
	LockstepClock clock(dt, rtf);
	const long k = lockstep(
	    sr.get(), ticks, clock,
	    [&](long tick) {
		    const double t = static_cast<double>(tick) * dt;
		    bool fresh = false;
		    while (row < rows.size() && rows[row].t_s <= t + 0.5 * dt) {
			    ++row;
			    fresh = true;
		    }
		    if (row == 0)
			    return true; // before the first row: at rest
		    if (fresh)
			    started = tick;
		    if ((tick - started) % keep_ticks == 0) {
			    const auto m =
			        encode_velocity(simrun_now_us(sr.get()), seq++, rows[row - 1]);
			    simrun_command(sr.get(), m.data(), m.size());
		    }
		    return true;
	    },
	    {},
	    [&](double frac) {
		    if (progress)
			    progress(frac, row, rows.size());
	    },
	    stop);
	if (progress && !clock.interrupted)
		progress(1.0, rows.size(), rows.size());
	ScenarioResult res;
	res.run = finish_run(sr.get(), clock, k);
	return res;
}

} // namespace omni4
