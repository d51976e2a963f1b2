/* ctl_encoder: the encoder of ctl_encoder.h. */
#include "ctl_encoder.h"

#include <math.h>
#include <stddef.h>

#define TWO_PI 6.283185307179586

static const char *const FIELD_NAMES[] = {
    "counts_per_rev", "noise_std", "seed", "delay", "Ts", "started", "last", "rng", "head", "history"};

const char *ctl_encoder_field_name(int field)
{
    return ctl_name(FIELD_NAMES, (int)(sizeof FIELD_NAMES / sizeof FIELD_NAMES[0]), field);
}

static int refuse(int f, const char *rule, int *field, const char **why)
{
    return ctl_refuse(f, CTL_ENC_N_PARAMS, rule, field, why);
}

static int whole(double x, double most)
{
    return x >= 0.0 && x <= most && x == floor(x);
}

int ctl_encoder_check(const ctl_encoder_params *p, double capacity, int *field, const char **why)
{
    if (!p) return CTL_BAD_ARGUMENT;
    if (!whole(p->counts_per_rev, 2147483647.0))
        return refuse(CTL_ENC_COUNTS_PER_REV, "must be a whole number >= 0 (0: no quantisation)", field, why);
    if (!(p->noise_std >= 0.0) || !isfinite(p->noise_std))
        return refuse(CTL_ENC_NOISE_STD, "must be finite and >= 0", field, why);
    if (!whole(p->seed, 9007199254740991.0))
        return refuse(CTL_ENC_SEED, "must be a whole number >= 0", field, why);
    if (!whole(p->delay, 2147483647.0)) return refuse(CTL_ENC_DELAY, "must be a whole number >= 0", field, why);
    if (p->delay + 1.0 > capacity) return refuse(CTL_ENC_DELAY, "exceeds the delay line's length", field, why);
    if (!(p->Ts > 0.0) || !isfinite(p->Ts))
        return refuse(CTL_ENC_TS, "sample time must be finite and > 0", field, why);
    return CTL_OK;
}

int ctl_encoder_check_state(const ctl_encoder_params *p, const ctl_encoder_state *s, const double *history,
                            int *field, const char **why)
{
    if (!p || !s || !history) return CTL_BAD_ARGUMENT;
    if (s->started != 0.0 && s->started != 1.0) return refuse(CTL_ENC_STARTED, "must be 0 or 1", field, why);
    if (!isfinite(s->last)) return refuse(CTL_ENC_LAST, "must be finite", field, why);
    if (ctl_rng_check(&s->rng) != CTL_OK)
        return refuse(CTL_ENC_RNG, "must be two whole numbers in [0, 2^32)", field, why);
    if (!whole(s->head, p->delay)) return refuse(CTL_ENC_HEAD, "must be a whole number in [0, delay]", field, why);
    for (long k = 0; k <= (long)p->delay; k++)
        if (!isfinite(history[k])) return refuse(CTL_ENC_HISTORY, "must hold finite readings", field, why);
    return CTL_OK;
}

int ctl_encoder_reset(const ctl_encoder_params *p, ctl_encoder_state *s)
{
    if (!p || !s) return CTL_BAD_ARGUMENT;
    s->started = 0.0;
    s->last = 0.0;
    s->head = 0.0;
    return ctl_rng_seed(&s->rng, p->seed);
}

int ctl_encoder_measure(const ctl_encoder_params *p, ctl_encoder_state *s, double x, double *m)
{
    double z, q;
    if (!p || !s || !m) return CTL_BAD_ARGUMENT;
    if (!isfinite(x)) return CTL_BAD_INPUT;
    if (p->noise_std > 0.0) {
        int st = ctl_rng_normal(&s->rng, &z);
        if (st != CTL_OK) return st;
        x = x + p->noise_std * z;
    }
    q = p->counts_per_rev > 0.0 ? TWO_PI / p->counts_per_rev : 0.0;
    *m = q > 0.0 ? floor(x / q) * q : x;
    return CTL_OK;
}

int ctl_encoder_sample(const ctl_encoder_params *p, ctl_encoder_state *s, double *history, double x,
                       double *position, double *speed)
{
    long length, head, k;
    double m, out;
    int st;
    if (!p || !s || !history || !position || !speed) return CTL_BAD_ARGUMENT;
    if ((st = ctl_encoder_measure(p, s, x, &m)) != CTL_OK) return st;
    length = (long)p->delay + 1;
    /* a ring of delay + 1 readings, head at the oldest: the reading delay samples ago */
    if (s->started == 0.0) {
        for (k = 0; k < length; k++) history[k] = m;  /* the first sample fills the line */
        head = 0;
    } else {
        head = (long)s->head;
        history[head] = m;
        head = (head + 1) % length;
    }
    out = history[head];
    *speed = s->started != 0.0 ? (out - s->last) / p->Ts : 0.0;
    *position = out;
    s->head = (double)head;
    s->last = out;
    s->started = 1.0;
    return CTL_OK;
}
