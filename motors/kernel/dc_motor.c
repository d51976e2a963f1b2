/* dc_motor: the motor model of dc_motor.h.  Equations: motors/dc_motor.py's docstring. */
#include "dc_motor.h"

#include <math.h>
#include <stddef.h>

/* Relative: a current this close to I_max is at the limit.  Without the band
 * a current that reached the limit exactly (t_hit from a logarithm) could sit a
 * rounding error below or above it and take the wrong branch of the voltage law. */
#define LIMIT_TOL 1e-12

/* Below this |a h| the thermal step's (exp(a h) - 1) / (a h) is 1 + a h / 2:
 * expm1 / x loses nothing there, but x = 0 (no loss, no cooling) must not divide. */
#define SMALL_EXPONENT 1e-12

static const char *const FIELD_NAMES[] = {
    "resistance", "inductance", "torque_constant", "back_emf_constant", "rotor_inertia",
    "viscous_friction", "coulomb_friction", "smoothing_speed", "thermal_resistance",
    "thermal_time_constant", "temperature_coefficient", "reference_temperature", "gear_ratio",
    "gear_efficiency", "supply_voltage", "current_limit", "ambient_temperature", "max_substep",
    "current", "temperature"};

const char *dcm_field_name(int field)
{
    if (field < 0 || field >= (int)(sizeof FIELD_NAMES / sizeof FIELD_NAMES[0]))
        return NULL;
    return FIELD_NAMES[field];
}

const char *dcm_status_message(int status)
{
    switch (status) {
    case DCM_OK: return "ok";
    case DCM_BAD_PARAMETER: return "a parameter is out of range";
    case DCM_BAD_STATE: return "the state is not finite, beyond the current limit, or where R(T) <= 0";
    case DCM_BAD_VOLTAGE: return "the commanded voltage must be finite";
    case DCM_BAD_SHAFT_SPEED: return "the shaft speed must be finite";
    case DCM_BAD_STEP_SIZE: return "the step size must be positive and finite, and at most 1e8 max_substep";
    case DCM_RESISTANCE_VANISHED:
        return "the winding temperature is where R(T) = R_ref (1 + alpha (T - T_ref)) <= 0";
    case DCM_BAD_ARGUMENT: return "a NULL pointer or a negative count";
    default: return "unknown status";
    }
}

/* R(T) = R_ref (1 + alpha (T - T_ref)): copper's resistance rises about 0.39 %/K. */
static double resistance_at(const dcm_params *p, double temperature)
{
    return p->resistance * (1.0 + p->temperature_coefficient * (temperature - p->reference_temperature));
}

static int refuse(int f, const char *rule, int *field, const char **why)
{
    if (field) *field = f;
    if (why) *why = rule;
    return f >= DCM_N_PARAMS ? DCM_BAD_STATE : DCM_BAD_PARAMETER;
}

int dcm_check_params(const dcm_params *p, int *field, const char **why)
{
    if (!p) return DCM_BAD_ARGUMENT;
    /* the struct's doubles in enum dcm_field order */
    const double v[DCM_N_PARAMS] = {
        p->resistance, p->inductance, p->torque_constant, p->back_emf_constant, p->rotor_inertia,
        p->viscous_friction, p->coulomb_friction, p->smoothing_speed, p->thermal_resistance,
        p->thermal_time_constant, p->temperature_coefficient, p->reference_temperature, p->gear_ratio,
        p->gear_efficiency, p->supply_voltage, p->current_limit, p->ambient_temperature, p->max_substep};
    for (int f = 0; f < DCM_N_PARAMS; f++) {
        if (isnan(v[f]) || (isinf(v[f]) && f != DCM_CURRENT_LIMIT))
            return refuse(f, "must be finite", field, why);
        switch (f) {
        case DCM_VISCOUS_FRICTION: case DCM_COULOMB_FRICTION: case DCM_TEMPERATURE_COEFFICIENT:
            /* negative friction would feed energy in; negative alpha is no metal winding */
            if (v[f] < 0.0) return refuse(f, "must be >= 0", field, why);
            break;
        case DCM_REFERENCE_TEMPERATURE: case DCM_AMBIENT_TEMPERATURE:
            break; /* degC: any sign */
        default:
            if (!(v[f] > 0.0)) return refuse(f, "must be positive", field, why);
        }
    }
    if (fabs(p->back_emf_constant / p->torque_constant - 1.0) > DCM_KE_KT_TOLERANCE)
        return refuse(DCM_BACK_EMF_CONSTANT, "must be within 2 % of torque_constant (in SI units they are the "
                      "same constant)", field, why);
    if (p->gear_ratio < 1.0) return refuse(DCM_GEAR_RATIO, "must be >= 1 (a reduction)", field, why);
    if (p->gear_efficiency > 1.0) return refuse(DCM_GEAR_EFFICIENCY, "must be in (0, 1]", field, why);
    if (p->ambient_temperature < DCM_AMBIENT_MIN || p->ambient_temperature > DCM_AMBIENT_MAX)
        return refuse(DCM_AMBIENT_TEMPERATURE, "must lie in -50 .. 200 degC", field, why);
    if (!(resistance_at(p, p->ambient_temperature) > 0.0))
        return refuse(DCM_AMBIENT_TEMPERATURE, "is below where R(T) = R_ref (1 + alpha (T - T_ref)) vanishes",
                      field, why);
    return DCM_OK;
}

int dcm_check_state(const dcm_params *p, const dcm_state *s, int *field, const char **why)
{
    if (!p || !s) return DCM_BAD_ARGUMENT;
    if (!isfinite(s->current)) return refuse(DCM_CURRENT, "must be finite", field, why);
    if (fabs(s->current) > p->current_limit)
        return refuse(DCM_CURRENT, "exceeds the current limit", field, why);
    if (!isfinite(s->temperature)) return refuse(DCM_TEMPERATURE, "must be finite", field, why);
    if (!(resistance_at(p, s->temperature) > 0.0))
        return refuse(DCM_TEMPERATURE, "is below where R(T) = R_ref (1 + alpha (T - T_ref)) vanishes", field, why);
    return DCM_OK;
}

static double clamp(double x, double lo, double hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}

/* The drive's voltage law: the voltage it applies at current i, and in
 * *holding whether it holds the current at the limit.  Like a drive's current
 * loop, at the limit it lowers its output to the voltage that holds di/dt = 0,
 * v = +-R I_max + k_e omega_m, if the supply can; beyond the limit (a motor
 * back-driven faster than the bridge can oppose) it opposes with the whole
 * supply, as the freewheeling diodes do. */
static double terminal_voltage(const dcm_params *p, double i, double v_cmd, double emf, double r, int *holding)
{
    const double vs = p->supply_voltage, imax = p->current_limit;
    const double v = clamp(v_cmd, -vs, vs);
    *holding = 0;
    if (fabs(i) >= imax * (1.0 - LIMIT_TOL)) {
        const double s = i > 0.0 ? 1.0 : -1.0;
        if (fabs(i) > imax * (1.0 + LIMIT_TOL))
            return -s * vs;
        const double v_hold = s * imax * r + emf;
        if (s * v > s * v_hold) { /* the command would push the current past the limit */
            if (fabs(v_hold) <= vs) {
                *holding = 1;
                return v_hold;
            }
            return clamp(v_hold, -vs, vs);
        }
    }
    return v;
}

/* Integral of i^2 over [0, t] for i = i_ss + (i0 - i_ss) exp(-s / tau): the
 * copper loss of the sub-step, exactly, for the thermal model. */
static double integral_square(double i0, double i_ss, double t, double tau)
{
    const double c = i0 - i_ss;
    const double e1 = -expm1(-t / tau), e2 = -expm1(-2.0 * t / tau);
    return i_ss * i_ss * t + 2.0 * i_ss * c * tau * e1 + 0.5 * c * c * tau * e2;
}

/* The current after h [s] from i, and in *i2 the integral of i^2 over it:
 * exact for constant v_cmd and emf, L di/dt = v - R i - emf.  The step is cut
 * where the current reaches the limit (from below, or coming back from above),
 * after which the drive's voltage law changes; at most four pieces: free rise,
 * hit the limit, hold; or beyond, come back, hold. */
static double advance_current(const dcm_params *p, double i, double v_cmd, double emf, double r, double tau,
                              double h, double *i2)
{
    const double imax = p->current_limit;
    double t = 0.0, acc = 0.0;
    for (int piece = 0; piece < 4; piece++) {
        const double rem = h - t;
        if (rem <= 0.0)
            break;
        int holding;
        const double v = terminal_voltage(p, i, v_cmd, emf, r, &holding);
        if (holding) {
            i = copysign(imax, i);
            acc += i * i * rem;
            break;
        }
        const double i_ss = (v - emf) / r;
        int crosses = 0;
        double target = 0.0;
        if (isfinite(imax)) { /* the nearest limit the current crosses on its way to i_ss */
            /* nearer first; on a tie (i = 0) +I_max first */
            const double lims[2] = {fabs(i - imax) <= fabs(i + imax) ? imax : -imax,
                                    fabs(i - imax) <= fabs(i + imax) ? -imax : imax};
            for (int k = 0; k < 2 && !crosses; k++) {
                const double a = i - lims[k], b = i_ss - lims[k];
                if (a * b < 0.0 && fabs(a) > LIMIT_TOL * imax) {
                    crosses = 1;
                    target = lims[k];
                }
            }
        }
        if (crosses) {
            const double t_hit = -tau * log((target - i_ss) / (i - i_ss));
            if (t_hit < rem) {
                acc += integral_square(i, i_ss, t_hit, tau);
                i = target;
                t += t_hit;
                continue;
            }
        }
        acc += integral_square(i, i_ss, rem, tau);
        i = i_ss + (i - i_ss) * exp(-rem / tau);
        break;
    }
    *i2 = acc;
    return i;
}

/* The winding temperature after h [s] at mean square current i2_mean:
 * C_th dT/dt = i2 R(T) - (T - T_amb) / R_th is linear in T (R(T) is), so
 * dT/dt = a T + c and T(h) = T + (a T + c) h (exp(a h) - 1) / (a h) exactly. */
static double advance_temperature(const dcm_params *p, double temp, double i2_mean, double h)
{
    const double c_th = p->thermal_time_constant / p->thermal_resistance;
    const double loss = i2_mean * p->resistance;
    const double a = (loss * p->temperature_coefficient - 1.0 / p->thermal_resistance) / c_th;
    const double c = (loss * (1.0 - p->temperature_coefficient * p->reference_temperature)
                      + p->ambient_temperature / p->thermal_resistance) / c_th;
    const double x = a * h;
    const double phi = fabs(x) > SMALL_EXPONENT ? expm1(x) / x : 1.0 + 0.5 * x;
    return temp + (a * temp + c) * h * phi;
}

/* tanh(omega_m / omega_s): the smoothed sign of the motor speed, over which
 * both the dry friction and the gearbox's direction of power flow turn. */
static double speed_sign(const dcm_params *p, double motor_speed)
{
    return tanh(motor_speed / p->smoothing_speed);
}

/* Motor-shaft friction torque, b omega_m + tau_c tanh(omega_m / omega_s): the
 * dry friction smoothed so that a speed held over a step does not chatter. */
static double friction(const dcm_params *p, double motor_speed, double sign_w)
{
    return p->viscous_friction * motor_speed + p->coulomb_friction * sign_w;
}

/* Output torque / motor torque: N eta when the motor drives (torque and motor
 * speed of one sign), N / eta when the load drives it, blended as
 * N eta^tanh(sign(torque) omega_m / omega_s) so the torque stays continuous
 * (and lossless) through standstill; tanh is odd, so the exponent is
 * sign(torque) sign_w.  The factor is positive: the output torque and the motor
 * torque share the sign that picks the direction. */
static double gear_factor(const dcm_params *p, double torque, double sign_w)
{
    return p->gear_ratio * pow(p->gear_efficiency, copysign(1.0, torque) * sign_w);
}

static double output_torque(const dcm_params *p, double current, double motor_speed)
{
    const double sign_w = speed_sign(p, motor_speed);
    const double tau_m = p->torque_constant * current - friction(p, motor_speed, sign_w);
    return tau_m * gear_factor(p, tau_m, sign_w);
}

int dcm_shaft_torque(const dcm_params *p, double current, double motor_speed, double *torque)
{
    if (!p || !torque) return DCM_BAD_ARGUMENT;
    *torque = output_torque(p, current, motor_speed);
    return DCM_OK;
}

int dcm_linearize(const dcm_params *p, const dcm_state *s, double shaft_speed, double *jac)
{
    if (!p || !s || !jac) return DCM_BAD_ARGUMENT;
    if (!isfinite(shaft_speed)) return DCM_BAD_SHAFT_SPEED;
    const double r = resistance_at(p, s->temperature);
    if (!isfinite(s->current) || !(r > 0.0)) return DCM_BAD_STATE;
    const double n = p->gear_ratio, w = n * shaft_speed;
    const double sign_w = speed_sign(p, w), dsign_w = (1.0 - sign_w * sign_w) / p->smoothing_speed;
    const double tau_m = p->torque_constant * s->current - friction(p, w, sign_w);
    const double sigma = copysign(1.0, tau_m), g = gear_factor(p, tau_m, sign_w);
    /* L di/dt = v - R(T) i - k_e omega_m */
    jac[0] = -r / p->inductance;
    jac[1] = -p->back_emf_constant * n / p->inductance;
    jac[2] = 1.0 / p->inductance;
    /* tau = tau_m g with g = N eta^(sigma sign_w): sigma is constant on either
     * side of tau_m = 0, and where tau_m = 0 its term vanishes with tau_m */
    jac[3] = g * p->torque_constant;
    jac[4] = n * (g * (-p->viscous_friction - p->coulomb_friction * dsign_w)
                  + tau_m * g * log(p->gear_efficiency) * sigma * dsign_w);
    return DCM_OK;
}

int dcm_current_for_torque(const dcm_params *p, long n, const double *torque, const double *motor_speed,
                           double *current)
{
    if (!p || n < 0 || (n > 0 && (!torque || !motor_speed || !current))) return DCM_BAD_ARGUMENT;
    for (long k = 0; k < n; k++) {
        const double w = motor_speed[k], sign_w = speed_sign(p, w);
        const double tau_m = torque[k] / gear_factor(p, torque[k], sign_w);
        current[k] = (tau_m + friction(p, w, sign_w)) / p->torque_constant;
    }
    return DCM_OK;
}

int dcm_reflected_inertia(const dcm_params *p, double *inertia)
{
    if (!p || !inertia) return DCM_BAD_ARGUMENT;
    *inertia = p->rotor_inertia * p->gear_ratio * p->gear_ratio;
    return DCM_OK;
}

int dcm_chatter_free_step(const dcm_params *p, double *step)
{
    if (!p || !step) return DCM_BAD_ARGUMENT;
    *step = p->coulomb_friction > 0.0 ? 2.0 * p->smoothing_speed * p->rotor_inertia / p->coulomb_friction
                                      : INFINITY;
    return DCM_OK;
}

int dcm_observe(const dcm_params *p, const dcm_state *s, double voltage, double shaft_speed, dcm_outputs *out)
{
    if (!p || !s || !out) return DCM_BAD_ARGUMENT;
    if (!isfinite(voltage)) return DCM_BAD_VOLTAGE;
    if (!isfinite(shaft_speed)) return DCM_BAD_SHAFT_SPEED;
    const double w = p->gear_ratio * shaft_speed;
    const double emf = p->back_emf_constant * w;
    int holding;
    const double v = terminal_voltage(p, s->current, voltage, emf, resistance_at(p, s->temperature), &holding);
    out->shaft_torque = output_torque(p, s->current, w);
    out->current = s->current;
    out->winding_temperature = s->temperature;
    out->electrical_power = v * s->current;
    out->motor_speed = w;
    out->back_emf = emf;
    out->terminal_voltage = v;
    return DCM_OK;
}

int dcm_step(const dcm_params *p, dcm_state *s, double voltage, double shaft_speed, double dt, dcm_outputs *out)
{
    if (!p || !s) return DCM_BAD_ARGUMENT;
    if (!isfinite(voltage)) return DCM_BAD_VOLTAGE;
    if (!isfinite(shaft_speed)) return DCM_BAD_SHAFT_SPEED;
    if (!(dt > 0.0 && isfinite(dt))) return DCM_BAD_STEP_SIZE;
    if (!isfinite(s->current) || !isfinite(s->temperature)) return DCM_BAD_STATE;
    /* the current is exact for any step; sub-steps only refresh R(T) and the
     * thermal coupling (the 1e-9 keeps dt = k max_substep from rounding up to k + 1) */
    double n = ceil(dt / p->max_substep - 1e-9);
    if (n < 1.0) n = 1.0;
    if (n > DCM_MAX_SUBSTEPS) return DCM_BAD_STEP_SIZE;
    const double h = dt / n;
    const double w = p->gear_ratio * shaft_speed;
    const double emf = p->back_emf_constant * w;
    double i = s->current, temp = s->temperature;
    for (double k = 0.0; k < n; k += 1.0) {
        const double r = resistance_at(p, temp); /* held over the sub-step */
        if (!(r > 0.0)) return DCM_RESISTANCE_VANISHED;
        double i2;
        i = advance_current(p, i, voltage, emf, r, p->inductance / r, h, &i2);
        temp = advance_temperature(p, temp, i2 / h, h);
    }
    const dcm_state next = {i, temp};
    if (out) {
        const int status = dcm_observe(p, &next, voltage, shaft_speed, out);
        if (status != DCM_OK) return status;
    }
    *s = next;
    return DCM_OK;
}
