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
} grb_fmu;

/* The run: which master, its clock, and where recorded rows go. */
typedef struct {
    int jacobi;               /* 0: Gauss-Seidel in the array's order; 1: Jacobi */
    double t0, step, t_end;
    long n_steps, record_every;
    size_t n_columns;
    const int *column_fmu;    /* a recorded column: its FMU, or -1 for a value slot */
    const int *column_index;  /* ... and its index in that FMU's read buffer, or the slot */
    double *times;            /* one per recorded row */
    double *data;             /* rows x n_columns */
} grb_run;

/* Where a run stopped: the FMU, the call (0 setReal, 1 doStep, 2 getReal), its status, the step's start. */
typedef struct {
    int fmu, call, status;
    double t;
} grb_failure;

enum { CALL_SET, CALL_STEP, CALL_GET };

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
        if (!run->jacobi) {
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
