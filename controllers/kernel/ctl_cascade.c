/* ctl_cascade: the cascade of ctl_cascade.h. */
#include "ctl_cascade.h"

#include <math.h>
#include <stddef.h>

static const char *const FIELD_NAMES[] = {
    "K_position", "Ti_position", "K_speed", "Ti_speed", "velocity_feedforward", "speed_limit", "u_min", "u_max",
    "Tt_speed", "Ts", "K_current", "Ti_current", "current_limit", "position_loop", "speed_loop", "speed_setpoint",
    "current_loop", "current_setpoint"};

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
    if (!(p->K_current >= 0.0) || !isfinite(p->K_current))
        return refuse(CTL_CAS_K_CURRENT, "must be finite and >= 0 (0: no current loop)", field, why);
    if (!(p->Ti_current >= 0.0) || !isfinite(p->Ti_current))
        return refuse(CTL_CAS_TI_CURRENT, "must be finite and >= 0 (0: a P loop)", field, why);
    if (!(p->current_limit > 0.0) || !isfinite(p->current_limit))
        return refuse(CTL_CAS_CURRENT_LIMIT, "must be finite and > 0", field, why);
    return CTL_OK;
}

int ctl_cascade_loops(const ctl_cascade_params *p, ctl_pid_params *position_loop, ctl_pid_params *speed_loop,
                      ctl_pid_params *current_loop)
{
    const ctl_pid_params plain = {1.0, 0.0, 0.0, 10.0, 1.0, 1.0, 1e-3, -1e300, 1e300, CTL_AW_BACK_CALCULATION, 0.0};
    if (!p || !position_loop || !speed_loop || !current_loop) return CTL_BAD_ARGUMENT;
    /* P or PI, limited to the speed limit with back-calculation */
    *position_loop = plain;
    position_loop->K = p->K_position;
    position_loop->Ti = p->Ti_position;
    position_loop->Ts = p->Ts;
    position_loop->u_min = -p->speed_limit;
    position_loop->u_max = p->speed_limit;
    /* PI on the speed error, limited to [u_min, u_max], or with a current loop to the current limit */
    *speed_loop = plain;
    speed_loop->K = p->K_speed;
    speed_loop->Ti = p->Ti_speed;
    speed_loop->Ts = p->Ts;
    speed_loop->u_min = p->K_current > 0.0 ? -p->current_limit : p->u_min;
    speed_loop->u_max = p->K_current > 0.0 ? p->current_limit : p->u_max;
    speed_loop->Tt = p->Tt_speed;
    /* PI on the current error, limited to [u_min, u_max] (used when K_current > 0) */
    *current_loop = plain;
    current_loop->K = p->K_current;
    current_loop->Ti = p->Ti_current;
    current_loop->Ts = p->Ts;
    current_loop->u_min = p->u_min;
    current_loop->u_max = p->u_max;
    return CTL_OK;
}

int ctl_cascade_check_state(const ctl_cascade_params *p, const ctl_cascade_state *s, int *field, const char **why)
{
    ctl_pid_params outer, inner, current;
    if (!p || !s) return CTL_BAD_ARGUMENT;
    ctl_cascade_loops(p, &outer, &inner, &current);
    if (ctl_pid_check_state(&outer, &s->position_loop, NULL, why) != CTL_OK)
        return refuse(CTL_CAS_POSITION_LOOP, why ? *why : "", field, why);
    if (ctl_pid_check_state(&inner, &s->speed_loop, NULL, why) != CTL_OK)
        return refuse(CTL_CAS_SPEED_LOOP, why ? *why : "", field, why);
    if (!isfinite(s->speed_setpoint)) return refuse(CTL_CAS_SPEED_SETPOINT, "must be finite", field, why);
    if (ctl_pid_check_state(&current, &s->current_loop, NULL, why) != CTL_OK)
        return refuse(CTL_CAS_CURRENT_LOOP, why ? *why : "", field, why);
    if (!isfinite(s->current_setpoint)) return refuse(CTL_CAS_CURRENT_SETPOINT, "must be finite", field, why);
    return CTL_OK;
}

int ctl_cascade_reset(const ctl_cascade_params *p, ctl_cascade_state *s)
{
    ctl_pid_params outer, inner, current;
    if (!p || !s) return CTL_BAD_ARGUMENT;
    ctl_cascade_loops(p, &outer, &inner, &current);
    ctl_pid_reset(&outer, 0.0, &s->position_loop);
    ctl_pid_reset(&inner, 0.0, &s->speed_loop);
    ctl_pid_reset(&current, 0.0, &s->current_loop);
    s->speed_setpoint = 0.0;
    s->current_setpoint = 0.0;
    return CTL_OK;
}

int ctl_cascade_sample(const ctl_cascade_params *p, ctl_cascade_state *s, double position_setpoint,
                       double velocity_setpoint, double position, double speed, double current, double *u)
{
    ctl_pid_params outer, inner, current_loop;
    ctl_cascade_state next;
    double speed_setpoint, speed_output;
    int st;
    if (!p || !s || !u) return CTL_BAD_ARGUMENT;
    if (!isfinite(velocity_setpoint) || !isfinite(speed) || !isfinite(current)) return CTL_BAD_INPUT;
    ctl_cascade_loops(p, &outer, &inner, &current_loop);
    next = *s;  /* all or nothing: an outer loop moves only if the inner ones can */
    st = ctl_pid_sample(&outer, &next.position_loop, position_setpoint, position,
                        p->velocity_feedforward * velocity_setpoint, &speed_setpoint);
    if (st != CTL_OK) return st;
    if ((st = ctl_pid_sample(&inner, &next.speed_loop, speed_setpoint, speed, 0.0, &speed_output)) != CTL_OK)
        return st;
    next.speed_setpoint = speed_setpoint;
    if (p->K_current > 0.0) {  /* the speed loop's output is the current setpoint */
        st = ctl_pid_sample(&current_loop, &next.current_loop, speed_output, current, 0.0, u);
        if (st != CTL_OK) return st;
        next.current_setpoint = speed_output;
    } else {
        *u = speed_output;
    }
    *s = next;
    return CTL_OK;
}

int ctl_cascade_initial_output(const ctl_cascade_params *p, double *u)
{
    ctl_pid_params outer, inner, current;
    if (!p || !u) return CTL_BAD_ARGUMENT;
    ctl_cascade_loops(p, &outer, &inner, &current);
    return ctl_pid_initial_output(p->K_current > 0.0 ? &current : &inner, u);
}
