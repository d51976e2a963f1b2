/* The FMI 2.0 co-simulation adapter of every native grubler FMU.
 *
 * Thin: each fmi2 function checks its call against the states it is allowed
 * in (one mask per function, named after it), converts FMI 2.0's types to the
 * model contract's and calls the common FMI side (fmi_common.c), which holds
 * the instance, the checks, the values and the FMU state for both standards.
 * The FMU state's serialised layout is documented there.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "fmi_common.h"

/* states in which each call is allowed (FMI 2.0 co-simulation, section 4.2.4) */
#define MASK_GET (GRB_INITIALIZATION | GRB_STEP_COMPLETE | GRB_TERMINATED)
#define MASK_SET (GRB_INSTANTIATED | GRB_INITIALIZATION | GRB_STEP_COMPLETE)
#define MASK_fmi2SetDebugLogging GRB_ANY_LIVE
#define MASK_fmi2SetupExperiment GRB_INSTANTIATED
#define MASK_fmi2EnterInitializationMode GRB_INSTANTIATED
#define MASK_fmi2ExitInitializationMode GRB_INITIALIZATION
#define MASK_fmi2Terminate GRB_STEP_COMPLETE
#define MASK_fmi2GetReal MASK_GET
#define MASK_fmi2GetInteger MASK_GET
#define MASK_fmi2GetBoolean MASK_GET
#define MASK_fmi2GetString MASK_GET
#define MASK_fmi2SetReal MASK_SET
#define MASK_fmi2SetInteger MASK_SET
#define MASK_fmi2SetBoolean MASK_SET
#define MASK_fmi2SetString MASK_SET
#define MASK_fmi2DoStep GRB_STEP_COMPLETE
#define MASK_fmi2CancelStep GRB_ANY_LIVE
#define MASK_fmi2SetRealInputDerivatives GRB_ANY_LIVE
#define MASK_fmi2GetRealOutputDerivatives GRB_ANY_LIVE
#if MODEL_DIRECTIONAL_DERIVATIVE
#define MASK_fmi2GetDirectionalDerivative MASK_GET
#else
#define MASK_fmi2GetDirectionalDerivative GRB_ANY_LIVE
#endif
#define MASK_fmi2GetStatus GRB_ANY_LIVE
#define MASK_fmi2GetRealStatus MASK_GET
#define MASK_fmi2GetIntegerStatus GRB_ANY_LIVE
#define MASK_fmi2GetBooleanStatus GRB_ANY_LIVE
#define MASK_fmi2GetStringStatus GRB_ANY_LIVE
#define MASK_fmi2GetFMUstate GRB_FMU_STATE_CALLS
#define MASK_fmi2SetFMUstate GRB_FMU_STATE_CALLS
#define MASK_fmi2SerializedFMUstateSize GRB_FMU_STATE_CALLS
#define MASK_fmi2SerializeFMUstate GRB_FMU_STATE_CALLS
#define MASK_fmi2DeSerializeFMUstate GRB_FMU_STATE_CALLS

/* Every call starts here: its name and allowed states from one token. */
#define BEGIN(F)                                              \
    static const char *const call = #F;                       \
    grb_instance *inst = (grb_instance *)c;                   \
    if (!grb_allowed(inst, call, MASK_##F)) return fmi2Error

static void logger(const grb_instance *inst, grb_fmi_status status, const char *category, const char *message) {
    fmi2CallbackLogger log = (fmi2CallbackLogger)inst->host_log;
    if (log != NULL) log((fmi2ComponentEnvironment)inst->host, inst->name, (fmi2Status)status, category, message);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    BEGIN(fmi2SetDebugLogging);
    return (fmi2Status)grb_set_debug_logging(inst, call, loggingOn, nCategories, categories);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    grb_instance adapter;
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL || functions->allocateMemory == NULL || functions->freeMemory == NULL) return NULL;
    memset(&adapter, 0, sizeof adapter);
    adapter.fmi = 2;
    adapter.allocate = functions->allocateMemory;
    adapter.release = functions->freeMemory;
    adapter.logger = logger;
    /* the logger and its environment are copied, as the memory functions are: a
     * host may free its callback struct once fmi2Instantiate returns (fmpy's
     * container FMU does), and the Reference FMUs copy them too */
    adapter.host = functions->componentEnvironment;
    adapter.host_log = (void (*)(void))functions->logger;
    adapter.name = (char *)(instanceName ? instanceName : "");
    if (fmuType != fmi2CoSimulation) {
        grb_log(&adapter, GRB_FMI_ERROR, "fmi2Instantiate: %s is a co-simulation FMU (no model exchange)", MODEL_NAME);
        return NULL;
    }
    return grb_instantiate(&adapter, "fmi2Instantiate", instanceName, fmuGUID, loggingOn);
}

void fmi2FreeInstance(fmi2Component c) { grb_free_instance((grb_instance *)c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    BEGIN(fmi2SetupExperiment);
    (void)toleranceDefined;
    (void)tolerance;  /* the model's own rtol parameter governs its sub-steps */
    (void)stopTimeDefined;
    (void)stopTime;
    return (fmi2Status)grb_set_start_time(inst, call, startTime);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    BEGIN(fmi2EnterInitializationMode);
    inst->state = GRB_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    BEGIN(fmi2ExitInitializationMode);
    return (fmi2Status)grb_exit_initialization(inst);
}

fmi2Status fmi2Terminate(fmi2Component c) {
    BEGIN(fmi2Terminate);
    inst->state = GRB_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    grb_instance *inst = (grb_instance *)c;
    if (inst == NULL) return fmi2Error;
    grb_reset(inst);
    return fmi2OK;
}

/* ---- values ------------------------------------------------------------------ */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    BEGIN(fmi2GetReal);
    return (fmi2Status)grb_get_real(inst, call, vr, nvr, value);
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    size_t k;
    BEGIN(fmi2GetInteger);
    if (!grb_check_array(inst, call, vr, nvr, value)) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = grb_lookup(inst, call, vr[k], GRB_T_INTEGER);
        if (v == NULL) return fmi2Error;
        value[k] = (fmi2Integer)inst->p[v->slot];
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    size_t k;
    BEGIN(fmi2GetBoolean);
    if (!grb_check_array(inst, call, vr, nvr, value)) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = grb_lookup(inst, call, vr[k], GRB_T_BOOLEAN);
        if (v == NULL) return fmi2Error;
        value[k] = inst->p[v->slot] != 0.0;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    BEGIN(fmi2GetString);
    return (fmi2Status)grb_get_string(inst, call, vr, nvr, value);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    BEGIN(fmi2SetReal);
    return (fmi2Status)grb_set_real(inst, call, vr, nvr, value);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    size_t k;
    BEGIN(fmi2SetInteger);
    if (!grb_check_array(inst, call, vr, nvr, value)) return fmi2Error;
    for (k = 0; k < nvr; k++)  /* all checked before any is stored */
        if (grb_settable(inst, call, vr[k], GRB_T_INTEGER, (double)value[k]) == NULL) return fmi2Error;
    for (k = 0; k < nvr; k++) grb_store(inst, &model_variables[vr[k] - 1], (double)value[k]);
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    size_t k;
    BEGIN(fmi2SetBoolean);
    if (!grb_check_array(inst, call, vr, nvr, value)) return fmi2Error;
    for (k = 0; k < nvr; k++)
        if (grb_settable(inst, call, vr[k], GRB_T_BOOLEAN, value[k] ? 1.0 : 0.0) == NULL) return fmi2Error;
    for (k = 0; k < nvr; k++) grb_store(inst, &model_variables[vr[k] - 1], value[k] ? 1.0 : 0.0);
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    BEGIN(fmi2SetString);
    return (fmi2Status)grb_set_string(inst, call, vr, nvr, value);
}

/* ---- stepping ------------------------------------------------------------------ */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    BEGIN(fmi2DoStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    return (fmi2Status)grb_do_step(inst, call, currentCommunicationPoint, communicationStepSize);
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    BEGIN(fmi2CancelStep);
    return (fmi2Status)grb_fail(inst, "%s: steps are synchronous (canRunAsynchronuously is false)", call);
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    BEGIN(fmi2SetRealInputDerivatives);
    (void)vr; (void)nvr; (void)order; (void)value;
    return (fmi2Status)grb_fail(inst, "%s: not supported (canInterpolateInputs is false)", call);
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    BEGIN(fmi2GetRealOutputDerivatives);
    (void)vr; (void)nvr; (void)order; (void)value;
    return (fmi2Status)grb_fail(inst, "%s: not supported (maxOutputDerivativeOrder is 0)", call);
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    BEGIN(fmi2GetDirectionalDerivative);
    return (fmi2Status)grb_directional_derivative(inst, call, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown,
                                                  dvUnknown);
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    BEGIN(fmi2GetStatus);
    (void)s;
    if (value == NULL) return (fmi2Status)grb_fail(inst, "%s: NULL value", call);
    return (fmi2Status)grb_fail(inst, "%s: no asynchronous step is ever pending", call);
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    BEGIN(fmi2GetRealStatus);
    if (value == NULL) return (fmi2Status)grb_fail(inst, "%s: NULL value", call);
    if (s != fmi2LastSuccessfulTime) return (fmi2Status)grb_fail(inst, "%s: only fmi2LastSuccessfulTime is known", call);
    *value = model_time(inst);
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    BEGIN(fmi2GetIntegerStatus);
    (void)s; (void)value;
    return (fmi2Status)grb_fail(inst, "%s: no integer status exists", call);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    BEGIN(fmi2GetBooleanStatus);
    if (value == NULL) return (fmi2Status)grb_fail(inst, "%s: NULL value", call);
    if (s != fmi2Terminated) return (fmi2Status)grb_fail(inst, "%s: only fmi2Terminated is known", call);
    *value = fmi2False;  /* the model never asks to end the simulation */
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    BEGIN(fmi2GetStringStatus);
    (void)s; (void)value;
    return (fmi2Status)grb_fail(inst, "%s: no asynchronous step is ever pending", call);
}

/* ---- FMU state ---------------------------------------------------------------- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    BEGIN(fmi2GetFMUstate);
    return (fmi2Status)grb_get_state(inst, call, FMUstate);
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    BEGIN(fmi2SetFMUstate);
    return (fmi2Status)grb_set_state(inst, call, FMUstate);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    grb_instance *inst = (grb_instance *)c;
    if (inst == NULL) return fmi2Error;  /* allowed in every state, the error state too */
    return (fmi2Status)grb_free_state(inst, "fmi2FreeFMUstate", FMUstate);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    BEGIN(fmi2SerializedFMUstateSize);
    return (fmi2Status)grb_serialized_size(inst, call, FMUstate, size);
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    BEGIN(fmi2SerializeFMUstate);
    return (fmi2Status)grb_serialize(inst, call, FMUstate, (unsigned char *)serializedState, size);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    BEGIN(fmi2DeSerializeFMUstate);
    return (fmi2Status)grb_deserialize(inst, call, (const unsigned char *)serializedState, size, FMUstate);
}

/* ---- model exchange: not provided (the description declares co-simulation only) ---- */
