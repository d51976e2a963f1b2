/* The generic model of a sampled control law on the FMI wrapper (fmi2_model.h),
 * the law itself behind law.h.
 *
 * It runs the sample-and-hold clock of controllers/law.py (ctl_samples_due,
 * the same C the Python Sampler calls): a communication step from t to t + h
 * runs every sample instant in [t, t + h) on the inputs held over the step,
 * and the outputs are those of the last sample; a continuous law is evaluated
 * at t + h.  The outputs are held in the persistent block, so a restored FMU
 * state brings them back with the law's state.
 *
 * The model's part of the persistent block (indices P_* from config.h, from
 * the ModelSpec's state layout, grubler.controllers.native_fmu):
 *   P_STARTED  1: the block holds a started run
 *   P_T0       start time: the sample grid's origin
 *   P_T        time of the state
 *   P_SAMPLES  samples run so far
 *   P_OUT      the held outputs (MODEL_N_OUTPUTS)
 *   P_LAW      the law's state (LAW_N_STATE)
 *   P_END      its size
 * Parameters take slots 0 .. LAW_N_PARAMS - 1, the inputs the next LAW_N_INPUTS.
 */
#include <math.h>
#include <stdio.h>

#include "fmi2_model.h"
#include "law.h"

#ifndef LAW_N_CHECK
#define LAW_N_CHECK 0
#endif

typedef struct law_scratch {
    double derived[LAW_N_SCRATCH > 0 ? LAW_N_SCRATCH : 1];
    double check[LAW_N_CHECK > 0 ? LAW_N_CHECK : 1];  /* law_check's working memory */
} law_scratch;

size_t model_persistent_size(void) { return (size_t)P_END; }
size_t model_scratch_bytes(void) { return sizeof(law_scratch); }
int model_input_free_level(void) { return 1; }  /* held outputs: none depends on an input at the same instant */
const double *model_outputs(const grb_instance *inst) { return inst->p + P_OUT; }
double model_time(const grb_instance *inst) { return inst->p[P_T]; }

void model_reset(grb_instance *inst) {
    inst->p[P_STARTED] = 0.0;
    inst->p[P_T] = 0.0;
    inst->p[P_SAMPLES] = 0.0;
}

#define BAD(...) do { grb_log(inst, fmi2Error, __VA_ARGS__); return fmi2Error; } while (0)

/* The name of the variable in a stored slot (a parameter or an input). */
static const char *slot_name(int slot) {
    int k;
    for (k = 0; k < MODEL_N_VARIABLES; k++)
        if (model_variables[k].causality != GRB_C_OUTPUT && model_variables[k].slot == slot)
            return model_variables[k].name;
    return "parameter";
}

/* The law's parameter check (it names the parameter), then a started run's
 * state: its time, sample count and held outputs, and the law's own check. */
fmi2Status model_check(grb_instance *inst, const double *p) {
    law_scratch *ls = (law_scratch *)inst->model;
    int field = -1, st, k;
    const char *why = "";
    st = law_check(p, ls->check, &field, &why);
    if (st != CTL_OK && field == LAW_FIELD_IN_WHY) BAD("%s", why);
    if (st != CTL_OK)
        BAD("%s: %s (got %.17g)", field >= 0 && field < LAW_N_PARAMS ? slot_name(field) : "parameter",
            why ? why : ctl_status_message(st), field >= 0 && field < LAW_N_PARAMS ? p[field] : NAN);
    if (p[P_STARTED] != 0.0 && p[P_STARTED] != 1.0) BAD("state.started: must be 0 or 1, got %g", p[P_STARTED]);
    if (p[P_STARTED] == 0.0) return fmi2OK;
    if (!isfinite(p[P_T])) BAD("state.t: the time must be finite, got %g", p[P_T]);
    if (!isfinite(p[P_T0]) || p[P_T0] > p[P_T]) BAD("state.t0: the start time must be finite and not after t, got %g",
                                                   p[P_T0]);
    if (!(p[P_SAMPLES] >= 0.0 && p[P_SAMPLES] <= 9007199254740992.0 && p[P_SAMPLES] == floor(p[P_SAMPLES])))
        BAD("state.samples: must be a whole number >= 0, got %g", p[P_SAMPLES]);
    for (k = 0; k < MODEL_N_OUTPUTS; k++)
        if (!isfinite(p[P_OUT + k])) BAD("state.outputs: the held outputs must be finite, got %g", p[P_OUT + k]);
    st = law_check_state(p, p + P_LAW, &field, &why);
    if (st != CTL_OK) {
        const char *name = law_state_name(field);
        BAD("state.%s: %s", name ? name : "law", why ? why : ctl_status_message(st));
    }
    return fmi2OK;
}

fmi2Status model_prepare(grb_instance *inst) {
    law_scratch *ls = (law_scratch *)inst->model;
    double *p = inst->p;
    int st;
    fmi2Status status = model_check(inst, p);
    if (status != fmi2OK) return status;
#if LAW_N_SCRATCH > 0
    st = law_prepare(p, ls->derived);
    if (st != CTL_OK) BAD("the law's parameters: %s", ctl_status_message(st));
#endif
    if (p[P_STARTED] != 0.0) return fmi2OK;  /* a restored run keeps its state */
    p[P_T0] = p[P_T] = inst->start_time;
    p[P_SAMPLES] = 0.0;
    st = law_start(p, ls->derived, inst->start_time, p + P_LAW, p + P_OUT);
    if (st != CTL_OK) BAD("the law's start at t = %g s: %s", inst->start_time, ctl_status_message(st));
    return fmi2OK;
}

fmi2Status model_start(grb_instance *inst) {
    inst->p[P_STARTED] = 1.0;
    return fmi2OK;
}

fmi2Status model_compute(grb_instance *inst, int level) {
    (void)inst;
    (void)level;
    return fmi2OK;  /* the outputs are held in the block */
}

fmi2Status model_do_step(grb_instance *inst, double t, double h) {
    law_scratch *ls = (law_scratch *)inst->model;
    double *p = inst->p, due = 0.0, when, i;
    const double *in = p + LAW_N_PARAMS;
    ctl_clock clock;
    int st, k;
    for (k = 0; k < LAW_N_INPUTS; k++) {
        if (!isfinite(in[k])) {
            grb_log(inst, fmi2Discard, "%s is %g at t = %.12g s: inputs must be finite", slot_name(LAW_N_PARAMS + k),
                    in[k], t);
            return fmi2Discard;
        }
    }
    clock.t0 = p[P_T0];
#if LAW_CONTINUOUS
    clock.Ts = 0.0;
    clock.continuous = 1;
#else
    clock.Ts = p[LAW_TS_SLOT];
    clock.continuous = 0;
#endif
    st = ctl_samples_due(&clock, p[P_SAMPLES], t, h, &due);
    if (st == CTL_TOO_MANY_SAMPLES) {
        grb_log(inst, fmi2Discard, "a step of %g s holds %.3g samples of Ts = %g s; at most %d per communication step",
                h, due, clock.Ts, CTL_MAX_SAMPLES_PER_STEP);
        return fmi2Discard;
    }
    if (st != CTL_OK) {
        grb_log(inst, fmi2Discard, "step from t = %g s: %s", t, ctl_status_message(st));
        return fmi2Discard;
    }
    for (i = 0.0; i < due; i += 1.0) {
        ctl_sample_instant(&clock, p[P_SAMPLES], t, h, 0.0, &when);
        st = law_sample(p, ls->derived, p + P_LAW, when, in, p + P_OUT);
        if (st != CTL_OK) {  /* the step's earlier samples ran: no rollback to its start, the run ends */
            grb_log(inst, fmi2Error, "sample at t = %.12g s: %s", when, ctl_status_message(st));
            return fmi2Error;
        }
        p[P_SAMPLES] += 1.0;
    }
    p[P_T] = t + h;
    inst->level = 1;
    return fmi2OK;
}
