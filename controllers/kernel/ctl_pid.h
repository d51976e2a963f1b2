/* ctl_pid: the discrete PID of grubler.controllers.pid (the equations are
 * stated in controllers/pid.py's docstring).  C99, libm only.
 *
 *   ctl_pid_params p = { K, Ti, Td, N, b, c, Ts, u_min, u_max, anti_windup, Tt };
 *   ctl_pid_state  s;
 *   ctl_pid_check(&p, &field, &why)    once: CTL_BAD_PARAMETER names the field
 *       (ctl_pid_field_name(field)) and the rule it breaks;
 *   ctl_pid_reset(&p, integral, &s)    back to the start;
 *   ctl_pid_sample(&p, &s, r, y, u_ff, &u)   one sample: u, and s advanced
 *       (all or nothing: CTL_NOT_FINITE leaves s as it was);
 *   ctl_pid_initial_output(&p, &u)     the output before the first sample.
 *
 * The parameters are all doubles in the FMU's parameter order, so a model
 * file reads them from its block as they are (anti_windup as the index of
 * back-calculation, conditional, none).
 */
#ifndef CTL_PID_H
#define CTL_PID_H

#include "ctl_law.h"

#ifdef __cplusplus
extern "C" {
#endif

enum ctl_anti_windup { CTL_AW_BACK_CALCULATION = 0, CTL_AW_CONDITIONAL = 1, CTL_AW_NONE = 2 };

typedef struct ctl_pid_params {
    double K;            /* proportional gain [unit of u per unit of the error] */
    double Ti, Td;       /* integral and derivative times [s]; 0 switches the action off */
    double N;            /* derivative filter Tf = Td / N [1], > 0 */
    double b, c;         /* setpoint weights of the proportional and derivative actions [1] */
    double Ts;           /* sample time [s], > 0 */
    double u_min, u_max; /* output limits, u_min < u_max (+-1e300: none) */
    double anti_windup;  /* enum ctl_anti_windup */
    double Tt;           /* tracking time of the back-calculation [s]; 0: sqrt(Ti Td), or Ti without Td */
} ctl_pid_params;

enum ctl_pid_field {
    CTL_PID_K, CTL_PID_TI, CTL_PID_TD, CTL_PID_N, CTL_PID_B, CTL_PID_C, CTL_PID_TS, CTL_PID_U_MIN, CTL_PID_U_MAX,
    CTL_PID_ANTI_WINDUP, CTL_PID_TT, CTL_PID_N_PARAMS,
    /* fields of ctl_pid_state, for ctl_pid_check_state */
    CTL_PID_INTEGRAL = CTL_PID_N_PARAMS, CTL_PID_DERIVATIVE, CTL_PID_ED_PREV, CTL_PID_STARTED
};

/* What the PID remembers between samples. */
typedef struct ctl_pid_state {
    double I;            /* integral action [unit of u] */
    double D;            /* filtered derivative action [unit of u] */
    double ed_prev;      /* last derivative error c r - y */
    double started;      /* 1 once a sample ran (ed_prev holds a value) */
} ctl_pid_state;

CTL_API const char *ctl_pid_field_name(int field);
CTL_API int ctl_pid_check(const ctl_pid_params *p, int *field, const char **why);
CTL_API int ctl_pid_check_state(const ctl_pid_params *p, const ctl_pid_state *s, int *field, const char **why);
/* The tracking time the back-calculation uses (Tt, or its default). */
CTL_API int ctl_pid_tracking_time(const ctl_pid_params *p, double *Tt);
CTL_API int ctl_pid_reset(const ctl_pid_params *p, double integral, ctl_pid_state *s);
CTL_API int ctl_pid_sample(const ctl_pid_params *p, ctl_pid_state *s, double r, double y, double u_ff, double *u);
CTL_API int ctl_pid_initial_output(const ctl_pid_params *p, double *u);

#ifdef __cplusplus
}
#endif
#endif
