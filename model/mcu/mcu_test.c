/* mcu_test.c - the model on the Cortex-M4F: fixed-point IK and feedforward against their double
 * twins over the operating envelope, run under qemu-system-arm (mps2-an386, semihosting).
 * Prints "N passed, M failed". The double twin uses the soft-double helpers; the fixed-point
 * path itself is checked separately to need none (check_no_undefined.cmake). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "omni4/model/dynamics.h"
#include "omni4/model/feedforward.h"
#include "omni4/model/kinematics.h"
#include "omni4/model/params.h"
#include "omni4/model/rng.h"

/* The per-wheel model (docs/model.md) on this core: equal wheels give the scalar bits (soft
 * double over 200 parameter sets, and Q16.16), and the per-wheel fixed-point feedforward and
 * wheel-rate kinematics with wheels a few per cent apart stay near their double twins. */
static void wheels_checks(int *pass, int *fail)
{
	const struct model_params *p = &model_params_table3;
	struct model_wheels w;
	struct model_ss ss;
	struct model_ss_wheels sw;
	struct ff_q16 ff;
	struct ff_q16_wheels fw;
	struct rng g;
	int same = 1;

	rng_seed(&g, 7);
	for (int n = 0; n < 200; n++) { /* Table III's fields each scaled by 0.5 .. 2 */
		struct model_params q = *p;

		for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
			*model_params_field(&q, i) *= rng_uniform(&g, 0.5, 2.0);
		model_wheels_from_params(&q, &w);
		dyn_state_space(&q, &ss);
		dyn_state_space_wheels(&q, &w, &sw);
		for (int k = 0; k < 3; k++)
			same &= memcmp(&sw.A[k][k], &ss.A[k], sizeof(double)) == 0 &&
			        memcmp(sw.B[k], ss.B[k], sizeof(ss.B[k])) == 0;
	}
	model_wheels_from_params(p, &w);
	same &= ff_q16_init(&ff, p, 12.0) == 0 && ff_q16_wheels_init(&fw, p, &w, 12.0) == 0;
	const double scale[4] = {1.03, 0.96, 1.0, 1.05};
	double worst = 0;

	for (int j = 0; j < 4; j++) { /* a different robot for the twin comparison */
		w.R[j] *= scale[j];
		w.r[j] *= scale[3 - j];
		w.Kv[j] *= scale[(j + 1) % 4];
	}
	struct ff_q16_wheels fo;

	same &= ff_q16_wheels_init(&fo, p, &w, 12.0) == 0;
	for (int n = 0; n < 500; n++) {
		const double vel[3] = {rng_uniform(&g, -3, 3), rng_uniform(&g, -3, 3),
		                       rng_uniform(&g, -20, 20)};
		const double acc[3] = {rng_uniform(&g, -10, 10), rng_uniform(&g, -10, 10),
		                       rng_uniform(&g, -10, 10)};
		q16_t vq[3], aq[3], u1[4], u2[4];
		double u[4];

		for (int k = 0; k < 3; k++) {
			vq[k] = q16_from_double(vel[k]);
			aq[k] = q16_from_double(acc[k]);
		}
		ff_voltages_q16(&ff, vq, aq, u1);
		ff_voltages_q16_wheels(&fw, vq, aq, u2);
		same &= memcmp(u1, u2, sizeof(u1)) == 0;
		ff_voltages_wheels(p, &w, vel, acc, 12.0, u);
		ff_voltages_q16_wheels(&fo, vq, aq, u2);
		for (int j = 0; j < 4; j++)
			worst = fmax(worst, fabs(q16_to_double(u2[j]) - u[j]));
	}
	struct kin_wheels_q16 kq;
	const q16_t x[3] = {q16_from_double(1.0), q16_from_double(-0.5), q16_from_double(2.0)};
	q16_t rate[4], back[3];
	int round_trip = kin_wheels_q16_init(&kq, p->d, w.r) == 0;

	ik_wheel_rates_q16(&kq, x, rate);
	fk_robot_velocity_rates_q16(&kq, rate, back);
	for (int k = 0; k < 3; k++)
		round_trip &= fabs(q16_to_double(back[k]) - q16_to_double(x[k])) < 1e-3;
	const int ok = same && worst <= 2e-3 && round_trip;

	*pass += ok;
	*fail += !ok;
	printf("cortex-m4: per-wheel model: equal wheels %s the scalar bits; feedforward q16 vs "
	       "double, 500 points: max |du| = %.3g mV; rates round trip %s\n",
	       same ? "give" : "DO NOT give", worst * 1e3, round_trip ? "ok" : "FAILED");
}

int main(void)
{
	struct ff_q16 ff;
	struct rng g;
	int pass = 0, fail = 0;
	double worst = 0;

	if (ff_q16_init(&ff, &model_params_table3, 12.0)) {
		printf("ff_q16_init failed\n0 passed, 1 failed\n");
		return 1;
	}
	rng_seed(&g, 5);
	for (int n = 0; n < 2000; n++) {
		const double vel[3] = {rng_uniform(&g, -3, 3), rng_uniform(&g, -3, 3),
		                       rng_uniform(&g, -20, 20)};
		const double acc[3] = {rng_uniform(&g, -10, 10), rng_uniform(&g, -10, 10),
		                       rng_uniform(&g, -10, 10)};
		q16_t vq[3], aq[3], uq[4];
		double u[4];

		for (int k = 0; k < 3; k++) {
			vq[k] = q16_from_double(vel[k]);
			aq[k] = q16_from_double(acc[k]);
		}
		ff_voltages(&model_params_table3, vel, acc, 12.0, u);
		ff_voltages_q16(&ff, vq, aq, uq);
		for (int j = 0; j < 4; j++) {
			const double e = fabs(q16_to_double(uq[j]) - u[j]);

			worst = e > worst ? e : worst;
		}
	}
	if (worst <= 2e-3)
		pass++;
	else
		fail++;
	printf("cortex-m4: feedforward q16 vs double, 2000 points: max |du| = %.3g mV\n",
	       worst * 1e3);

	const q16_t x[3] = {q16_from_double(1.0), q16_from_double(-0.5), q16_from_double(2.0)};
	q16_t v[4], back[3];

	ik_wheel_speeds_q16(ff.d, x, v);
	fk_robot_velocity_q16(q16_from_double(1.0 / (4 * 0.089)), v, back);
	int ok = 1;

	for (int k = 0; k < 3; k++)
		ok &= fabs(q16_to_double(back[k]) - q16_to_double(x[k])) < 1e-3;
	if (ok)
		pass++;
	else
		fail++;
	printf("cortex-m4: IK -> FK round trip %s\n", ok ? "ok" : "FAILED");
	wheels_checks(&pass, &fail);
	/* Cost of one tick's IK + feedforward, fixed point and its double twin (soft double on this
	 * core): SysTick across 1000 calls. Under qemu -icount virtual time advances per
	 * instruction, so SysTick counts instructions; the scale is calibrated on a loop of 100
	 * NOPs (an emulator count, not silicon cycles). */
	volatile uint32_t *const syst = (volatile uint32_t *)0xE000E010;

	syst[1] = 0xFFFFFF; /* RVR */
	syst[2] = 0;        /* CVR */
	syst[0] = 5;        /* CSR: enable, processor clock */
	uint32_t c0 = syst[2];

	for (int n = 0; n < 1000; n++)
		__asm volatile(".rept 100\n nop\n .endr");
	const uint32_t cal = (c0 - syst[2]) & 0xFFFFFF; /* ticks for ~101000 instructions */
	q16_t u[4];
	uint32_t t0 = syst[2];

	for (int n = 0; n < 1000; n++) {
		ik_wheel_speeds_q16(ff.d, x, v);
		ff_voltages_q16(&ff, x, x, u);
	}
	const uint32_t fixed_ticks = (t0 - syst[2]) & 0xFFFFFF;
	struct model_wheels mw;
	struct ff_q16_wheels fw;

	model_wheels_from_params(&model_params_table3, &mw);
	ff_q16_wheels_init(&fw, &model_params_table3, &mw, 12.0);
	t0 = syst[2];
	for (int n = 0; n < 1000; n++) {
		ik_wheel_speeds_q16(ff.d, x, v);
		ff_voltages_q16_wheels(&fw, x, x, u);
	}
	const uint32_t wheels_ticks = (t0 - syst[2]) & 0xFFFFFF;
	const double xd[3] = {1.0, -0.5, 2.0};
	double vd[4], ud[4];

	t0 = syst[2];
	for (int n = 0; n < 100; n++) { /* 100 calls: keeps SysTick inside its 24 bits */
		ik_wheel_speeds(model_params_table3.d, xd, vd);
		ff_voltages(&model_params_table3, xd, xd, 12.0, ud);
		__asm volatile("" ::"r"(vd), "r"(ud) : "memory");
	}
	const uint32_t double_ticks = (t0 - syst[2]) & 0xFFFFFF;

	printf("cortex-m4: IK + feedforward per tick: Q16.16 %lu instructions, double twin %lu "
	       "(qemu -icount, calibrated on NOPs, incl. call and loop overhead)\n",
	       (unsigned long)((uint64_t)fixed_ticks * 101000 / cal / 1000),
	       (unsigned long)((uint64_t)double_ticks * 101000 / cal / 100));
	printf(
	    "cortex-m4: IK + per-wheel feedforward per tick: Q16.16 %lu instructions (as above)\n",
	    (unsigned long)((uint64_t)wheels_ticks * 101000 / cal / 1000));
	printf("%d passed, %d failed\n", pass, fail);
	return fail ? 1 : 0;
}
