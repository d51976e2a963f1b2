/* ctl_sensor: the analog sensor of ctl_sensor.h. */
#include "ctl_sensor.h"

#include <math.h>
#include <stddef.h>

#define TWO_PI 6.283185307179586

static const char *const FIELD_NAMES[] = {
    "gain_error", "offset", "noise_std", "seed", "bandwidth", "Ts", "started", "filtered", "rng"};

const char *ctl_sensor_field_name(int field)
{
    return ctl_name(FIELD_NAMES, (int)(sizeof FIELD_NAMES / sizeof FIELD_NAMES[0]), field);
}

static int refuse(int f, const char *rule, int *field, const char **why)
{
    return ctl_refuse(f, CTL_SEN_N_PARAMS, rule, field, why);
}

int ctl_sensor_check(const ctl_sensor_params *p, int *field, const char **why)
{
    if (!p) return CTL_BAD_ARGUMENT;
    if (!(p->gain_error > -1.0) || !isfinite(p->gain_error))
        return refuse(CTL_SEN_GAIN_ERROR, "must be finite and > -1 (the gain stays positive)", field, why);
    if (!isfinite(p->offset)) return refuse(CTL_SEN_OFFSET, "must be finite", field, why);
    if (!(p->noise_std >= 0.0) || !isfinite(p->noise_std))
        return refuse(CTL_SEN_NOISE_STD, "must be finite and >= 0", field, why);
    if (!(p->seed >= 0.0 && p->seed <= 9007199254740991.0 && p->seed == floor(p->seed)))
        return refuse(CTL_SEN_SEED, "must be a whole number >= 0", field, why);
    if (!(p->bandwidth >= 0.0) || !isfinite(p->bandwidth))
        return refuse(CTL_SEN_BANDWIDTH, "must be finite and >= 0 (0: instantaneous)", field, why);
    if (!(p->Ts > 0.0) || !isfinite(p->Ts)) return refuse(CTL_SEN_TS, "sample time must be finite and > 0", field, why);
    return CTL_OK;
}

int ctl_sensor_check_state(const ctl_sensor_params *p, const ctl_sensor_state *s, int *field, const char **why)
{
    if (!p || !s) return CTL_BAD_ARGUMENT;
    if (s->started != 0.0 && s->started != 1.0) return refuse(CTL_SEN_STARTED, "must be 0 or 1", field, why);
    if (!isfinite(s->filtered)) return refuse(CTL_SEN_FILTERED, "must be finite", field, why);
    if (ctl_rng_check(&s->rng) != CTL_OK)
        return refuse(CTL_SEN_RNG, "must be two whole numbers in [0, 2^32)", field, why);
    return CTL_OK;
}

int ctl_sensor_reset(const ctl_sensor_params *p, ctl_sensor_state *s)
{
    if (!p || !s) return CTL_BAD_ARGUMENT;
    s->started = 0.0;
    s->filtered = 0.0;
    return ctl_rng_seed(&s->rng, p->seed);
}

int ctl_sensor_sample(const ctl_sensor_params *p, ctl_sensor_state *s, double x, double *measured)
{
    double seen, filtered, z = 0.0;
    ctl_rng rng;
    int st;
    if (!p || !s || !measured) return CTL_BAD_ARGUMENT;
    if (!isfinite(x)) return CTL_BAD_INPUT;
    seen = (1.0 + p->gain_error) * x;
    /* the first-order response y' = 2 pi f (u - y) sampled exactly for an input
     * that steps just after a sample and holds: y_k = a y_k-1 + (1 - a) u_k,
     * a = exp(-2 pi f Ts), so a step has risen to 1 - a at the first sample that
     * sees it; the first sample starts settled, as the encoder's delay line starts full */
    if (s->started == 0.0 || p->bandwidth == 0.0) {
        filtered = seen;
    } else {
        double a = exp(-TWO_PI * p->bandwidth * p->Ts);
        filtered = a * s->filtered + (1.0 - a) * seen;
    }
    rng = s->rng;
    if (p->noise_std > 0.0 && (st = ctl_rng_normal(&rng, &z)) != CTL_OK) return st;
    if (!isfinite(filtered) || !isfinite(filtered + p->offset + p->noise_std * z)) return CTL_NOT_FINITE;
    s->filtered = filtered;
    s->rng = rng;
    s->started = 1.0;
    *measured = filtered + p->offset + p->noise_std * z;
    return CTL_OK;
}
