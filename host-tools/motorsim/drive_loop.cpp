// drive_loop.cpp - one period of the simulated drives and the plant (drive_loop.hpp).
#include "drive_loop.hpp"

namespace motorsim
{

// The drives' view of the plant after its last step.
static void look(DriveLoop &d)
{
	double wheel_rad_s[4];
	plant_wheel_speeds(d.pl, wheel_rad_s);
	for (int j = 0; j < 4; ++j) {
		d.view.motor_rad_s[j] = wheel_rad_s[j] * d.pl->p.l;
		d.view.current_a[j] = d.pl->current_a[j];
	}
	d.view.supply_v = supply_sag(d.supply.v, d.supply.r_ohm, d.view.current_a);
}

void drive_loop_init(DriveLoop &d, Protocol proto, const VescOptions &vo, const OdriveOptions &oo,
                     const Supply &supply, plant *pl)
{
	d.proto = proto;
	d.pl = pl;
	d.supply = supply;
	Motors m{};
	for (int j = 0; j < 4; ++j) {
		m.w.r[j] = pl->r_eff[j];
		m.w.Kv[j] = pl->Kv_eff[j];
		m.w.Kt[j] = pl->Kt_eff[j];
		m.w.R[j] = pl->R_eff[j];
	}
	m.gear = pl->p.l;
	vesc_sim_init(d.vesc, vo, m);
	odrive_sim_init(d.odrive, oo, m);
	d.out.reserve(64);
	look(d);
}

void drive_loop_advance(DriveLoop &d, double t_s, double dt_s, const Frames &in)
{
	const bool vesc = d.proto == Protocol::vesc;
	for (const omni4_can_frame &f : in) {
		if (vesc)
			vesc_sim_receive(d.vesc, f, t_s);
		else
			odrive_sim_receive(d.odrive, f, t_s);
	}
	const DriveOut u =
	    vesc ? vesc_sim_step(d.vesc, t_s, d.view) : odrive_sim_step(d.odrive, t_s, d.view);
	if (d.step)
		d.step(u, dt_s);
	else
		plant_step(d.pl, u.u_v, u.driven, dt_s);
	look(d);
	d.out.clear();
	DriveView seen = d.view;
	if (d.sense)
		d.sense(seen);
	if (vesc)
		vesc_sim_emit(d.vesc, seen, d.out);
	else
		odrive_sim_emit(d.odrive, t_s + dt_s, seen, d.out);
}

} // namespace motorsim
