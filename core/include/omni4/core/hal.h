/*
 * hal.h - hardware abstraction for the control loop: one ops struct per device kind, an opaque
 * context, thin inline wrappers. The loop includes this header only, never a backend's.
 *
 * Calling context: every op marked "fast loop" runs inside the fixed-rate loop: it must not
 * block, allocate or log; it returns 0 or a negative errno. Each op says whether a backend must
 * provide it (mandatory) or may leave it NULL (optional: the wrapper then does what is said).
 */
#ifndef OMNI4_HAL_H
#define OMNI4_HAL_H

#include <errno.h>
#include <stdbool.h>
#include <stdint.h>

/* Driver-side faults of a motor backend (motor_sample.faults). The HAL's own vocabulary: the
 * controller maps them onto its fault bits (ctl.h). */
#define HAL_FAULT_DRIVER_TIMEOUT (1u << 0) /* a motor driver stopped reporting */
#define HAL_FAULT_DRIVER (1u << 1)         /* a motor driver reported a fault of its own */
#define HAL_FAULT_BUS (1u << 2)            /* the bus to the drivers is down (CAN bus-off) */

/* One reading of the four motor channels. */
struct motor_sample {
	float current_a[4];   /* measured motor current [A]; NaN if unknown */
	float wheel_rad_s[4]; /* wheel angular speed after the gearbox [rad/s]; NaN if unknown */
	float supply_v;       /* H-bridge supply [V]; NaN if not measured */
	uint32_t faults;      /* driver-side fault bits (HAL_FAULT_*), 0 if healthy */
};

/* A camera's pose as a backend hands it to the loop (pose_t). */
struct hal_pose {
	int64_t utime;  /* capture time [us] */
	double pose[3]; /* world x, y [m], theta [rad] */
};

/* A simulated plant's true state after a read's step (sim_truth_t). */
struct hal_truth {
	int64_t utime;        /* the step's end [us] */
	double pose[3];       /* world x, y [m], theta [rad] */
	double vel[3];        /* robot frame v, vn [m/s], w [rad/s] */
	double wheel_slip[4]; /* rim speed minus ground speed at the wheel [m/s] */
	uint32_t flags;       /* the simulator's truth flags (sim_truth_t) */
};

struct motor_hal_ops {
	/* Mandatory. Fast loop. Turn the H-bridges on (driving) or off (free-wheeling, no
	 * braking). */
	int (*enable)(void *ctx, bool on);
	/* Mandatory. Fast loop. Set the four channel voltages [V]; the caller has clamped them. */
	int (*write)(void *ctx, const float volts[4]);
	/* Mandatory. Fast loop. Latest reading; -EAGAIN if none is available yet. */
	int (*read)(void *ctx, struct motor_sample *out);
	/* Optional (NULL: nothing to clear, 0). Fast loop, on the tick that takes a
	 * MODE_CLEAR_FAULT command only: ask the drivers to clear their latched faults, without
	 * waiting for their answer (the next readings show it). */
	int (*clear_faults)(void *ctx);
	/* Optional (NULL: no camera behind this backend, -EAGAIN). Fast loop, right after read:
	 * the loop polls it until -EAGAIN. The next camera pose that fell due by that read, oldest
	 * first; one not taken before the next read is lost. */
	int (*read_pose)(void *ctx, struct hal_pose *out);
	/* Optional (NULL: no truth, -EAGAIN). Fast loop, right after read (whatever read
	 * returned): a simulated plant's true state after that read's step, once per read. */
	int (*read_truth)(void *ctx, struct hal_truth *out);
	/* Optional (NULL: the caller's 0 V / disable writes are the last word). Any thread, also a
	 * crash handler: async-signal-safe. Outputs off for good: every later enable / write is
	 * dropped, and the backend makes sure its own off command is the last one to reach the
	 * drivers even if another thread is in a write at that instant. */
	void (*halt)(void *ctx);
	/* Optional (NULL: nothing to release). Start-up / shutdown only. Outputs off, resources
	 * released. */
	void (*close)(void *ctx);
};

struct motor_hal {
	const struct motor_hal_ops *ops;
	void *ctx;
};

static inline int hal_motor_enable(const struct motor_hal *h, bool on)
{
	return h->ops->enable(h->ctx, on);
}

static inline int hal_motor_write(const struct motor_hal *h, const float volts[4])
{
	return h->ops->write(h->ctx, volts);
}

static inline int hal_motor_read(const struct motor_hal *h, struct motor_sample *out)
{
	return h->ops->read(h->ctx, out);
}

static inline int hal_motor_clear_faults(const struct motor_hal *h)
{
	return h->ops->clear_faults ? h->ops->clear_faults(h->ctx) : 0;
}

static inline int hal_motor_read_pose(const struct motor_hal *h, struct hal_pose *out)
{
	return h->ops->read_pose ? h->ops->read_pose(h->ctx, out) : -EAGAIN;
}

static inline int hal_motor_read_truth(const struct motor_hal *h, struct hal_truth *out)
{
	return h->ops->read_truth ? h->ops->read_truth(h->ctx, out) : -EAGAIN;
}

static inline void hal_motor_halt(const struct motor_hal *h)
{
	if (h->ops && h->ops->halt)
		h->ops->halt(h->ctx);
}

static inline void hal_motor_close(const struct motor_hal *h)
{
	if (h->ops && h->ops->close)
		h->ops->close(h->ctx);
}

/* Digital lines: e-stop input, enable output, status LED. */
struct line_hal_ops {
	/* Mandatory. Fast loop. *active = e-stop pressed (after the configured polarity). */
	int (*read_estop)(void *ctx, bool *active);
	/* Mandatory. Fast loop; also the crash path (async-signal-safe). Drive the enable output
	 * of the power stage. */
	int (*set_enable)(void *ctx, bool on);
	/* Mandatory. Fast loop. Status LED. */
	int (*set_led)(void *ctx, bool on);
	/* Optional (NULL: nothing to release). Start-up / shutdown only. Lines released (enable
	 * low). */
	void (*close)(void *ctx);
};

struct line_hal {
	const struct line_hal_ops *ops;
	void *ctx;
};

static inline int hal_line_read_estop(const struct line_hal *h, bool *active)
{
	return h->ops->read_estop(h->ctx, active);
}

static inline int hal_line_set_enable(const struct line_hal *h, bool on)
{
	return h->ops->set_enable(h->ctx, on);
}

static inline int hal_line_set_led(const struct line_hal *h, bool on)
{
	return h->ops->set_led(h->ctx, on);
}

static inline void hal_line_close(const struct line_hal *h)
{
	if (h->ops && h->ops->close)
		h->ops->close(h->ctx);
}

/* A line backend with nothing wired: e-stop never active, outputs ignored. */
extern const struct line_hal_ops line_none_ops;

#endif /* OMNI4_HAL_H */
