/* ctl_cascade: the cascaded position, speed and (optional) current loops of
 * grubler.controllers.cascade (controllers/cascade.py's docstring): ctl_pid
 * loops sampled together, each one's output the next one's setpoint (the
 * position loop's plus the weighted setpoint velocity).  With K_current = 0
 * there is no current loop and the speed loop's output is u.
 *
 *   ctl_cascade_params p;  ctl_cascade_state s;
 *   ctl_cascade_check(&p, &field, &why);  ctl_cascade_reset(&p, &s);
 *   ctl_cascade_sample(&p, &s, position_setpoint, velocity_setpoint, position, speed, current, &u);
 *   ctl_cascade_loops(&p, &position_loop, &speed_loop, &current_loop): the PIDs' parameters.
 */
#ifndef CTL_CASCADE_H
#define CTL_CASCADE_H

#include "ctl_pid.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ctl_cascade_params {
    double K_position;            /* position loop gain [1/s] */
    double Ti_position;           /* its integral time [s]; 0: a P loop */
    double K_speed;               /* speed loop gain [unit of u per rad/s] */
    double Ti_speed;              /* its integral time [s]; 0: a P loop */
    double velocity_feedforward;  /* weight of the setpoint velocity added to the speed setpoint [1] */
    double speed_limit;           /* limit of the speed setpoint [rad/s], > 0 */
    double u_min, u_max;          /* output limits */
    double Tt_speed;              /* speed loop tracking time [s]; 0: Ti_speed */
    double Ts;                    /* sample time of the loops [s] */
    double K_current;             /* current loop gain [unit of u per A], >= 0; 0: no current loop */
    double Ti_current;            /* its integral time [s]; 0: a P loop */
    double current_limit;         /* limit of the current setpoint [A], > 0 (with a current loop) */
} ctl_cascade_params;

enum ctl_cascade_field {
    CTL_CAS_K_POSITION, CTL_CAS_TI_POSITION, CTL_CAS_K_SPEED, CTL_CAS_TI_SPEED, CTL_CAS_VELOCITY_FEEDFORWARD,
    CTL_CAS_SPEED_LIMIT, CTL_CAS_U_MIN, CTL_CAS_U_MAX, CTL_CAS_TT_SPEED, CTL_CAS_TS, CTL_CAS_K_CURRENT,
    CTL_CAS_TI_CURRENT, CTL_CAS_CURRENT_LIMIT, CTL_CAS_N_PARAMS,
    CTL_CAS_POSITION_LOOP = CTL_CAS_N_PARAMS, CTL_CAS_SPEED_LOOP, CTL_CAS_SPEED_SETPOINT, CTL_CAS_CURRENT_LOOP,
    CTL_CAS_CURRENT_SETPOINT
};

typedef struct ctl_cascade_state {
    ctl_pid_state position_loop;
    ctl_pid_state speed_loop;
    double speed_setpoint;        /* the last speed setpoint [rad/s] */
    ctl_pid_state current_loop;
    double current_setpoint;      /* the last current setpoint [A] (0 without a current loop) */
} ctl_cascade_state;

CTL_API const char *ctl_cascade_field_name(int field);
CTL_API int ctl_cascade_check(const ctl_cascade_params *p, int *field, const char **why);
CTL_API int ctl_cascade_check_state(const ctl_cascade_params *p, const ctl_cascade_state *s, int *field,
                                    const char **why);
CTL_API int ctl_cascade_loops(const ctl_cascade_params *p, ctl_pid_params *position_loop, ctl_pid_params *speed_loop,
                              ctl_pid_params *current_loop);
CTL_API int ctl_cascade_reset(const ctl_cascade_params *p, ctl_cascade_state *s);
CTL_API int ctl_cascade_sample(const ctl_cascade_params *p, ctl_cascade_state *s, double position_setpoint,
                               double velocity_setpoint, double position, double speed, double current, double *u);
CTL_API int ctl_cascade_initial_output(const ctl_cascade_params *p, double *u);

#ifdef __cplusplus
}
#endif
#endif
