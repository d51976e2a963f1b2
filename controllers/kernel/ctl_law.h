/* ctl_law: what every control law of grubler.controllers shares in C: the
 * status codes, the sample-and-hold clock (the semantics stated in
 * controllers/law.py), and a seeded noise generator.  C99, libm only.
 *
 * One implementation: the Python Sampler (grubler.controllers.law) asks
 * ctl_samples_due which sample instants a communication step holds, and the
 * native law FMUs (fmu_src/fmi/c/law_model.c) ask the same function; the
 * sensors' noise comes from ctl_rng_normal in the library and in the FMU.
 *
 * API (every function but the two that name things returns a ctl_status; no
 * globals, no allocation: the caller owns every struct and buffer):
 *
 *   ctl_samples_due(&clock, samples, t, h, &n)   how many samples the step
 *       [t, t + h) runs, the first being sample number `samples` (the count
 *       run so far); ctl_sample_instant(&clock, samples, t, h, i, &when) is
 *       the time of the i-th of them.
 *   ctl_rng_seed(&rng, seed), ctl_rng_normal(&rng, &z)   a standard normal
 *       number from a 64-bit SplitMix generator whose state is two doubles
 *       (exact 32-bit halves), so that an FMU state can hold and check it.
 *   ctl_status_message(status): a sentence for a log.
 */
#ifndef CTL_LAW_H
#define CTL_LAW_H

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32) && defined(GRB_SHARED)
#define CTL_API __declspec(dllexport)
#else
#define CTL_API
#endif

typedef enum ctl_status {
    CTL_OK = 0,
    CTL_BAD_PARAMETER,     /* a check: field and why say which and how */
    CTL_BAD_STATE,         /* a state set from outside that the law never reaches */
    CTL_BAD_INPUT,         /* an input is not finite */
    CTL_BAD_STEP_SIZE,     /* a communication step not positive and finite */
    CTL_TOO_MANY_SAMPLES,  /* a step holding more than CTL_MAX_SAMPLES_PER_STEP samples */
    CTL_NOT_FINITE,        /* a sample made an output or the state overflow to inf or NaN */
    CTL_BAD_ARGUMENT,      /* a NULL pointer, or a buffer too small */
    CTL_LAW_REFUSED,       /* a user's law_step (grubler_law.h) returned a failure */
    CTL_MECHANISM_REFUSED  /* the mechanism cannot take the motion asked (computed torque) */
} ctl_status;

/* A sample instant within this fraction of Ts of a step's end belongs to the
 * next step: communication points accumulated in floating point (0.1 + 0.2)
 * miss the sample grid by a few ulps. */
#define CTL_GRID_TOL 1e-7
/* Samples one communication step may run: a step of 100 s at 1 kHz.  A longer
 * step is refused rather than computed for minutes (or for ever: h = 1e300). */
#define CTL_MAX_SAMPLES_PER_STEP 100000

/* When a law samples. */
typedef struct ctl_clock {
    double t0;          /* start time [s]: the first sample instant */
    double Ts;          /* sample time [s]; 0: once per communication step, at its start */
    int continuous;     /* 1: a law of time alone, evaluated at the end of each step (t + h) */
} ctl_clock;

/* The seeded generator's state: the 64-bit SplitMix state as two 32-bit halves. */
typedef struct ctl_rng {
    double hi, lo;
} ctl_rng;

CTL_API const char *ctl_status_message(int status);

/* What a law's check returns: *field = f and *why = rule (either may be NULL),
 * CTL_BAD_PARAMETER for a parameter (f < n_params), else CTL_BAD_STATE. */
CTL_API int ctl_refuse(int f, int n_params, const char *rule, int *field, const char **why);

/* names[field] of a table of count names, or NULL outside it. */
CTL_API const char *ctl_name(const char *const *names, int count, int field);

/* *n samples in the step from t to t + h: CTL_BAD_STEP_SIZE for h not positive
 * and finite, CTL_TOO_MANY_SAMPLES (*n then the count asked for, capped) for
 * more than CTL_MAX_SAMPLES_PER_STEP. */
CTL_API int ctl_samples_due(const ctl_clock *c, double samples, double t, double h, double *n);

/* The time of the i-th (from 0) sample of that step. */
CTL_API int ctl_sample_instant(const ctl_clock *c, double samples, double t, double h, double i, double *when);

/* The generator seeded with a whole number 0 <= seed < 2^53. */
CTL_API int ctl_rng_seed(ctl_rng *r, double seed);

/* CTL_OK when the state's halves are whole numbers in [0, 2^32). */
CTL_API int ctl_rng_check(const ctl_rng *r);

/* One standard normal number (Box-Muller on two 53-bit uniforms). */
CTL_API int ctl_rng_normal(ctl_rng *r, double *z);

#ifdef __cplusplus
}
#endif
#endif
