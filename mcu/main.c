/*
 * main.c - the controller core on the Cortex-M4F (MPS2 AN386 under qemu-system-arm): SysTick
 * interrupts at 1 kHz, the main loop sleeps (WFI) until the next one and then runs one tick of
 * the core against the sim backend. This is the flashable shape; a real board replaces the sim
 * backend with its CAN peripheral and GPIO (see README, "The controller on a microcontroller").
 *
 * Prints the HIL scenarios' lines over semihosting (the same lines as the host's
 * test_scenarios) and the per-tick cost in instructions. Under qemu -icount shift=0 one
 * instruction is one nanosecond of virtual time and SysTick counts the 25 MHz system clock of
 * virtual time, so SysTick measures instructions: calibrated on a loop of NOPs, an emulator
 * figure (no caches, no wait states, no pipeline stalls), not silicon cycles.
 */
#include <stdint.h>
#include <stdio.h>

#include "scenarios.h"

#define SYST ((volatile uint32_t *)0xE000E010) /* CSR, RVR, CVR, CALIB */
#define SYSCLK_HZ 25000000u                    /* MPS2 AN386 system clock */
#define RELOAD (SYSCLK_HZ / 1000u)             /* 1 kHz */

static volatile uint32_t g_ms;        /* SysTick interrupts so far */
static uint32_t g_served;             /* ticks the main loop has run */
static uint32_t g_instr_per_count_q8; /* instructions per SysTick count, x256 */

void systick_handler(void);
void systick_handler(void)
{
	g_ms++;
}

#define ICSR (*(volatile uint32_t *)0xE000ED04) /* interrupt control and state */
#define ICSR_PENDSTSET (1u << 26)               /* SysTick exception pending */
#define WRAP_SETTLE 8u /* counts after a wrap within which its interrupt may not have run */

/* SysTick counts down from RELOAD-1; with the interrupt count it gives a running clock. Just
 * after the counter wraps, its interrupt is pending and then taken, but under qemu the counter
 * can read reloaded a little before the interrupt is even pending: a read there would miss that
 * millisecond (a span measured across it one RELOAD off). A pending interrupt counts; within
 * WRAP_SETTLE counts of a wrap with none pending, read again once they have passed (at most
 * WRAP_SETTLE counts late, once per millisecond at most). */
static uint32_t counts(void)
{
	uint32_t ms, cvr, pend;

	do {
		ms = g_ms;
		cvr = SYST[2];
		pend = ICSR & ICSR_PENDSTSET;
	} while (ms != g_ms || (!pend && cvr > RELOAD - 1u - WRAP_SETTLE));
	if (pend && cvr > RELOAD / 2u)
		ms++;
	return ms * RELOAD + (RELOAD - 1u - cvr);
}

static uint32_t instructions(void)
{
	return (uint32_t)(((uint64_t)counts() * g_instr_per_count_q8) >> 8);
}

static uint32_t g_no_wait; /* ticks whose interrupt had already fired: the loop was late */

/* The loop's pace: sleep until SysTick has fired once more than the ticks served. */
static void wait_tick(void)
{
	if (g_ms > g_served)
		g_no_wait++;
	while (g_ms <= g_served)
		__asm volatile("wfi");
	g_served = g_ms;
}

static void print_line(const char *line)
{
	printf("%s\n", line);
}

int main(void)
{
	SYST[1] = RELOAD - 1u; /* RVR */
	SYST[2] = 0;           /* CVR */
	SYST[0] = 7;           /* CSR: enable, interrupt, processor clock */

	/* The counter reloads on its first count: start once the first interrupt has come. */
	while (g_ms == 0)
		__asm volatile("wfi");
	/* Calibrate: 1000 x (100 NOPs + loop) = about 102000 instructions. */
	const uint32_t c0 = counts();

	for (int n = 0; n < 1000; n++)
		__asm volatile(".rept 100\n nop\n .endr");
	const uint32_t cal = counts() - c0;

	g_instr_per_count_q8 = cal ? (uint32_t)((102000ull << 8) / cal) : 0;
	g_served = g_ms;

	static const struct scenario_meter meter = {
	    .read = instructions, .unit = "instructions (qemu -icount, calibrated on NOPs)"};

	scenarios_set_meter(&meter);
	printf("cortex-m4: SysTick 1 kHz, calibration %lu counts for 102000 instructions\n",
	       (unsigned long)cal);
	const int failed = scenarios_run(print_line, wait_tick);

	printf("cortex-m4: %lu SysTick interrupts; %lu ticks found their interrupt already fired "
	       "(each scenario's set-up runs between two ticks)\n",
	       (unsigned long)g_ms, (unsigned long)g_no_wait);
	return failed ? 1 : 0;
}
