/* fracbms from C on a Cortex-M4F: estimate one cell's R_i, R_ct, Q, alpha
 * and U_oc from a replayed record.
 *
 * The record comes from record.h (written by `cargo xtask c-demo`): on a
 * real board the samples come from your ADC instead, one (current,
 * voltage) pair per sample period. */

#include <stddef.h>
#include <stdint.h>

#include "fracbms.h"
#include "record.h"
#include "semihosting.h"

/* The cell's whole state lives in this static buffer (in .bss): the library
 * never allocates. fracbms_cell_size() says how much a window/memory needs
 * (about 30 KB for window 256, memory 64); check it at start-up. */
#ifndef STATE_BYTES
#define STATE_BYTES (34u * 1024u)
#endif
static uint8_t state[STATE_BYTES] __attribute__((aligned(8)));

static FracbmsCell *cell;

static int fail(const char *what, FracbmsCode code)
{
    semihosting_print("error: ");
    semihosting_print(what);
    semihosting_print(" returned ");
    print_int(code);
    semihosting_print(" (");
    semihosting_print(fracbms_code_message(code));
    semihosting_print(")\n");
    return 1;
}

/* One sample period: call this from your timer task or ADC-complete
 * interrupt, every RECORD_H seconds (settings.h), and from that context
 * only: no other call may use the same cell meanwhile. It never allocates;
 * a NaN or implausible reading is rejected (counted in est->rejected)
 * rather than returned as an error. */
static FracbmsCode on_sample(float current_a, float voltage_v, FracbmsEstimate *est)
{
    return fracbms_cell_push(cell, current_a, voltage_v, est);
}

int main(void)
{
    FracbmsSettings settings;
    FracbmsCode rc = fracbms_settings_default(RECORD_H, &settings);
    if (rc != FRACBMS_OK)
        return fail("fracbms_settings_default", rc);
    /* Defaults: window 256, memory 64, the Rust firmware's settings. */
#ifdef RECORD_OCV_POINTS
    /* The cell's OCV table (read only during init) and capacity: the
     * estimator then also tracks the state of charge. */
    settings.ocv_soc = RECORD_OCV_SOC;
    settings.ocv_v = RECORD_OCV_V;
    settings.ocv_points = RECORD_OCV_POINTS;
    settings.capacity_ah = RECORD_CAPACITY_AH;
#endif

    size_t size, align;
    rc = fracbms_cell_size(settings.window, settings.memory, &size, &align);
    if (rc != FRACBMS_OK)
        return fail("fracbms_cell_size", rc);
    if (size > sizeof state || align > 8) {
        semihosting_print("error: the cell state needs ");
        print_int((int32_t)size);
        semihosting_print(" bytes aligned to ");
        print_int((int32_t)align);
        semihosting_print("; raise STATE_BYTES\n");
        return 1;
    }
    /* Needs a deep stack once: the state is built on the stack, then moved
     * into `state` (the STACK line below measures it; STACK_SIZE in
     * link.ld). */
    stack_paint();
    rc = fracbms_cell_init(state, sizeof state, &settings, &cell);
    if (rc != FRACBMS_OK)
        return fail("fracbms_cell_init", rc);
    uint32_t init_stack = stack_peak();
    semihosting_print("fracbms: cell state ");
    print_int((int32_t)size);
    semihosting_print(" bytes, window ");
    print_int(settings.window);
    semihosting_print(", memory ");
    print_int(settings.memory);
    semihosting_print(", h = ");
    print_float(settings.h);
    semihosting_print(" s, ");
    print_int(RECORD_ROWS);
    semihosting_print(" samples\n");

    FracbmsEstimate est;
    stack_paint();
    for (uint32_t k = 0; k < RECORD_ROWS; k++) {
        rc = on_sample(RECORD_CURRENT_A[k], RECORD_VOLTAGE_V[k], &est);
        if (rc != FRACBMS_OK)
            return fail("fracbms_cell_push", rc);
    }

    /* Stack used (bytes, from the stack's top) by init and by the pushes. */
    semihosting_print("STACK init=");
    print_int((int32_t)init_stack);
    semihosting_print(" push=");
    print_int((int32_t)stack_peak());
    semihosting_print("\n");
    semihosting_print("status ");
    semihosting_print(fracbms_status_name(est.status));
    semihosting_print("\n");
    if (!est.valid) {
        semihosting_print("error: no estimate after the record\n");
        return 1;
    }
    const FracbmsParameters *p = &est.parameters;
    semihosting_print("RESULT r_i=");
    print_float(p->r_i);
    semihosting_print(" r_ct=");
    print_float(p->r_ct);
    semihosting_print(" q=");
    print_float(p->q);
    semihosting_print(" alpha=");
    print_float(p->alpha);
    semihosting_print(" u_oc=");
    print_float(p->u_oc);
    semihosting_print(" samples=");
    print_int((int32_t)est.samples);
    semihosting_print(" rejected=");
    print_int((int32_t)est.rejected);
#ifdef RECORD_OCV_POINTS
    semihosting_print(" soc=");
    print_float(est.state_of_charge);
    semihosting_print(" ocv_offset_v=");
    print_float(est.ocv_offset);
#endif
    semihosting_print("\n");
    return 0;
}
