/* The cylinder FMUs' model: FMI variables <-> motors/kernel/hydraulic_cylinder.c
 * or pneumatic_cylinder.c, as config.h says (CYLINDER_HYDRAULIC or
 * CYLINDER_PNEUMATIC); the two models share their API's shape.
 *
 * No physics here: the parameters become the model's parameter struct (its own
 * check names the field it refuses), a communication step is one model step
 * with the inputs held (the actuator's length moving at the held rate), and the
 * outputs are the step's, or the model's observation after an input changed.
 * The cylinder's whole memory is its state struct (spool, its rate, the
 * pressures, the step size control's last sub-step), kept in the persistent
 * block.
 */
#include <math.h>
#include <stdio.h>

#include "fmi2_model.h"

#if defined(CYLINDER_HYDRAULIC)
#include "hydraulic_cylinder.h"
typedef hyd_params cyl_params;
typedef hyd_state cyl_state;
typedef hyd_inputs cyl_inputs;
typedef hyd_outputs cyl_outputs;
#define CYL_N_PARAMS HYD_N_PARAMS
#define CYL_OK HYD_OK
#define cyl_check_params hyd_check_params
#define cyl_check_state hyd_check_state
#define cyl_step hyd_step
#define cyl_observe hyd_observe
#define cyl_field_name hyd_field_name
#define cyl_status_message hyd_status_message
#elif defined(CYLINDER_PNEUMATIC)
#include "pneumatic_cylinder.h"
typedef pnc_params cyl_params;
typedef pnc_state cyl_state;
typedef pnc_inputs cyl_inputs;
typedef pnc_outputs cyl_outputs;
#define CYL_N_PARAMS PNC_N_PARAMS
#define CYL_OK PNC_OK
#define cyl_check_params pnc_check_params
#define cyl_check_state pnc_check_state
#define cyl_step pnc_step
#define cyl_observe pnc_observe
#define cyl_field_name pnc_field_name
#define cyl_status_message pnc_status_message
#else
#error "config.h names no cylinder model"
#endif

/* the state struct is doubles: spool, spool_rate, the pressures, substep */
#define N_STATE ((int)(sizeof(cyl_state) / sizeof(double)))
#define N_PRESSURES (N_STATE - 3)

/* The model's part of the block (config.h, from the ModelSpec's state):
 *   P_STARTED   1: the block holds a started run
 *   P_T         time of the state
 *   P_STATE     N_STATE doubles: the model's state struct
 *   P_END       its size */

typedef struct cylinder {
    cyl_params params;
    double out[MODEL_N_OUTPUTS];
} cylinder;

size_t model_persistent_size(void) { return (size_t)P_END; }
size_t model_scratch_bytes(void) { return sizeof(cylinder); }
int model_input_free_level(void) { return 0; }
const double *model_outputs(const grb_instance *inst) { return ((const cylinder *)inst->model)->out; }
double model_time(const grb_instance *inst) { return inst->p[P_T]; }

void model_reset(grb_instance *inst) {
    inst->p[P_STARTED] = 0.0;
    inst->p[P_T] = 0.0;
}

#define BAD(...) do { grb_log(inst, fmi2Error, __VA_ARGS__); return fmi2Error; } while (0)

static cyl_state state_of(const double *p) {
    cyl_state s;
    double *v = (double *)&s;
    for (int k = 0; k < N_STATE; k++) v[k] = p[P_STATE + k];
    return s;
}

static void keep_state(double *p, const cyl_state *s) {
    const double *v = (const double *)s;
    for (int k = 0; k < N_STATE; k++) p[P_STATE + k] = v[k];
}

static cyl_inputs inputs_of(const double *p) {
    cyl_inputs in = {p[SLOT_COMMAND], p[SLOT_LENGTH], p[SLOT_RATE]};
    return in;
}

/* The start state a block that holds no started run begins from: at rest, the
 * spool centred, the pressures as set (initial_pressure_a, ...). */
static cyl_state initial_state(const grb_instance *inst, const double *p) {
    cyl_state s;
    double *sv = (double *)&s;
    for (int k = 0; k < N_STATE; k++) sv[k] = 0.0;
    for (int k = 0; k < N_PRESSURES; k++) sv[2 + k] = p[SLOT_INITIAL_PRESSURE_A + k];
#ifdef SLOT_UNSET_INITIAL_FROM
    /* a start pressure the importer did not set follows the parameter it defaults to */
    if (p[MODEL_N_STORED + SLOT_UNSET_INITIAL] == 0.0)
        sv[2 + SLOT_UNSET_INITIAL - SLOT_INITIAL_PRESSURE_A] = p[SLOT_UNSET_INITIAL_FROM];
#endif
    (void)inst;
    return s;
}

/* The constants and, for a started run, its state: what set values and a
 * restored FMU state must both pass before anything uses them. */
fmi2Status model_check(grb_instance *inst, const double *p) {
    cyl_params params;
    double *d = (double *)&params;
    int field = -1, st, started = p[P_STARTED] != 0.0;
    const char *why = "", *prefix = started ? "state." : "initial_";
    /* the parameter struct is CYL_N_PARAMS doubles in its field order, and so
     * are the parameters' slots from SLOT_BORE on (grubler.fmi.cylinder) */
    for (int k = 0; k < CYL_N_PARAMS; k++) d[k] = p[SLOT_BORE + k];
    st = cyl_check_params(&params, &field, &why);
    if (st != CYL_OK) {
        const char *name = cyl_field_name(field);
        BAD("%s: %s (got %g)", name ? name : "parameter", why ? why : cyl_status_message(st),
            field >= 0 && field < CYL_N_PARAMS ? d[field] : NAN);
    }
    if (p[P_STARTED] != 0.0 && p[P_STARTED] != 1.0) BAD("state.started: must be 0 or 1, got %g", p[P_STARTED]);
    if (started && !isfinite(p[P_T])) BAD("state.t: the time must be finite, got %g", p[P_T]);
    cyl_state s = started ? state_of(p) : initial_state(inst, p);
    st = cyl_check_state(&params, &s, &field, &why);
    if (st != CYL_OK) {
        const char *name = cyl_field_name(field);
        BAD("%s%s: %s", prefix, name ? name : "state", why ? why : cyl_status_message(st));
    }
    return fmi2OK;
}

fmi2Status model_prepare(grb_instance *inst) {
    cylinder *cc = (cylinder *)inst->model;
    double *p = inst->p, *d = (double *)&cc->params;
    fmi2Status status = model_check(inst, p);
    if (status != fmi2OK) return status;
    for (int k = 0; k < CYL_N_PARAMS; k++) d[k] = p[SLOT_BORE + k];
    if (p[P_STARTED] != 0.0) return fmi2OK;  /* a restored run keeps its state */
    cyl_state s = initial_state(inst, p);
    p[P_T] = inst->start_time;
    keep_state(p, &s);
    return fmi2OK;
}

fmi2Status model_start(grb_instance *inst) {
    inst->p[P_STARTED] = 1.0;
    return fmi2OK;
}

static void record(cylinder *cc, const cyl_outputs *o) {
    /* the outputs struct is MODEL_N_OUTPUTS doubles in the outputs' order */
    const double *v = (const double *)o;
    for (int k = 0; k < MODEL_N_OUTPUTS; k++) cc->out[k] = v[k];
}

fmi2Status model_compute(grb_instance *inst, int level) {
    cylinder *cc = (cylinder *)inst->model;
    const double *p = inst->p;
    cyl_state s = state_of(p);
    cyl_inputs in = inputs_of(p);
    cyl_outputs o;
    (void)level;
    int st = cyl_observe(&cc->params, &s, &in, &o);
    if (st != CYL_OK) {
        for (int k = 0; k < MODEL_N_OUTPUTS; k++) cc->out[k] = NAN;
        grb_log(inst, fmi2Warning, "outputs at t = %.12g s: %s; they read as NaN", p[P_T], cyl_status_message(st));
        return fmi2Warning;
    }
    record(cc, &o);
    return fmi2OK;
}

fmi2Status model_do_step(grb_instance *inst, double t, double h) {
    cylinder *cc = (cylinder *)inst->model;
    double *p = inst->p;
    cyl_state s = state_of(p);
    cyl_inputs in = inputs_of(p);
    cyl_outputs o;
    if (!isfinite(in.command) || !isfinite(in.length) || !isfinite(in.rate)) {
        const char *name = !isfinite(in.command) ? "command" : (!isfinite(in.length) ? "length" : "rate");
        double v = !isfinite(in.command) ? in.command : (!isfinite(in.length) ? in.length : in.rate);
        grb_log(inst, fmi2Discard, "%s is %g at t = %.12g s: inputs must be finite", name, v, t);
        return fmi2Discard;
    }
    int st = cyl_step(&cc->params, &s, &in, h, &o);
    if (st != CYL_OK) {
        grb_log(inst, fmi2Discard, "step from t = %g s failed: %s", t, cyl_status_message(st));
        return fmi2Discard;
    }
    p[P_T] = t + h;
    keep_state(p, &s);
    record(cc, &o);
    inst->level = 1;  /* the step's own outputs, for the inputs it held */
    return fmi2OK;
}
