/* hydraulic_cylinder: the model of hydraulic_cylinder.h. */
#include "hydraulic_cylinder.h"

#include "rosenbrock.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#define N_STATE 5       /* x, x', p_A, p_B, p_S */
/* Absolute pressure [Pa] about which the oil cavitates: its stiffness falls as
 * (p / P_CAVITATION)^2 below it, so a chamber the piston pulls from never reaches
 * a vacuum (the pressure approaches it ever more slowly), and the equations stay
 * smooth where a clamp would switch. */
#define P_CAVITATION 1000.0
/* The pressures' error scale: a relative tolerance applies to at least this. */
#define PRESSURE_SCALE 1e5

static const char *const FIELD_NAMES[] = {
    "bore", "rod", "stroke", "retracted_length", "dead_volume_a", "dead_volume_b", "viscous_friction",
    "coulomb_friction", "smoothing_speed", "stop_stiffness", "stop_damping", "bulk_modulus", "air_fraction",
    "leakage", "nominal_flow", "nominal_pressure_drop", "valve_frequency", "valve_damping", "overlap",
    "valve_leakage", "transition_pressure", "pump_flow", "relief_pressure", "relief_gradient", "supply_volume",
    "tank_pressure", "tolerance",
    "spool", "spool_rate", "pressure_a", "pressure_b", "supply_pressure"};

const char *hyd_field_name(int field)
{
    if (field < 0 || field >= (int)(sizeof FIELD_NAMES / sizeof FIELD_NAMES[0])) return NULL;
    return FIELD_NAMES[field];
}

const char *hyd_status_message(int status)
{
    switch (status) {
    case HYD_OK: return "ok";
    case HYD_BAD_PARAMETER: return "a parameter is out of range";
    case HYD_BAD_STATE: return "the state is not finite, or a pressure is below vacuum";
    case HYD_BAD_INPUT: return "the valve command, the actuator length and its rate must be finite";
    case HYD_BAD_STEP_SIZE: return "the step size must be positive and finite";
    case HYD_STEP_FAILED:
        return "the step size control gave up (more than 1e6 sub-steps in one step, or a sub-step below 1e-14 s)";
    case HYD_BAD_ARGUMENT: return "a NULL pointer";
    default: return "unknown status";
    }
}

static int refuse(int f, const char *rule, int *field, const char **why)
{
    if (field) *field = f;
    if (why) *why = rule;
    return f >= HYD_N_PARAMS ? HYD_BAD_STATE : HYD_BAD_PARAMETER;
}

static void params_as_array(const hyd_params *p, double *v)
{
    memcpy(v, p, sizeof *p); /* the struct is HYD_N_PARAMS doubles in enum order */
}

int hyd_check_params(const hyd_params *p, int *field, const char **why)
{
    if (!p) return HYD_BAD_ARGUMENT;
    int f = -1;
    const char *rule = "";
    cyl_check_piston(&p->piston, &f, &rule);
    if (f >= 0) return refuse(f, rule, field, why);
    double v[HYD_N_PARAMS];
    params_as_array(p, v);
    for (f = CYL_PISTON_FIELDS; f < HYD_N_PARAMS; f++) {
        if (!isfinite(v[f])) return refuse(f, "must be finite", field, why);
        switch (f) {
        case HYD_TANK_PRESSURE:
            break; /* a gauge pressure: any sign; checked below */
        case HYD_LEAKAGE: case HYD_VALVE_LEAKAGE: case HYD_PUMP_FLOW: case HYD_AIR_FRACTION: case HYD_OVERLAP:
            /* negative leakage or flow would feed energy in */
            if (v[f] < 0.0) return refuse(f, "must be >= 0", field, why);
            break;
        default:
            if (!(v[f] > 0.0)) return refuse(f, "must be positive", field, why);
        }
    }
    if (!(p->air_fraction < 0.5)) return refuse(HYD_AIR_FRACTION, "must be below 0.5 (a froth is no hydraulic fluid)",
                                                 field, why);
    if (!(p->overlap < 1.0)) return refuse(HYD_OVERLAP, "must be below 1 (the valve would never open)", field, why);
    if (!(p->tank_pressure > -HYD_ATMOSPHERE))
        return refuse(HYD_TANK_PRESSURE, "must be above vacuum (-101325 Pa gauge)", field, why);
    if (!(p->relief_pressure > p->tank_pressure))
        return refuse(HYD_RELIEF_PRESSURE, "must be above the tank pressure", field, why);
    if (!(p->tolerance < 0.1)) return refuse(HYD_TOLERANCE, "must be below 0.1", field, why);
    return HYD_OK;
}

int hyd_check_state(const hyd_params *p, const hyd_state *s, int *field, const char **why)
{
    if (!p || !s) return HYD_BAD_ARGUMENT;
    const double v[N_STATE] = {s->spool, s->spool_rate, s->pressure_a, s->pressure_b, s->supply_pressure};
    for (int k = 0; k < N_STATE; k++) {
        if (!isfinite(v[k])) return refuse(HYD_SPOOL + k, "must be finite", field, why);
        if (k >= 2 && !(v[k] > -HYD_ATMOSPHERE))
            return refuse(HYD_SPOOL + k, "must be above vacuum (-101325 Pa gauge)", field, why);
    }
    if (!(fabs(s->spool) <= 1.5)) return refuse(HYD_SPOOL, "must be within [-1.5, 1.5] of full opening", field, why);
    if (!(isfinite(s->substep) && s->substep >= 0.0)) return refuse(HYD_SPOOL, "substep must be >= 0", field, why);
    (void)p;
    return HYD_OK;
}

/* ---- the equations -------------------------------------------------------------- */

/* The bulk modulus of oil with entrained air at gauge pressure pg: the air's
 * volume fraction follows the isothermal gas law from air_fraction at one
 * atmosphere, the mixture's compliance is the volume-weighted sum, and near a
 * vacuum the stiffness vanishes as the oil cavitates (P_CAVITATION). */
static double effective_bulk_modulus(const hyd_params *p, double pg)
{
    double pa = pg + HYD_ATMOSPHERE, beta = p->bulk_modulus;
    /* at a vacuum (cavitated) the oil is this soft, so inflow raises the pressure again at once */
    if (pa < 0.1 * P_CAVITATION) pa = 0.1 * P_CAVITATION;
    if (p->air_fraction > 0.0) {
        double air = p->air_fraction * HYD_ATMOSPHERE / pa, oil = 1.0 - p->air_fraction;
        double x = air / (air + oil);
        beta = 1.0 / ((1.0 - x) / beta + x / pa);
    }
    return beta * pa * pa / (pa * pa + P_CAVITATION * P_CAVITATION);
}

/* Flow through one metering edge of relative opening a at pressure drop dp:
 * turbulent (sqrt) above p_tr, turning laminar below it, smooth at dp = 0;
 * plus the edge's laminar leakage. */
static double edge_flow(const hyd_params *p, double a, double dp)
{
    double K = p->nominal_flow / sqrt(p->nominal_pressure_drop), pt = p->transition_pressure;
    return K * a * dp / sqrt(sqrt(dp * dp + pt * pt)) + p->valve_leakage * dp;
}

typedef struct flows {
    cyl_chambers ch;           /* piston position, the speed that changes the volumes, the volumes */
    double pa_in, at, pb_in, bt, leak, relief; /* P->A, A->T, P->B, B->T, A->B, relief */
} flows;

/* Everything the derivatives and the outputs share, at state y, length and rate. */
static flows flows_at(const hyd_params *p, const double *y, double length, double rate)
{
    flows f;
    double plus, minus, pa = y[2], pb = y[3], ps = y[4], pt = p->tank_pressure;
    f.ch = cyl_chambers_at(&p->piston, length, rate);
    cyl_openings(y[0], p->overlap, &plus, &minus);
    f.pa_in = edge_flow(p, plus, ps - pa);
    f.at = edge_flow(p, minus, pa - pt);
    f.pb_in = edge_flow(p, minus, ps - pb);
    f.bt = edge_flow(p, plus, pb - pt);
    f.leak = p->leakage * (pa - pb);
    f.relief = ps > p->relief_pressure ? p->relief_gradient * (ps - p->relief_pressure) : 0.0;
    return f;
}

static void derivatives(const hyd_params *p, const double *y, double length, double rate, double command,
                        double *dy)
{
    flows f = flows_at(p, y, length, rate);
    const cyl_chambers *ch = &f.ch;
    dy[0] = y[1];
    dy[1] = cyl_spool_acceleration(y[0], y[1], command, p->valve_frequency, p->valve_damping);
    dy[2] = effective_bulk_modulus(p, y[2]) / ch->volume_a * (f.pa_in - f.at - f.leak - ch->area_a * ch->displacement_rate);
    dy[3] = effective_bulk_modulus(p, y[3]) / ch->volume_b * (f.pb_in - f.bt + f.leak + ch->area_b * ch->displacement_rate);
    dy[4] = effective_bulk_modulus(p, y[4]) / p->supply_volume * (p->pump_flow - f.relief - f.pa_in - f.pb_in);
}

static void outputs_at(const hyd_params *p, const double *y, double length, double rate, hyd_outputs *o)
{
    flows f = flows_at(p, y, length, rate);
    const cyl_chambers *ch = &f.ch;
    double pt = p->tank_pressure, pa = y[2], pb = y[3], ps = y[4];
    o->force = cyl_rod_force(&p->piston, pa * ch->area_a - pb * ch->area_b, length, rate);
    o->pressure_a = pa;
    o->pressure_b = pb;
    o->supply_pressure = ps;
    o->flow_a = f.pa_in - f.at;
    o->flow_b = f.pb_in - f.bt;
    o->relief_flow = f.relief;
    o->position = ch->position;
    o->spool = y[0];
    o->pump_power = (ps - pt) * p->pump_flow;
    o->piston_power = ((pa - pt) * ch->area_a - (pb - pt) * ch->area_b) * ch->displacement_rate;
    o->mechanical_power = o->force * rate;
    o->throttling_loss = f.pa_in * (ps - pa) + f.at * (pa - pt) + f.pb_in * (ps - pb) + f.bt * (pb - pt) +
                         f.leak * (pa - pb) + f.relief * (ps - pt);
    double dy[N_STATE];
    derivatives(p, y, length, rate, 0.0, dy); /* the command moves only the spool, not the pressures' rates */
    o->compression_power = ch->volume_a / effective_bulk_modulus(p, pa) * (pa - pt) * dy[2] +
                           ch->volume_b / effective_bulk_modulus(p, pb) * (pb - pt) * dy[3] +
                           p->supply_volume / effective_bulk_modulus(p, ps) * (ps - pt) * dy[4];
}

/* ---- stepping: ROS2 with error control (rosenbrock.h) ---------------------------- */

static void step_rhs(const void *ctx, double t, const double *y, double *dy)
{
    const hyd_params *p = ((const void *const *)ctx)[0];
    const hyd_inputs *in = ((const void *const *)ctx)[1];
    derivatives(p, y, in->length + in->rate * t, in->rate, in->command, dy); /* the length moves at the held rate */
}

int hyd_derivatives(const hyd_params *p, const hyd_state *s, const hyd_inputs *in, double *dydt)
{
    if (!p || !s || !in || !dydt) return HYD_BAD_ARGUMENT;
    const double y[N_STATE] = {s->spool, s->spool_rate, s->pressure_a, s->pressure_b, s->supply_pressure};
    derivatives(p, y, in->length, in->rate, in->command, dydt);
    return HYD_OK;
}

int hyd_step(const hyd_params *p, hyd_state *s, const hyd_inputs *in, double dt, hyd_outputs *out)
{
    if (!p || !s || !in) return HYD_BAD_ARGUMENT;
    if (!(isfinite(in->command) && isfinite(in->length) && isfinite(in->rate))) return HYD_BAD_INPUT;
    if (!(dt > 0.0 && isfinite(dt))) return HYD_BAD_STEP_SIZE;
    static const double scale[N_STATE] = {1.0, 1.0, PRESSURE_SCALE, PRESSURE_SCALE, PRESSURE_SCALE};
    /* no pressure below a vacuum: a chamber drawn down to it stays there,
     * cavitated, until oil flows in */
    static const double lower[N_STATE] = {-INFINITY, -INFINITY, -HYD_ATMOSPHERE, -HYD_ATMOSPHERE, -HYD_ATMOSPHERE};
    const void *ctx[2] = {p, in};
    ros_problem pr = {N_STATE, step_rhs, ctx, scale, lower, p->tolerance};
    double y[N_STATE] = {s->spool, s->spool_rate, s->pressure_a, s->pressure_b, s->supply_pressure};
    double substep = s->substep;
    if (ros_advance(&pr, y, dt, &substep) != 0) return HYD_STEP_FAILED;
    hyd_outputs o;
    outputs_at(p, y, in->length + in->rate * dt, in->rate, &o);
    s->spool = y[0];
    s->spool_rate = y[1];
    s->pressure_a = y[2];
    s->pressure_b = y[3];
    s->supply_pressure = y[4];
    s->substep = substep;
    if (out) *out = o;
    return HYD_OK;
}

int hyd_observe(const hyd_params *p, const hyd_state *s, const hyd_inputs *in, hyd_outputs *out)
{
    if (!p || !s || !in || !out) return HYD_BAD_ARGUMENT;
    if (!(isfinite(in->command) && isfinite(in->length) && isfinite(in->rate))) return HYD_BAD_INPUT;
    const double y[N_STATE] = {s->spool, s->spool_rate, s->pressure_a, s->pressure_b, s->supply_pressure};
    outputs_at(p, y, in->length, in->rate, out);
    return HYD_OK;
}
