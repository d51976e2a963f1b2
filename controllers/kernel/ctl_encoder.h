/* ctl_encoder: the position sensor of grubler.controllers.encoder (stated in
 * controllers/encoder.py's docstring): seeded Gaussian noise, the count
 * below, a pure delay of whole samples, a differencing speed estimate.
 *
 *   ctl_encoder_params p = { counts_per_rev, noise_std, seed, delay, Ts };
 *   ctl_encoder_state  s;  double history[delay + 1];   (caller-owned)
 *   ctl_encoder_check(&p, capacity, &field, &why)   delay + 1 <= capacity;
 *   ctl_encoder_reset(&p, &s)                        the generator seeded;
 *   ctl_encoder_measure(&p, &s, x, &m)               noise and count of one reading;
 *   ctl_encoder_sample(&p, &s, history, x, &position, &speed)   one sample.
 */
#ifndef CTL_ENCODER_H
#define CTL_ENCODER_H

#include "ctl_law.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ctl_encoder_params {
    double counts_per_rev;  /* counts per revolution, a whole number; 0: no quantisation */
    double noise_std;       /* standard deviation of the additive noise [rad], >= 0 */
    double seed;            /* seed of the noise generator, a whole number >= 0 */
    double delay;           /* pure delay [samples], a whole number >= 0 */
    double Ts;              /* sample time [s], > 0 */
} ctl_encoder_params;

enum ctl_encoder_field {
    CTL_ENC_COUNTS_PER_REV, CTL_ENC_NOISE_STD, CTL_ENC_SEED, CTL_ENC_DELAY, CTL_ENC_TS, CTL_ENC_N_PARAMS,
    CTL_ENC_STARTED = CTL_ENC_N_PARAMS, CTL_ENC_LAST, CTL_ENC_RNG, CTL_ENC_HEAD, CTL_ENC_HISTORY
};

/* What the encoder remembers besides its delay line. */
typedef struct ctl_encoder_state {
    double started;   /* 1 once a sample ran (the delay line and last hold readings) */
    double last;      /* the last measured position [rad], for the speed estimate */
    ctl_rng rng;      /* the noise generator */
    double head;      /* index of the oldest reading in the delay line */
} ctl_encoder_state;

CTL_API const char *ctl_encoder_field_name(int field);
/* capacity: the delay line's length the caller provides (delay + 1 must fit). */
CTL_API int ctl_encoder_check(const ctl_encoder_params *p, double capacity, int *field, const char **why);
CTL_API int ctl_encoder_check_state(const ctl_encoder_params *p, const ctl_encoder_state *s, const double *history,
                                    int *field, const char **why);
CTL_API int ctl_encoder_reset(const ctl_encoder_params *p, ctl_encoder_state *s);
CTL_API int ctl_encoder_measure(const ctl_encoder_params *p, ctl_encoder_state *s, double x, double *m);
CTL_API int ctl_encoder_sample(const ctl_encoder_params *p, ctl_encoder_state *s, double *history, double x,
                               double *position, double *speed);

#ifdef __cplusplus
}
#endif
#endif
