/*
 * vesc_settings.h - the "vesc" motor backend's settings ([vesc]): the interface, the four
 * controllers' CAN ids, the motors' pole pairs and what the backend commands. Keys, defaults
 * and ranges: vesc_keys.def.
 */
#ifndef OMNI4_VESC_SETTINGS_H
#define OMNI4_VESC_SETTINGS_H

/* [vesc] mode: the command each tick carries (the index of its word in "duty|current"). */
enum vesc_mode { VESC_MODE_DUTY = 0, VESC_MODE_CURRENT = 1 };

struct vesc_settings {
	char iface[16];        /* a network interface name: IFNAMSIZ with its NUL */
	int id[4];             /* controller CAN id of wheel j (VESC Tool: App Settings, General) */
	int pole_pairs;        /* motor pole pairs: ERPM = mechanical RPM x pole_pairs */
	int mode;              /* enum vesc_mode */
	int status_timeout_ms; /* a controller silent this long: FAULT_DRIVER_TIMEOUT */
};

#endif /* OMNI4_VESC_SETTINGS_H */
