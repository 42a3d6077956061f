#include "semihosting.h"

#define SYS_WRITE0 0x04
#define SYS_EXIT 0x18
#define ADP_Stopped_ApplicationExit 0x20026
#define ADP_Stopped_RunTimeErrorUnknown 0x20023

/* A semihosting call: operation in r0, argument in r1, `bkpt 0xAB`. */
static int semihosting_call(int op, const void *arg)
{
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void semihosting_print(const char *s)
{
    semihosting_call(SYS_WRITE0, s);
}

void semihosting_exit(bool ok)
{
    /* On 32-bit ARM, SYS_EXIT takes the reason code itself in r1. */
    uintptr_t reason = ok ? ADP_Stopped_ApplicationExit : ADP_Stopped_RunTimeErrorUnknown;
    for (;;)
        semihosting_call(SYS_EXIT, (const void *)reason);
}

/* Writes the decimal digits of v before `end`; returns the first one. */
static char *digits(char *end, uint32_t v)
{
    do {
        *--end = (char)('0' + v % 10);
        v /= 10;
    } while (v != 0);
    return end;
}

void print_int(int32_t v)
{
    char buf[12];
    char *p = digits(buf + sizeof buf - 1, v < 0 ? 0u - (uint32_t)v : (uint32_t)v);
    buf[sizeof buf - 1] = '\0';
    if (v < 0)
        *--p = '-';
    semihosting_print(p);
}

void print_float(float v)
{
    char buf[24];
    char *p = buf;
    if (v != v) {
        semihosting_print("NaN");
        return;
    }
    if (v < 0) {
        *p++ = '-';
        v = -v;
    }
    if (v > 3.4028235e38f) {
        *p++ = 'i', *p++ = 'n', *p++ = 'f', *p = '\0';
        semihosting_print(buf);
        return;
    }
    if (v == 0) {
        *p++ = '0', *p = '\0';
        semihosting_print(buf);
        return;
    }
    /* x = m * 10^(e - 6) with m a 7-digit integer (the scaling in double,
     * exact enough for 7 digits; doubles cost only a few libgcc calls). */
    double x = v;
    int e = 0;
    while (x >= 10.0)
        x /= 10.0, e++;
    while (x < 1.0)
        x *= 10.0, e--;
    uint32_t m = (uint32_t)(x * 1e6 + 0.5);
    if (m >= 10000000u)
        m /= 10, e++;
    char d[7];
    for (int k = 6; k >= 0; k--, m /= 10)
        d[k] = (char)('0' + m % 10);
    int n = 7; /* significant digits without trailing zeros */
    while (n > 1 && d[n - 1] == '0')
        n--;

    if (e >= -5 && e < 7) { /* fixed point: 0.0001234567 .. 1234567 */
        if (e < 0) {
            *p++ = '0', *p++ = '.';
            for (int k = -1; k > e; k--)
                *p++ = '0';
            for (int k = 0; k < n; k++)
                *p++ = d[k];
        } else {
            for (int k = 0; k <= e; k++)
                *p++ = k < n ? d[k] : '0';
            if (n > e + 1) {
                *p++ = '.';
                for (int k = e + 1; k < n; k++)
                    *p++ = d[k];
            }
        }
    } else { /* scientific: 1.234567e-7 */
        *p++ = d[0];
        if (n > 1) {
            *p++ = '.';
            for (int k = 1; k < n; k++)
                *p++ = d[k];
        }
        *p++ = 'e';
        if (e < 0)
            *p++ = '-', e = -e;
        char ebuf[4];
        char *q = digits(ebuf + sizeof ebuf, (uint32_t)e);
        while (q < ebuf + sizeof ebuf)
            *p++ = *q++;
    }
    *p = '\0';
    semihosting_print(buf);
}

extern uint32_t __stack_bottom, __stack_top;

#define STACK_PATTERN 0x5AC4DEADu

void stack_paint(void)
{
    uint32_t here;
    /* Leave 256 bytes below this frame untouched. */
    uint32_t *end = (uint32_t *)((uintptr_t)&here - 256u);
    for (volatile uint32_t *w = &__stack_bottom; w < end; w++)
        *w = STACK_PATTERN;
}

uint32_t stack_peak(void)
{
    const uint32_t *w = &__stack_bottom;
    while (w < &__stack_top && *w == STACK_PATTERN)
        w++;
    return (uint32_t)((uintptr_t)&__stack_top - (uintptr_t)w);
}
