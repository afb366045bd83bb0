/*
 * thermal.h - the four motor windings' temperatures, each a single thermal node (winding to
 * ambient through R_th, heat capacity C_th) heated by its own copper loss:
 *   C_th dT_j/dt = i_j^2 R_j(T_j) - (T_j - ambient) / R_th,
 *   R_j(T) = R_j,cold (1 + THERMAL_ALPHA_CU (T - ambient)),
 * R_j,cold the resistance at ambient (the identified one). With i_j held over a step the ODE
 * is linear in T_j and each step is integrated exactly (zero-order hold), so a coarse step
 * only delays the current's change, never the heating.
 */
#ifndef OMNI4_THERMAL_H
#define OMNI4_THERMAL_H

#define THERMAL_ALPHA_CU 0.00393 /* copper's resistance temperature coefficient [1/K] */

struct thermal {
	double r_th_k_w;  /* winding to ambient [K/W] */
	double c_th_j_k;  /* winding heat capacity [J/K] */
	double ambient_c; /* [deg C] */
	double R_cold[4]; /* each winding's resistance at ambient [ohm] */
	double temp_c[4]; /* each winding's temperature [deg C] */
};

/* At ambient. -EINVAL unless r_th, c_th and every R_cold are > 0 and all finite. */
int thermal_init(struct thermal *th, double r_th_k_w, double c_th_j_k, double ambient_c,
                 const double R_cold[4]);
/* Every winding back at ambient. */
void thermal_reset(struct thermal *th);
/* dt [s] with the currents current_a [A] held. */
void thermal_step(struct thermal *th, const double current_a[4], double dt);
/* Each winding's resistance at its present temperature [ohm]. */
void thermal_resistance(const struct thermal *th, double R_ohm[4]);

#endif /* OMNI4_THERMAL_H */
