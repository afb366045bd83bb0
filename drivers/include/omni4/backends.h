/*
 * backends.h - which backend drives the motors and the lines: a robot's INI names one of each
 * ([hal] motor, [hal] lines); the INI key table holds these names in the enums' order and the
 * composition root (firmware/ robot.c) maps each value onto the backend's code.
 */
#ifndef OMNI4_BACKENDS_H
#define OMNI4_BACKENDS_H

/* [hal] motor: "sim|socketcan". */
enum omni4_motor_backend { OMNI4_MOTOR_SIM = 0, OMNI4_MOTOR_SOCKETCAN = 1 };
/* [hal] lines: "none|sim|gpiod". */
enum omni4_lines_backend { OMNI4_LINES_NONE = 0, OMNI4_LINES_SIM = 1, OMNI4_LINES_GPIOD = 2 };

#endif /* OMNI4_BACKENDS_H */
