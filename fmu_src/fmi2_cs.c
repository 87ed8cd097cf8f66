/*
 * FMI 2.0 co-simulation wrapper over the sphrom model core (rom.h).
 *
 * Thin glue: a state machine (Instantiated -> InitializationMode -> StepComplete
 * -> Terminated, and Error), argument checks, logging through the importer's
 * logger, and value references mapped onto the core.  Every function checks
 * its instance, its state and its arguments; an error puts the instance into
 * the Error state, from which only fmi2Reset, fmi2FreeInstance and
 * fmi2SetFMUstate (restart from a saved state, as the standard allows) lead out.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "rom.h"

typedef enum {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepComplete = 1 << 2,
    Terminated = 1 << 3,
    Error = 1 << 4
} Mode;

#define ANY_MODE (Instantiated | InitializationMode | StepComplete | Terminated | Error)
#define NOT_ERROR (Instantiated | InitializationMode | StepComplete | Terminated)

/* snapshot tags: the mode the state was saved in */
#define TAG_INSTANTIATED 1u
#define TAG_INITIALIZATION 2u
#define TAG_STEP 3u
#define TAG_TERMINATED 4u

typedef struct {
    RomModel *model;
    RomState *state;
    Mode mode;
    char *name;
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment environment;
    uint32_t log_mask;               /* enabled ROM_LOG_* categories */
    char message[ROM_MESSAGE_SIZE];  /* the core's last message */
} Instance;

typedef struct {
    size_t size;
    unsigned char data[];
} Snapshot;

/* ------------------------------------------------------------------------ */
/* logging                                                                   */
/* ------------------------------------------------------------------------ */

static void emit(fmi2CallbackLogger logger, fmi2ComponentEnvironment environment, const char *name,
                 fmi2Status status, const char *category, const char *text, char *escaped, size_t escaped_size) {
    if (!logger) return;
    /* FMI 2.0: the message is a printf format and '#' starts a value
     * reference (#r12#): escape both as '%%' and '##' */
    size_t n = 0;
    for (const char *c = text; *c && n + 2 < escaped_size; c++) {
        if (*c == '%' || *c == '#') escaped[n++] = *c;
        escaped[n++] = *c;
    }
    escaped[n] = '\0';
    logger(environment, name ? name : "sphrom", status, category, escaped);
}

static void log_message(Instance *inst, fmi2Status status, uint32_t category, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

static void log_message(Instance *inst, fmi2Status status, uint32_t category, const char *format, ...) {
    if (!inst || !(inst->log_mask & category)) return;
    char text[ROM_MESSAGE_SIZE + 256];
    char escaped[2 * sizeof text];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    emit(inst->logger, inst->environment, inst->name, status, rom_log_category_name(category), text, escaped,
         sizeof escaped);
}

/* log an error, enter the Error state, return fmi2Error */
static fmi2Status error(Instance *inst, const char *function, const char *text) {
    inst->mode = Error;
    log_message(inst, fmi2Error, ROM_LOG_ERROR, "%s: %s", function, text);
    return fmi2Error;
}

static const char *mode_name(Mode mode) {
    switch (mode) {
        case Instantiated: return "Instantiated";
        case InitializationMode: return "InitializationMode";
        case StepComplete: return "StepComplete";
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
        snprintf(text, sizeof text, "illegal call in the Error state after an earlier error (allowed: fmi2Reset, "
                 "fmi2FreeInstance, fmi2SetFMUstate)");
    } else {
        snprintf(text, sizeof text, "illegal call sequence: not allowed in %s", mode_name(inst->mode));
    }
    error(inst, function, text);
    return 0;
}

#define CHECK(function, modes) \
    Instance *inst = (Instance *)c; \
    if (!allowed(inst, function, modes)) return fmi2Error;

#define CHECK_POINTER(function, pointer) \
    if (!(pointer)) return error(inst, function, #pointer " is NULL");

/* ------------------------------------------------------------------------ */
/* common functions                                                          */
/* ------------------------------------------------------------------------ */

const char *fmi2GetTypesPlatform(void) {
    return fmi2TypesPlatform;
}

const char *fmi2GetVersion(void) {
    return fmi2Version;
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    CHECK("fmi2SetDebugLogging", NOT_ERROR)
    if (nCategories > 0 && !categories) return error(inst, "fmi2SetDebugLogging", "categories is NULL");
    if (nCategories == 0) {
        inst->log_mask = loggingOn ? ROM_LOG_ALL : 0;
        return fmi2OK;
    }
    uint32_t mask = inst->log_mask;
    for (size_t i = 0; i < nCategories; i++) {
        const uint32_t bit = rom_log_category(categories[i]);
        if (!bit) {
            char text[300];
            snprintf(text, sizeof text, "unknown log category '%.200s' (declared: logEvents, logStatusWarning, "
                     "logStatusError)", categories[i] ? categories[i] : "(null)");
            return error(inst, "fmi2SetDebugLogging", text);
        }
        mask = loggingOn ? (mask | bit) : (mask & ~bit);
    }
    inst->log_mask = mask;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)visible;
    fmi2CallbackLogger logger = functions ? functions->logger : NULL;
    fmi2ComponentEnvironment environment = functions ? functions->componentEnvironment : NULL;
    char text[ROM_MESSAGE_SIZE + 512];
    char escaped[2 * sizeof text];
    const char *name = instanceName && *instanceName ? instanceName : "sphrom";
#define INSTANTIATE_FAIL(...) \
    do { \
        snprintf(text, sizeof text, __VA_ARGS__); \
        emit(logger, environment, name, fmi2Error, "logStatusError", text, escaped, sizeof escaped); \
        return NULL; \
    } while (0)
    if (!functions) return NULL;
    if (!instanceName || !*instanceName) INSTANTIATE_FAIL("fmi2Instantiate: instanceName is missing");
    if (fmuType != fmi2CoSimulation) {
        INSTANTIATE_FAIL("fmi2Instantiate: this FMU supports co-simulation only (fmuType = %d)", (int)fmuType);
    }
    if (!fmuGUID) INSTANTIATE_FAIL("fmi2Instantiate: fmuGUID is missing");
    char path[4096];
    char core[ROM_MESSAGE_SIZE];
    if (rom_resource_file(fmuResourceLocation, 1, path, sizeof path, core, sizeof core) != ROM_OK) {
        INSTANTIATE_FAIL("fmi2Instantiate: %s", core);
    }
    RomModel *model = NULL;
    if (rom_model_load_file(path, &model, core, sizeof core) != ROM_OK) {
        INSTANTIATE_FAIL("fmi2Instantiate: cannot load the model: %s", core);
    }
    if (strcmp(fmuGUID, model->token) != 0) {
        snprintf(text, sizeof text, "fmi2Instantiate: fmuGUID '%.100s' does not match the resources' token '%s' "
                 "(modelDescription.xml and resources/model.bin belong to different FMUs)", fmuGUID, model->token);
        rom_model_free(model);
        emit(logger, environment, name, fmi2Error, "logStatusError", text, escaped, sizeof escaped);
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
        INSTANTIATE_FAIL("fmi2Instantiate: out of memory");
    }
#undef INSTANTIATE_FAIL
    strcpy(copy, instanceName);
    inst->model = model;
    inst->state = state;
    inst->name = copy;
    inst->logger = logger;
    inst->environment = environment;
    inst->log_mask = ROM_LOG_WARNING | ROM_LOG_ERROR | (loggingOn ? ROM_LOG_EVENTS : 0u);
    inst->mode = Instantiated;
    log_message(inst, fmi2OK, ROM_LOG_EVENTS, "fmi2Instantiate: k_v = %u, k_rho = %u, %u probes, dt = %g s, "
                "n_freeze = %u, %s", model->k_v, model->k_rho, model->n_probes, model->dt, model->n_freeze_default,
                model->integrator == ROM_INTEGRATOR_SYMPLECTIC ? "symplectic" : "euler");
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return;
    rom_state_free(inst->state);
    rom_model_free(inst->model);
    free(inst->name);
    free(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    CHECK("fmi2SetupExperiment", Instantiated)
    if (stopTimeDefined && !(stopTime >= startTime)) {
        return error(inst, "fmi2SetupExperiment", "stopTime is before startTime");
    }
    if (rom_set_start_time(inst->state, startTime, inst->message, sizeof inst->message) != ROM_OK) {
        return error(inst, "fmi2SetupExperiment", inst->message);
    }
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    CHECK("fmi2EnterInitializationMode", Instantiated)
    inst->mode = InitializationMode;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    CHECK("fmi2ExitInitializationMode", InitializationMode)
    if (rom_check_outputs(inst->state, inst->message, sizeof inst->message) != ROM_OK) {
        return error(inst, "fmi2ExitInitializationMode", inst->message);
    }
    inst->mode = StepComplete;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK("fmi2Terminate", StepComplete)
    inst->mode = Terminated;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    CHECK("fmi2Reset", ANY_MODE)
    rom_state_reset(inst->state, 0.0);
    inst->mode = Instantiated;
    return fmi2OK;
}

/* ------------------------------------------------------------------------ */
/* variables                                                                 */
/* ------------------------------------------------------------------------ */

static fmi2Status unknown_reference(Instance *inst, const char *function, fmi2ValueReference vr) {
    char text[160];
    snprintf(text, sizeof text, "unknown value reference %u for this type", (unsigned)vr);
    return error(inst, function, text);
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    CHECK("fmi2GetReal", InitializationMode | StepComplete | Terminated)
    if (nvr == 0) return fmi2OK;
    CHECK_POINTER("fmi2GetReal", vr)
    CHECK_POINTER("fmi2GetReal", value)
    const uint32_t np = inst->model->n_probes;
    for (size_t i = 0; i < nvr; i++) {
        const fmi2ValueReference r = vr[i];
        if (r == ROM_VR_F) {
            value[i] = inst->state->f;
        } else if (r == ROM_VR_DT) {
            value[i] = inst->state->dt;
        } else if (r >= ROM_VR_V_PROBE && r < ROM_VR_V_PROBE + np) {
            value[i] = rom_v_probe(inst->state, r - ROM_VR_V_PROBE);
        } else if (r >= ROM_VR_RHO_PROBE && r < ROM_VR_RHO_PROBE + np) {
            value[i] = rom_rho_probe(inst->state, r - ROM_VR_RHO_PROBE);
        } else {
            return unknown_reference(inst, "fmi2GetReal", r);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    CHECK("fmi2GetInteger", InitializationMode | StepComplete | Terminated)
    if (nvr == 0) return fmi2OK;
    CHECK_POINTER("fmi2GetInteger", vr)
    CHECK_POINTER("fmi2GetInteger", value)
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] != ROM_VR_N_FREEZE) return unknown_reference(inst, "fmi2GetInteger", vr[i]);
        value[i] = inst->state->n_freeze;
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    CHECK("fmi2GetBoolean", InitializationMode | StepComplete | Terminated)
    (void)value;
    if (nvr == 0) return fmi2OK;
    CHECK_POINTER("fmi2GetBoolean", vr)
    return unknown_reference(inst, "fmi2GetBoolean", vr[0]);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    CHECK("fmi2GetString", InitializationMode | StepComplete | Terminated)
    (void)value;
    if (nvr == 0) return fmi2OK;
    CHECK_POINTER("fmi2GetString", vr)
    return unknown_reference(inst, "fmi2GetString", vr[0]);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    CHECK("fmi2SetReal", Instantiated | InitializationMode | StepComplete)
    if (nvr == 0) return fmi2OK;
    CHECK_POINTER("fmi2SetReal", vr)
    CHECK_POINTER("fmi2SetReal", value)
    for (size_t i = 0; i < nvr; i++) {
        const fmi2ValueReference r = vr[i];
        if (r == ROM_VR_F) {
            if (rom_set_input(inst->state, value[i], inst->message, sizeof inst->message) != ROM_OK) {
                return error(inst, "fmi2SetReal", inst->message);
            }
        } else if (r == ROM_VR_DT) {
            if (inst->mode == StepComplete) {
                return error(inst, "fmi2SetReal", "dt is a fixed parameter: it can be set only before "
                             "fmi2ExitInitializationMode");
            }
            if (rom_set_dt(inst->state, value[i], inst->message, sizeof inst->message) != ROM_OK) {
                return error(inst, "fmi2SetReal", inst->message);
            }
        } else if ((r >= ROM_VR_V_PROBE && r < ROM_VR_V_PROBE + inst->model->n_probes) ||
                   (r >= ROM_VR_RHO_PROBE && r < ROM_VR_RHO_PROBE + inst->model->n_probes)) {
            return error(inst, "fmi2SetReal", "outputs cannot be set");
        } else {
            return unknown_reference(inst, "fmi2SetReal", r);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    CHECK("fmi2SetInteger", Instantiated | InitializationMode | StepComplete)
    if (nvr == 0) return fmi2OK;
    CHECK_POINTER("fmi2SetInteger", vr)
    CHECK_POINTER("fmi2SetInteger", value)
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] != ROM_VR_N_FREEZE) return unknown_reference(inst, "fmi2SetInteger", vr[i]);
        if (inst->mode == StepComplete) {
            return error(inst, "fmi2SetInteger", "n_freeze is a fixed parameter: it can be set only before "
                         "fmi2ExitInitializationMode");
        }
        if (rom_set_n_freeze(inst->state, value[i], inst->message, sizeof inst->message) != ROM_OK) {
            return error(inst, "fmi2SetInteger", inst->message);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    CHECK("fmi2SetBoolean", Instantiated | InitializationMode | StepComplete)
    (void)value;
    if (nvr == 0) return fmi2OK;
    CHECK_POINTER("fmi2SetBoolean", vr)
    return unknown_reference(inst, "fmi2SetBoolean", vr[0]);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    CHECK("fmi2SetString", Instantiated | InitializationMode | StepComplete)
    (void)value;
    if (nvr == 0) return fmi2OK;
    CHECK_POINTER("fmi2SetString", vr)
    return unknown_reference(inst, "fmi2SetString", vr[0]);
}

/* ------------------------------------------------------------------------ */
/* FMU state                                                                 */
/* ------------------------------------------------------------------------ */

static uint32_t mode_tag(Mode mode) {
    switch (mode) {
        case InitializationMode: return TAG_INITIALIZATION;
        case StepComplete: return TAG_STEP;
        case Terminated: return TAG_TERMINATED;
        default: return TAG_INSTANTIATED;
    }
}

static Mode tag_mode(uint32_t tag) {
    switch (tag) {
        case TAG_INITIALIZATION: return InitializationMode;
        case TAG_STEP: return StepComplete;
        case TAG_TERMINATED: return Terminated;
        default: return Instantiated;
    }
}

/* a snapshot of the right size: reuse *existing when it fits, else allocate */
static Snapshot *snapshot_for(Instance *inst, Snapshot *existing) {
    const size_t size = rom_state_serialized_size(inst->model);
    if (existing && existing->size == size) return existing;
    Snapshot *snap = (Snapshot *)malloc(sizeof(Snapshot) + size);
    if (snap) snap->size = size;
    return snap;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK("fmi2GetFMUstate", NOT_ERROR)
    CHECK_POINTER("fmi2GetFMUstate", FMUstate)
    Snapshot *snap = snapshot_for(inst, (Snapshot *)*FMUstate);
    if (!snap) return error(inst, "fmi2GetFMUstate", "out of memory");
    rom_state_serialize(inst->state, mode_tag(inst->mode), snap->data);
    *FMUstate = snap;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    CHECK("fmi2SetFMUstate", ANY_MODE)
    CHECK_POINTER("fmi2SetFMUstate", FMUstate)
    const Snapshot *snap = (const Snapshot *)FMUstate;
    uint32_t tag = 0;
    if (rom_state_deserialize(inst->state, snap->data, snap->size, &tag, inst->message, sizeof inst->message) !=
        ROM_OK) {
        return error(inst, "fmi2SetFMUstate", inst->message);
    }
    inst->mode = tag_mode(tag);
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK("fmi2FreeFMUstate", ANY_MODE)
    CHECK_POINTER("fmi2FreeFMUstate", FMUstate)
    free(*FMUstate);
    *FMUstate = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    CHECK("fmi2SerializedFMUstateSize", NOT_ERROR)
    CHECK_POINTER("fmi2SerializedFMUstateSize", FMUstate)
    CHECK_POINTER("fmi2SerializedFMUstateSize", size)
    *size = ((const Snapshot *)FMUstate)->size;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    CHECK("fmi2SerializeFMUstate", NOT_ERROR)
    CHECK_POINTER("fmi2SerializeFMUstate", FMUstate)
    CHECK_POINTER("fmi2SerializeFMUstate", serializedState)
    const Snapshot *snap = (const Snapshot *)FMUstate;
    if (size != snap->size) {
        char text[160];
        snprintf(text, sizeof text, "size %zu does not match the serialized state size %zu", size, snap->size);
        return error(inst, "fmi2SerializeFMUstate", text);
    }
    memcpy(serializedState, snap->data, size);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    CHECK("fmi2DeSerializeFMUstate", ANY_MODE)
    CHECK_POINTER("fmi2DeSerializeFMUstate", serializedState)
    CHECK_POINTER("fmi2DeSerializeFMUstate", FMUstate)
    if (rom_state_check(inst->model, (const unsigned char *)serializedState, size, inst->message,
                        sizeof inst->message) != ROM_OK) {
        return error(inst, "fmi2DeSerializeFMUstate", inst->message);
    }
    Snapshot *snap = snapshot_for(inst, (Snapshot *)*FMUstate);
    if (!snap) return error(inst, "fmi2DeSerializeFMUstate", "out of memory");
    memcpy(snap->data, serializedState, size);
    *FMUstate = snap;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    CHECK("fmi2GetDirectionalDerivative", NOT_ERROR)
    return error(inst, "fmi2GetDirectionalDerivative", "not provided (providesDirectionalDerivative = false)");
}

/* ------------------------------------------------------------------------ */
/* co-simulation                                                             */
/* ------------------------------------------------------------------------ */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr;
    (void)order;
    (void)value;
    CHECK("fmi2SetRealInputDerivatives", NOT_ERROR)
    if (nvr == 0) return fmi2OK;
    return error(inst, "fmi2SetRealInputDerivatives", "not supported (canInterpolateInputs = false)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr;
    (void)order;
    (void)value;
    CHECK("fmi2GetRealOutputDerivatives", NOT_ERROR)
    if (nvr == 0) return fmi2OK;
    return error(inst, "fmi2GetRealOutputDerivatives", "not supported (maxOutputDerivativeOrder = 0)");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK("fmi2DoStep", StepComplete)
    if (rom_do_step(inst->state, currentCommunicationPoint, communicationStepSize, inst->message,
                    sizeof inst->message) != ROM_OK) {
        return error(inst, "fmi2DoStep", inst->message);
    }
    log_message(inst, fmi2OK, ROM_LOG_EVENTS, "fmi2DoStep: t = %.9g s reached (%lld internal steps in all)",
                inst->state->time, (long long)inst->state->n);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    CHECK("fmi2CancelStep", NOT_ERROR)
    return error(inst, "fmi2CancelStep", "no asynchronous step to cancel (fmi2DoStep always completes)");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    CHECK("fmi2GetStatus", StepComplete | Terminated)
    CHECK_POINTER("fmi2GetStatus", value)
    if (s != fmi2DoStepStatus) return error(inst, "fmi2GetStatus", "status kind not provided");
    *value = fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    CHECK("fmi2GetRealStatus", StepComplete | Terminated)
    CHECK_POINTER("fmi2GetRealStatus", value)
    if (s != fmi2LastSuccessfulTime) return error(inst, "fmi2GetRealStatus", "status kind not provided");
    *value = inst->state->time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s;
    (void)value;
    CHECK("fmi2GetIntegerStatus", StepComplete | Terminated)
    return error(inst, "fmi2GetIntegerStatus", "status kind not provided");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    CHECK("fmi2GetBooleanStatus", StepComplete | Terminated)
    CHECK_POINTER("fmi2GetBooleanStatus", value)
    if (s != fmi2Terminated) return error(inst, "fmi2GetBooleanStatus", "status kind not provided");
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s;
    (void)value;
    CHECK("fmi2GetStringStatus", StepComplete | Terminated)
    return error(inst, "fmi2GetStringStatus", "status kind not provided");
}
