// drive_lockstep: the paper's experiment sequence (as omni4-sim --experiments plays it) with the
// controller on omni4-fw's vesc or odrive backend ([hal] motor of --params), its CAN socket an
// in-process queue to omni4-motorsim's simulated drives (DriveLoop, host-tools/motorsim) and the
// simulated robot's plant behind them, in lockstep at the loop's rate in simulated time. The
// log is omni4-sim's: the controller's channels, the marks on OMNI4_EXPERIMENT, the sim
// backend's camera (its noise and latency) and truth, for omni4-ident identify. The drives
// measure the plant with the sim backend's sensors (current noise, encoder counts, as
// omni4-sim's runs; --no-noise: exact) and report it in their protocol's units and resolution
// (STATUS_1's 0.1 A and 1 ERPM, ODrive's floats at its message rates); that is what the
// controller reads.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "cli.hpp"
#include "drive_bridge.h"
#include "drive_loop.hpp"
#include "simexp.hpp"
#include "traction_exp.hpp"

namespace
{

struct Args {
	std::string params_path, out_path;
	std::vector<std::string> only;
	bool no_noise = false;
	int seed = -1;
	double encoder_ms = 10; // the ODrives' encoder estimate period
	double iq_ms = 0;       // their cyclic Get_Iq period (0: on request only)
};

// The drives' period: the controller's frames in, the plant stepped by the drives' voltages,
// their frames to the controller's socket.
void advance(void *ctx, double t_s, double dt_s, const omni4_can_frame *in, int n)
{
	auto &d = *static_cast<motorsim::DriveLoop *>(ctx);
	const motorsim::Frames frames(in, in + n);
	motorsim::drive_loop_advance(d, t_s, dt_s, frames);
	for (const omni4_can_frame &f : d.out)
		drive_bridge_deliver(&f);
}

void add_options(CLI::App &app, Args &a)
{
	app.add_option("--params", a.params_path,
	               "robot INI: [hal] motor = vesc or odrive, its section, [model] of the "
	               "simulated robot and the controller")
	    ->required();
	app.add_option("--out", a.out_path, "event log to write")->required();
	app.add_option("--only", a.only,
	               "run only these experiment kinds (steady_rotation coast motor step)");
	app.add_option("--seed", a.seed, "noise seed (default: [sim] seed)")
	    ->check(CLI::Range(0, 2147483647));
	app.add_option("--encoder-ms", a.encoder_ms,
	               "the ODrives' encoder estimate period (encoder_msg_rate_ms; default 10)")
	    ->check(CLI::Range(1.0, 1000.0));
	app.add_option("--iq-ms", a.iq_ms,
	               "the ODrives' cyclic Get_Iq period (iq_msg_rate_ms; default 0: only "
	               "answered to the controller's requests)")
	    ->check(CLI::Range(0.0, 1000.0));
	app.add_flag("--no-noise", a.no_noise,
	             "exact sensors (no current, encoder or camera noise)");
}

// What the run wrote and how fast; the exit status (1: log errors or a fault).
int report(const Args &a, const omni4::SimRunResult &r)
{
	const simrun_stats &st = r.stats;
	std::printf("drive_lockstep: wrote %s: %llu messages; %.1f s simulated in %.2f s wall, "
	            "%llu ticks; faults seen: %#x; commands rejected: %llu\n",
	            a.out_path.c_str(), (unsigned long long)st.messages, r.simulated_s, r.wall_s,
	            (unsigned long long)st.ticks, static_cast<unsigned>(st.faults),
	            (unsigned long long)st.cmd_rejected);
	if (st.log_errors || st.log_dropped) {
		std::fprintf(stderr,
		             "drive_lockstep: %llu log write errors, %llu samples dropped\n",
		             (unsigned long long)st.log_errors, (unsigned long long)st.log_dropped);
		return 1;
	}
	return st.faults ? 1 : 0;
}

} // namespace

int main(int argc, char **argv)
{
	CLI::App app{"The paper's experiments through simulated VESC or ODrive drives: omni4-fw's "
	             "backend of [hal]\nmotor on an in-process CAN queue to omni4-motorsim's "
	             "drives and plant, in lockstep.\n"
	             "Example: drive_lockstep --params vesc.ini --out vesc.lcmlog",
	             "drive_lockstep"};
	omni4_cli_setup(app);
	Args a;
	add_options(app, a);
	OMNI4_CLI_PARSE(app, argc, argv);

	omni4_config cfg;
	config_defaults(&cfg);
	config_error err;
	if (config_load(a.params_path.c_str(), &cfg, &err) != 0) {
		std::fprintf(stderr, "drive_lockstep: %s\n", err.msg);
		return 2;
	}
	if (a.seed >= 0)
		cfg.sim.seed = a.seed;
	char why[256];
	motorsim::DriveLoop d;
	if (drive_bridge_setup(&cfg, advance, &d, why, sizeof(why))) {
		std::fprintf(stderr, "drive_lockstep: %s: %s\n", a.params_path.c_str(), why);
		return 2;
	}
	motorsim::VescOptions vo;
	motorsim::OdriveOptions oo;
	for (int j = 0; j < 4; ++j) {
		vo.ids[j] = cfg.vesc.id[j];
		oo.nodes[j] = cfg.odrive.node[j];
	}
	vo.pole_pairs = cfg.vesc.pole_pairs;
	oo.encoder_s = a.encoder_ms * 1e-3;
	oo.iq_s = a.iq_ms * 1e-3;
	const auto proto = cfg.fw.motor == OMNI4_MOTOR_VESC ? motorsim::Protocol::vesc
	                                                    : motorsim::Protocol::odrive;

	omni4::SimRunResult r;
	try {
		const omni4::Layout layout = omni4::layout_of_settings(cfg.ctl, "--params");
		std::vector<omni4::Phase> phases =
		    omni4::selected_sequence(a.only, 3.0, 3.0, layout);
		omni4::limit_ramps(phases, cfg.ctl.model,
		                   omni4::traction_hold_n(cfg.ctl.model, cfg.ctl.limits.traction_mu,
		                                          cfg.ctl.limits.traction_margin),
		                   layout);
		std::unique_ptr<simrun, void (*)(simrun *)> sr(
		    simrun_create_wrapped(&cfg, &cfg.ctl.model, !a.no_noise, a.out_path.c_str(),
		                          drive_bridge_wrap, nullptr, why, sizeof(why)),
		    simrun_destroy);
		if (!sr) {
			std::fprintf(stderr, "drive_lockstep: %s\n", why);
			return 1;
		}
		if (*drive_bridge_error()) {
			std::fprintf(stderr, "drive_lockstep: %s\n", drive_bridge_error());
			return 1;
		}
		// The drives on the simulated robot's plant, which its sim backend steps (camera,
		// truth).
		motorsim::drive_loop_init(d, proto, vo, oo,
		                          motorsim::Supply{cfg.ctl.limits.supply_v, 0.0},
		                          drive_bridge_plant());
		// What the drives report: the sim backend's readings (its current noise and encoder
		// counts; exact with --no-noise) in their protocol's units and resolution.
		double current_a[4] = {}, wheel_rad_s[4] = {};
		d.step = [&](const motorsim::DriveOut &u, double) {
			drive_bridge_step_plant(u.u_v, u.driven, current_a, wheel_rad_s);
		};
		d.sense = [&](motorsim::DriveView &v) {
			for (int j = 0; j < 4; ++j) {
				v.current_a[j] = current_a[j];
				v.motor_rad_s[j] = wheel_rad_s[j] * cfg.ctl.model.l;
			}
		};
		r = omni4::play_phases(sr.get(), cfg, phases, 0.0, 0.0);
		char line[512];
		std::printf("drive_lockstep: %s\n", drive_bridge_summary(line, sizeof(line)));
		sr.reset();
		drive_bridge_close();
	} catch (const std::exception &e) {
		std::fprintf(stderr, "drive_lockstep: %s\n", e.what());
		return 1;
	}
	return report(a, r);
}
