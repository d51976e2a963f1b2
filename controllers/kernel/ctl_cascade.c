/* ctl_cascade: the cascade of ctl_cascade.h. */
#include "ctl_cascade.h"

#include <math.h>
#include <stddef.h>

static const char *const FIELD_NAMES[] = {
    "K_position", "Ti_position", "K_speed", "Ti_speed", "velocity_feedforward", "speed_limit", "u_min", "u_max",
    "Tt_speed", "Ts", "position_loop", "speed_loop", "speed_setpoint"};

const char *ctl_cascade_field_name(int field)
{
    return ctl_name(FIELD_NAMES, (int)(sizeof FIELD_NAMES / sizeof FIELD_NAMES[0]), field);
}

static int refuse(int f, const char *rule, int *field, const char **why)
{
    return ctl_refuse(f, CTL_CAS_N_PARAMS, rule, field, why);
}

int ctl_cascade_check(const ctl_cascade_params *p, int *field, const char **why)
{
    if (!p) return CTL_BAD_ARGUMENT;
    /* in the order the library checks them, so an error names the cascade's field, not an inner loop's */
    if (!(p->speed_limit > 0.0) || !isfinite(p->speed_limit))
        return refuse(CTL_CAS_SPEED_LIMIT, "must be finite and > 0", field, why);
    if (!isfinite(p->velocity_feedforward)) return refuse(CTL_CAS_VELOCITY_FEEDFORWARD, "must be finite", field, why);
    if (!isfinite(p->K_position)) return refuse(CTL_CAS_K_POSITION, "must be finite", field, why);
    if (!isfinite(p->K_speed)) return refuse(CTL_CAS_K_SPEED, "must be finite", field, why);
    if (!(p->Ti_position >= 0.0) || !isfinite(p->Ti_position))
        return refuse(CTL_CAS_TI_POSITION, "must be finite and >= 0 (0: a P loop)", field, why);
    if (!(p->Ti_speed >= 0.0) || !isfinite(p->Ti_speed))
        return refuse(CTL_CAS_TI_SPEED, "must be finite and >= 0 (0: a P loop)", field, why);
    if (!(p->Tt_speed >= 0.0) || !isfinite(p->Tt_speed))
        return refuse(CTL_CAS_TT_SPEED, "must be finite and >= 0 (0: Ti_speed)", field, why);
    if (!isfinite(p->u_min)) return refuse(CTL_CAS_U_MIN, "must be finite", field, why);
    if (!isfinite(p->u_max)) return refuse(CTL_CAS_U_MAX, "must be finite", field, why);
    if (!(p->u_min < p->u_max)) return refuse(CTL_CAS_U_MAX, "must exceed u_min", field, why);
    if (!(p->Ts > 0.0) || !isfinite(p->Ts)) return refuse(CTL_CAS_TS, "sample time must be finite and > 0", field, why);
    return CTL_OK;
}

int ctl_cascade_loops(const ctl_cascade_params *p, ctl_pid_params *position_loop, ctl_pid_params *speed_loop)
{
    const ctl_pid_params plain = {1.0, 0.0, 0.0, 10.0, 1.0, 1.0, 1e-3, -1e300, 1e300, CTL_AW_BACK_CALCULATION, 0.0};
    if (!p || !position_loop || !speed_loop) return CTL_BAD_ARGUMENT;
    /* P or PI, limited to the speed limit with back-calculation */
    *position_loop = plain;
    position_loop->K = p->K_position;
    position_loop->Ti = p->Ti_position;
    position_loop->Ts = p->Ts;
    position_loop->u_min = -p->speed_limit;
    position_loop->u_max = p->speed_limit;
    /* PI on the speed error, limited to [u_min, u_max] */
    *speed_loop = plain;
    speed_loop->K = p->K_speed;
    speed_loop->Ti = p->Ti_speed;
    speed_loop->Ts = p->Ts;
    speed_loop->u_min = p->u_min;
    speed_loop->u_max = p->u_max;
    speed_loop->Tt = p->Tt_speed;
    return CTL_OK;
}

int ctl_cascade_check_state(const ctl_cascade_params *p, const ctl_cascade_state *s, int *field, const char **why)
{
    ctl_pid_params outer, inner;
    if (!p || !s) return CTL_BAD_ARGUMENT;
    ctl_cascade_loops(p, &outer, &inner);
    if (ctl_pid_check_state(&outer, &s->position_loop, NULL, why) != CTL_OK)
        return refuse(CTL_CAS_POSITION_LOOP, why ? *why : "", field, why);
    if (ctl_pid_check_state(&inner, &s->speed_loop, NULL, why) != CTL_OK)
        return refuse(CTL_CAS_SPEED_LOOP, why ? *why : "", field, why);
    if (!isfinite(s->speed_setpoint)) return refuse(CTL_CAS_SPEED_SETPOINT, "must be finite", field, why);
    return CTL_OK;
}

int ctl_cascade_reset(const ctl_cascade_params *p, ctl_cascade_state *s)
{
    ctl_pid_params outer, inner;
    if (!p || !s) return CTL_BAD_ARGUMENT;
    ctl_cascade_loops(p, &outer, &inner);
    ctl_pid_reset(&outer, 0.0, &s->position_loop);
    ctl_pid_reset(&inner, 0.0, &s->speed_loop);
    s->speed_setpoint = 0.0;
    return CTL_OK;
}

int ctl_cascade_sample(const ctl_cascade_params *p, ctl_cascade_state *s, double position_setpoint,
                       double velocity_setpoint, double position, double speed, double *u)
{
    ctl_pid_params outer, inner;
    ctl_cascade_state next;
    double speed_setpoint;
    int st;
    if (!p || !s || !u) return CTL_BAD_ARGUMENT;
    if (!isfinite(velocity_setpoint) || !isfinite(speed)) return CTL_BAD_INPUT;
    ctl_cascade_loops(p, &outer, &inner);
    next = *s;  /* all or nothing: the outer loop moves only if the inner one can */
    st = ctl_pid_sample(&outer, &next.position_loop, position_setpoint, position,
                        p->velocity_feedforward * velocity_setpoint, &speed_setpoint);
    if (st != CTL_OK) return st;
    if ((st = ctl_pid_sample(&inner, &next.speed_loop, speed_setpoint, speed, 0.0, u)) != CTL_OK) return st;
    next.speed_setpoint = speed_setpoint;
    *s = next;
    return CTL_OK;
}

int ctl_cascade_initial_output(const ctl_cascade_params *p, double *u)
{
    ctl_pid_params outer, inner;
    if (!p || !u) return CTL_BAD_ARGUMENT;
    ctl_cascade_loops(p, &outer, &inner);
    return ctl_pid_initial_output(&inner, u);
}
