/* The linear controller law file (law.h) over controllers/kernel/ctl_linear.c,
 * for the native FMU of one discretised controller (LINEAR_ORDER states): the
 * FMU's parameters are Ts, then A (row-major), B, C and D, as
 * ctl_linear_sample reads them; its inputs setpoint, measurement and
 * feedforward, its output u, its state x. */
#include <math.h>

#include "ctl_linear.h"
#include "law.h"

#define N LINEAR_ORDER
typedef char params_fit[LAW_N_PARAMS == 1 + CTL_LINEAR_SIZE(N) ? 1 : -1];
typedef char state_fits[LAW_N_STATE == N ? 1 : -1];

int law_check(const double *param, double *work, int *field, const char **why) {
    int k;
    (void)work;
    if (!(param[0] > 0.0) || !isfinite(param[0]))
        return ctl_refuse(0, LAW_N_PARAMS, "sample time must be finite and > 0", field, why);
    for (k = 1; k < LAW_N_PARAMS; k++)  /* the entry itself is named: A[2,1], B[1], ... */
        if (!isfinite(param[k])) return ctl_refuse(k, LAW_N_PARAMS, "must be finite", field, why);
    return CTL_OK;
}

int law_check_state(const double *param, const double *state, int *field, const char **why) {
    int st;
    (void)param;
    st = ctl_linear_check_state(N, state, field, why);
    if (st != CTL_OK && field) *field = LAW_N_PARAMS;
    return st;
}

const char *law_state_name(int field) {
    (void)field;
    return "x";
}

int law_start(const double *param, const double *scratch, double t0, double *state, double *out) {
    int k;
    (void)param;
    (void)scratch;
    (void)t0;
    for (k = 0; k < N; k++) state[k] = 0.0;
    out[0] = 0.0;
    return CTL_OK;
}

int law_sample(const double *param, double *scratch, double *state, double t, const double *in, double *out) {
    double work[N > 0 ? N : 1];
    (void)scratch;
    (void)t;
    return ctl_linear_sample(N, param + 1, state, in[0], in[1], in[2], &out[0], work);
}
