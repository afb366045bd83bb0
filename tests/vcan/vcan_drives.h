/* vcan_drives.h - vcan_check's checks on simulated VESCs and ODrives (vcan_drives.c). */
#ifndef OMNI4_VCAN_DRIVES_H
#define OMNI4_VCAN_DRIVES_H

#include <stdbool.h>

/* drivestop: SIGKILL the controller fw_pid while it drives; 0 when every drive stopped on its
 * own within max_s seconds (timeout_s, the drive's own timeout, is printed beside the figure). */
int vcan_drive_stop(const char *iface, bool odrive, int fw_pid, double max_s, double timeout_s);

/* goal: a goal offset (x m, y m, theta rad) from the simulated truth's pose; 0 when REACHED
 * within max_s seconds and the truth is then within 1 cm and 1 deg of it, or when the goal
 * cannot be judged: the emulated controller starved, or the simulated world paused during it
 * (motorsim_log, omni4-motorsim's stderr, says so; NULL: not watched). */
int vcan_goal(const double offset[3], double max_s, const char *motorsim_log);

#endif /* OMNI4_VCAN_DRIVES_H */
