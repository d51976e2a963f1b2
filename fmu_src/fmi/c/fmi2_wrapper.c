/* Generic FMI 2.0 co-simulation wrapper: the FMI side of every native grubler FMU.
 *
 * In the spirit of the FMI Reference FMUs: one instance struct, the FMI state
 * machine as a bit mask per call, every argument checked.  A call that breaks
 * the contract (unknown value reference, wrong type, a parameter after
 * initialisation, a call in the wrong state, a bad FMU state) logs why and
 * returns fmi2Error, and the instance then refuses everything but fmi2Reset and
 * fmi2FreeInstance: the importer never gets a crash, nor a silently ignored call.
 *
 * The FMU state is a copy of the instance's persistent block of doubles
 * (parameters, inputs, the model's run state).  Serialised, it is a plain byte
 * layout, little-endian whatever the platform, checked on the way in:
 *
 *   offset  size  field
 *   0       8     magic "GRBFMI2S"
 *   8       4     layout version (1)
 *   12      4     MODEL_N_STORED (parameter and input slots)
 *   16      4     doubles in the block (model_persistent_size())
 *   20      4     reserved, 0
 *   24      8     FNV-1a 64 of MODEL_GUID: a state of another model is foreign
 *   32      8     FNV-1a 64 of the parameter and input slots' bytes
 *   40      8     FNV-1a 64 of the whole block's bytes
 *   48      8*n   the block, IEEE 754 doubles
 *
 * Nothing in it is executed or interpreted beyond these numbers, and the
 * checksums only catch accidents: anyone can write a blob that passes them.  So
 * a state's values, whether restored from memory or from bytes, pass the same
 * checks as values set one by one (value_ok for each variable, model_check for
 * the model's parameters and its run state) before anything uses them.
 */
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "fmi2_model.h"

#define STATE_MAGIC "GRBFMI2S"
#define STATE_VERSION 1u
#define STATE_HEADER 48u

/* states in which each call is allowed (FMI 2.0 co-simulation, section 4.2.4) */
#define ANY_LIVE (GRB_INSTANTIATED | GRB_INITIALIZATION | GRB_STEP_COMPLETE | GRB_TERMINATED)
#define MASK_SETUP GRB_INSTANTIATED
#define MASK_ENTER_INIT GRB_INSTANTIATED
#define MASK_EXIT_INIT GRB_INITIALIZATION
#define MASK_TERMINATE GRB_STEP_COMPLETE
#define MASK_GET (GRB_INITIALIZATION | GRB_STEP_COMPLETE | GRB_TERMINATED)
#define MASK_SET (GRB_INSTANTIATED | GRB_INITIALIZATION | GRB_STEP_COMPLETE)
#define MASK_DO_STEP GRB_STEP_COMPLETE
#define MASK_FMU_STATE ANY_LIVE

/* an fmi2FMUstate: a tagged copy of the persistent block; guid is the model's
 * GUID hash, so that a state of another FMU of the same layout is refused in
 * memory as it is serialised */
typedef struct grb_saved {
    char tag[8];
    uint64_t guid;
    size_t n;
    double block[1];
} grb_saved;

static const char *status_category(fmi2Status s) {
    switch (s) {
    case fmi2OK: return "logAll";
    case fmi2Warning: return "logStatusWarning";
    case fmi2Discard: return "logStatusDiscard";
    case fmi2Error: return "logStatusError";
    default: return "logStatusFatal";
    }
}

void grb_log(grb_instance *inst, fmi2Status status, const char *fmt, ...) {
    char msg[1024], out[2048];
    size_t i, j = 0;
    va_list ap;
    const fmi2CallbackFunctions *f;
    if (inst == NULL) return;
    f = inst->functions != NULL ? inst->functions : &inst->cb;
    if (f->logger == NULL) return;
    if (status == fmi2OK && !inst->logging) return;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    /* Some hosts use the message as a printf format, others print it as is: a
     * message without % reads the same to both (and cannot make a formatting
     * host read arguments that are not there), so a % becomes a word. */
    for (i = 0; msg[i] != '\0' && j + 8 < sizeof out; i++) {
        if (msg[i] == '%') {
            memcpy(out + j, "percent", 7);
            j += 7;
        } else {
            out[j++] = msg[i];
        }
    }
    out[j] = '\0';
    f->logger(f->componentEnvironment, inst->name, status, status_category(status), out);
}

/* log, enter the error state, return fmi2Error */
static fmi2Status fail(grb_instance *inst, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static fmi2Status fail(grb_instance *inst, const char *fmt, ...) {
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    grb_log(inst, fmi2Error, "%s", msg);
    inst->state = GRB_ERROR;
    return fmi2Error;
}

static const char *state_name(int state) {
    switch (state) {
    case GRB_INSTANTIATED: return "instantiated";
    case GRB_INITIALIZATION: return "initialization mode";
    case GRB_STEP_COMPLETE: return "stepping (step complete)";
    case GRB_TERMINATED: return "terminated";
    default: return "error";
    }
}

/* The checks every call starts with. */
static int allowed(grb_instance *inst, const char *call, int mask) {
    if (inst == NULL) return 0;
    if (inst->state == GRB_ERROR) {
        grb_log(inst, fmi2Error, "%s refused: an earlier call failed (see the log); only fmi2Reset and "
                "fmi2FreeInstance are allowed now", call);
        return 0;
    }
    if (!(inst->state & mask)) {
        fail(inst, "%s is not allowed in the state %s", call, state_name(inst->state));
        return 0;
    }
    return 1;
}

static const grb_variable *lookup(grb_instance *inst, const char *call, fmi2ValueReference vr, int type) {
    static const char *const type_name[] = {"Real", "Integer", "Boolean", "String"};
    const grb_variable *v;
    if (vr < 1 || vr > MODEL_N_VARIABLES) {
        fail(inst, "%s: unknown value reference %u (this model has 1 .. %d)", call, (unsigned)vr, MODEL_N_VARIABLES);
        return NULL;
    }
    v = &model_variables[vr - 1];
    if (v->type != type) {
        fail(inst, "%s: %s (value reference %u) is a %s variable, not %s", call, v->name, (unsigned)vr,
             type_name[v->type], type_name[type]);
        return NULL;
    }
    return v;
}

static int check_array(grb_instance *inst, const char *call, const void *vr, size_t nvr, const void *value) {
    if (nvr > 0 && (vr == NULL || value == NULL)) {
        fail(inst, "%s: NULL value reference or value array for %u values", call, (unsigned)nvr);
        return 0;
    }
    return 1;
}

/* May this variable be set now?  Parameters are fixed once initialisation ends. */
static int settable(grb_instance *inst, const char *call, const grb_variable *v) {
    if (v->causality == GRB_C_OUTPUT) {
        fail(inst, "%s: %s is an output, it cannot be set", call, v->name);
        return 0;
    }
    if (v->causality == GRB_C_PARAMETER && !(inst->state & (GRB_INSTANTIATED | GRB_INITIALIZATION))) {
        fail(inst, "%s: %s is a fixed parameter; it cannot change after initialisation (fmi2Reset, then set it)",
             call, v->name);
        return 0;
    }
    return 1;
}

/* Is x a value this variable can hold, as fmi2SetInteger, fmi2SetBoolean and
 * fmi2SetString store them (a Real holds any double: the model checks it)?
 * The one check for values set by the importer and values a state brings. */
static int value_ok(grb_instance *inst, const char *call, const grb_variable *v, double x) {
    switch (v->type) {
    case GRB_T_INTEGER:
        if (!(x == floor(x) && fabs(x) <= INT_MAX)) {
            fail(inst, "%s: %s must be an integer, got %.17g", call, v->name, x);
            return 0;
        }
        if (v->enum_items > 0 && (x < 1 || x > v->enum_items)) {
            fail(inst, "%s: %s must be an item 1 .. %d of its enumeration, got %.17g", call, v->name,
                 v->enum_items, x);
            return 0;
        }
        if ((v->min != 0 || v->max != 0) && (x < v->min || x > v->max)) {
            fail(inst, "%s: %s must be in %d .. %d, got %.17g", call, v->name, v->min, v->max, x);
            return 0;
        }
        return 1;
    case GRB_T_BOOLEAN:
        if (x != 0.0 && x != 1.0) {
            fail(inst, "%s: %s must be a Boolean (0 or 1), got %.17g", call, v->name, x);
            return 0;
        }
        return 1;
    case GRB_T_STRING:  /* stored as the index of one of its choices */
        if (!(x == floor(x) && x >= 0 && x < v->n_choices)) {
            fail(inst, "%s: %s must be the index of one of its %d accepted values, got %.17g", call, v->name,
                 v->n_choices, x);
            return 0;
        }
        return 1;
    default:
        return 1;
    }
}

/* The values of a whole persistent block (a state to restore): every
 * parameter's and input's by value_ok, the was-set flags, then the model's
 * checks of its parameters and its run state (model_check). */
static int block_ok(grb_instance *inst, const char *call, const double *block) {
    int k;
    for (k = 0; k < MODEL_N_VARIABLES; k++) {
        const grb_variable *v = &model_variables[k];
        double set;
        if (v->causality == GRB_C_OUTPUT) continue;
        if (!value_ok(inst, call, v, block[v->slot])) return 0;
        set = block[MODEL_N_STORED + v->slot];
        if (set != 0.0 && set != 1.0) {
            fail(inst, "%s: the flag saying whether %s was set must be 0 or 1, got %.17g", call, v->name, set);
            return 0;
        }
    }
    if (model_check(inst, block) != fmi2OK) {
        grb_log(inst, fmi2Error, "%s: the state is refused (see the reason above); only fmi2Reset and "
                "fmi2FreeInstance are allowed now", call);
        inst->state = GRB_ERROR;
        return 0;
    }
    return 1;
}

static void set_stored(grb_instance *inst, const grb_variable *v, double x) {
    inst->p[MODEL_N_STORED + v->slot] = 1.0;
    if (inst->p[v->slot] == x) return;
    inst->p[v->slot] = x;
    if (v->causality == GRB_C_PARAMETER) {
        inst->dirty = 1;
        inst->level = 0;
    } else if (inst->level > model_input_free_level()) {
        inst->level = model_input_free_level();
    }
}

/* Before reading outputs: the model agrees with its parameters, and the level is computed. */
static fmi2Status ready(grb_instance *inst, int level) {
    fmi2Status s;
    if (inst->dirty) {
        s = model_prepare(inst);
        if (s > fmi2Warning) {
            inst->state = GRB_ERROR;
            return fmi2Error;
        }
        inst->dirty = 0;
        inst->level = 0;
    }
    if (level > inst->level) {
        s = model_compute(inst, level);
        if (s > fmi2Warning) {
            inst->state = GRB_ERROR;
            return fmi2Error;
        }
        if (s == fmi2OK) inst->level = level;
        return s;
    }
    return fmi2OK;
}

static void fresh_block(grb_instance *inst) {
    size_t n = model_persistent_size(), k;
    for (k = 0; k < n; k++) inst->p[k] = 0.0;
    memcpy(inst->p, model_starts, sizeof model_starts);
    model_reset(inst);
    inst->dirty = 1;
    inst->level = 0;
}

/* ---- FNV-1a and little-endian encoding ---------------------------------- */

static uint64_t fnv1a(uint64_t h, const unsigned char *b, size_t n) {
    size_t k;
    for (k = 0; k < n; k++) {
        h ^= b[k];
        h *= 1099511628211ull;
    }
    return h;
}
#define FNV_OFFSET 14695981039346656037ull

static void put_u32(unsigned char *b, uint32_t x) {
    int k;
    for (k = 0; k < 4; k++) b[k] = (unsigned char)(x >> (8 * k));
}
static void put_u64(unsigned char *b, uint64_t x) {
    int k;
    for (k = 0; k < 8; k++) b[k] = (unsigned char)(x >> (8 * k));
}
static uint32_t get_u32(const unsigned char *b) {
    uint32_t x = 0;
    int k;
    for (k = 0; k < 4; k++) x |= (uint32_t)b[k] << (8 * k);
    return x;
}
static uint64_t get_u64(const unsigned char *b) {
    uint64_t x = 0;
    int k;
    for (k = 0; k < 8; k++) x |= (uint64_t)b[k] << (8 * k);
    return x;
}
static void put_doubles(unsigned char *b, const double *x, size_t n) {
    size_t k;
    for (k = 0; k < n; k++) {
        uint64_t u;
        memcpy(&u, &x[k], 8);
        put_u64(b + 8 * k, u);
    }
}
static uint64_t guid_hash(void) {
    return fnv1a(FNV_OFFSET, (const unsigned char *)MODEL_GUID, strlen(MODEL_GUID));
}

/* ---- the FMI functions ---------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    grb_instance *inst = (grb_instance *)c;
    size_t k;
    if (!allowed(inst, "fmi2SetDebugLogging", ANY_LIVE)) return fmi2Error;
    if (nCategories > 0 && categories == NULL) return fail(inst, "fmi2SetDebugLogging: NULL categories");
    for (k = 0; k < nCategories; k++) {
        const char *cat = categories[k];
        if (cat == NULL || (strcmp(cat, "logAll") && strcmp(cat, "logStatusWarning") &&
                            strcmp(cat, "logStatusDiscard") && strcmp(cat, "logStatusError") &&
                            strcmp(cat, "logStatusFatal")))
            return fail(inst, "fmi2SetDebugLogging: unknown log category %s", cat ? cat : "(NULL)");
    }
    inst->logging = loggingOn ? 1 : 0;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    grb_instance tmp, *inst;
    const char *name = instanceName ? instanceName : "";
    size_t len;
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL || functions->allocateMemory == NULL || functions->freeMemory == NULL) return NULL;
    memset(&tmp, 0, sizeof tmp);
    tmp.cb = *functions;
    tmp.functions = functions;
    tmp.name = (char *)name;
    tmp.state = GRB_INSTANTIATED;
    if (instanceName == NULL || instanceName[0] == '\0') {
        grb_log(&tmp, fmi2Error, "fmi2Instantiate: an instance needs a non-empty name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        grb_log(&tmp, fmi2Error, "fmi2Instantiate: %s is a co-simulation FMU (no model exchange)", MODEL_NAME);
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, MODEL_GUID) != 0) {
        grb_log(&tmp, fmi2Error, "fmi2Instantiate: GUID %s does not match this binary's %s (a model description "
                "from another build?)", fmuGUID ? fmuGUID : "(NULL)", MODEL_GUID);
        return NULL;
    }
    inst = (grb_instance *)functions->allocateMemory(1, sizeof *inst);
    if (inst == NULL) return NULL;
    *inst = tmp;
    len = strlen(name);
    inst->name = (char *)functions->allocateMemory(len + 1, 1);
    inst->p = (double *)functions->allocateMemory(model_persistent_size(), sizeof(double));
    inst->model = functions->allocateMemory(1, model_scratch_bytes());
    if (inst->name == NULL || inst->p == NULL || inst->model == NULL) {
        grb_log(&tmp, fmi2Error, "fmi2Instantiate: out of memory");
        if (inst->name) functions->freeMemory(inst->name);
        if (inst->p) functions->freeMemory(inst->p);
        if (inst->model) functions->freeMemory(inst->model);
        functions->freeMemory(inst);
        return NULL;
    }
    memcpy(inst->name, name, len + 1);
    inst->logging = loggingOn ? 1 : 0;
    fresh_block(inst);
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    grb_instance *inst = (grb_instance *)c;
    fmi2CallbackFreeMemory release;
    if (inst == NULL) return;
    release = inst->cb.freeMemory;
    release(inst->model);
    release(inst->p);
    release(inst->name);
    release(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    grb_instance *inst = (grb_instance *)c;
    (void)toleranceDefined;
    (void)tolerance;  /* the model's own rtol parameter governs its sub-steps */
    (void)stopTimeDefined;
    (void)stopTime;
    if (!allowed(inst, "fmi2SetupExperiment", MASK_SETUP)) return fmi2Error;
    if (!isfinite(startTime)) return fail(inst, "fmi2SetupExperiment: start time must be finite, got %g", startTime);
    inst->start_time = startTime;
    inst->dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    grb_instance *inst = (grb_instance *)c;
    if (!allowed(inst, "fmi2EnterInitializationMode", MASK_ENTER_INIT)) return fmi2Error;
    inst->state = GRB_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    grb_instance *inst = (grb_instance *)c;
    fmi2Status s;
    if (!allowed(inst, "fmi2ExitInitializationMode", MASK_EXIT_INIT)) return fmi2Error;
    s = ready(inst, 0);
    if (s > fmi2Warning) return fmi2Error;
    s = model_start(inst);
    if (s > fmi2Warning) {
        inst->state = GRB_ERROR;
        return fmi2Error;
    }
    inst->state = GRB_STEP_COMPLETE;
    return s;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    grb_instance *inst = (grb_instance *)c;
    if (!allowed(inst, "fmi2Terminate", MASK_TERMINATE)) return fmi2Error;
    inst->state = GRB_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    grb_instance *inst = (grb_instance *)c;
    if (inst == NULL) return fmi2Error;
    fresh_block(inst);
    inst->start_time = 0.0;
    inst->state = GRB_INSTANTIATED;
    return fmi2OK;
}

/* ---- values ------------------------------------------------------------------ */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    grb_instance *inst = (grb_instance *)c;
    int level = 0;
    size_t k;
    fmi2Status s = fmi2OK;
    const double *out;
    if (!allowed(inst, "fmi2GetReal", MASK_GET) || !check_array(inst, "fmi2GetReal", vr, nvr, value))
        return fmi2Error;
    /* the costliest output group asked for, computed once (it includes the cheaper ones' work) */
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = lookup(inst, "fmi2GetReal", vr[k], GRB_T_REAL);
        if (v == NULL) return fmi2Error;
        if (v->causality == GRB_C_OUTPUT && v->level > level) level = v->level;
    }
    if (level > 0) {  /* parameters and inputs read back need no model */
        s = ready(inst, level);
        if (s > fmi2Warning) return fmi2Error;
    }
    out = model_outputs(inst);
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = &model_variables[vr[k] - 1];
        value[k] = v->causality == GRB_C_OUTPUT ? (v->level <= inst->level ? out[v->slot] : NAN) : inst->p[v->slot];
    }
    return s;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    grb_instance *inst = (grb_instance *)c;
    size_t k;
    if (!allowed(inst, "fmi2GetInteger", MASK_GET) || !check_array(inst, "fmi2GetInteger", vr, nvr, value))
        return fmi2Error;
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = lookup(inst, "fmi2GetInteger", vr[k], GRB_T_INTEGER);
        if (v == NULL) return fmi2Error;
        value[k] = (fmi2Integer)inst->p[v->slot];
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    grb_instance *inst = (grb_instance *)c;
    size_t k;
    if (!allowed(inst, "fmi2GetBoolean", MASK_GET) || !check_array(inst, "fmi2GetBoolean", vr, nvr, value))
        return fmi2Error;
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = lookup(inst, "fmi2GetBoolean", vr[k], GRB_T_BOOLEAN);
        if (v == NULL) return fmi2Error;
        value[k] = inst->p[v->slot] != 0.0;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    grb_instance *inst = (grb_instance *)c;
    size_t k;
    if (!allowed(inst, "fmi2GetString", MASK_GET) || !check_array(inst, "fmi2GetString", vr, nvr, value))
        return fmi2Error;
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = lookup(inst, "fmi2GetString", vr[k], GRB_T_STRING);
        int i;
        if (v == NULL) return fmi2Error;
        i = (int)inst->p[v->slot];
        if (i < 0 || i >= v->n_choices) return fail(inst, "fmi2GetString: %s holds no valid value", v->name);
        value[k] = v->choices[i];  /* static text: valid for the FMU's lifetime */
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    grb_instance *inst = (grb_instance *)c;
    size_t k;
    if (!allowed(inst, "fmi2SetReal", MASK_SET) || !check_array(inst, "fmi2SetReal", vr, nvr, value))
        return fmi2Error;
    for (k = 0; k < nvr; k++) {  /* all checked before any is stored */
        const grb_variable *v = lookup(inst, "fmi2SetReal", vr[k], GRB_T_REAL);
        if (v == NULL || !settable(inst, "fmi2SetReal", v)) return fmi2Error;
    }
    for (k = 0; k < nvr; k++) set_stored(inst, &model_variables[vr[k] - 1], value[k]);
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    grb_instance *inst = (grb_instance *)c;
    size_t k;
    if (!allowed(inst, "fmi2SetInteger", MASK_SET) || !check_array(inst, "fmi2SetInteger", vr, nvr, value))
        return fmi2Error;
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = lookup(inst, "fmi2SetInteger", vr[k], GRB_T_INTEGER);
        if (v == NULL || !settable(inst, "fmi2SetInteger", v) || !value_ok(inst, "fmi2SetInteger", v, value[k]))
            return fmi2Error;
    }
    for (k = 0; k < nvr; k++) set_stored(inst, &model_variables[vr[k] - 1], (double)value[k]);
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    grb_instance *inst = (grb_instance *)c;
    size_t k;
    if (!allowed(inst, "fmi2SetBoolean", MASK_SET) || !check_array(inst, "fmi2SetBoolean", vr, nvr, value))
        return fmi2Error;
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = lookup(inst, "fmi2SetBoolean", vr[k], GRB_T_BOOLEAN);
        if (v == NULL || !settable(inst, "fmi2SetBoolean", v)) return fmi2Error;
    }
    for (k = 0; k < nvr; k++) set_stored(inst, &model_variables[vr[k] - 1], value[k] ? 1.0 : 0.0);
    return fmi2OK;
}

static int choice_index(const grb_variable *v, const char *text) {
    int i;
    for (i = 0; i < v->n_choices; i++)
        if (strcmp(text, v->choices[i]) == 0) return i;
    return -1;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    grb_instance *inst = (grb_instance *)c;
    size_t k;
    if (!allowed(inst, "fmi2SetString", MASK_SET) || !check_array(inst, "fmi2SetString", vr, nvr, value))
        return fmi2Error;
    for (k = 0; k < nvr; k++) {  /* all checked before any is stored */
        const grb_variable *v = lookup(inst, "fmi2SetString", vr[k], GRB_T_STRING);
        char accepted[512];
        size_t used = 0;
        int i;
        if (v == NULL || !settable(inst, "fmi2SetString", v)) return fmi2Error;
        if (value[k] == NULL) return fail(inst, "fmi2SetString: NULL value for %s", v->name);
        if (choice_index(v, value[k]) >= 0) continue;
        accepted[0] = '\0';
        for (i = 0; i < v->n_choices && used + 4 < sizeof accepted; i++) {
            int w = snprintf(accepted + used, sizeof accepted - used, "%s'%s'", i ? ", " : "", v->choices[i]);
            if (w < 0) break;
            used += (size_t)w;
        }
        return fail(inst, "fmi2SetString: %s cannot be '%.100s'; it accepts %s", v->name, value[k], accepted);
    }
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = &model_variables[vr[k] - 1];
        set_stored(inst, v, (double)choice_index(v, value[k]));
    }
    return fmi2OK;
}

/* ---- stepping ------------------------------------------------------------------ */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    grb_instance *inst = (grb_instance *)c;
    double t;
    fmi2Status s;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(inst, "fmi2DoStep", MASK_DO_STEP)) return fmi2Error;
    if (inst->dirty) {  /* a state restored while stepping: the model follows its parameters */
        s = ready(inst, 0);
        if (s > fmi2Warning) return fmi2Error;
        s = model_start(inst);  /* (a state saved before initialisation starts here) */
        if (s > fmi2Warning) {
            inst->state = GRB_ERROR;
            return fmi2Error;
        }
    }
    /* a step the model cannot take from here is refused, not fatal: the master
     * may retry with another step, or restore a saved state to roll back */
    if (!(communicationStepSize > 0.0) || !isfinite(communicationStepSize)) {
        grb_log(inst, fmi2Discard, "fmi2DoStep: the step size must be positive and finite, got %g",
                communicationStepSize);
        return fmi2Discard;
    }
    t = model_time(inst);
    if (!isfinite(currentCommunicationPoint) || fabs(currentCommunicationPoint - t) > 1e-9 * (1.0 + fabs(t))) {
        grb_log(inst, fmi2Discard, "fmi2DoStep at t = %.17g s, but the model is at t = %.17g s (restore a saved FMU "
                "state to roll back)", currentCommunicationPoint, t);
        return fmi2Discard;
    }
    s = model_do_step(inst, currentCommunicationPoint, communicationStepSize);
    if (s > fmi2Discard) {
        inst->state = GRB_ERROR;
        return fmi2Error;
    }
    return s;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    grb_instance *inst = (grb_instance *)c;
    if (!allowed(inst, "fmi2CancelStep", ANY_LIVE)) return fmi2Error;
    return fail(inst, "fmi2CancelStep: steps are synchronous (canRunAsynchronuously is false)");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    grb_instance *inst = (grb_instance *)c;
    (void)vr; (void)nvr; (void)order; (void)value;
    if (!allowed(inst, "fmi2SetRealInputDerivatives", ANY_LIVE)) return fmi2Error;
    return fail(inst, "fmi2SetRealInputDerivatives: not supported (canInterpolateInputs is false)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    grb_instance *inst = (grb_instance *)c;
    (void)vr; (void)nvr; (void)order; (void)value;
    if (!allowed(inst, "fmi2GetRealOutputDerivatives", ANY_LIVE)) return fmi2Error;
    return fail(inst, "fmi2GetRealOutputDerivatives: not supported (maxOutputDerivativeOrder is 0)");
}

/* A co-simulation FMU's partial derivatives are those of its outputs with
 * respect to its inputs at the present state (FMI 2.0, section 4.2.3): every
 * unknown must be a Real output and every known a Real input. */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    grb_instance *inst = (grb_instance *)c;
#if MODEL_DIRECTIONAL_DERIVATIVE
    static const char *const call = "fmi2GetDirectionalDerivative";
    size_t k;
    if (!allowed(inst, call, MASK_GET) || !check_array(inst, call, vUnknown_ref, nUnknown, dvUnknown) ||
        !check_array(inst, call, vKnown_ref, nKnown, dvKnown))
        return fmi2Error;
    for (k = 0; k < nUnknown; k++) {
        const grb_variable *v = lookup(inst, call, vUnknown_ref[k], GRB_T_REAL);
        if (v == NULL) return fmi2Error;
        if (v->causality != GRB_C_OUTPUT)
            return fail(inst, "%s: %s is not an output; a co-simulation FMU's unknowns are its outputs", call,
                        v->name);
    }
    for (k = 0; k < nKnown; k++) {
        const grb_variable *v = lookup(inst, call, vKnown_ref[k], GRB_T_REAL);
        if (v == NULL) return fmi2Error;
        if (v->causality != GRB_C_INPUT)
            return fail(inst, "%s: %s is not an input; a co-simulation FMU's knowns are its inputs", call, v->name);
        if (!isfinite(dvKnown[k])) return fail(inst, "%s: the seed of %s is %g; it must be finite", call, v->name,
                                               dvKnown[k]);
    }
    if (ready(inst, 0) > fmi2Warning) return fmi2Error;
    return model_directional_derivative(inst, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown, dvUnknown);
#else
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    if (!allowed(inst, "fmi2GetDirectionalDerivative", ANY_LIVE)) return fmi2Error;
    return fail(inst, "fmi2GetDirectionalDerivative: not supported (providesDirectionalDerivative is false)");
#endif
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    grb_instance *inst = (grb_instance *)c;
    (void)s;
    if (!allowed(inst, "fmi2GetStatus", ANY_LIVE)) return fmi2Error;
    if (value == NULL) return fail(inst, "fmi2GetStatus: NULL value");
    return fail(inst, "fmi2GetStatus: no asynchronous step is ever pending");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    grb_instance *inst = (grb_instance *)c;
    if (!allowed(inst, "fmi2GetRealStatus", MASK_GET)) return fmi2Error;
    if (value == NULL) return fail(inst, "fmi2GetRealStatus: NULL value");
    if (s != fmi2LastSuccessfulTime) return fail(inst, "fmi2GetRealStatus: only fmi2LastSuccessfulTime is known");
    *value = model_time(inst);
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    grb_instance *inst = (grb_instance *)c;
    (void)s; (void)value;
    if (!allowed(inst, "fmi2GetIntegerStatus", ANY_LIVE)) return fmi2Error;
    return fail(inst, "fmi2GetIntegerStatus: no integer status exists");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    grb_instance *inst = (grb_instance *)c;
    if (!allowed(inst, "fmi2GetBooleanStatus", ANY_LIVE)) return fmi2Error;
    if (value == NULL) return fail(inst, "fmi2GetBooleanStatus: NULL value");
    if (s != fmi2Terminated) return fail(inst, "fmi2GetBooleanStatus: only fmi2Terminated is known");
    *value = fmi2False;  /* the model never asks to end the simulation */
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    grb_instance *inst = (grb_instance *)c;
    (void)s; (void)value;
    if (!allowed(inst, "fmi2GetStringStatus", ANY_LIVE)) return fmi2Error;
    return fail(inst, "fmi2GetStringStatus: no asynchronous step is ever pending");
}

/* ---- FMU state ---------------------------------------------------------------- */

/* Is this fmi2FMUstate one this model made (its tag, its model's GUID, its size)? */
static int ours(const grb_saved *saved) {
    return saved != NULL && memcmp(saved->tag, STATE_MAGIC, 8) == 0 && saved->guid == guid_hash() &&
           saved->n == model_persistent_size();
}

static grb_saved *new_saved(grb_instance *inst) {
    size_t n = model_persistent_size();
    grb_saved *saved = (grb_saved *)inst->cb.allocateMemory(1, sizeof(grb_saved) + (n - 1) * sizeof(double));
    if (saved == NULL) return NULL;
    memcpy(saved->tag, STATE_MAGIC, 8);
    saved->guid = guid_hash();
    saved->n = n;
    return saved;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    grb_instance *inst = (grb_instance *)c;
    size_t n = model_persistent_size();
    grb_saved *saved;
    if (!allowed(inst, "fmi2GetFMUstate", MASK_FMU_STATE)) return fmi2Error;
    if (FMUstate == NULL) return fail(inst, "fmi2GetFMUstate: NULL FMUstate pointer");
    saved = (grb_saved *)*FMUstate;
    if (saved != NULL && !ours(saved))
        return fail(inst, "fmi2GetFMUstate: *FMUstate is not a state of this model (pass NULL for a new one)");
    if (saved == NULL && (saved = new_saved(inst)) == NULL) return fail(inst, "fmi2GetFMUstate: out of memory");
    memcpy(saved->block, inst->p, n * sizeof(double));
    *FMUstate = saved;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    grb_instance *inst = (grb_instance *)c;
    const grb_saved *saved = (const grb_saved *)FMUstate;
    if (!allowed(inst, "fmi2SetFMUstate", MASK_FMU_STATE)) return fmi2Error;
    if (!ours(saved))
        return fail(inst, "fmi2SetFMUstate: not a state of this model (another FMU's, or not a state at all)");
    if (!block_ok(inst, "fmi2SetFMUstate", saved->block)) return fmi2Error;
    memcpy(inst->p, saved->block, model_persistent_size() * sizeof(double));
    inst->dirty = 1;
    inst->level = 0;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    grb_instance *inst = (grb_instance *)c;
    if (inst == NULL) return fmi2Error;
    if (FMUstate == NULL) return fail(inst, "fmi2FreeFMUstate: NULL FMUstate pointer");
    if (*FMUstate != NULL) inst->cb.freeMemory(*FMUstate);
    *FMUstate = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    grb_instance *inst = (grb_instance *)c;
    const grb_saved *saved = (const grb_saved *)FMUstate;
    if (!allowed(inst, "fmi2SerializedFMUstateSize", MASK_FMU_STATE)) return fmi2Error;
    if (size == NULL) return fail(inst, "fmi2SerializedFMUstateSize: NULL size");
    if (!ours(saved)) return fail(inst, "fmi2SerializedFMUstateSize: not a state of this model");
    *size = STATE_HEADER + 8 * saved->n;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    grb_instance *inst = (grb_instance *)c;
    const grb_saved *saved = (const grb_saved *)FMUstate;
    unsigned char *b = (unsigned char *)serializedState;
    size_t n;
    if (!allowed(inst, "fmi2SerializeFMUstate", MASK_FMU_STATE)) return fmi2Error;
    if (!ours(saved)) return fail(inst, "fmi2SerializeFMUstate: not a state of this model");
    n = saved->n;
    if (b == NULL || size < STATE_HEADER + 8 * n)
        return fail(inst, "fmi2SerializeFMUstate: the buffer holds %u bytes, the state needs %u", (unsigned)size,
                    (unsigned)(STATE_HEADER + 8 * n));
    memcpy(b, STATE_MAGIC, 8);
    put_u32(b + 8, STATE_VERSION);
    put_u32(b + 12, (uint32_t)MODEL_N_STORED);
    put_u32(b + 16, (uint32_t)n);
    put_u32(b + 20, 0);
    put_u64(b + 24, guid_hash());
    put_doubles(b + STATE_HEADER, saved->block, n);
    put_u64(b + 32, fnv1a(FNV_OFFSET, b + STATE_HEADER, 8 * (size_t)MODEL_N_STORED));
    put_u64(b + 40, fnv1a(FNV_OFFSET, b + STATE_HEADER, 8 * n));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    grb_instance *inst = (grb_instance *)c;
    const unsigned char *b = (const unsigned char *)serializedState;
    size_t n = model_persistent_size(), k;
    grb_saved *saved, *fresh;
    const char *call = "fmi2DeSerializeFMUstate";
    if (!allowed(inst, call, MASK_FMU_STATE)) return fmi2Error;
    if (FMUstate == NULL) return fail(inst, "%s: NULL FMUstate pointer", call);
    if (b == NULL || size < STATE_HEADER) return fail(inst, "%s: %u bytes are no serialised state (truncated?)", call,
                                                      (unsigned)size);
    if (memcmp(b, STATE_MAGIC, 8) != 0) return fail(inst, "%s: not a serialised grubler FMU state (bad magic)", call);
    if (get_u32(b + 8) != STATE_VERSION)
        return fail(inst, "%s: state layout version %u, this FMU reads version %u", call, (unsigned)get_u32(b + 8),
                    STATE_VERSION);
    if (get_u64(b + 24) != guid_hash() || get_u32(b + 12) != (uint32_t)MODEL_N_STORED || get_u32(b + 16) != n)
        return fail(inst, "%s: the state belongs to another model (its GUID or sizes differ from %s's)", call,
                    MODEL_NAME);
    if (size != STATE_HEADER + 8 * n)
        return fail(inst, "%s: %u bytes, a state of this model has %u (truncated or padded)", call, (unsigned)size,
                    (unsigned)(STATE_HEADER + 8 * n));
    if (get_u64(b + 32) != fnv1a(FNV_OFFSET, b + STATE_HEADER, 8 * (size_t)MODEL_N_STORED))
        return fail(inst, "%s: the parameters' checksum does not match (corrupted state)", call);
    if (get_u64(b + 40) != fnv1a(FNV_OFFSET, b + STATE_HEADER, 8 * n))
        return fail(inst, "%s: the state's checksum does not match (corrupted state)", call);
    saved = (grb_saved *)*FMUstate;
    if (saved != NULL && !ours(saved))
        return fail(inst, "%s: *FMUstate is not a state of this model (pass NULL for a new one)", call);
    /* decoded aside and checked: a refused blob leaves *FMUstate as it was */
    if ((fresh = new_saved(inst)) == NULL) return fail(inst, "%s: out of memory", call);
    for (k = 0; k < n; k++) {
        uint64_t u = get_u64(b + STATE_HEADER + 8 * k);
        memcpy(&fresh->block[k], &u, 8);
    }
    if (!block_ok(inst, call, fresh->block)) {
        inst->cb.freeMemory(fresh);
        return fmi2Error;
    }
    if (saved == NULL) {
        *FMUstate = fresh;
    } else {
        memcpy(saved->block, fresh->block, n * sizeof(double));
        inst->cb.freeMemory(fresh);
    }
    return fmi2OK;
}

/* ---- model exchange: not provided (the description declares co-simulation only) ---- */
