// drive_loop.hpp - the simulated VESCs or ODrives with the plant behind them: one period takes
// the frames received, steps the drives and the plant, and returns the frames to send. No
// socket here: omni4_motorsim.cpp moves the frames, motorsim_vectors prints them.
#pragma once

#include <functional>

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
	// Who steps pl under the drives' voltages over dt_s (empty: plant_step): e.g. a simulated
	// robot that keeps its own sensors (a camera, the truth) on the same plant.
	std::function<void(const DriveOut &u, double dt_s)> step;
	// What the drives measure of the plant after the step (empty: look's exact view), e.g. a
	// simulated robot's sensors (current noise, encoder counts): their reports carry it, what
	// they apply does not.
	std::function<void(DriveView &view)> sense;
};

// The drives of proto on the plant pl (the caller keeps it), at rest.
void drive_loop_init(DriveLoop &d, Protocol proto, const VescOptions &vo, const OdriveOptions &oo,
                     const Supply &supply, plant *pl);
// One period of dt_s ending the interval that starts at t_s: the frames in, the drives'
// voltages held over the plant's step, d.out the frames the drives send after it.
void drive_loop_advance(DriveLoop &d, double t_s, double dt_s, const Frames &in);

} // namespace motorsim
