/* The DC motor FMU's model: FMI variables <-> motors/kernel/dc_motor.c.
 *
 * No physics here: the parameters become a dcm_params (its own check names the
 * field it refuses), a communication step is one dcm_step with the inputs held
 * (the current is exact for any step), and the outputs are the step's, or
 * dcm_observe's after an input changed.  The motor's whole memory is its
 * winding current and temperature, kept in the persistent block.
 */
#include <math.h>
#include <stdio.h>

#include "dc_motor.h"
#include "fmi2_model.h"

/* The model's part of the persistent block: its fields' indices P_* come with
 * config.h, from the ModelSpec's state layout (grubler.fmi.motor.RUN_STATE):
 *   P_STARTED         1: the block holds a started run
 *   P_T               time of the state
 *   P_CURRENT, P_TEMPERATURE   the dcm_state
 *   P_WARNED_CHATTER  the chatter warning was given in this run
 *   P_WARNED_HOT      the winding-temperature warning was given
 *   P_END             its size */

typedef struct motor {
    dcm_params params;
    double reflected_inertia;
    double out[MODEL_N_OUTPUTS];
} motor;

size_t model_persistent_size(void) { return (size_t)P_END; }
size_t model_scratch_bytes(void) { return sizeof(motor); }
int model_input_free_level(void) { return 0; }
const double *model_outputs(const grb_instance *inst) { return ((const motor *)inst->model)->out; }
double model_time(const grb_instance *inst) { return inst->p[P_T]; }

void model_reset(grb_instance *inst) {
    inst->p[P_STARTED] = 0.0;
    inst->p[P_T] = 0.0;
}

/* unless the importer set it, the winding starts at ambient temperature */
static double initial_temperature(const double *p) {
    return p[MODEL_N_STORED + SLOT_INITIAL_TEMPERATURE] != 0.0 ? p[SLOT_INITIAL_TEMPERATURE]
                                                                : p[SLOT_AMBIENT_TEMPERATURE];
}

#define BAD(...) do { grb_log(inst, fmi2Error, __VA_ARGS__); return fmi2Error; } while (0)

/* The block's parameters as the C model's, the FMU's "0: no limit" its INFINITY. */
static void params_of(const double *p, dcm_params *d) {
    double limit = p[SLOT_CURRENT_LIMIT];
    d->resistance = p[SLOT_RESISTANCE];
    d->inductance = p[SLOT_INDUCTANCE];
    d->torque_constant = p[SLOT_TORQUE_CONSTANT];
    d->back_emf_constant = p[SLOT_BACK_EMF_CONSTANT];
    d->rotor_inertia = p[SLOT_ROTOR_INERTIA];
    d->viscous_friction = p[SLOT_VISCOUS_FRICTION];
    d->coulomb_friction = p[SLOT_COULOMB_FRICTION];
    d->smoothing_speed = p[SLOT_SMOOTHING_SPEED];
    d->thermal_resistance = p[SLOT_THERMAL_RESISTANCE];
    d->thermal_time_constant = p[SLOT_THERMAL_TIME_CONSTANT];
    d->temperature_coefficient = p[SLOT_TEMPERATURE_COEFFICIENT];
    d->reference_temperature = p[SLOT_REFERENCE_TEMPERATURE];
    d->gear_ratio = p[SLOT_GEAR_RATIO];
    d->gear_efficiency = p[SLOT_GEAR_EFFICIENCY];
    d->supply_voltage = p[SLOT_SUPPLY_VOLTAGE];
    d->current_limit = limit > 0.0 ? limit : INFINITY;
    d->ambient_temperature = p[SLOT_AMBIENT_TEMPERATURE];
    d->max_substep = p[SLOT_MAX_SUBSTEP];
}

/* The parameters by dcm_check_params (it names the field), then the state: the
 * initial one (dcm_check_state) or a started run's (the same check, and its
 * time and flags). */
fmi2Status model_check(grb_instance *inst, const double *p) {
    dcm_params params, *d = &params;
    dcm_state s;
    int field = -1, st, started = p[P_STARTED] != 0.0;
    const char *why = "", *prefix = started ? "state." : "initial_";
    if (!(p[SLOT_CURRENT_LIMIT] >= 0.0) || !isfinite(p[SLOT_CURRENT_LIMIT]))
        BAD("current_limit: must be >= 0 and finite (0: none), got %g", p[SLOT_CURRENT_LIMIT]);
    params_of(p, d);
    st = dcm_check_params(d, &field, &why);
    if (st != DCM_OK) {
        const char *name = dcm_field_name(field);
        /* dcm_params is DCM_N_PARAMS doubles in enum dcm_field's order (dc_motor.h) */
        BAD("%s: %s (got %g)", name ? name : "parameter", why ? why : dcm_status_message(st),
            field >= 0 && field < DCM_N_PARAMS ? ((const double *)d)[field] : NAN);
    }
    if (!isfinite(p[SLOT_MAX_WINDING_TEMPERATURE]))
        BAD("max_winding_temperature: must be finite (0: none), got %g", p[SLOT_MAX_WINDING_TEMPERATURE]);
    if (p[P_STARTED] != 0.0 && p[P_STARTED] != 1.0) BAD("state.started: must be 0 or 1, got %g", p[P_STARTED]);
    if (started) {
        if (!isfinite(p[P_T])) BAD("state.t: the time must be finite, got %g", p[P_T]);
        if (p[P_WARNED_CHATTER] != 0.0 && p[P_WARNED_CHATTER] != 1.0)
            BAD("state.warned_chatter: must be 0 or 1, got %g", p[P_WARNED_CHATTER]);
        if (p[P_WARNED_HOT] != 0.0 && p[P_WARNED_HOT] != 1.0)
            BAD("state.warned_hot: must be 0 or 1, got %g", p[P_WARNED_HOT]);
        s.current = p[P_CURRENT];
        s.temperature = p[P_TEMPERATURE];
    } else {
        s.current = p[SLOT_INITIAL_CURRENT];
        s.temperature = initial_temperature(p);
    }
    st = dcm_check_state(d, &s, &field, &why);
    if (st != DCM_OK) {
        const char *name = dcm_field_name(field);
        BAD("%s%s: %s (got %g)", prefix, name ? name : "state", why ? why : dcm_status_message(st),
            field == DCM_CURRENT ? s.current : s.temperature);
    }
    return fmi2OK;
}

fmi2Status model_prepare(grb_instance *inst) {
    motor *mm = (motor *)inst->model;
    double *p = inst->p;
    fmi2Status status = model_check(inst, p);
    if (status != fmi2OK) return status;
    params_of(p, &mm->params);
    dcm_reflected_inertia(&mm->params, &mm->reflected_inertia);
    if (p[P_STARTED] != 0.0) return fmi2OK;  /* a restored run keeps its state */
    p[P_T] = inst->start_time;
    p[P_CURRENT] = p[SLOT_INITIAL_CURRENT];
    p[P_TEMPERATURE] = initial_temperature(p);
    p[P_WARNED_CHATTER] = p[P_WARNED_HOT] = 0.0;
    return fmi2OK;
}

fmi2Status model_start(grb_instance *inst) {
    inst->p[P_STARTED] = 1.0;
    return fmi2OK;
}

static void record(motor *mm, const dcm_outputs *o) {
    mm->out[0] = o->shaft_torque;
    mm->out[1] = o->current;
    mm->out[2] = o->winding_temperature;
    mm->out[3] = o->electrical_power;
    mm->out[4] = o->motor_speed;
    mm->out[5] = o->back_emf;
    mm->out[6] = o->terminal_voltage;
    mm->out[7] = mm->reflected_inertia;
}

fmi2Status model_compute(grb_instance *inst, int level) {
    motor *mm = (motor *)inst->model;
    const double *p = inst->p;
    dcm_state s;
    dcm_outputs o;
    int st, k;
    (void)level;
    s.current = p[P_CURRENT];
    s.temperature = p[P_TEMPERATURE];
    st = dcm_observe(&mm->params, &s, p[SLOT_VOLTAGE], p[SLOT_SHAFT_SPEED], &o);
    if (st != DCM_OK) {
        for (k = 0; k < MODEL_N_OUTPUTS; k++) mm->out[k] = NAN;
        grb_log(inst, fmi2Warning, "outputs at t = %.12g s: %s; they read as NaN", p[P_T], dcm_status_message(st));
        return fmi2Warning;
    }
    record(mm, &o);
    return fmi2OK;
}

fmi2Status model_do_step(grb_instance *inst, double t, double h) {
    motor *mm = (motor *)inst->model;
    double *p = inst->p, voltage = p[SLOT_VOLTAGE], speed = p[SLOT_SHAFT_SPEED], limit;
    dcm_state s;
    dcm_outputs o;
    int st;
    if (!isfinite(voltage) || !isfinite(speed)) {
        int v = !isfinite(voltage);
        grb_log(inst, fmi2Discard, "%s is %g at t = %.12g s: inputs must be finite", v ? "voltage" : "shaft_speed",
                v ? voltage : speed, t);
        return fmi2Discard;
    }
    if (p[P_WARNED_CHATTER] == 0.0 && dcm_chatter_free_step(&mm->params, &limit) == DCM_OK && h > limit) {
        p[P_WARNED_CHATTER] = 1.0;
        grb_log(inst, fmi2Warning, "communication step %g s exceeds 2 smoothing_speed rotor_inertia / "
                "coulomb_friction = %.3g s: with the speed held over a step the friction torque may chatter "
                "(raise smoothing_speed)", h, limit);
    }
    s.current = p[P_CURRENT];
    s.temperature = p[P_TEMPERATURE];
    st = dcm_step(&mm->params, &s, voltage, speed, h, &o);
    if (st != DCM_OK) {
        grb_log(inst, fmi2Discard, "step from t = %g s failed: %s", t, dcm_status_message(st));
        return fmi2Discard;
    }
    p[P_T] = t + h;
    p[P_CURRENT] = s.current;
    p[P_TEMPERATURE] = s.temperature;
    record(mm, &o);
    inst->level = 1;  /* the step's own outputs, for the inputs it held */
    if (p[SLOT_MAX_WINDING_TEMPERATURE] > 0.0 && p[P_WARNED_HOT] == 0.0 &&
        s.temperature > p[SLOT_MAX_WINDING_TEMPERATURE]) {
        p[P_WARNED_HOT] = 1.0;
        grb_log(inst, fmi2Warning, "winding at %.1f degC at t = %g s exceeds the datasheet's maximum %g degC",
                s.temperature, t + h, p[SLOT_MAX_WINDING_TEMPERATURE]);
    }
    return fmi2OK;
}
