/* ctl_sensor: an analog sensor (a tachometer, a current sensor) of
 * grubler.controllers.sensors (controllers/sensors.py's docstring): gain
 * error, offset, first-order bandwidth and seeded Gaussian noise, sampled.
 *
 *   ctl_sensor_params p = { gain_error, offset, noise_std, seed, bandwidth, Ts };
 *   ctl_sensor_state  s;
 *   ctl_sensor_check(&p, &field, &why);  ctl_sensor_reset(&p, &s);
 *   ctl_sensor_sample(&p, &s, x, &measured)   one sample of the true value x.
 */
#ifndef CTL_SENSOR_H
#define CTL_SENSOR_H

#include "ctl_law.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ctl_sensor_params {
    double gain_error;   /* relative error of the gain [1]: it reads (1 + gain_error) x */
    double offset;       /* added to the reading [unit of x] */
    double noise_std;    /* standard deviation of the additive noise [unit of x], >= 0 */
    double seed;         /* seed of the noise generator, a whole number >= 0 */
    double bandwidth;    /* -3 dB frequency of the first-order response [Hz]; 0: none (instantaneous) */
    double Ts;           /* sample time [s], > 0 */
} ctl_sensor_params;

enum ctl_sensor_field {
    CTL_SEN_GAIN_ERROR, CTL_SEN_OFFSET, CTL_SEN_NOISE_STD, CTL_SEN_SEED, CTL_SEN_BANDWIDTH, CTL_SEN_TS,
    CTL_SEN_N_PARAMS, CTL_SEN_STARTED = CTL_SEN_N_PARAMS, CTL_SEN_FILTERED, CTL_SEN_RNG
};

typedef struct ctl_sensor_state {
    double started;      /* 1 once a sample ran */
    double filtered;     /* the first-order response's output, before offset and noise */
    ctl_rng rng;         /* the noise generator */
} ctl_sensor_state;

CTL_API const char *ctl_sensor_field_name(int field);
CTL_API int ctl_sensor_check(const ctl_sensor_params *p, int *field, const char **why);
CTL_API int ctl_sensor_check_state(const ctl_sensor_params *p, const ctl_sensor_state *s, int *field,
                                   const char **why);
CTL_API int ctl_sensor_reset(const ctl_sensor_params *p, ctl_sensor_state *s);
CTL_API int ctl_sensor_sample(const ctl_sensor_params *p, ctl_sensor_state *s, double x, double *measured);

#ifdef __cplusplus
}
#endif
#endif
