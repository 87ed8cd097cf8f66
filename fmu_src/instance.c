/*
 * The FMU instance, version-neutral (instance.h).
 */
#include "instance.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define INSTANCE_TEXT_SIZE (ROM_MESSAGE_SIZE + 512)    /* a message with the function's name and context */

/* snapshot tags: the mode the state was saved in */
#define TAG_INSTANTIATED 1u
#define TAG_INITIALIZATION 2u
#define TAG_STEP 3u
#define TAG_TERMINATED 4u
#define TAG_ERROR 5u            /* taken in the Error state (for debugging): restored, the instance is in it again */

/* ------------------------------------------------------------------------ */
/* logging                                                                   */
/* ------------------------------------------------------------------------ */

static const char *category_name(uint32_t bit) {
    switch (bit) {
        case INSTANCE_LOG_EVENTS: return "logEvents";
        case INSTANCE_LOG_WARNING: return "logStatusWarning";
        default: return "logStatusError";
    }
}

/* bit of a log category name, 0 when unknown */
static uint32_t category_bit(const char *name) {
    if (!name) return 0;
    if (strcmp(name, "logEvents") == 0) return INSTANCE_LOG_EVENTS;
    if (strcmp(name, "logStatusWarning") == 0) return INSTANCE_LOG_WARNING;
    if (strcmp(name, "logStatusError") == 0) return INSTANCE_LOG_ERROR;
    return 0;
}

void instance_report(const InstanceVersion *version, InstanceCallback logger, void *environment, const char *name,
                     const char *format, ...) {
    char text[INSTANCE_TEXT_SIZE];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    version->emit(logger, environment, name && *name ? name : "sphrom", INSTANCE_ERROR,
                  category_name(INSTANCE_LOG_ERROR), text);
}

static void log_text(Instance *inst, InstanceStatus status, uint32_t category, const char *format, va_list args) {
    if (!inst || !(inst->log_mask & category)) return;
    char text[INSTANCE_TEXT_SIZE];
    vsnprintf(text, sizeof text, format, args);
    inst->version->emit(inst->logger, inst->environment, inst->name, status, category_name(category), text);
}

void instance_log(Instance *inst, InstanceStatus status, uint32_t category, const char *format, ...) {
    va_list args;
    va_start(args, format);
    log_text(inst, status, category, format, args);
    va_end(args);
}

InstanceStatus instance_error(Instance *inst, const char *fn, const char *format, ...) {
    char text[INSTANCE_TEXT_SIZE];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    inst->mode = MODE_ERROR;
    instance_log(inst, INSTANCE_ERROR, INSTANCE_LOG_ERROR, "%s: %s", fn, text);
    return INSTANCE_ERROR;
}

InstanceStatus instance_set_debug_logging(Instance *inst, const char *fn, int logging_on, size_t n_categories,
                                          const char *const categories[]) {
    if (n_categories > 0 && !categories) return instance_error(inst, fn, "categories is NULL");
    if (n_categories == 0) {
        inst->log_mask = logging_on ? INSTANCE_LOG_ALL : 0;
        return INSTANCE_OK;
    }
    uint32_t mask = inst->log_mask;
    InstanceStatus status = INSTANCE_OK;
    for (size_t i = 0; i < n_categories; i++) {
        const uint32_t bit = category_bit(categories[i]);
        if (!bit) {     /* the importer's mistake, not the model's: the instance stays usable */
            instance_log(inst, INSTANCE_WARNING, INSTANCE_LOG_WARNING, "%s: unknown log category '%.200s' ignored "
                         "(known: logEvents, logStatusWarning, logStatusError)", fn,
                         categories[i] ? categories[i] : "(null)");
            status = INSTANCE_WARNING;
            continue;
        }
        mask = logging_on ? (mask | bit) : (mask & ~bit);
    }
    inst->log_mask = mask;
    return status;
}

/* ------------------------------------------------------------------------ */
/* instantiation                                                             */
/* ------------------------------------------------------------------------ */

static int hex_value(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* resources/model.bin from a resource location: a file URI (is_uri) or a folder path */
static RomStatus resource_file(const char *location, int is_uri, char *path, size_t path_size, char *message,
                               size_t message_size) {
    path[0] = '\0';
    if (!location || !*location) {
        return rom_fail(message, message_size, "no resource location given (the FMU needs its resources folder)");
    }
    const char *src = location;
    int decode = 0;
    if (is_uri && strncmp(location, "file:", 5) == 0) {
        src = location + 5;
        decode = 1;
        if (strncmp(src, "///", 3) == 0) {
            src += 2;                                   /* file:///path -> /path */
        } else if (strncmp(src, "//localhost/", 12) == 0) {
            src += 11;
        } else if (strncmp(src, "//", 2) == 0) {
            return rom_fail(message, message_size, "resource location '%s': file URIs with a host are not supported",
                            location);
        }
#if defined(_WIN32)
        if (src[0] == '/' && src[1] && src[2] == ':') src += 1;   /* /C:/dir -> C:/dir */
#endif
    } else if (is_uri && strstr(location, "://")) {
        return rom_fail(message, message_size, "resource location '%s' is not a file URI", location);
    }
    size_t n = 0;
    for (const char *c = src; *c; c++) {
        char out = *c;
        if (decode && *c == '%') {
            const int hi = hex_value(c[1]);
            const int lo = hi >= 0 ? hex_value(c[2]) : -1;
            if (hi < 0 || lo < 0 || (hi == 0 && lo == 0)) {
                return rom_fail(message, message_size, "resource location '%s': bad percent escape", location);
            }
            out = (char)(hi * 16 + lo);
            c += 2;
        }
        if (n + 1 >= path_size) {
            return rom_fail(message, message_size, "resource location '%s' is too long", location);
        }
        path[n++] = out;
    }
    if (n > 0 && path[n - 1] != '/' && path[n - 1] != '\\') {
        if (n + 1 >= path_size) {
            return rom_fail(message, message_size, "resource location '%s' is too long", location);
        }
        path[n++] = '/';
    }
    const size_t name_length = strlen(ROM_RESOURCE_FILE);
    if (n + name_length + 1 > path_size) {
        return rom_fail(message, message_size, "resource location '%s' is too long", location);
    }
    memcpy(path + n, ROM_RESOURCE_FILE, name_length + 1);
    return ROM_OK;
}

static void apply_start_values(Instance *inst);   /* the table's start values (variables, below) */

Instance *instance_new(const InstanceVersion *version, const char *fn, const char *name, const char *token,
                       const char *resource_location, int logging_on, InstanceCallback logger, void *environment) {
    char core[ROM_MESSAGE_SIZE];
    char path[4096];
    if (!name || !*name) {
        instance_report(version, logger, environment, NULL, "%s: instanceName is missing", fn);
        return NULL;
    }
    if (!token) {
        instance_report(version, logger, environment, name, "%s: %s is missing", fn, version->token_name);
        return NULL;
    }
    if (resource_file(resource_location, version->resource_uri, path, sizeof path, core, sizeof core) != ROM_OK) {
        instance_report(version, logger, environment, name, "%s: %s", fn, core);
        return NULL;
    }
    RomModel *model = NULL;
    if (rom_model_load_file(path, &model, core, sizeof core) != ROM_OK) {
        instance_report(version, logger, environment, name, "%s: cannot load the model: %s", fn, core);
        return NULL;
    }
    if (strcmp(token, model->token) != 0) {
        instance_report(version, logger, environment, name, "%s: %s '%.100s' does not match the resources' token "
                        "'%s' (modelDescription.xml and resources/model.bin belong to different FMUs)", fn,
                        version->token_name, token, model->token);
        rom_model_free(model);
        return NULL;
    }
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    RomState *state = rom_state_new(model);
    char *copy = (char *)malloc(strlen(name) + 1);
    if (!inst || !state || !copy) {
        free(inst);
        rom_state_free(state);
        free(copy);
        rom_model_free(model);
        instance_report(version, logger, environment, name, "%s: out of memory", fn);
        return NULL;
    }
    strcpy(copy, name);
    inst->model = model;
    inst->state = state;
    inst->name = copy;
    inst->version = version;
    inst->logger = logger;
    inst->environment = environment;
    inst->log_mask = INSTANCE_LOG_WARNING | INSTANCE_LOG_ERROR | (logging_on ? INSTANCE_LOG_EVENTS : 0u);
    inst->mode = MODE_INSTANTIATED;
    apply_start_values(inst);
    char about[512];
    rom_describe(model, about, sizeof about);
    instance_log(inst, INSTANCE_OK, INSTANCE_LOG_EVENTS, "%s: %s", fn, about);
    return inst;
}

void instance_free(Instance *inst) {
    if (!inst) return;
    rom_state_free(inst->state);
    rom_model_free(inst->model);
    free(inst->name);
    free(inst);
}

/* ------------------------------------------------------------------------ */
/* the state machine                                                         */
/* ------------------------------------------------------------------------ */

static const char *mode_name(const Instance *inst) {
    switch (inst->mode) {
        case MODE_INSTANTIATED: return "Instantiated";
        case MODE_INITIALIZATION: return "InitializationMode";
        case MODE_STEP: return inst->version->step_mode;
        case MODE_TERMINATED: return "Terminated";
        case MODE_ERROR: return "Error";
        default: return "unknown";
    }
}

int instance_allowed(Instance *inst, const char *fn, unsigned modes) {
    if (!inst) return 0;
    if (inst->mode & modes) return 1;
    if (inst->mode == MODE_ERROR) {
        instance_error(inst, fn, "illegal call in the Error state after an earlier error (allowed: %s)",
                       inst->version->error_exits);
    } else {
        instance_error(inst, fn, "illegal call sequence: not allowed in %s", mode_name(inst));
    }
    return 0;
}

InstanceStatus instance_setup_experiment(Instance *inst, const char *fn, double start_time, int stop_time_defined,
                                         double stop_time) {
    if (stop_time_defined && !(stop_time >= start_time)) {
        return instance_error(inst, fn, "stopTime is before startTime");
    }
    if (rom_set_start_time(inst->state, start_time, inst->message, sizeof inst->message) != ROM_OK) {
        return instance_error(inst, fn, "%s", inst->message);
    }
    return INSTANCE_OK;
}

InstanceStatus instance_enter_initialization(Instance *inst) {
    inst->mode = MODE_INITIALIZATION;
    return INSTANCE_OK;
}

/* A parametric model's operators at the state's c and d (O(k^2)), recording which ones the model holds;
 * force: assemble even when they are the ones recorded */
static RomStatus assemble_at_state(Instance *inst, int force) {
    const double c = inst->state->c, d = inst->state->d;
    if (!force && inst->assembled && c == inst->assembled_c && d == inst->assembled_d) return ROM_OK;
    if (rom_model_assemble(inst->model, inst->state, inst->message, sizeof inst->message) != ROM_OK) return ROM_FAIL;
    inst->assembled = 1;
    inst->assembled_c = c;
    inst->assembled_d = d;
    return ROM_OK;
}

static RomStatus assemble(Instance *inst) {
    if (!rom_model_section(inst->model, "PARAMS")) return ROM_OK;
    return assemble_at_state(inst, 0);
}

InstanceStatus instance_exit_initialization(Instance *inst, const char *fn) {
    /* a parametric model's operators from the parameters now fixed (O(k^2)); always, as before states carried
     * them (it also empties the exact model's exponential cache) */
    if (assemble_at_state(inst, 1) != ROM_OK) {
        return instance_error(inst, fn, "%s", inst->message);
    }
    if (rom_check_outputs(inst->state, inst->message, sizeof inst->message) != ROM_OK) {
        return instance_error(inst, fn, "%s", inst->message);
    }
    inst->mode = MODE_STEP;
    return INSTANCE_OK;
}

InstanceStatus instance_terminate(Instance *inst) {
    inst->mode = MODE_TERMINATED;
    return INSTANCE_OK;
}

InstanceStatus instance_reset(Instance *inst) {
    rom_state_reset(inst->state, 0.0);
    inst->warned_envelope = 0;
    apply_start_values(inst);
    inst->mode = MODE_INSTANTIATED;
    return INSTANCE_OK;
}

/* ------------------------------------------------------------------------ */
/* variables                                                                 */
/* ------------------------------------------------------------------------ */

typedef enum { TYPE_FLOAT64, TYPE_INT32 } VariableType;
typedef enum { ROLE_INDEPENDENT, ROLE_INPUT, ROLE_FIXED, ROLE_OUTPUT, ROLE_CALCULATED } VariableRole;
/* FIXED: fixed parameter; CALCULATED: calculated parameter (read only) */
typedef enum { COUNT_ONE, COUNT_PER_PROBE, COUNT_PER_PORT } VariableCount;   /* value references a row stands for */

/* The getters and setters the table names (fmu_variables.h), j the 0-based member of a family: for one variable
 * (j unused) a getter returning an expression of the state s, a setter calling the core's setter */
#define SCALAR_GETTER(type, name, expression) \
    static type name(const RomState *s, uint32_t j) { (void)j; return (expression); }
#define SCALAR_SETTER(type, name, core_setter) \
    static RomStatus name(RomState *s, uint32_t j, type value, char *message, size_t message_size) { \
        (void)j; \
        return core_setter(s, value, message, message_size); \
    }
SCALAR_GETTER(double, get_time, s->time)
SCALAR_GETTER(double, get_f, s->f)
/* Setting f without a new derivative holds it: the rate goes back to 0, so an
 * importer that never sets input derivatives gets held inputs. */
static RomStatus set_f(RomState *s, uint32_t j, double value, char *message, size_t message_size) {
    (void)j;
    const RomStatus status = rom_set_input(s, value, message, message_size);
    return status == ROM_OK ? rom_set_input_rate(s, 0.0, message, message_size) : status;
}
SCALAR_SETTER(double, set_f_rate, rom_set_input_rate)
SCALAR_GETTER(int32_t, get_n_freeze, rom_n_freeze(s))
SCALAR_SETTER(int64_t, set_n_freeze, rom_set_n_freeze)
SCALAR_GETTER(double, get_dt, rom_dt(s))
SCALAR_SETTER(double, set_dt, rom_set_dt)
SCALAR_GETTER(double, get_initial_state_scale, s->initial_state_scale)
SCALAR_SETTER(double, set_initial_state_scale, rom_set_initial_state_scale)

/* The certified error bounds of a linear model (section BOUNDS: row 0 force, row 1 initial state, one column per
 * probe): per probe j, and the largest over the probes */
static double bound_of(const RomState *s, uint32_t row, uint32_t j) {
    const RomSection *b = rom_model_section(s->model, "BOUNDS");
    return b && j < b->cols ? b->data[(size_t)row * b->cols + j] : NAN;
}
static double largest_bound(const RomState *s, uint32_t row) {
    double best = 0.0;
    for (uint32_t j = 0; j < s->model->n_probes; j++) best = fmax(best, bound_of(s, row, j));
    return best;
}
static double get_force_bound(const RomState *s, uint32_t j) { return bound_of(s, 0, j); }
static double get_initial_bound(const RomState *s, uint32_t j) { return bound_of(s, 1, j); }
SCALAR_GETTER(double, get_force_bound_max, largest_bound(s, 0))
SCALAR_GETTER(double, get_initial_bound_max, largest_bound(s, 1))

/* the certified error bounds (rom_bound.c): the warning's tolerance [m s^-1] */
SCALAR_GETTER(double, get_error_tolerance, s->error_tolerance)
SCALAR_SETTER(double, set_error_tolerance, rom_set_error_tolerance)

/* parametric models: the stiffness c [kg m^-1 s^-2] and the damping d [s^-1], each only where it was varied */
static RomStatus set_param_c(RomState *s, double value, char *message, size_t message_size) {
    return rom_set_param(s, ROM_PARAM_C, value, message, message_size);
}
static RomStatus set_param_d(RomState *s, double value, char *message, size_t message_size) {
    return rom_set_param(s, ROM_PARAM_D, value, message, message_size);
}
SCALAR_GETTER(double, get_c, rom_get_param(s, ROM_PARAM_C))
SCALAR_SETTER(double, set_c, set_param_c)
SCALAR_GETTER(double, get_d, rom_get_param(s, ROM_PARAM_D))
SCALAR_SETTER(double, set_d, set_param_d)

/* mechanical ports: the area, and per port j the force F_port (held when set: its rate goes back to 0) */
SCALAR_GETTER(double, get_area, s->area)
SCALAR_SETTER(double, set_area, rom_set_area)
static double get_port_force(const RomState *s, uint32_t j) { return rom_port_force(s, j); }
/* the wave form of the ports (rom_port.c): the line impedance Z */
SCALAR_GETTER(double, get_port_impedance, rom_port_impedance(s))
SCALAR_SETTER(double, set_port_impedance, rom_set_port_impedance)
static RomStatus set_port_force(RomState *s, uint32_t j, double value, char *message, size_t message_size) {
    const RomStatus status = rom_set_port_force(s, j, value, message, message_size);
    return status == ROM_OK ? rom_set_port_rate(s, j, 0.0, message, message_size) : status;
}
/* the incident wave a_port_j (held when set: its rate goes back to 0, as F_port_j's) */
static RomStatus set_port_wave(RomState *s, uint32_t j, double value, char *message, size_t message_size) {
    const RomStatus status = rom_set_port_wave(s, j, value, message, message_size);
    return status == ROM_OK ? rom_set_port_wave_rate(s, j, 0.0, message, message_size) : status;
}

/* The presence rules the table names (harness/fmu/variables.py RULES, decided there from the same resources):
 * 1 when the FMU has the rule's variables */
static int rule_fmi3(const Instance *inst) { return inst->version->has_time; }
static int rule_frozen(const Instance *inst) { return rom_has_internal_step(inst->model); }
static int rule_bounds(const Instance *inst) { return rom_model_section(inst->model, "BOUNDS") != NULL; }
static int rule_varied_c(const Instance *inst) { return rom_varies(inst->model, ROM_PARAM_C); }
static int rule_varied_d(const Instance *inst) { return rom_varies(inst->model, ROM_PARAM_D); }
static int rule_ports(const Instance *inst) { return rom_n_ports(inst->model) > 0; }
static int rule_shadow(const Instance *inst) { return rom_has_bounds(inst->model); }
static int rule_shadow_ports(const Instance *inst) { return rule_shadow(inst) && rule_ports(inst); }
static int rule_channel(const Instance *inst) { return rom_has_channel(inst->model); }

/* The FMU's variables: the one place that maps value references onto the core, its rows generated into
 * fmu_variables.h from harness/fmu/variables.py (which also writes both modelDescriptions).  A family row
 * (COUNT_PER_PROBE, COUNT_PER_PORT) stands for the value references vr + j, j < the model's probes or ports, its
 * functions receiving j; a row with a `present` rule exists only in the FMUs the rule accepts (its value
 * references are unknown in the others). */
typedef struct {
    const char *name;                      /* a family's name is name, j + 1, name_tail (v_probe_2) */
    const char *name_tail;
    uint32_t vr;
    VariableCount count;
    VariableType type;
    VariableRole role;
    int (*present)(const Instance *inst);  /* NULL: every FMU has it */
    double (*get_float64)(const RomState *s, uint32_t j);
    int32_t (*get_int32)(const RomState *s, uint32_t j);
    RomStatus (*set_float64)(RomState *s, uint32_t j, double value, char *message, size_t message_size);
    RomStatus (*set_int32)(RomState *s, uint32_t j, int64_t value, char *message, size_t message_size);
    /* outputs: the first time derivative; inputs: its rate over the next steps (NULL: none) */
    RomStatus (*get_rate)(const RomState *s, uint32_t j, double *rate, char *message, size_t message_size);
    RomStatus (*set_rate)(RomState *s, uint32_t j, double rate, char *message, size_t message_size);
    int has_start;                         /* the instance applies start after every instantiation and reset */
    double start;
} Variable;

static const Variable VARIABLES[] = {FMU_VARIABLE_ROWS};
#define N_VARIABLES (sizeof VARIABLES / sizeof VARIABLES[0])
/* lookup's slots keep a row + 1 and a member in 16 bits */
typedef char lookup_fits_16_bits[(N_VARIABLES < 65535u && ROM_MAX_PROBES < 65535u) ? 1 : -1];

/* the number of value references var stands for in this FMU (0: absent) */
static uint32_t variable_count(const Instance *inst, const Variable *var) {
    if (var->present && !var->present(inst)) return 0;
    switch (var->count) {
        case COUNT_PER_PROBE: return inst->model->n_probes;
        case COUNT_PER_PORT: return rom_n_ports(inst->model);
        default: return 1;
    }
}

/* the FMI name of var's member j (v_probe_2 for j = 1) */
static const char *variable_name(const Variable *var, uint32_t j, char *out, size_t size) {
    if (var->count == COUNT_ONE) return var->name;
    snprintf(out, size, "%s%u%s", var->name, (unsigned)(j + 1), var->name_tail ? var->name_tail : "");
    return out;
}

/* The FMU's start values (the table's constant starts; the others come from resources/model.bin, which the core
 * applies at reset): after every instantiation and reset, whatever the core's own defaults (initial_state_scale
 * starts at 0: the component at rest) */
static void apply_start_values(Instance *inst) {
    for (size_t i = 0; i < N_VARIABLES; i++) {
        const Variable *var = &VARIABLES[i];
        if (!var->has_start || !var->set_float64) continue;
        const uint32_t count = variable_count(inst, var);
        for (uint32_t j = 0; j < count; j++) (void)var->set_float64(inst->state, j, var->start, NULL, 0);
    }
}

/* the most value references var can stand for in any FMU (the presence rule and the model's counts not asked) */
static uint32_t variable_span(const Variable *var) {
    return var->count == COUNT_PER_PROBE ? ROM_MAX_PROBES : var->count == COUNT_PER_PORT ? ROM_MAX_PORTS : 1u;
}

/* row var holds value reference ref in this FMU (*j: the member of a family); a row whose span cannot hold ref is
 * passed over before its presence rule, which may search the model's sections, is asked */
static int row_holds(const Instance *inst, const Variable *var, uint32_t ref, uint32_t *j) {
    if (ref < var->vr || ref - var->vr >= variable_span(var)) return 0;
    if (ref - var->vr >= variable_count(inst, var)) return 0;
    *j = ref - var->vr;
    return 1;
}

/* the variable of value reference ref in this FMU, or NULL.  The rows' spans do not overlap, so at most one row
 * holds ref.  An importer reads and writes the same references every step: each one found is remembered in a
 * direct-mapped slot (a multiplicative hash of ref), asked first; else the table in order.  What a row holds depends
 * on the model only (its presence rule and counts), so a remembered answer stays true for the instance's life */
static const Variable *lookup(Instance *inst, uint32_t ref, uint32_t *j) {
    const uint32_t slot = (uint32_t)(ref * 2654435761u) >> (32 - INSTANCE_LOOKUP_BITS);
    if (inst->lookup_row[slot] && inst->lookup_ref[slot] == ref) {
        *j = inst->lookup_member[slot];
        return &VARIABLES[inst->lookup_row[slot] - 1];
    }
    for (size_t i = 0; i < N_VARIABLES; i++) {
        if (row_holds(inst, &VARIABLES[i], ref, j)) {
            inst->lookup_ref[slot] = ref;
            inst->lookup_row[slot] = (uint16_t)(i + 1);
            inst->lookup_member[slot] = (uint16_t)*j;
            return &VARIABLES[i];
        }
    }
    return NULL;
}

static InstanceStatus unknown_reference(Instance *inst, const char *fn, uint32_t ref) {
    return instance_error(inst, fn, "unknown value reference %u for this type", (unsigned)ref);
}

InstanceStatus instance_dependencies(Instance *inst, const char *fn, uint32_t ref, size_t *count) {
    uint32_t j;
    if (!count) return instance_error(inst, fn, "the dependency count pointer is NULL");
    if (!lookup(inst, ref, &j)) return unknown_reference(inst, fn, ref);
    *count = 0;
    return INSTANCE_OK;
}

/* the counts and arrays of a get or set call */
static InstanceStatus check_arguments(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                      const void *values, size_t n_values) {
    if (n_refs != n_values) {
        return instance_error(inst, fn, "nValues = %zu must equal nValueReferences = %zu (all variables are "
                              "scalars)", n_values, n_refs);
    }
    if (n_refs > 0 && !refs) return instance_error(inst, fn, "the value reference array is NULL");
    if (n_refs > 0 && !values) return instance_error(inst, fn, "the value array is NULL");
    return INSTANCE_OK;
}

/* reals or ints (by type) receive the values */
static InstanceStatus get_values(Instance *inst, const char *fn, VariableType type, const uint32_t refs[],
                                 size_t n_refs, double reals[], int32_t ints[], size_t n_values) {
    const void *values = type == TYPE_FLOAT64 ? (const void *)reals : (const void *)ints;
    if (check_arguments(inst, fn, refs, n_refs, values, n_values) != INSTANCE_OK) return INSTANCE_ERROR;
    for (size_t i = 0; i < n_refs; i++) {
        uint32_t j = 0;
        const Variable *var = lookup(inst, refs[i], &j);
        if (!var || var->type != type) return unknown_reference(inst, fn, refs[i]);
        if (type == TYPE_FLOAT64) {
            reals[i] = var->get_float64(inst->state, j);
        } else {
            ints[i] = var->get_int32(inst->state, j);
        }
    }
    return INSTANCE_OK;
}

/* in order: each value reference known for the type, settable in this mode, the value in range */
static InstanceStatus set_values(Instance *inst, const char *fn, VariableType type, const uint32_t refs[],
                                 size_t n_refs, const double reals[], const int32_t ints[], size_t n_values) {
    const void *values = type == TYPE_FLOAT64 ? (const void *)reals : (const void *)ints;
    if (check_arguments(inst, fn, refs, n_refs, values, n_values) != INSTANCE_OK) return INSTANCE_ERROR;
    for (size_t i = 0; i < n_refs; i++) {
        uint32_t j = 0;
        char name[64];
        const Variable *var = lookup(inst, refs[i], &j);
        if (!var || var->type != type) return unknown_reference(inst, fn, refs[i]);
        switch (var->role) {
            case ROLE_OUTPUT: return instance_error(inst, fn, "outputs cannot be set");
            case ROLE_CALCULATED:
                return instance_error(inst, fn, "%s is a calculated parameter (computed at packaging) and cannot be "
                                      "set", variable_name(var, j, name, sizeof name));
            case ROLE_INDEPENDENT:
                return instance_error(inst, fn, "%s is the independent variable and cannot be set", var->name);
            case ROLE_FIXED:
                if (inst->mode == MODE_STEP) {
                    return instance_error(inst, fn, "%s is a fixed parameter: it can be set only before %s",
                                          variable_name(var, j, name, sizeof name),
                                          inst->version->exit_initialization);
                }
                break;
            case ROLE_INPUT: break;
        }
        const RomStatus status = type == TYPE_FLOAT64
                                     ? var->set_float64(inst->state, j, reals[i], inst->message, sizeof inst->message)
                                     : var->set_int32(inst->state, j, ints[i], inst->message, sizeof inst->message);
        if (status != ROM_OK) return instance_error(inst, fn, "%s", inst->message);
    }
    return INSTANCE_OK;
}

InstanceStatus instance_get_float64(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                    double values[], size_t n_values) {
    return get_values(inst, fn, TYPE_FLOAT64, refs, n_refs, values, NULL, n_values);
}

InstanceStatus instance_set_float64(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                    const double values[], size_t n_values) {
    return set_values(inst, fn, TYPE_FLOAT64, refs, n_refs, values, NULL, n_values);
}

InstanceStatus instance_get_int32(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                  int32_t values[], size_t n_values) {
    return get_values(inst, fn, TYPE_INT32, refs, n_refs, NULL, values, n_values);
}

InstanceStatus instance_set_int32(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                  const int32_t values[], size_t n_values) {
    return set_values(inst, fn, TYPE_INT32, refs, n_refs, NULL, values, n_values);
}

InstanceStatus instance_no_variables(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                     const void *values, size_t n_values) {
    if (check_arguments(inst, fn, refs, n_refs, values, n_values) != INSTANCE_OK) return INSTANCE_ERROR;
    return n_refs == 0 ? INSTANCE_OK : unknown_reference(inst, fn, refs[0]);
}

/* the inputs that take a rate in this FMU, for messages: "1 (f), 3000 to 3001 (F_port_1 to F_port_2)" */
static void rate_inputs(const Instance *inst, char *out, size_t size) {
    size_t used = 0;
    out[0] = '\0';
    for (size_t i = 0; i < N_VARIABLES && used < size; i++) {
        const Variable *var = &VARIABLES[i];
        const uint32_t count = variable_count(inst, var);
        if (!var->set_rate || count == 0) continue;
        char first[64], last[64];
        const int n = count == 1
            ? snprintf(out + used, size - used, "%s%u (%s)", used ? ", " : "", (unsigned)var->vr,
                       variable_name(var, 0, first, sizeof first))
            : snprintf(out + used, size - used, "%s%u to %u (%s to %s)", used ? ", " : "", (unsigned)var->vr,
                       (unsigned)(var->vr + count - 1), variable_name(var, 0, first, sizeof first),
                       variable_name(var, count - 1, last, sizeof last));
        if (n < 0) break;
        used += (size_t)n;
    }
}

InstanceStatus instance_set_input_derivatives(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                             const int32_t orders[], const double values[]) {
    if (n_refs > 0 && (!refs || !orders || !values)) {
        return instance_error(inst, fn, "the value reference, order or value array is NULL");
    }
    for (size_t i = 0; i < n_refs; i++) {
        uint32_t j = 0;
        const Variable *var = lookup(inst, refs[i], &j);
        if (!var || !var->set_rate) {
            char allowed[256];
            rate_inputs(inst, allowed, sizeof allowed);
            return instance_error(inst, fn, "value reference %u is not a real input (allowed: %s)", (unsigned)refs[i],
                                  allowed);
        }
        if (orders[i] != 1) {
            return instance_error(inst, fn, "order %d is not supported (allowed: 1)", (int)orders[i]);
        }
    }
    for (size_t i = 0; i < n_refs; i++) {
        uint32_t j = 0;
        const Variable *var = lookup(inst, refs[i], &j);
        if (var->set_rate(inst->state, j, values[i], inst->message, sizeof inst->message) != ROM_OK) {
            return instance_error(inst, fn, "%s", inst->message);
        }
    }
    return INSTANCE_OK;
}

InstanceStatus instance_get_output_derivatives(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                               const int32_t orders[], double values[], size_t n_values) {
    if (check_arguments(inst, fn, refs, n_refs, values, n_values) != INSTANCE_OK) return INSTANCE_ERROR;
    if (n_refs > 0 && !orders) return instance_error(inst, fn, "the order array is NULL");
    const int max_order = rom_max_output_derivative_order(inst->model);
    for (size_t i = 0; i < n_refs; i++) {
        uint32_t j = 0;
        char name[64];
        const Variable *var = lookup(inst, refs[i], &j);
        if (!var || var->type != TYPE_FLOAT64) return unknown_reference(inst, fn, refs[i]);
        if (var->role != ROLE_OUTPUT) {
            return instance_error(inst, fn, "%s is not an output (derivatives exist for " FMU_OUTPUTS_WITH_RATES ")",
                                  variable_name(var, j, name, sizeof name));
        }
        if (max_order == 0) {
            return instance_error(inst, fn, "the frozen model provides no output derivatives "
                                  "(maxOutputDerivativeOrder = 0: its trajectory is a discrete map of internal "
                                  "steps, not a differentiable function of time)");
        }
        if (orders[i] < 1 || orders[i] > max_order) {
            return instance_error(inst, fn, "order %d of the derivative of %s is not supported "
                                  "(maxOutputDerivativeOrder = %d: allowed orders 1 to %d)", (int)orders[i],
                                  variable_name(var, j, name, sizeof name), max_order, max_order);
        }
        if (!var->get_rate) {
            return instance_error(inst, fn, "no derivative of %s is provided (derivatives exist for "
                                  FMU_OUTPUTS_WITH_RATES ")", variable_name(var, j, name, sizeof name));
        }
        if (var->get_rate(inst->state, j, &values[i], inst->message, sizeof inst->message) != ROM_OK) {
            return instance_error(inst, fn, "%s", inst->message);
        }
    }
    return INSTANCE_OK;
}

/* ------------------------------------------------------------------------ */
/* stepping                                                                  */
/* ------------------------------------------------------------------------ */

InstanceStatus instance_do_step(Instance *inst, const char *fn, double t_comm, double h) {
    if (!inst->warned_long_dt && rom_step_exceeds(inst->state, h)) {
        inst->warned_long_dt = 1;
        instance_log(inst, INSTANCE_WARNING, INSTANCE_LOG_WARNING, "%s: dt = %g s is larger than the communication "
                     "step h = %g s at t = %.9g s: such a step is one internal step of length h (warned once per "
                     "instance)", fn, rom_dt(inst->state), h, t_comm);
    }
    if (rom_do_step(inst->state, t_comm, h, inst->message, sizeof inst->message) != ROM_OK) {
        return instance_error(inst, fn, "%s", inst->message);
    }
    /* the error signal: with certified bounds, a bound above error_tolerance (rom_bound.c); without them, the
     * training envelope (rom_envelope.c).  A warning, never an error, once per instance */
    if (rom_has_bounds(inst->model)) {
        if (!inst->warned_envelope && rom_bound_exceeded(inst->state, inst->message, sizeof inst->message)) {
            inst->warned_envelope = 1;
            instance_log(inst, INSTANCE_WARNING, INSTANCE_LOG_WARNING, "%s: %s (warned once per instance)", fn,
                         inst->message);
        }
    } else if (!inst->warned_envelope && rom_envelope_check(inst->state, inst->message, sizeof inst->message)) {
        inst->warned_envelope = 1;
        instance_log(inst, INSTANCE_WARNING, INSTANCE_LOG_WARNING, "%s: %s; the frozen model may be inaccurate "
                     "there (warned once per instance)", fn, inst->message);
    }
    instance_log(inst, INSTANCE_OK, INSTANCE_LOG_EVENTS, "%s: t = %.9g s reached (%lld internal steps in all)", fn,
                 inst->state->time, (long long)inst->state->n);
    return INSTANCE_OK;
}

double instance_time(const Instance *inst) {
    return inst->state->time;
}

/* ------------------------------------------------------------------------ */
/* FMU state snapshots                                                       */
/* ------------------------------------------------------------------------ */

typedef struct {
    size_t size;
    unsigned char data[];
} Snapshot;

static uint32_t mode_tag(InstanceMode mode) {
    switch (mode) {
        case MODE_INITIALIZATION: return TAG_INITIALIZATION;
        case MODE_STEP: return TAG_STEP;
        case MODE_TERMINATED: return TAG_TERMINATED;
        case MODE_ERROR: return TAG_ERROR;
        default: return TAG_INSTANTIATED;
    }
}

static InstanceMode tag_mode(uint32_t tag) {
    switch (tag) {
        case TAG_INITIALIZATION: return MODE_INITIALIZATION;
        case TAG_STEP: return MODE_STEP;
        case TAG_TERMINATED: return MODE_TERMINATED;
        case TAG_ERROR: return MODE_ERROR;
        default: return MODE_INSTANTIATED;
    }
}

/* a snapshot of size bytes (a serialized state of some version): reuse existing when it fits, else resize it
 * (a state of another version may be given in place of one of this version) or allocate; NULL when out of
 * memory (existing is then left as it was) */
static Snapshot *snapshot_for(Snapshot *existing, size_t size) {
    if (existing && existing->size == size) return existing;
    Snapshot *snap = (Snapshot *)realloc(existing, sizeof(Snapshot) + size);
    if (snap) snap->size = size;
    return snap;
}

InstanceStatus instance_get_state(Instance *inst, const char *fn, void **snapshot) {
    if (!snapshot) return instance_error(inst, fn, "the FMU state pointer is NULL");
    Snapshot *snap = snapshot_for((Snapshot *)*snapshot, rom_state_serialized_size(inst->model));
    if (!snap) return instance_error(inst, fn, "out of memory");
    rom_state_serialize(inst->state, mode_tag(inst->mode), snap->data);
    *snapshot = snap;
    return INSTANCE_OK;
}

InstanceStatus instance_set_state(Instance *inst, const char *fn, const void *snapshot) {
    if (!snapshot) return instance_error(inst, fn, "the FMU state is NULL");
    const Snapshot *snap = (const Snapshot *)snapshot;
    uint32_t tag = 0;
    if (rom_state_deserialize(inst->state, snap->data, snap->size, &tag, inst->message, sizeof inst->message) !=
        ROM_OK) {
        return instance_error(inst, fn, "%s", inst->message);
    }
    /* the state carries c and d (format 3): a parametric model's operators follow them, as the instance that
     * saved the state had them (assembled again only when they differ from the ones this model holds) */
    if (assemble(inst) != ROM_OK) return instance_error(inst, fn, "%s", inst->message);
    inst->mode = tag_mode(tag);
    return INSTANCE_OK;
}

InstanceStatus instance_free_state(Instance *inst, const char *fn, void **snapshot) {
    if (!snapshot) return instance_error(inst, fn, "the FMU state pointer is NULL");
    free(*snapshot);
    *snapshot = NULL;
    return INSTANCE_OK;
}

InstanceStatus instance_state_size(Instance *inst, const char *fn, const void *snapshot, size_t *size) {
    if (!snapshot) return instance_error(inst, fn, "the FMU state is NULL");
    if (!size) return instance_error(inst, fn, "size is NULL");
    *size = ((const Snapshot *)snapshot)->size;
    return INSTANCE_OK;
}

InstanceStatus instance_serialize_state(Instance *inst, const char *fn, const void *snapshot, unsigned char bytes[],
                                        size_t size) {
    if (!snapshot) return instance_error(inst, fn, "the FMU state is NULL");
    if (!bytes) return instance_error(inst, fn, "serializedState is NULL");
    const Snapshot *snap = (const Snapshot *)snapshot;
    if (size != snap->size) {
        return instance_error(inst, fn, "size %zu does not match the serialized state size %zu", size, snap->size);
    }
    memcpy(bytes, snap->data, size);
    return INSTANCE_OK;
}

InstanceStatus instance_deserialize_state(Instance *inst, const char *fn, const unsigned char bytes[], size_t size,
                                          void **snapshot) {
    if (!bytes) return instance_error(inst, fn, "serializedState is NULL");
    if (!snapshot) return instance_error(inst, fn, "the FMU state pointer is NULL");
    if (rom_state_check(inst->model, bytes, size, inst->message, sizeof inst->message) != ROM_OK) {
        return instance_error(inst, fn, "%s", inst->message);
    }
    Snapshot *snap = snapshot_for((Snapshot *)*snapshot, size);
    if (!snap) return instance_error(inst, fn, "out of memory");
    memcpy(snap->data, bytes, size);
    *snapshot = snap;
    return INSTANCE_OK;
}
