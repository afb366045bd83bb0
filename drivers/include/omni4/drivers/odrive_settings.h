/*
 * odrive_settings.h - the "odrive" motor backend's settings ([odrive]): the interface, the four
 * axes' CANSimple node ids and what the backend commands. Keys, defaults and ranges:
 * odrive_keys.def.
 */
#ifndef OMNI4_ODRIVE_SETTINGS_H
#define OMNI4_ODRIVE_SETTINGS_H

/* [odrive] mode: the command each tick carries (the index of its word in "torque"). */
enum odrive_mode { ODRIVE_MODE_TORQUE = 0 };

struct odrive_settings {
	char iface[16];        /* a network interface name: IFNAMSIZ with its NUL */
	int node[4];           /* CANSimple node id of wheel j's axis (axis.config.can.node_id) */
	int mode;              /* enum odrive_mode */
	int status_timeout_ms; /* an axis silent this long: FAULT_DRIVER_TIMEOUT */
};

#endif /* OMNI4_ODRIVE_SETTINGS_H */
