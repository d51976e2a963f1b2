/* Explicit Runge-Kutta integration of the spatial chain, projected onto its
 * closures after every accepted step, and carried through change points on a
 * chart of its branch.
 *
 * The planar integrator (integrate.c) is tied to the planar model; this is
 * the advance the spatial chain needs, over the same Butcher tableaus
 * (tableaus.c: DOP853, RK45) and the same step-size control (Hairer, Norsett
 * and Wanner, Solving ODEs I, II.4), without dense output: each output time is
 * the end of a step, and the state is projected onto the closures (position,
 * then velocity: grs_project_ws) after every accepted step.
 *
 * Change points, as integrate.c passes them: for a loop of mobility one the
 * closure's conditioning (relative to the best the run has seen) and its
 * branch orientation (grs_closure_watch) are watched at the end of every
 * accepted step; a step that ends deep in a change point's zone, or steps over
 * one (the orientation flips while the motion goes on the same way), is
 * shortened to end at the zone's edge, and from there the motion follows its
 * branch's chart (sp_chart.c) until it leaves the chart's range on the far
 * side; crossing the chart's pinch counts a passage (grs_passages).  A step that the projection finds has jumped
 * to another branch (it takes a good part of the speed away) is retried
 * shorter, so that the watch meets the zone; where no chart can be made, or
 * the mobility is not one, such a jump stops the run (GRB_BRANCH_JUMP). */
#include <math.h>
#include <string.h>

#include "chart.h"
#include "sp_workspace.h"
#include "tableaus.h"

#define SAFETY 0.9
#define MIN_FACTOR 0.2
#define MAX_FACTOR 10.0
/* fraction of the joint speeds one projection may remove before the step is
 * taken for a jump between assembly branches (integrate.c's BRANCH_JUMP) */
#define BRANCH_JUMP 1e-2
/* closure conditioning (relative to the best seen) below which the motion
 * follows its branch's chart (integrate.c's CONDITIONING_NEAR) */
#define CONDITIONING_NEAR 1e-1
/* closure conditioning (relative) below which the chart's worst point counts
 * as a change point passed (integrate.c's CONDITIONING_PINCH) */
#define CONDITIONING_PINCH 1e-2
/* stepper slots after the chart, kept from one advance to the next (a
 * co-simulation step is one advance): a tag, the best conditioning seen, and
 * the change points passed */
#define SEEN_TAG 5.1173e-219
enum { SEEN_TAG_AT, SEEN_BEST, SEEN_PASSAGES, SEEN_SLOTS };

/* stepper rows (2N doubles each): s + 1 stage derivatives, then the stage
 * state, the proposed state, the current state; then the change-point chart
 * (grb_chart_size) and the best conditioning seen */
size_t grs_stepper_size(int tableau, int n_coords) {
    const grb_tableau_data *tab = grb_tableau(tableau);
    if (!tab || !tab->adaptive || n_coords <= 0) return 0;
    return (size_t)(tab->stages + 4) * 2 * (size_t)n_coords + grb_chart_size(n_coords) + SEEN_SLOTS;
}

/* the slots after the stages and the chart */
static double *seen_of(double *stepper, const grb_tableau_data *tab, int n_coords) {
    return stepper + (size_t)(tab->stages + 4) * 2 * (size_t)n_coords + grb_chart_size(n_coords);
}

double grs_passages(const double *stepper, int tableau, int n_coords) {
    const grb_tableau_data *tab = grb_tableau(tableau);
    if (!stepper || !tab || !tab->adaptive || n_coords <= 0) return 0.0;
    const double *seen = seen_of((double *)stepper, tab, n_coords);
    return seen[SEEN_TAG_AT] == SEEN_TAG ? seen[SEEN_PASSAGES] : 0.0;
}

typedef struct stepper {
    const grs_model *md;
    const grs_settings *s;
    const grb_tableau_data *tab;
    double *work;
    int N; /* states, 2n */
    double *Y, *stage, *nw, *cur;
    long evals;
    grs_ws *w;
    grs_chart *chart; /* the branch followed near a change point, when active */
} stepper;

#define ROW(st, i) ((st)->Y + (size_t)(i) * (st)->N)

static int rhs(stepper *st, const double *y, double *out) {
    st->evals++;
    if (st->chart && st->chart->active) {
        grs_chart_rhs(st->md, st->chart, y, st->s->tau, st->w, out);
        for (int i = 0; i < st->N; i++)
            if (!isfinite(out[i])) return 0;
        return 1;
    }
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

/* The change-point watch at y (grs_closure_watch): the closure's conditioning
 * relative to the best seen (which it updates), y's row directions into
 * basis_out, the branch orientation against basis (the step's start) and
 * against its own. */
static double watch(const grs_model *md, const double *y, double *seen, const double *basis, double *basis_out,
                    double *orientation, double *own_orientation, grs_ws *w) {
    double k;
    grs_closure_watch(md, y, basis, basis_out, &k, orientation, own_orientation, w);
    if (k > *seen) *seen = k;
    return *seen > 0.0 ? k / *seen : 1.0;
}

/* The fraction of a step to try instead of one that ends deep in a change
 * point's zone (conditioning k_nw), or steps over one (over: the branch
 * orientation flipped while the motion went on the same way): aim at the
 * zone's edge, the conditioning falling about linearly towards the change
 * point (integrate.c's change_point_ahead). */
static double towards_edge(double k_cur, double k_nw, int over) {
    double frac = 0.5;
    if (!over && k_cur > k_nw)
        frac = (k_cur - 0.75 * CONDITIONING_NEAR) / (k_cur - k_nw);
    else if (over) /* down to the pinch and up again */
        frac = (k_cur - 0.75 * CONDITIONING_NEAR) / (k_cur + k_nw);
    return fmin(0.9, fmax(0.05, frac));
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
    stepper st = {md, s, tab, work, 2 * w.n, stepper_buf, NULL, NULL, NULL, 0, &w, NULL};
    int S = tab->stages, n = w.n;
    st.stage = ROW(&st, S + 1);
    st.nw = ROW(&st, S + 2);
    st.cur = ROW(&st, S + 3);
    memcpy(st.cur, y, sizeof(double) * (size_t)st.N);
    /* change points are passed on a chart where the closures leave one degree of freedom besides the idle
     * ones (grs_idle_coords: the RSSR coupler's spin, which the chart leaves to its own equation) */
    grs_chart chart;
    double *seen = seen_of(stepper_buf, tab, n);
    int idle = w.m > 0 ? grs_idle_coords(md, st.cur, &w) : 0;
    int passing = w.m > 0 && grs_closure_freedom(md, st.cur, &w) - idle == 1, uncharted = 0;
    double k_cur = 1.0, o_cur = 0.0, o_nw = 0.0, o_nw_own = 0.0, unused;
    /* the row directions at the current state and at the proposed one's end (the orientation's basis) */
    double *b_cur = w.basis, *b_nw = w.basis + (size_t)(n > 1 ? n - 1 : 0) * w.m;
    if (passing) {
        grb_chart_init(&chart, n, ROW(&st, S + 4));
        grs_chart_resume(&chart, st.cur, s->scale, &w);
        st.chart = &chart;
        if (seen[SEEN_TAG_AT] != SEEN_TAG) seen[SEEN_PASSAGES] = 0.0;
        if (seen[SEEN_TAG_AT] != SEEN_TAG || !(seen[SEEN_BEST] > 0.0)) seen[SEEN_BEST] = 0.0;
        if (!(seen[SEEN_PASSAGES] >= 0.0)) seen[SEEN_PASSAGES] = 0.0;
        seen[SEEN_TAG_AT] = SEEN_TAG;
        if (!chart.active) k_cur = watch(md, st.cur, &seen[SEEN_BEST], NULL, b_cur, &unused, &o_cur, &w);
    }
    if (!rhs(&st, st.cur, ROW(&st, 0))) return stop(where, *t, GRB_NONFINITE_DERIVATIVE);
    double time = *t, step = *h > 0.0 ? fmin(*h, s->h_max) : initial_step(&st);
    if (!(step > 0.0)) return stop(where, time, GRB_NONFINITE_DERIVATIVE);
    long taken = 0;
    double exponent = 1.0 / (tab->error_order + 1);
    for (int o = 0; o < n_out; o++) {
        while (time < t_out[o]) {
            /* near a change point: onto the branch's chart (where one can be made) */
            if (passing && !chart.active && !uncharted && k_cur < CONDITIONING_NEAR) {
                if (grs_chart_build(md, s->scale, st.cur, seen[SEEN_BEST], CONDITIONING_NEAR, &chart, &w) == GRB_OK) {
                    grs_chart_put(&chart, st.cur, &w);
                    if (!rhs(&st, st.cur, ROW(&st, 0))) return stop(where, time, GRB_NONFINITE_DERIVATIVE);
                } else
                    uncharted = 1;
            }
            double left = t_out[o] - time, hh = fmin(step, left);
            if (passing && chart.active) { /* a step ends a little past the chart's far end at most */
                double x = st.cur[chart.held], xd = st.cur[n + chart.held];
                double room = (xd > 0.0 ? chart.hi - x : x - chart.lo) + 0.02 * chart.half;
                if (room > 0.0 && fabs(xd) * hh > room) hh = room / fabs(xd);
            }
            int last = hh >= left;
            double err = try_step(&st, hh);
            double fac = err == 0.0 ? MAX_FACTOR : fmin(MAX_FACTOR, fmax(MIN_FACTOR, SAFETY * pow(err, -exponent)));
            if (err <= 1.0) {
                double k_nw = 1.0;
                if (passing && !chart.active) {
                    /* a step that ends deep in a change point's zone, or steps over one, ends at its edge
                     * instead */
                    double seen_before = seen[SEEN_BEST], same_way = 0.0;
                    k_nw = watch(md, st.nw, &seen[SEEN_BEST], b_cur, b_nw, &o_nw, &o_nw_own, &w);
                    for (int i = n; i < st.N; i++) /* along the branch: an idle spin may go on either way */
                        if (!grs_is_idle(&w, i - n)) same_way += st.cur[i] * st.nw[i];
                    int over = same_way > 0.0 && o_cur * o_nw < 0.0;
                    if (!uncharted && (over || k_nw < 0.5 * CONDITIONING_NEAR)) {
                        seen[SEEN_BEST] = seen_before;
                        step = hh * towards_edge(k_cur, k_nw, over);
                        continue;
                    }
                }
                int charted = 0;
                if (passing && chart.active) { /* on the chart: put there exactly, let go past its range */
                    double *p = st.nw;
                    int held = chart.held;
                    /* a passage: the motion crossing the chart's pinch, where the branches meet */
                    int crossed = chart.pinch_kappa < CONDITIONING_PINCH &&
                                  (st.cur[held] - chart.pinch) * (p[held] - chart.pinch) < 0.0;
                    charted = grs_chart_put(&chart, p, &w);
                    if (charted && crossed) seen[SEEN_PASSAGES] += 1.0;
                    if (!charted || p[chart.held] < chart.lo || p[chart.held] > chart.hi) chart.active = 0;
                    if (!chart.active) k_nw = watch(md, p, &seen[SEEN_BEST], NULL, b_nw, &unused, &o_nw_own, &w);
                }
                if (w.m > 0 && !charted) {
                    /* the projection moves the state by the order of the tolerance; one that takes a good
                     * part of the speed away crossed where two assembly branches meet and landed on the
                     * other: retried shorter while a chart may still take over, else the run stops */
                    memcpy(st.stage, st.nw, sizeof(double) * (size_t)st.N);
                    grs_project_ws(md, s->scale, st.stage, &w);
                    double dv2 = 0.0, v2 = 0.0;
                    for (int i = n; i < st.N; i++) {
                        dv2 += (st.stage[i] - st.nw[i]) * (st.stage[i] - st.nw[i]);
                        v2 += st.nw[i] * st.nw[i];
                    }
                    if (dv2 > BRANCH_JUMP * BRANCH_JUMP * v2 && dv2 > (1e3 * s->atol) * (1e3 * s->atol)) {
                        if (passing && !uncharted && 0.25 * hh > 1e-12 * fmax(1.0, fabs(time))) {
                            step = 0.25 * hh;
                            continue;
                        }
                        return stop(where, time + hh, GRB_BRANCH_JUMP);
                    }
                    memcpy(st.nw, st.stage, sizeof(double) * (size_t)st.N);
                }
                time = last ? t_out[o] : time + hh;
                memcpy(st.cur, st.nw, sizeof(double) * (size_t)st.N);
                k_cur = k_nw;
                if (passing && !chart.active) { /* the end's row directions become the next step's basis */
                    double *b = b_cur;
                    b_cur = b_nw;
                    b_nw = b;
                    o_cur = o_nw_own;
                    if (k_cur >= CONDITIONING_NEAR) uncharted = 0;
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
    if (passing) grb_chart_save(&chart);
    memcpy(y, st.cur, sizeof(double) * (size_t)st.N);
    *t = time;
    *h = step;
    *steps += taken;
    return GRB_OK;
}
