/* The law file (law.h) of a law written as one C function (grubler_law.h,
 * grubler export-law): its parameters finite and its sample time >= 0, its
 * state and outputs finite after every sample, all or nothing.
 *
 * All or nothing takes a copy of the state and the outputs for law_step to
 * work on: the copy sits in the scratch (grubler.controllers.native_fmu
 * sizes it LAW_N_STATE + MODEL_N_OUTPUTS doubles), never on the stack, where
 * a state at the limit (GRUBLER_STATE(100000), 800 kB) would overflow an
 * importer's thread. */
#include <math.h>
#include <string.h>

#include "grubler_law.h"
#include "law.h"

typedef char scratch_fits[LAW_N_SCRATCH == LAW_N_STATE + MODEL_N_OUTPUTS ? 1 : -1];

int law_check(const double *param, double *work, int *field, const char **why) {
    int k;
    (void)work;
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

int law_prepare(const double *param, double *scratch) {
    (void)param;
    (void)scratch;
    return CTL_OK;  /* nothing derived: the scratch is law_sample's working copy */
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

int law_sample(const double *param, double *scratch, double *state, double t, const double *in, double *out) {
    double *s = scratch, *o = scratch + LAW_N_STATE;
    int k;
    memcpy(s, state, LAW_N_STATE * sizeof(double));
    memcpy(o, out, MODEL_N_OUTPUTS * sizeof(double));
    if (law_step(param, s, t, in, o) != 0) return CTL_LAW_REFUSED;
    for (k = 0; k < LAW_N_STATE; k++)
        if (!isfinite(s[k])) return CTL_NOT_FINITE;
    for (k = 0; k < MODEL_N_OUTPUTS; k++)
        if (!isfinite(o[k])) return CTL_NOT_FINITE;
    memcpy(state, s, LAW_N_STATE * sizeof(double));
    memcpy(out, o, MODEL_N_OUTPUTS * sizeof(double));
    return CTL_OK;
}
