/*
 * socketcan_settings.h - the "socketcan" motor backend's settings ([can]): the interface, its
 * bit rate and the driver boards' silence timeout. Keys, defaults and ranges: socketcan_keys.def.
 */
#ifndef OMNI4_SOCKETCAN_SETTINGS_H
#define OMNI4_SOCKETCAN_SETTINGS_H

struct socketcan_settings {
	char iface[16];        /* a network interface name: IFNAMSIZ with its NUL */
	int bitrate;           /* [bit/s], as set with ip link */
	int status_timeout_ms; /* a board silent this long: FAULT_DRIVER_TIMEOUT */
};

#endif /* OMNI4_SOCKETCAN_SETTINGS_H */
