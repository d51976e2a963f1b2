/* The encoder law file (law.h) over controllers/kernel/ctl_encoder.c: the
 * FMU's parameters are ctl_encoder_params' doubles in order, its input the
 * true position, its outputs measured_position and measured_speed; its state
 * a ctl_encoder_state and the delay line of ENCODER_CAPACITY readings. */
#include <string.h>

#include "ctl_encoder.h"
#include "law.h"

#define HEAD_DOUBLES (sizeof(ctl_encoder_state) / sizeof(double))
typedef char params_fit[LAW_N_PARAMS * sizeof(double) == sizeof(ctl_encoder_params) ? 1 : -1];
typedef char state_fits[LAW_N_STATE == HEAD_DOUBLES + ENCODER_CAPACITY ? 1 : -1];

int law_check(const double *param, double *work, int *field, const char **why) {
    ctl_encoder_params p;
    (void)work;
    memcpy(&p, param, sizeof p);
    return ctl_encoder_check(&p, (double)ENCODER_CAPACITY, field, why);
}

int law_check_state(const double *param, const double *state, int *field, const char **why) {
    ctl_encoder_params p;
    ctl_encoder_state s;
    memcpy(&p, param, sizeof p);
    memcpy(&s, state, sizeof s);
    return ctl_encoder_check_state(&p, &s, state + HEAD_DOUBLES, field, why);
}

const char *law_state_name(int field) { return ctl_encoder_field_name(field); }

int law_start(const double *param, const double *scratch, double t0, double *state, double *out) {
    ctl_encoder_params p;
    ctl_encoder_state s;
    int st, k;
    (void)scratch;
    (void)t0;
    memcpy(&p, param, sizeof p);
    if ((st = ctl_encoder_reset(&p, &s)) != CTL_OK) return st;
    memcpy(state, &s, sizeof s);
    for (k = 0; k < ENCODER_CAPACITY; k++) state[HEAD_DOUBLES + k] = 0.0;
    out[0] = out[1] = 0.0;
    return CTL_OK;
}

/* The delay line's part a run reads or writes: delay + 1 readings (ctl_encoder_sample's ring) of
 * ENCODER_CAPACITY.  (Parameters law_check refuses: the whole state.) */
long law_state_used(const double *param) {
    ctl_encoder_params p;
    memcpy(&p, param, sizeof p);
    if (!(p.delay >= 0.0 && p.delay + 1.0 <= (double)ENCODER_CAPACITY)) return LAW_N_STATE;
    return (long)HEAD_DOUBLES + (long)p.delay + 1;
}

int law_sample(const double *param, double *scratch, double *state, double t, const double *in, double *out) {
    ctl_encoder_params p;
    ctl_encoder_state s;
    double position, speed;
    int st;
    (void)scratch;
    (void)t;
    memcpy(&p, param, sizeof p);
    memcpy(&s, state, sizeof s);
    /* the delay line changes only with the rest of the sample: ctl_encoder_sample fails before writing it */
    if ((st = ctl_encoder_sample(&p, &s, state + HEAD_DOUBLES, in[0], &position, &speed)) != CTL_OK) return st;
    memcpy(state, &s, sizeof s);
    out[0] = position;
    out[1] = speed;
    return CTL_OK;
}
