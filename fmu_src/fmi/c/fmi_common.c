/* The FMI side of every native grubler FMU, common to the FMI 2.0 and 3.0
 * adapters (fmi2_wrapper.c, fmi3_wrapper.c): the instance, the state machine,
 * every argument and state check, value references and types, logging, and the
 * FMU state.
 *
 * In the spirit of the FMI Reference FMUs: one instance struct, the FMI state
 * machine as a bit mask per call, every argument checked.  A call that breaks
 * the contract (unknown value reference, wrong type, a parameter after
 * initialisation, a call in the wrong state, a bad FMU state) logs why and
 * returns Error, and the instance then refuses everything but Reset,
 * FreeInstance and the FMU state calls (restoring a state saved before the
 * error makes it usable again, as FMI 2.0 section 2.1.3 and FMI 3.0 section
 * 2.2.3 allow): the importer never gets a crash, nor a silently ignored call.
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
 *   20      4     the state machine's state when saved: GRB_STEP_COMPLETE and
 *                 the like (fmi_model.h; GRB_ERROR: saved after a failed
 *                 call, never restored), 0 if not recorded
 *   24      8     FNV-1a 64 of MODEL_GUID: a state of another model is foreign
 *   32      8     FNV-1a 64 of the parameter and input slots' bytes
 *   40      8     FNV-1a 64 of the whole block's bytes
 *   48      8*n   the block, IEEE 754 doubles
 *
 * The layout is the model's, not the FMI version's: MODEL_GUID is the FMI 2.0
 * guid and the FMI 3.0 instantiationToken of the same model, so a state one
 * build serialised restores in the other (the magic keeps its first name).
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
#include <stdlib.h>
#include <string.h>

#include "fmi_common.h"

#define STATE_MAGIC "GRBFMI2S"
#define STATE_VERSION 1u
#define STATE_HEADER 48u

/* an FMU state (fmi2FMUstate, fmi3FMUState): a tagged copy of the persistent block; guid is the model's
 * GUID hash, so that a state of another FMU of the same layout is refused in
 * memory as it is serialised */
typedef struct grb_saved {
    char tag[8];
    uint64_t guid;
    int mode;  /* the state machine's state when saved (0: not recorded) */
    size_t n;
    double block[1];
} grb_saved;

static const char *status_category(grb_fmi_status s) {
    switch (s) {
    case GRB_FMI_OK: return "logAll";
    case GRB_FMI_WARNING: return "logStatusWarning";
    case GRB_FMI_DISCARD: return "logStatusDiscard";
    case GRB_FMI_ERROR: return "logStatusError";
    default: return "logStatusFatal";
    }
}

void grb_log(grb_instance *inst, grb_fmi_status status, const char *fmt, ...) {
    char msg[1024], out[2048];
    size_t i, j = 0;
    va_list ap;
    if (inst == NULL || inst->logger == NULL) return;
    if (status == GRB_FMI_OK && !inst->logging) return;
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
    inst->logger(inst, status, status_category(status), out);
}

/* log, enter the error state, return GRB_FMI_ERROR */
grb_fmi_status grb_fail(grb_instance *inst, const char *fmt, ...) {
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    grb_log(inst, GRB_FMI_ERROR, "%s", msg);
    inst->state = GRB_ERROR;
    return GRB_FMI_ERROR;
}

grb_fmi_status grb_raise(grb_instance *inst, grb_fmi_status s) {
    if (s > GRB_FMI_DISCARD) {
        inst->state = GRB_ERROR;
        return GRB_FMI_ERROR;
    }
    return s;
}

static const char *state_name(int state) {
    switch (state) {
    case GRB_INSTANTIATED: return "instantiated";
    case GRB_INITIALIZATION: return "initialization mode";
    case GRB_STEP_COMPLETE: return "stepping (step complete, FMI 3.0's step mode)";
    case GRB_TERMINATED: return "terminated";
    default: return "error";
    }
}

/* What an instance in the error state still takes. */
static const char *way_out(const grb_instance *inst) {
    return inst->fmi >= 3 ? "only fmi3Reset, fmi3FreeInstance and fmi3SetFMUState (a state saved before the error) "
                            "are allowed now"
                          : "only fmi2Reset, fmi2FreeInstance and fmi2SetFMUstate (a state saved before the error) "
                            "are allowed now";
}

int grb_allowed(grb_instance *inst, const char *call, int mask) {
    if (inst == NULL) return 0;
    if (inst->resume && inst->state == GRB_INSTANTIATED) {
        /* A state saved while stepping and restored before initialisation: a
         * call of step mode resumes the run there (as an importer that restores
         * the mode with the state expects: fmusim's --initial-fmu-state-file),
         * a call of initialisation takes the importer's own way there. */
        if (!(mask & GRB_INSTANTIATED) && (mask & inst->resume)) {
            inst->state = inst->resume;
            inst->resume = 0;
        } else if (!(mask & inst->resume)) {
            inst->resume = 0;
        }
    }
    if (inst->state == GRB_ERROR) {
        if (mask & GRB_ERROR) return 1;
        grb_log(inst, GRB_FMI_ERROR, "%s refused: an earlier call failed (see the log); %s", call, way_out(inst));
        return 0;
    }
    if (!(inst->state & mask)) {
        grb_fail(inst, "%s is not allowed in the state %s", call, state_name(inst->state));
        return 0;
    }
    return 1;
}

/* FMI 3.0's independent variable */
static const grb_variable time_variable = {"time", GRB_T_REAL, GRB_C_INDEPENDENT, 0, 0, 0, NULL, 0, 0, 0};

const grb_variable *grb_lookup(grb_instance *inst, const char *call, grb_value_reference vr, int type) {
    static const char *const type_name[] = {"Real", "Integer", "Boolean", "String"};
    const grb_variable *v;
    if (vr == GRB_VR_TIME && inst->fmi >= 3 && type == GRB_T_REAL) return &time_variable;
    if (vr < 1 || vr > MODEL_N_VARIABLES) {
        grb_fail(inst, "%s: unknown value reference %u (this model has 1 .. %d)", call, (unsigned)vr, MODEL_N_VARIABLES);
        return NULL;
    }
    v = &model_variables[vr - 1];
    if (v->type != type) {
        grb_fail(inst, "%s: %s (value reference %u) is a %s variable, not %s", call, v->name, (unsigned)vr,
             type_name[v->type], type_name[type]);
        return NULL;
    }
    return v;
}

int grb_check_array(grb_instance *inst, const char *call, const void *vr, size_t nvr, const void *value) {
    if (nvr > 0 && (vr == NULL || value == NULL)) {
        grb_fail(inst, "%s: NULL value reference or value array for %u values", call, (unsigned)nvr);
        return 0;
    }
    return 1;
}

/* May this variable be set now?  Parameters are fixed once initialisation ends. */
static int settable(grb_instance *inst, const char *call, const grb_variable *v) {
    if (v->causality == GRB_C_INDEPENDENT) {
        grb_fail(inst, "%s: time is the independent variable; the importer's calls advance it, it cannot be set", call);
        return 0;
    }
    if (v->causality == GRB_C_OUTPUT) {
        grb_fail(inst, "%s: %s is an output, it cannot be set", call, v->name);
        return 0;
    }
    if (v->causality == GRB_C_PARAMETER && !(inst->state & (GRB_INSTANTIATED | GRB_INITIALIZATION))) {
        grb_fail(inst, "%s: %s is a fixed parameter; it cannot change after initialisation (fmi%dReset, then set it)",
             call, v->name, inst->fmi);
        return 0;
    }
    return 1;
}

/* Is x a value this variable can hold, as the Integer, Boolean and
 * String setters store them (a Real holds any double: the model checks it)?
 * The one check for values set by the importer and values a state brings. */
static int value_ok(grb_instance *inst, const char *call, const grb_variable *v, double x) {
    switch (v->type) {
    case GRB_T_INTEGER:
        if (!(x == floor(x) && fabs(x) <= INT_MAX)) {
            grb_fail(inst, "%s: %s must be an integer, got %.17g", call, v->name, x);
            return 0;
        }
        if (v->enum_items > 0 && (x < 1 || x > v->enum_items)) {
            grb_fail(inst, "%s: %s must be an item 1 .. %d of its enumeration, got %.17g", call, v->name,
                 v->enum_items, x);
            return 0;
        }
        if ((v->min != 0 || v->max != 0) && (x < v->min || x > v->max)) {
            grb_fail(inst, "%s: %s must be in %d .. %d, got %.17g", call, v->name, v->min, v->max, x);
            return 0;
        }
        return 1;
    case GRB_T_BOOLEAN:
        if (x != 0.0 && x != 1.0) {
            grb_fail(inst, "%s: %s must be a Boolean (0 or 1), got %.17g", call, v->name, x);
            return 0;
        }
        return 1;
    case GRB_T_STRING:  /* stored as the index of one of its choices */
        if (!(x == floor(x) && x >= 0 && x < v->n_choices)) {
            grb_fail(inst, "%s: %s must be the index of one of its %d accepted values, got %.17g", call, v->name,
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
            grb_fail(inst, "%s: the flag saying whether %s was set must be 0 or 1, got %.17g", call, v->name, set);
            return 0;
        }
    }
    if (model_check(inst, block) != GRB_FMI_OK) {
        grb_log(inst, GRB_FMI_ERROR, "%s: the state is refused (see the reason above); %s", call, way_out(inst));
        inst->state = GRB_ERROR;
        return 0;
    }
    return 1;
}

void grb_store(grb_instance *inst, const grb_variable *v, double x) {
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
static grb_fmi_status ready(grb_instance *inst, int level) {
    grb_fmi_status s;
    if (inst->dirty) {
        s = model_prepare(inst);
        if (s > GRB_FMI_WARNING) {
            inst->state = GRB_ERROR;
            return GRB_FMI_ERROR;
        }
        inst->dirty = 0;
        inst->level = 0;
    }
    if (level > inst->level) {
        s = model_compute(inst, level);
        if (s > GRB_FMI_WARNING) {
            inst->state = GRB_ERROR;
            return GRB_FMI_ERROR;
        }
        if (s == GRB_FMI_OK) inst->level = level;
        return s;
    }
    return GRB_FMI_OK;
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

/* ---- instance and state machine ------------------------------------------- */

grb_fmi_status grb_set_debug_logging(grb_instance *inst, const char *call, int on, size_t n,
                                     const char *const categories[]) {
    size_t k;
    if (n > 0 && categories == NULL) return grb_fail(inst, "%s: NULL categories", call);
    for (k = 0; k < n; k++) {
        const char *cat = categories[k];
        if (cat == NULL || (strcmp(cat, "logAll") && strcmp(cat, "logStatusWarning") &&
                            strcmp(cat, "logStatusDiscard") && strcmp(cat, "logStatusError") &&
                            strcmp(cat, "logStatusFatal")))
            return grb_fail(inst, "%s: unknown log category %s", call, cat ? cat : "(NULL)");
    }
    inst->logging = on ? 1 : 0;
    return GRB_FMI_OK;
}

grb_instance *grb_instantiate(const grb_instance *adapter, const char *call, const char *name, const char *token,
                              int logging) {
    grb_instance tmp, *inst;
    size_t len;
    if (adapter->allocate == NULL || adapter->release == NULL) return NULL;
    tmp = *adapter;
    tmp.name = (char *)(name ? name : "");
    tmp.state = GRB_INSTANTIATED;
    if (name == NULL || name[0] == '\0') {
        grb_log(&tmp, GRB_FMI_ERROR, "%s: an instance needs a non-empty name", call);
        return NULL;
    }
    if (token == NULL || strcmp(token, MODEL_GUID) != 0) {
        grb_log(&tmp, GRB_FMI_ERROR, "%s: %s %s does not match this binary's %s (a model description from another "
                "build?)", call, tmp.fmi >= 3 ? "instantiationToken" : "GUID", token ? token : "(NULL)", MODEL_GUID);
        return NULL;
    }
    inst = (grb_instance *)adapter->allocate(1, sizeof *inst);
    if (inst == NULL) return NULL;
    *inst = tmp;
    len = strlen(name);
    inst->name = (char *)adapter->allocate(len + 1, 1);
    inst->p = (double *)adapter->allocate(model_persistent_size(), sizeof(double));
    inst->model = adapter->allocate(1, model_scratch_bytes());
    if (inst->name == NULL || inst->p == NULL || inst->model == NULL) {
        grb_log(&tmp, GRB_FMI_ERROR, "%s: out of memory", call);
        if (inst->name) adapter->release(inst->name);
        if (inst->p) adapter->release(inst->p);
        if (inst->model) adapter->release(inst->model);
        adapter->release(inst);
        return NULL;
    }
    memcpy(inst->name, name, len + 1);
    inst->logging = logging ? 1 : 0;
    fresh_block(inst);
    return inst;
}

void grb_free_instance(grb_instance *inst) {
    void (*release)(void *);
    if (inst == NULL) return;
    release = inst->release;
    release(inst->model);
    release(inst->p);
    release(inst->name);
    release(inst);
}

void grb_reset(grb_instance *inst) {
    fresh_block(inst);
    inst->resume = 0;
    inst->start_time = 0.0;
    inst->state = GRB_INSTANTIATED;
}

grb_fmi_status grb_set_start_time(grb_instance *inst, const char *call, double start_time) {
    if (!isfinite(start_time)) return grb_fail(inst, "%s: start time must be finite, got %g", call, start_time);
    inst->start_time = start_time;
    inst->dirty = 1;
    return GRB_FMI_OK;
}

/* The run starts from its parameters (once they prepared the model). */
static grb_fmi_status start(grb_instance *inst) {
    grb_fmi_status s;
    if (ready(inst, 0) > GRB_FMI_WARNING) return GRB_FMI_ERROR;
    s = model_start(inst);
    return s > GRB_FMI_WARNING ? grb_raise(inst, GRB_FMI_ERROR) : s;
}

grb_fmi_status grb_exit_initialization(grb_instance *inst) {
    grb_fmi_status s = start(inst);
    if (s <= GRB_FMI_WARNING) inst->state = GRB_STEP_COMPLETE;
    return s;
}

double grb_time(const grb_instance *inst) {
    return inst->state & (GRB_INSTANTIATED | GRB_INITIALIZATION) ? inst->start_time : model_time(inst);
}

/* ---- values ------------------------------------------------------------------ */

const grb_variable *grb_settable(grb_instance *inst, const char *call, grb_value_reference vr, int type, double x) {
    const grb_variable *v = grb_lookup(inst, call, vr, type);
    if (v == NULL || !settable(inst, call, v) || !value_ok(inst, call, v, x)) return NULL;
    return v;
}

grb_fmi_status grb_get_real(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                            double value[]) {
    int level = 0;
    size_t k;
    grb_fmi_status s = GRB_FMI_OK;
    const double *out;
    if (!grb_check_array(inst, call, vr, nvr, value)) return GRB_FMI_ERROR;
    /* the costliest output group asked for, computed once (it includes the cheaper ones' work) */
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = grb_lookup(inst, call, vr[k], GRB_T_REAL);
        if (v == NULL) return GRB_FMI_ERROR;
        if (v->causality == GRB_C_OUTPUT && v->level > level) level = v->level;
    }
    if (level > 0) {  /* parameters and inputs read back need no model */
        s = ready(inst, level);
        if (s > GRB_FMI_WARNING) return GRB_FMI_ERROR;
    }
    out = model_outputs(inst);
    for (k = 0; k < nvr; k++) {
        const grb_variable *v;
        if (vr[k] == GRB_VR_TIME) {  /* (only FMI 3.0 got past grb_lookup with it) */
            value[k] = grb_time(inst);
            continue;
        }
        v = &model_variables[vr[k] - 1];
        value[k] = v->causality == GRB_C_OUTPUT ? (v->level <= inst->level ? out[v->slot] : NAN) : inst->p[v->slot];
    }
    return s;
}

grb_fmi_status grb_set_real(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                            const double value[]) {
    size_t k;
    if (!grb_check_array(inst, call, vr, nvr, value)) return GRB_FMI_ERROR;
    for (k = 0; k < nvr; k++) {  /* all checked before any is stored */
        const grb_variable *v = grb_lookup(inst, call, vr[k], GRB_T_REAL);
        if (v == NULL || !settable(inst, call, v)) return GRB_FMI_ERROR;
    }
    for (k = 0; k < nvr; k++) grb_store(inst, &model_variables[vr[k] - 1], value[k]);
    return GRB_FMI_OK;
}

grb_fmi_status grb_get_stored(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                              int type, double value[]) {
    size_t k;
    if (!grb_check_array(inst, call, vr, nvr, value)) return GRB_FMI_ERROR;
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = grb_lookup(inst, call, vr[k], type);
        if (v == NULL) return GRB_FMI_ERROR;
        value[k] = inst->p[v->slot];
    }
    return GRB_FMI_OK;
}

grb_fmi_status grb_get_string(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                              const char *value[]) {
    size_t k;
    if (!grb_check_array(inst, call, vr, nvr, value)) return GRB_FMI_ERROR;
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = grb_lookup(inst, call, vr[k], GRB_T_STRING);
        int i;
        if (v == NULL) return GRB_FMI_ERROR;
        i = (int)inst->p[v->slot];
        if (i < 0 || i >= v->n_choices) return grb_fail(inst, "%s: %s holds no valid value", call, v->name);
        value[k] = v->choices[i];  /* static text: valid for the FMU's lifetime */
    }
    return GRB_FMI_OK;
}

static int choice_index(const grb_variable *v, const char *text) {
    int i;
    for (i = 0; i < v->n_choices; i++)
        if (strcmp(text, v->choices[i]) == 0) return i;
    return -1;
}

grb_fmi_status grb_set_string(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                              const char *const value[]) {
    size_t k;
    if (!grb_check_array(inst, call, vr, nvr, value)) return GRB_FMI_ERROR;
    for (k = 0; k < nvr; k++) {  /* all checked before any is stored */
        const grb_variable *v = grb_lookup(inst, call, vr[k], GRB_T_STRING);
        char accepted[512];
        size_t used = 0;
        int i;
        if (v == NULL || !settable(inst, call, v)) return GRB_FMI_ERROR;
        if (value[k] == NULL) return grb_fail(inst, "%s: NULL value for %s", call, v->name);
        if (choice_index(v, value[k]) >= 0) continue;
        accepted[0] = '\0';
        for (i = 0; i < v->n_choices && used + 4 < sizeof accepted; i++) {
            int w = snprintf(accepted + used, sizeof accepted - used, "%s'%s'", i ? ", " : "", v->choices[i]);
            if (w < 0) break;
            used += (size_t)w;
        }
        return grb_fail(inst, "%s: %s cannot be '%.100s'; it accepts %s", call, v->name, value[k], accepted);
    }
    for (k = 0; k < nvr; k++) {
        const grb_variable *v = &model_variables[vr[k] - 1];
        grb_store(inst, v, (double)choice_index(v, value[k]));
    }
    return GRB_FMI_OK;
}

/* ---- stepping ------------------------------------------------------------------ */

grb_fmi_status grb_do_step(grb_instance *inst, const char *call, double t, double h) {
    double now;
    /* a state restored while stepping: the model follows its parameters (a
     * state saved before initialisation starts here) */
    if (inst->dirty && start(inst) > GRB_FMI_WARNING) return GRB_FMI_ERROR;
    /* a step the model cannot take from here is refused, not fatal: the master
     * may retry with another step, or restore a saved state to roll back */
    if (!(h > 0.0) || !isfinite(h)) {
        grb_log(inst, GRB_FMI_DISCARD, "%s: the step size must be positive and finite, got %g", call, h);
        return GRB_FMI_DISCARD;
    }
    now = model_time(inst);
    if (!isfinite(t) || fabs(t - now) > 1e-9 * (1.0 + fabs(now))) {
        grb_log(inst, GRB_FMI_DISCARD, "%s at t = %.17g s, but the model is at t = %.17g s (restore a saved FMU "
                "state to roll back)", call, t, now);
        return GRB_FMI_DISCARD;
    }
    return grb_raise(inst, model_do_step(inst, t, h));
}

/* A co-simulation FMU's partial derivatives are those of its outputs with
 * respect to its inputs at the present state (FMI 2.0, section 4.2.3; FMI 3.0,
 * section 4.2.4): every unknown must be a Real output and every known a Real input. */
grb_fmi_status grb_directional_derivative(grb_instance *inst, const char *call, const grb_value_reference unknown[],
                                          size_t n_unknown, const grb_value_reference known[], size_t n_known,
                                          const double seed[], double sensitivity[]) {
#if MODEL_DIRECTIONAL_DERIVATIVE
    size_t k;
    if (!grb_check_array(inst, call, unknown, n_unknown, sensitivity) ||
        !grb_check_array(inst, call, known, n_known, seed))
        return GRB_FMI_ERROR;
    for (k = 0; k < n_unknown; k++) {
        const grb_variable *v = grb_lookup(inst, call, unknown[k], GRB_T_REAL);
        if (v == NULL) return GRB_FMI_ERROR;
        if (v->causality != GRB_C_OUTPUT)
            return grb_fail(inst, "%s: %s is not an output; a co-simulation FMU's unknowns are its outputs", call,
                            v->name);
    }
    for (k = 0; k < n_known; k++) {
        const grb_variable *v = grb_lookup(inst, call, known[k], GRB_T_REAL);
        if (v == NULL) return GRB_FMI_ERROR;
        if (v->causality != GRB_C_INPUT)
            return grb_fail(inst, "%s: %s is not an input; a co-simulation FMU's knowns are its inputs", call, v->name);
        if (!isfinite(seed[k]))
            return grb_fail(inst, "%s: the seed of %s is %g; it must be finite", call, v->name, seed[k]);
    }
    if (ready(inst, 0) > GRB_FMI_WARNING) return GRB_FMI_ERROR;
    return grb_raise(inst, model_directional_derivative(inst, unknown, n_unknown, known, n_known, seed, sensitivity));
#else
    (void)unknown; (void)n_unknown; (void)known; (void)n_known; (void)seed; (void)sensitivity;
    return grb_fail(inst, "%s: not supported (the model provides no directional derivatives)", call);
#endif
}

/* ---- FMU state ---------------------------------------------------------------- */

/* Is this state one this model made (its tag, its model's GUID, its size)? */
static int ours(const grb_saved *saved) {
    return saved != NULL && memcmp(saved->tag, STATE_MAGIC, 8) == 0 && saved->guid == guid_hash() &&
           saved->n == model_persistent_size();
}

static grb_saved *new_saved(grb_instance *inst) {
    size_t n = model_persistent_size();
    grb_saved *saved = (grb_saved *)inst->allocate(1, sizeof(grb_saved) + (n - 1) * sizeof(double));
    if (saved == NULL) return NULL;
    memcpy(saved->tag, STATE_MAGIC, 8);
    saved->guid = guid_hash();
    saved->n = n;
    return saved;
}

grb_fmi_status grb_get_state(grb_instance *inst, const char *call, void **state) {
    size_t n = model_persistent_size();
    grb_saved *saved;
    if (state == NULL) return grb_fail(inst, "%s: NULL FMU state pointer", call);
    saved = (grb_saved *)*state;
    if (saved != NULL && !ours(saved))
        return grb_fail(inst, "%s: the FMU state given is not a state of this model (pass NULL for a new one)", call);
    if (saved == NULL && (saved = new_saved(inst)) == NULL) return grb_fail(inst, "%s: out of memory", call);
    memcpy(saved->block, inst->p, n * sizeof(double));
    saved->mode = inst->state;
    *state = saved;
    return GRB_FMI_OK;
}

grb_fmi_status grb_set_state(grb_instance *inst, const char *call, const void *state) {
    const grb_saved *saved = (const grb_saved *)state;
    if (!ours(saved))
        return grb_fail(inst, "%s: not a state of this model (another FMU's, or not a state at all)", call);
    if (saved->mode == GRB_ERROR)
        return grb_fail(inst, "%s: the state was saved in the error state, after a call failed; restore one saved "
                        "before the failure", call);
    if (!block_ok(inst, call, saved->block)) return GRB_FMI_ERROR;
    memcpy(inst->p, saved->block, model_persistent_size() * sizeof(double));
    if (inst->state == GRB_ERROR) {
        /* out of the error state into the mode the state was saved in; a state that does not record
         * it (0) resumes as one restored before initialisation does: stepping, unless the importer
         * initialises */
        inst->state = saved->mode != 0 ? saved->mode : GRB_INSTANTIATED;
        inst->resume = saved->mode != 0 ? 0 : GRB_STEP_COMPLETE;
    } else {
        inst->resume = inst->state == GRB_INSTANTIATED && saved->mode == GRB_STEP_COMPLETE ? GRB_STEP_COMPLETE : 0;
    }
    inst->dirty = 1;
    inst->level = 0;
    return GRB_FMI_OK;
}

grb_fmi_status grb_free_state(grb_instance *inst, const char *call, void **state) {
    if (state == NULL) return grb_fail(inst, "%s: NULL FMU state pointer", call);
    /* An importer that passes the state instead of its address (fmusim 0.0.39
     * saving a final state does) hands us a state whose tag reads, as a
     * pointer, as no address a 64-bit process can have: free that state
     * rather than crash on the tag, and say so (the call did what it was for,
     * so its status is OK). */
    if (sizeof(void *) == 8 && memcmp(state, STATE_MAGIC, 8) == 0 && ours((const grb_saved *)state)) {
        grb_log(inst, GRB_FMI_WARNING, "%s: given the FMU state itself, not the address of the importer's pointer "
                "to it; freed, but the importer's pointer still points to the freed state", call);
        inst->release(state);
        return GRB_FMI_OK;
    }
    if (*state != NULL) inst->release(*state);
    *state = NULL;
    return GRB_FMI_OK;
}

grb_fmi_status grb_serialized_size(grb_instance *inst, const char *call, const void *state, size_t *size) {
    const grb_saved *saved = (const grb_saved *)state;
    if (size == NULL) return grb_fail(inst, "%s: NULL size", call);
    if (!ours(saved)) return grb_fail(inst, "%s: not a state of this model", call);
    *size = STATE_HEADER + 8 * saved->n;
    return GRB_FMI_OK;
}

grb_fmi_status grb_serialize(grb_instance *inst, const char *call, const void *state, unsigned char *b,
                             size_t size) {
    const grb_saved *saved = (const grb_saved *)state;
    size_t n;
    if (!ours(saved)) return grb_fail(inst, "%s: not a state of this model", call);
    n = saved->n;
    if (b == NULL || size < STATE_HEADER + 8 * n)
        return grb_fail(inst, "%s: the buffer holds %u bytes, the state needs %u", call, (unsigned)size,
                        (unsigned)(STATE_HEADER + 8 * n));
    memcpy(b, STATE_MAGIC, 8);
    put_u32(b + 8, STATE_VERSION);
    put_u32(b + 12, (uint32_t)MODEL_N_STORED);
    put_u32(b + 16, (uint32_t)n);
    put_u32(b + 20, (uint32_t)saved->mode);
    put_u64(b + 24, guid_hash());
    put_doubles(b + STATE_HEADER, saved->block, n);
    put_u64(b + 32, fnv1a(FNV_OFFSET, b + STATE_HEADER, 8 * (size_t)MODEL_N_STORED));
    put_u64(b + 40, fnv1a(FNV_OFFSET, b + STATE_HEADER, 8 * n));
    return GRB_FMI_OK;
}

grb_fmi_status grb_deserialize(grb_instance *inst, const char *call, const unsigned char *b, size_t size,
                               void **state) {
    size_t n = model_persistent_size(), k;
    grb_saved *saved, *fresh;
    if (state == NULL) return grb_fail(inst, "%s: NULL FMU state pointer", call);
    if (b == NULL || size < STATE_HEADER)
        return grb_fail(inst, "%s: %u bytes are no serialised state (truncated?)", call, (unsigned)size);
    if (memcmp(b, STATE_MAGIC, 8) != 0) return grb_fail(inst, "%s: not a serialised grubler FMU state (bad magic)", call);
    if (get_u32(b + 8) != STATE_VERSION)
        return grb_fail(inst, "%s: state layout version %u, this FMU reads version %u", call, (unsigned)get_u32(b + 8),
                        STATE_VERSION);
    if (get_u64(b + 24) != guid_hash() || get_u32(b + 12) != (uint32_t)MODEL_N_STORED || get_u32(b + 16) != n)
        return grb_fail(inst, "%s: the state belongs to another model (its GUID or sizes differ from %s's)", call,
                        MODEL_NAME);
    if (size != STATE_HEADER + 8 * n)
        return grb_fail(inst, "%s: %u bytes, a state of this model has %u (truncated or padded)", call, (unsigned)size,
                        (unsigned)(STATE_HEADER + 8 * n));
    if (get_u64(b + 32) != fnv1a(FNV_OFFSET, b + STATE_HEADER, 8 * (size_t)MODEL_N_STORED))
        return grb_fail(inst, "%s: the parameters' checksum does not match (corrupted state)", call);
    if (get_u64(b + 40) != fnv1a(FNV_OFFSET, b + STATE_HEADER, 8 * n))
        return grb_fail(inst, "%s: the state's checksum does not match (corrupted state)", call);
    switch (get_u32(b + 20)) {
    case 0: case GRB_INSTANTIATED: case GRB_INITIALIZATION: case GRB_STEP_COMPLETE: case GRB_TERMINATED:
    case GRB_ERROR: break;  /* (a state saved in the error state serialises; fmi2SetFMUstate refuses it) */
    default: return grb_fail(inst, "%s: the state machine's state %u is none of this FMU's (corrupted state)", call,
                             (unsigned)get_u32(b + 20));
    }
    saved = (grb_saved *)*state;
    if (saved != NULL && !ours(saved))
        return grb_fail(inst, "%s: the FMU state given is not a state of this model (pass NULL for a new one)", call);
    /* decoded aside and checked: a refused blob leaves *state as it was */
    if ((fresh = new_saved(inst)) == NULL) return grb_fail(inst, "%s: out of memory", call);
    for (k = 0; k < n; k++) {
        uint64_t u = get_u64(b + STATE_HEADER + 8 * k);
        memcpy(&fresh->block[k], &u, 8);
    }
    fresh->mode = (int)get_u32(b + 20);
    if (!block_ok(inst, call, fresh->block)) {
        inst->release(fresh);
        return GRB_FMI_ERROR;
    }
    if (saved == NULL) {
        *state = fresh;
    } else {
        memcpy(saved->block, fresh->block, n * sizeof(double));
        saved->mode = fresh->mode;
        inst->release(fresh);
    }
    return GRB_FMI_OK;
}
