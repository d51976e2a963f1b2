/* The PID law file (law.h) over controllers/kernel/ctl_pid.c: the FMU's
 * parameters are ctl_pid_params' doubles in order, its inputs setpoint,
 * measurement and feedforward, its output u, its state a ctl_pid_state. */
#include <string.h>

#include "ctl_pid.h"
#include "law.h"

/* the block's layout is the structs' (grubler.controllers.native_fmu declares it from them) */
typedef char params_fit[LAW_N_PARAMS * sizeof(double) == sizeof(ctl_pid_params) ? 1 : -1];
typedef char state_fits[LAW_N_STATE * sizeof(double) == sizeof(ctl_pid_state) ? 1 : -1];

int law_check(const double *param, int *field, const char **why) {
    ctl_pid_params p;
    memcpy(&p, param, sizeof p);
    return ctl_pid_check(&p, field, why);
}

int law_check_state(const double *param, const double *state, int *field, const char **why) {
    ctl_pid_params p;
    ctl_pid_state s;
    memcpy(&p, param, sizeof p);
    memcpy(&s, state, sizeof s);
    return ctl_pid_check_state(&p, &s, field, why);
}

const char *law_state_name(int field) { return ctl_pid_field_name(field); }

int law_prepare(const double *param, double *scratch) {
    (void)param;
    (void)scratch;
    return CTL_OK;
}

int law_start(const double *param, const double *scratch, double t0, double *state, double *out) {
    ctl_pid_params p;
    ctl_pid_state s;
    int st;
    (void)scratch;
    (void)t0;
    memcpy(&p, param, sizeof p);
    if ((st = ctl_pid_reset(&p, 0.0, &s)) != CTL_OK) return st;
    memcpy(state, &s, sizeof s);
    return ctl_pid_initial_output(&p, &out[0]);
}

int law_sample(const double *param, const double *scratch, double *state, double t, const double *in, double *out) {
    ctl_pid_params p;
    ctl_pid_state s;
    double u;
    int st;
    (void)scratch;
    (void)t;
    memcpy(&p, param, sizeof p);
    memcpy(&s, state, sizeof s);
    if ((st = ctl_pid_sample(&p, &s, in[0], in[1], in[2], &u)) != CTL_OK) return st;
    memcpy(state, &s, sizeof s);
    out[0] = u;
    return CTL_OK;
}
