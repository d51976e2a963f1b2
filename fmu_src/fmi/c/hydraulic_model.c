/* The hydraulic cylinder FMU's model: FMI variables <-> motors/kernel/hydraulic_cylinder.c.
 *
 * No physics here: the parameters become a hyd_params (its own check names the
 * field it refuses), a communication step is one hyd_step with the inputs held
 * (the actuator's length moving at the held rate), and the outputs are the
 * step's, or hyd_observe's after an input changed.  The cylinder's whole memory
 * is its spool, its three pressures and the step size control's last sub-step,
 * kept in the persistent block.
 */
#include <math.h>
#include <stdio.h>

#include "fmi2_model.h"
#include "hydraulic_cylinder.h"

enum {
    P_STARTED = GRB_MODEL_BASE, /* 1: the block holds a started run */
    P_T,                        /* time of the state */
    P_SPOOL, P_SPOOL_RATE, P_PRESSURE_A, P_PRESSURE_B, P_SUPPLY_PRESSURE, P_SUBSTEP, /* hyd_state */
    P_END
};

typedef struct cylinder {
    hyd_params params;
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

static hyd_state state_of(const double *p) {
    hyd_state s = {p[P_SPOOL], p[P_SPOOL_RATE], p[P_PRESSURE_A], p[P_PRESSURE_B], p[P_SUPPLY_PRESSURE], p[P_SUBSTEP]};
    return s;
}

static void keep_state(double *p, const hyd_state *s) {
    p[P_SPOOL] = s->spool;
    p[P_SPOOL_RATE] = s->spool_rate;
    p[P_PRESSURE_A] = s->pressure_a;
    p[P_PRESSURE_B] = s->pressure_b;
    p[P_SUPPLY_PRESSURE] = s->supply_pressure;
    p[P_SUBSTEP] = s->substep;
}

static hyd_inputs inputs_of(const double *p) {
    hyd_inputs in = {p[SLOT_COMMAND], p[SLOT_LENGTH], p[SLOT_RATE]};
    return in;
}

fmi2Status model_prepare(grb_instance *inst) {
    cylinder *cc = (cylinder *)inst->model;
    double *p = inst->p, *d = (double *)&cc->params;
    hyd_state s;
    int field = -1, st;
    const char *why = "";
    /* hyd_params is HYD_N_PARAMS doubles in enum hyd_field's order, and so are
     * the parameters' slots from SLOT_BORE on (grubler.fmi.hydraulic) */
    for (int k = 0; k < HYD_N_PARAMS; k++) d[k] = p[SLOT_BORE + k];
    st = hyd_check_params(&cc->params, &field, &why);
    if (st != HYD_OK) {
        const char *name = hyd_field_name(field);
        BAD("%s: %s (got %g)", name ? name : "parameter", why ? why : hyd_status_message(st),
            field >= 0 && field < HYD_N_PARAMS ? d[field] : NAN);
    }
    if (p[P_STARTED] != 0.0) return fmi2OK;  /* a restored run keeps its state */
    s.spool = 0.0;
    s.spool_rate = 0.0;
    s.pressure_a = p[SLOT_INITIAL_PRESSURE_A];
    s.pressure_b = p[SLOT_INITIAL_PRESSURE_B];
    /* unless the importer set it, the supply starts at the relief valve's pressure */
    s.supply_pressure = GRB_WAS_SET(inst, SLOT_INITIAL_SUPPLY_PRESSURE) ? p[SLOT_INITIAL_SUPPLY_PRESSURE]
                                                                       : cc->params.relief_pressure;
    s.substep = 0.0;
    st = hyd_check_state(&cc->params, &s, &field, &why);
    if (st != HYD_OK) {
        const char *name = hyd_field_name(field);
        BAD("initial_%s: %s", name ? name : "state", why ? why : hyd_status_message(st));
    }
    p[P_T] = inst->start_time;
    keep_state(p, &s);
    return fmi2OK;
}

fmi2Status model_start(grb_instance *inst) {
    inst->p[P_STARTED] = 1.0;
    return fmi2OK;
}

static void record(cylinder *cc, const hyd_outputs *o) {
    /* hyd_outputs is MODEL_N_OUTPUTS doubles in the outputs' order */
    const double *v = (const double *)o;
    for (int k = 0; k < MODEL_N_OUTPUTS; k++) cc->out[k] = v[k];
}

fmi2Status model_compute(grb_instance *inst, int level) {
    cylinder *cc = (cylinder *)inst->model;
    const double *p = inst->p;
    hyd_state s = state_of(p);
    hyd_inputs in = inputs_of(p);
    hyd_outputs o;
    int st;
    (void)level;
    st = hyd_observe(&cc->params, &s, &in, &o);
    if (st != HYD_OK) {
        for (int k = 0; k < MODEL_N_OUTPUTS; k++) cc->out[k] = NAN;
        grb_log(inst, fmi2Warning, "outputs at t = %.12g s: %s; they read as NaN", p[P_T], hyd_status_message(st));
        return fmi2Warning;
    }
    record(cc, &o);
    return fmi2OK;
}

fmi2Status model_do_step(grb_instance *inst, double t, double h) {
    cylinder *cc = (cylinder *)inst->model;
    double *p = inst->p;
    hyd_state s = state_of(p);
    hyd_inputs in = inputs_of(p);
    hyd_outputs o;
    if (!isfinite(in.command) || !isfinite(in.length) || !isfinite(in.rate)) {
        const char *name = !isfinite(in.command) ? "command" : (!isfinite(in.length) ? "length" : "rate");
        double v = !isfinite(in.command) ? in.command : (!isfinite(in.length) ? in.length : in.rate);
        grb_log(inst, fmi2Discard, "%s is %g at t = %.12g s: inputs must be finite", name, v, t);
        return fmi2Discard;
    }
    int st = hyd_step(&cc->params, &s, &in, h, &o);
    if (st != HYD_OK) {
        grb_log(inst, fmi2Discard, "step from t = %g s failed: %s", t, hyd_status_message(st));
        return fmi2Discard;
    }
    p[P_T] = t + h;
    /* the master holds the rate over the step: the length it will set next is
     * where the cylinder's own extrapolation ended */
    keep_state(p, &s);
    record(cc, &o);
    inst->level = 1;  /* the step's own outputs, for the inputs it held */
    return fmi2OK;
}
