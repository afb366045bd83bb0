/*
 * backends.h - which backend drives the motors and the lines: a robot's INI names one of each
 * ([hal] motor, [hal] lines). Enums and choice strings ("sim|socketcan") from backends.def, in
 * its rows' order; the INI key table takes the choices from here and the composition root
 * (firmware/ robot.c) maps each value onto the backend's code.
 *
 * OMNI4_BACKENDS_DEF names another row file (a test adds a row with it); default backends.def.
 */
#ifndef OMNI4_BACKENDS_H
#define OMNI4_BACKENDS_H

#ifndef OMNI4_BACKENDS_DEF
#define OMNI4_BACKENDS_DEF "omni4/drivers/backends.def"
#endif

/* One HAL's rows only: BACKEND_<HAL>_<hal>(...) keeps its arguments for its own HAL. */
#define BACKEND_MOTOR_MOTOR(...) __VA_ARGS__
#define BACKEND_MOTOR_LINES(...)
#define BACKEND_LINES_MOTOR(...)
#define BACKEND_LINES_LINES(...) __VA_ARGS__

/* Rows built here only: BACKEND_OS_<os>(...) keeps its arguments where the row's os column
 * (ANY, LINUX) is built. */
#define BACKEND_OS_ANY(...) __VA_ARGS__
#ifdef OMNI4_ROBOT_LINUX
#define BACKEND_OS_LINUX(...) __VA_ARGS__
#else
#define BACKEND_OS_LINUX(...)
#endif

/* The state column of a backend that needs none (no lines). */
struct backend_stateless {
	char unused;
};

/* [hal] motor */
enum omni4_motor_backend {
#define OMNI4_BACKEND(hal, name, ...) BACKEND_MOTOR_##hal(OMNI4_MOTOR_##name, )
#include OMNI4_BACKENDS_DEF
	OMNI4_MOTOR_COUNT
};
/* [hal] lines */
enum omni4_lines_backend {
#define OMNI4_BACKEND(hal, name, ...) BACKEND_LINES_##hal(OMNI4_LINES_##name, )
#include OMNI4_BACKENDS_DEF
	OMNI4_LINES_COUNT
};

#endif /* OMNI4_BACKENDS_H */
