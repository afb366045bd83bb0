/*
 * plant.h - simulator of the robot of eq 23 with Coulomb friction and stiction.
 *
 * The axes of eq 23 are decoupled (A, K diagonal), so each axis is integrated exactly over a
 * step with zero-order-hold input: x' = a x + b - c sgn(x). A velocity that would cross zero
 * stops at zero for the rest of the step; at zero it stays while |b| <= c (stiction) and
 * breaks away in the direction of b otherwise. With the channels disabled (null traction,
 * the paper's experiment 2) there is no drive and no back-EMF braking: a = -B/M (-Bw/J).
 * The world pose integrates eq 1 inverted, with the mid-step heading.
 *
 * The floor (struct plant_floor, all off by default; off, the plant is the one above to the
 * last bit):
 * - Traction limit: with traction_mu > 0 a wheel grips while its traction force l Kt i / r
 *   (eqs 12-13, the massless wheel of the paper) stays within F_j = mu N_j. The coefficient
 *   depends on the direction at the contact: an omni wheel grips along its drive direction
 *   (mu) and its rollers roll freely across it (no lateral force, so none of mu N_j is spent
 *   across): only the drive-direction force meets the limit. N_j is wheel j's normal load with
 *   the load transfer of the body's acceleration (com_height > 0): a rigid body on four
 *   wheels at p_j (wheel 0 at +d along v, 1 at +d along vn, 2 and 3 opposite, eq 2) carries
 *   N_j = M g / 4 - M h (a . p_j) / (2 d^2), a the centre of mass's acceleration in the body
 *   frame (v' - w vn, vn' + w v), h = com_height (N_j >= 0): the wheels ahead of the
 *   acceleration unload, those behind it load (braking loads the front), and the sum stays
 *   M g. The acceleration is that of the previous (sub)step. Beyond the limit the
 *   wheel slips: it pushes the body with the kinetic friction F_j opposing the slip velocity
 *   (rim speed minus the ground speed at the wheel, eq 2), and wheel + motor spin on their own
 *   inertia J_w (reflected at the wheel): J_w w_j' = l Kt i_j - r F sgn(slip), with i_j from
 *   eq 21 at the wheel's own speed. Its rim speed s_j = r w_j then follows
 *   s' = -s / tau_w + r l Kt u / (J_w R) - r^2 F sgn(slip) / J_w, tau_w = J_w R / (l^2 Kt Kv),
 *   until the slip velocity returns to 0 and the wheel grips again. The body stays eq 23
 *   (viscous + Coulomb friction) with the wheel forces summed as eqs 9-11. A step where no
 *   wheel slips (checked at both ends) is integrated exactly as above; otherwise it is split
 *   into substeps of at most PLANT_SUBSTEP_S, each exact per axis and per wheel with the
 *   gripping wheels' cross-axis back-EMF terms held from the substep's start.
 * - Radius error: wheel j's effective radius is r (1 + radius_error[j]): its force and
 *   back-EMF use that radius, and its angular speed is its ground speed / r (1 + e_j), so
 *   odometry with the model's r reads the ground speed / (1 + e_j).
 * - Motor errors: wheel j's motor + bridge resistance is R (1 + R_error[j]) and its motor
 *   constant Kv (1 + Kv_error[j]) (back-EMF), Kt (1 + Kv_error[j]) (torque: one motor constant,
 *   Kt = Kv in SI units): each wheel's force (eqs 12-13) and current (eq 21) use its own.
 * - Creep: a small continuous slip per wheel that scales with the wheel's ground speed v_j
 *   (eq 2): c_j |v_j|, c_j a first-order Gauss-Markov process (time constant
 *   PLANT_CREEP_TAU_S, standard deviation slip_noise, a share of the speed), added to the rim
 *   speed only (the body dynamics and the currents do not see it). A robot at rest reads 0.
 * - An external body force ext_force [Fv N, Fvn N, T N m] and a blocked body (velocity held at
 *   0, the wheels' motors still pushing: they stall, or slip beyond the traction limit), set
 *   by the caller between steps.
 * - A robot that changes as it runs, set by the caller between steps: each motor's resistance
 *   (a warm winding: plant_set_resistance; then the per-wheel path) and the body's friction
 *   (a new floor: plant_set_friction_scale).
 *
 * The layout (plant_set_geom; none given: the paper's four at 0/90/180/270 deg at d, the closed
 * forms above, to the last bit as without it). A layout given (struct wheel_geom: three or four
 * wheels, any angles and distances) replaces eq 2's rows, eqs 9-11's G^T, the loads and eq 23
 * with those of struct wheel_phys, prepared once (no trigonometry per step): rims G x, body
 * force G^T f, loads load0 + load_a a_c, and A = A_coast - m^-1 G^T diag(e) G,
 * B = m^-1 G^T diag(b), m = (M, M, J), e_j = b_j kemf_j. When A's off-diagonal entries vanish
 * to rounding (the paper's rows; three or four equal wheels evenly spaced at one distance) the
 * step stays exact per axis as above. Otherwise the back-EMF couples the axes, and x' = A x +
 * B u + K sgn(x) with a full A and Coulomb friction has no closed form per axis: a driven step
 * takes the substep path of the floor (substeps of at most PLANT_SUBSTEP_S, each exact in its
 * own axis's back-EMF with the other axes' held from the substep's start: an error of order
 * PLANT_SUBSTEP_S times the coupling, 1e-4 s x a few 1/s). With the H-bridges off there is no
 * back-EMF: A_coast is diagonal and the exact path holds for every layout. A three-wheel robot
 * has no motor in slot 3: its voltage is taken as 0, and it reports 0 V, 0 A, 0 rad/s, a load
 * of 0 and never slips.
 */
#ifndef OMNI4_PLANT_H
#define OMNI4_PLANT_H

#include <stdbool.h>
#include <stdint.h>

#include "omni4/model/dynamics.h"
#include "omni4/model/params.h"
#include "omni4/model/rng.h"
#include "omni4/model/wheels.h"

#define PLANT_SUBSTEP_S 1e-4  /* longest substep while a wheel slips [s] */
#define PLANT_CREEP_TAU_S 0.2 /* time constant of the creep process [s] */

struct plant_floor {
	double traction_mu;     /* wheel-floor friction coefficient; 0 = no traction limit */
	double wheel_inertia;   /* J_w: wheel + motor + gearbox reflected at the wheel [kg m^2] */
	double radius_error[4]; /* relative effective-radius error per wheel, |e| < 0.5 */
	double R_error[4];      /* relative resistance error per motor, |e| < 0.5 */
	double Kv_error[4];     /* relative motor-constant error (Kv and Kt), |e| < 0.5 */
	double slip_noise;      /* creep std dev, a share of the ground speed; 0 = none */
	double com_height;      /* centre of mass above the floor [m]: load transfer; 0 = none */
	uint64_t seed;          /* of the creep */
};

struct plant {
	struct model_params p;
	struct model_ss ss;
	double x[3];         /* robot velocity [v m/s, vn m/s, w rad/s] */
	double pose[3];      /* world pose [x m, y m, theta rad] */
	double current_a[4]; /* motor currents [A] */
	double voltage_v[4]; /* voltages applied in the last step [V] */
	bool driven;         /* H-bridges on in the last step */
	/* The floor (plant_set_floor) and its state. */
	struct plant_floor floor;
	double r_eff[4];                       /* effective wheel radii [m] */
	double R_eff[4], Kv_eff[4], Kt_eff[4]; /* each motor's own R, Kv, Kt (motor errors) */
	double rim[4];   /* wheel rim speeds r_eff_j w_j [m/s] (ground speed when gripping) */
	double creep[4]; /* creep process per wheel (share of the ground speed) */
	double acc[3];   /* body acceleration over the last (sub)step [m/s^2, m/s^2, rad/s^2] */
	bool slipping[4];
	int8_t slip_dir[4]; /* direction of a slip that has just started (slip velocity 0) */
	struct rng rng;     /* creep */
	/* Set by the caller, held until changed. */
	double ext_force[3];   /* external force on the body [Fv N, Fvn N, T N m] */
	bool blocked;          /* body held at rest (velocity 0, pose fixed) */
	double friction_scale; /* Bv..Cw of p scaled by it in ss (plant_set_friction_scale) */
	/* The layout (plant_set_geom); none: the paper's closed forms. */
	bool has_geom;
	bool coupled;           /* the layout's A not diagonal: driven steps take substeps */
	struct wheel_geom geom; /* as given */
	struct wheel_phys ph;   /* its rows, drives (nominal) and loads (floor's com_height) */
};

/* -EINVAL if p fails model_params_check. Starts at rest at the origin, the floor off. */
int plant_init(struct plant *pl, const struct model_params *p);
/* At rest at the origin, every wheel gripping, no external force, not blocked; the floor's
 * settings stay. */
void plant_reset(struct plant *pl);
/* The floor's settings (then plant_reset). -EINVAL if mu < 0, J_w <= 0 with mu > 0, an |e_j|
 * (radius, R or Kv error) >= 0.5, slip_noise < 0, com_height < 0 or anything not finite. */
int plant_set_floor(struct plant *pl, const struct plant_floor *f);
/* The wheels' layout from now on (then plant_reset); NULL: the paper's closed forms again, as
 * after plant_init. -EINVAL (nothing changed) for a layout wheel_phys_init refuses; kept across
 * plant_set_floor (which re-prepares its loads at the new com_height). */
int plant_set_geom(struct plant *pl, const struct wheel_geom *g);

/* Each motor + bridge resistance from now on [ohm] (R_eff; plant_set_floor sets them back to
 * R (1 + R_error_j)). Every R_j must be > 0 and finite (unchecked: the caller's model is). */
void plant_set_resistance(struct plant *pl, const double R_ohm[4]);
/* The body's viscous and Coulomb friction (Bv, Bvn, Bw, Cv, Cvn, Cw) scaled by scale (>= 0,
 * finite; unchecked) from now on; 1 after plant_init. */
void plant_set_friction_scale(struct plant *pl, double scale);

/*
 * Advance by dt [s] with voltages u [V] held (driven) or with the H-bridges off
 * (driven = false: u ignored, currents 0).
 */
void plant_step(struct plant *pl, const double u[4], bool driven, double dt);

/* Wheel angular speeds after the gearbox [rad/s]: the wheels' own, rim_j / r_eff_j (v_j / r
 * with the floor off). */
void plant_wheel_speeds(const struct plant *pl, double wheel_rad_s[4]);

/* Normal load per wheel [N] with the load transfer of the last (sub)step's acceleration, and
 * the drive-direction force each can hold, mu N_j [N] (0 without a traction limit). */
void plant_wheel_loads(const struct plant *pl, double normal_n[4], double hold_n[4]);

/* Slip velocity per wheel [m/s]: rim speed minus the ground speed at the wheel (eq 2). */
void plant_wheel_slip(const struct plant *pl, double slip_m_s[4]);
/* Bit j set: wheel j slips (beyond the traction limit; creep alone is not a slip). */
uint32_t plant_slip_flags(const struct plant *pl);

#endif /* OMNI4_PLANT_H */
