/* Host test of the fracbms C API: replays a record and checks the error
 * paths. Build and run (from the workspace root):
 *
 *   cargo build -p estimator-ffi --release
 *   cc -std=c11 -O2 -Wall -Wextra -Iinclude examples/c/host_test.c \
 *      target/release/libfracbms.a -lpthread -ldl -lm -o target/host_test
 *   target/host_test firmware/data/cell-pulse.csv
 *
 * The record is `time_s,current_a,voltage_v` (other columns ignored; an
 * empty cell is NaN; a gap in time is pushed as NaN samples). Prints the
 * same RESULT line as the firmware example; exits 1 if any check fails. */

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fracbms.h"

static int failures;

#define CHECK(cond)                                                                 \
    do {                                                                            \
        if (!(cond)) {                                                              \
            fprintf(stderr, "host_test: check failed (line %d): %s\n", __LINE__, #cond); \
            failures++;                                                             \
        }                                                                           \
    } while (0)

#define CHECK_CODE(call, want)                                                           \
    do {                                                                                 \
        FracbmsCode got_ = (call);                                                       \
        if (got_ != (want)) {                                                            \
            fprintf(stderr, "host_test: check failed (line %d): %s returned %d, not %s (%d)\n", \
                    __LINE__, #call, (int)got_, #want, (int)(want));                    \
            failures++;                                                                  \
        }                                                                                \
    } while (0)

/* A zeroed buffer of `size` bytes aligned to `align` (at least 16). */
static void *aligned_buffer(size_t size, size_t align)
{
    if (align < 16)
        align = 16;
    void *p = aligned_alloc(align, (size + align - 1) / align * align);
    if (!p) {
        fprintf(stderr, "host_test: out of memory\n");
        exit(1);
    }
    memset(p, 0, size);
    return p;
}

/* Index of `name` in the comma-separated header `line`, or -1. */
static int column(const char *line, const char *name)
{
    size_t n = strlen(name);
    const char *p = line;
    for (int k = 0;; k++) {
        p += strspn(p, " ");
        /* strchr also matches the terminating NUL: the last column. */
        if (strncmp(p, name, n) == 0 && strchr(", \r\n", p[n]))
            return k;
        p = strchr(p, ',');
        if (!p)
            return -1;
        p++;
    }
}

/* Field `k` of a CSV line as a number; NaN when empty. */
static double field(const char *line, int k)
{
    const char *p = line;
    for (int j = 0; j < k && p; j++) {
        p = strchr(p, ',');
        if (p)
            p++;
    }
    if (!p)
        return NAN;
    char *end;
    double v = strtod(p, &end);
    return end == p ? NAN : v;
}

/* Replays `path` through a fresh cell; prints the RESULT line. */
static int replay(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "host_test: %s: cannot open\n", path);
        return 1;
    }
    static char line[4096];
    if (!fgets(line, sizeof line, f)) {
        fprintf(stderr, "host_test: %s: empty\n", path);
        fclose(f);
        return 1;
    }
    int ct = column(line, "time_s"), ci = column(line, "current_a"), cv = column(line, "voltage_v");
    if (ct < 0 || ci < 0 || cv < 0) {
        fprintf(stderr, "host_test: %s: the header must have time_s,current_a,voltage_v\n", path);
        fclose(f);
        return 1;
    }
    /* Read the rows; h is the first time step. */
    size_t rows = 0, cap = 1024;
    double *t = malloc(cap * sizeof *t), *cur = malloc(cap * sizeof *cur), *volt = malloc(cap * sizeof *volt);
    while (t && cur && volt && fgets(line, sizeof line, f)) {
        if (line[0] == '\n' || line[0] == '\r' || line[0] == '\0')
            continue;
        if (rows == cap) {
            cap *= 2;
            t = realloc(t, cap * sizeof *t);
            cur = realloc(cur, cap * sizeof *cur);
            volt = realloc(volt, cap * sizeof *volt);
            if (!t || !cur || !volt)
                break;
        }
        t[rows] = field(line, ct);
        cur[rows] = field(line, ci);
        volt[rows] = field(line, cv);
        rows++;
    }
    fclose(f);
    if (!t || !cur || !volt) {
        fprintf(stderr, "host_test: out of memory\n");
        exit(1);
    }
    if (rows < 2 || !(t[1] > t[0])) {
        fprintf(stderr, "host_test: %s: needs 2 rows with increasing time_s\n", path);
        return 1;
    }
    float h = (float)(t[1] - t[0]);

    FracbmsSettings s;
    size_t size, align;
    CHECK_CODE(fracbms_settings_default(h, &s), FRACBMS_OK);
    CHECK_CODE(fracbms_cell_size(s.window, s.memory, &size, &align), FRACBMS_OK);
    void *mem = aligned_buffer(size, align);
    FracbmsCell *cell = NULL;
    FracbmsCode rc = fracbms_cell_init(mem, size, &s, &cell);
    if (rc != FRACBMS_OK) {
        fprintf(stderr, "host_test: fracbms_cell_init returned %d\n", (int)rc);
        return 1;
    }
    FracbmsEstimate e;
    memset(&e, 0, sizeof e);
    for (size_t k = 0; k < rows; k++) {
        /* A gap in time: the missing periods are pushed as NaN samples. */
        long gap = k ? lround((t[k] - t[k - 1]) / h) : 1;
        for (long j = 1; j < gap; j++)
            CHECK_CODE(fracbms_cell_push(cell, NAN, NAN, &e), FRACBMS_OK);
        rc = fracbms_cell_push(cell, (float)cur[k], (float)volt[k], &e);
        if (rc != FRACBMS_OK) {
            fprintf(stderr, "host_test: fracbms_cell_push returned %d at row %zu\n", (int)rc, k + 2);
            return 1;
        }
    }
    FracbmsEstimate again;
    CHECK_CODE(fracbms_cell_estimate(cell, &again), FRACBMS_OK);
    CHECK(again.samples == e.samples && again.valid == e.valid);
    fprintf(stderr, "host_test: %u samples, status %s, rmse %g V\n", (unsigned)e.samples,
            fracbms_status_name(e.status), (double)e.rmse);
    if (!e.valid) {
        fprintf(stderr, "host_test: no estimate after the record\n");
        return 1;
    }
    /* The state of power now: 10 and 30 s, 3.0-4.2 V, 20 A, a 2 A discharge. */
    FracbmsPowerRequest req;
    memset(&req, 0, sizeof req);
    req.voltage_min = 3.0f;
    req.voltage_max = 4.2f;
    req.current_limit = 20.0f;
    req.horizons_s[0] = 10.0f;
    req.horizons_s[1] = 30.0f;
    req.horizon_count = 2;
    req.pulse_current = -2.0f;
    req.carry_s = NAN;
    req.confidence = NAN;
    FracbmsPower pw;
    CHECK_CODE(fracbms_cell_state_of_power(cell, &req, &pw), FRACBMS_OK);
    if (pw.published) {
        CHECK(pw.horizon_count == 2);
        CHECK(pw.horizons[1].discharge_a > 0.0f && pw.horizons[1].discharge_a <= 20.0f);
        CHECK(pw.horizons[1].discharge_a <= pw.horizons[0].discharge_a);
        CHECK(pw.horizons[0].pulse_v < 4.2f);
        fprintf(stderr, "host_test: state of power 10 s: %g A discharge, %g A charge\n",
                (double)pw.horizons[0].discharge_a, (double)pw.horizons[0].charge_a);
    }
    req.voltage_min = 4.5f; /* above the maximum: refused */
    CHECK_CODE(fracbms_cell_state_of_power(cell, &req, &pw), FRACBMS_ERROR_SETTINGS);
    CHECK_CODE(fracbms_cell_state_of_power(cell, NULL, &pw), FRACBMS_ERROR_NULL);
    const FracbmsParameters *p = &e.parameters;
    printf("RESULT r_i=%.7g r_ct=%.7g q=%.7g alpha=%.7g u_oc=%.7g samples=%u rejected=%u\n",
           (double)p->r_i, (double)p->r_ct, (double)p->q, (double)p->alpha, (double)p->u_oc,
           (unsigned)e.samples, (unsigned)e.rejected);
    free(mem);
    free(t);
    free(cur);
    free(volt);
    return 0;
}

/* The error paths. */
static void error_paths(void)
{
    FracbmsSettings s;
    size_t size = 0, align = 0;
    FracbmsCell *cell = NULL;
    FracbmsEstimate e;

    CHECK_CODE(fracbms_settings_default(1.0f, &s), FRACBMS_OK);
    CHECK(s.window == 256 && s.memory == 64 && s.h == 1.0f && s.ocv_points == 0);
    CHECK_CODE(fracbms_cell_size(s.window, s.memory, &size, &align), FRACBMS_OK);
    CHECK(size > 0 && align > 1 && (align & (align - 1)) == 0);
    uint8_t *mem = aligned_buffer(size + align, align);

    /* NULL pointers. */
    CHECK_CODE(fracbms_settings_default(1.0f, NULL), FRACBMS_ERROR_NULL);
    CHECK_CODE(fracbms_cell_size(s.window, s.memory, NULL, &align), FRACBMS_ERROR_NULL);
    CHECK_CODE(fracbms_cell_size(s.window, s.memory, &size, NULL), FRACBMS_ERROR_NULL);
    CHECK_CODE(fracbms_cell_init(NULL, size, &s, &cell), FRACBMS_ERROR_NULL);
    CHECK_CODE(fracbms_cell_init(mem, size, NULL, &cell), FRACBMS_ERROR_NULL);
    CHECK_CODE(fracbms_cell_init(mem, size, &s, NULL), FRACBMS_ERROR_NULL);
    CHECK_CODE(fracbms_cell_push(NULL, 1.0f, 3.7f, &e), FRACBMS_ERROR_NULL);
    CHECK_CODE(fracbms_cell_estimate(NULL, &e), FRACBMS_ERROR_NULL);
    CHECK_CODE(fracbms_cell_set_state_of_charge(NULL, 0.5f), FRACBMS_ERROR_NULL);

    /* Memory too small, misaligned. */
    CHECK_CODE(fracbms_cell_init(mem, size - 1, &s, &cell), FRACBMS_ERROR_TOO_SMALL);
    CHECK_CODE(fracbms_cell_init(mem, 0, &s, &cell), FRACBMS_ERROR_TOO_SMALL);
    CHECK_CODE(fracbms_cell_init(mem + 1, size, &s, &cell), FRACBMS_ERROR_MISALIGNED);
    CHECK_CODE(fracbms_cell_init(mem + align / 2, size, &s, &cell), FRACBMS_ERROR_MISALIGNED);

    /* A window the library was not built for. */
    size_t other = 0;
    CHECK_CODE(fracbms_cell_size(100, 25, &other, &align), FRACBMS_ERROR_UNSUPPORTED_SIZE);
    FracbmsSettings bad = s;
    bad.window = 100;
    bad.memory = 25;
    CHECK_CODE(fracbms_cell_init(mem, size, &bad, &cell), FRACBMS_ERROR_UNSUPPORTED_SIZE);

    /* A NaN voltage is rejected and counted, not an error. */
    CHECK_CODE(fracbms_cell_init(mem, size, &s, &cell), FRACBMS_OK);
    CHECK(cell != NULL);
    CHECK_CODE(fracbms_cell_push(cell, 1.0f, 3.7f, &e), FRACBMS_OK);
    CHECK(e.rejection == FRACBMS_REJECTION_NONE && e.rejected == 0 && e.samples == 1);
    CHECK_CODE(fracbms_cell_push(cell, 1.0f, NAN, &e), FRACBMS_OK);
    CHECK(e.rejection == FRACBMS_REJECTION_NON_FINITE);
    CHECK(e.rejected == 1 && e.samples == 2);
    CHECK_CODE(fracbms_cell_push(cell, 1.0f, 3.7f, &e), FRACBMS_OK);
    CHECK(e.rejection == FRACBMS_REJECTION_NONE && e.rejected == 1 && e.samples == 3);
    CHECK(fracbms_status_name(e.status) != NULL);
    free(mem);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s RECORD.csv   (time_s,current_a,voltage_v)\n", argv[0]);
        return 2;
    }
    error_paths();
    if (replay(argv[1]) != 0)
        failures++;
    if (failures) {
        fprintf(stderr, "host_test: %d check(s) failed\n", failures);
        return 1;
    }
    fprintf(stderr, "host_test: all checks passed\n");
    return 0;
}
