/*
 * main.c - the controller core on the Cortex-M4F (MPS2 AN386 under qemu-system-arm): SysTick
 * interrupts at 1 kHz, the main loop sleeps (WFI) until the next one and then runs one tick of
 * the core against the sim backend. This is the flashable shape; a real board replaces the sim
 * backend with its CAN peripheral and GPIO (see README, "The controller on a microcontroller").
 *
 * Prints the HIL scenarios' lines over semihosting (the same lines as the host's
 * test_scenarios) and the per-tick cost in instructions. Under qemu -icount shift=0 one
 * instruction is one nanosecond of virtual time and SysTick counts the 25 MHz system clock of
 * virtual time, so SysTick measures instructions (40 per count): calibrated on a loop of NOPs,
 * an emulator figure (no caches, no wait states, no pipeline stalls), not silicon cycles. The
 * meter checks itself against known spans before the scenarios (meter_self_test).
 */
#include <stdint.h>
#include <stdio.h>

#include "scenarios.h"
#include "traj_cost.h"

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

/*
 * SysTick as a 64-bit count of its clock since it started, read without a race. SysTick counts
 * down RELOAD-1 .. 1, 0, then reloads; the interrupt (g_ms) counts the wraps. The value 0 is
 * the one state a read cannot place: qemu (7.2) shows it on both sides of the interrupt (the
 * handler has run or not), so a 0 read is read again (it lasts one count, 40 instructions,
 * once per millisecond). Any other value is placed by the wrap count read before and after it
 * (equal, else read again: the interrupt came between) and the pending bit read after it: a
 * wrap whose interrupt is pending but not yet taken (interrupts masked) counts when the value
 * is from after the reload (above RELOAD/2). COUNTFLAG is not used: reading CSR clears it.
 * DWT CYCCNT would need no interrupt, but qemu 7.2 does not model the DWT (on mps2-an386
 * DWT_CTRL and CYCCNT read 0 and do not count; DEMCR is a bad NVIC offset).
 */
static uint64_t counts(void)
{
	uint32_t ms, cvr, pend;

	do {
		ms = g_ms;
		cvr = SYST[2];
		pend = ICSR & ICSR_PENDSTSET;
	} while (cvr == 0 || ms != g_ms);
	const uint64_t wraps = (uint64_t)ms + (pend && cvr > RELOAD / 2u);

	return wraps * RELOAD + (RELOAD - 1u - cvr);
}

/* The meter's reading: counts in instructions, calibrated; differences are right mod 2^32. */
static uint32_t instructions(void)
{
	return (uint32_t)((counts() * g_instr_per_count_q8) >> 8);
}

/* ---- the meter's self-test: known spans measured (a failed check fails the run) ---------- */

#define KNOWN_LOOP_INSTR 102001u /* known_loop(): 1 + 1000 x (100 NOPs + subs + bne) */
#define INSTR_PER_COUNT 40u      /* -icount shift=0: 1 ns per instruction; SysTick 25 MHz */
#define SELFTEST_PERIODS 20u

/* Exactly KNOWN_LOOP_INSTR instructions, whatever the compiler does around it. */
static void known_loop(void)
{
	__asm volatile("mov r0, #1000\n"
	               "1:\n"
	               ".rept 100\n nop\n .endr\n"
	               "subs r0, r0, #1\n"
	               "bne 1b\n" ::
	                   : "r0", "cc");
}

/* Busy wait until the interrupt count changes: returns the count then. */
static uint32_t next_interrupt(void)
{
	const uint32_t ms = g_ms;

	while (g_ms == ms)
		;
	return g_ms;
}

/*
 * The count against spans known independently of it: (1) back-to-back reads over
 * SELFTEST_PERIODS wraps never step back nor jump (every phase of a wrap is read); (2) the known
 * loop, 40 times at phases that walk through the period, is KNOWN_LOOP_INSTR / 40 counts (+2
 * for an interrupt inside); (3) N interrupts apart is N x RELOAD counts (+-2: the same
 * interrupt latency at both ends). Prints one line; 0 if every check held.
 */
static int meter_self_test(void)
{
	uint64_t worst_step = 0, loop_lo = UINT64_MAX, loop_hi = 0;
	uint32_t backward = 0;
	const uint64_t loop_counts = KNOWN_LOOP_INSTR / INSTR_PER_COUNT;
	const uint32_t end = g_ms + SELFTEST_PERIODS;
	uint64_t prev = counts();

	while (g_ms < end) {
		const uint64_t now = counts();

		backward += now < prev;
		worst_step = now >= prev && now - prev > worst_step ? now - prev : worst_step;
		prev = now;
	}
	for (int i = 0; i < 40; i++) {
		const uint64_t c0 = counts();

		known_loop();
		const uint64_t c = counts() - c0;

		loop_lo = c < loop_lo ? c : loop_lo;
		loop_hi = c > loop_hi ? c : loop_hi;
	}
	next_interrupt();
	const uint64_t t0 = counts();

	for (uint32_t k = 0; k < SELFTEST_PERIODS; k++)
		next_interrupt();
	const uint64_t periods = counts() - t0;
	const uint64_t expect = (uint64_t)SELFTEST_PERIODS * RELOAD;
	const int bad = backward || worst_step > 100u || loop_lo + 1u < loop_counts ||
	                loop_hi > loop_counts + 2u || periods + 2u < expect ||
	                periods > expect + 2u;

	printf("cortex-m4: meter self-test %s: back-to-back reads over %lu wraps: %lu steps back, "
	       "largest step %lu counts; known loop (%lu instructions = %lu counts) read %lu..%lu; "
	       "%lu interrupts apart read %lu counts (%lu expected)\n",
	       bad ? "WRONG" : "passed", (unsigned long)SELFTEST_PERIODS, (unsigned long)backward,
	       (unsigned long)worst_step, (unsigned long)KNOWN_LOOP_INSTR,
	       (unsigned long)loop_counts, (unsigned long)loop_lo, (unsigned long)loop_hi,
	       (unsigned long)SELFTEST_PERIODS, (unsigned long)periods, (unsigned long)expect);
	return bad;
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
	/* Calibrate on the known loop (KNOWN_LOOP_INSTR instructions). */
	const uint64_t c0 = counts();

	known_loop();
	const uint32_t cal = (uint32_t)(counts() - c0);

	g_instr_per_count_q8 = cal ? (uint32_t)(((uint64_t)KNOWN_LOOP_INSTR << 8) / cal) : 0;
	const int meter_bad = meter_self_test();

	g_served = g_ms;

	static const struct scenario_meter meter = {
	    .read = instructions, .unit = "instructions (qemu -icount, calibrated on NOPs)"};

	scenarios_set_meter(&meter);
	printf("cortex-m4: SysTick 1 kHz, calibration %lu counts for %lu instructions\n",
	       (unsigned long)cal, (unsigned long)KNOWN_LOOP_INSTR);
	const int failed = scenarios_run(print_line, wait_tick);

	traj_cost(instructions, meter.unit, print_line);

	printf("cortex-m4: %lu SysTick interrupts; %lu ticks found their interrupt already fired "
	       "(each scenario's set-up runs between two ticks)\n",
	       (unsigned long)g_ms, (unsigned long)g_no_wait);
	return failed || meter_bad ? 1 : 0;
}
