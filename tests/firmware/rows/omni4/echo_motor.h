/* echo_motor.h - a test-only motor backend (rows/backends_echo.def): reads return the voltages
 * last written, and it counts what the robot asked of it. */
#ifndef OMNI4_ECHO_MOTOR_H
#define OMNI4_ECHO_MOTOR_H

#include <stdbool.h>

struct echo_motor {
	bool open, enabled;
	int started, reads, writes, summaries, closed;
	float volts[4];
};

#endif /* OMNI4_ECHO_MOTOR_H */
