/*
 * C test driver for the sphrom FMU binaries, built by CMake (target
 * sphrom_driver) with or without -fsanitize=address,undefined and run from
 * pytest (tests/test_fmu_c.py).  It links the core and both FMI wrappers
 * directly and exercises them through the FMI functions:
 *
 *   sphrom_driver RESOURCES_DIR SCRATCH_DIR [scenario ...]
 *
 * scenarios: basic, state, bad, resources, cycles, threads, edge, bound (default: all).
 * Every failed check prints a line; the exit status is the number of failed
 * checks (capped at 100).  Under AddressSanitizer, leaks fail the run at exit.
 */
#define _POSIX_C_SOURCE 200809L     /* clock_gettime (the bound scenario times one doStep) */
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "fmi2Functions.h"
#include "fmi3Functions.h"
#include "rom.h"
#include "rom_exact.h"     /* the exact model's probe rows (the J <= 0 check below) */
#include "fmu_variables.h"

#define MAX_OUT (2 * ROM_MAX_PROBES)

static int failures = 0;
static int checks = 0;

#define EXPECT(cond, ...) \
    do { \
        checks++; \
        if (!(cond)) { \
            failures++; \
            printf("FAIL %s:%d: ", __FILE__, __LINE__); \
            printf(__VA_ARGS__); \
            printf("\n"); \
        } \
    } while (0)

/* ------------------------------------------------------------------------ */
/* log book: per-instance environment recording what the FMU logged           */
/* ------------------------------------------------------------------------ */

typedef struct {
    int errors;
    int warnings;
    int messages;
    char last[2048];
} LogBook;

static void logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                    fmi2String message, ...) {
    (void)name;
    (void)category;
    LogBook *book = (LogBook *)env;
    if (!book) return;
    book->messages++;
    if (status == fmi2Error || status == fmi2Fatal) book->errors++;
    if (status == fmi2Warning) book->warnings++;
    snprintf(book->last, sizeof book->last, "%s", message ? message : "");
}

static void logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)category;
    LogBook *book = (LogBook *)env;
    if (!book) return;
    book->messages++;
    if (status == fmi3Error || status == fmi3Fatal) book->errors++;
    if (status == fmi3Warning) book->warnings++;
    snprintf(book->last, sizeof book->last, "%s", message ? message : "");
}

/* status must be an error and a new error message must have been logged */
#define EXPECT_ERROR(book, call, ok_value) \
    do { \
        const int _before = (book)->errors; \
        const int _status = (int)(call); \
        EXPECT(_status != (int)(ok_value), "%s returned OK, expected an error", #call); \
        EXPECT((book)->errors > _before, "%s logged no error message", #call); \
    } while (0)

/* ------------------------------------------------------------------------ */
/* setup                                                                     */
/* ------------------------------------------------------------------------ */

typedef struct {
    char resources[4096];   /* folder */
    char uri[4200];         /* file URI of the folder (FMI 2) */
    char path3[4200];       /* folder path with a trailing slash (FMI 3) */
    char token[ROM_TOKEN_SIZE + 1];
    uint32_t n_probes;
    uint32_t kind;          /* ROM_MODEL_FROZEN or ROM_MODEL_EXACT_LINEAR */
    double dt;
    double dt_floor;        /* the smallest dt the FMU accepts (rom_dt_floor; 0: no internal step) */
    double max_steps;       /* the most internal steps of one doStep at the default n_freeze and dt_floor */
    uint32_t n_ports;       /* 0: no ports */
    int has_params;         /* a parametric model (a PARAMS section): c and d rows below */
    double params[2][4];    /* per c, d: varied (0 or 1), start, min, max */
    const char *scratch;
} Setup;

static Setup setup;

static fmi2CallbackFunctions callbacks2(LogBook *book) {
    fmi2CallbackFunctions f;
    f.logger = logger2;
    f.allocateMemory = calloc;
    f.freeMemory = free;
    f.stepFinished = NULL;
    f.componentEnvironment = book;
    return f;
}

static fmi2Component instantiate2(LogBook *book, const fmi2CallbackFunctions *f, const char *uri, const char *token) {
    (void)book;
    return fmi2Instantiate("driver2", fmi2CoSimulation, token, uri, f, fmi2False, fmi2False);
}

static fmi3Instance instantiate3(LogBook *book, const char *path, const char *token) {
    return fmi3InstantiateCoSimulation("driver3", token, path, fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0,
                                       book, logger3, NULL);
}

static size_t output_refs(fmi2ValueReference *vr) {
    size_t n = 0;
    for (uint32_t j = 0; j < setup.n_probes; j++) vr[n++] = ROM_VR_V_PROBE + j;
    for (uint32_t j = 0; j < setup.n_probes; j++) vr[n++] = ROM_VR_RHO_PROBE + j;
    return n;
}

/* the step unit of the scenarios for a model without internal steps (the linear models: exact over any step) [s] */
#define LINEAR_STEP 2e-4

/* the input sequence of every scenario: f_k = 0.05 sin(0.7 k) [m s^-2] */
static double input_at(int k) {
    return 0.05 * sin(0.7 * (double)k);
}

/* communication step k: alternates whole multiples and non-multiples of dt */
static double step_at(int k) {
    static const double factors[4] = {3.0, 2.5, 0.4, 7.25};
    return factors[k % 4] * setup.dt;
}

/* run n communication steps from step k0 at time t; record outputs (n x n_out) */
static int run2(fmi2Component c, int k0, int n, double *t, double *out) {
    fmi2ValueReference vr[MAX_OUT];
    const size_t n_out = output_refs(vr);
    const fmi2ValueReference vf = ROM_VR_F;
    for (int k = k0; k < k0 + n; k++) {
        const double f = input_at(k);
        if (fmi2SetReal(c, &vf, 1, &f) != fmi2OK) return 0;
        const double h = step_at(k);
        if (fmi2DoStep(c, *t, h, fmi2True) != fmi2OK) return 0;
        *t += h;
        if (fmi2GetReal(c, vr, n_out, out + (size_t)(k - k0) * n_out) != fmi2OK) return 0;
    }
    return 1;
}

static int run3(fmi3Instance c, int k0, int n, double *t, double *out) {
    fmi3ValueReference vr[MAX_OUT];
    const size_t n_out = output_refs(vr);
    const fmi3ValueReference vf = ROM_VR_F;
    for (int k = k0; k < k0 + n; k++) {
        const double f = input_at(k);
        if (fmi3SetFloat64(c, &vf, 1, &f, 1) != fmi3OK) return 0;
        const double h = step_at(k);
        fmi3Boolean event, terminate, early;
        fmi3Float64 last;
        if (fmi3DoStep(c, *t, h, fmi3True, &event, &terminate, &early, &last) != fmi3OK) return 0;
        *t += h;
        if (fmi3GetFloat64(c, vr, n_out, out + (size_t)(k - k0) * n_out, n_out) != fmi3OK) return 0;
    }
    return 1;
}

static fmi2Component ready2(LogBook *book, const fmi2CallbackFunctions *f) {
    fmi2Component c = instantiate2(book, f, setup.uri, setup.token);
    if (!c) return NULL;
    if (fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK ||
        fmi2EnterInitializationMode(c) != fmi2OK || fmi2ExitInitializationMode(c) != fmi2OK) {
        fmi2FreeInstance(c);
        return NULL;
    }
    return c;
}

static fmi3Instance ready3(LogBook *book) {
    fmi3Instance c = instantiate3(book, setup.path3, setup.token);
    if (!c) return NULL;
    if (fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0) != fmi3OK ||
        fmi3ExitInitializationMode(c) != fmi3OK) {
        fmi3FreeInstance(c);
        return NULL;
    }
    return c;
}

/* an initialized instance of each version; 0 (and none left) when either fails */
static int ready_both(LogBook *book2, const fmi2CallbackFunctions *f2, LogBook *book3, fmi2Component *c2,
                      fmi3Instance *c3) {
    *c2 = ready2(book2, f2);
    *c3 = ready3(book3);
    EXPECT(*c2 && *c3, "instantiation failed: %s / %s", book2->last, book3->last);
    if (*c2 && *c3) return 1;
    fmi2FreeInstance(*c2);
    fmi3FreeInstance(*c3);
    return 0;
}

/* ------------------------------------------------------------------------ */
/* scenarios                                                                 */
/* ------------------------------------------------------------------------ */

#define N_STEPS 40

static void scenario_basic(void) {
    LogBook book2 = {0}, book3 = {0};
    const fmi2CallbackFunctions f2 = callbacks2(&book2);
    fmi2Component c2;
    fmi3Instance c3;
    if (!ready_both(&book2, &f2, &book3, &c2, &c3)) return;
    const size_t n_out = 2 * setup.n_probes;
    double *out2 = calloc(N_STEPS * n_out, sizeof(double));
    double *out3 = calloc(N_STEPS * n_out, sizeof(double));
    double t2 = 0.0, t3 = 0.0;
    EXPECT(run2(c2, 0, N_STEPS, &t2, out2), "FMI 2 run failed: %s", book2.last);
    EXPECT(run3(c3, 0, N_STEPS, &t3, out3), "FMI 3 run failed: %s", book3.last);
    EXPECT(memcmp(out2, out3, N_STEPS * n_out * sizeof(double)) == 0, "FMI 2 and FMI 3 outputs differ");
    for (size_t i = 0; i < N_STEPS * n_out; i++) EXPECT(isfinite(out2[i]), "non-finite output %zu", i);
    /* FMI 3 time reaches the communication point exactly */
    const fmi3ValueReference vt = ROM_VR_TIME;
    double time3 = -1.0;
    EXPECT(fmi3GetFloat64(c3, &vt, 1, &time3, 1) == fmi3OK && time3 == t3, "FMI 3 time %.17g != %.17g", time3, t3);
    fmi2Real last = -1.0;
    EXPECT(fmi2GetRealStatus(c2, fmi2LastSuccessfulTime, &last) == fmi2OK && last == t2, "FMI 2 time %.17g", last);
    EXPECT(fmi2Terminate(c2) == fmi2OK, "fmi2Terminate");
    EXPECT(fmi3Terminate(c3) == fmi3OK, "fmi3Terminate");
    /* debug logging is honoured: logEvents on gives messages, all off gives none */
    EXPECT(fmi2Reset(c2) == fmi2OK, "fmi2Reset");
    const fmi2String events[1] = {"logEvents"};
    EXPECT(fmi2SetDebugLogging(c2, fmi2True, 1, events) == fmi2OK, "fmi2SetDebugLogging");
    const int before = book2.messages;
    EXPECT(fmi2SetupExperiment(c2, fmi2False, 0, 0, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c2) ==
           fmi2OK && fmi2ExitInitializationMode(c2) == fmi2OK && fmi2DoStep(c2, 0.0, setup.dt, fmi2True) == fmi2OK,
           "run after reset");
    EXPECT(book2.messages > before, "logEvents on: no message");
    EXPECT(fmi2SetDebugLogging(c2, fmi2False, 0, NULL) == fmi2OK, "fmi2SetDebugLogging off");
    const int before_off = book2.messages;
    EXPECT(fmi2DoStep(c2, setup.dt, setup.dt, fmi2True) == fmi2OK, "doStep");
    EXPECT(fmi2DoStep(c2, 0.0, setup.dt, fmi2True) == fmi2Error, "wrong time accepted");
    EXPECT(book2.messages == before_off, "logging off: the FMU still logged '%s'", book2.last);
    /* an unknown category is a warning naming it and the known ones; the instance stays usable */
    const fmi3String bogus[2] = {"logBogus", "logEvents"};
    const int warnings3 = book3.warnings;
    EXPECT(fmi3SetDebugLogging(c3, fmi3True, 2, bogus) == fmi3Warning, "unknown category: not fmi3Warning");
    EXPECT(book3.warnings == warnings3 + 1 && strstr(book3.last, "logBogus") && strstr(book3.last, "logEvents"),
           "unknown category: warning should name it and the known ones: %s", book3.last);
    EXPECT(fmi3Reset(c3) == fmi3OK && fmi3EnterInitializationMode(c3, fmi3False, 0, 0, fmi3False, 0) == fmi3OK &&
           fmi3ExitInitializationMode(c3) == fmi3OK, "FMI 3 instance unusable after an unknown category");
    fmi2FreeInstance(c2);
    fmi3FreeInstance(c3);
    free(out2);
    free(out3);
}

/* The calls of the get/set check, per FMI version (handles and states are void * in both) */
typedef struct {
    const char *name;
    int (*run)(void *c, int k0, int n, double *t, double *out);
    int (*get_state)(void *c, void **state);
    int (*set_state)(void *c, void *state);
} Version;

static int get_state2(void *c, void **state) { return fmi2GetFMUstate(c, state) == fmi2OK; }
static int set_state2(void *c, void *state) { return fmi2SetFMUstate(c, state) == fmi2OK; }
static int get_state3(void *c, void **state) { return fmi3GetFMUState(c, state) == fmi3OK; }
static int set_state3(void *c, void *state) { return fmi3SetFMUState(c, state) == fmi3OK; }

static const Version VERSION2 = {"FMI 2", run2, get_state2, set_state2};
static const Version VERSION3 = {"FMI 3", run3, get_state3, set_state3};

/* Run 13 steps, save the state (returned; *t1 its time), run on to N_STEPS into a, restore the state and run
 * again into b: the outputs must be the same bits. */
static void *check_get_set(const Version *v, void *c, double *a, double *b, double *t1) {
    const size_t n_out = 2 * setup.n_probes;
    double t = 0.0;
    EXPECT(v->run(c, 0, 13, &t, a), "%s: run to t1", v->name);
    *t1 = t;
    void *state = NULL;
    EXPECT(v->get_state(c, &state) && state, "%s: get the FMU state", v->name);
    EXPECT(v->run(c, 13, N_STEPS, &t, a), "%s: run to t2", v->name);
    t = *t1;
    EXPECT(v->set_state(c, state), "%s: set the FMU state", v->name);
    EXPECT(v->run(c, 13, N_STEPS, &t, b), "%s: rerun to t2", v->name);
    EXPECT(memcmp(a, b, N_STEPS * n_out * sizeof(double)) == 0, "%s get/set: outputs differ after restore", v->name);
    return state;
}

/* Little-endian fields of a serialized state, and its checksum after an edit */
static double blob_f64(const unsigned char *p) {
    uint64_t bits = 0;
    for (int i = 7; i >= 0; i--) bits = (bits << 8) | p[i];
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static void blob_put_f64(unsigned char *p, double value) {
    uint64_t bits;
    memcpy(&bits, &value, sizeof bits);
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)((bits >> (8 * i)) & 0xffu);
}

static void blob_put_u32(unsigned char *p, uint32_t value) {
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)((value >> (8 * i)) & 0xffu);
}

static void blob_seal(unsigned char *blob, size_t size) {
    blob_put_u32(blob + size - 4, rom_crc32(blob, size - 4));
}

/* A state accepted where a refusal was expected: freed, so that the failed check leaks nothing */
static void free_unexpected(fmi2Component c2, fmi2FMUstate *state) {
    if (*state) fmi2FreeFMUstate(c2, state);
    *state = NULL;
}

/* Where the parameter block (initial_state_scale, c, d) of a serialized state starts: after it come the port
 * values (area, F_port[P], port_driven, dF_port/dt[P]; none without ports) and the checksum. */
static size_t state_params_offset(size_t size) {
    const size_t ports = setup.n_ports ? 2 * (1 + (size_t)setup.n_ports) : 0;
    return size - 4 - 8 * (3 + ports);
}

/* A serialized state (blob of size bytes, saved at t1, whose run to N_STEPS gave a): the parameter block
 * initial_state_scale, c, d before the port values and the checksum, c and d 0 in a model without them and
 * their start values in a parametric one; a c or d this FMU cannot take (any other than 0 without them, outside
 * the trained range of a varied one, another value of a fixed one), a non-finite initial_state_scale, and any
 * version but ROM_STATE_VERSION are refused naming them (an older one saying why it cannot be this FMU's). */
static void check_state_parameters(fmi2Component c2, LogBook *book, const unsigned char *blob, size_t size,
                                   double t1, const double *a, double *out) {
    const size_t n_out = 2 * setup.n_probes;
    const size_t params = state_params_offset(size);
    const double c_now = blob_f64(blob + params + 8), d_now = blob_f64(blob + params + 16);
    EXPECT(blob[8] == ROM_STATE_VERSION && ROM_STATE_VERSION == 5u, "the state is version %u", (unsigned)blob[8]);
    EXPECT(isfinite(blob_f64(blob + params)), "initial_state_scale %g", blob_f64(blob + params));
    if (setup.has_params) {
        EXPECT(c_now == setup.params[0][1] && d_now == setup.params[1][1], "c = %g, d = %g: not the start values "
               "%g, %g", c_now, d_now, setup.params[0][1], setup.params[1][1]);
    } else {
        EXPECT(c_now == 0.0 && d_now == 0.0, "c = %g, d = %g: not 0 in a model without them", c_now, d_now);
    }
    unsigned char *bad = malloc(size);
    fmi2FMUstate s_bad = NULL;
    const double *row_c = setup.params[0];
    const double c_bad = !setup.has_params ? 0.1 : row_c[0] != 0.0 ? 2.0 * row_c[3] + 1.0 : row_c[1] + 1.0;
    struct { size_t at; double value; const char *name; const char *reason; } fields[3] = {
        {8, c_bad, "c", "but this FMU has no parameter c"},
        {16, NAN, "d", "but this FMU has no parameter d"},
        {0, INFINITY, "initial_state_scale", "is out of range"}};
    for (int which = 0; which < 2 && setup.has_params; which++) {
        fields[which].reason = setup.params[which][0] != 0.0 ? "is outside the trained range" : "is fixed at";
    }
    for (int i = 0; i < 3; i++) {
        char want[96];
        memcpy(bad, blob, size);
        blob_put_f64(bad + params + fields[i].at, fields[i].value);
        blob_seal(bad, size);
        EXPECT_ERROR(book, fmi2DeSerializeFMUstate(c2, (const fmi2Byte *)bad, size, &s_bad), fmi2OK);
        free_unexpected(c2, &s_bad);
        snprintf(want, sizeof want, "parameter %s = %g", fields[i].name, fields[i].value);
        EXPECT(strstr(book->last, want) != NULL && strstr(book->last, fields[i].reason) != NULL,
               "message should say '%s' and '%s': %s", want, fields[i].reason, book->last);
        EXPECT(fmi2Reset(c2) == fmi2OK, "reset");
    }
    static const uint32_t VERSIONS[4] = {1u, 3u, ROM_STATE_VERSION + 1u, 0xffffffffu};
    for (int i = 0; i < 4; i++) {
        char want[96];
        memcpy(bad, blob, size);
        blob_put_u32(bad + 8, VERSIONS[i]);
        blob_seal(bad, size);
        EXPECT_ERROR(book, fmi2DeSerializeFMUstate(c2, (const fmi2Byte *)bad, size, &s_bad), fmi2OK);
        free_unexpected(c2, &s_bad);
        snprintf(want, sizeof want, "format version %u is not supported (this binary reads %u", VERSIONS[i],
                 ROM_STATE_VERSION);
        EXPECT(strstr(book->last, want) != NULL, "message should say '%s': %s", want, book->last);
        EXPECT(VERSIONS[i] > ROM_STATE_VERSION || strstr(book->last, "restores only into the FMU that wrote it"),
               "an older version's message should say why: %s", book->last);
        EXPECT(fmi2Reset(c2) == fmi2OK, "reset");
    }
    (void)t1;
    (void)a;
    (void)out;
    (void)n_out;
    free(bad);
}

static void scenario_state(void) {
    LogBook book2 = {0}, book3 = {0};
    const fmi2CallbackFunctions f2 = callbacks2(&book2);
    fmi2Component c2;
    fmi3Instance c3;
    if (!ready_both(&book2, &f2, &book3, &c2, &c3)) return;
    const size_t n_out = 2 * setup.n_probes;
    double *a = calloc(N_STEPS * n_out, sizeof(double));
    double *b = calloc(N_STEPS * n_out, sizeof(double));
    double *c = calloc(N_STEPS * n_out, sizeof(double));
    double t, t1;
    /* FMI 2: get/set and serialize/deserialize */
    fmi2FMUstate s2 = check_get_set(&VERSION2, c2, a, b, &t1);
    size_t size = 0;
    EXPECT(fmi2SerializedFMUstateSize(c2, s2, &size) == fmi2OK && size > 0, "size");
    fmi2Byte *blob = malloc(size);
    EXPECT(fmi2SerializeFMUstate(c2, s2, blob, size) == fmi2OK, "serialize");
    fmi2FMUstate s2b = NULL;
    EXPECT(fmi2DeSerializeFMUstate(c2, blob, size, &s2b) == fmi2OK && s2b, "deserialize");
    t = t1;
    EXPECT(fmi2SetFMUstate(c2, s2b) == fmi2OK, "set deserialized");
    EXPECT(run2(c2, 13, N_STEPS, &t, c), "rerun after deserialize");
    EXPECT(memcmp(a, c, N_STEPS * n_out * sizeof(double)) == 0, "FMI 2 serialize: outputs differ after restore");
    /* a blob from another FMU (other token), truncated or corrupt: refused */
    fmi2Byte *other = malloc(size);
    memcpy(other, blob, size);
    other[40] ^= 0x01;                        /* inside the token */
    fmi2FMUstate s_bad = NULL;
    EXPECT_ERROR(&book2, fmi2DeSerializeFMUstate(c2, other, size, &s_bad), fmi2OK);
    EXPECT(s_bad == NULL, "no state may be created from a refused blob");
    free_unexpected(c2, &s_bad);
    EXPECT(strstr(book2.last, "another FMU") != NULL, "message should say 'another FMU': %s", book2.last);
    EXPECT(fmi2Reset(c2) == fmi2OK, "reset after a refused blob");
    memcpy(other, blob, size);
    other[16] ^= 0x01;                        /* k_v */
    EXPECT_ERROR(&book2, fmi2DeSerializeFMUstate(c2, other, size, &s_bad), fmi2OK);
    free_unexpected(c2, &s_bad);
    EXPECT(fmi2Reset(c2) == fmi2OK, "reset");
    EXPECT_ERROR(&book2, fmi2DeSerializeFMUstate(c2, blob, size - 5, &s_bad), fmi2OK);
    free_unexpected(c2, &s_bad);
    EXPECT(fmi2Reset(c2) == fmi2OK, "reset");
    memcpy(other, blob, size);
    other[size / 2] ^= 0x10;                  /* payload: crc mismatch */
    EXPECT_ERROR(&book2, fmi2DeSerializeFMUstate(c2, other, size, &s_bad), fmi2OK);
    free_unexpected(c2, &s_bad);
    /* restart from a saved state out of the Error state (allowed by FMI 2.0) */
    t = t1;
    EXPECT(fmi2SetFMUstate(c2, s2) == fmi2OK, "set state in the Error state");
    EXPECT(run2(c2, 13, N_STEPS, &t, b), "run after restart from error");
    EXPECT(memcmp(a, b, N_STEPS * n_out * sizeof(double)) == 0, "restart from error: outputs differ");
    check_state_parameters(c2, &book2, (const unsigned char *)blob, size, t1, a, c);
    EXPECT(fmi2FreeFMUstate(c2, &s2) == fmi2OK && s2 == NULL, "free state");
    EXPECT(fmi2FreeFMUstate(c2, &s2b) == fmi2OK, "free state");
    free(other);

    /* FMI 3 */
    fmi3FMUState s3 = check_get_set(&VERSION3, c3, a, b, &t1);
    size_t size3 = 0;
    EXPECT(fmi3SerializedFMUStateSize(c3, s3, &size3) == fmi3OK && size3 == size, "size3");
    fmi3Byte *blob3 = malloc(size3);
    EXPECT(fmi3SerializeFMUState(c3, s3, blob3, size3) == fmi3OK, "serialize3");
    /* a state serialized by FMI 3 restores in a fresh instance */
    LogBook book3b = {0};
    fmi3Instance d3 = instantiate3(&book3b, setup.path3, setup.token);
    fmi3FMUState s3b = NULL;
    EXPECT(d3 && fmi3DeserializeFMUState(d3, blob3, size3, &s3b) == fmi3OK, "deserialize3");
    EXPECT(d3 && fmi3SetFMUState(d3, s3b) == fmi3OK, "set3 in a fresh instance");
    t = t1;
    EXPECT(d3 && run3(d3, 13, N_STEPS, &t, c), "run in the fresh instance: %s", book3b.last);
    EXPECT(memcmp(a, c, N_STEPS * n_out * sizeof(double)) == 0, "FMI 3 serialize: outputs differ");
    blob3[40] ^= 0x01;
    fmi3FMUState s3_bad = NULL;
    EXPECT_ERROR(&book3, fmi3DeserializeFMUState(c3, blob3, size3, &s3_bad), fmi3OK);
    if (s3_bad) fmi3FreeFMUState(c3, &s3_bad);
    EXPECT(fmi3FreeFMUState(c3, &s3) == fmi3OK, "free3");
    if (d3) {
        EXPECT(fmi3FreeFMUState(d3, &s3b) == fmi3OK, "free3b");
        fmi3FreeInstance(d3);
    }
    fmi2FreeInstance(c2);
    fmi3FreeInstance(c3);
    free(blob);
    free(blob3);
    free(a);
    free(b);
    free(c);
}

static void scenario_bad(void) {
    LogBook book = {0};
    const fmi2CallbackFunctions f2 = callbacks2(&book);
    const fmi2ValueReference vf = ROM_VR_F, vdt = ROM_VR_DT, vnf = ROM_VR_N_FREEZE, vout = ROM_VR_V_PROBE;
    const fmi2ValueReference vbad = 777;
    double value = 0.0;
    fmi2Integer ivalue = 0;

    /* NULL instance: error, no crash */
    EXPECT(fmi2DoStep(NULL, 0.0, 1.0, fmi2True) == fmi2Error, "NULL instance");
    EXPECT(fmi2GetReal(NULL, &vf, 1, &value) == fmi2Error, "NULL instance");
    EXPECT(fmi2Reset(NULL) == fmi2Error, "NULL instance");
    fmi2FreeInstance(NULL);
    EXPECT(fmi3DoStep(NULL, 0.0, 1.0, fmi3True, NULL, NULL, NULL, NULL) == fmi3Error, "NULL instance");
    fmi3FreeInstance(NULL);

    fmi2Component c = instantiate2(&book, &f2, setup.uri, setup.token);
    EXPECT(c != NULL, "instantiate: %s", book.last);
    if (!c) return;
    /* illegal call sequences */
    EXPECT_ERROR(&book, fmi2DoStep(c, 0.0, setup.dt, fmi2True), fmi2OK);       /* before initialization */
    EXPECT(fmi2GetReal(c, &vout, 1, &value) == fmi2OK, "fmi2GetReal in the Error state (FMI 2.0 allows it, for "
           "debugging)");
    EXPECT_ERROR(&book, fmi2DoStep(c, 0.0, setup.dt, fmi2True), fmi2OK);       /* in the Error state */
    EXPECT(strstr(book.last, "Error state") != NULL, "message should name the Error state: %s", book.last);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset leaves the Error state");
    EXPECT_ERROR(&book, fmi2ExitInitializationMode(c), fmi2OK);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    /* bad parameter values */
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK, "setup");
    EXPECT(fmi2EnterInitializationMode(c) == fmi2OK, "enter");
    const fmi2Integer zero = 0;
    EXPECT_ERROR(&book, fmi2SetInteger(c, &vnf, 1, &zero), fmi2OK);
    /* the frozen model refuses the value; a linear model has no n_freeze (nor dt): no internal step */
    EXPECT(strstr(book.last, setup.kind == ROM_MODEL_FROZEN ? "n_freeze = 0 is out of range (allowed: an integer >= 1)"
                                                            : "unknown value reference 2") != NULL,
           "n_freeze = 0: %s", book.last);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    const double nan_value = NAN, inf_value = INFINITY, negative = -1.0;
    EXPECT_ERROR(&book, fmi2SetReal(c, &vdt, 1, &negative), fmi2OK);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    EXPECT_ERROR(&book, fmi2SetReal(c, &vdt, 1, &nan_value), fmi2OK);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    /* NaN and Inf input */
    EXPECT_ERROR(&book, fmi2SetReal(c, &vf, 1, &nan_value), fmi2OK);
    EXPECT(strstr(book.last, "not finite") != NULL, "NaN message: %s", book.last);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    EXPECT_ERROR(&book, fmi2SetReal(c, &vf, 1, &inf_value), fmi2OK);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    /* unknown value references, NULL arrays */
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
           fmi2OK, "init");
    EXPECT_ERROR(&book, fmi2GetReal(c, &vbad, 1, &value), fmi2OK);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
           fmi2OK, "init");
    EXPECT_ERROR(&book, fmi2GetReal(c, &vout, 1, NULL), fmi2OK);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    /* step mode: parameters are fixed, time must match, h > 0 */
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0.5, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
           fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK, "init at t = 0.5");
    if (setup.kind == ROM_MODEL_FROZEN) {
        EXPECT(fmi2GetInteger(c, &vnf, 1, &ivalue) == fmi2OK && ivalue >= 1, "n_freeze readable");
    }
    const fmi2ValueReference vfixed = setup.kind == ROM_MODEL_FROZEN ? vdt : ROM_VR_INITIAL_STATE_SCALE;
    EXPECT_ERROR(&book, fmi2SetReal(c, &vfixed, 1, &value), fmi2OK);
    EXPECT(strstr(book.last, "fixed parameter") != NULL, "message: %s", book.last);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0.5, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
           fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK, "init at t = 0.5");
    EXPECT_ERROR(&book, fmi2DoStep(c, 0.0, setup.dt, fmi2True), fmi2OK);        /* wrong time */
    EXPECT(strstr(book.last, "does not match") != NULL, "message: %s", book.last);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
           fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK, "init");
    EXPECT_ERROR(&book, fmi2DoStep(c, 0.0, 0.0, fmi2True), fmi2OK);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
           fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK, "init");
    EXPECT_ERROR(&book, fmi2DoStep(c, 0.0, -setup.dt, fmi2True), fmi2OK);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
           fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK, "init");
    EXPECT_ERROR(&book, fmi2DoStep(c, 0.0, nan_value, fmi2True), fmi2OK);
    /* everything but reset/free/setFMUstate (and, for debugging, the getters and getFMUstate) fails in the Error
     * state */
    EXPECT_ERROR(&book, fmi2SetReal(c, &vf, 1, &value), fmi2OK);
    EXPECT_ERROR(&book, fmi2Terminate(c), fmi2OK);
    EXPECT_ERROR(&book, fmi2EnterInitializationMode(c), fmi2OK);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    /* a runaway state is an error naming the time, never a silent NaN */
    const double huge_force = 1e300;
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
           fmi2OK && fmi2SetReal(c, &vf, 1, &huge_force) == fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK,
           "init with a huge force");
    EXPECT_ERROR(&book, fmi2DoStep(c, 0.0, 10 * setup.dt, fmi2True), fmi2OK);
    EXPECT(strstr(book.last, "t = ") != NULL, "runaway message should name the time: %s", book.last);
    EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    /* an unstable dt: non-finite or runaway, an error (the exact model ignores dt: any step is exact) */
    if (setup.kind == ROM_MODEL_FROZEN) {
        const double big_dt = 1e6;
        EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
               fmi2OK && fmi2SetReal(c, &vdt, 1, &big_dt) == fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK,
               "init with dt = 1e6");
        EXPECT_ERROR(&book, fmi2DoStep(c, 0.0, 1e9, fmi2True), fmi2OK);
        EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    }
    /* input derivatives: order 1 on f over the next step, both models (f continues linearly); order 2
     * refused naming what is allowed; not before initialization */
    {
        const fmi2Integer order1 = 1, order2 = 2;
        const double f0 = 0.01, rate = 0.5, h = 0.01;
        EXPECT_ERROR(&book, fmi2SetRealInputDerivatives(c, &vf, 1, &order1, &rate), fmi2OK);
        EXPECT(fmi2Reset(c) == fmi2OK, "reset");
        EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK &&
               fmi2EnterInitializationMode(c) == fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK &&
               fmi2SetReal(c, &vf, 1, &f0) == fmi2OK, "init for input derivatives");
        EXPECT(fmi2SetRealInputDerivatives(c, &vf, 1, &order1, &rate) == fmi2OK, "order 1: %s", book.last);
        EXPECT(fmi2DoStep(c, 0.0, h, fmi2True) == fmi2OK, "step with a rate: %s", book.last);
        EXPECT(fmi2GetReal(c, &vf, 1, &value) == fmi2OK && fabs(value - (f0 + rate * h)) <= 1e-15,
               "f after a step with df/dt = %g: %.17g", rate, value);
        EXPECT_ERROR(&book, fmi2SetRealInputDerivatives(c, &vf, 1, &order2, &rate), fmi2OK);
        EXPECT(strstr(book.last, "order 2 is not supported (allowed: 1)") != NULL, "message: %s", book.last);
        EXPECT(fmi2Reset(c) == fmi2OK, "reset");
    }
    /* after all that, a clean run works */
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK && fmi2EnterInitializationMode(c) ==
           fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK && fmi2DoStep(c, 0.0, 0.01, fmi2True) == fmi2OK,
           "clean run after reset: %s", book.last);
    fmi2FreeInstance(c);

    /* FMI 3 */
    LogBook book3 = {0};
    fmi3Instance c3 = instantiate3(&book3, setup.path3, setup.token);
    EXPECT(c3 != NULL, "instantiate3: %s", book3.last);
    if (!c3) return;
    fmi3Boolean e, term, early;
    fmi3Float64 last;
    EXPECT_ERROR(&book3, fmi3DoStep(c3, 0.0, setup.dt, fmi3True, &e, &term, &early, &last), fmi3OK);
    EXPECT(fmi3Reset(c3) == fmi3OK, "reset3");
    EXPECT(fmi3EnterInitializationMode(c3, fmi3False, 0, 0, fmi3False, 0) == fmi3OK, "enter3");
    EXPECT_ERROR(&book3, fmi3SetFloat64(c3, &vf, 1, &nan_value, 1), fmi3OK);
    EXPECT(fmi3Reset(c3) == fmi3OK, "reset3");
    const fmi3ValueReference vt = ROM_VR_TIME;
    EXPECT(fmi3EnterInitializationMode(c3, fmi3False, 0, 0, fmi3False, 0) == fmi3OK, "enter3");
    EXPECT_ERROR(&book3, fmi3SetFloat64(c3, &vt, 1, &value, 1), fmi3OK);
    EXPECT(fmi3Reset(c3) == fmi3OK, "reset3");
    EXPECT(fmi3EnterInitializationMode(c3, fmi3False, 0, 0, fmi3False, 0) == fmi3OK, "enter3");
    EXPECT_ERROR(&book3, fmi3GetFloat64(c3, &vf, 1, &value, 2), fmi3OK);      /* nValues mismatch */
    EXPECT(fmi3Reset(c3) == fmi3OK, "reset3");
    EXPECT(fmi3EnterInitializationMode(c3, fmi3False, 0, 0, fmi3False, 0) == fmi3OK && fmi3ExitInitializationMode(c3)
           == fmi3OK, "init3");
    const fmi3Int32 nf = 5;
    EXPECT_ERROR(&book3, fmi3SetInt32(c3, &vnf, 1, &nf, 1), fmi3OK);          /* fixed parameter in step mode */
    EXPECT_ERROR(&book3, fmi3EnterEventMode(c3), fmi3OK);
    EXPECT(fmi3Reset(c3) == fmi3OK, "reset3");
    EXPECT(fmi3EnterInitializationMode(c3, fmi3False, 0, 0, fmi3False, 0) == fmi3OK && fmi3ExitInitializationMode(c3)
           == fmi3OK, "init3");
    EXPECT_ERROR(&book3, fmi3DoStep(c3, 0.0, setup.dt, fmi3True, NULL, &term, &early, &last), fmi3OK);
    EXPECT(fmi3Reset(c3) == fmi3OK, "reset3");
    EXPECT_ERROR(&book3, fmi3UpdateDiscreteStates(c3, NULL, NULL, NULL, NULL, NULL, NULL), fmi3OK);
    fmi3FreeInstance(c3);
}

static int write_file(const char *path, const unsigned char *data, size_t size) {
    FILE *f = fopen(path, "wb");
    if (!f) return 0;
    const size_t written = fwrite(data, 1, size, f);
    fclose(f);
    return written == size;
}

static unsigned char *read_file(const char *path, size_t *size) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    const long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *data = malloc((size_t)n);
    if (data && fread(data, 1, (size_t)n, f) != (size_t)n) {
        free(data);
        data = NULL;
    }
    fclose(f);
    *size = (size_t)n;
    return data;
}

/* instantiate both versions on a resources variant; both must refuse it with a message */
static void expect_refused(const char *folder, const char *what) {
    char uri[4200], path3[4200];
    snprintf(uri, sizeof uri, "file://%s", folder);
    snprintf(path3, sizeof path3, "%s/", folder);
    LogBook book2 = {0}, book3 = {0};
    const fmi2CallbackFunctions f2 = callbacks2(&book2);
    fmi2Component c2 = instantiate2(&book2, &f2, uri, setup.token);
    fmi3Instance c3 = instantiate3(&book3, path3, setup.token);
    EXPECT(c2 == NULL && book2.errors == 1, "FMI 2 accepted resources with %s", what);
    EXPECT(c3 == NULL && book3.errors == 1, "FMI 3 accepted resources with %s", what);
    fmi2FreeInstance(c2);
    fmi3FreeInstance(c3);
}

static void scenario_resources(void) {
    char source[4300];
    snprintf(source, sizeof source, "%s/%s", setup.resources, ROM_RESOURCE_FILE);
    size_t size = 0;
    unsigned char *data = read_file(source, &size);
    EXPECT(data != NULL, "cannot read %s", source);
    if (!data) return;
    char folder[4200], file[4300];
    snprintf(folder, sizeof folder, "%s/variant", setup.scratch);
    mkdir(folder, 0755);
    snprintf(file, sizeof file, "%s/%s", folder, ROM_RESOURCE_FILE);

    /* missing file */
    remove(file);
    expect_refused(folder, "no model.bin");
    /* truncated at several lengths */
    const size_t cuts[6] = {0, 7, 40, ROM_HEADER_SIZE, size / 2, size - 1};
    for (int i = 0; i < 6; i++) {
        char what[64];
        snprintf(what, sizeof what, "the file cut to %zu bytes", cuts[i]);
        EXPECT(write_file(file, data, cuts[i]), "write");
        expect_refused(folder, what);
    }
    /* one extra byte */
    unsigned char *padded = malloc(size + 1);
    memcpy(padded, data, size);
    padded[size] = 0;
    EXPECT(write_file(file, padded, size + 1), "write");
    expect_refused(folder, "a trailing byte");
    free(padded);
    /* a flipped bit at many positions: header, arrays, token, crc */
    unsigned char *copy = malloc(size);
    const size_t step = size > 64 ? size / 61 : 1;
    for (size_t pos = 0; pos < size; pos += step) {
        memcpy(copy, data, size);
        copy[pos] ^= 0x04;
        EXPECT(write_file(file, copy, size), "write");
        char what[64];
        snprintf(what, sizeof what, "a flipped bit at byte %zu", pos);
        expect_refused(folder, what);
    }
    memcpy(copy, data, size);
    copy[size - 1] ^= 0x80;
    EXPECT(write_file(file, copy, size), "write");
    expect_refused(folder, "a corrupt crc");
    free(copy);
    /* the intact file works from the scratch folder */
    EXPECT(write_file(file, data, size), "write");
    {
        char uri[4300];
        snprintf(uri, sizeof uri, "file://%s", folder);
        LogBook book = {0};
        const fmi2CallbackFunctions f2 = callbacks2(&book);
        fmi2Component c = instantiate2(&book, &f2, uri, setup.token);
        EXPECT(c != NULL, "intact copy refused: %s", book.last);
        fmi2FreeInstance(c);
        /* wrong token, wrong type, missing arguments */
        book.errors = 0;
        c = instantiate2(&book, &f2, uri, "{00000000-0000-0000-0000-000000000000}");
        EXPECT(c == NULL && book.errors == 1 && strstr(book.last, "does not match"), "wrong GUID: %s", book.last);
        fmi2FreeInstance(c);
        c = fmi2Instantiate("x", fmi2ModelExchange, setup.token, uri, &f2, fmi2False, fmi2False);
        EXPECT(c == NULL, "model exchange accepted");
        fmi2FreeInstance(c);
        c = fmi2Instantiate("x", fmi2CoSimulation, setup.token, NULL, &f2, fmi2False, fmi2False);
        EXPECT(c == NULL, "NULL resource location accepted");
        c = fmi2Instantiate("x", fmi2CoSimulation, setup.token, "http://example.com/r", &f2, fmi2False, fmi2False);
        EXPECT(c == NULL, "http resource location accepted");
        c = fmi2Instantiate("x", fmi2CoSimulation, setup.token, uri, NULL, fmi2False, fmi2False);
        EXPECT(c == NULL, "NULL callbacks accepted");
        LogBook book3 = {0};
        fmi3Instance c3 = instantiate3(&book3, folder, "{00000000-0000-0000-0000-000000000000}");
        EXPECT(c3 == NULL && book3.errors == 1, "wrong token accepted by FMI 3");
        c3 = fmi3InstantiateModelExchange("x", setup.token, folder, fmi3False, fmi3False, &book3, logger3);
        EXPECT(c3 == NULL, "FMI 3 model exchange accepted");
        c3 = instantiate3(&book3, folder, setup.token);      /* path without a trailing slash */
        EXPECT(c3 != NULL, "FMI 3 path without trailing slash: %s", book3.last);
        fmi3FreeInstance(c3);
    }
    free(data);
}

/* Instantiate, step, save a state and free, SPHROM_DRIVER_CYCLES times (default 1000; the sanitizer runs take
 * fewer: a leak or a use after free shows in the first cycle already, and each cycle is 20x slower there). */
static int cycle_count(void) {
    const char *text = getenv("SPHROM_DRIVER_CYCLES");
    char *end = NULL;
    const long n = text ? strtol(text, &end, 10) : 1000;
    if (text && (end == text || *end != '\0' || n < 1 || n > 1000000)) {
        fprintf(stderr, "SPHROM_DRIVER_CYCLES = '%s': must be an integer from 1 to 1000000\n", text);
        exit(2);
    }
    return (int)n;
}

static void scenario_cycles(void) {
    LogBook book = {0};
    const fmi2CallbackFunctions f2 = callbacks2(&book);
    const int cycles = cycle_count();
    int ok2 = 0, ok3 = 0;
    for (int i = 0; i < cycles; i++) {
        fmi2Component c = ready2(&book, &f2);
        if (c && fmi2DoStep(c, 0.0, 2.5 * setup.dt, fmi2True) == fmi2OK) {
            fmi2FMUstate s = NULL;
            if (fmi2GetFMUstate(c, &s) == fmi2OK && fmi2FreeFMUstate(c, &s) == fmi2OK) ok2++;
        }
        fmi2FreeInstance(c);
        fmi3Instance d = ready3(&book);
        fmi3Boolean e, t, r;
        fmi3Float64 last;
        if (d && fmi3DoStep(d, 0.0, 2.5 * setup.dt, fmi3True, &e, &t, &r, &last) == fmi3OK) ok3++;
        fmi3FreeInstance(d);
    }
    EXPECT(ok2 == cycles && ok3 == cycles, "instantiate/free cycles: %d, %d of %d ok: %s", ok2, ok3, cycles,
           book.last);
}

#define N_THREADS 4

typedef struct {
    double *out;
    int ok;
} Job;

static void *thread_main(void *arg) {
    Job *job = (Job *)arg;
    LogBook book = {0};
    const fmi2CallbackFunctions f2 = callbacks2(&book);
    fmi2Component c = ready2(&book, &f2);
    double t = 0.0;
    job->ok = c != NULL && run2(c, 0, N_STEPS, &t, job->out);
    fmi2FreeInstance(c);
    return NULL;
}

static void scenario_threads(void) {
    const size_t n_out = 2 * setup.n_probes;
    pthread_t threads[N_THREADS];
    Job jobs[N_THREADS];
    for (int i = 0; i < N_THREADS; i++) {
        jobs[i].out = calloc(N_STEPS * n_out, sizeof(double));
        jobs[i].ok = 0;
        pthread_create(&threads[i], NULL, thread_main, &jobs[i]);
    }
    for (int i = 0; i < N_THREADS; i++) pthread_join(threads[i], NULL);
    for (int i = 0; i < N_THREADS; i++) {
        EXPECT(jobs[i].ok, "thread %d failed", i);
        size_t first = 0;
        while (first < N_STEPS * n_out && jobs[0].out[first] == jobs[i].out[first]) first++;
        EXPECT(first == N_STEPS * n_out, "thread %d differs at value %zu: %.17g vs %.17g", i, first,
               first < N_STEPS * n_out ? jobs[0].out[first] : 0.0, first < N_STEPS * n_out ? jobs[i].out[first] : 0.0);
    }
    for (int i = 0; i < N_THREADS; i++) free(jobs[i].out);
}


/* Edge cases: dt far above the communication step h, a serialized state of other
 * sizes, J <= 0 in the exact model. */
static fmi2Component ready2_dt(LogBook *book, const fmi2CallbackFunctions *f, double dt) {
    fmi2Component c = instantiate2(book, f, setup.uri, setup.token);
    if (!c) return NULL;
    const fmi2ValueReference vdt = ROM_VR_DT;
    const int has_dt = setup.kind == ROM_MODEL_FROZEN;      /* a linear model has no internal step: no dt */
    if (fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK ||
        fmi2EnterInitializationMode(c) != fmi2OK || (has_dt && fmi2SetReal(c, &vdt, 1, &dt) != fmi2OK) ||
        fmi2ExitInitializationMode(c) != fmi2OK) {
        fmi2FreeInstance(c);
        return NULL;
    }
    return c;
}

static void scenario_edge(void) {
    /* dt = 1e10 h: each step is one internal step of length h (not a no-op), warned once */
    const double h = setup.dt;
    LogBook big = {0}, same = {0};
    const fmi2CallbackFunctions fb = callbacks2(&big), fs = callbacks2(&same);
    fmi2Component cb = ready2_dt(&big, &fb, 1e10 * h), cs = ready2_dt(&same, &fs, h);
    EXPECT(cb && cs, "instantiation with dt failed: %s / %s", big.last, same.last);
    if (cb && cs) {
        fmi2ValueReference vr[MAX_OUT];
        const size_t n_out = output_refs(vr);
        double before[MAX_OUT], ob[MAX_OUT], os[MAX_OUT];
        const fmi2ValueReference vf = ROM_VR_F;
        const double f = 0.02;      /* inside the forced scenes' training envelope: only the dt warning is due */
        EXPECT(fmi2GetReal(cb, vr, n_out, before) == fmi2OK, "outputs before");
        for (int k = 0; k < 3; k++) {
            EXPECT(fmi2SetReal(cb, &vf, 1, &f) == fmi2OK && fmi2SetReal(cs, &vf, 1, &f) == fmi2OK, "set f");
            EXPECT(fmi2DoStep(cb, k * h, h, fmi2True) == fmi2OK, "dt = 1e10 h: doStep failed: %s", big.last);
            EXPECT(fmi2DoStep(cs, k * h, h, fmi2True) == fmi2OK, "dt = h: doStep failed: %s", same.last);
        }
        EXPECT(fmi2GetReal(cb, vr, n_out, ob) == fmi2OK && fmi2GetReal(cs, vr, n_out, os) == fmi2OK, "outputs");
        EXPECT(memcmp(ob, before, n_out * sizeof(double)) != 0, "dt = 1e10 h: the state did not advance");
        EXPECT(memcmp(ob, os, n_out * sizeof(double)) == 0, "dt = 1e10 h: outputs %.17g differ from dt = h %.17g",
               ob[0], os[0]);
        const int expected = setup.kind == ROM_MODEL_FROZEN ? 1 : 0;     /* a linear model has no dt */
        EXPECT(big.warnings == expected && same.warnings == 0, "warnings on dt > h: %d (expected %d): %s",
               big.warnings, expected, big.last);
        if (expected) EXPECT(strstr(big.last, "dt = ") && strstr(big.last, "h = ") && strstr(big.last, "t = "),
                             "the warning should name dt, h and the time: %s", big.last);
        /* FMI 2: an unknown log category is a warning, the instance goes on stepping */
        const fmi2String bogus[1] = {"logBogus"};
        const int warnings = same.warnings, errors = same.errors;
        EXPECT(fmi2SetDebugLogging(cs, fmi2True, 1, bogus) == fmi2Warning, "fmi2 unknown category: not fmi2Warning");
        EXPECT(same.warnings == warnings + 1 && same.errors == errors && strstr(same.last, "logBogus"),
               "fmi2 unknown category: %s", same.last);
        EXPECT(fmi2DoStep(cs, 3 * h, h, fmi2True) == fmi2OK, "doStep after an unknown category: %s", same.last);
        /* a serialized state whose k_v differs: the message names the field and both values */
        fmi2FMUstate st = NULL;
        size_t size = 0;
        EXPECT(fmi2GetFMUstate(cs, &st) == fmi2OK && fmi2SerializedFMUstateSize(cs, st, &size) == fmi2OK, "state");
        unsigned char *blob = calloc(size ? size : 1, 1);
        EXPECT(fmi2SerializeFMUstate(cs, st, (fmi2Byte *)blob, size) == fmi2OK, "serialize");
        const unsigned k_v = (unsigned)blob[16] | (unsigned)blob[17] << 8;
        blob[16] = (unsigned char)(blob[16] + 1);
        fmi2FMUstate other = NULL;
        EXPECT_ERROR(&same, fmi2DeSerializeFMUstate(cs, (const fmi2Byte *)blob, size, &other), fmi2OK);
        char want[64];
        snprintf(want, sizeof want, "k_v is %u in the state, %u in this FMU", k_v + 1, k_v);
        EXPECT(strstr(same.last, want) != NULL, "state of other size: message should say '%s': %s", want, same.last);
        free(blob);
        fmi2FreeFMUstate(cs, &st);
    }
    fmi2FreeInstance(cb);
    fmi2FreeInstance(cs);
    /* exact model: J = 1 + e <= 0 at a probe is named as such, not as a NaN density */
    char path[4300], message[ROM_MESSAGE_SIZE];
    snprintf(path, sizeof path, "%s/%s", setup.resources, ROM_RESOURCE_FILE);
    RomModel *model = NULL;
    EXPECT(rom_model_load_file(path, &model, message, sizeof message) == ROM_OK, "load: %s", message);
    RomState *s = model ? rom_state_new(model) : NULL;
    if (s && setup.kind == ROM_MODEL_EXACT_LINEAR) {
        /* probe 1's first e row over b (the row over z = (a; b) from k_v on; zero over a in these resources) */
        const double *row = ((const RomExactModel *)model->body)->Pe + model->k_v;
        double norm = 0.0;
        for (uint32_t q = 0; q < model->k_rho; q++) norm += row[q] * row[q];
        for (uint32_t q = 0; q < model->k_rho; q++) s->ar[q] = -2.0 * row[q] / norm;    /* e = -2 at probe 1 */
        EXPECT(rom_check_outputs(s, message, sizeof message) != ROM_OK, "J <= 0 accepted");
        EXPECT(strstr(message, "specific volume J = 1 + e = ") && strstr(message, "<= 0 at probe 1 (x/L = ") &&
               strstr(message, "compression beyond the model's range"), "J <= 0: message %s", message);
    }
    rom_state_free(s);
    rom_model_free(model);
}


/* The work of one doStep is bounded (rom.h): a dt below the floor (parameter, serialized state, resources) is
 * refused naming dt and the floor; a communication step above the cap is refused naming the cap; the smallest dt
 * accepted with the largest step accepted answers within 10 s (SPHROM_DRIVER_NO_TIMING: not timed, e.g. under
 * the sanitizers).  A linear model (no internal step) takes any of these. */
static double seconds_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int do_step_either(fmi2Component c2, fmi3Instance c3, double t, double h) {
    if (c2) return fmi2DoStep(c2, t, h, fmi2True) == fmi2OK;
    fmi3Boolean event, terminate, early;
    fmi3Float64 last;
    return fmi3DoStep(c3, t, h, fmi3True, &event, &terminate, &early, &last) == fmi3OK;
}

static void bound_version(int version) {
    const int frozen = setup.kind == ROM_MODEL_FROZEN;
    const int timed = getenv("SPHROM_DRIVER_NO_TIMING") == NULL;
    const fmi2ValueReference vdt = ROM_VR_DT;
    LogBook book = {0};
    const fmi2CallbackFunctions f2 = callbacks2(&book);
    fmi2Component c2 = NULL;
    fmi3Instance c3 = NULL;
    /* (1) dt below the floor in initialization mode: refused at once, naming dt, the value and the floor; the
     * instance is usable after a reset */
    if (frozen) {
        const double tiny = 1e-12;
        if (version == 2) {
            c2 = instantiate2(&book, &f2, setup.uri, setup.token);
            EXPECT(c2 && fmi2SetupExperiment(c2, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK &&
                   fmi2EnterInitializationMode(c2) == fmi2OK, "FMI 2 init: %s", book.last);
        } else {
            c3 = instantiate3(&book, setup.path3, setup.token);
            EXPECT(c3 && fmi3EnterInitializationMode(c3, fmi3False, 0.0, 0.0, fmi3False, 0.0) == fmi3OK,
                   "FMI 3 init: %s", book.last);
        }
        if (!c2 && !c3) return;
        const double t0 = seconds_now();
        if (c2) EXPECT_ERROR(&book, fmi2SetReal(c2, &vdt, 1, &tiny), fmi2OK);
        else EXPECT_ERROR(&book, fmi3SetFloat64(c3, &vdt, 1, &tiny, 1), fmi3OK);
        const double took = seconds_now() - t0;
        char want[96];
        snprintf(want, sizeof want, "below its floor %g s", setup.dt_floor);
        EXPECT(strstr(book.last, "dt = 1e-12 s") && strstr(book.last, want), "dt below the floor: %s", book.last);
        EXPECT(!timed || took < 0.01, "refusing dt took %.3f s", took);
        EXPECT(c2 ? fmi2Reset(c2) == fmi2OK : fmi3Reset(c3) == fmi3OK, "reset after the refused dt: %s", book.last);
        if (c2) {
            EXPECT(fmi2SetupExperiment(c2, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK &&
                   fmi2EnterInitializationMode(c2) == fmi2OK && fmi2ExitInitializationMode(c2) == fmi2OK,
                   "FMI 2 after reset: %s", book.last);
        } else {
            EXPECT(fmi3EnterInitializationMode(c3, fmi3False, 0.0, 0.0, fmi3False, 0.0) == fmi3OK &&
                   fmi3ExitInitializationMode(c3) == fmi3OK, "FMI 3 after reset: %s", book.last);
        }
        EXPECT(do_step_either(c2, c3, 0.0, 3.0 * setup.dt), "a step after the reset: %s", book.last);
        if (c2) fmi2FreeInstance(c2);
        else fmi3FreeInstance(c3);
        c2 = NULL;
        c3 = NULL;
    }
    /* (2) a serialized state carrying dt = 1e-12 (checksum recomputed): refused on deserialize (frozen) */
    if (version == 2) c2 = ready2(&book, &f2);
    else c3 = ready3(&book);
    EXPECT(c2 || c3, "instantiation: %s", book.last);
    if (!c2 && !c3) return;
    void *state = NULL;
    size_t size = 0;
    if (c2) {
        EXPECT(fmi2GetFMUstate(c2, &state) == fmi2OK && fmi2SerializedFMUstateSize(c2, state, &size) == fmi2OK,
               "state");
    } else {
        EXPECT(fmi3GetFMUState(c3, &state) == fmi3OK && fmi3SerializedFMUStateSize(c3, state, &size) == fmi3OK,
               "state");
    }
    unsigned char *blob = calloc(size ? size : 1, 1);
    if (c2) EXPECT(fmi2SerializeFMUstate(c2, state, (fmi2Byte *)blob, size) == fmi2OK, "serialize");
    else EXPECT(fmi3SerializeFMUState(c3, state, blob, size) == fmi3OK, "serialize");
    if (c2) fmi2FreeFMUstate(c2, &state);
    else fmi3FreeFMUState(c3, &state);
    /* the frozen kind's block follows a^v, a^rho: n_freeze, then dt (rom_layout.h) */
    const size_t dt_at = ROM_STATE_HEADER_SIZE + 8 * ((size_t)rom_get_u32(blob + ROM_STATE_K_V) +
                                                      rom_get_u32(blob + ROM_STATE_K_RHO)) + 8;
    if (frozen) {
        EXPECT(blob_f64(blob + dt_at) == setup.dt, "dt at byte %zu of a state: %g", dt_at, blob_f64(blob + dt_at));
        blob_put_f64(blob + dt_at, 1e-12);
        blob_seal(blob, size);
    }
    void *restored = NULL;
    if (frozen) {
        if (c2) EXPECT_ERROR(&book, fmi2DeSerializeFMUstate(c2, (const fmi2Byte *)blob, size, &restored), fmi2OK);
        else EXPECT_ERROR(&book, fmi3DeserializeFMUState(c3, blob, size, &restored), fmi3OK);
        EXPECT(restored == NULL && strstr(book.last, "dt = 1e-12 s") && strstr(book.last, "floor"),
               "state dt below the floor: %s", book.last);
    } else {                                            /* a linear model steps exactly over any h: no dt */
        if (c2) EXPECT(fmi2DeSerializeFMUstate(c2, (const fmi2Byte *)blob, size, &restored) == fmi2OK, "exact");
        else EXPECT(fmi3DeserializeFMUState(c3, blob, size, &restored) == fmi3OK, "exact");
    }
    if (restored) {
        if (c2) fmi2FreeFMUstate(c2, &restored);
        else fmi3FreeFMUState(c3, &restored);
    }
    free(blob);
    if (c2) fmi2FreeInstance(c2);
    else fmi3FreeInstance(c3);
    c2 = NULL;
    c3 = NULL;
    /* (4) doStep with h = 1e4 s and 1e7 s at the model's dt: done or refused (naming the cap) within 10 s */
    const double hs[2] = {1e4, 1e7};
    for (int i = 0; i < 2; i++) {
        if (version == 2) c2 = ready2(&book, &f2);
        else c3 = ready3(&book);
        if (!c2 && !c3) return;
        const double t0 = seconds_now();
        const int errors = book.errors;
        const int ok = do_step_either(c2, c3, 0.0, hs[i]);
        const double took = seconds_now() - t0;
        EXPECT(!timed || took < 10.0, "doStep h = %g took %.1f s", hs[i], took);
        if (frozen && hs[i] / setup.dt > setup.max_steps) {
            EXPECT(!ok && book.errors > errors && strstr(book.last, "above the cap of") &&
                   strstr(book.last, "per doStep"), "h = %g: expected the cap's refusal: %s", hs[i], book.last);
        } else {
            EXPECT(ok || strstr(book.last, "ran away") || strstr(book.last, "non-finite"), "h = %g: %s", hs[i],
                   book.last);
        }
        if (c2) fmi2FreeInstance(c2);
        else fmi3FreeInstance(c3);
        c2 = NULL;
        c3 = NULL;
    }
    /* (5) the smallest dt accepted and the largest communication step accepted: answered within 10 s */
    if (frozen && timed) {
        const double h = setup.max_steps * setup.dt_floor;
        if (version == 2) {
            c2 = instantiate2(&book, &f2, setup.uri, setup.token);
            EXPECT(c2 && fmi2SetupExperiment(c2, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK &&
                   fmi2EnterInitializationMode(c2) == fmi2OK && fmi2SetReal(c2, &vdt, 1, &setup.dt_floor) == fmi2OK &&
                   fmi2ExitInitializationMode(c2) == fmi2OK, "FMI 2 dt at the floor: %s", book.last);
        } else {
            c3 = instantiate3(&book, setup.path3, setup.token);
            EXPECT(c3 && fmi3EnterInitializationMode(c3, fmi3False, 0.0, 0.0, fmi3False, 0.0) == fmi3OK &&
                   fmi3SetFloat64(c3, &vdt, 1, &setup.dt_floor, 1) == fmi3OK &&
                   fmi3ExitInitializationMode(c3) == fmi3OK, "FMI 3 dt at the floor: %s", book.last);
        }
        if (c2 || c3) {
            const double t0 = seconds_now();
            const int ok = do_step_either(c2, c3, 0.0, h);
            const double took = seconds_now() - t0;
            printf("bound FMI %d: dt = %g s (the floor), h = %g s (%.0f internal steps, the cap): %s in %.3f s\n",
                   version, setup.dt_floor, h, setup.max_steps, ok ? "done" : book.last, took);
            EXPECT(ok || strstr(book.last, "ran away") || strstr(book.last, "non-finite"),
                   "the largest step at the smallest dt was refused: %s", book.last);
            EXPECT(took < 10.0, "the largest step at the smallest dt took %.1f s", took);
            if (c2) fmi2FreeInstance(c2);
            else fmi3FreeInstance(c3);
        }
    }
}

static void scenario_bound(void) {
    bound_version(2);
    bound_version(3);
    /* (3) resources whose dt (the frozen kind's header) is 1e-12 s, checksum recomputed: refused at instantiation
     * with the reason (below ROM_DT_MIN); a linear model has no dt */
    char source[4300];
    snprintf(source, sizeof source, "%s/%s", setup.resources, ROM_RESOURCE_FILE);
    size_t size = 0;
    unsigned char *data = read_file(source, &size);
    EXPECT(data != NULL, "cannot read %s", source);
    if (!data) return;
    char folder[4200], file[4300];
    snprintf(folder, sizeof folder, "%s/bound", setup.scratch);
    mkdir(folder, 0755);
    snprintf(file, sizeof file, "%s/%s", folder, ROM_RESOURCE_FILE);
    if (setup.kind == ROM_MODEL_FROZEN) {           /* dt: the frozen kind's own header (rom_layout.h) */
        blob_put_f64(data + ROM_HEADER_SIZE + ROM_FROZEN_HEAD_DT, 1e-12);
        blob_seal(data, size);
        EXPECT(write_file(file, data, size), "write %s", file);
        RomModel *model = NULL;
        char message[ROM_MESSAGE_SIZE];
        const RomStatus status = rom_model_load_file(file, &model, message, sizeof message);
        EXPECT(status != ROM_OK && strstr(message, "dt = 1e-12 s is below the smallest internal step"),
               "resources dt = 1e-12: %s", status == ROM_OK ? "accepted" : message);
        expect_refused(folder, "dt = 1e-12 s");
        rom_model_free(model);
    }                                               /* a linear model has no internal step: no dt to damage */
    free(data);
}

/* ------------------------------------------------------------------------ */

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s RESOURCES_DIR SCRATCH_DIR [basic|state|bad|resources|cycles|threads|edge|bound ...]\n",
                argv[0]);
        return 2;
    }
    snprintf(setup.resources, sizeof setup.resources, "%s", argv[1]);
    snprintf(setup.uri, sizeof setup.uri, "file://%s", argv[1]);
    snprintf(setup.path3, sizeof setup.path3, "%s/", argv[1]);
    setup.scratch = argv[2];
    char path[4300];
    snprintf(path, sizeof path, "%s/%s", argv[1], ROM_RESOURCE_FILE);
    RomModel *model = NULL;
    char message[ROM_MESSAGE_SIZE];
    if (rom_model_load_file(path, &model, message, sizeof message) != ROM_OK) {
        fprintf(stderr, "cannot load %s: %s\n", path, message);
        return 2;
    }
    snprintf(setup.token, sizeof setup.token, "%s", model->token);
    setup.n_probes = model->n_probes;
    setup.kind = model->kind;
    setup.n_ports = model->n_ports;
    setup.dt_floor = rom_dt_floor(model);
    RomState *probe_state = rom_state_new(model);
    setup.max_steps = probe_state ? rom_max_steps_per_call(probe_state) : 0.0;
    /* the scenarios' step unit: the model's internal step, or (a linear model has none) LINEAR_STEP */
    setup.dt = probe_state && rom_has_internal_step(model) ? rom_dt(probe_state) : LINEAR_STEP;
    rom_state_free(probe_state);
    const RomSection *params = rom_model_section(model, "PARAMS");
    setup.has_params = params != NULL;
    for (int i = 0; params && i < 8 && (uint32_t)i < params->rows * params->cols; i++) {
        setup.params[i / 4][i % 4] = params->data[i];
    }
    rom_model_free(model);

    static const char *all[] = {"basic", "state", "bad", "resources", "cycles", "threads", "edge", "bound"};
    const char **names = argc > 3 ? (const char **)(argv + 3) : all;
    const int count = argc > 3 ? argc - 3 : 8;
    for (int i = 0; i < count; i++) {
        const int before = failures, checks_before = checks;
        if (strcmp(names[i], "basic") == 0) scenario_basic();
        else if (strcmp(names[i], "state") == 0) scenario_state();
        else if (strcmp(names[i], "bad") == 0) scenario_bad();
        else if (strcmp(names[i], "resources") == 0) scenario_resources();
        else if (strcmp(names[i], "cycles") == 0) scenario_cycles();
        else if (strcmp(names[i], "threads") == 0) scenario_threads();
        else if (strcmp(names[i], "edge") == 0) scenario_edge();
        else if (strcmp(names[i], "bound") == 0) scenario_bound();
        else {
            fprintf(stderr, "unknown scenario %s\n", names[i]);
            return 2;
        }
        printf("scenario %s: %s (%d checks, %d failed)\n", names[i], failures == before ? "ok" : "FAILED",
               checks - checks_before, failures - before);
    }
    fflush(stdout);
    return failures > 100 ? 100 : failures;
}
