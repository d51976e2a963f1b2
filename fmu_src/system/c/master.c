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
#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#endif
#include <stddef.h>
#include <time.h>
#ifdef _WIN32
#include <windows.h>
#endif

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
} grb_fmu;

/* How the extrapolating master sets an input over a step. */
enum grb_input_mode {
    GRB_INPUT_HELD = 0,         /* as Gauss-Seidel: its source's latest value */
    GRB_INPUT_INTERPOLATED = 1, /* midpoint of its source's start and end values (the source stepped first) */
    GRB_INPUT_EXTRAPOLATED = 2  /* midpoint extrapolated from its source's last two communication points */
};

/* The masters grb_run.scheme names. */
enum grb_scheme { GRB_GAUSS_SEIDEL = 0, GRB_JACOBI = 1, GRB_EXTRAPOLATE = 2 };

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
} grb_run;

/* Where a run stopped: the FMU, the call (0 setReal, 1 doStep, 2 getReal), its status, the step's start. */
typedef struct {
    int fmu, call, status;
    double t;
} grb_failure;

enum { CALL_SET, CALL_STEP, CALL_GET };

static double now(void) {
#ifdef _WIN32
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

static int step(grb_fmu *f, double t, double h) {
    double t0 = f->seconds ? now() : 0.0;
    int s = f->do_step(f->instance, t, h, 1);
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

/* One extrapolating step of every FMU, in the array's order, from tn over h. */
static int extrapolating_step(grb_fmu *fmus, int n_fmus, double *values, const grb_run *run, long n, double tn,
                              double h, int recording, grb_failure *fail) {
    double ratio = n > 0 ? h / run->step : 0.0;
    size_t j;
    int k, s;
    if (n > 0)
        for (j = 0; j < run->n_slots; j++) run->prev[j] = run->start[j];
    for (j = 0; j < run->n_slots; j++) run->start[j] = values[j];
    for (k = 0; k < n_fmus; k++) {
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
        if (run->scheme == GRB_EXTRAPOLATE) {
            if ((s = extrapolating_step(fmus, n_fmus, values, run, n, tn, h, recording, fail)) != 0) return s;
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
