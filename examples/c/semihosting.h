/* Output and exit through ARM semihosting (QEMU -semihosting-config
 * enable=on, or a debugger), and a small number printer: no C library
 * needed. On a board without a debugger replace semihosting_print by your
 * UART's write. */

#ifndef SEMIHOSTING_H
#define SEMIHOSTING_H

#include <stdbool.h>
#include <stdint.h>

/* Writes a NUL-terminated string to the host's console (SYS_WRITE0). */
void semihosting_print(const char *s);

/* Ends the program (SYS_EXIT): QEMU exits with status 0 when ok, else 1. */
__attribute__((noreturn)) void semihosting_exit(bool ok);

/* Prints an integer in decimal. */
void print_int(int32_t v);

/* Prints a float with 7 significant digits ("0.02006106", "552.9318",
 * "1.234567e-7"); NaN and infinities as "NaN", "inf", "-inf". */
void print_float(float v);

/* Stack measurement: stack_paint() fills the free stack below the caller
 * with a pattern; stack_peak() is the most stack (bytes) used since, found
 * as the lowest word the pattern no longer holds. */
void stack_paint(void);
uint32_t stack_peak(void);

#endif
