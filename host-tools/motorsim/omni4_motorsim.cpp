// omni4-motorsim: the two motor-driver boards of the CAN protocol with the model plant behind
// them. Receives CMD_VOLTAGE / CMD_CONTROL, steps the plant at 1 kHz, answers with STATUS
// (every ms) and HEALTH (100 Hz), so the unmodified omni4-fw (socketcan backend) drives a
// simulated robot. Works with candump / cansend by hand. With --protocol vesc or odrive, four
// simulated VESCs or ODrives instead (drive_loop.hpp). With --camera-hz, a camera that sees the
// plant's exact pose: OMNI4_POSE on LCM, so the controller's goal mode runs.
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cli.hpp"
#include "drive_loop.hpp"

extern "C" {
#include "omni4/drivers/can_proto.h"
#include "omni4/base/clock.h"
#include "omni4/config/config.h"
#include "omni4/model/consts.h"
#include "omni4/model/plant.h"
#include "omni4/model/rng.h"
#include "omni4/drivers/sc_os.h"
#include "omni4_pose_t.h"
#include <lcm/lcm.h>
}

namespace
{

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int)
{
	g_stop = 1;
}

struct Stats {
	unsigned long long rx = 0, tx = 0, tx_dropped = 0, crc_errors = 0, replayed = 0,
	                   cmd_timeouts = 0;
};

float clip(double x, float lim)
{
	return static_cast<float>(std::fmax(-lim, std::fmin(lim, x)));
}

// The receiver's counter policy of the protocol (as the controller's, socketcan_motor.h): a
// frame is taken if its counter is 1..CAN_COUNTER_WINDOW ahead of the last taken one; any
// other value is rejected unless the next frame continues from it (resynchronisation).
struct CounterWindow {
	bool have = false;
	uint8_t last = 0;
	int candidate = -1;
	bool accept(uint8_t now)
	{
		if (have) {
			const int gap = can_counter_gap(last, now);
			if (gap == -EALREADY || gap > CAN_COUNTER_WINDOW - 1) {
				if (gap != -EALREADY && candidate >= 0 &&
				    can_counter_gap(static_cast<uint8_t>(candidate), now) == 0) {
					candidate = -1;
					last = now;
					return true;
				}
				candidate = gap == -EALREADY ? -1 : now;
				return false;
			}
		}
		have = true;
		candidate = -1;
		last = now;
		return true;
	}
};

struct Options {
	std::string iface = "vcan0", params_path, protocol = "omni4";
	double duration_s = 0, replay_at = -1, corrupt_at = -1;
	bool no_noise = false, quiet = false;
	std::vector<int> ids{0, 1, 2, 3}, nodes{0, 1, 2, 3};
	int pole_pairs = 7, fault_node = 0;
	double supply_v = 0, supply_ohm = 0, watchdog_s = 0.2, fault_at_s = -1, timeout_s = 0.5;
	int encoder_ms = 10, iq_ms = 0; // the ODrive's message rates [ms] (its defaults)
	int status_ms = 1;              // the VESC's status messages [ms]
	double camera_hz = 0;
	std::string lcm_url;
};

// The drives' message rates and timeouts (group g).
void add_drive_rates(CLI::App &app, Options &o, const char *g)
{
	app.add_option("--watchdog-s", o.watchdog_s, "ODrive: watchdog timeout (0: off)")
	    ->check(CLI::NonNegativeNumber)
	    ->capture_default_str()
	    ->group(g);
	app.add_option(
	       "--encoder-ms", o.encoder_ms,
	       "ODrive: encoder estimates every MS (encoder_msg_rate_ms; the drive's default)")
	    ->check(CLI::Range(1, 1000))
	    ->capture_default_str()
	    ->group(g);
	app.add_option("--iq-ms", o.iq_ms,
	               "ODrive: Get_Iq sent every MS (iq_msg_rate_ms; 0: on request only, the "
	               "drive's default)")
	    ->check(CLI::Range(0, 1000))
	    ->capture_default_str()
	    ->group(g);
	app.add_option("--status-ms", o.status_ms,
	               "VESC: STATUS_1, 4 and 5 every MS (the app's CAN status rate, set in VESC "
	               "Tool)")
	    ->check(CLI::Range(1, 1000))
	    ->capture_default_str()
	    ->group(g);
	app.add_option("--timeout-s", o.timeout_s, "VESC: command timeout (the firmware's default)")
	    ->check(CLI::PositiveNumber)
	    ->capture_default_str()
	    ->group(g);
}

// The options of the simulated VESCs and ODrives (--protocol vesc|odrive).
void add_drive_options(CLI::App &app, Options &o)
{
	const char *g = "VESC / ODrive";
	app.add_option("--protocol", o.protocol, "omni4 (the boards), vesc or odrive")
	    ->check(CLI::IsMember({"omni4", "vesc", "odrive"}))
	    ->capture_default_str();
	app.add_option("--ids", o.ids, "VESC controller IDs of wheels 0-3 (default 0,1,2,3)")
	    ->delimiter(',')
	    ->expected(4)
	    ->check(CLI::Range(0, 254))
	    ->group(g);
	app.add_option("--nodes", o.nodes, "ODrive node IDs of wheels 0-3 (default 0,1,2,3)")
	    ->delimiter(',')
	    ->expected(4)
	    ->check(CLI::Range(0, 63))
	    ->group(g);
	app.add_option("--pole-pairs", o.pole_pairs, "VESC: motor pole pairs (ERPM, tachometer)")
	    ->check(CLI::Range(1, 100))
	    ->capture_default_str()
	    ->group(g);
	app.add_option("--supply-v", o.supply_v,
	               "open-circuit supply [V] (default [limits] supply_v)")
	    ->check(CLI::PositiveNumber)
	    ->group(g);
	app.add_option("--supply-ohm", o.supply_ohm, "supply's internal resistance: V - R sum|i|")
	    ->check(CLI::NonNegativeNumber)
	    ->capture_default_str()
	    ->group(g);
	add_drive_rates(app, o, g);
	app.add_option("--fault-at-s", o.fault_at_s,
	               "fault at S seconds on --fault-node's drive (ODrive: axis error DRV_FAULT, "
	               "IDLE; VESC: the drive goes silent and releases its motor)")
	    ->check(CLI::NonNegativeNumber)
	    ->group(g);
	app.add_option("--fault-node", o.fault_node, "wheel 0-3 whose drive --fault-at-s breaks")
	    ->check(CLI::Range(0, 3))
	    ->capture_default_str()
	    ->group(g);
}

void add_options(CLI::App &app, Options &o)
{
	app.add_option("--iface", o.iface, "CAN interface")->capture_default_str();
	app.add_option("--params", o.params_path, "robot INI ([model]; default Table III)");
	app.add_option("--duration", o.duration_s, "stop after S seconds (default: until SIGINT)");
	app.add_flag("--no-noise", o.no_noise, "exact current readings");
	app.add_option("--camera-hz", o.camera_hz,
	               "publish the plant's exact pose on OMNI4_POSE at HZ (a perfect camera)")
	    ->check(CLI::Range(0.1, 1000.0));
	app.add_option("--lcm", o.lcm_url, "LCM URL of the camera (default: LCM's default)");
	// Test hooks: not in the user's help (group "").
	app.add_option("--replay-at", o.replay_at,
	               "test: at S seconds, send the last STATUS_0 again")
	    ->group("");
	app.add_option("--corrupt-at", o.corrupt_at,
	               "test: at S seconds, send a STATUS_0 with a bad CRC")
	    ->group("");
	app.add_flag("-q,--quiet", o.quiet, "no summary");
	add_drive_options(app, o);
}

// The robot INI (Table III without one) and the plant it describes. Returns 0 or the exit
// status after a one-line error.
int load_robot(const std::string &params_path, omni4_config *cfg, plant *pl)
{
	config_defaults(cfg);
	if (!params_path.empty()) {
		config_error err;
		if (config_load(params_path.c_str(), cfg, &err)) {
			std::fprintf(stderr, "omni4-motorsim: %s\n", err.msg);
			return 2;
		}
	}
	if (plant_init(pl, &cfg->ctl.model)) {
		std::fprintf(stderr, "omni4-motorsim: invalid model parameters\n");
		return 2;
	}
	return 0;
}

// What the two boards remember between ticks.
struct Boards {
	double u[4] = {0, 0, 0, 0}; // commanded voltages [V]
	bool cmd_enable = false, ctl_enable = true;
	CounterWindow cmd_window;
	bool have_ctl_counter = false;
	uint8_t ctl_counter = 0;
	uint8_t status_counter[2] = {0, 0}, health_counter[2] = {0, 0};
	uint8_t drv_faults = 0;
	int64_t last_cmd = 0;
	omni4_can_frame last_status0{};

	bool driven() const
	{
		return cmd_enable && ctl_enable && !(drv_faults & CAN_DRV_CMD_TIMEOUT);
	}
};

void take_cmd_voltage(const omni4_can_frame &f, int64_t now, Boards &b, Stats &st)
{
	float v[4];
	bool en;
	uint8_t c;
	if (can_decode_cmd_voltage(&f, v, &en, &c)) {
		++st.crc_errors;
		return;
	}
	if (!b.cmd_window.accept(c)) {
		++st.replayed;
		return;
	}
	for (int j = 0; j < 4; ++j)
		b.u[j] = v[j];
	b.cmd_enable = en;
	b.last_cmd = now;
	b.drv_faults &= static_cast<uint8_t>(~CAN_DRV_CMD_TIMEOUT);
}

void take_control(const omni4_can_frame &f, Boards &b, Stats &st)
{
	enum can_control cmd;
	uint8_t c;
	if (can_decode_control(&f, &cmd, &c) != 0) {
		++st.crc_errors;
		return;
	}
	// Control frames are sparse events (a restarted controller's first ENABLE must not wait
	// for a second frame): only the same counter again is refused; 36 reserved bits keep
	// a random frame's acceptance far below the protocol's bound.
	if (b.have_ctl_counter && can_counter_gap(b.ctl_counter, c) == -EALREADY) {
		++st.replayed;
		return;
	}
	b.have_ctl_counter = true;
	b.ctl_counter = c;
	if (cmd == CAN_CTL_ENABLE)
		b.ctl_enable = true;
	if (cmd == CAN_CTL_DISABLE)
		b.ctl_enable = false;
	if (cmd == CAN_CTL_CLEAR_FAULTS)
		b.drv_faults = 0;
}

// Everything the controller sent since the last tick.
void receive_commands(int fd, int64_t now, Boards &b, Stats &st)
{
	omni4_can_frame f;
	uint32_t err;
	int rc;
	while ((rc = sc_os_recv(fd, &f, &err)) > 0) {
		if (rc != 1)
			continue;
		++st.rx;
		if (f.id == CAN_ID_CMD_VOLTAGE)
			take_cmd_voltage(f, now, b, st);
		else
			take_control(f, b, st);
	}
}

void check_cmd_timeout(int64_t now, Boards &b, Stats &st)
{
	if (b.last_cmd && now - b.last_cmd > CAN_BOARD_CMD_TIMEOUT_US &&
	    !(b.drv_faults & CAN_DRV_CMD_TIMEOUT)) {
		b.drv_faults |= CAN_DRV_CMD_TIMEOUT;
		++st.cmd_timeouts;
	}
}

void send_counted(int fd, const omni4_can_frame &f, Stats &st)
{
	if (sc_os_send(fd, &f))
		++st.tx_dropped;
	else
		++st.tx;
}

// The simulator: the CAN socket, the robot and its plant, the boards' state, the counts.
struct Sim {
	int fd = -1;
	omni4_config cfg;
	plant pl;
	rng g;
	Boards b;
	Stats st;
};

void send_status(Sim &sim, int n, const double w[4], bool noisy)
{
	can_status s;
	for (int k = 0; k < 2; ++k) {
		const int j = 2 * n + k;
		const double noise = noisy ? rng_normal(&sim.g, sim.cfg.sim.current_noise_a) : 0.0;
		s.current_a[k] = clip(sim.pl.current_a[j] + noise, CAN_CURR_MAX);
		s.speed_rad_s[k] = clip(w[j], CAN_SPEED_MAX);
	}
	omni4_can_frame f;
	can_encode_status(n, &s, sim.b.status_counter[n]++ & 0xF, &f);
	if (n == 0)
		sim.b.last_status0 = f;
	send_counted(sim.fd, f, sim.st);
}

void send_health(Sim &sim, int n, bool driven)
{
	Boards &b = sim.b;
	// The command timeout is the board protecting itself, not a hardware fault: it keeps
	// the state "disabled" so that the controller's own timeout logic rules.
	const bool self_off = b.drv_faults == CAN_DRV_CMD_TIMEOUT;
	can_health hh{};
	hh.faults = self_off ? 0 : b.drv_faults;
	hh.supply_v = static_cast<float>(sim.cfg.ctl.limits.supply_v);
	hh.temp_c = 30;
	hh.state = static_cast<uint8_t>(self_off       ? CAN_STATE_DISABLED
	                                : b.drv_faults ? CAN_STATE_FAULT
	                                : driven       ? CAN_STATE_ENABLED
	                                               : CAN_STATE_DISABLED);
	omni4_can_frame f;
	can_encode_health(n, &hh, b.health_counter[n]++ & 0xF, &f);
	send_counted(sim.fd, f, sim.st);
}

// One board period: commands in, the plant stepped 1 ms, STATUS of both nodes out (HEALTH
// of node n at ticks n, n + 10, ...).
void simulate_tick(Sim &sim, long tick, int64_t now, bool no_noise)
{
	receive_commands(sim.fd, now, sim.b, sim.st);
	check_cmd_timeout(now, sim.b, sim.st);
	const bool driven = sim.b.driven();
	plant_step(&sim.pl, sim.b.u, driven, 1e-3);
	double w[4];
	plant_wheel_speeds(&sim.pl, w);
	for (int n = 0; n < CAN_NODES; ++n) {
		send_status(sim, n, w, !no_noise && driven);
		if (tick % 10 == n)
			send_health(sim, n, driven);
	}
}

// The test options: the last STATUS_0 again (same counter), or with a flipped bit, once each.
void inject_test_frames(int fd, double t, Options &o, const Boards &b)
{
	if (o.replay_at >= 0 && t >= o.replay_at) {
		sc_os_send(fd, &b.last_status0); // same counter again
		o.replay_at = -1;
	}
	if (o.corrupt_at >= 0 && t >= o.corrupt_at) {
		omni4_can_frame bad = b.last_status0;
		bad.data[2] ^= 0x10;
		sc_os_send(fd, &bad);
		o.corrupt_at = -1;
	}
}

// Sleeps until next_ns + 1 ms on the monotonic clock (omni4_monotonic_ns) and advances next_ns.
void sleep_one_ms(int64_t &next_ns)
{
	next_ns += 1000000;
	const timespec next{static_cast<time_t>(next_ns / 1000000000),
	                    static_cast<long>(next_ns % 1000000000)};
	while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR &&
	       !g_stop) {
	}
}

// The simulated drives of --protocol on the robot's plant; 2 after a one-line error.
int setup_drives(const Options &o, Sim &sim, motorsim::DriveLoop &d)
{
	motorsim::VescOptions vo;
	motorsim::OdriveOptions oo;
	for (int j = 0; j < 4; ++j) {
		vo.ids[j] = o.ids[static_cast<size_t>(j)];
		oo.nodes[j] = o.nodes[static_cast<size_t>(j)];
		for (int k = 0; k < j; ++k)
			if (vo.ids[k] == vo.ids[j] || oo.nodes[k] == oo.nodes[j]) {
				std::fprintf(stderr,
				             "omni4-motorsim: --ids and --nodes must be four "
				             "different numbers\n");
				return 2;
			}
	}
	vo.pole_pairs = o.pole_pairs;
	vo.timeout_s = o.timeout_s;
	vo.status_every = o.status_ms;
	oo.watchdog_s = o.watchdog_s;
	oo.encoder_s = o.encoder_ms * 1e-3;
	oo.iq_s = o.iq_ms * 1e-3;
	vo.fault = oo.fault = motorsim::Fault{o.fault_at_s, o.fault_node};
	const motorsim::Supply sup{o.supply_v > 0 ? o.supply_v : sim.cfg.ctl.limits.supply_v,
	                           o.supply_ohm};
	const auto proto =
	    o.protocol == "vesc" ? motorsim::Protocol::vesc : motorsim::Protocol::odrive;
	motorsim::drive_loop_init(d, proto, vo, oo, sup, &sim.pl);
	return 0;
}

// One period of the simulated drives: the frames received, the drives and the plant stepped,
// the drives' frames sent.
void drives_tick(int fd, double t, motorsim::DriveLoop &d, motorsim::Frames &in, Stats &st)
{
	omni4_can_frame f;
	uint32_t err;
	int rc;
	in.clear();
	while ((rc = sc_os_recv(fd, &f, &err)) > 0 && in.size() < 256) {
		if (rc != 1)
			continue;
		++st.rx;
		in.push_back(f);
	}
	motorsim::drive_loop_advance(d, t, 1e-3, in);
	for (const omni4_can_frame &g : d.out)
		send_counted(fd, g, st);
}

// The camera: the plant's pose now, stamped with the controller's clock (CLOCK_REALTIME [us],
// rtloop_clock_us).
void publish_pose(lcm_t *lcm, const plant &pl)
{
	timespec now;
	clock_gettime(CLOCK_REALTIME, &now);
	omni4_pose_t p{};
	p.utime = static_cast<int64_t>(now.tv_sec) * 1000000 + now.tv_nsec / 1000;
	p.x = pl.pose[0];
	p.y = pl.pose[1];
	p.theta = model_wrap_pi(pl.pose[2]);
	omni4_pose_t_publish(lcm, "OMNI4_POSE", &p);
}

// With the camera on, the plant must be where the wall clock says when a pose is stamped: no
// pose while the loop catches up 1 ms step after another (late by 2 ms or more), and a backlog
// of 100 ms or more is dropped (the simulated world pauses while the process is starved; the
// drives' reports and the camera stay on one clock). A pause is said on stderr: the
// controller's odometry ran on through it while the plant stood still, so whoever judges the
// controller against the camera's truth knows (tests/vcan). Returns true when a pose may be
// taken.
bool camera_clock(int64_t &next_ns)
{
	const int64_t late_ns = omni4_monotonic_ns() - next_ns;
	if (late_ns >= 100000000) {
		next_ns += late_ns;
		std::fprintf(stderr,
		             "omni4-motorsim: %.0f ms behind the clock: the simulated world paused "
		             "that long (a starved process)\n",
		             static_cast<double>(late_ns) * 1e-6);
	}
	return late_ns < 2000000;
}

// The periods until SIGINT, SIGTERM or --duration: the boards (dl null) or the drives, the
// camera's poses when it is on.
void run(Options &o, Sim &sim, motorsim::DriveLoop *dl, lcm_t *camera)
{
	motorsim::Frames in;
	in.reserve(256);
	std::signal(SIGINT, on_signal);
	std::signal(SIGTERM, on_signal);
	rng_seed(&sim.g, 7);
	int64_t next = omni4_monotonic_ns();
	const int64_t t0 = sc_os_now_us();
	double next_pose_s = 0;
	for (long tick = 0; !g_stop; ++tick) {
		const int64_t now = sc_os_now_us();
		const double t = (now - t0) * 1e-6;
		if (o.duration_s > 0 && t >= o.duration_s)
			break;
		if (dl) {
			drives_tick(sim.fd, t, *dl, in, sim.st);
		} else {
			simulate_tick(sim, tick, now, o.no_noise);
			inject_test_frames(sim.fd, t, o, sim.b);
		}
		if (camera && camera_clock(next) && t >= next_pose_s) {
			publish_pose(camera, sim.pl);
			next_pose_s = t + 1.0 / o.camera_hz;
		}
		sleep_one_ms(next);
	}
}

void print_summary(const Stats &st, const plant &pl)
{
	std::fprintf(
	    stderr,
	    "omni4-motorsim: rx %llu tx %llu tx_dropped %llu crc_errors %llu replayed %llu "
	    "cmd_timeouts %llu; final v %.3f vn %.3f w %.3f, pose x %.4f y %.4f theta %.4f\n",
	    st.rx, st.tx, st.tx_dropped, st.crc_errors, st.replayed, st.cmd_timeouts, pl.x[0],
	    pl.x[1], pl.x[2], pl.pose[0], pl.pose[1], pl.pose[2]);
}

} // namespace

int main(int argc, char **argv)
{
	CLI::App app{
	    "Simulated omni4 motor-driver boards, or four VESCs or ODrives (CANSimple), on a CAN "
	    "interface with the model's plant behind them (docs/can-drives.md).\n"
	    "Example: omni4-motorsim --iface vcan0 --params robot.ini\n"
	    "         omni4-motorsim --iface vcan0 --protocol odrive --nodes 4,5,6,7 "
	    "--supply-ohm 0.05 --fault-at-s 10 --fault-node 2",
	    "omni4-motorsim"};
	omni4_cli_setup(app);
	Options o;
	add_options(app, o);
	OMNI4_CLI_PARSE(app, argc, argv);

	Sim sim;
	if (int status = load_robot(o.params_path, &sim.cfg, &sim.pl))
		return status;
	const bool drives = o.protocol != "omni4";
	motorsim::DriveLoop dl;
	if (drives) {
		if (int status = setup_drives(o, sim, dl))
			return status;
	}
	const uint32_t ids[] = {CAN_ID_CMD_VOLTAGE, CAN_ID_CMD_CONTROL};
	if (int rc = sc_os_open(o.iface.c_str(), ids, drives ? 0 : 2, &sim.fd)) {
		char why[256];
		std::fprintf(stderr, "omni4-motorsim: CAN interface '%s': %s\n", o.iface.c_str(),
		             sc_os_strerror(rc, why, sizeof why));
		return 1;
	}
	lcm_t *camera = nullptr;
	if (o.camera_hz > 0 &&
	    !(camera = lcm_create(o.lcm_url.empty() ? nullptr : o.lcm_url.c_str()))) {
		std::fprintf(stderr, "omni4-motorsim: cannot open LCM for the camera\n");
		sc_os_close(sim.fd);
		return 1;
	}
	run(o, sim, drives ? &dl : nullptr, camera);
	if (camera)
		lcm_destroy(camera);
	sc_os_close(sim.fd);
	if (!o.quiet)
		print_summary(sim.st, sim.pl);
	return 0;
}
