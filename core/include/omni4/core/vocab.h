/*
 * vocab.h - the robot's vocabulary in C, expanded from vocab.def (the one place modes, fault
 * bits and state flags are written): the mode enum, the fault and flag bits, their bit sets
 * and the predicates every layer asks (does a mode drive the bridges, need keep-alive, is it a
 * fault state, may a command name it). Freestanding C11: no OS, no allocation; also compiled
 * into the Python package's model library (python/setup.py).
 *
 * OMNI4_VOCAB_DEF names another row file (a test adds a row with it); default vocab.def.
 */
#ifndef OMNI4_VOCAB_H
#define OMNI4_VOCAB_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifndef OMNI4_VOCAB_DEF
#define OMNI4_VOCAB_DEF "omni4/core/vocab.def"
#endif

/* Controller modes (command_t.mode, motors_t.mode). */
enum ctl_mode {
#define OMNI4_MODE(name, value, ...) CTL_##name = value,
#include OMNI4_VOCAB_DEF
};

/* Fault and state bits of motors_t.faults (ctl_output.faults). */
enum ctl_fault_bit {
#define OMNI4_FAULT(name, bit, ...) CTL_FAULT_##name = bit,
#include OMNI4_VOCAB_DEF
};

/* The estimator's state flags (state_t.flags, est_output.flags). */
enum est_flag_bit {
#define OMNI4_FLAG(name, bit, ...) EST_FLAG_##name = bit,
#include OMNI4_VOCAB_DEF
};

/* The columns as bit sets over the mode values (bit m: mode m), and the latching faults. */
#define VOCAB_WIRE_CMD 1
#define VOCAB_WIRE_STATE 2
#define VOCAB_WIRE_BOTH 3
#define VOCAB_MODE_BIT(value, yes) ((yes) ? UINT32_C(1) << (value) : 0u)
enum {
#define OMNI4_MODE(name, value, wire, drives, keep, faulted, doc) | VOCAB_MODE_BIT(value, drives)
	CTL_MODES_DRIVEN = 0u
#include OMNI4_VOCAB_DEF
	,
#define OMNI4_MODE(name, value, wire, drives, keep, faulted, doc) | VOCAB_MODE_BIT(value, keep)
	CTL_MODES_KEEP_ALIVE = 0u
#include OMNI4_VOCAB_DEF
	,
#define OMNI4_MODE(name, value, wire, drives, keep, faulted, doc) | VOCAB_MODE_BIT(value, faulted)
	CTL_MODES_FAULTED = 0u
#include OMNI4_VOCAB_DEF
	,
#define OMNI4_MODE(name, value, wire, ...) | VOCAB_MODE_BIT(value, VOCAB_WIRE_##wire & 1)
	CTL_MODES_COMMAND = 0u
#include OMNI4_VOCAB_DEF
	,
#define OMNI4_MODE(name, value, wire, ...) | VOCAB_MODE_BIT(value, VOCAB_WIRE_##wire & 2)
	CTL_MODES_REPORTED = 0u
#include OMNI4_VOCAB_DEF
	,
#define OMNI4_FAULT(name, bit, latching, doc) | ((latching) ? (bit) : 0)
	CTL_FAULTS_LATCHING = 0
#include OMNI4_VOCAB_DEF
	,
#define OMNI4_FAULT(name, bit, latching, doc) | (bit)
	CTL_FAULTS_ALL = 0
#include OMNI4_VOCAB_DEF
};

static inline bool vocab_mode_in(uint32_t set, int mode)
{
	return mode >= 0 && mode < 32 && ((set >> mode) & 1u);
}

/* The bridges are driven (volts applied) in this mode. */
static inline bool mode_drives(int mode)
{
	return vocab_mode_in(CTL_MODES_DRIVEN, mode);
}

/* The watchdog stops this mode when motion commands stop coming. */
static inline bool mode_keep_alive(int mode)
{
	return vocab_mode_in(CTL_MODES_KEEP_ALIVE, mode);
}

/* A fault state (FAULT, ESTOP): left only by CLEAR_FAULT once the cause is gone. */
static inline bool mode_faulted(int mode)
{
	return vocab_mode_in(CTL_MODES_FAULTED, mode);
}

/* A command may name this mode (command_t.mode). */
static inline bool mode_commandable(int mode)
{
	return vocab_mode_in(CTL_MODES_COMMAND, mode);
}

/* The mode's name ("IDLE", ...), NULL for a value that names no mode. */
static inline const char *mode_name(int mode)
{
	switch (mode) {
#define OMNI4_MODE(name, value, ...)                                                               \
	case value:                                                                                \
		return #name;
#include OMNI4_VOCAB_DEF
	default:
		return NULL;
	}
}

/* The FAULT_* name of one bit ("OVERCURRENT", ...), NULL for a bit that names no fault. */
static inline const char *fault_name(int32_t bit)
{
	switch (bit) {
#define OMNI4_FAULT(name, bit_, ...)                                                               \
	case bit_:                                                                                 \
		return #name;
#include OMNI4_VOCAB_DEF
	default:
		return NULL;
	}
}

#endif /* OMNI4_VOCAB_H */
