/*
 * FMI 3.0 co-simulation adapter: the fmi3* functions over the version-neutral
 * instance layer (instance.h), which holds the model core (rom.h).
 *
 * What is FMI 3 here: the table of the modes in which each function may be
 * called (Instantiated -> InitializationMode -> StepMode -> Terminated, and
 * Error, from which only fmi3Reset, fmi3FreeInstance and fmi3SetFMUState lead
 * out), the types and statuses, the logger (logMessage, the message prefixed
 * with the instance name), the resource folder path, the variable `time`, and
 * every other function of fmi3Functions.h, which reports an error: model
 * exchange, scheduled execution, event mode, clocks and derivatives.
 */
#include <stdio.h>

#include "fmi3Functions.h"
#include "instance.h"

/* Where each function may be called: the whole state machine.  FMI 3.0 (section 2.3.1): a function that returns
 * fmi3Error in the super state FMU State Setable takes the FMU to Terminated, where the values, the output
 * derivatives and the FMU state may be read ("for debugging purposes" after an error); the instance keeps its
 * Error mode (its messages say why), which allows what Terminated allows, and leaves it by fmi3Reset,
 * fmi3FreeInstance or fmi3SetFMUState.  Functions not listed take no instance (version, instantiate, free). */
#define FMI3_CALLS(X) \
    X(SetDebugLogging,                  MODES_ANY) \
    X(EnterInitializationMode,          MODE_INSTANTIATED) \
    X(ExitInitializationMode,           MODE_INITIALIZATION) \
    X(Terminate,                        MODE_STEP) \
    X(Reset,                            MODES_ANY) \
    X(GetValues,                        MODES_READABLE | MODE_ERROR)      /* fmi3Get<type> */ \
    X(SetValues,                        MODES_SETTABLE)      /* fmi3Set<type> */ \
    X(GetNumberOfVariableDependencies,  MODES_ANY) \
    X(GetVariableDependencies,          MODES_ANY) \
    X(GetFMUState,                      MODES_ANY) \
    X(SetFMUState,                      MODES_ANY) \
    X(FreeFMUState,                     MODES_ANY) \
    X(SerializedFMUStateSize,           MODES_ANY) \
    X(SerializeFMUState,                MODES_ANY) \
    X(DeserializeFMUState,              MODES_ANY) \
    X(DoStep,                           MODE_STEP) \
    X(GetOutputDerivatives,             MODES_READABLE | MODE_ERROR) \
    X(NotProvided,                      MODES_NOT_ERROR)     /* events, clocks, derivatives, model exchange */

INSTANCE_CALL_TABLE(FMI3_CALLS);

#define ENTER_AS(call, name) INSTANCE_ENTER(instance, call, name, fmi3Error)
#define ENTER(call) ENTER_AS(call, "fmi3" #call)

/* a function this FMU does not provide: the mode check, then an error saying why */
#define NOT_PROVIDED(name, why) \
    ENTER_AS(NotProvided, name); \
    return status3(instance_error(inst, fn, "not provided: %s", why))

#define REQUIRE(pointer) \
    if (!(pointer)) return status3(instance_error(inst, fn, "%s is NULL", #pointer))

/* InstanceStatus is numbered as fmi3Status */
INSTANCE_STATUS_NUMBERING(fmi3OK, fmi3Warning, fmi3Error);
#define status3(status) ((fmi3Status)(status))

/* the logger adapter: "[instance name] message" */
static void emit3(InstanceCallback logger, void *environment, const char *name, InstanceStatus status,
                  const char *category, const char *text) {
    if (!logger) return;
    char full[ROM_MESSAGE_SIZE + 1024];
    snprintf(full, sizeof full, "[%.100s] %s", name, text);
    ((fmi3LogMessageCallback)logger)(environment, status3(status), category, full);
}

static const InstanceVersion FMI3 = {
    "StepMode", "fmi3Reset, fmi3FreeInstance, fmi3SetFMUState; for debugging, as in Terminated, fmi3Get<type>, "
    "fmi3GetOutputDerivatives, fmi3GetFMUState and its serialization", "fmi3ExitInitializationMode",
    "instantiationToken",
    0 /* folder path */, 1 /* time variable */, emit3};

/* ------------------------------------------------------------------------ */
/* inquire version, logging, instantiation                                   */
/* ------------------------------------------------------------------------ */

const char *fmi3GetVersion(void) {
    return fmi3Version;
}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    ENTER(SetDebugLogging);
    return status3(instance_set_debug_logging(inst, fn, loggingOn, nCategories, categories));
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    instance_report(&FMI3, (InstanceCallback)logMessage, instanceEnvironment, instanceName,
                    "fmi3InstantiateModelExchange: this FMU supports co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    instance_report(&FMI3, (InstanceCallback)logMessage, instanceEnvironment, instanceName,
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
    const InstanceCallback logger = (InstanceCallback)logMessage;
    if (nRequiredIntermediateVariables > 0) {
        instance_report(&FMI3, logger, instanceEnvironment, instanceName,
                        "fmi3InstantiateCoSimulation: this FMU provides no intermediate variables");
        return NULL;
    }
    return instance_new(&FMI3, "fmi3InstantiateCoSimulation", instanceName, instantiationToken, resourcePath,
                        loggingOn, logger, instanceEnvironment);
}

void fmi3FreeInstance(fmi3Instance instance) {
    instance_free((Instance *)instance);
}

/* ------------------------------------------------------------------------ */
/* initialization, termination, reset                                        */
/* ------------------------------------------------------------------------ */

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    ENTER(EnterInitializationMode);
    if (instance_setup_experiment(inst, fn, startTime, stopTimeDefined, stopTime) != INSTANCE_OK) return fmi3Error;
    return status3(instance_enter_initialization(inst));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    ENTER(ExitInitializationMode);
    return status3(instance_exit_initialization(inst, fn));
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    ENTER(Terminate);
    return status3(instance_terminate(inst));
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    ENTER(Reset);
    return status3(instance_reset(inst));
}

/* ------------------------------------------------------------------------ */
/* getters and setters                                                       */
/* ------------------------------------------------------------------------ */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
    ENTER_AS(GetValues, "fmi3GetFloat64");
    return status3(instance_get_float64(inst, fn, valueReferences, nValueReferences, values, nValues));
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues) {
    ENTER_AS(GetValues, "fmi3GetInt32");
    return status3(instance_get_int32(inst, fn, valueReferences, nValueReferences, values, nValues));
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
    ENTER_AS(SetValues, "fmi3SetFloat64");
    return status3(instance_set_float64(inst, fn, valueReferences, nValueReferences, values, nValues));
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues) {
    ENTER_AS(SetValues, "fmi3SetInt32");
    return status3(instance_set_int32(inst, fn, valueReferences, nValueReferences, values, nValues));
}

/* types without variables: every value reference is unknown */
#define NO_VARIABLES(kind, type, qualifier) \
    fmi3Status fmi3##kind##type(fmi3Instance instance, const fmi3ValueReference valueReferences[], \
                                size_t nValueReferences, qualifier fmi3##type values[], size_t nValues) { \
        ENTER_AS(kind##Values, "fmi3" #kind #type); \
        return status3(instance_no_variables(inst, fn, valueReferences, nValueReferences, values, nValues)); \
    }
#define NO_VARIABLES_GET(type) NO_VARIABLES(Get, type, )
#define NO_VARIABLES_SET(type) NO_VARIABLES(Set, type, const)

NO_VARIABLES_GET(Float32)
NO_VARIABLES_GET(Int8)
NO_VARIABLES_GET(UInt8)
NO_VARIABLES_GET(Int16)
NO_VARIABLES_GET(UInt16)
NO_VARIABLES_GET(UInt32)
NO_VARIABLES_GET(Int64)
NO_VARIABLES_GET(UInt64)
NO_VARIABLES_GET(Boolean)
NO_VARIABLES_GET(String)
NO_VARIABLES_SET(Float32)
NO_VARIABLES_SET(Int8)
NO_VARIABLES_SET(UInt8)
NO_VARIABLES_SET(Int16)
NO_VARIABLES_SET(UInt16)
NO_VARIABLES_SET(UInt32)
NO_VARIABLES_SET(Int64)
NO_VARIABLES_SET(UInt64)
NO_VARIABLES_SET(Boolean)
NO_VARIABLES_SET(String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    (void)valueSizes;
    ENTER_AS(GetValues, "fmi3GetBinary");
    return status3(instance_no_variables(inst, fn, valueReferences, nValueReferences, values, nValues));
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    (void)valueSizes;
    ENTER_AS(SetValues, "fmi3SetBinary");
    return status3(instance_no_variables(inst, fn, valueReferences, nValueReferences, values, nValues));
}

/* ------------------------------------------------------------------------ */
/* variable dependencies (none declared: the outputs depend on the state)     */
/* ------------------------------------------------------------------------ */

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    ENTER(GetNumberOfVariableDependencies);
    return status3(instance_dependencies(inst, fn, valueReference, nDependencies));
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents; (void)dependencyKinds;
    ENTER(GetVariableDependencies);
    size_t count = 0;
    if (instance_dependencies(inst, fn, dependent, &count) != INSTANCE_OK) return fmi3Error;
    if (nDependencies != count) {
        return status3(instance_error(inst, fn, "nDependencies = %zu, must be %zu (as "
                                      "fmi3GetNumberOfVariableDependencies says)", nDependencies, count));
    }
    return fmi3OK;
}

/* ------------------------------------------------------------------------ */
/* FMU state                                                                 */
/* ------------------------------------------------------------------------ */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    ENTER(GetFMUState);
    return status3(instance_get_state(inst, fn, FMUState));
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    ENTER(SetFMUState);
    return status3(instance_set_state(inst, fn, FMUState));
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    ENTER(FreeFMUState);
    return status3(instance_free_state(inst, fn, FMUState));
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    ENTER(SerializedFMUStateSize);
    return status3(instance_state_size(inst, fn, FMUState, size));
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    ENTER(SerializeFMUState);
    return status3(instance_serialize_state(inst, fn, FMUState, serializedState, size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    ENTER(DeserializeFMUState);
    return status3(instance_deserialize_state(inst, fn, serializedState, size, FMUState));
}

/* ------------------------------------------------------------------------ */
/* co-simulation                                                             */
/* ------------------------------------------------------------------------ */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    (void)noSetFMUStatePriorToCurrentPoint;
    ENTER(DoStep);
    REQUIRE(eventHandlingNeeded);
    REQUIRE(terminateSimulation);
    REQUIRE(earlyReturn);
    REQUIRE(lastSuccessfulTime);
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    const InstanceStatus status = instance_do_step(inst, fn, currentCommunicationPoint, communicationStepSize);
    *lastSuccessfulTime = instance_time(inst);   /* t_comm + h, or the last point reached on an error */
    return status3(status);
}

/* ------------------------------------------------------------------------ */
/* not provided: derivatives, configuration, clocks, events, model exchange  */
/* ------------------------------------------------------------------------ */

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    NOT_PROVIDED("fmi3EnterEventMode", "hasEventMode = false");
}

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

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    (void)valueReferences; (void)nValueReferences; (void)values;
    NOT_PROVIDED("fmi3GetClock", "the FMU has no clocks");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    (void)valueReferences; (void)nValueReferences; (void)values;
    NOT_PROVIDED("fmi3SetClock", "the FMU has no clocks");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
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
    ENTER(GetOutputDerivatives);
    return status3(instance_get_output_derivatives(inst, fn, valueReferences, nValueReferences, orders, values,
                                                   nValues));
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference; (void)activationTime;
    NOT_PROVIDED("fmi3ActivateModelPartition", "co-simulation only");
}
