/* A thin FMI 2.0 co-simulation wrapper around pythonfmu's binary that reports
 * the status a slave means.
 *
 * pythonfmu 0.7's binary answers every call but doStep with fmi2OK or, when
 * the Python slave raises, fmi2Fatal (and it frees the Python instance then,
 * so the importer's next call reads freed memory).  A grubler slave never
 * raises: it logs what went wrong with the status the call deserves
 * (grubler.system.fmi_slave).  This wrapper forwards every call to pythonfmu's binary,
 * which sits beside it as <modelIdentifier>_pythonfmu.so, and returns the worst
 * of the binary's status and the statuses logged during the call, with Fatal
 * reported as Error.  After the binary reported fmi2Fatal the instance refuses
 * every further call with fmi2Error instead of forwarding it, and its inner
 * instance is never freed (pythonfmu has released it already).
 *
 * The inner binary always logs: the wrapper needs to see every message to know
 * a call's status.  It passes a message on to the importer when the importer
 * turned logging on, and a warning or worse always.
 */
#define _GNU_SOURCE /* dladdr */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

typedef struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *freeInstance;
    fmi2SetupExperimentTYPE *setupExperiment;
    fmi2EnterInitializationModeTYPE *enterInitializationMode;
    fmi2ExitInitializationModeTYPE *exitInitializationMode;
    fmi2TerminateTYPE *terminate;
    fmi2ResetTYPE *reset;
    fmi2GetRealTYPE *getReal;
    fmi2GetIntegerTYPE *getInteger;
    fmi2GetBooleanTYPE *getBoolean;
    fmi2GetStringTYPE *getString;
    fmi2SetRealTYPE *setReal;
    fmi2SetIntegerTYPE *setInteger;
    fmi2SetBooleanTYPE *setBoolean;
    fmi2SetStringTYPE *setString;
    fmi2GetFMUstateTYPE *getFMUstate;
    fmi2SetFMUstateTYPE *setFMUstate;
    fmi2FreeFMUstateTYPE *freeFMUstate;
    fmi2SerializedFMUstateSizeTYPE *serializedFMUstateSize;
    fmi2SerializeFMUstateTYPE *serializeFMUstate;
    fmi2DeSerializeFMUstateTYPE *deSerializeFMUstate;
    fmi2DoStepTYPE *doStep;
    fmi2GetRealStatusTYPE *getRealStatus;
    fmi2GetBooleanStatusTYPE *getBooleanStatus;
} Inner;

typedef struct {
    void *library;
    Inner f;
    fmi2Component inner;
    const fmi2CallbackFunctions *host; /* the importer's callbacks: kept by reference, as pythonfmu does */
    fmi2CallbackFunctions relay; /* what the inner binary gets: our logger */
    char *name;
    fmi2Boolean loggingOn;
    fmi2Status worst; /* worst status logged during the current call */
    int dead;         /* the inner binary reported fmi2Fatal */
} Wrapper;

static fmi2Status worse(fmi2Status a, fmi2Status b) {
    if (a == fmi2Fatal) a = fmi2Error; /* never Fatal: the instance refuses calls instead */
    if (b == fmi2Fatal) b = fmi2Error;
    if (a == fmi2Pending) return b;
    if (b == fmi2Pending) return a;
    return a > b ? a : b;
}

static void tell(Wrapper *w, fmi2Status status, const char *message) {
    if (w->host->logger && (w->loggingOn || status >= fmi2Warning))
        w->host->logger(w->host->componentEnvironment, w->name, status, "logStatusError", message);
}

static void relay(fmi2ComponentEnvironment env, fmi2String instanceName, fmi2Status status,
                  fmi2String category, fmi2String message, ...) {
    Wrapper *w = (Wrapper *)env;
    (void)instanceName;
    w->worst = worse(w->worst, status);
    if (status == fmi2Fatal) status = fmi2Error; /* pythonfmu's word for a Python exception: never Fatal here */
    if (w->host->logger && (w->loggingOn || status >= fmi2Warning))
        w->host->logger(w->host->componentEnvironment, w->name, status, category ? category : "", message);
}

/* The status of a forwarded call. */
static fmi2Status settle(Wrapper *w, fmi2Status status, const char *call) {
    if (status == fmi2Fatal) {
        char text[256];
        w->dead = 1;
        snprintf(text, sizeof text, "%s: the Python slave failed; this instance refuses every further call "
                 "(free it and instantiate again)", call);
        tell(w, fmi2Error, text);
        return fmi2Error;
    }
    return worse(status, w->worst);
}

static int refuse_dead(Wrapper *w, const char *call) {
    char text[256];
    if (!w->dead) return 0;
    snprintf(text, sizeof text, "%s refused: the Python slave failed earlier (free the instance)", call);
    tell(w, fmi2Error, text);
    return 1;
}

#define FORWARD(call, ...)                                   \
    Wrapper *w = (Wrapper *)c;                               \
    if (w == NULL) return fmi2Error;                         \
    if (refuse_dead(w, #call)) return fmi2Error;             \
    w->worst = fmi2OK;                                       \
    return settle(w, w->f.call(w->inner, __VA_ARGS__), #call)

#define FORWARD0(call)                                       \
    Wrapper *w = (Wrapper *)c;                               \
    if (w == NULL) return fmi2Error;                         \
    if (refuse_dead(w, #call)) return fmi2Error;             \
    w->worst = fmi2OK;                                       \
    return settle(w, w->f.call(w->inner), #call)

/* The inner binary's path: ours, with "_pythonfmu" before the extension. */
static int inner_path(char *out, size_t size) {
    Dl_info info;
    const char *dot;
    size_t stem;
    if (!dladdr((void *)&fmi2Instantiate, &info) || info.dli_fname == NULL) return -1;
    dot = strrchr(info.dli_fname, '.');
    stem = dot ? (size_t)(dot - info.dli_fname) : strlen(info.dli_fname);
    if (snprintf(out, size, "%.*s_pythonfmu%s", (int)stem, info.dli_fname, dot ? dot : "") >= (int)size) return -1;
    return 0;
}

static int load(Wrapper *w, char *why, size_t size) {
    char path[4096];
    if (inner_path(path, sizeof path)) {
        snprintf(why, size, "cannot locate the wrapper's own file");
        return -1;
    }
    w->library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (w->library == NULL) {
        snprintf(why, size, "cannot load %s: %s", path, dlerror());
        return -1;
    }
#define BIND(field, symbol)                                                            \
    if ((*(void **)&w->f.field = dlsym(w->library, #symbol)) == NULL) {                \
        snprintf(why, size, "%s has no %s", path, #symbol);                            \
        return -1;                                                                     \
    }
    BIND(instantiate, fmi2Instantiate) BIND(freeInstance, fmi2FreeInstance)
    BIND(setupExperiment, fmi2SetupExperiment) BIND(enterInitializationMode, fmi2EnterInitializationMode)
    BIND(exitInitializationMode, fmi2ExitInitializationMode) BIND(terminate, fmi2Terminate)
    BIND(reset, fmi2Reset) BIND(getReal, fmi2GetReal) BIND(getInteger, fmi2GetInteger)
    BIND(getBoolean, fmi2GetBoolean) BIND(getString, fmi2GetString) BIND(setReal, fmi2SetReal)
    BIND(setInteger, fmi2SetInteger) BIND(setBoolean, fmi2SetBoolean) BIND(setString, fmi2SetString)
    BIND(getFMUstate, fmi2GetFMUstate) BIND(setFMUstate, fmi2SetFMUstate) BIND(freeFMUstate, fmi2FreeFMUstate)
    BIND(serializedFMUstateSize, fmi2SerializedFMUstateSize) BIND(serializeFMUstate, fmi2SerializeFMUstate)
    BIND(deSerializeFMUstate, fmi2DeSerializeFMUstate) BIND(doStep, fmi2DoStep)
    BIND(getRealStatus, fmi2GetRealStatus) BIND(getBooleanStatus, fmi2GetBooleanStatus)
#undef BIND
    return 0;
}

static void release(Wrapper *w) {
    if (w->library) dlclose(w->library);
    free(w->name);
    free(w);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    char why[4200];
    Wrapper *w;
    if (functions == NULL) return NULL;
    w = (Wrapper *)calloc(1, sizeof *w);
    if (w == NULL) return NULL;
    w->host = functions;
    w->relay = *functions;
    w->relay.logger = relay;
    w->relay.componentEnvironment = w;
    w->loggingOn = loggingOn;
    w->name = strdup(instanceName ? instanceName : "");
    if (w->name == NULL) {
        free(w);
        return NULL;
    }
    if (load(w, why, sizeof why)) {
        tell(w, fmi2Error, why);
        release(w);
        return NULL;
    }
    w->inner = w->f.instantiate(instanceName, fmuType, fmuGUID, fmuResourceLocation, &w->relay, visible, fmi2True);
    if (w->inner == NULL) {
        release(w);
        return NULL;
    }
    return w;
}

void fmi2FreeInstance(fmi2Component c) {
    Wrapper *w = (Wrapper *)c;
    if (w == NULL) return;
    if (!w->dead) w->f.freeInstance(w->inner); /* a dead one was released by pythonfmu already */
    release(w);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    Wrapper *w = (Wrapper *)c;
    (void)nCategories;
    (void)categories;
    if (w == NULL) return fmi2Error;
    w->loggingOn = loggingOn; /* the inner binary keeps logging everything to us */
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    FORWARD(setupExperiment, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { FORWARD0(enterInitializationMode); }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { FORWARD0(exitInitializationMode); }
fmi2Status fmi2Terminate(fmi2Component c) { FORWARD0(terminate); }
fmi2Status fmi2Reset(fmi2Component c) { FORWARD0(reset); }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    FORWARD(getReal, vr, nvr, value);
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    FORWARD(getInteger, vr, nvr, value);
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    FORWARD(getBoolean, vr, nvr, value);
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    FORWARD(getString, vr, nvr, value);
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    FORWARD(setReal, vr, nvr, value);
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    FORWARD(setInteger, vr, nvr, value);
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    FORWARD(setBoolean, vr, nvr, value);
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    FORWARD(setString, vr, nvr, value);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) { FORWARD(getFMUstate, state); }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) { FORWARD(setFMUstate, state); }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) { FORWARD(freeFMUstate, state); }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    FORWARD(serializedFMUstateSize, state, size);
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte serializedState[], size_t size) {
    FORWARD(serializeFMUstate, state, serializedState, size);
}
/* Not a variable: through it the slave says whether the blob it just deserialised
 * is refused (grubler.system.fmi_slave.STATE_CHECK_VR), logging why. */
#define STATE_CHECK_VR ((fmi2ValueReference)0xFFFFFFFFu)

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *state) {
    Wrapper *w = (Wrapper *)c;
    fmi2ValueReference vr = STATE_CHECK_VR;
    fmi2String verdict = NULL;
    fmi2Status status;
    if (w == NULL || state == NULL) return fmi2Error;
    if (refuse_dead(w, "deSerializeFMUstate")) return fmi2Error;
    w->worst = fmi2OK;
    status = settle(w, w->f.deSerializeFMUstate(w->inner, serializedState, size, state), "deSerializeFMUstate");
    if (status >= fmi2Error) return status;
    /* pythonfmu deserialises on the class, which cannot log: ask the instance */
    w->worst = fmi2OK;
    if (settle(w, w->f.getString(w->inner, &vr, 1, &verdict), "deSerializeFMUstate") >= fmi2Error) {
        if (!w->dead) w->f.freeFMUstate(w->inner, state);
        *state = NULL;
        return fmi2Error;
    }
    return status;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    FORWARD(doStep, currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint);
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    FORWARD(getRealStatus, s, value);
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    FORWARD(getBooleanStatus, s, value);
}

static fmi2Status unsupported(fmi2Component c, const char *call) {
    Wrapper *w = (Wrapper *)c;
    char text[128];
    if (w == NULL) return fmi2Error;
    snprintf(text, sizeof text, "%s is not supported by this FMU", call);
    tell(w, fmi2Error, text);
    return fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value;
    return unsupported(c, "fmi2GetStatus");
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value;
    return unsupported(c, "fmi2GetIntegerStatus");
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value;
    return unsupported(c, "fmi2GetStringStatus");
}
fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "fmi2CancelStep"); }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return unsupported(c, "fmi2GetDirectionalDerivative");
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    return unsupported(c, "fmi2SetRealInputDerivatives");
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives");
}
