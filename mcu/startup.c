/* startup.c - minimal Cortex-M4F start-up for the bare-metal images: vector table, .data/.bss
 * set-up, FPU on, semihosting handles, main, exit code to the debugger (qemu -semihosting). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

extern uint32_t __etext, __data_start__, __data_end__, __bss_start__, __bss_end__, __stack_top;
extern int main(void);
extern void initialise_monitor_handles(void);
extern void __libc_init_array(void);
void reset_handler(void);
void default_handler(void);
/* An image that runs a timer defines its own; otherwise an interrupt ends the run (exit 3). */
void systick_handler(void) __attribute__((weak, alias("default_handler")));

void default_handler(void)
{
	exit(3);
}

__attribute__((section(".vectors"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(&__stack_top),
    reset_handler,
    default_handler,
    default_handler,
    default_handler,
    default_handler,
    default_handler,
    0,
    0,
    0,
    0,
    default_handler,
    default_handler,
    0,
    default_handler,
    systick_handler,
};

void reset_handler(void)
{
	memcpy(&__data_start__, &__etext,
	       (size_t)((char *)&__data_end__ - (char *)&__data_start__));
	memset(&__bss_start__, 0, (size_t)((char *)&__bss_end__ - (char *)&__bss_start__));
	/* CPACR: full access to CP10/CP11 (the FPU) before any float instruction. */
	*(volatile uint32_t *)0xE000ED88 |= 0xFu << 20;
	__asm volatile("dsb\n isb");
	initialise_monitor_handles();
	__libc_init_array();
	exit(main());
}
