/* pneumatic_cylinder: the model of pneumatic_cylinder.h. */
#include "pneumatic_cylinder.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "rosenbrock.h"

#define N_STATE 4           /* x, x', p_A, p_B */
#define PRESSURE_SCALE 1e5  /* the pressures' error scale: a relative tolerance applies to at least this */

static const char *const FIELD_NAMES[] = {
    "bore", "rod", "stroke", "retracted_length", "dead_volume_a", "dead_volume_b", "viscous_friction",
    "coulomb_friction", "smoothing_speed", "stop_stiffness", "stop_damping", "leakage", "sonic_conductance",
    "critical_pressure_ratio", "laminar_ratio", "valve_frequency", "valve_damping", "overlap", "supply_pressure",
    "exhaust_pressure", "supply_temperature", "polytropic_exponent", "tolerance",
    "spool", "spool_rate", "pressure_a", "pressure_b"};

const char *pnc_field_name(int field)
{
    if (field < 0 || field >= (int)(sizeof FIELD_NAMES / sizeof FIELD_NAMES[0])) return NULL;
    return FIELD_NAMES[field];
}

const char *pnc_status_message(int status)
{
    switch (status) {
    case PNC_OK: return "ok";
    case PNC_BAD_PARAMETER: return "a parameter is out of range";
    case PNC_BAD_STATE: return "the state is not finite, or a pressure is below vacuum";
    case PNC_BAD_INPUT: return "the valve command, the actuator length and its rate must be finite";
    case PNC_BAD_STEP_SIZE: return "the step size must be positive and finite";
    case PNC_STEP_FAILED:
        return "the step size control gave up (more than 1e6 sub-steps in one step, or a sub-step below 1e-14 s)";
    case PNC_BAD_ARGUMENT: return "a NULL pointer";
    default: return "unknown status";
    }
}

static int refuse(int f, const char *rule, int *field, const char **why)
{
    if (field) *field = f;
    if (why) *why = rule;
    return f >= PNC_N_PARAMS ? PNC_BAD_STATE : PNC_BAD_PARAMETER;
}

int pnc_check_params(const pnc_params *p, int *field, const char **why)
{
    if (!p) return PNC_BAD_ARGUMENT;
    int f = -1;
    const char *rule = "";
    cyl_check_piston(&p->piston, &f, &rule);
    if (f >= 0) return refuse(f, rule, field, why);
    const double *v = (const double *)p; /* the struct is PNC_N_PARAMS doubles in enum order */
    for (f = CYL_PISTON_FIELDS; f < PNC_N_PARAMS; f++) {
        if (!isfinite(v[f])) return refuse(f, "must be finite", field, why);
        switch (f) {
        case PNC_EXHAUST_PRESSURE:
            break; /* a gauge pressure; checked below */
        case PNC_LEAKAGE: case PNC_OVERLAP: case PNC_CRITICAL_PRESSURE_RATIO:
            if (v[f] < 0.0) return refuse(f, "must be >= 0", field, why);
            break;
        default:
            if (!(v[f] > 0.0)) return refuse(f, "must be positive", field, why);
        }
    }
    if (!(p->critical_pressure_ratio < 1.0)) return refuse(PNC_CRITICAL_PRESSURE_RATIO, "must be below 1", field, why);
    if (!(p->laminar_ratio > p->critical_pressure_ratio && p->laminar_ratio < 1.0))
        return refuse(PNC_LAMINAR_RATIO, "must lie between critical_pressure_ratio and 1", field, why);
    if (!(p->overlap < 1.0)) return refuse(PNC_OVERLAP, "must be below 1 (the valve would never open)", field, why);
    if (!(p->exhaust_pressure > -PNC_ATMOSPHERE))
        return refuse(PNC_EXHAUST_PRESSURE, "must be above vacuum (-101325 Pa gauge)", field, why);
    if (!(p->supply_pressure > p->exhaust_pressure))
        return refuse(PNC_SUPPLY_PRESSURE, "must be above the exhaust pressure", field, why);
    if (!(p->polytropic_exponent >= 1.0 && p->polytropic_exponent <= PNC_ADIABATIC))
        return refuse(PNC_POLYTROPIC_EXPONENT, "must lie in [1, 1.4]: isothermal to adiabatic", field, why);
    if (!(p->tolerance < 0.1)) return refuse(PNC_TOLERANCE, "must be below 0.1", field, why);
    return PNC_OK;
}

int pnc_check_state(const pnc_params *p, const pnc_state *s, int *field, const char **why)
{
    if (!p || !s) return PNC_BAD_ARGUMENT;
    const double v[N_STATE] = {s->spool, s->spool_rate, s->pressure_a, s->pressure_b};
    for (int k = 0; k < N_STATE; k++) {
        if (!isfinite(v[k])) return refuse(PNC_SPOOL + k, "must be finite", field, why);
        if (k >= 2 && !(v[k] > -PNC_ATMOSPHERE))
            return refuse(PNC_SPOOL + k, "must be above vacuum (-101325 Pa gauge)", field, why);
    }
    if (!(fabs(s->spool) <= 1.5)) return refuse(PNC_SPOOL, "must be within [-1.5, 1.5] of full opening", field, why);
    if (!(isfinite(s->substep) && s->substep >= 0.0)) return refuse(PNC_SPOOL, "substep must be >= 0", field, why);
    return PNC_OK;
}

/* ---- the equations -------------------------------------------------------------- */

/* ISO 6358's flow function of the pressure ratio r = p_down / p_up: choked (1)
 * up to b, the elliptic law above it, and linear to 0 at r = 1 above the
 * laminar ratio, where the elliptic law's slope would grow without bound. */
static double flow_function(const pnc_params *p, double r)
{
    double b = p->critical_pressure_ratio, rl = p->laminar_ratio;
    if (r <= b) return 1.0;
    double ratio = r < rl ? r : rl, e = (ratio - b) / (1.0 - b), phi = sqrt(1.0 - e * e);
    return r < rl ? phi : phi * (1.0 - r) / (1.0 - rl);
}

/* Mass flow [kg/s] through an edge of relative opening a from absolute pressure
 * p1 to p2 (negative when the gas flows back). */
static double edge_mass_flow(const pnc_params *p, double a, double p1, double p2)
{
    if (a <= 0.0) return 0.0;
    double up = p1 >= p2 ? p1 : p2, down = p1 >= p2 ? p2 : p1;
    double m = a * p->sonic_conductance * PNC_REFERENCE_DENSITY * up *
               sqrt(PNC_REFERENCE_TEMPERATURE / p->supply_temperature) * flow_function(p, down / up);
    return p1 >= p2 ? m : -m;
}

typedef struct flows {
    cyl_chambers ch;
    double sa, ae, sb, be, leak; /* supply->A, A->exhaust, supply->B, B->exhaust, A->B */
} flows;

static double absolute(double gauge)
{
    double a = gauge + PNC_ATMOSPHERE;
    return a > 0.0 ? a : 0.0;
}

static flows flows_at(const pnc_params *p, const double *y, double length, double rate)
{
    flows f;
    double plus, minus, pa = absolute(y[2]), pb = absolute(y[3]);
    double ps = absolute(p->supply_pressure), pe = absolute(p->exhaust_pressure);
    f.ch = cyl_chambers_at(&p->piston, length, rate);
    cyl_openings(y[0], p->overlap, &plus, &minus);
    f.sa = edge_mass_flow(p, plus, ps, pa);
    f.ae = edge_mass_flow(p, minus, pa, pe);
    f.sb = edge_mass_flow(p, minus, ps, pb);
    f.be = edge_mass_flow(p, plus, pb, pe);
    f.leak = p->leakage * (y[2] - y[3]);
    return f;
}

static void derivatives(const pnc_params *p, const double *y, double length, double rate, double command,
                        double *dy)
{
    flows f = flows_at(p, y, length, rate);
    const cyl_chambers *ch = &f.ch;
    double n = p->polytropic_exponent, RT = PNC_GAS_CONSTANT * p->supply_temperature;
    dy[0] = y[1];
    dy[1] = cyl_spool_acceleration(y[0], y[1], command, p->valve_frequency, p->valve_damping);
    /* a polytropic chamber: p V^n = const when closed, the inflow's R T_s m' added */
    dy[2] = n / ch->volume_a * (RT * (f.sa - f.ae - f.leak) - absolute(y[2]) * ch->area_a * ch->displacement_rate);
    dy[3] = n / ch->volume_b * (RT * (f.sb - f.be + f.leak) + absolute(y[3]) * ch->area_b * ch->displacement_rate);
}

static void outputs_at(const pnc_params *p, const double *y, double length, double rate, pnc_outputs *o)
{
    flows f = flows_at(p, y, length, rate);
    const cyl_chambers *ch = &f.ch;
    o->force = cyl_rod_force(&p->piston, y[2] * ch->area_a - y[3] * ch->area_b, length, rate);
    o->pressure_a = y[2];
    o->pressure_b = y[3];
    o->mass_flow_a = f.sa - f.ae;
    o->mass_flow_b = f.sb - f.be;
    o->air_consumption = f.sa + f.sb;
    o->position = ch->position;
    o->spool = y[0];
    o->mechanical_power = o->force * rate;
}

static void step_rhs(const void *ctx, double t, const double *y, double *dy)
{
    const pnc_params *p = ((const void *const *)ctx)[0];
    const pnc_inputs *in = ((const void *const *)ctx)[1];
    derivatives(p, y, in->length + in->rate * t, in->rate, in->command, dy); /* the length moves at the held rate */
}

int pnc_derivatives(const pnc_params *p, const pnc_state *s, const pnc_inputs *in, double *dydt)
{
    if (!p || !s || !in || !dydt) return PNC_BAD_ARGUMENT;
    const double y[N_STATE] = {s->spool, s->spool_rate, s->pressure_a, s->pressure_b};
    derivatives(p, y, in->length, in->rate, in->command, dydt);
    return PNC_OK;
}

int pnc_step(const pnc_params *p, pnc_state *s, const pnc_inputs *in, double dt, pnc_outputs *out)
{
    if (!p || !s || !in) return PNC_BAD_ARGUMENT;
    if (!(isfinite(in->command) && isfinite(in->length) && isfinite(in->rate))) return PNC_BAD_INPUT;
    if (!(dt > 0.0 && isfinite(dt))) return PNC_BAD_STEP_SIZE;
    static const double scale[N_STATE] = {1.0, 1.0, PRESSURE_SCALE, PRESSURE_SCALE};
    static const double lower[N_STATE] = {-INFINITY, -INFINITY, -PNC_ATMOSPHERE, -PNC_ATMOSPHERE};
    const void *ctx[2] = {p, in};
    ros_problem pr = {N_STATE, step_rhs, ctx, scale, lower, p->tolerance};
    double y[N_STATE] = {s->spool, s->spool_rate, s->pressure_a, s->pressure_b};
    double substep = s->substep;
    if (ros_advance(&pr, y, dt, &substep) != 0) return PNC_STEP_FAILED;
    pnc_outputs o;
    outputs_at(p, y, in->length + in->rate * dt, in->rate, &o);
    s->spool = y[0];
    s->spool_rate = y[1];
    s->pressure_a = y[2];
    s->pressure_b = y[3];
    s->substep = substep;
    if (out) *out = o;
    return PNC_OK;
}

int pnc_observe(const pnc_params *p, const pnc_state *s, const pnc_inputs *in, pnc_outputs *out)
{
    if (!p || !s || !in || !out) return PNC_BAD_ARGUMENT;
    if (!(isfinite(in->command) && isfinite(in->length) && isfinite(in->rate))) return PNC_BAD_INPUT;
    const double y[N_STATE] = {s->spool, s->spool_rate, s->pressure_a, s->pressure_b};
    outputs_at(p, y, in->length, in->rate, out);
    return PNC_OK;
}
