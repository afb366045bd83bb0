/*
 * battery.h - the supply the H-bridges see: a battery's open-circuit voltage, falling linearly
 * with the charge drawn from v_full at full charge to BATTERY_EMPTY_SHARE v_full at empty (and
 * held there beyond), minus its internal resistance times the current drawn. The bridges pass
 * power through losslessly: the battery current is the motors' electrical power over the
 * supply, I = P / V with P = sum_j u_j i_j (negative while the motors brake: the charge
 * comes back, never beyond full). With the power held over a step, the supply solves
 * V = V_oc - R_b P / V, i.e. V = (V_oc + sqrt(V_oc^2 - 4 R_b P)) / 2 (a power beyond
 * V_oc^2 / (4 R_b), more than the battery can give, collapses it to V_oc / 2).
 */
#ifndef OMNI4_BATTERY_H
#define OMNI4_BATTERY_H

/* 0.75: a lithium-polymer pack from 4.2 V per cell at full charge to ~3.15 V at empty. */
#define BATTERY_EMPTY_SHARE 0.75

struct battery {
	double v_full;     /* open-circuit voltage at full charge [V] */
	double capacity_c; /* [C] (A s) */
	double r_int_ohm;  /* internal resistance [ohm] */
	double drawn_c;    /* charge drawn so far [C], in [0, capacity_c] */
	double v_supply;   /* the supply the bridges saw over the last step [V] */
};

/* Full and unloaded. -EINVAL unless v_full and capacity_ah are > 0, r_int_ohm >= 0, all finite. */
int battery_init(struct battery *b, double v_full, double capacity_ah, double r_int_ohm);
/* Open-circuit voltage at the present charge [V]. */
double battery_open_circuit_v(const struct battery *b);
/* dt [s] delivering power_w [W] to the bridges: the supply over the step, then the charge. */
void battery_step(struct battery *b, double power_w, double dt);

#endif /* OMNI4_BATTERY_H */
