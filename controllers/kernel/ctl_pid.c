/* ctl_pid: the PID of ctl_pid.h.  Equations: controllers/pid.py's docstring. */
#include "ctl_pid.h"

#include <math.h>
#include <stddef.h>

static const char *const FIELD_NAMES[] = {
    "K", "Ti", "Td", "N", "b", "c", "Ts", "u_min", "u_max", "anti_windup", "Tt",
    "I", "D", "ed_prev", "started"};

const char *ctl_pid_field_name(int field)
{
    return ctl_name(FIELD_NAMES, (int)(sizeof FIELD_NAMES / sizeof FIELD_NAMES[0]), field);
}

static int refuse(int f, const char *rule, int *field, const char **why)
{
    return ctl_refuse(f, CTL_PID_N_PARAMS, rule, field, why);
}

int ctl_pid_check(const ctl_pid_params *p, int *field, const char **why)
{
    if (!p) return CTL_BAD_ARGUMENT;
    const double v[CTL_PID_N_PARAMS] = {p->K, p->Ti, p->Td, p->N, p->b, p->c, p->Ts, p->u_min, p->u_max,
                                        p->anti_windup, p->Tt};
    for (int f = 0; f < CTL_PID_N_PARAMS; f++)
        if (!isfinite(v[f])) return refuse(f, "must be finite", field, why);
    if (p->Ti < 0.0) return refuse(CTL_PID_TI, "must be >= 0 (0: no integral action)", field, why);
    if (p->Td < 0.0) return refuse(CTL_PID_TD, "must be >= 0 (0: no derivative action)", field, why);
    if (!(p->N > 0.0)) return refuse(CTL_PID_N, "must be > 0", field, why);
    if (!(p->Ts > 0.0)) return refuse(CTL_PID_TS, "sample time must be finite and > 0", field, why);
    if (!(p->u_min < p->u_max)) return refuse(CTL_PID_U_MAX, "must exceed u_min", field, why);
    if (!(p->anti_windup == CTL_AW_BACK_CALCULATION || p->anti_windup == CTL_AW_CONDITIONAL ||
          p->anti_windup == CTL_AW_NONE))
        return refuse(CTL_PID_ANTI_WINDUP, "must be one of back-calculation, conditional, none", field, why);
    if (p->Tt < 0.0) return refuse(CTL_PID_TT, "must be >= 0 (0: sqrt(Ti Td))", field, why);
    return CTL_OK;
}

int ctl_pid_check_state(const ctl_pid_params *p, const ctl_pid_state *s, int *field, const char **why)
{
    if (!p || !s) return CTL_BAD_ARGUMENT;
    if (!isfinite(s->I)) return refuse(CTL_PID_INTEGRAL, "must be finite", field, why);
    if (!isfinite(s->D)) return refuse(CTL_PID_DERIVATIVE, "must be finite", field, why);
    if (!isfinite(s->ed_prev)) return refuse(CTL_PID_ED_PREV, "must be finite", field, why);
    if (s->started != 0.0 && s->started != 1.0) return refuse(CTL_PID_STARTED, "must be 0 or 1", field, why);
    return CTL_OK;
}

int ctl_pid_tracking_time(const ctl_pid_params *p, double *Tt)
{
    if (!p || !Tt) return CTL_BAD_ARGUMENT;
    *Tt = p->Tt != 0.0 ? p->Tt : (p->Td > 0.0 ? sqrt(p->Ti * p->Td) : p->Ti);
    return CTL_OK;
}

int ctl_pid_reset(const ctl_pid_params *p, double integral, ctl_pid_state *s)
{
    if (!p || !s) return CTL_BAD_ARGUMENT;
    s->I = integral;
    s->D = 0.0;
    s->ed_prev = 0.0;
    s->started = 0.0;
    return CTL_OK;
}

static double clamp(double v, double lo, double hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

int ctl_pid_sample(const ctl_pid_params *p, ctl_pid_state *s, double r, double y, double u_ff, double *u)
{
    double Tt, Tf, bi, ad, bd, br, e, ed, ed_prev, D, v, out, di;
    if (!p || !s || !u) return CTL_BAD_ARGUMENT;
    if (!isfinite(r) || !isfinite(y) || !isfinite(u_ff)) return CTL_BAD_INPUT;
    /* the difference equations' coefficients (Astrom and Murray, Feedback Systems, 10.5) */
    ctl_pid_tracking_time(p, &Tt);
    Tf = p->Td / p->N;
    bi = p->Ti > 0.0 ? p->K * p->Ts / p->Ti : 0.0;
    ad = Tf / (Tf + p->Ts);
    bd = p->K * p->Td / (Tf + p->Ts);
    br = (p->Ti > 0.0 && Tt > 0.0) ? p->Ts / Tt : 0.0;
    e = r - y;
    ed = p->c * r - y;
    ed_prev = s->started != 0.0 ? s->ed_prev : ed;  /* no derivative kick on the first sample */
    D = ad * s->D + bd * (ed - ed_prev);
    v = p->K * (p->b * r - y) + s->I + D + u_ff;
    out = clamp(v, p->u_min, p->u_max);
    di = bi * e;
    if (p->anti_windup == CTL_AW_BACK_CALCULATION)
        di += br * (out - v);
    else if (p->anti_windup == CTL_AW_CONDITIONAL && ((v > p->u_max && di > 0.0) || (v < p->u_min && di < 0.0)))
        di = 0.0;
    if (!isfinite(D) || !isfinite(v) || !isfinite(s->I + di)) return CTL_NOT_FINITE;
    s->D = D;
    s->ed_prev = ed;
    s->started = 1.0;
    s->I += di;
    *u = out;
    return CTL_OK;
}

int ctl_pid_initial_output(const ctl_pid_params *p, double *u)
{
    if (!p || !u) return CTL_BAD_ARGUMENT;
    *u = clamp(0.0, p->u_min, p->u_max);
    return CTL_OK;
}
