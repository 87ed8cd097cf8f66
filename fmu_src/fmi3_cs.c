/*
 * FMI 3.0 co-simulation wrapper over the sphrom model core (rom.h).
 *
 * Thin glue: a state machine (Instantiated -> InitializationMode -> StepMode
 * -> Terminated, and Error), argument checks, logging through logMessage, and
 * value references mapped onto the core.  Every function of fmi3Functions.h is
 * defined; the model-exchange, scheduled-execution, event-mode, clock and
 * derivative functions report an error.  An error puts the instance into the
 * Error state, from which only fmi3Reset, fmi3FreeInstance and
 * fmi3SetFMUState (restart from a saved state) lead out.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "rom.h"

typedef enum {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepMode = 1 << 2,
    Terminated = 1 << 3,
    Error = 1 << 4
} Mode;

#define ANY_MODE (Instantiated | InitializationMode | StepMode | Terminated | Error)
#define NOT_ERROR (Instantiated | InitializationMode | StepMode | Terminated)
#define READABLE (InitializationMode | StepMode | Terminated)

#define TAG_INSTANTIATED 1u
#define TAG_INITIALIZATION 2u
#define TAG_STEP 3u
#define TAG_TERMINATED 4u

typedef struct {
    RomModel *model;
    RomState *state;
    Mode mode;
    char *name;
    fmi3LogMessageCallback logger;
    fmi3InstanceEnvironment environment;
    uint32_t log_mask;
    char message[ROM_MESSAGE_SIZE];
} Instance;

typedef struct {
    size_t size;
    unsigned char data[];
} Snapshot;

/* ------------------------------------------------------------------------ */
/* logging                                                                   */
/* ------------------------------------------------------------------------ */

static void log_message(Instance *inst, fmi3Status status, uint32_t category, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

static void log_message(Instance *inst, fmi3Status status, uint32_t category, const char *format, ...) {
    if (!inst || !inst->logger || !(inst->log_mask & category)) return;
    char text[ROM_MESSAGE_SIZE + 256];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    char full[sizeof text + 128];
    snprintf(full, sizeof full, "[%.100s] %s", inst->name, text);
    inst->logger(inst->environment, status, rom_log_category_name(category), full);
}

static fmi3Status error(Instance *inst, const char *function, const char *text) {
    inst->mode = Error;
    log_message(inst, fmi3Error, ROM_LOG_ERROR, "%s: %s", function, text);
    return fmi3Error;
}

static const char *mode_name(Mode mode) {
    switch (mode) {
        case Instantiated: return "Instantiated";
        case InitializationMode: return "InitializationMode";
        case StepMode: return "StepMode";
        case Terminated: return "Terminated";
        case Error: return "Error";
        default: return "unknown";
    }
}

static int allowed(Instance *inst, const char *function, int modes) {
    if (!inst) return 0;
    if (inst->mode & modes) return 1;
    char text[256];
    if (inst->mode == Error) {
        snprintf(text, sizeof text, "illegal call in the Error state after an earlier error (allowed: fmi3Reset, "
                 "fmi3FreeInstance, fmi3SetFMUState)");
    } else {
        snprintf(text, sizeof text, "illegal call sequence: not allowed in %s", mode_name(inst->mode));
    }
    error(inst, function, text);
    return 0;
}

#define CHECK(function, modes) \
    Instance *inst = (Instance *)instance; \
    if (!allowed(inst, function, modes)) return fmi3Error;

#define CHECK_POINTER(function, pointer) \
    if (!(pointer)) return error(inst, function, #pointer " is NULL");

/* functions this FMU does not provide: check the instance, then report */
#define NOT_PROVIDED(function, why) \
    do { \
        CHECK(function, NOT_ERROR) \
        return error(inst, function, "not provided: " why); \
    } while (0)

/* ------------------------------------------------------------------------ */
/* inquire version, logging, instantiation                                   */
/* ------------------------------------------------------------------------ */

const char *fmi3GetVersion(void) {
    return fmi3Version;
}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    CHECK("fmi3SetDebugLogging", NOT_ERROR)
    if (nCategories > 0 && !categories) return error(inst, "fmi3SetDebugLogging", "categories is NULL");
    if (nCategories == 0) {
        inst->log_mask = loggingOn ? ROM_LOG_ALL : 0;
        return fmi3OK;
    }
    uint32_t mask = inst->log_mask;
    for (size_t i = 0; i < nCategories; i++) {
        const uint32_t bit = rom_log_category(categories[i]);
        if (!bit) {
            char text[300];
            snprintf(text, sizeof text, "unknown log category '%.200s' (declared: logEvents, logStatusWarning, "
                     "logStatusError)", categories[i] ? categories[i] : "(null)");
            return error(inst, "fmi3SetDebugLogging", text);
        }
        mask = loggingOn ? (mask | bit) : (mask & ~bit);
    }
    inst->log_mask = mask;
    return fmi3OK;
}

static void instantiate_error(fmi3LogMessageCallback logger, fmi3InstanceEnvironment environment, const char *name,
                              const char *text) {
    if (!logger) return;
    char full[ROM_MESSAGE_SIZE + 512];
    snprintf(full, sizeof full, "[%.100s] %s", name ? name : "sphrom", text);
    logger(environment, fmi3Error, "logStatusError", full);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    instantiate_error(logMessage, instanceEnvironment, instanceName,
                      "fmi3InstantiateModelExchange: this FMU supports co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    instantiate_error(logMessage, instanceEnvironment, instanceName,
                      "fmi3InstantiateScheduledExecution: this FMU supports co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    (void)visible;
    (void)eventModeUsed;        /* hasEventMode = false: the FMU never needs event mode */
    (void)earlyReturnAllowed;   /* the FMU never returns early */
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    char text[ROM_MESSAGE_SIZE + 256];
    char core[ROM_MESSAGE_SIZE];
    if (!instanceName || !*instanceName) {
        instantiate_error(logMessage, instanceEnvironment, NULL, "fmi3InstantiateCoSimulation: instanceName is "
                          "missing");
        return NULL;
    }
    if (nRequiredIntermediateVariables > 0) {
        instantiate_error(logMessage, instanceEnvironment, instanceName, "fmi3InstantiateCoSimulation: this FMU "
                          "provides no intermediate variables");
        return NULL;
    }
    if (!instantiationToken) {
        instantiate_error(logMessage, instanceEnvironment, instanceName, "fmi3InstantiateCoSimulation: "
                          "instantiationToken is missing");
        return NULL;
    }
    char path[4096];
    if (rom_resource_file(resourcePath, 0, path, sizeof path, core, sizeof core) != ROM_OK) {
        snprintf(text, sizeof text, "fmi3InstantiateCoSimulation: %s", core);
        instantiate_error(logMessage, instanceEnvironment, instanceName, text);
        return NULL;
    }
    RomModel *model = NULL;
    if (rom_model_load_file(path, &model, core, sizeof core) != ROM_OK) {
        snprintf(text, sizeof text, "fmi3InstantiateCoSimulation: cannot load the model: %s", core);
        instantiate_error(logMessage, instanceEnvironment, instanceName, text);
        return NULL;
    }
    if (strcmp(instantiationToken, model->token) != 0) {
        snprintf(text, sizeof text, "fmi3InstantiateCoSimulation: instantiationToken '%.100s' does not match the "
                 "resources' token '%s' (modelDescription.xml and resources/model.bin belong to different FMUs)",
                 instantiationToken, model->token);
        rom_model_free(model);
        instantiate_error(logMessage, instanceEnvironment, instanceName, text);
        return NULL;
    }
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    RomState *state = rom_state_new(model);
    char *copy = (char *)malloc(strlen(instanceName) + 1);
    if (!inst || !state || !copy) {
        free(inst);
        rom_state_free(state);
        free(copy);
        rom_model_free(model);
        instantiate_error(logMessage, instanceEnvironment, instanceName, "fmi3InstantiateCoSimulation: out of "
                          "memory");
        return NULL;
    }
    strcpy(copy, instanceName);
    inst->model = model;
    inst->state = state;
    inst->name = copy;
    inst->logger = logMessage;
    inst->environment = instanceEnvironment;
    inst->log_mask = ROM_LOG_WARNING | ROM_LOG_ERROR | (loggingOn ? ROM_LOG_EVENTS : 0u);
    inst->mode = Instantiated;
    log_message(inst, fmi3OK, ROM_LOG_EVENTS, "fmi3InstantiateCoSimulation: k_v = %u, k_rho = %u, %u probes, "
                "dt = %g s, n_freeze = %u, %s", model->k_v, model->k_rho, model->n_probes, model->dt,
                model->n_freeze_default, model->integrator == ROM_INTEGRATOR_SYMPLECTIC ? "symplectic" : "euler");
    return inst;
}

void fmi3FreeInstance(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (!inst) return;
    rom_state_free(inst->state);
    rom_model_free(inst->model);
    free(inst->name);
    free(inst);
}

/* ------------------------------------------------------------------------ */
/* initialization, termination, reset                                        */
/* ------------------------------------------------------------------------ */

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    CHECK("fmi3EnterInitializationMode", Instantiated)
    if (stopTimeDefined && !(stopTime >= startTime)) {
        return error(inst, "fmi3EnterInitializationMode", "stopTime is before startTime");
    }
    if (rom_set_start_time(inst->state, startTime, inst->message, sizeof inst->message) != ROM_OK) {
        return error(inst, "fmi3EnterInitializationMode", inst->message);
    }
    inst->mode = InitializationMode;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    CHECK("fmi3ExitInitializationMode", InitializationMode)
    if (rom_check_outputs(inst->state, inst->message, sizeof inst->message) != ROM_OK) {
        return error(inst, "fmi3ExitInitializationMode", inst->message);
    }
    inst->mode = StepMode;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    NOT_PROVIDED("fmi3EnterEventMode", "hasEventMode = false");
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    CHECK("fmi3Terminate", StepMode)
    inst->mode = Terminated;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    CHECK("fmi3Reset", ANY_MODE)
    rom_state_reset(inst->state, 0.0);
    inst->mode = Instantiated;
    return fmi3OK;
}

/* ------------------------------------------------------------------------ */
/* getters and setters                                                       */
/* ------------------------------------------------------------------------ */

static fmi3Status unknown_reference(Instance *inst, const char *function, fmi3ValueReference vr) {
    char text[160];
    snprintf(text, sizeof text, "unknown value reference %u for this type", (unsigned)vr);
    return error(inst, function, text);
}

static fmi3Status check_counts(Instance *inst, const char *function, size_t nvr, size_t nValues) {
    if (nvr == nValues) return fmi3OK;
    char text[160];
    snprintf(text, sizeof text, "nValues = %zu must equal nValueReferences = %zu (all variables are scalars)",
             nValues, nvr);
    return error(inst, function, text);
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
    CHECK("fmi3GetFloat64", READABLE)
    if (check_counts(inst, "fmi3GetFloat64", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    if (nValueReferences == 0) return fmi3OK;
    CHECK_POINTER("fmi3GetFloat64", valueReferences)
    CHECK_POINTER("fmi3GetFloat64", values)
    const uint32_t np = inst->model->n_probes;
    for (size_t i = 0; i < nValueReferences; i++) {
        const fmi3ValueReference r = valueReferences[i];
        if (r == ROM_VR_TIME) {
            values[i] = inst->state->time;
        } else if (r == ROM_VR_F) {
            values[i] = inst->state->f;
        } else if (r == ROM_VR_DT) {
            values[i] = inst->state->dt;
        } else if (r >= ROM_VR_V_PROBE && r < ROM_VR_V_PROBE + np) {
            values[i] = rom_v_probe(inst->state, r - ROM_VR_V_PROBE);
        } else if (r >= ROM_VR_RHO_PROBE && r < ROM_VR_RHO_PROBE + np) {
            values[i] = rom_rho_probe(inst->state, r - ROM_VR_RHO_PROBE);
        } else {
            return unknown_reference(inst, "fmi3GetFloat64", r);
        }
    }
    return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues) {
    CHECK("fmi3GetInt32", READABLE)
    if (check_counts(inst, "fmi3GetInt32", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    if (nValueReferences == 0) return fmi3OK;
    CHECK_POINTER("fmi3GetInt32", valueReferences)
    CHECK_POINTER("fmi3GetInt32", values)
    for (size_t i = 0; i < nValueReferences; i++) {
        if (valueReferences[i] != ROM_VR_N_FREEZE) {
            return unknown_reference(inst, "fmi3GetInt32", valueReferences[i]);
        }
        values[i] = inst->state->n_freeze;
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
    CHECK("fmi3SetFloat64", Instantiated | InitializationMode | StepMode)
    if (check_counts(inst, "fmi3SetFloat64", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    if (nValueReferences == 0) return fmi3OK;
    CHECK_POINTER("fmi3SetFloat64", valueReferences)
    CHECK_POINTER("fmi3SetFloat64", values)
    const uint32_t np = inst->model->n_probes;
    for (size_t i = 0; i < nValueReferences; i++) {
        const fmi3ValueReference r = valueReferences[i];
        if (r == ROM_VR_F) {
            if (rom_set_input(inst->state, values[i], inst->message, sizeof inst->message) != ROM_OK) {
                return error(inst, "fmi3SetFloat64", inst->message);
            }
        } else if (r == ROM_VR_DT) {
            if (inst->mode == StepMode) {
                return error(inst, "fmi3SetFloat64", "dt is a fixed parameter: it can be set only before "
                             "fmi3ExitInitializationMode");
            }
            if (rom_set_dt(inst->state, values[i], inst->message, sizeof inst->message) != ROM_OK) {
                return error(inst, "fmi3SetFloat64", inst->message);
            }
        } else if (r == ROM_VR_TIME) {
            return error(inst, "fmi3SetFloat64", "time is the independent variable and cannot be set");
        } else if ((r >= ROM_VR_V_PROBE && r < ROM_VR_V_PROBE + np) ||
                   (r >= ROM_VR_RHO_PROBE && r < ROM_VR_RHO_PROBE + np)) {
            return error(inst, "fmi3SetFloat64", "outputs cannot be set");
        } else {
            return unknown_reference(inst, "fmi3SetFloat64", r);
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues) {
    CHECK("fmi3SetInt32", Instantiated | InitializationMode | StepMode)
    if (check_counts(inst, "fmi3SetInt32", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    if (nValueReferences == 0) return fmi3OK;
    CHECK_POINTER("fmi3SetInt32", valueReferences)
    CHECK_POINTER("fmi3SetInt32", values)
    for (size_t i = 0; i < nValueReferences; i++) {
        if (valueReferences[i] != ROM_VR_N_FREEZE) {
            return unknown_reference(inst, "fmi3SetInt32", valueReferences[i]);
        }
        if (inst->mode == StepMode) {
            return error(inst, "fmi3SetInt32", "n_freeze is a fixed parameter: it can be set only before "
                         "fmi3ExitInitializationMode");
        }
        if (rom_set_n_freeze(inst->state, values[i], inst->message, sizeof inst->message) != ROM_OK) {
            return error(inst, "fmi3SetInt32", inst->message);
        }
    }
    return fmi3OK;
}

/* types without variables: nothing to get or set */
#define NO_VARIABLES_GET(name, type) \
    fmi3Status name(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                    type values[], size_t nValues) { \
        CHECK(#name, READABLE) \
        (void)values; \
        if (check_counts(inst, #name, nValueReferences, nValues) != fmi3OK) return fmi3Error; \
        if (nValueReferences == 0) return fmi3OK; \
        CHECK_POINTER(#name, valueReferences) \
        return unknown_reference(inst, #name, valueReferences[0]); \
    }

#define NO_VARIABLES_SET(name, type) \
    fmi3Status name(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                    const type values[], size_t nValues) { \
        CHECK(#name, Instantiated | InitializationMode | StepMode) \
        (void)values; \
        if (check_counts(inst, #name, nValueReferences, nValues) != fmi3OK) return fmi3Error; \
        if (nValueReferences == 0) return fmi3OK; \
        CHECK_POINTER(#name, valueReferences) \
        return unknown_reference(inst, #name, valueReferences[0]); \
    }

NO_VARIABLES_GET(fmi3GetFloat32, fmi3Float32)
NO_VARIABLES_GET(fmi3GetInt8, fmi3Int8)
NO_VARIABLES_GET(fmi3GetUInt8, fmi3UInt8)
NO_VARIABLES_GET(fmi3GetInt16, fmi3Int16)
NO_VARIABLES_GET(fmi3GetUInt16, fmi3UInt16)
NO_VARIABLES_GET(fmi3GetUInt32, fmi3UInt32)
NO_VARIABLES_GET(fmi3GetInt64, fmi3Int64)
NO_VARIABLES_GET(fmi3GetUInt64, fmi3UInt64)
NO_VARIABLES_GET(fmi3GetBoolean, fmi3Boolean)
NO_VARIABLES_GET(fmi3GetString, fmi3String)
NO_VARIABLES_SET(fmi3SetFloat32, fmi3Float32)
NO_VARIABLES_SET(fmi3SetInt8, fmi3Int8)
NO_VARIABLES_SET(fmi3SetUInt8, fmi3UInt8)
NO_VARIABLES_SET(fmi3SetInt16, fmi3Int16)
NO_VARIABLES_SET(fmi3SetUInt16, fmi3UInt16)
NO_VARIABLES_SET(fmi3SetUInt32, fmi3UInt32)
NO_VARIABLES_SET(fmi3SetInt64, fmi3Int64)
NO_VARIABLES_SET(fmi3SetUInt64, fmi3UInt64)
NO_VARIABLES_SET(fmi3SetBoolean, fmi3Boolean)
NO_VARIABLES_SET(fmi3SetString, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    CHECK("fmi3GetBinary", READABLE)
    (void)valueSizes;
    (void)values;
    if (check_counts(inst, "fmi3GetBinary", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    if (nValueReferences == 0) return fmi3OK;
    CHECK_POINTER("fmi3GetBinary", valueReferences)
    return unknown_reference(inst, "fmi3GetBinary", valueReferences[0]);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    CHECK("fmi3SetBinary", Instantiated | InitializationMode | StepMode)
    (void)valueSizes;
    (void)values;
    if (check_counts(inst, "fmi3SetBinary", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    if (nValueReferences == 0) return fmi3OK;
    CHECK_POINTER("fmi3SetBinary", valueReferences)
    return unknown_reference(inst, "fmi3SetBinary", valueReferences[0]);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)values;
    NOT_PROVIDED("fmi3GetClock", "the FMU has no clocks");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)values;
    NOT_PROVIDED("fmi3SetClock", "the FMU has no clocks");
}

/* ------------------------------------------------------------------------ */
/* variable dependencies (all declared empty: outputs depend on the state)    */
/* ------------------------------------------------------------------------ */

static int known_reference(const Instance *inst, fmi3ValueReference r) {
    const uint32_t np = inst->model->n_probes;
    return r == ROM_VR_TIME || r == ROM_VR_F || r == ROM_VR_N_FREEZE || r == ROM_VR_DT ||
           (r >= ROM_VR_V_PROBE && r < ROM_VR_V_PROBE + np) || (r >= ROM_VR_RHO_PROBE && r < ROM_VR_RHO_PROBE + np);
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    CHECK("fmi3GetNumberOfVariableDependencies", NOT_ERROR)
    CHECK_POINTER("fmi3GetNumberOfVariableDependencies", nDependencies)
    if (!known_reference(inst, valueReference)) {
        return unknown_reference(inst, "fmi3GetNumberOfVariableDependencies", valueReference);
    }
    *nDependencies = 0;
    return fmi3OK;
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)elementIndicesOfDependent;
    (void)independents;
    (void)elementIndicesOfIndependents;
    (void)dependencyKinds;
    CHECK("fmi3GetVariableDependencies", NOT_ERROR)
    if (!known_reference(inst, dependent)) return unknown_reference(inst, "fmi3GetVariableDependencies", dependent);
    if (nDependencies != 0) {
        return error(inst, "fmi3GetVariableDependencies", "nDependencies must be 0 (no variable has dependencies)");
    }
    return fmi3OK;
}

/* ------------------------------------------------------------------------ */
/* FMU state                                                                 */
/* ------------------------------------------------------------------------ */

static uint32_t mode_tag(Mode mode) {
    switch (mode) {
        case InitializationMode: return TAG_INITIALIZATION;
        case StepMode: return TAG_STEP;
        case Terminated: return TAG_TERMINATED;
        default: return TAG_INSTANTIATED;
    }
}

static Mode tag_mode(uint32_t tag) {
    switch (tag) {
        case TAG_INITIALIZATION: return InitializationMode;
        case TAG_STEP: return StepMode;
        case TAG_TERMINATED: return Terminated;
        default: return Instantiated;
    }
}

static Snapshot *snapshot_for(Instance *inst, Snapshot *existing) {
    const size_t size = rom_state_serialized_size(inst->model);
    if (existing && existing->size == size) return existing;
    Snapshot *snap = (Snapshot *)malloc(sizeof(Snapshot) + size);
    if (snap) snap->size = size;
    return snap;
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    CHECK("fmi3GetFMUState", NOT_ERROR)
    CHECK_POINTER("fmi3GetFMUState", FMUState)
    Snapshot *snap = snapshot_for(inst, (Snapshot *)*FMUState);
    if (!snap) return error(inst, "fmi3GetFMUState", "out of memory");
    rom_state_serialize(inst->state, mode_tag(inst->mode), snap->data);
    *FMUState = snap;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    CHECK("fmi3SetFMUState", ANY_MODE)
    CHECK_POINTER("fmi3SetFMUState", FMUState)
    const Snapshot *snap = (const Snapshot *)FMUState;
    uint32_t tag = 0;
    if (rom_state_deserialize(inst->state, snap->data, snap->size, &tag, inst->message, sizeof inst->message) !=
        ROM_OK) {
        return error(inst, "fmi3SetFMUState", inst->message);
    }
    inst->mode = tag_mode(tag);
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    CHECK("fmi3FreeFMUState", ANY_MODE)
    CHECK_POINTER("fmi3FreeFMUState", FMUState)
    free(*FMUState);
    *FMUState = NULL;
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    CHECK("fmi3SerializedFMUStateSize", NOT_ERROR)
    CHECK_POINTER("fmi3SerializedFMUStateSize", FMUState)
    CHECK_POINTER("fmi3SerializedFMUStateSize", size)
    *size = ((const Snapshot *)FMUState)->size;
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    CHECK("fmi3SerializeFMUState", NOT_ERROR)
    CHECK_POINTER("fmi3SerializeFMUState", FMUState)
    CHECK_POINTER("fmi3SerializeFMUState", serializedState)
    const Snapshot *snap = (const Snapshot *)FMUState;
    if (size != snap->size) {
        char text[160];
        snprintf(text, sizeof text, "size %zu does not match the serialized state size %zu", size, snap->size);
        return error(inst, "fmi3SerializeFMUState", text);
    }
    memcpy(serializedState, snap->data, size);
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    CHECK("fmi3DeserializeFMUState", ANY_MODE)
    CHECK_POINTER("fmi3DeserializeFMUState", serializedState)
    CHECK_POINTER("fmi3DeserializeFMUState", FMUState)
    if (rom_state_check(inst->model, serializedState, size, inst->message, sizeof inst->message) != ROM_OK) {
        return error(inst, "fmi3DeserializeFMUState", inst->message);
    }
    Snapshot *snap = snapshot_for(inst, (Snapshot *)*FMUState);
    if (!snap) return error(inst, "fmi3DeserializeFMUState", "out of memory");
    memcpy(snap->data, serializedState, size);
    *FMUState = snap;
    return fmi3OK;
}

/* ------------------------------------------------------------------------ */
/* not provided: derivatives, configuration, clocks, events, model exchange  */
/* ------------------------------------------------------------------------ */

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns;
    (void)seed; (void)nSeed; (void)sensitivity; (void)nSensitivity;
    NOT_PROVIDED("fmi3GetDirectionalDerivative", "providesDirectionalDerivatives = false");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns;
    (void)seed; (void)nSeed; (void)sensitivity; (void)nSensitivity;
    NOT_PROVIDED("fmi3GetAdjointDerivative", "providesAdjointDerivatives = false");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    NOT_PROVIDED("fmi3EnterConfigurationMode", "the FMU has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    NOT_PROVIDED("fmi3ExitConfigurationMode", "the FMU has no structural parameters");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences; (void)nValueReferences; (void)intervals; (void)qualifiers;
    NOT_PROVIDED("fmi3GetIntervalDecimal", "the FMU has no clocks");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions; (void)qualifiers;
    NOT_PROVIDED("fmi3GetIntervalFraction", "the FMU has no clocks");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences; (void)nValueReferences; (void)shifts;
    NOT_PROVIDED("fmi3GetShiftDecimal", "the FMU has no clocks");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
    NOT_PROVIDED("fmi3GetShiftFraction", "the FMU has no clocks");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    (void)valueReferences; (void)nValueReferences; (void)intervals;
    NOT_PROVIDED("fmi3SetIntervalDecimal", "the FMU has no clocks");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
    NOT_PROVIDED("fmi3SetIntervalFraction", "the FMU has no clocks");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences; (void)nValueReferences; (void)shifts;
    NOT_PROVIDED("fmi3SetShiftDecimal", "the FMU has no clocks");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
    NOT_PROVIDED("fmi3SetShiftFraction", "the FMU has no clocks");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    NOT_PROVIDED("fmi3EvaluateDiscreteStates", "the FMU has no discrete states");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    (void)discreteStatesNeedUpdate; (void)terminateSimulation; (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged; (void)nextEventTimeDefined; (void)nextEventTime;
    NOT_PROVIDED("fmi3UpdateDiscreteStates", "hasEventMode = false");
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    NOT_PROVIDED("fmi3EnterContinuousTimeMode", "co-simulation only");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint; (void)enterEventMode; (void)terminateSimulation;
    NOT_PROVIDED("fmi3CompletedIntegratorStep", "co-simulation only");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    (void)time;
    NOT_PROVIDED("fmi3SetTime", "co-simulation only");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    NOT_PROVIDED("fmi3SetContinuousStates", "co-simulation only");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    (void)derivatives; (void)nContinuousStates;
    NOT_PROVIDED("fmi3GetContinuousStateDerivatives", "co-simulation only");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    (void)eventIndicators; (void)nEventIndicators;
    NOT_PROVIDED("fmi3GetEventIndicators", "co-simulation only");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    NOT_PROVIDED("fmi3GetContinuousStates", "co-simulation only");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    (void)nominals; (void)nContinuousStates;
    NOT_PROVIDED("fmi3GetNominalsOfContinuousStates", "co-simulation only");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    (void)nEventIndicators;
    NOT_PROVIDED("fmi3GetNumberOfEventIndicators", "co-simulation only");
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    (void)nContinuousStates;
    NOT_PROVIDED("fmi3GetNumberOfContinuousStates", "co-simulation only");
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    NOT_PROVIDED("fmi3EnterStepMode", "hasEventMode = false (the FMU goes to step mode on "
                 "fmi3ExitInitializationMode)");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    (void)valueReferences; (void)nValueReferences; (void)orders; (void)values; (void)nValues;
    NOT_PROVIDED("fmi3GetOutputDerivatives", "maxOutputDerivativeOrder = 0");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference; (void)activationTime;
    NOT_PROVIDED("fmi3ActivateModelPartition", "co-simulation only");
}

/* ------------------------------------------------------------------------ */
/* co-simulation                                                             */
/* ------------------------------------------------------------------------ */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK("fmi3DoStep", StepMode)
    CHECK_POINTER("fmi3DoStep", eventHandlingNeeded)
    CHECK_POINTER("fmi3DoStep", terminateSimulation)
    CHECK_POINTER("fmi3DoStep", earlyReturn)
    CHECK_POINTER("fmi3DoStep", lastSuccessfulTime)
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    const RomStatus status = rom_do_step(inst->state, currentCommunicationPoint, communicationStepSize,
                                         inst->message, sizeof inst->message);
    *lastSuccessfulTime = inst->state->time;   /* t_comm + h, or the last point reached on an error */
    if (status != ROM_OK) return error(inst, "fmi3DoStep", inst->message);
    log_message(inst, fmi3OK, ROM_LOG_EVENTS, "fmi3DoStep: t = %.9g s reached (%lld internal steps in all)",
                inst->state->time, (long long)inst->state->n);
    return fmi3OK;
}
