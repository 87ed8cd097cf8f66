/*
 * FMI 2.0 co-simulation adapter: the fmi2* functions over the version-neutral
 * instance layer (instance.h), which holds the model core (rom.h).
 *
 * What is FMI 2 here: the table of the modes in which each function may be
 * called (Instantiated -> InitializationMode -> StepComplete -> Terminated, and
 * Error, from which only fmi2Reset, fmi2FreeInstance and fmi2SetFMUstate lead
 * out; there, as the standard's table allows, the values, the output
 * derivatives and the FMU state may still be read, for debugging), the types
 * and statuses, the logger (messages are printf formats with
 * '#' starting a value reference: '%' and '#' are escaped), the file URI of the
 * resources, and the status queries.
 */
#include <stddef.h>

#include "fmi2Functions.h"
#include "instance.h"

/* Where each function may be called: the whole state machine (FMI 2.0.4, section 4.2.4's table of calling
 * sequences: fmi2Get<type>, fmi2GetRealOutputDerivatives, fmi2GetFMUstate and its serialization are allowed in the
 * Error state, their values "usable for debugging only").  Functions not listed take no instance (version,
 * platform, instantiate, free). */
#define FMI2_CALLS(X) \
    X(SetDebugLogging,          MODES_ANY) \
    X(SetupExperiment,          MODE_INSTANTIATED) \
    X(EnterInitializationMode,  MODE_INSTANTIATED) \
    X(ExitInitializationMode,   MODE_INITIALIZATION) \
    X(Terminate,                MODE_STEP) \
    X(Reset,                    MODES_ANY) \
    X(GetValues,                MODES_READABLE | MODE_ERROR)     /* fmi2GetReal, Integer, Boolean, String */ \
    X(SetValues,                MODES_SETTABLE)                  /* fmi2SetReal, Integer, Boolean, String */ \
    X(GetFMUstate,              MODES_ANY) \
    X(SetFMUstate,              MODES_ANY) \
    X(FreeFMUstate,             MODES_ANY) \
    X(SerializedFMUstateSize,   MODES_ANY) \
    X(SerializeFMUstate,        MODES_ANY) \
    X(DeSerializeFMUstate,      MODES_ANY) \
    X(SetRealInputDerivatives,  MODE_INITIALIZATION | MODE_STEP) \
    X(GetRealOutputDerivatives, MODES_READABLE | MODE_ERROR) \
    X(DoStep,                   MODE_STEP) \
    X(GetStatus,                MODE_STEP | MODE_TERMINATED)     /* and fmi2Get<type>Status */ \
    X(NotProvided,              MODES_NOT_ERROR)                 /* derivatives, fmi2CancelStep */

INSTANCE_CALL_TABLE(FMI2_CALLS);

#define ENTER_AS(call, name) INSTANCE_ENTER(c, call, name, fmi2Error)
#define ENTER(call) ENTER_AS(call, "fmi2" #call)

/* InstanceStatus is numbered as fmi2Status */
INSTANCE_STATUS_NUMBERING(fmi2OK, fmi2Warning, fmi2Error);
#define status2(status) ((fmi2Status)(status))

/* the logger adapter: the message is a printf format and '#' starts a value
 * reference (#r12#): escape both as '%%' and '##' */
static void emit2(InstanceCallback logger, void *environment, const char *name, InstanceStatus status,
                  const char *category, const char *text) {
    if (!logger) return;
    char escaped[2 * ROM_MESSAGE_SIZE + 1024];
    size_t n = 0;
    for (const char *c = text; *c && n + 2 < sizeof escaped; c++) {
        if (*c == '%' || *c == '#') escaped[n++] = *c;
        escaped[n++] = *c;
    }
    escaped[n] = '\0';
    ((fmi2CallbackLogger)logger)(environment, name, status2(status), category, escaped);
}

static const InstanceVersion FMI2 = {
    "StepComplete", "fmi2Reset, fmi2FreeInstance, fmi2SetFMUstate; for debugging fmi2Get<type>, "
    "fmi2GetRealOutputDerivatives, fmi2GetFMUstate and its serialization", "fmi2ExitInitializationMode", "fmuGUID",
    1 /* file URI */, 0 /* no time variable */, emit2};

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
    ENTER(SetDebugLogging);
    return status2(instance_set_debug_logging(inst, fn, loggingOn, nCategories, categories));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)visible;
    if (!functions) return NULL;
    const InstanceCallback logger = (InstanceCallback)functions->logger;
    if (fmuType != fmi2CoSimulation) {
        instance_report(&FMI2, logger, functions->componentEnvironment, instanceName,
                        "fmi2Instantiate: this FMU supports co-simulation only (fmuType = %d)", (int)fmuType);
        return NULL;
    }
    return instance_new(&FMI2, "fmi2Instantiate", instanceName, fmuGUID, fmuResourceLocation, loggingOn, logger,
                        functions->componentEnvironment);
}

void fmi2FreeInstance(fmi2Component c) {
    instance_free((Instance *)c);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    ENTER(SetupExperiment);
    return status2(instance_setup_experiment(inst, fn, startTime, stopTimeDefined, stopTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    ENTER(EnterInitializationMode);
    return status2(instance_enter_initialization(inst));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    ENTER(ExitInitializationMode);
    return status2(instance_exit_initialization(inst, fn));
}

fmi2Status fmi2Terminate(fmi2Component c) {
    ENTER(Terminate);
    return status2(instance_terminate(inst));
}

fmi2Status fmi2Reset(fmi2Component c) {
    ENTER(Reset);
    return status2(instance_reset(inst));
}

/* ------------------------------------------------------------------------ */
/* variables                                                                 */
/* ------------------------------------------------------------------------ */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    ENTER_AS(GetValues, "fmi2GetReal");
    return status2(instance_get_float64(inst, fn, vr, nvr, value, nvr));
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    ENTER_AS(GetValues, "fmi2GetInteger");
    return status2(instance_get_int32(inst, fn, vr, nvr, value, nvr));
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    ENTER_AS(SetValues, "fmi2SetReal");
    return status2(instance_set_float64(inst, fn, vr, nvr, value, nvr));
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    ENTER_AS(SetValues, "fmi2SetInteger");
    return status2(instance_set_int32(inst, fn, vr, nvr, value, nvr));
}

/* types without variables: every value reference is unknown */
#define NO_VARIABLES(kind, type, qualifier) \
    fmi2Status fmi2##kind##type(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, \
                                qualifier fmi2##type value[]) { \
        ENTER_AS(kind##Values, "fmi2" #kind #type); \
        return status2(instance_no_variables(inst, fn, vr, nvr, value, nvr)); \
    }

NO_VARIABLES(Get, Boolean, )
NO_VARIABLES(Get, String, )
NO_VARIABLES(Set, Boolean, const)
NO_VARIABLES(Set, String, const)

/* ------------------------------------------------------------------------ */
/* FMU state                                                                 */
/* ------------------------------------------------------------------------ */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ENTER(GetFMUstate);
    return status2(instance_get_state(inst, fn, FMUstate));
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    ENTER(SetFMUstate);
    return status2(instance_set_state(inst, fn, FMUstate));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ENTER(FreeFMUstate);
    return status2(instance_free_state(inst, fn, FMUstate));
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    ENTER(SerializedFMUstateSize);
    return status2(instance_state_size(inst, fn, FMUstate, size));
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    ENTER(SerializeFMUstate);
    return status2(instance_serialize_state(inst, fn, FMUstate, (unsigned char *)serializedState, size));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    ENTER(DeSerializeFMUstate);
    return status2(instance_deserialize_state(inst, fn, (const unsigned char *)serializedState, size, FMUstate));
}

/* ------------------------------------------------------------------------ */
/* not provided                                                              */
/* ------------------------------------------------------------------------ */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    ENTER_AS(NotProvided, "fmi2GetDirectionalDerivative");
    return status2(instance_error(inst, fn, "not provided (providesDirectionalDerivative = false)"));
}


fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    ENTER(GetRealOutputDerivatives);
    return status2(instance_get_output_derivatives(inst, fn, vr, nvr, order, value, nvr));
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    ENTER_AS(NotProvided, "fmi2CancelStep");
    return status2(instance_error(inst, fn, "no asynchronous step to cancel (fmi2DoStep always completes)"));
}

/* ------------------------------------------------------------------------ */
/* co-simulation                                                             */
/* ------------------------------------------------------------------------ */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    ENTER(DoStep);
    return status2(instance_do_step(inst, fn, currentCommunicationPoint, communicationStepSize));
}

/* df/dt of the input f (order 1 only; exact model only), applied over the following steps */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    ENTER(SetRealInputDerivatives);
    return status2(instance_set_input_derivatives(inst, fn, vr, nvr, order, value));
}

/* a status query: the value pointer given and the kind one this FMU answers */
static fmi2Status status_query(Instance *inst, const char *fn, int provided, const void *value) {
    if (!value) return status2(instance_error(inst, fn, "value is NULL"));
    if (!provided) return status2(instance_error(inst, fn, "status kind not provided"));
    return fmi2OK;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    ENTER_AS(GetStatus, "fmi2GetStatus");
    if (status_query(inst, fn, s == fmi2DoStepStatus, value) != fmi2OK) return fmi2Error;
    *value = fmi2OK;                     /* fmi2DoStep always completes */
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    ENTER_AS(GetStatus, "fmi2GetRealStatus");
    if (status_query(inst, fn, s == fmi2LastSuccessfulTime, value) != fmi2OK) return fmi2Error;
    *value = instance_time(inst);
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s;
    ENTER_AS(GetStatus, "fmi2GetIntegerStatus");
    return status_query(inst, fn, 0, value);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    ENTER_AS(GetStatus, "fmi2GetBooleanStatus");
    if (status_query(inst, fn, s == fmi2Terminated, value) != fmi2OK) return fmi2Error;
    *value = fmi2False;                  /* the FMU never asks to terminate */
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s;
    ENTER_AS(GetStatus, "fmi2GetStringStatus");
    return status_query(inst, fn, 0, value);
}
