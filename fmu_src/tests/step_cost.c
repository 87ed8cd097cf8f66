/*
 * A native FMI 2 co-simulation master that measures an FMU's cost per communication step (target
 * sphrom_step_cost; harness/bench/port_cost.py runs it).  It loads the FMU's own binary (binaries/<platform>/
 * sphrom.so of an unzipped FMU) with dlopen, as an importer does, and runs a plain master loop:
 *
 *   per step: fmi2SetReal of the inputs (f and each F_port_j, or each a_port_j in the wave form: a spring on each
 *   port, its force from the port velocity read after the last step), fmi2DoStep, fmi2GetReal of the outputs
 *   (v_probe_j, rho_probe_j, v_port_j; with --bounds their *_error_bound too).
 *
 *   sphrom_step_cost FMU_DIR --probes P [--ports N] [--steps M] [--h H] [--repeats R] [--scale S] [--bounds]
 *                    [--impedance Z] [--floor]
 *   sphrom_step_cost --calibrate [--repeats R]
 *
 * Each repeat instantiates the FMU, sets the parameters (initial_state_scale S, port_impedance Z), initializes and
 * times M steps of H, thread CPU time and wall time; the first step of a repeat (the exponentials of a new step
 * length) is outside the clock.  --floor times the same loop without fmi2DoStep (the calls' own cost: the floor of
 * this driver).  Prints one line of JSON: the medians over the repeats in ns per step, and the values of the last
 * step's outputs (a check that the run was the same in every repeat).
 *
 * --calibrate times the core's own inner loop, a row times a state (acc += row[j] * z[j], compiled with the core's
 * flags: no fused multiply-add, one dependent sum), over rows of 8 to 64 entries, and prints the median ns per
 * multiply-add: the rate at which a linear model's multiply-adds are done, beside which its cost per step is read.
 *
 * No Python, no checks beyond the FMI statuses: a failed call prints its message and exits with status 1.
 */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2FunctionTypes.h"
#include "fmu_variables.h"

#define MAX_VARS 512
#define MAX_REPEATS 101

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env;
    (void)name;
    (void)category;
    if (status >= fmi2Error) fprintf(stderr, "fmu: %s\n", message ? message : "");
}

static double seconds(clockid_t clock) {
    struct timespec ts;
    clock_gettime(clock, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int compare(const void *a, const void *b) {
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof(double), compare);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

#define LOAD(type, name)                                                                       \
    type name = (type)dlsym(lib, #name);                                                       \
    if (!name) {                                                                               \
        fprintf(stderr, "step_cost: %s not found in the FMU's binary\n", #name);               \
        return 1;                                                                              \
    }

#define CHECK(call)                                                                            \
    do {                                                                                       \
        if ((call) > fmi2Warning) {                                                            \
            fprintf(stderr, "step_cost: %s failed\n", #call);                                  \
            return 1;                                                                          \
        }                                                                                      \
    } while (0)

static int read_token(const char *dir, char *token, size_t size) {
    char path[4200];
    snprintf(path, sizeof path, "%s/modelDescription.xml", dir);
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    static char text[1 << 20];
    const size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = '\0';
    const char *at = strstr(text, "guid=\"");
    if (!at) return 0;
    at += 6;
    const char *end = strchr(at, '"');
    if (!end || (size_t)(end - at) >= size) return 0;
    memcpy(token, at, (size_t)(end - at));
    token[end - at] = '\0';
    return 1;
}

/* ns per multiply-add of the core's row loop (module comment, --calibrate) */
static int calibrate(int repeats) {
    enum { ROWS = 64, LONGEST = 64, SWEEPS = 4000 };
    static double row[ROWS * LONGEST], z[LONGEST];
    for (int i = 0; i < ROWS * LONGEST; i++) row[i] = 1.0 / (double)(i + 3);
    for (int j = 0; j < LONGEST; j++) z[j] = 0.5 + 1e-3 * (double)j;
    double ns[MAX_REPEATS];
    volatile double sink = 0.0;
    for (int r = 0; r < repeats; r++) {
        double madds = 0.0;
        const double c0 = seconds(CLOCK_THREAD_CPUTIME_ID);
        for (int sweep = 0; sweep < SWEEPS; sweep++) {
            const int k = 8 + 8 * (sweep % 8);          /* rows of 8, 16, ..., 64 entries */
            for (int i = 0; i < ROWS; i++) {
                const double *w = row + (size_t)i * LONGEST;
                double acc = 0.0;
                for (int j = 0; j < k; j++) acc += w[j] * z[j];
                z[i % k] = 0.5 + 1e-9 * acc;             /* the next row reads this one's result */
            }
            madds += (double)ROWS * (double)k;
        }
        ns[r] = (seconds(CLOCK_THREAD_CPUTIME_ID) - c0) * 1e9 / madds;
        sink = sink + z[0];
    }
    printf("{\"ns_per_madd\": %.6g, \"repeats\": %d}\n", median(ns, repeats), repeats);
    (void)sink;
    return 0;
}

int main(int argc, char **argv) {
    if (argc >= 2 && !strcmp(argv[1], "--calibrate")) {
        const int repeats = argc >= 4 && !strcmp(argv[2], "--repeats") ? atoi(argv[3]) : 5;
        if (repeats < 1 || repeats > MAX_REPEATS) {
            fprintf(stderr, "step_cost: --repeats 1..%d\n", MAX_REPEATS);
            return 2;
        }
        return calibrate(repeats);
    }
    if (argc < 2) {
        fprintf(stderr, "usage: %s FMU_DIR --probes P [--ports N] [--steps M] [--h H] [--repeats R] [--scale S] "
                "[--bounds] [--impedance Z] [--floor]\n", argv[0]);
        return 2;
    }
    const char *dir = argv[1];
    unsigned probes = 0, ports = 0;
    long steps = 20000;
    int repeats = 5, bounds = 0, floor_only = 0;
    double h = 1e-3, scale = 1.0, impedance = 0.0;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--bounds")) bounds = 1;
        else if (!strcmp(a, "--floor")) floor_only = 1;
        else if (v && !strcmp(a, "--probes")) probes = (unsigned)atoi(argv[++i]);
        else if (v && !strcmp(a, "--ports")) ports = (unsigned)atoi(argv[++i]);
        else if (v && !strcmp(a, "--steps")) steps = atol(argv[++i]);
        else if (v && !strcmp(a, "--h")) h = atof(argv[++i]);
        else if (v && !strcmp(a, "--repeats")) repeats = atoi(argv[++i]);
        else if (v && !strcmp(a, "--scale")) scale = atof(argv[++i]);
        else if (v && !strcmp(a, "--impedance")) impedance = atof(argv[++i]);
        else {
            fprintf(stderr, "step_cost: unknown option %s\n", a);
            return 2;
        }
    }
    if (probes < 1 || probes > 100 || ports > 4 || steps < 1 || !(h > 0) || repeats < 1 || repeats > MAX_REPEATS) {
        fprintf(stderr, "step_cost: --probes 1..100, --ports 0..4, --steps >= 1, --h > 0, --repeats 1..%d\n",
                MAX_REPEATS);
        return 2;
    }
    char so[4200], uri[4300], token[128];
    snprintf(so, sizeof so, "%s/binaries/linux64/sphrom.so", dir);
    snprintf(uri, sizeof uri, "file://%s/resources", dir);
    if (!read_token(dir, token, sizeof token)) {
        fprintf(stderr, "step_cost: no guid in %s/modelDescription.xml\n", dir);
        return 1;
    }
    void *lib = dlopen(so, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "step_cost: %s\n", dlerror());
        return 1;
    }
    LOAD(fmi2InstantiateTYPE *, fmi2Instantiate)
    LOAD(fmi2FreeInstanceTYPE *, fmi2FreeInstance)
    LOAD(fmi2SetupExperimentTYPE *, fmi2SetupExperiment)
    LOAD(fmi2EnterInitializationModeTYPE *, fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationModeTYPE *, fmi2ExitInitializationMode)
    LOAD(fmi2SetRealTYPE *, fmi2SetReal)
    LOAD(fmi2GetRealTYPE *, fmi2GetReal)
    LOAD(fmi2DoStepTYPE *, fmi2DoStep)

    /* the outputs read after every step */
    fmi2ValueReference out[MAX_VARS];
    size_t n_out = 0;
    for (unsigned j = 0; j < probes; j++) {
        out[n_out++] = ROM_VR_V_PROBE + j;
        out[n_out++] = ROM_VR_RHO_PROBE + j;
        if (bounds) {
            out[n_out++] = ROM_VR_V_PROBE_ERROR_BOUND + j;
            out[n_out++] = ROM_VR_RHO_PROBE_ERROR_BOUND + j;
        }
    }
    fmi2ValueReference vport[4], fin[5];
    for (unsigned j = 0; j < ports; j++) {
        vport[j] = ROM_VR_V_PORT + j;
        out[n_out++] = ROM_VR_V_PORT + j;
        if (bounds) out[n_out++] = ROM_VR_V_PORT_ERROR_BOUND + j;
        if (impedance > 0) out[n_out++] = ROM_VR_B_PORT + j;
    }
    fin[0] = ROM_VR_F;
    for (unsigned j = 0; j < ports; j++) fin[1 + j] = (impedance > 0 ? ROM_VR_A_PORT : ROM_VR_F_PORT) + j;
    double values[MAX_VARS], cpu[MAX_REPEATS], wall[MAX_REPEATS];
    const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    for (int r = 0; r < repeats; r++) {
        fmi2Component c = fmi2Instantiate("cost", fmi2CoSimulation, token, uri, &callbacks, fmi2False, fmi2False);
        if (!c) {
            fprintf(stderr, "step_cost: fmi2Instantiate failed\n");
            return 1;
        }
        CHECK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        CHECK(fmi2EnterInitializationMode(c));
        const fmi2ValueReference params[2] = {ROM_VR_INITIAL_STATE_SCALE, ROM_VR_PORT_IMPEDANCE};
        const double pvals[2] = {scale, impedance};
        CHECK(fmi2SetReal(c, params, impedance > 0 ? 2 : 1, pvals));
        CHECK(fmi2ExitInitializationMode(c));
        /* a spring of 5 N/m to ground on each port (its elongation from the port velocity held over the step) */
        double x[4] = {1e-3, -1e-3, 1e-3, -1e-3}, v[4] = {0.0, 0.0, 0.0, 0.0}, in[5];
        double t = 0.0, c0 = 0.0, w0 = 0.0;
        for (long n = 0; n <= steps; n++) {
            if (n == 1) {                  /* the first step (a new step length's exponentials) is not timed */
                c0 = seconds(CLOCK_THREAD_CPUTIME_ID);
                w0 = seconds(CLOCK_MONOTONIC);
            }
            in[0] = 1e-3 * sin(2.0 * t);
            for (unsigned j = 0; j < ports; j++) {
                x[j] -= v[j] * h;
                in[1 + j] = 5.0 * x[j];
            }
            CHECK(fmi2SetReal(c, fin, 1 + ports, in));
            if (!floor_only) CHECK(fmi2DoStep(c, t, h, fmi2True));
            t = (double)(n + 1) * h;
            CHECK(fmi2GetReal(c, out, n_out, values));
            if (ports) CHECK(fmi2GetReal(c, vport, ports, v));
        }
        cpu[r] = (seconds(CLOCK_THREAD_CPUTIME_ID) - c0) / (double)steps * 1e9;
        wall[r] = (seconds(CLOCK_MONOTONIC) - w0) / (double)steps * 1e9;
        fmi2FreeInstance(c);
    }
    printf("{\"ns_per_step_cpu\": %.6g, \"ns_per_step_wall\": %.6g, \"steps\": %ld, \"repeats\": %d, \"h\": %.9g, "
           "\"outputs\": %zu, \"floor\": %d, \"last\": [", median(cpu, repeats), median(wall, repeats), steps, repeats,
           h, n_out, floor_only);
    for (size_t i = 0; i < n_out; i++) printf("%s%.17g", i ? ", " : "", values[i]);
    printf("]}\n");
    dlclose(lib);
    return 0;
}
