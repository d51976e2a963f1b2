/* The law file (law.h) of a law written as one C function (grubler_law.h,
 * grubler export-law): its parameters finite and its sample time >= 0, its
 * state and outputs finite after every sample, all or nothing. */
#include <math.h>
#include <string.h>

#include "grubler_law.h"
#include "law.h"

#define N_STATE (LAW_N_STATE > 0 ? LAW_N_STATE : 1)

int law_check(const double *param, int *field, const char **why) {
    int k;
    for (k = 0; k < LAW_N_PARAMS; k++)
        if (!isfinite(param[k])) return ctl_refuse(k, LAW_N_PARAMS, "must be finite", field, why);
    if (param[LAW_TS_SLOT] < 0.0)
        return ctl_refuse(LAW_TS_SLOT, LAW_N_PARAMS, "sample time must be >= 0 (0: once per communication step)",
                          field, why);
    return CTL_OK;
}

int law_check_state(const double *param, const double *state, int *field, const char **why) {
    int k;
    (void)param;
    for (k = 0; k < LAW_N_STATE; k++)
        if (!isfinite(state[k])) return ctl_refuse(LAW_N_PARAMS, LAW_N_PARAMS, "must hold finite numbers", field, why);
    return CTL_OK;
}

const char *law_state_name(int field) {
    (void)field;
    return "law";
}

int law_start(const double *param, const double *scratch, double t0, double *state, double *out) {
    int k;
    (void)param;
    (void)scratch;
    (void)t0;
    for (k = 0; k < LAW_N_STATE; k++) state[k] = 0.0;
    for (k = 0; k < MODEL_N_OUTPUTS; k++) out[k] = 0.0;
    return CTL_OK;
}

int law_sample(const double *param, const double *scratch, double *state, double t, const double *in, double *out) {
    double s[N_STATE], o[MODEL_N_OUTPUTS];
    int k;
    (void)scratch;
    memcpy(s, state, LAW_N_STATE * sizeof(double));
    memcpy(o, out, sizeof o);
    if (law_step(param, s, t, in, o) != 0) return CTL_LAW_REFUSED;
    for (k = 0; k < LAW_N_STATE; k++)
        if (!isfinite(s[k])) return CTL_NOT_FINITE;
    for (k = 0; k < MODEL_N_OUTPUTS; k++)
        if (!isfinite(o[k])) return CTL_NOT_FINITE;
    memcpy(state, s, LAW_N_STATE * sizeof(double));
    memcpy(out, o, sizeof o);
    return CTL_OK;
}
