// drive_sim.cpp - what the simulated drives share: the supply's sag and the motor side of a
// drive (its current loop, a released motor) from the model's eq 21.
#include <cmath>

#include "drive_sim.hpp"

extern "C" {
#include "omni4/model/dynamics.h"
}

namespace motorsim
{

double supply_sag(double v, double r_int_ohm, const double current_a[4])
{
	double sum = 0;
	for (int j = 0; j < 4; ++j)
		sum += std::fabs(current_a[j]);
	return v - r_int_ohm * sum;
}

// eq 21 for motor j alone (its own R and Kv).
static double motor_j_voltage(const Motors &m, int j, double current_a, double motor_rad_s)
{
	double i[4] = {0, 0, 0, 0}, w[4] = {0, 0, 0, 0}, u[4];
	i[j] = current_a;
	w[j] = motor_rad_s;
	motor_voltages_wheels(&m.w, i, w, u);
	return u[j];
}

double current_loop_voltage(const Motors &m, int j, double current_a, double motor_rad_s,
                            double supply_v)
{
	const double u = motor_j_voltage(m, j, current_a, motor_rad_s);
	const double lim = std::fmax(0.0, supply_v);
	return std::fmax(-lim, std::fmin(lim, u));
}

double coast_voltage(const Motors &m, int j, double motor_rad_s)
{
	return motor_j_voltage(m, j, 0.0, motor_rad_s);
}

} // namespace motorsim
