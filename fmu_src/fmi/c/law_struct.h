/* law_struct.h: the law.h functions of a law whose parameters and state are
 * each one plain struct of doubles (the PID, the cascade, the analog sensors).
 * A law file defines these, then includes this header:
 *
 *   LAW_PARAMS, LAW_STATE            the two struct types
 *   LAW_CHECK, LAW_CHECK_STATE       their checks (params, field, why) and (params, state, field, why)
 *   LAW_FIELD_NAME                   the field names of both
 *   LAW_RESET(p, s)                  the state at the start
 *   LAW_INITIAL(p, out)              the outputs before the first sample
 *   LAW_SAMPLE(p, s, in, out)        one sample
 *
 * The block holds the structs' doubles in field order (the ModelSpec declares
 * them from the same structs); they are copied in and out, never aliased. */
#ifndef GRB_LAW_STRUCT_H
#define GRB_LAW_STRUCT_H

#include <string.h>

#include "law.h"

typedef char law_params_fit[LAW_N_PARAMS * sizeof(double) == sizeof(LAW_PARAMS) ? 1 : -1];
typedef char law_state_fits[LAW_N_STATE * sizeof(double) == sizeof(LAW_STATE) ? 1 : -1];

int law_check(const double *param, double *work, int *field, const char **why) {
    LAW_PARAMS p;
    (void)work;
    memcpy(&p, param, sizeof p);
    return LAW_CHECK(&p, field, why);
}

int law_check_state(const double *param, const double *state, int *field, const char **why) {
    LAW_PARAMS p;
    LAW_STATE s;
    memcpy(&p, param, sizeof p);
    memcpy(&s, state, sizeof s);
    return LAW_CHECK_STATE(&p, &s, field, why);
}

const char *law_state_name(int field) { return LAW_FIELD_NAME(field); }

int law_start(const double *param, const double *scratch, double t0, double *state, double *out) {
    LAW_PARAMS p;
    LAW_STATE s;
    int st;
    (void)scratch;
    (void)t0;
    memcpy(&p, param, sizeof p);
    if ((st = LAW_RESET(&p, &s)) != CTL_OK) return st;
    memcpy(state, &s, sizeof s);
    return LAW_INITIAL(&p, out);
}

int law_sample(const double *param, double *scratch, double *state, double t, const double *in, double *out) {
    LAW_PARAMS p;
    LAW_STATE s;
    int st;
    (void)scratch;
    (void)t;
    memcpy(&p, param, sizeof p);
    memcpy(&s, state, sizeof s);
    if ((st = LAW_SAMPLE(&p, &s, in, out)) != CTL_OK) return st;  /* all or nothing: s is kept only on success */
    memcpy(state, &s, sizeof s);
    return CTL_OK;
}

#endif
