/* ctl_law: the sample clock and the noise generator of ctl_law.h. */
#include "ctl_law.h"

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define TWO_PI 6.283185307179586

const char *ctl_status_message(int status)
{
    switch (status) {
    case CTL_OK: return "ok";
    case CTL_BAD_PARAMETER: return "a parameter is out of range";
    case CTL_BAD_STATE: return "the state is one the law never reaches";
    case CTL_BAD_INPUT: return "an input is not finite";
    case CTL_BAD_STEP_SIZE: return "the step size must be positive and finite";
    case CTL_TOO_MANY_SAMPLES: return "the step holds more than 100000 samples";
    case CTL_NOT_FINITE: return "a sample overflowed: an output or the law's state is not finite";
    case CTL_BAD_ARGUMENT: return "a NULL pointer or a buffer too small";
    case CTL_LAW_REFUSED: return "the law's step refused the sample (law_step returned non-zero)";
    case CTL_MECHANISM_REFUSED:
        return "the mechanism cannot take that drive position: its loop does not close there, or two assembly "
               "branches meet (a change point), where the drive's motion does not fix the others'";
    default: return "unknown status";
    }
}

int ctl_refuse(int f, int n_params, const char *rule, int *field, const char **why)
{
    if (field) *field = f;
    if (why) *why = rule;
    return f >= n_params ? CTL_BAD_STATE : CTL_BAD_PARAMETER;
}

const char *ctl_name(const char *const *names, int count, int field)
{
    return field < 0 || field >= count ? NULL : names[field];
}

int ctl_samples_due(const ctl_clock *c, double samples, double t, double h, double *n)
{
    double end, due, k;
    if (!c || !n) return CTL_BAD_ARGUMENT;
    *n = 0.0;
    if (!(h > 0.0) || !isfinite(h)) return CTL_BAD_STEP_SIZE;
    if (c->continuous || c->Ts == 0.0) {
        *n = 1.0;
        return CTL_OK;
    }
    end = t + h - CTL_GRID_TOL * c->Ts;
    due = (end - c->t0) / c->Ts - samples;  /* inf for a step of 1e300 s */
    if (due > CTL_MAX_SAMPLES_PER_STEP) {
        *n = due;
        return CTL_TOO_MANY_SAMPLES;
    }
    /* counted, not rounded: the grid test is the one a sample is run on */
    for (k = samples; c->t0 + k * c->Ts < end; k += 1.0) *n += 1.0;
    return CTL_OK;
}

int ctl_sample_instant(const ctl_clock *c, double samples, double t, double h, double i, double *when)
{
    if (!c || !when) return CTL_BAD_ARGUMENT;
    if (c->continuous) *when = t + h;
    else if (c->Ts == 0.0) *when = t;
    else *when = c->t0 + (samples + i) * c->Ts;
    return CTL_OK;
}

static uint64_t rng_state(const ctl_rng *r)
{
    return ((uint64_t)r->hi << 32) | (uint64_t)r->lo;
}

static void rng_store(ctl_rng *r, uint64_t x)
{
    r->hi = (double)(x >> 32);
    r->lo = (double)(x & 0xffffffffu);
}

int ctl_rng_seed(ctl_rng *r, double seed)
{
    if (!r) return CTL_BAD_ARGUMENT;
    if (!(seed >= 0.0 && seed < 9007199254740992.0 && seed == floor(seed))) return CTL_BAD_PARAMETER;
    rng_store(r, (uint64_t)seed);
    return CTL_OK;
}

int ctl_rng_check(const ctl_rng *r)
{
    if (!r) return CTL_BAD_ARGUMENT;
    if (!(r->hi >= 0.0 && r->hi < 4294967296.0 && r->hi == floor(r->hi)) ||
        !(r->lo >= 0.0 && r->lo < 4294967296.0 && r->lo == floor(r->lo)))
        return CTL_BAD_STATE;
    return CTL_OK;
}

/* SplitMix64 (Steele, Lea and Flood 2014): a Weyl sequence through a mixer */
static uint64_t next64(ctl_rng *r)
{
    uint64_t z = rng_state(r) + 0x9e3779b97f4a7c15ull;
    rng_store(r, z);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

int ctl_rng_normal(ctl_rng *r, double *z)
{
    double u1, u2;
    if (!r || !z) return CTL_BAD_ARGUMENT;
    if (ctl_rng_check(r) != CTL_OK) return CTL_BAD_STATE;
    u1 = ((double)(next64(r) >> 11) + 1.0) * 0x1p-53;  /* (0, 1]: log(u1) is finite */
    u2 = (double)(next64(r) >> 11) * 0x1p-53;          /* [0, 1) */
    *z = sqrt(-2.0 * log(u1)) * cos(TWO_PI * u2);
    return CTL_OK;
}
