/* Explicit Runge-Kutta integration of the spatial chain, projected onto its
 * closures after every accepted step.
 *
 * The planar integrator (integrate.c) is tied to the planar model through its
 * change-point charts; this is the small advance the spatial chain needs now,
 * over the same Butcher tableaus (tableaus.c: DOP853, RK45) and the same
 * step-size control (Hairer, Norsett and Wanner, Solving ODEs I, II.4), without
 * change-point passages or dense output: each output time is the end of a
 * step, and the state is projected onto the closures (position, then
 * velocity: grs_project_ws) after every accepted step; a projection that
 * takes a good part of the speed away stops the run (GRB_BRANCH_JUMP). */
#include <math.h>
#include <string.h>

#include "sp_workspace.h"
#include "tableaus.h"

#define SAFETY 0.9
#define MIN_FACTOR 0.2
#define MAX_FACTOR 10.0
/* fraction of the joint speeds one projection may remove before the step is
 * taken for a jump between assembly branches (integrate.c's BRANCH_JUMP) */
#define BRANCH_JUMP 1e-2

/* stepper rows (2N doubles each): s + 1 stage derivatives, then the stage
 * state, the proposed state, the current state */
size_t grs_stepper_size(int tableau, int n_coords) {
    const grb_tableau_data *tab = grb_tableau(tableau);
    if (!tab || !tab->adaptive || n_coords <= 0) return 0;
    return (size_t)(tab->stages + 4) * 2 * (size_t)n_coords;
}

typedef struct stepper {
    const grs_model *md;
    const grs_settings *s;
    const grb_tableau_data *tab;
    double *work;
    int N; /* states, 2n */
    double *Y, *stage, *nw, *cur;
    long evals;
} stepper;

#define ROW(st, i) ((st)->Y + (size_t)(i) * (st)->N)

static int rhs(stepper *st, const double *y, double *out) {
    st->evals++;
    grb_status status = grs_rhs(st->md, y, st->s->tau, st->work, out);
    for (int i = 0; i < st->N; i++)
        if (!isfinite(out[i])) return 0;
    return status == GRB_OK;
}

/* The scaled error of the step in the stage rows (Hairer's norms: DOP853
 * mixes its 5th- and 3rd-order estimates; integrate.c's error_norm). */
static double error_norm(const stepper *st, double h) {
    const grb_tableau_data *tab = st->tab;
    int s = tab->stages, N = st->N;
    double e5 = 0.0, e3 = 0.0;
    for (int r = 0; r < N; r++) {
        double sc = st->s->atol + st->s->rtol * fmax(fabs(st->cur[r]), fabs(st->nw[r]));
        double a5 = 0.0, a3 = 0.0;
        for (int j = 0; j <= s; j++) {
            a5 += tab->e[j] * ROW(st, j)[r];
            if (tab->e3) a3 += tab->e3[j] * ROW(st, j)[r];
        }
        e5 += (a5 / sc) * (a5 / sc);
        e3 += (a3 / sc) * (a3 / sc);
    }
    if (!tab->e3) return fabs(h) * sqrt(e5 / N);
    if (e5 == 0.0 && e3 == 0.0) return 0.0;
    return fabs(h) * e5 / sqrt((e5 + 0.01 * e3) * N);
}

/* One step of size h from cur (its derivative in row 0): the proposed state
 * and its derivative (row s); the scaled error, inf on a non-finite number. */
static double try_step(stepper *st, double h) {
    const grb_tableau_data *tab = st->tab;
    int s = tab->stages, N = st->N;
    for (int i = 1; i < s; i++) {
        for (int r = 0; r < N; r++) {
            double acc = 0.0;
            for (int j = 0; j < i; j++) acc += tab->A[i * tab->lda + j] * ROW(st, j)[r];
            st->stage[r] = st->cur[r] + h * acc;
        }
        if (!rhs(st, st->stage, ROW(st, i))) return INFINITY;
    }
    for (int r = 0; r < N; r++) {
        double acc = 0.0;
        for (int j = 0; j < s; j++) acc += tab->b[j] * ROW(st, j)[r];
        st->nw[r] = st->cur[r] + h * acc;
    }
    if (!rhs(st, st->nw, ROW(st, s))) return INFINITY;
    return error_norm(st, h);
}

/* Hairer's starting step (Solving ODEs I, II.4). */
static double initial_step(stepper *st) {
    int N = st->N;
    double d0 = 0.0, d1 = 0.0, d2 = 0.0, rtol = st->s->rtol, atol = st->s->atol;
    for (int r = 0; r < N; r++) {
        double sc = atol + rtol * fabs(st->cur[r]);
        d0 += (st->cur[r] / sc) * (st->cur[r] / sc);
        d1 += (ROW(st, 0)[r] / sc) * (ROW(st, 0)[r] / sc);
    }
    d0 = sqrt(d0 / N);
    d1 = sqrt(d1 / N);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    for (int r = 0; r < N; r++) st->stage[r] = st->cur[r] + h0 * ROW(st, 0)[r];
    double *f1 = ROW(st, 1);
    if (!rhs(st, st->stage, f1)) return NAN;
    for (int r = 0; r < N; r++) {
        double v = (f1[r] - ROW(st, 0)[r]) / (atol + rtol * fabs(st->cur[r]));
        d2 += v * v;
    }
    d2 = sqrt(d2 / N) / h0;
    double h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? fmax(1e-6, h0 * 1e-3)
                                             : pow(0.01 / fmax(d1, d2), 1.0 / (st->tab->error_order + 1));
    return fmin(fmin(100.0 * h0, h1), st->s->h_max);
}

static grb_status stop(double *where, double t, grb_status status) {
    if (where) *where = t;
    return status;
}

grb_status grs_advance(const grs_model *md, const grs_settings *s, double *t, double *h, long *steps, double *y,
                       const double *t_out, int n_out, double *out, double *work, double *stepper_buf,
                       double *where) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return stop(where, *t, status);
    const grb_tableau_data *tab = grb_tableau(s->tableau);
    if (!tab || !tab->adaptive || n_out < 1 || !(s->rtol > 0.0) || !(s->atol > 0.0) || !(s->h_max > 0.0) ||
        s->max_steps < 0 || !(s->scale > 0.0) || !isfinite(s->scale) || !isfinite(*t))
        return stop(where, *t, GRB_BAD_ARGUMENT);
    for (int o = 0; o < n_out; o++)
        if (!isfinite(t_out[o]) || t_out[o] < (o ? t_out[o - 1] : *t)) return stop(where, t_out[o], GRB_BAD_ARGUMENT);
    stepper st = {md, s, tab, work, 2 * w.n, stepper_buf, NULL, NULL, NULL, 0};
    int S = tab->stages;
    st.stage = ROW(&st, S + 1);
    st.nw = ROW(&st, S + 2);
    st.cur = ROW(&st, S + 3);
    memcpy(st.cur, y, sizeof(double) * (size_t)st.N);
    if (!rhs(&st, st.cur, ROW(&st, 0))) return stop(where, *t, GRB_NONFINITE_DERIVATIVE);
    double time = *t, step = *h > 0.0 ? fmin(*h, s->h_max) : initial_step(&st);
    if (!(step > 0.0)) return stop(where, time, GRB_NONFINITE_DERIVATIVE);
    long taken = 0;
    double exponent = 1.0 / (tab->error_order + 1);
    for (int o = 0; o < n_out; o++) {
        while (time < t_out[o]) {
            double left = t_out[o] - time, hh = fmin(step, left);
            int last = hh >= left;
            double err = try_step(&st, hh);
            double fac = err == 0.0 ? MAX_FACTOR : fmin(MAX_FACTOR, fmax(MIN_FACTOR, SAFETY * pow(err, -exponent)));
            if (err <= 1.0) {
                time = last ? t_out[o] : time + hh;
                memcpy(st.cur, st.nw, sizeof(double) * (size_t)st.N);
                if (w.m > 0) {
                    grs_project_ws(md, s->scale, st.cur, &w);
                    /* a correction of the order of the tolerance, not a good part of the speed: one that
                     * takes that much away crossed where two assembly branches meet and landed on the
                     * other (the planar kernel follows a chart there; this advance stops) */
                    double dv2 = 0.0, v2 = 0.0;
                    for (int i = w.n; i < st.N; i++) {
                        dv2 += (st.cur[i] - st.nw[i]) * (st.cur[i] - st.nw[i]);
                        v2 += st.nw[i] * st.nw[i];
                    }
                    if (dv2 > BRANCH_JUMP * BRANCH_JUMP * v2 && dv2 > (1e3 * s->atol) * (1e3 * s->atol))
                        return stop(where, time, GRB_BRANCH_JUMP);
                }
                if (!rhs(&st, st.cur, ROW(&st, 0))) return stop(where, time, GRB_NONFINITE_DERIVATIVE);
                /* a step cut short to land on an output says nothing against the step before it */
                step = last && hh < step ? fmax(step, hh * fac) : hh * fac;
                if (++taken > s->max_steps) return stop(where, t_out[o], GRB_TOO_MANY_STEPS);
            } else {
                if (!isfinite(err)) fac = MIN_FACTOR;
                step = hh * fac;
            }
            step = fmin(step, s->h_max);
            if (!(step > 1e-14 * fmax(1.0, fabs(time)))) return stop(where, time, GRB_STEP_UNDERFLOW);
        }
        memcpy(out + (size_t)o * st.N, st.cur, sizeof(double) * (size_t)st.N);
    }
    memcpy(y, st.cur, sizeof(double) * (size_t)st.N);
    *t = time;
    *h = step;
    *steps += taken;
    return GRB_OK;
}
