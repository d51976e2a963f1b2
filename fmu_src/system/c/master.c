/* The co-simulation master's stepping loop (grubler.system.cosim), in C.
 *
 * Python plans, instantiates, initialises and records; this loop makes the
 * FMI calls of the communication steps themselves, so that a step costs the
 * FMUs' own work and little more (a Python loop paid a few microseconds per
 * FMU and step in ctypes calls and list indexing).  It calls the FMUs' own
 * fmi2SetReal, fmi2DoStep and fmi2GetReal through the pointers the master
 * found in each FMU's library, in the order the Python loop made them, with
 * the same arithmetic for the time: the results are the same bits.
 *
 * The same loop steps the components inside a system FMU (grubler export
 * SYSTEM.ssd, fmi/c/system_model.c includes this file): there the pointers are
 * each component model's own calls, compiled into the one binary.
 *
 * Plain structs, caller-owned memory, no globals; every function returns a
 * status (0: done, 1: an FMU refused a call, described in the failure record).
 *
 * The extrapolating master (GRB_EXTRAPOLATE) steps in the Gauss-Seidel order
 * but holds each continuous input of a continuous component at its value at
 * the step's midpoint instead of its start: the mean of a smooth input over the
 * step to O(h^2), so the coupling is second order where holding the start value
 * is first.  The midpoint is interpolated between the source's values at the
 * step's start and end when the source has already stepped, and extrapolated
 * from its last two communication points when it has not.  After the step, the
 * inputs are set to their end-of-step values before the outputs are read, so
 * an output that depends on an input now (a motor's torque on its speed) is
 * the end-of-step value too.  A sampled component (in_mode 0 on every input)
 * and a discrete source are stepped as Gauss-Seidel steps them: a sampled law
 * reads its inputs at the sample instant, and a discrete output is held.  It
 * needs nothing of an FMU beyond fmi2SetReal between fmi2DoStep and fmi2GetReal.
 */
/* GRB_MASTER_NO_CLOCK: no profiling clock, for a build that never profiles (the
 * system FMU, fmi/c/system_model.c, which includes this file: its binary then
 * needs nothing of the C library beyond what the models need) */
#ifndef GRB_MASTER_NO_CLOCK
#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#endif
#include <time.h>
#ifdef _WIN32
#include <windows.h>
#endif
#endif
#include <math.h>
#include <stddef.h>

#if defined(_WIN32) && defined(GRB_SHARED)
#define GRB_MASTER_API __declspec(dllexport)
#else
#define GRB_MASTER_API
#endif

/* FMI 2.0's calls as the ABI has them (fmi2Status is an int-sized enum,
   fmi2ValueReference an unsigned int, fmi2Boolean an int) */
typedef int (*grb_set_real_fn)(void *instance, const unsigned int *vr, size_t n, const double *value);
typedef int (*grb_get_real_fn)(void *instance, const unsigned int *vr, size_t n, double *value);
typedef int (*grb_do_step_fn)(void *instance, double t, double h, int no_set_fmu_state_prior);
typedef int (*grb_get_state_fn)(void *instance, void **state);
typedef int (*grb_set_state_fn)(void *instance, void *state);
typedef int (*grb_free_state_fn)(void *instance, void **state);

/* One FMU instance as the loop drives it: its calls, its wiring, its buffers. */
typedef struct {
    void *instance;
    grb_set_real_fn set_real;
    grb_get_real_fn get_real;
    grb_do_step_fn do_step;
    size_t n_in;              /* connected inputs */
    const unsigned int *in_vr;
    const int *in_slot;       /* where each input's value sits in the values */
    double *in_buf;
    size_t n_conn;            /* connected outputs: the first n_conn of read_vr */
    size_t n_read;            /* connected, then the rest recorded */
    const unsigned int *read_vr;
    double *read_buf;
    const int *out_slot;      /* where each connected output's value goes */
    double *seconds;          /* NULL, or three sums: setReal, doStep, getReal (s) */
    const int *in_mode;       /* NULL, or per input a grb_input_mode (the extrapolating master's) */
    int sampled;              /* adaptive: 1 steps once per communication step (a sampled law), 0 in sub-steps */
    grb_get_state_fn get_state; /* adaptive, a sub-stepped FMU: its FMU state calls, for rollback */
    grb_set_state_fn set_state;
    grb_free_state_fn free_state;
    void *state;              /* the state saved at a sub-step's start (the FMU's; grb_master_free_states) */
} grb_fmu;

/* How the extrapolating master sets an input over a step. */
enum grb_input_mode {
    GRB_INPUT_HELD = 0,         /* as Gauss-Seidel: its source's latest value */
    GRB_INPUT_INTERPOLATED = 1, /* midpoint of its source's start and end values (the source stepped first) */
    GRB_INPUT_EXTRAPOLATED = 2  /* midpoint extrapolated from its source's last two communication points */
};

/* The masters grb_run.scheme names. */
enum grb_scheme { GRB_GAUSS_SEIDEL = 0, GRB_JACOBI = 1, GRB_EXTRAPOLATE = 2, GRB_NEWTON = 3 };

/* The run: which master, its clock, and where recorded rows go. */
typedef struct {
    int scheme;               /* a grb_scheme: Gauss-Seidel (in the array's order), Jacobi, extrapolating */
    double t0, step, t_end;
    long n_steps, record_every;
    size_t n_columns;
    const int *column_fmu;    /* a recorded column: its FMU, or -1 for a value slot */
    const int *column_index;  /* ... and its index in that FMU's read buffer, or the slot */
    double *times;            /* one per recorded row */
    double *data;             /* rows x n_columns */
    size_t n_slots;           /* the extrapolating master's history of the values (else 0 and NULL): */
    double *start;            /* ... the values at the step's start */
    double *prev;             /* ... and at the communication point before it */
    double tol;               /* > 0: sub-steps of the continuous FMUs adapt to this error estimate */
    double *work;             /* adaptive: 4 n_slots doubles */
    struct grb_adapt *adapt;  /* adaptive: the sub-step's clock, carried from one call to the next */
    struct grb_newton *newton; /* GRB_NEWTON: what it solves for, its work and counts (else NULL) */
} grb_run;

/* The adaptive master's sub-step clock and counts. */
typedef struct grb_adapt {
    double h;                 /* the next sub-step to try */
    double h_prev;            /* the last sub-step taken (0: none yet, no slope to extrapolate) */
    long substeps, rejected;  /* sub-steps accepted (each two half-steps), tries rejected */
    double worst;             /* the largest error estimate accepted, relative to tol */
    long worst_slot;          /* the value whose estimate was largest in the last try (-1: none) */
} grb_adapt;

/* The Newton master's unknowns, work and counts (GRB_NEWTON; the caller owns every array).
 * The unknowns are the end-of-step values of the outputs that continuous inputs of the iterated FMUs read
 * (the slots an in_mode other than GRB_INPUT_HELD reads). */
typedef struct grb_newton {
    double tol;               /* a step's iteration ends when every residual, relative to max(1, |value|), is within */
    long max_iter;            /* evaluations a step may take before it is kept unconverged */
    size_t n_unknown;
    const int *unknown_slot;  /* n_unknown: each unknown's slot */
    const int *index;         /* n_slots: a slot's unknown, or -1 */
    double *work;             /* 3 n_slots + 3 n_unknown + n_unknown^2 doubles */
    int *pivot;               /* n_unknown */
    int have_jacobian;        /* the factored Jacobian in work is usable (kept from step to step) */
    long steps, evaluations, jacobians, unconverged;
    double worst;             /* the largest residual a step ended with, relative to tol */
    long worst_slot;          /* ... and its slot */
} grb_newton;

/* Where a run stopped: the FMU, the call (0 setReal, 1 doStep, 2 getReal, 3 get/set FMU state, 4 the
 * tolerance: the error estimate stays above it down to the smallest sub-step), its status, the step's start
 * (with call 4, fmu is the sub-step's first FMU and t the sub-step's start). */
typedef struct {
    int fmu, call, status;
    double t;
} grb_failure;

enum { CALL_SET, CALL_STEP, CALL_GET, CALL_STATE, CALL_TOL };

static double now(void) {
#if defined(GRB_MASTER_NO_CLOCK)
    return 0.0;
#elif defined(_WIN32)
    LARGE_INTEGER f, c;
    QueryPerformanceFrequency(&f);
    QueryPerformanceCounter(&c);
    return (double)c.QuadPart / (double)f.QuadPart;
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
#endif
}

static int failed(grb_failure *fail, int fmu, int call, int status, double t) {
    fail->fmu = fmu;
    fail->call = call;
    fail->status = status;
    fail->t = t;
    return 1;
}

/* setReal of the connected inputs from the values (none: no call) */
static int push(grb_fmu *f, const double *values) {
    size_t i;
    double t0 = 0.0;
    int s;
    if (f->n_in == 0) return 0;
    for (i = 0; i < f->n_in; i++) f->in_buf[i] = values[f->in_slot[i]];
    if (f->seconds) t0 = now();
    s = f->set_real(f->instance, f->in_vr, f->n_in, f->in_buf);
    if (f->seconds) f->seconds[CALL_SET] += now() - t0;
    return s;
}

/* doStep; noSetFMUStatePriorToCurrentPoint is false only for an FMU the adaptive master may roll back */
static int step(grb_fmu *f, double t, double h) {
    double t0 = f->seconds ? now() : 0.0;
    int s = f->do_step(f->instance, t, h, f->get_state == NULL);
    if (f->seconds) f->seconds[CALL_STEP] += now() - t0;
    return s;
}

/* getReal of the connected outputs (and, with everything, the recorded ones) into the values */
static int publish(grb_fmu *f, double *values, int everything) {
    size_t i, n = everything ? f->n_read : f->n_conn;
    double t0;
    int s = 0;
    if (n) {
        t0 = f->seconds ? now() : 0.0;
        s = f->get_real(f->instance, f->read_vr, n, f->read_buf);
        if (f->seconds) f->seconds[CALL_GET] += now() - t0;
    }
    if (s > 1) return s;
    for (i = 0; i < f->n_conn; i++) values[f->out_slot[i]] = f->read_buf[i];
    return s;
}

/* An input's value over the step (at == 0.5, the midpoint) or at its end (at == 1) under the
 * extrapolating master; ratio is this step over the last one (0 on the first step: no slope yet). */
static double input_at(int mode, int slot, const double *values, const grb_run *run, double ratio, double at) {
    double u0 = run->start[slot], u1;
    if (mode == GRB_INPUT_HELD) return values[slot];
    u1 = mode == GRB_INPUT_INTERPOLATED ? values[slot] : u0 + ratio * (u0 - run->prev[slot]);
    return at == 1.0 ? u1 : u0 + at * (u1 - u0);
}

/* setReal of the connected inputs at a point of the step (the extrapolating master's push) */
static int push_at(grb_fmu *f, const double *values, const grb_run *run, double ratio, double at) {
    size_t i;
    double t0 = 0.0;
    int s;
    if (f->n_in == 0) return 0;
    for (i = 0; i < f->n_in; i++)
        f->in_buf[i] = input_at(f->in_mode[i], f->in_slot[i], values, run, ratio, at);
    if (f->seconds) t0 = now();
    s = f->set_real(f->instance, f->in_vr, f->n_in, f->in_buf);
    if (f->seconds) f->seconds[CALL_SET] += now() - t0;
    return s;
}

static int moves_inputs(const grb_fmu *f) {
    size_t i;
    for (i = 0; i < f->n_in; i++)
        if (f->in_mode[i] != GRB_INPUT_HELD) return 1;
    return 0;
}

/* The history of the values at a new point: the start becomes the previous point (when there was one). */
static void remember(const grb_run *run, const double *values, int shift) {
    size_t j;
    if (shift)
        for (j = 0; j < run->n_slots; j++) run->prev[j] = run->start[j];
    for (j = 0; j < run->n_slots; j++) run->start[j] = values[j];
}

/* FMUs k0 .. k1 - 1, in order, over one extrapolating step from tn over h; ratio is h over the last step. */
static int extrapolating_pass(grb_fmu *fmus, int k0, int k1, double *values, const grb_run *run, double ratio,
                              double tn, double h, int recording, grb_failure *fail) {
    int k, s;
    for (k = k0; k < k1; k++) {
        grb_fmu *f = &fmus[k];
        int moving = f->in_mode && moves_inputs(f);
        if ((s = moving ? push_at(f, values, run, ratio, 0.5) : push(f, values)) > 1)
            return failed(fail, k, CALL_SET, s, tn);
        if ((s = step(f, tn, h)) > 1) return failed(fail, k, CALL_STEP, s, tn);
        if (moving && (s = push_at(f, values, run, ratio, 1.0)) > 1) return failed(fail, k, CALL_SET, s, tn);
        if ((s = publish(f, values, recording)) > 1) return failed(fail, k, CALL_GET, s, tn);
    }
    return 0;
}

/* -- the adaptive master: sampled FMUs once per communication step, the others in sub-steps ---------- */

/* Every sub-stepped FMU's state saved (save) or restored (!save). */
static int states(grb_fmu *fmus, int k0, int k1, int save, double t, grb_failure *fail) {
    int k, s;
    for (k = k0; k < k1; k++) {
        s = save ? fmus[k].get_state(fmus[k].instance, &fmus[k].state) : fmus[k].set_state(fmus[k].instance, fmus[k].state);
        if (s > 1) return failed(fail, k, CALL_STATE, s, t);
    }
    return 0;
}

/* One sub-step of FMUs k0 .. k1 - 1 from t over h, the history moved on. */
static int substep(grb_fmu *fmus, int k0, int k1, double *values, const grb_run *run, double t, double h,
                   int recording, grb_failure *fail) {
    grb_adapt *a = run->adapt;
    double ratio = a->h_prev > 0.0 ? h / a->h_prev : 0.0;
    remember(run, values, a->h_prev > 0.0);
    a->h_prev = h;
    return extrapolating_pass(fmus, k0, k1, values, run, ratio, t, h, recording, fail);
}

/* The error estimate of a sub-step: two half-steps against one whole (step doubling; the coupling is second
 * order, so the halves' error is a third of their difference), over every value, relative to max(1, |value|). */
static double estimate(const double *halves, const double *whole, size_t n, long *worst) {
    double e = 0.0, d, scale;
    size_t j;
    *worst = -1;
    for (j = 0; j < n; j++) {
        scale = fabs(halves[j]) > 1.0 ? fabs(halves[j]) : 1.0;
        d = fabs(halves[j] - whole[j]) / scale / 3.0;
        if (!(d <= e)) { /* a NaN wins */
            e = d;
            *worst = (long)j;
        }
    }
    return e;
}

/* With no past point to extrapolate from (the run's first sub-step), a slope from a predictor: one
 * sub-step of h on the start values, rolled back, whose end values the history then points at (a past
 * point u0 - (u1 - u0) one h back), so that the sub-steps that follow take the midpoint of the predicted
 * end: second order from the first sub-step, where a start value held would make it first order. */
static int predict(grb_fmu *fmus, int k0, int k1, double *values, const grb_run *run, double t, double h,
                   grb_failure *fail) {
    size_t j, n = run->n_slots;
    double *saved = run->work, *predicted = run->work + n;
    int s;
    if ((s = substep(fmus, k0, k1, values, run, t, h, 0, fail)) != 0) return s;
    for (j = 0; j < n; j++) { predicted[j] = values[j]; values[j] = saved[j]; }
    if ((s = states(fmus, k0, k1, 0, t, fail)) != 0) return s;
    for (j = 0; j < n; j++) run->start[j] = 2.0 * saved[j] - predicted[j];
    run->adapt->h_prev = h;
    return 0;
}

/* FMUs k0 .. k1 - 1 from tn to tn + h in sub-steps whose error estimate is within run->tol. */
static int adaptive_span(grb_fmu *fmus, int k0, int k1, double *values, const grb_run *run, double tn, double h,
                         int recording, grb_failure *fail) {
    grb_adapt *a = run->adapt;
    size_t n = run->n_slots, j;
    double *saved = run->work, *whole = run->work + n, *start = run->work + 2 * n, *prev = run->work + 3 * n;
    double t = tn, end = tn + h, hs, tried, h_prev, h_first, err, grow;
    int s, last;
    while (t < end) {
        tried = a->h;
        hs = tried < end - t ? tried : end - t;
        last = hs >= end - t || end - (t + hs) < 1e-9 * h; /* no sliver of a sub-step before the end */
        if (last) hs = end - t;
        if ((s = states(fmus, k0, k1, 1, t, fail)) != 0) return s;
        for (j = 0; j < n; j++) saved[j] = values[j];
        h_first = a->h_prev;
        if (h_first <= 0.0 && (s = predict(fmus, k0, k1, values, run, t, hs, fail)) != 0) return s;
        for (j = 0; j < n; j++) { start[j] = run->start[j]; prev[j] = run->prev[j]; }
        h_prev = a->h_prev;
        if ((s = substep(fmus, k0, k1, values, run, t, hs, 0, fail)) != 0) return s;
        for (j = 0; j < n; j++) { whole[j] = values[j]; values[j] = saved[j]; run->start[j] = start[j]; run->prev[j] = prev[j]; }
        a->h_prev = h_prev;
        if ((s = states(fmus, k0, k1, 0, t, fail)) != 0) return s;
        if ((s = substep(fmus, k0, k1, values, run, t, 0.5 * hs, 0, fail)) != 0) return s;
        if ((s = substep(fmus, k0, k1, values, run, t + 0.5 * hs, last ? end - (t + 0.5 * hs) : 0.5 * hs,
                         recording && last, fail)) != 0) return s;
        err = estimate(values, whole, n, &a->worst_slot) / run->tol;
        grow = err > 0.0 ? 0.9 * pow(err, -1.0 / 3.0) : 4.0; /* local error ~ h^3 */
        if (err <= 1.0) {
            a->substeps++;
            if (err > a->worst) a->worst = err;
            t = last ? end : t + hs;
            /* the next try: grown, but never past the communication step */
            a->h = hs * (grow < 4.0 ? grow : 4.0);
            if (last && hs < tried && a->h < tried) a->h = tried; /* a piece cut to end the step says little */
            if (a->h > run->step) a->h = run->step;
            continue;
        }
        /* rejected: back to the sub-step's start, and a shorter try (predicted again when it was) */
        a->rejected++;
        for (j = 0; j < n; j++) { values[j] = saved[j]; run->start[j] = start[j]; run->prev[j] = prev[j]; }
        a->h_prev = h_first > 0.0 ? h_prev : 0.0;
        if ((s = states(fmus, k0, k1, 0, t, fail)) != 0) return s;
        a->h = hs * (grow > 0.2 ? grow : 0.2);
        if (!(a->h >= 1e-6 * run->step)) return failed(fail, k0, CALL_TOL, 0, t); /* also a NaN */
    }
    return 0;
}

/* One adaptive communication step: every sampled FMU once, in order, then every other one in sub-steps. */
static int adaptive_step(grb_fmu *fmus, int n_fmus, double *values, const grb_run *run, double tn, double h,
                         int recording, grb_failure *fail) {
    int k, k1, s;
    for (k = 0; k < n_fmus; k = k1) {
        if (fmus[k].sampled) {
            k1 = k + 1;
            if ((s = push(&fmus[k], values)) > 1) return failed(fail, k, CALL_SET, s, tn);
            if ((s = step(&fmus[k], tn, h)) > 1) return failed(fail, k, CALL_STEP, s, tn);
            if ((s = publish(&fmus[k], values, recording)) > 1) return failed(fail, k, CALL_GET, s, tn);
            continue;
        }
        for (k1 = k; k1 < n_fmus && !fmus[k1].sampled; k1++) {}
        if ((s = adaptive_span(fmus, k, k1, values, run, tn, h, recording, fail)) != 0) return s;
    }
    return 0;
}

/* -- the Newton master: each step's coupled values iterated to their fixed point, with rollback --------- */

/* An FMU the Newton master iterates: continuous (not sampled), with an input that moves with the unknowns. */
static int iterated(const grb_fmu *f) {
    return !f->sampled && f->in_mode != NULL && moves_inputs(f);
}

/* setReal of the connected inputs on a guess of the unknowns' end values: a moving input held over the step
 * at the mean of its source's start value and the guess (at == 0.5), or at the guess (at == 1: the end, set
 * before the outputs are read); a held input at its value. */
static int push_guess(grb_fmu *f, const double *values, const double *start, const double *guess, double at) {
    size_t i;
    double t0 = 0.0;
    int s;
    if (f->n_in == 0) return 0;
    for (i = 0; i < f->n_in; i++) {
        int slot = f->in_slot[i];
        f->in_buf[i] = f->in_mode[i] == GRB_INPUT_HELD ? values[slot]
                       : at == 1.0 ? guess[slot] : start[slot] + at * (guess[slot] - start[slot]);
    }
    if (f->seconds) t0 = now();
    s = f->set_real(f->instance, f->in_vr, f->n_in, f->in_buf);
    if (f->seconds) f->seconds[CALL_SET] += now() - t0;
    return s;
}

/* Iterated FMU k over the step on the guess (from its saved state when restore), its outputs into values. */
static int evaluate(grb_fmu *fmus, int k, double *values, const double *start, const double *guess, double tn,
                    double h, int recording, int restore, grb_failure *fail) {
    grb_fmu *f = &fmus[k];
    int s;
    if (restore && (s = f->set_state(f->instance, f->state)) > 1) return failed(fail, k, CALL_STATE, s, tn);
    if ((s = push_guess(f, values, start, guess, 0.5)) > 1) return failed(fail, k, CALL_SET, s, tn);
    if ((s = step(f, tn, h)) > 1) return failed(fail, k, CALL_STEP, s, tn);
    if ((s = push_guess(f, values, start, guess, 1.0)) > 1) return failed(fail, k, CALL_SET, s, tn);
    if ((s = publish(f, values, recording)) > 1) return failed(fail, k, CALL_GET, s, tn);
    return 0;
}

/* Does FMU f read slot through an input that moves? */
static int reads_moving(const grb_fmu *f, int slot) {
    size_t i;
    for (i = 0; i < f->n_in; i++)
        if (f->in_slot[i] == slot && f->in_mode[i] != GRB_INPUT_HELD) return 1;
    return 0;
}

/* LU factorisation with partial pivoting of the n x n row-major a, in place; 1 when singular. */
static int lu_factor(double *a, int *pivot, size_t n) {
    size_t i, j, k, p;
    double t;
    for (k = 0; k < n; k++) {
        p = k;
        for (i = k + 1; i < n; i++)
            if (fabs(a[i * n + k]) > fabs(a[p * n + k])) p = i;
        if (!(fabs(a[p * n + k]) > 0.0)) return 1; /* also a NaN */
        pivot[k] = (int)p;
        if (p != k)
            for (j = 0; j < n; j++) { t = a[k * n + j]; a[k * n + j] = a[p * n + j]; a[p * n + j] = t; }
        for (i = k + 1; i < n; i++) {
            a[i * n + k] /= a[k * n + k];
            for (j = k + 1; j < n; j++) a[i * n + j] -= a[i * n + k] * a[k * n + j];
        }
    }
    return 0;
}

/* x = A^-1 b with A factored by lu_factor (b overwritten by x). */
static void lu_solve(const double *a, const int *pivot, double *b, size_t n) {
    size_t i, j, k;
    double t;
    for (k = 0; k < n; k++)
        if ((size_t)pivot[k] != k) { t = b[k]; b[k] = b[pivot[k]]; b[pivot[k]] = t; }
    for (i = 1; i < n; i++)
        for (j = 0; j < i; j++) b[i] -= a[i * n + j] * b[j];
    for (i = n; i-- > 0;) {
        for (j = i + 1; j < n; j++) b[i] -= a[i * n + j] * b[j];
        b[i] /= a[i * n + i];
    }
}

/* The Jacobian of the residual R(guess) = Y(guess) - guess over the step, factored: each column by one
 * perturbed step of the FMUs that read that unknown, from their saved state (the FMUs' own directional
 * derivatives are instantaneous, d output / d input at one instant, where a state's is zero; the step's
 * sensitivity of a state to an input held over it is what the iteration needs).  y holds Y(guess). */
static int jacobian(grb_fmu *fmus, int n_fmus, double *values, const grb_run *run, double *guess,
                    const double *y, const double *base, double tn, double h, grb_failure *fail) {
    grb_newton *nw = run->newton;
    size_t nu = nw->n_unknown, n_s = run->n_slots, i, j, o;
    double *jac = nw->work + 3 * n_s + 3 * nu, g, d;
    int k, s, slot;
    for (j = 0; j < nu; j++) {
        slot = nw->unknown_slot[j];
        g = guess[slot];
        d = 1e-4 * (fabs(g) > 1.0 ? fabs(g) : 1.0); /* well above the FMUs' own integration noise */
        guess[slot] = g + d;
        for (i = 0; i < nu; i++) jac[i * nu + j] = i == j ? -1.0 : 0.0;
        for (k = 0; k < n_fmus; k++) {
            grb_fmu *f = &fmus[k];
            if (!iterated(f) || !reads_moving(f, slot)) continue;
            for (i = 0; i < n_s; i++) values[i] = base[i];
            if ((s = evaluate(fmus, k, values, run->start, guess, tn, h, 0, 1, fail)) != 0) return s;
            for (o = 0; o < f->n_conn; o++) {
                int r = nw->index[f->out_slot[o]];
                if (r >= 0) jac[(size_t)r * nu + j] += (values[f->out_slot[o]] - y[f->out_slot[o]]) / d;
            }
        }
        guess[slot] = g;
    }
    nw->jacobians++;
    nw->have_jacobian = !lu_factor(jac, nw->pivot, nu);
    return 0;
}

/* One Newton communication step: the sampled FMUs once, reading the sample instant's values; the continuous
 * FMUs that no iterated value feeds once; then the iterated ones from one saved state, on a guess of the
 * unknowns' end values (extrapolated from the last two points), again and again, each guess moved by a
 * Newton update R'(guess) d = -R(guess) of the residual R = Y(guess) - guess, until every residual is within
 * tol.  The Jacobian is kept from step to step and made again when a kept one converges too slowly. */
static int newton_step(grb_fmu *fmus, int n_fmus, double *values, const grb_run *run, long n, double tn,
                       double h, int recording, grb_failure *fail) {
    grb_newton *nw = run->newton;
    size_t n_s = run->n_slots, nu = nw->n_unknown, j;
    double *guess = nw->work, *base = guess + n_s, *y = base + n_s, *r = y + n_s;
    double *jac = nw->work + 3 * n_s + 3 * nu, err = 0.0, err_prev = 0.0, e, ratio = n > 0 ? h / run->step : 0.0;
    long it, worst = -1;
    int k, s, slot, fresh = 0;
    for (k = 0; k < n_fmus; k++) {
        grb_fmu *f = &fmus[k];
        if (!f->sampled) continue;
        if ((s = push(f, values)) > 1) return failed(fail, k, CALL_SET, s, tn);
        if ((s = step(f, tn, h)) > 1) return failed(fail, k, CALL_STEP, s, tn);
        if ((s = publish(f, values, recording)) > 1) return failed(fail, k, CALL_GET, s, tn);
    }
    remember(run, values, n > 0);
    for (k = 0; k < n_fmus; k++) {
        grb_fmu *f = &fmus[k];
        if (f->sampled || iterated(f)) continue;
        if ((s = push(f, values)) > 1) return failed(fail, k, CALL_SET, s, tn);
        if ((s = step(f, tn, h)) > 1) return failed(fail, k, CALL_STEP, s, tn);
        if ((s = publish(f, values, recording)) > 1) return failed(fail, k, CALL_GET, s, tn);
    }
    for (j = 0; j < n_s; j++) base[j] = guess[j] = values[j];
    for (j = 0; j < nu; j++) {
        slot = nw->unknown_slot[j];
        guess[slot] = run->start[slot] + ratio * (run->start[slot] - run->prev[slot]);
    }
    for (k = 0; k < n_fmus; k++)
        if (iterated(&fmus[k]) && (s = fmus[k].get_state(fmus[k].instance, &fmus[k].state)) > 1)
            return failed(fail, k, CALL_STATE, s, tn);
    for (it = 0;; it++) {
        if (it > 0)
            for (j = 0; j < n_s; j++) values[j] = base[j];
        for (k = 0; k < n_fmus; k++)
            if (iterated(&fmus[k]) && (s = evaluate(fmus, k, values, run->start, guess, tn, h, recording, it > 0,
                                                    fail)) != 0)
                return s;
        nw->evaluations++;
        err = 0.0;
        for (j = 0; j < nu; j++) {
            slot = nw->unknown_slot[j];
            r[j] = values[slot] - guess[slot];
            e = fabs(r[j]) / (fabs(guess[slot]) > 1.0 ? fabs(guess[slot]) : 1.0);
            if (!(e <= err)) { /* a NaN wins */
                err = e;
                worst = slot;
            }
        }
        err /= nw->tol;
        if (err <= 1.0) break;
        if (it + 1 >= nw->max_iter) {
            nw->unconverged++;
            break;
        }
        /* a kept Jacobian is made again when, at the rate it converges, it would take more than two more
         * evaluations (a fresh one converges quadratically: about two, and costs one perturbed step per
         * unknown of the FMUs that read it) */
        if (!nw->have_jacobian || (it > 0 && !fresh && !(err * (err / err_prev) * (err / err_prev) <= 1.0))) {
            for (j = 0; j < n_s; j++) y[j] = values[j];
            if ((s = jacobian(fmus, n_fmus, values, run, guess, y, base, tn, h, fail)) != 0) return s;
            fresh = 1;
        }
        if (nw->have_jacobian) {
            lu_solve(jac, nw->pivot, r, nu); /* R'(guess) x = R(guess): the guess moves by -x */
            for (j = 0; j < nu; j++) guess[nw->unknown_slot[j]] -= r[j];
        } else { /* a singular Jacobian: a fixed-point pass, the guess moved to what the FMUs gave */
            for (j = 0; j < nu; j++) guess[nw->unknown_slot[j]] += r[j];
        }
        err_prev = err;
    }
    if (!(err <= nw->worst)) {
        nw->worst = err;
        nw->worst_slot = worst;
    }
    nw->steps++;
    return 0;
}

/* Free the FMU states the adaptive and Newton masters saved (after the run, before the FMUs are freed). */
GRB_MASTER_API void grb_master_free_states(grb_fmu *fmus, int n_fmus) {
    int k;
    for (k = 0; k < n_fmus; k++)
        if (fmus[k].state && fmus[k].free_state) {
            fmus[k].free_state(fmus[k].instance, &fmus[k].state);
            fmus[k].state = NULL;
        }
}

/* Communication steps first .. first + count - 1 of run (of run->n_steps), from time *t.
 * *row is the next recorded row, advanced by each one written; *t is the time reached. */
GRB_MASTER_API int grb_master_steps(grb_fmu *fmus, int n_fmus, double *values, const grb_run *run, long first,
                                    long count, double *t, long *row, grb_failure *fail) {
    long n;
    int k, s;
    size_t j;
    for (n = first; n < first + count && n < run->n_steps; n++) {
        int last = n == run->n_steps - 1;
        double h = run->step, tn = *t;
        int recording = (n + 1) % run->record_every == 0 || last;
        if (last && run->t_end - tn < h) h = run->t_end - tn;  /* a last, shorter step lands on t_end */
        if (run->scheme == GRB_NEWTON) {
            if ((s = newton_step(fmus, n_fmus, values, run, n, tn, h, recording, fail)) != 0) return s;
        } else if (run->scheme == GRB_EXTRAPOLATE && run->tol > 0.0) {
            if ((s = adaptive_step(fmus, n_fmus, values, run, tn, h, recording, fail)) != 0) return s;
        } else if (run->scheme == GRB_EXTRAPOLATE) {
            remember(run, values, n > 0);
            if ((s = extrapolating_pass(fmus, 0, n_fmus, values, run, n > 0 ? h / run->step : 0.0, tn, h, recording,
                                        fail)) != 0) return s;
        } else if (run->scheme != GRB_JACOBI) {
            for (k = 0; k < n_fmus; k++) {
                if ((s = push(&fmus[k], values)) > 1) return failed(fail, k, CALL_SET, s, tn);
                if ((s = step(&fmus[k], tn, h)) > 1) return failed(fail, k, CALL_STEP, s, tn);
                if ((s = publish(&fmus[k], values, recording)) > 1) return failed(fail, k, CALL_GET, s, tn);
            }
        } else {
            for (k = 0; k < n_fmus; k++)
                if ((s = push(&fmus[k], values)) > 1) return failed(fail, k, CALL_SET, s, tn);
            for (k = 0; k < n_fmus; k++)
                if ((s = step(&fmus[k], tn, h)) > 1) return failed(fail, k, CALL_STEP, s, tn);
            for (k = 0; k < n_fmus; k++)
                if ((s = publish(&fmus[k], values, recording)) > 1) return failed(fail, k, CALL_GET, s, tn);
        }
        *t = last ? run->t_end : run->t0 + (double)(n + 1) * run->step;
        if (recording) {
            double *out = run->data + (size_t)*row * run->n_columns;
            run->times[*row] = *t;
            for (j = 0; j < run->n_columns; j++) {
                int c = run->column_fmu[j];
                out[j] = c < 0 ? values[run->column_index[j]] : fmus[c].read_buf[run->column_index[j]];
            }
            (*row)++;
        }
    }
    return 0;
}
