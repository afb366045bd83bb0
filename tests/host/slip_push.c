/* slip_push.c - test_slip_hold's push on the simulated body (sim_motor.h is C only). */
#include "omni4/drivers/sim_motor.h"
#include "omni4/sil/simrun.h"

void slip_push_set(struct simrun *sr, double force_v_n);

void slip_push_set(struct simrun *sr, double force_v_n)
{
	simrun_faults(sr)->ext_force[0] = force_v_n;
}
