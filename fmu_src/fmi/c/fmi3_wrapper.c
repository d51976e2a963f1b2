/* The FMI 3.0 co-simulation adapter of every native grubler FMU: the same
 * model files as the FMI 2.0 one (fmi2_wrapper.c), the same common FMI side
 * (fmi_common.c), FMI 3.0's functions and types.
 *
 * What FMI 3.0 changes here:
 * - Float64 for Real, Int32 for Integer, Int64 for an Enumeration, bool for
 *   Boolean; the model has no variable of the other types, whose getters and
 *   setters refuse any value reference;
 * - time is the independent variable at value reference 0;
 * - fmi3EnterInitializationMode takes the start time (no fmi3SetupExperiment);
 * - no event mode (hasEventMode is false, so an importer that asks for it is
 *   refused at instantiation, as the standard says) and no early return: a
 *   doStep carries the motion through a change point as the library does, its
 *   outputs continuous there, so there is no event to report (docs/fmi.md);
 * - memory is the FMU's own (calloc and free); the log goes to logMessage.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fmi_common.h"

/* the contract's value references are FMI 3.0's */
typedef char grb_vr_is_fmi3_vr[sizeof(grb_value_reference) == sizeof(fmi3ValueReference) ? 1 : -1];
#define VRS(vr) ((const grb_value_reference *)(vr))

/* states in which each call is allowed (FMI 3.0 co-simulation without event
 * mode, section 4.3.1; GRB_STEP_COMPLETE is step mode) */
#define MASK_GET (GRB_INITIALIZATION | GRB_STEP_COMPLETE | GRB_TERMINATED)
#define MASK_SET (GRB_INSTANTIATED | GRB_INITIALIZATION | GRB_STEP_COMPLETE)
#define MASK_fmi3SetDebugLogging GRB_ANY_LIVE
#define MASK_fmi3EnterInitializationMode GRB_INSTANTIATED
#define MASK_fmi3ExitInitializationMode GRB_INITIALIZATION
#define MASK_fmi3Terminate GRB_STEP_COMPLETE
#define MASK_fmi3GetFloat64 MASK_GET
#define MASK_fmi3GetInt32 MASK_GET
#define MASK_fmi3GetInt64 MASK_GET
#define MASK_fmi3GetBoolean MASK_GET
#define MASK_fmi3GetString MASK_GET
#define MASK_fmi3SetFloat64 MASK_SET
#define MASK_fmi3SetInt32 MASK_SET
#define MASK_fmi3SetInt64 MASK_SET
#define MASK_fmi3SetBoolean MASK_SET
#define MASK_fmi3SetString MASK_SET
#define MASK_fmi3DoStep GRB_STEP_COMPLETE
#if MODEL_DIRECTIONAL_DERIVATIVE
#define MASK_fmi3GetDirectionalDerivative MASK_GET
#else
#define MASK_fmi3GetDirectionalDerivative GRB_ANY_LIVE
#endif
#define MASK_fmi3GetFMUState GRB_FMU_STATE_CALLS
#define MASK_fmi3SetFMUState GRB_FMU_STATE_CALLS
#define MASK_fmi3SerializedFMUStateSize GRB_FMU_STATE_CALLS
#define MASK_fmi3SerializeFMUState GRB_FMU_STATE_CALLS
#define MASK_fmi3DeserializeFMUState GRB_FMU_STATE_CALLS
#define MASK_UNSUPPORTED GRB_ANY_LIVE

/* Every call starts here: its name and allowed states from one token. */
#define BEGIN(F)                                              \
    static const char *const call = #F;                       \
    grb_instance *inst = (grb_instance *)instance;            \
    if (!grb_allowed(inst, call, MASK_##F)) return fmi3Error

/* A function of a feature the FMU does not declare: refused, naming the attribute that says so. */
#define UNSUPPORTED(F, why)                                                       \
    static const char *const call = #F;                                           \
    grb_instance *inst = (grb_instance *)instance;                                \
    if (!grb_allowed(inst, call, MASK_UNSUPPORTED)) return fmi3Error;             \
    return (fmi3Status)grb_fail(inst, "%s: not supported (%s)", call, why)

static void logger(const grb_instance *inst, grb_fmi_status status, const char *category, const char *message) {
    fmi3LogMessageCallback log = (fmi3LogMessageCallback)inst->host_log;
    if (log != NULL) log((fmi3InstanceEnvironment)inst->host, (fmi3Status)status, category, message);
}

/* Every variable is a scalar: as many values as value references. */
static int scalars(grb_instance *inst, const char *call, size_t nvr, size_t n_values) {
    if (n_values != nvr) {
        grb_fail(inst, "%s: %u values for %u value references (every variable of this model is a scalar)", call,
                 (unsigned)n_values, (unsigned)nvr);
        return 0;
    }
    return 1;
}

/* An Integer variable through the type FMI 3.0 gives it: Int64 for an enumeration, Int32 otherwise. */
static const grb_variable *integer(grb_instance *inst, const char *call, fmi3ValueReference vr, int enumeration) {
    const grb_variable *v = grb_lookup(inst, call, vr, GRB_T_INTEGER);
    if (v != NULL && (v->enum_items > 0) != enumeration) {
        grb_fail(inst, "%s: %s (value reference %u) is %s", call, v->name, (unsigned)vr,
                 enumeration ? "an Int32, which fmi3GetInt32 and fmi3SetInt32 read and set"
                             : "an Enumeration, which fmi3GetInt64 and fmi3SetInt64 read and set");
        return NULL;
    }
    return v;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    BEGIN(fmi3SetDebugLogging);
    return (fmi3Status)grb_set_debug_logging(inst, call, loggingOn, nCategories, categories);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    grb_instance adapter;
    (void)resourcePath;
    (void)visible;
    (void)earlyReturnAllowed;  /* allowed, never used: a doStep always reaches its end or is discarded */
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    memset(&adapter, 0, sizeof adapter);
    adapter.fmi = 3;
    adapter.allocate = calloc;
    adapter.release = free;
    adapter.logger = logger;
    adapter.host = instanceEnvironment;
    adapter.host_log = (void (*)(void))logMessage;
    adapter.name = (char *)(instanceName ? instanceName : "");
    if (eventModeUsed) {
        grb_log(&adapter, GRB_FMI_ERROR, "fmi3InstantiateCoSimulation: %s has no event mode (hasEventMode is "
                "false): instantiate it with eventModeUsed false", MODEL_NAME);
        return NULL;
    }
    if (nRequiredIntermediateVariables > 0) {
        grb_log(&adapter, GRB_FMI_ERROR, "fmi3InstantiateCoSimulation: %s provides no intermediate update "
                "(providesIntermediateUpdate is false): require no intermediate variables", MODEL_NAME);
        return NULL;
    }
    return grb_instantiate(&adapter, "fmi3InstantiateCoSimulation", instanceName, instantiationToken, loggingOn);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    if (logMessage != NULL)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateModelExchange: " MODEL_NAME " is a co-simulation FMU (no model exchange)");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage != NULL)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution: " MODEL_NAME " is a co-simulation FMU (no scheduled execution)");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) { grb_free_instance((grb_instance *)instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    BEGIN(fmi3EnterInitializationMode);
    (void)toleranceDefined;
    (void)tolerance;  /* the model's own rtol parameter governs its sub-steps */
    (void)stopTimeDefined;
    (void)stopTime;
    if (grb_set_start_time(inst, call, startTime) != GRB_FMI_OK) return fmi3Error;
    inst->state = GRB_INITIALIZATION;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    BEGIN(fmi3ExitInitializationMode);
    return (fmi3Status)grb_exit_initialization(inst);
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    BEGIN(fmi3Terminate);
    inst->state = GRB_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    grb_instance *inst = (grb_instance *)instance;
    if (inst == NULL) return fmi3Error;
    grb_reset(inst);
    return fmi3OK;
}

/* ---- values ------------------------------------------------------------------ */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    BEGIN(fmi3GetFloat64);
    if (!scalars(inst, call, nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)grb_get_real(inst, call, VRS(valueReferences), nValueReferences, values);
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    BEGIN(fmi3SetFloat64);
    if (!scalars(inst, call, nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)grb_set_real(inst, call, VRS(valueReferences), nValueReferences, values);
}

/* Int32 (an Integer) and Int64 (an Enumeration): the same stored integers */
#define GET_INTEGER(F, T, ENUMERATION)                                                                       \
    fmi3Status F(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                 T values[], size_t nValues) {                                                              \
        size_t k;                                                                                            \
        BEGIN(F);                                                                                            \
        if (!scalars(inst, call, nValueReferences, nValues) ||                                               \
            !grb_check_array(inst, call, valueReferences, nValueReferences, values))                          \
            return fmi3Error;                                                                                \
        for (k = 0; k < nValueReferences; k++) {                                                             \
            const grb_variable *v = integer(inst, call, valueReferences[k], ENUMERATION);                    \
            if (v == NULL) return fmi3Error;                                                                 \
            values[k] = (T)inst->p[v->slot];                                                                 \
        }                                                                                                    \
        return fmi3OK;                                                                                       \
    }
#define SET_INTEGER(F, T, ENUMERATION)                                                                       \
    fmi3Status F(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                 const T values[], size_t nValues) {                                                        \
        size_t k;                                                                                            \
        BEGIN(F);                                                                                            \
        if (!scalars(inst, call, nValueReferences, nValues) ||                                               \
            !grb_check_array(inst, call, valueReferences, nValueReferences, values))                          \
            return fmi3Error;                                                                                \
        for (k = 0; k < nValueReferences; k++) /* all checked before any is stored */                       \
            if (integer(inst, call, valueReferences[k], ENUMERATION) == NULL ||                              \
                grb_settable(inst, call, valueReferences[k], GRB_T_INTEGER, (double)values[k]) == NULL)      \
                return fmi3Error;                                                                            \
        for (k = 0; k < nValueReferences; k++)                                                               \
            grb_store(inst, &model_variables[valueReferences[k] - 1], (double)values[k]);                    \
        return fmi3OK;                                                                                       \
    }
GET_INTEGER(fmi3GetInt32, fmi3Int32, 0)
GET_INTEGER(fmi3GetInt64, fmi3Int64, 1)
SET_INTEGER(fmi3SetInt32, fmi3Int32, 0)
SET_INTEGER(fmi3SetInt64, fmi3Int64, 1)

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues) {
    size_t k;
    BEGIN(fmi3GetBoolean);
    if (!scalars(inst, call, nValueReferences, nValues) ||
        !grb_check_array(inst, call, valueReferences, nValueReferences, values))
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++) {
        const grb_variable *v = grb_lookup(inst, call, valueReferences[k], GRB_T_BOOLEAN);
        if (v == NULL) return fmi3Error;
        values[k] = inst->p[v->slot] != 0.0;
    }
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues) {
    size_t k;
    BEGIN(fmi3SetBoolean);
    if (!scalars(inst, call, nValueReferences, nValues) ||
        !grb_check_array(inst, call, valueReferences, nValueReferences, values))
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++)
        if (grb_settable(inst, call, valueReferences[k], GRB_T_BOOLEAN, values[k] ? 1.0 : 0.0) == NULL)
            return fmi3Error;
    for (k = 0; k < nValueReferences; k++)
        grb_store(inst, &model_variables[valueReferences[k] - 1], values[k] ? 1.0 : 0.0);
    return fmi3OK;
}

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, fmi3String values[], size_t nValues) {
    BEGIN(fmi3GetString);
    if (!scalars(inst, call, nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)grb_get_string(inst, call, VRS(valueReferences), nValueReferences, values);
}

fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const fmi3String values[], size_t nValues) {
    BEGIN(fmi3SetString);
    if (!scalars(inst, call, nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)grb_set_string(inst, call, VRS(valueReferences), nValueReferences, values);
}

/* The types the model has no variable of: nothing to get or set (an empty call is fine). */
#define NO_SUCH_TYPE(F, T, CONST, TYPE)                                                                      \
    fmi3Status F(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                 CONST T values[], size_t nValues) {                                                        \
        static const char *const call = #F;                                                                  \
        grb_instance *inst = (grb_instance *)instance;                                                       \
        (void)values; (void)nValues;                                                                         \
        if (!grb_allowed(inst, call, GRB_ANY_LIVE)) return fmi3Error;                                        \
        if (nValueReferences == 0) return fmi3OK;                                                            \
        if (valueReferences == NULL) return (fmi3Status)grb_fail(inst, "%s: NULL value references", call);  \
        return (fmi3Status)grb_fail(inst, "%s: value reference %u is no " TYPE " variable (this model has "  \
                                    "none)", call, (unsigned)valueReferences[0]);                            \
    }
NO_SUCH_TYPE(fmi3GetFloat32, fmi3Float32, , "Float32")
NO_SUCH_TYPE(fmi3GetInt8, fmi3Int8, , "Int8")
NO_SUCH_TYPE(fmi3GetUInt8, fmi3UInt8, , "UInt8")
NO_SUCH_TYPE(fmi3GetInt16, fmi3Int16, , "Int16")
NO_SUCH_TYPE(fmi3GetUInt16, fmi3UInt16, , "UInt16")
NO_SUCH_TYPE(fmi3GetUInt32, fmi3UInt32, , "UInt32")
NO_SUCH_TYPE(fmi3GetUInt64, fmi3UInt64, , "UInt64")
NO_SUCH_TYPE(fmi3SetFloat32, fmi3Float32, const, "Float32")
NO_SUCH_TYPE(fmi3SetInt8, fmi3Int8, const, "Int8")
NO_SUCH_TYPE(fmi3SetUInt8, fmi3UInt8, const, "UInt8")
NO_SUCH_TYPE(fmi3SetInt16, fmi3Int16, const, "Int16")
NO_SUCH_TYPE(fmi3SetUInt16, fmi3UInt16, const, "UInt16")
NO_SUCH_TYPE(fmi3SetUInt32, fmi3UInt32, const, "UInt32")
NO_SUCH_TYPE(fmi3SetUInt64, fmi3UInt64, const, "UInt64")

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    static const char *const call = "fmi3GetBinary";
    grb_instance *inst = (grb_instance *)instance;
    (void)valueReferences; (void)valueSizes; (void)values; (void)nValues;
    if (!grb_allowed(inst, call, GRB_ANY_LIVE)) return fmi3Error;
    if (nValueReferences == 0) return fmi3OK;
    return (fmi3Status)grb_fail(inst, "%s: this model has no Binary variable", call);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    static const char *const call = "fmi3SetBinary";
    grb_instance *inst = (grb_instance *)instance;
    (void)valueReferences; (void)valueSizes; (void)values; (void)nValues;
    if (!grb_allowed(inst, call, GRB_ANY_LIVE)) return fmi3Error;
    if (nValueReferences == 0) return fmi3OK;
    return (fmi3Status)grb_fail(inst, "%s: this model has no Binary variable", call);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    (void)valueReferences; (void)nValueReferences; (void)values;
    UNSUPPORTED(fmi3GetClock, "this model has no clocks");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    (void)valueReferences; (void)nValueReferences; (void)values;
    UNSUPPORTED(fmi3SetClock, "this model has no clocks");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences; (void)nValueReferences; (void)intervals; (void)qualifiers;
    UNSUPPORTED(fmi3GetIntervalDecimal, "this model has no clocks");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions; (void)qualifiers;
    UNSUPPORTED(fmi3GetIntervalFraction, "this model has no clocks");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences; (void)nValueReferences; (void)shifts;
    UNSUPPORTED(fmi3GetShiftDecimal, "this model has no clocks");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
    UNSUPPORTED(fmi3GetShiftFraction, "this model has no clocks");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    (void)valueReferences; (void)nValueReferences; (void)intervals;
    UNSUPPORTED(fmi3SetIntervalDecimal, "this model has no clocks");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
    UNSUPPORTED(fmi3SetIntervalFraction, "this model has no clocks");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences; (void)nValueReferences; (void)shifts;
    UNSUPPORTED(fmi3SetShiftDecimal, "this model has no clocks");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
    UNSUPPORTED(fmi3SetShiftFraction, "this model has no clocks");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    UNSUPPORTED(fmi3EvaluateDiscreteStates, "providesEvaluateDiscreteStates is false");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    (void)discreteStatesNeedUpdate; (void)terminateSimulation; (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged; (void)nextEventTimeDefined; (void)nextEventTime;
    UNSUPPORTED(fmi3UpdateDiscreteStates, "hasEventMode is false");
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) { UNSUPPORTED(fmi3EnterEventMode, "hasEventMode is false"); }

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    UNSUPPORTED(fmi3EnterStepMode, "hasEventMode is false: step mode begins at fmi3ExitInitializationMode");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    UNSUPPORTED(fmi3EnterConfigurationMode, "this model has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    UNSUPPORTED(fmi3ExitConfigurationMode, "this model has no structural parameters");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference; (void)nDependencies;
    UNSUPPORTED(fmi3GetNumberOfVariableDependencies,
                "providesPerElementDependencies is false; the model description lists the dependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent; (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents;
    (void)dependencyKinds; (void)nDependencies;
    UNSUPPORTED(fmi3GetVariableDependencies,
                "providesPerElementDependencies is false; the model description lists the dependencies");
}

/* ---- FMU state ---------------------------------------------------------------- */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    BEGIN(fmi3GetFMUState);
    return (fmi3Status)grb_get_state(inst, call, FMUState);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    BEGIN(fmi3SetFMUState);
    return (fmi3Status)grb_set_state(inst, call, FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    grb_instance *inst = (grb_instance *)instance;
    if (inst == NULL) return fmi3Error;  /* allowed in every state, the error state too */
    return (fmi3Status)grb_free_state(inst, "fmi3FreeFMUState", FMUState);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    BEGIN(fmi3SerializedFMUStateSize);
    return (fmi3Status)grb_serialized_size(inst, call, FMUState, size);
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    BEGIN(fmi3SerializeFMUState);
    return (fmi3Status)grb_serialize(inst, call, FMUState, serializedState, size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    BEGIN(fmi3DeserializeFMUState);
    return (fmi3Status)grb_deserialize(inst, call, serializedState, size, FMUState);
}

/* ---- derivatives ---------------------------------------------------------------- */

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                        const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                        size_t nSensitivity) {
    BEGIN(fmi3GetDirectionalDerivative);
    if (nSeed != nKnowns || nSensitivity != nUnknowns)
        return (fmi3Status)grb_fail(inst, "%s: %u seeds for %u knowns and %u sensitivities for %u unknowns (every "
                                    "variable of this model is a scalar)", call, (unsigned)nSeed, (unsigned)nKnowns,
                                    (unsigned)nSensitivity, (unsigned)nUnknowns);
    return (fmi3Status)grb_directional_derivative(inst, call, VRS(unknowns), nUnknowns, VRS(knowns), nKnowns, seed,
                                                  sensitivity);
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    UNSUPPORTED(fmi3GetAdjointDerivative, "providesAdjointDerivatives is false");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    (void)valueReferences; (void)nValueReferences; (void)orders; (void)values; (void)nValues;
    UNSUPPORTED(fmi3GetOutputDerivatives, "maxOutputDerivativeOrder is 0");
}

/* ---- stepping ------------------------------------------------------------------ */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
    grb_fmi_status s;
    BEGIN(fmi3DoStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (eventHandlingNeeded == NULL || terminateSimulation == NULL || earlyReturn == NULL ||
        lastSuccessfulTime == NULL)
        return (fmi3Status)grb_fail(inst, "%s: NULL eventHandlingNeeded, terminateSimulation, earlyReturn or "
                                    "lastSuccessfulTime", call);
    s = grb_do_step(inst, call, currentCommunicationPoint, communicationStepSize);
    /* no event, no early return: the step reached its end (or, discarded, stayed where it was) */
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = s <= GRB_FMI_DISCARD ? model_time(inst) : currentCommunicationPoint;
    return (fmi3Status)s;
}

/* ---- model exchange: not provided (the description declares co-simulation only) ---- */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    UNSUPPORTED(fmi3EnterContinuousTimeMode, "a co-simulation FMU");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint; (void)enterEventMode; (void)terminateSimulation;
    UNSUPPORTED(fmi3CompletedIntegratorStep, "a co-simulation FMU");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    (void)time;
    UNSUPPORTED(fmi3SetTime, "a co-simulation FMU: time advances by fmi3DoStep");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    UNSUPPORTED(fmi3SetContinuousStates, "a co-simulation FMU");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    (void)derivatives; (void)nContinuousStates;
    UNSUPPORTED(fmi3GetContinuousStateDerivatives, "a co-simulation FMU");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    (void)eventIndicators; (void)nEventIndicators;
    UNSUPPORTED(fmi3GetEventIndicators, "a co-simulation FMU");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    UNSUPPORTED(fmi3GetContinuousStates, "a co-simulation FMU");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    (void)nominals; (void)nContinuousStates;
    UNSUPPORTED(fmi3GetNominalsOfContinuousStates, "a co-simulation FMU");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    (void)nEventIndicators;
    UNSUPPORTED(fmi3GetNumberOfEventIndicators, "a co-simulation FMU");
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    (void)nContinuousStates;
    UNSUPPORTED(fmi3GetNumberOfContinuousStates, "a co-simulation FMU");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference; (void)activationTime;
    UNSUPPORTED(fmi3ActivateModelPartition, "a co-simulation FMU");
}
