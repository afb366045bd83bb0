/*
 * sim_settings.h - the sensors of the "sim" motor backend as a robot's INI sets them ([sim]):
 * noise, encoder resolution, the camera, and the sensor faults a test can ask for. Keys,
 * defaults and ranges: sim_keys.def.
 */
#ifndef OMNI4_SIM_SETTINGS_H
#define OMNI4_SIM_SETTINGS_H

#include <stdbool.h>

struct sim_settings {
	double current_noise_a; /* std dev [A] */
	int encoder_cpr;        /* counts per wheel revolution; 0 = ideal */
	double camera_rate_hz;
	double camera_pos_noise_m;     /* std dev [m] */
	double camera_theta_noise_rad; /* std dev [rad] */
	int seed;
	/* Sensor faults (0: none) */
	double current_offset_a[4];  /* added to each channel's current readings [A] */
	double encoder_eccentricity; /* motor-shaft encoder reads theta + e sin(theta - phi) */
	/* The floor and the camera's timing (0: off; plant.h) */
	double traction_mu;           /* wheel-floor friction; 0 = no traction limit */
	double wheel_inertia;         /* reflected at the wheel [kg m^2] */
	double wheel_radius_error[4]; /* relative effective-radius error per wheel */
	double motor_R_error[4];      /* relative motor + bridge resistance error per motor */
	double motor_Kv_error[4];     /* relative motor-constant (Kv, Kt) error per motor */
	double slip_noise;            /* creep std dev, a share of the ground speed */
	double com_height;            /* centre of mass above the floor [m] (load transfer) */
	double camera_latency_ms;     /* capture -> delivery [ms] */
	/* A robot that changes as it runs (off: the plant above, to the last bit) */
	bool thermal;                /* each winding's R follows its temperature */
	double thermal_resistance;   /* winding to ambient [K/W] */
	double thermal_capacity;     /* winding heat capacity [J/K] */
	double ambient;              /* [deg C] */
	bool battery;                /* the supply sags as a battery's */
	double battery_capacity;     /* [Ah] */
	double battery_resistance;   /* internal [ohm] */
	double floor_change_s;       /* simulated time the floor changes [s]; 0 = never */
	double floor_friction_scale; /* the body's B and C times this from then on */
	bool current_drive;          /* the motors behind a current drive (sim_motor.h) */
	/* The lockstep simulator only (sil/) */
	bool truth;    /* log the plant's true state (OMNI4_SIM_TRUTH) */
	bool estimate; /* run the state estimator (OMNI4_STATE) */
};

/* The defaults of sim_keys.def: the paper's set-up (1 cm / 3 deg camera at 25 Hz, ...). */
void sim_settings_defaults(struct sim_settings *s);

#endif /* OMNI4_SIM_SETTINGS_H */
