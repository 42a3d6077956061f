/* Start-up of the C example on a Cortex-M4F: the vector table and the reset
 * handler (copy .data, zero .bss, enable the FPU, call main). A vendor's
 * start-up file does the same; keep yours if you have one, but check that
 * it enables the FPU before any code built with -mfloat-abi=hard runs. */

#include <stdint.h>

#include "semihosting.h"

extern uint32_t __stack_top, __data_start, __data_end, __data_load, __bss_start, __bss_end;

int main(void);
void Reset_Handler(void);
void Fault_Handler(void);

/* Initial stack pointer, then the exception handlers (the mps2-an386's
 * interrupts are not used by this example). */
__attribute__((section(".vectors"), used))
static void (*const vector_table[16])(void) = {
    (void (*)(void))&__stack_top,
    Reset_Handler,
    Fault_Handler, /* NMI */
    Fault_Handler, /* HardFault */
    Fault_Handler, /* MemManage */
    Fault_Handler, /* BusFault */
    Fault_Handler, /* UsageFault */
    0, 0, 0, 0,
    Fault_Handler, /* SVCall */
    Fault_Handler, /* DebugMonitor */
    0,
    Fault_Handler, /* PendSV */
    Fault_Handler, /* SysTick */
};

void Reset_Handler(void)
{
    /* Initialised variables: copy their values from flash to RAM. */
    const uint32_t *src = &__data_load;
    for (uint32_t *dst = &__data_start; dst < &__data_end;)
        *dst++ = *src++;
    /* Zero-initialised variables (the estimator's state buffer is here). */
    for (uint32_t *dst = &__bss_start; dst < &__bss_end;)
        *dst++ = 0;

    /* Enable the FPU: full access to coprocessors CP10 and CP11. */
    volatile uint32_t *const CPACR = (volatile uint32_t *)0xE000ED88u;
    *CPACR |= 0xFu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");

    int rc = main();
    semihosting_exit(rc == 0);
}

void Fault_Handler(void)
{
    semihosting_print("fault: unexpected exception (HardFault, stack overflow?)\n");
    semihosting_exit(0);
}
