// drive_loop.hpp - the simulated VESCs or ODrives with the plant behind them: one period takes
// the frames received, steps the drives and the plant, and returns the frames to send. No
// socket here: omni4_motorsim.cpp moves the frames, motorsim_vectors prints them.
#pragma once

#include "odrive_sim.hpp"

extern "C" {
#include "omni4/model/plant.h"
}

namespace motorsim
{

enum class Protocol { vesc, odrive };

struct Supply {
	double v;     // open-circuit voltage [V]
	double r_ohm; // internal resistance [ohm]
};

struct DriveLoop {
	Protocol proto = Protocol::vesc;
	VescSim vesc;
	OdriveSim odrive;
	plant *pl = nullptr;
	Supply supply{};
	DriveView view{};
	Frames out;
};

// The drives of proto on the plant pl (the caller keeps it), at rest.
void drive_loop_init(DriveLoop &d, Protocol proto, const VescOptions &vo, const OdriveOptions &oo,
                     const Supply &supply, plant *pl);
// One period of dt_s ending the interval that starts at t_s: the frames in, the drives'
// voltages held over the plant's step, d.out the frames the drives send after it.
void drive_loop_advance(DriveLoop &d, double t_s, double dt_s, const Frames &in);

} // namespace motorsim
