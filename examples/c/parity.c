/* The C face of the parity test (python/tests/test_parity.py): runs a record
 * through the C ABI and prints what it gives, one JSON object per line, for
 * the test to hold against `host-sim` and the Python package.
 *
 *   cargo build -p estimator-ffi --release
 *   cc -std=c11 -O2 -Wall -Wextra -Werror -Iinclude examples/c/parity.c \
 *      target/release/libfracbms.a -lpthread -ldl -lm -o target/parity
 *   target/parity identify RECORD.csv [OPTIONS]
 *   target/parity online RECORD.csv [OPTIONS]
 *
 * RECORD.csv is `time_s,current_a,voltage_v` with a header (other columns
 * ignored; `nan` or an empty cell is NaN); one sample per row, the period
 * `h` the first time step. OPTIONS:
 *
 *   --ocv OCV.csv --capacity-ah C   an OCV table `soc,ocv_v` and the capacity
 *   --soc0 Z                        the SOC before the first row
 *                                   (online: fracbms_cell_set_state_of_charge)
 *   --map MAP.csv                   online: the prior follows the map
 *                                   (fracbms_cell_follow_map before each push;
 *                                   the rows whose `identifiable` is true)
 *   --sop VMIN,VMAX,ILIMIT,IPULSE   online: fracbms_cell_state_of_power after
 *                                   each push, horizons 10 and 30 s (the
 *                                   pulse voltage corrected at IPULSE,
 *                                   FracbmsSettings::pulse_current)
 *   --soc-rest-s S, --soc-bias-sigma-a A, --soc-rest-load-sigma-a A,
 *   --soc-voltage-sigma-v V
 *                                   online: the SOC observer's settings as the
 *                                   CLI's flags set them
 *                                   (fracbms_cell_init_with_soc)
 *
 * identify prints one line: the FracbmsFit (`code`, `message` on an error).
 * online prints one line per sample (the FracbmsEstimate after the push,
 * names as `host-sim online battery` writes them) and a last line with
 * `"summary": true`: samples, rejected, the rejections by reason, and the
 * map's levels used and left out.
 * Numbers: 17 digits, an f32 as the double it converts to (both read back
 * exactly as a double); NaN as `NaN` (Python's json reads it). Exit 1 on a
 * failed call, 2 on bad usage. */

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fracbms.h"

#define HORIZONS 2
static const float HORIZON_S[HORIZONS] = {10.0f, 30.0f};

/* Columns of a CSV file, as doubles. */
typedef struct {
    size_t rows;
    int columns;
    double *data[16];
} Table;

_Noreturn static void die(const char *what)
{
    fprintf(stderr, "parity: %s\n", what);
    exit(1);
}

/* Index of `name` in the comma-separated header `line`, or -1. */
static int column(const char *line, const char *name)
{
    size_t n = strlen(name);
    const char *p = line;
    for (int k = 0;; k++) {
        p += strspn(p, " ");
        if (strncmp(p, name, n) == 0 && strchr(", \r\n", p[n]))
            return k;
        p = strchr(p, ',');
        if (!p)
            return -1;
        p++;
    }
}

/* Field `k` of a CSV line: a number, NaN when empty; `true`/`false` as 1/0. */
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
    p += strspn(p, " ");
    if (strncmp(p, "true", 4) == 0)
        return 1.0;
    if (strncmp(p, "false", 5) == 0)
        return 0.0;
    char *end;
    double v = strtod(p, &end);
    return end == p ? NAN : v;
}

/* Reads the named columns of `path` (a missing one is an error). */
static Table read_table(const char *path, const char *const *names, int count)
{
    Table t = {0, count, {0}};
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "parity: %s: cannot open\n", path);
        exit(1);
    }
    static char line[8192];
    if (!fgets(line, sizeof line, f))
        die("empty file");
    int idx[16];
    for (int c = 0; c < count; c++) {
        idx[c] = column(line, names[c]);
        if (idx[c] < 0) {
            fprintf(stderr, "parity: %s: no column %s\n", path, names[c]);
            exit(1);
        }
    }
    size_t cap = 1024;
    for (int c = 0; c < count; c++)
        if (!(t.data[c] = malloc(cap * sizeof(double))))
            die("out of memory");
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '\n' || line[0] == '\r' || line[0] == '\0')
            continue;
        if (t.rows == cap) {
            cap *= 2;
            for (int c = 0; c < count; c++)
                if (!(t.data[c] = realloc(t.data[c], cap * sizeof(double))))
                    die("out of memory");
        }
        for (int c = 0; c < count; c++)
            t.data[c][t.rows] = field(line, idx[c]);
        t.rows++;
    }
    fclose(f);
    return t;
}

static void free_table(Table *t)
{
    for (int c = 0; c < t->columns; c++)
        free(t->data[c]);
}

/* A JSON number with `digits` significant digits; NaN as `NaN`. */
static void num(const char *key, double v, int digits, int last)
{
    if (isnan(v))
        printf("\"%s\": NaN", key);
    else
        printf("\"%s\": %.*g", key, digits, v);
    printf(last ? "" : ", ");
}

/* An f32 as the double it converts to exactly (17 digits read back as that
 * double; 9 would read back as the f32 only). */
static void f32v(const char *key, float v) { num(key, (double)v, 17, 0); }

static const char *rejection_name(FracbmsRejection r)
{
    switch (r) {
    case FRACBMS_REJECTION_NONE:
        return "";
    case FRACBMS_REJECTION_NON_FINITE:
        return "non_finite";
    case FRACBMS_REJECTION_OUT_OF_RANGE:
        return "out_of_range";
    case FRACBMS_REJECTION_SPIKE:
        return "spike";
    }
    return "unknown";
}

typedef struct {
    const char *ocv, *map;
    double capacity_ah, soc0;
    int sop;
    float sop_limits[4];
    /* The CLI's --soc-rest-s, --soc-bias-sigma-a, --soc-rest-load-sigma-a,
     * --soc-voltage-sigma-v (NaN: not given). */
    double soc_rest_s, soc_bias_sigma_a, soc_rest_load_sigma_a, soc_voltage_sigma_v;
} Options;

static int identify(const Table *rec, const Options *o)
{
    FracbmsIdentifyOptions opt;
    FracbmsFit fit;
    Table ocv = {0, 0, {0}};
    if (fracbms_identify_options_default(&opt) != FRACBMS_OK)
        die("fracbms_identify_options_default");
    if (o->ocv) {
        static const char *const cols[] = {"soc", "ocv_v"};
        ocv = read_table(o->ocv, cols, 2);
        opt.ocv_soc = ocv.data[0];
        opt.ocv_v = ocv.data[1];
        opt.ocv_points = (uint32_t)ocv.rows;
        opt.capacity_ah = o->capacity_ah;
        opt.soc0 = o->soc0;
    }
    FracbmsCode rc = fracbms_identify_battery(rec->data[0], rec->data[1], rec->data[2], rec->rows,
                                              &opt, &fit);
    printf("{\"code\": %d, ", (int)rc);
    if (rc != FRACBMS_OK) {
        /* The message is the CLI's one line; JSON-escape what it may hold. */
        printf("\"message\": \"");
        for (const char *p = fit.message; *p; p++) {
            if (*p == '"' || *p == '\\')
                putchar('\\');
            putchar(*p);
        }
        printf("\"}\n");
    } else {
        printf("\"model\": \"%s\", ",
               fit.model == FRACBMS_MODEL_BUTLER_VOLMER ? "butler-volmer" : "linear");
        num("r_i", fit.r_i, 17, 0);
        num("r_ct", fit.r_ct, 17, 0);
        num("q", fit.q, 17, 0);
        num("alpha", fit.alpha, 17, 0);
        num("u_oc", fit.u_oc, 17, 0);
        num("bv_a_v", fit.bv_a_v, 17, 0);
        num("bv_i0_a", fit.bv_i0_a, 17, 0);
        num("ocv_offset_v", fit.ocv_offset_v, 17, 0);
        num("soc0", fit.soc0, 17, 0);
        num("soc_end", fit.soc_end, 17, 0);
        num("rmse_v", fit.rmse_v, 17, 0);
        printf("\"iterations\": %u, \"converged\": %s, \"rejected\": %u, \"identifiable\": %s}\n",
               (unsigned)fit.iterations, fit.converged ? "true" : "false", (unsigned)fit.rejected,
               fit.identifiable ? "true" : "false");
    }
    if (o->ocv)
        free_table(&ocv);
    return rc == FRACBMS_OK ? 0 : 1;
}

/* The identifiable rows of a map CSV as levels; `left_out` counts the others. */
static size_t read_map(const char *path, FracbmsMapLevel *levels, size_t max, unsigned *left_out)
{
    static const char *const cols[] = {"temperature_c", "soc", "r_i", "r_ct", "q", "alpha",
                                       "bv_a_v", "bv_i0_a", "ocv_offset_v", "identifiable"};
    Table m = read_table(path, cols, 10);
    size_t n = 0;
    for (size_t k = 0; k < m.rows; k++) {
        if (m.data[9][k] != 1.0) {
            ++*left_out;
            continue;
        }
        if (n == max)
            die("map: too many levels");
        double bv_a = m.data[6][k], bv_i0 = m.data[7][k];
        FracbmsMapLevel *l = &levels[n++];
        l->temperature_c = (float)m.data[0][k];
        l->soc = (float)m.data[1][k];
        l->parameters.r_i = (float)m.data[2][k];
        l->parameters.r_ct = (float)m.data[3][k];
        l->parameters.q = (float)m.data[4][k];
        l->parameters.alpha = (float)m.data[5][k];
        l->parameters.u_oc = (float)m.data[8][k];
        l->parameters.bv_a = isnan(bv_a) ? 0.0f : (float)bv_a;
        l->parameters.bv_i0 = isnan(bv_i0) ? 1.0f : (float)bv_i0;
    }
    free_table(&m);
    return n;
}

static int online(const Table *rec, const Options *o)
{
    if (rec->rows < 2 || !(rec->data[0][1] > rec->data[0][0]))
        die("needs 2 rows with increasing time_s");
    float h = (float)(rec->data[0][1] - rec->data[0][0]);
    FracbmsSettings s;
    size_t size, align;
    if (fracbms_settings_default(h, &s) != FRACBMS_OK)
        die("fracbms_settings_default");
    Table ocv = {0, 0, {0}};
    float *ocv_soc = NULL, *ocv_v = NULL;
    if (o->ocv) {
        static const char *const cols[] = {"soc", "ocv_v"};
        ocv = read_table(o->ocv, cols, 2);
        ocv_soc = malloc(ocv.rows * sizeof *ocv_soc);
        ocv_v = malloc(ocv.rows * sizeof *ocv_v);
        if (!ocv_soc || !ocv_v)
            die("out of memory");
        for (size_t k = 0; k < ocv.rows; k++) {
            ocv_soc[k] = (float)ocv.data[0][k];
            ocv_v[k] = (float)ocv.data[1][k];
        }
        s.ocv_soc = ocv_soc;
        s.ocv_v = ocv_v;
        s.ocv_points = (uint16_t)ocv.rows;
        s.capacity_ah = (float)o->capacity_ah;
    }
    /* The pulse voltage corrected at the pulse asked, as the CLI does. */
    if (o->sop)
        s.pulse_current = o->sop_limits[3];
    if (fracbms_cell_size(s.window, s.memory, &size, &align) != FRACBMS_OK)
        die("fracbms_cell_size");
    if (align < 16)
        align = 16;
    void *mem = aligned_alloc(align, (size + align - 1) / align * align);
    if (!mem)
        die("out of memory");
    /* The SOC observer's settings (with an OCV table only: the observer
     * runs only with one): the defaults for this cell, changed as the
     * CLI's flags change them. */
    FracbmsSocSettings soc;
    if (o->ocv) {
        if (fracbms_soc_settings_default(&s, &soc) != FRACBMS_OK)
            die("fracbms_soc_settings_default");
        if (!isnan(o->soc_rest_s)) {
            soc.rest_s = (float)o->soc_rest_s;
            if (soc.rest_max_s < soc.rest_s)
                soc.rest_max_s = soc.rest_s;
        }
        if (!isnan(o->soc_bias_sigma_a)) {
            soc.bias_sigma_a = (float)o->soc_bias_sigma_a;
            if (o->soc_bias_sigma_a == 0.0)
                soc.bias_walk_a = 0.0f;
        }
        if (!isnan(o->soc_rest_load_sigma_a))
            soc.rest_load_sigma_a = (float)o->soc_rest_load_sigma_a;
        if (!isnan(o->soc_voltage_sigma_v))
            soc.voltage_sigma_v = (float)o->soc_voltage_sigma_v;
    }
    FracbmsCell *cell = NULL;
    FracbmsCode rc = fracbms_cell_init_with_soc(mem, size, &s, o->ocv ? &soc : NULL, &cell);
    if (rc != FRACBMS_OK) {
        fprintf(stderr, "parity: fracbms_cell_init_with_soc: %s\n", fracbms_code_message(rc));
        return 1;
    }
    if (!isnan(o->soc0) && fracbms_cell_set_state_of_charge(cell, (float)o->soc0) != FRACBMS_OK)
        die("fracbms_cell_set_state_of_charge");
    static FracbmsMapLevel levels[FRACBMS_MAP_LEVELS_MAX];
    unsigned left_out = 0;
    size_t n_levels = o->map ? read_map(o->map, levels, FRACBMS_MAP_LEVELS_MAX, &left_out) : 0;
    FracbmsPowerRequest req;
    memset(&req, 0, sizeof req);
    req.voltage_min = o->sop_limits[0];
    req.voltage_max = o->sop_limits[1];
    req.current_limit = o->sop_limits[2];
    req.pulse_current = o->sop_limits[3];
    for (int k = 0; k < HORIZONS; k++)
        req.horizons_s[k] = HORIZON_S[k];
    req.horizon_count = HORIZONS;
    req.carry_s = NAN;
    req.confidence = NAN;
    unsigned by_reason[4] = {0, 0, 0, 0};
    FracbmsEstimate e;
    for (size_t k = 0; k < rec->rows; k++) {
        int taken = 0;
        if (o->map) {
            bool t = false;
            rc = fracbms_cell_follow_map(cell, levels, (uint16_t)n_levels, NAN, &t);
            if (rc != FRACBMS_OK) {
                fprintf(stderr, "parity: fracbms_cell_follow_map: %s\n", fracbms_code_message(rc));
                return 1;
            }
            taken = t;
        }
        rc = fracbms_cell_push(cell, (float)rec->data[1][k], (float)rec->data[2][k], &e);
        if (rc != FRACBMS_OK) {
            fprintf(stderr, "parity: fracbms_cell_push: %s\n", fracbms_code_message(rc));
            return 1;
        }
        if ((unsigned)e.rejection < 4)
            by_reason[e.rejection]++;
        const FracbmsParameters *p = &e.parameters;
        const FracbmsPublished *pb = &e.published;
        printf("{\"row\": %zu, \"status\": \"%s\", \"rejected\": \"%s\", \"samples\": %u, "
               "\"rejected_so_far\": %u, \"valid\": %s, \"map_taken\": %s, ",
               k, fracbms_status_name(e.status), rejection_name(e.rejection),
               (unsigned)e.samples, (unsigned)e.rejected, e.valid ? "true" : "false",
               taken ? "true" : "false");
        printf("\"r_i_status\": \"%s\", \"r_ct_status\": \"%s\", \"q_status\": \"%s\", "
               "\"alpha_status\": \"%s\", ",
               fracbms_identification_name(pb->r_i_status),
               fracbms_identification_name(pb->r_ct_status),
               fracbms_identification_name(pb->q_status),
               fracbms_identification_name(pb->alpha_status));
        f32v("r_i", pb->r_i);
        f32v("r_ct", pb->r_ct);
        f32v("q", pb->q);
        f32v("alpha", pb->alpha);
        f32v("window_r_i", e.valid ? p->r_i : NAN);
        f32v("window_r_ct", e.valid ? p->r_ct : NAN);
        f32v("window_q", e.valid ? p->q : NAN);
        f32v("window_alpha", e.valid ? p->alpha : NAN);
        f32v("u_oc", e.valid ? p->u_oc : NAN);
        f32v("ocv_offset_v", e.valid ? e.ocv_offset : NAN);
        f32v("step_resistance_ohm", e.step_resistance);
        f32v("soc_coulomb", e.state_of_charge);
        f32v("soc", e.soc.state_of_charge);
        f32v("soc_sigma", e.soc.sigma);
        f32v("current_bias_a", e.soc.current_bias);
        f32v("capacity_ah", e.soc.capacity_ah);
        f32v("capacity_sigma_ah", e.soc.capacity_sigma_ah);
        f32v("soc_ocv_weight", e.soc.ocv_weight);
        printf("\"capacity_status\": \"%s\", ",
               isnan(e.soc.state_of_charge) ? ""
               : e.soc.capacity_identified  ? "identified"
                                            : "not_identified");
        if (o->sop) {
            FracbmsPower pw;
            rc = fracbms_cell_state_of_power(cell, &req, &pw);
            if (rc != FRACBMS_OK) {
                fprintf(stderr, "parity: fracbms_cell_state_of_power: %s\n",
                        fracbms_code_message(rc));
                return 1;
            }
            printf("\"sop_published\": %s, ", pw.published ? "true" : "false");
            /* The basis as the track's `sop_basis` (empty without one). */
            static const char *const BASIS[] = {"window", "map", "held", "stale"};
            printf("\"sop_basis\": \"%s\", ",
                   pw.published && pw.basis < 4 ? BASIS[pw.basis] : "");
            f32v("sop_uncertainty_v", pw.published ? pw.uncertainty_v : NAN);
            for (int j = 0; j < HORIZONS; j++) {
                char key[64];
                int hs = (int)HORIZON_S[j];
                snprintf(key, sizeof key, "sop_discharge_a_%ds", hs);
                f32v(key, pw.published ? pw.horizons[j].discharge_a : NAN);
                snprintf(key, sizeof key, "sop_charge_a_%ds", hs);
                f32v(key, pw.published ? pw.horizons[j].charge_a : NAN);
                snprintf(key, sizeof key, "pulse_v_%ds", hs);
                f32v(key, pw.published ? pw.horizons[j].pulse_v : NAN);
                snprintf(key, sizeof key, "sop_uncertainty_v_%ds", hs);
                f32v(key, pw.published ? pw.horizons[j].uncertainty_v : NAN);
                snprintf(key, sizeof key, "pulse_ratio_%ds", hs);
                f32v(key, pw.published ? pw.horizons[j].pulse_ratio : NAN);
            }
        }
        printf("\"iterations\": %u}\n", (unsigned)e.iterations);
    }
    FracbmsEstimate last;
    if (fracbms_cell_estimate(cell, &last) != FRACBMS_OK)
        die("fracbms_cell_estimate");
    printf("{\"summary\": true, \"samples\": %u, \"rejected\": %u, \"non_finite\": %u, "
           "\"out_of_range\": %u, \"spikes\": %u, \"map_levels\": %zu, \"map_left_out\": %u}\n",
           (unsigned)last.samples, (unsigned)last.rejected, by_reason[FRACBMS_REJECTION_NON_FINITE],
           by_reason[FRACBMS_REJECTION_OUT_OF_RANGE], by_reason[FRACBMS_REJECTION_SPIKE], n_levels,
           left_out);
    free(mem);
    free(ocv_soc);
    free(ocv_v);
    if (o->ocv)
        free_table(&ocv);
    return 0;
}

_Noreturn static void usage(void)
{
    fprintf(stderr, "usage: parity identify|online RECORD.csv [--ocv OCV.csv --capacity-ah C] "
                    "[--soc0 Z] [--map MAP.csv] [--sop VMIN,VMAX,ILIMIT,IPULSE] "
                    "[--soc-rest-s S] [--soc-bias-sigma-a A] [--soc-rest-load-sigma-a A]\n"
                    "       [--soc-voltage-sigma-v V]\n");
    exit(2);
}

int main(int argc, char **argv)
{
    if (argc < 3)
        usage();
    Options o = {NULL, NULL, NAN, NAN, 0, {0}, NAN, NAN, NAN, NAN};
    for (int k = 3; k < argc; k++) {
        if (k + 1 >= argc)
            usage();
        const char *flag = argv[k], *value = argv[++k];
        if (strcmp(flag, "--ocv") == 0)
            o.ocv = value;
        else if (strcmp(flag, "--capacity-ah") == 0)
            o.capacity_ah = strtod(value, NULL);
        else if (strcmp(flag, "--soc0") == 0)
            o.soc0 = strtod(value, NULL);
        else if (strcmp(flag, "--map") == 0)
            o.map = value;
        else if (strcmp(flag, "--soc-rest-s") == 0)
            o.soc_rest_s = strtod(value, NULL);
        else if (strcmp(flag, "--soc-bias-sigma-a") == 0)
            o.soc_bias_sigma_a = strtod(value, NULL);
        else if (strcmp(flag, "--soc-rest-load-sigma-a") == 0)
            o.soc_rest_load_sigma_a = strtod(value, NULL);
        else if (strcmp(flag, "--soc-voltage-sigma-v") == 0)
            o.soc_voltage_sigma_v = strtod(value, NULL);
        else if (strcmp(flag, "--sop") == 0) {
            char *p = (char *)value;
            for (int j = 0; j < 4; j++) {
                o.sop_limits[j] = strtof(p, &p);
                if (j < 3 && *p++ != ',')
                    usage();
            }
            o.sop = 1;
        } else
            usage();
    }
    static const char *const cols[] = {"time_s", "current_a", "voltage_v"};
    Table rec = read_table(argv[2], cols, 3);
    int rc;
    if (strcmp(argv[1], "identify") == 0)
        rc = identify(&rec, &o);
    else if (strcmp(argv[1], "online") == 0)
        rc = online(&rec, &o);
    else
        usage();
    free_table(&rec);
    return rc;
}
