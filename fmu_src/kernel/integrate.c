/* Explicit Runge-Kutta integration with error control, dense output and
 * projection onto the closures.
 *
 * Written here rather than borrowed because a closed loop needs two things a
 * general ODE solver does not give: a projection back onto the closure after
 * every accepted step (the exact method's drift control), and an integrator
 * state that is plain data (grb_clock, y, f), saved and restored whole as an
 * FMU's rollback requires.  Step-size control and the initial step follow
 * Hairer, Norsett and Wanner (Solving ODEs I, II.4); DOP853's error estimate and
 * continuous extension are theirs (II.5, II.6). */
#include <math.h>
#include <string.h>

#include "chart.h"
#include "tableaus.h"
#include "workspace.h"

#define SAFETY 0.9
#define MIN_FACTOR 0.2
#define MAX_FACTOR 10.0
/* fraction of the joint speeds one projection may remove before the step is
 * taken for a jump between assembly branches (a change point) */
#define BRANCH_JUMP 1e-2
/* Closure conditioning (its Jacobian's (N-1)-th singular value over its largest,
 * relative to the best the run has seen: a chain of very unequal lengths is
 * ill-conditioned everywhere, and that is no change point) below which the
 * motion is followed on its branch's chart (chart.c), and below which the
 * chart's worst point counts as a change point passed */
#define CONDITIONING_NEAR 1e-1
#define CONDITIONING_PINCH 1e-2
/* the chart's rows in the stepper table (2n doubles each) */
#define CHART_ROWS ((CHART_PER_COORD + 1) / 2)

/* rows of the stepper table after the s + 1 stage derivatives and the dense
 * stages: stage state, proposed state, projected state, current state, current
 * derivative, then the change-point chart */
typedef struct rows {
    int stage, new_, proj, cur, der, chart, count;
} rows;

static rows rows_of(const grb_tableau_data *tab) {
    rows r;
    int k = tab->stages + 1 + tab->dense_stages;
    r.stage = k;
    r.new_ = k + 1;
    r.proj = k + 2;
    r.cur = k + 3;
    r.der = k + 4;
    r.chart = k + 5;
    r.count = k + 5 + CHART_ROWS;
    return r;
}

size_t grb_stepper_size(int tableau, int n_states) {
    const grb_tableau_data *tab = grb_tableau(tableau);
    if (!tab || n_states <= 0) return 0;
    return (size_t)rows_of(tab).count * (size_t)n_states;
}

/* what one evaluation of the state equation needs */
typedef struct problem {
    const grb_model *md;
    const grb_settings *s;
    grb_ws ws;
    double *work;
    int N; /* states, 2n */
    grb_chart *chart; /* the branch followed near a change point, when active */
} problem;

static void rhs(problem *p, double t, const double *y, double *out) {
    double tau = p->s->drive_fn ? p->s->drive_fn(p->s->drive_ctx, t) : p->s->tau_drive;
    if (p->chart && p->chart->active)
        grb_chart_rhs(p->md, p->chart, y, tau, p->s->tau_load, &p->ws, out);
    else
        grb_rhs(p->md, p->s->method, y, tau, p->s->tau_load, p->work, out);
}

/* The closure's conditioning at y, relative to the best the run has seen (which
 * it updates), and the branch orientation there, from one evaluation of the
 * closure rows. */
static void watch(problem *p, double *kappa_seen, const double *y, const double *basis, double *kappa,
                  double *orientation) {
    double k;
    grb_closure_watch(p->md, y, basis, &p->ws, &k, orientation);
    if (k > *kappa_seen) *kappa_seen = k;
    *kappa = *kappa_seen > 0.0 ? k / *kappa_seen : 1.0;
}

/* Onto the closure: onto the chart while one is followed, else the projection. */
static void put_on_closure(problem *p, double *y) {
    if (p->chart && p->chart->active)
        grb_chart_put(p->chart, y);
    else
        grb_project_ws(p->md, p->s->scale, y, &p->ws);
}

static int all_finite(const double *x, int n) {
    for (int i = 0; i < n; i++)
        if (!isfinite(x[i])) return 0;
    return 1;
}

#define ROW(Y, i) ((Y) + (size_t)(i) * N)

/* Scaled error of the step in Y; <= 1 accepts it. */
static double error_norm(const grb_tableau_data *tab, double h, const double *Y, int N, double rtol, double atol) {
    int s = tab->stages;
    rows rw = rows_of(tab);
    double e5_sum = 0.0, e3_sum = 0.0;
    for (int r = 0; r < N; r++) {
        double sc = atol + rtol * fmax(fabs(ROW(Y, rw.cur)[r]), fabs(ROW(Y, rw.new_)[r]));
        double acc5 = 0.0, acc3 = 0.0;
        for (int j = 0; j <= s; j++) {
            acc5 += tab->e[j] * ROW(Y, j)[r];
            if (tab->e3) acc3 += tab->e3[j] * ROW(Y, j)[r];
        }
        e5_sum += (acc5 / sc) * (acc5 / sc);
        e3_sum += (acc3 / sc) * (acc3 / sc);
    }
    if (!tab->e3) return fabs(h) * sqrt(e5_sum / N);
    /* Hairer's DOP853 estimate, mixing the 5th- and 3rd-order errors */
    if (e5_sum == 0.0 && e3_sum == 0.0) return 0.0;
    return fabs(h) * e5_sum / sqrt((e5_sum + 0.01 * e3_sum) * N);
}

/* One step of size h from the current state, f(t, y) in Y[0].  Fills the
 * proposed state and, when adaptive, Y[s] = its derivative.  Returns the
 * scaled error (0 for a fixed step, inf when the step made a non-finite number)
 * and adds the evaluations made to *evals. */
static double try_step(const grb_tableau_data *tab, problem *p, double t, double h, double *Y, long *evals) {
    int s = tab->stages, N = p->N;
    rows rw = rows_of(tab);
    double *stage = ROW(Y, rw.stage), *cur = ROW(Y, rw.cur), *nw = ROW(Y, rw.new_);
    for (int i = 1; i < s; i++) {
        for (int r = 0; r < N; r++) {
            double acc = 0.0;
            for (int j = 0; j < i; j++) acc += tab->A[i * tab->lda + j] * ROW(Y, j)[r];
            stage[r] = cur[r] + h * acc;
        }
        rhs(p, t + tab->c[i] * h, stage, ROW(Y, i));
    }
    for (int r = 0; r < N; r++) {
        double acc = 0.0;
        for (int j = 0; j < s; j++) acc += tab->b[j] * ROW(Y, j)[r];
        nw[r] = cur[r] + h * acc;
    }
    *evals += s - 1;
    if (!tab->adaptive) return 0.0;
    rhs(p, t + h, nw, ROW(Y, s));
    *evals += 1;
    if (!(all_finite(nw, N) && all_finite(ROW(Y, s), N))) return INFINITY;
    return error_norm(tab, h, Y, N, p->s->rtol, p->s->atol);
}

static double initial_step(const grb_tableau_data *tab, problem *p, double t, double *Y, double h_max) {
    int s = tab->stages, N = p->N;
    rows rw = rows_of(tab);
    double rtol = p->s->rtol, atol = p->s->atol;
    double *cur = ROW(Y, rw.cur), *der = ROW(Y, rw.der), *stage = ROW(Y, rw.stage);
    double d0 = 0.0, d1 = 0.0, d2 = 0.0;
    for (int r = 0; r < N; r++) {
        double sc = atol + rtol * fabs(cur[r]);
        d0 += (cur[r] / sc) * (cur[r] / sc);
        d1 += (der[r] / sc) * (der[r] / sc);
    }
    d0 = sqrt(d0 / N);
    d1 = sqrt(d1 / N);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    for (int r = 0; r < N; r++) stage[r] = cur[r] + h0 * der[r];
    rhs(p, t + h0, stage, ROW(Y, s));
    for (int r = 0; r < N; r++) {
        double v = (ROW(Y, s)[r] - der[r]) / (atol + rtol * fabs(cur[r]));
        d2 += v * v;
    }
    d2 = sqrt(d2 / N) / h0;
    double h1;
    if (d1 <= 1e-15 && d2 <= 1e-15)
        h1 = fmax(1e-6, h0 * 1e-3);
    else
        h1 = pow(0.01 / fmax(d1, d2), 1.0 / (tab->error_order + 1));
    double h = 100.0 * h0;
    if (h1 < h) h = h1;
    if (h_max < h) h = h_max;
    return h; /* nan when the derivative is: the caller's guard stops on it */
}

/* The continuous extension's extra stages of the step just accepted. */
static void dense_stages(const grb_tableau_data *tab, problem *p, double t, double h, double *Y, long *evals) {
    int s = tab->stages, N = p->N;
    rows rw = rows_of(tab);
    double *stage = ROW(Y, rw.stage), *cur = ROW(Y, rw.cur);
    for (int k = 0; k < tab->dense_stages; k++) {
        for (int r = 0; r < N; r++) {
            double acc = 0.0;
            for (int j = 0; j < s + 1 + k; j++) acc += tab->dense_a[k * tab->lda + j] * ROW(Y, j)[r];
            stage[r] = cur[r] + h * acc;
        }
        rhs(p, t + tab->dense_c[k] * h, stage, ROW(Y, s + 1 + k));
    }
    *evals += tab->dense_stages;
}

/* The state at fraction x of the step just accepted (DOP853's interpolant in
 * Hairer's nested form y0 + x (F0 + (1 - x) (F1 + x (F2 + ...)))). */
static void interpolate(const grb_tableau_data *tab, double x, double h, const double *Y, int N, double *out) {
    int s = tab->stages, n_k = s + 1 + tab->dense_stages, rows_d = tab->dense_rows;
    rows rw = rows_of(tab);
    const double *cur = ROW(Y, rw.cur), *nw = ROW(Y, rw.new_);
    for (int r = 0; r < N; r++) {
        double dy = nw[r] - cur[r], acc = 0.0;
        for (int i = 0; i < rows_d + 3; i++) {
            int row = rows_d + 2 - i; /* F6 first, F0 last */
            double f;
            if (row >= 3) {
                f = 0.0;
                for (int j = 0; j < n_k; j++) f += tab->dense_d[(row - 3) * tab->lda + j] * ROW(Y, j)[r];
                f *= h;
            } else if (row == 2)
                f = 2.0 * dy - h * (ROW(Y, s)[r] + ROW(Y, 0)[r]);
            else if (row == 1)
                f = h * ROW(Y, 0)[r] - dy;
            else
                f = dy;
            acc += f;
            acc *= (i % 2 == 0) ? x : 1.0 - x;
        }
        out[r] = cur[r] + acc;
    }
}

/* Where in [0, 1] the cubic Hermite curve through (x0, slope d0) and (x1,
 * slope d1) reaches x: the time of a passage within its step, to the step's
 * fourth power (x lies between x0 and x1). */
static double crossing(double x0, double d0, double x1, double d1, double x) {
    double u = (x - x0) / (x1 - x0);
    for (int it = 0; it < 20; it++) {
        double h00 = (1 + 2 * u) * (1 - u) * (1 - u), h10 = u * (1 - u) * (1 - u), h01 = u * u * (3 - 2 * u),
               h11 = u * u * (u - 1);
        double f = h00 * x0 + h10 * d0 + h01 * x1 + h11 * d1 - x;
        double df = (6 * u * u - 6 * u) * x0 + (3 * u * u - 4 * u + 1) * d0 + (6 * u - 6 * u * u) * x1 +
                    (3 * u * u - 2 * u) * d1;
        if (!(df != 0.0)) break;
        double du = f / df;
        u = fmin(1.0, fmax(0.0, u - du));
        if (fabs(du) < 1e-15) break;
    }
    return u;
}

static grb_status fail(grb_failure *why, grb_status status, double where, double limit) {
    if (why) {
        why->where = where;
        why->limit = limit;
    }
    return status;
}

/* What one advance carries from step to step.  Three parties share it, each
 * with its own fields and its own functions below: the integrator's step
 * (t, h, the stepper rows), the change-point watch (the closure's
 * conditioning and branch orientation at the current and the proposed
 * state) and the chart that carries the motion through a change point. */
typedef struct run {
    const grb_tableau_data *tab;
    const grb_settings *st;
    problem p;
    int N, s, dense;
    double *Y, *cur, *der, *nw, *proj;
    /* the integrator's step */
    double t, h, exponent;
    int have_f;
    long steps, rejected, evals;
    /* the outputs: t_out[o] is the next to fill */
    const double *t_out;
    double *out;
    int o, last;
    /* the change-point watch: conditioning and orientation at the current
     * state, kept from the step that ended there (the projection after it
     * moves them by rounding only), and at the proposed state */
    int passing, square, uncharted; /* uncharted: near a zone where no chart could be made */
    double kappa_seen, cur_kappa, cur_orient, nw_kappa, nw_orient;
    int cur_watched, nw_watched;
    /* the chart */
    grb_chart chart;
    long passages, charts;
    long passages_before; /* the clock's, for the passage log's ring index */
} run;

/* The request is well formed: a known tableau, tolerances, step limits and
 * output times that do not go back before the clock. */
static grb_status request_ok(const grb_tableau_data *tab, const grb_settings *st, const grb_clock *clock,
                             const double *t_out, int n_out, grb_failure *why) {
    if (!tab || n_out < 1 || !(st->rtol > 0.0) || !(st->atol > 0.0) || !isfinite(st->rtol) ||
        !isfinite(st->atol) || !(st->h_max > 0.0) || st->max_steps < 0)
        return fail(why, GRB_BAD_ARGUMENT, clock->t, 0.0);
    if (!tab->adaptive && !(st->h_fixed > 0.0 && isfinite(st->h_fixed)))
        return fail(why, GRB_BAD_ARGUMENT, clock->t, st->h_fixed);
    for (int i = 0; i < n_out; i++) {
        double lo = i ? t_out[i - 1] : clock->t - 1e-12 * fmax(1.0, fabs(clock->t));
        if (!isfinite(t_out[i]) || !(t_out[i] >= lo)) return fail(why, GRB_BAD_ARGUMENT, t_out[i], 0.0);
    }
    return GRB_OK;
}

/* Set the run up from the clock and the state y, f.  Change points are
 * followed on a chart of their branch where the motion has a continuous
 * extension (DOP853), the closure is kept by projection and the mechanism has
 * one degree of freedom. */
static grb_status run_start(run *r, const grb_model *md, const grb_settings *st, const grb_clock *clock,
                            const double *y, const double *f, const double *t_out, int n_out, double *out,
                            double *work, double *stepper) {
    const grb_tableau_data *tab = grb_tableau(st->tableau);
    memset(r, 0, sizeof *r);
    r->tab = tab;
    r->st = st;
    r->p.md = md;
    r->p.s = st;
    r->p.work = work;
    r->p.N = r->N = 2 * md->n_links;
    r->p.chart = NULL;
    grb_status status = grb_ws_init(&r->p.ws, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    int N = r->N;
    rows rw = rows_of(tab);
    r->s = tab->stages;
    r->dense = tab->dense_stages > 0;
    r->Y = stepper;
    double *Y = stepper;
    r->cur = ROW(Y, rw.cur);
    r->der = ROW(Y, rw.der);
    r->nw = ROW(Y, rw.new_);
    r->proj = ROW(Y, rw.proj);
    r->square = md->n_links == 2 * md->n_closures + 1; /* mobility one, no redundant closure rows */
    r->passing = r->dense && st->project && md->n_closures > 0 &&
                 (r->square || (md->n_links <= 2 * md->n_closures && grb_closure_freedom(md, y, &r->p.ws) == 1));
    r->kappa_seen = clock->kappa_seen;
    r->cur_kappa = r->nw_kappa = 1.0;
    r->cur_orient = r->nw_orient = 0.0;
    if (r->passing) {
        grb_chart_init(&r->chart, md->n_links, ROW(Y, rw.chart));
        grb_chart_resume(&r->chart, y, st->scale);
        r->p.chart = &r->chart;
    }
    memcpy(r->cur, y, sizeof(double) * N);
    r->have_f = clock->have_f;
    if (r->have_f) memcpy(r->der, f, sizeof(double) * N);
    r->t = clock->t;
    r->h = tab->adaptive ? clock->h : st->h_fixed;
    r->exponent = -1.0 / (tab->error_order + 1);
    r->t_out = t_out;
    r->out = out;
    r->last = n_out - 1;
    r->passages_before = clock->passages;
    return GRB_OK;
}

/* The change-point watch before a step: near a change point (the closure's
 * conditioning fallen below CONDITIONING_NEAR), the motion goes on along the
 * branch's chart.  Where none can be made (the closure is ill-conditioned but
 * no branch crosses: a joint at a limit of its travel) the ordinary steps go
 * on, watched by the projection, until the conditioning recovers. */
static void watch_before_step(run *r) {
    if (!r->passing || r->chart.active) return;
    if (!r->cur_watched) watch(&r->p, &r->kappa_seen, r->cur, NULL, &r->cur_kappa, &r->cur_orient);
    r->cur_watched = 1;
    if (r->cur_kappa >= CONDITIONING_NEAR)
        r->uncharted = 0;
    else if (!r->uncharted) {
        r->charts++;
        if (grb_chart_build(r->p.md, r->st->scale, r->cur, r->kappa_seen, CONDITIONING_NEAR, &r->chart, &r->p.ws) ==
            GRB_OK) {
            grb_chart_put(&r->chart, r->cur);
            r->have_f = 0;
            r->cur_watched = 0;
        } else
            r->uncharted = 1;
    }
}

/* The derivative at the current state, evaluated unless the last step left it. */
static grb_status derivative_at_current(run *r, grb_failure *why) {
    if (!r->have_f) {
        rhs(&r->p, r->t, r->cur, r->der);
        r->evals++;
        if (!all_finite(r->der, r->N)) return fail(why, GRB_NONFINITE_DERIVATIVE, r->t, 0.0);
        r->have_f = 1;
    }
    memcpy(r->Y, r->der, sizeof(double) * r->N);
    return GRB_OK;
}

/* The change-point watch on a step the error control accepted: a step that
 * ends deep in a change point's zone, or steps over one (the branch
 * orientation flips while the motion goes on the same way), is shortened so
 * that the chart takes over at its edge.  Returns the fraction of the step to
 * try instead, or 0 to keep it. */
static double change_point_ahead(run *r) {
    const grb_model *md = r->p.md;
    int N = r->N;
    const double *vc = r->cur + N / 2, *vn = r->nw + N / 2;
    double same_way = 0.0;
    for (int i = 0; i < N / 2; i++) same_way += vc[i] * vn[i];
    /* (with redundant rows, along the rows' dominant directions at the step's
     * start; the chart's buffer is free while no chart is followed) */
    const double *basis = NULL;
    double o_cur = r->cur_orient;
    if (!r->square && grb_closure_row_basis(md, r->cur, &r->p.ws, r->chart.c) == GRB_OK) {
        basis = r->chart.c;
        o_cur = grb_branch_orientation(md, r->cur, basis, &r->p.ws);
    }
    watch(&r->p, &r->kappa_seen, r->nw, basis, &r->nw_kappa, &r->nw_orient);
    r->nw_watched = basis == NULL;
    int over = same_way > 0.0 && o_cur * r->nw_orient < 0.0;
    double k_nw = r->nw_kappa;
    if (!over && !(k_nw < 0.5 * CONDITIONING_NEAR)) return 0.0;
    /* aim at the zone's edge: the conditioning falls about linearly towards a
     * change point */
    double k_cur = r->cur_kappa, frac = 0.5;
    if (!over && k_cur > k_nw)
        frac = (k_cur - 0.75 * CONDITIONING_NEAR) / (k_cur - k_nw);
    else if (over) /* down to the pinch and up again */
        frac = (k_cur - 0.75 * CONDITIONING_NEAR) / (k_cur + k_nw);
    return fmin(0.9, fmax(0.05, frac));
}

/* On a chart, a step ends a little past its far end at most (its stages may
 * read the chart only a little beyond). */
static double within_chart(const run *r, double proposed) {
    if (!(r->passing && r->chart.active)) return proposed;
    const grb_chart *ch = &r->chart;
    double xd = r->cur[r->N / 2 + ch->held], x = r->cur[ch->held];
    double room = (xd > 0.0 ? ch->hi - x : x - ch->lo) + 0.02 * ch->half;
    if (room > 0.0 && fabs(xd) * proposed > room) proposed = room / fabs(xd);
    return proposed;
}

/* The output times inside the step just accepted, from the continuous
 * extension, put on the closure. */
static void interpolate_outputs(run *r, double step) {
    double t_end = r->t + step;
    if (!(r->dense && r->o < r->last && r->t_out[r->o] < t_end - 1e-12 * fmax(1.0, fabs(t_end)))) return;
    dense_stages(r->tab, &r->p, r->t, step, r->Y, &r->evals);
    while (r->o < r->last && r->t_out[r->o] < t_end - 1e-12 * fmax(1.0, fabs(t_end))) {
        double *row = r->out + (size_t)r->o * r->N;
        interpolate(r->tab, (r->t_out[r->o] - r->t) / step, step, r->Y, r->N, row);
        if (r->st->project) put_on_closure(&r->p, row);
        r->o++;
    }
}

/* One step of the fixed-step tableau towards t_target. */
static grb_status fixed_step(run *r, double t_target, double *step, int *have_new_f, grb_failure *why) {
    *step = fmin(r->h, t_target - r->t);
    try_step(r->tab, &r->p, r->t, *step, r->Y, &r->evals);
    if (!all_finite(r->nw, r->N)) return fail(why, GRB_NONFINITE_FIXED_STEP, r->t + *step, *step);
    *have_new_f = 0;
    return GRB_OK;
}

/* One accepted step of the adaptive tableau towards t_target: tried, and
 * shortened until the error control and the change-point watch accept it;
 * then the next step's size, and the outputs inside this one. */
static grb_status adaptive_step(run *r, double t_target, double *step_out, int *have_new_f, grb_failure *why) {
    const grb_settings *st = r->st;
    if (!(r->h > 0.0)) {
        r->h = initial_step(r->tab, &r->p, r->t, r->Y, st->h_max);
        r->evals++;
    }
    double proposed = within_chart(r, fmin(r->h, st->h_max));
    double step = fmin(proposed, t_target - r->t);
    int clipped = step < proposed, rejected = 0;
    double h_min = 1e-13 * fmax(1.0, fabs(r->t)), err;
    for (;;) {
        /* (a nan step fails this test too: no endless rejection loop) */
        if (!(step >= h_min)) return fail(why, GRB_STEP_UNDERFLOW, r->t, h_min);
        err = try_step(r->tab, &r->p, r->t, step, r->Y, &r->evals);
        if (err <= 1.0 && r->passing && !r->chart.active && !r->uncharted) {
            double frac = change_point_ahead(r);
            if (frac > 0.0) {
                r->rejected++;
                step *= frac;
                clipped = 0;
                continue;
            }
        }
        if (err <= 1.0) break;
        r->rejected++;
        rejected = 1;
        if (isfinite(err))
            step *= fmax(MIN_FACTOR, SAFETY * pow(err, r->exponent));
        else
            step *= MIN_FACTOR;
        clipped = 0;
    }
    double factor = err == 0.0 ? MAX_FACTOR : fmin(MAX_FACTOR, SAFETY * pow(err, r->exponent));
    if (rejected) factor = fmin(1.0, factor);
    /* a step shortened only to land on t_target keeps the controller's proposal */
    r->h = clipped ? fmax(proposed, step * factor) : step * factor;
    *have_new_f = 1;
    interpolate_outputs(r, step);
    *step_out = step;
    return GRB_OK;
}

/* On the chart: the new state is put on it exactly, and a passage is the
 * motion crossing the chart's pinch.  Returns 1 when the chart placed the new
 * state (it then needs no projection).  Off the chart (well conditioned there;
 * beyond its reach, the projection puts the state on the closure) the chart
 * is let go. */
static int follow_chart(run *r, double step, int *have_new_f) {
    if (!(r->passing && r->chart.active)) return 0;
    grb_chart *ch = &r->chart;
    const grb_settings *st = r->st;
    int N = r->N, held = ch->held;
    if (ch->pinch_kappa < CONDITIONING_PINCH && (r->cur[held] - ch->pinch) * (r->nw[held] - ch->pinch) < 0.0) {
        double at = r->t + step * crossing(r->cur[held], step * r->cur[N / 2 + held], r->nw[held],
                                           step * r->nw[N / 2 + held], ch->pinch);
        if (st->passage_log && st->passage_capacity > 0)
            st->passage_log[(r->passages_before + r->passages) % st->passage_capacity] = at;
        r->passages++;
    }
    int charted = grb_chart_put(ch, r->nw);
    if (charted) *have_new_f = 0;
    if (!charted || r->nw[held] < ch->lo || r->nw[held] > ch->hi) ch->active = 0;
    return charted;
}

/* The new state projected onto the closures.  A step's correction is of the
 * order of the tolerance; one that takes a good part of the speed away means
 * the step crossed a position where two assembly branches meet (a change
 * point) and landed on the other: the motion would go on, closed but with
 * energy gone.  (Relative to the speed, and far above the tolerance: a
 * resting linkage's last 1e-9 rad/s may well go.)  A correction far below
 * the tolerance leaves the step's derivative valid. */
static grb_status project_step(run *r, int *have_new_f, grb_failure *why) {
    const grb_settings *st = r->st;
    int N = r->N, half = N / 2;
    double *proj = r->proj, *nw = r->nw;
    memcpy(proj, nw, sizeof(double) * N);
    grb_project_ws(r->p.md, st->scale, proj, &r->p.ws);
    double dv2 = 0.0, v2 = 0.0;
    for (int i = half; i < N; i++) {
        dv2 += (proj[i] - nw[i]) * (proj[i] - nw[i]);
        v2 += nw[i] * nw[i];
    }
    if (dv2 > BRANCH_JUMP * BRANCH_JUMP * v2 && dv2 > (1e3 * st->atol) * (1e3 * st->atol))
        return fail(why, GRB_BRANCH_JUMP, r->t, sqrt(dv2 / v2));
    if (!all_finite(proj, N)) return fail(why, GRB_NONFINITE_DERIVATIVE, r->t, 0.0);
    if (*have_new_f) {
        double d = 0.0;
        for (int i = 0; i < N; i++) {
            double v = (proj[i] - nw[i]) / (st->atol + st->rtol * fabs(proj[i]));
            d += v * v;
        }
        if (sqrt(d / N) > 1e-3) *have_new_f = 0;
    }
    memcpy(nw, proj, sizeof(double) * N);
    return GRB_OK;
}

/* The new state becomes the current one, with what was watched at its end
 * and its derivative when still valid. */
static void accept_step(run *r, double step, int have_new_f) {
    int N = r->N;
    r->t += step;
    memcpy(r->cur, r->nw, sizeof(double) * N);
    r->cur_watched = r->nw_watched && !r->chart.active;
    r->cur_kappa = r->nw_kappa;
    r->cur_orient = r->nw_orient;
    r->nw_watched = 0;
    if (have_new_f) memcpy(r->der, ROW(r->Y, r->s), sizeof(double) * N);
    r->have_f = have_new_f;
    r->steps++;
}

/* Output times the step just taken ended on (to rounding) take its state. */
static void outputs_at_step_end(run *r) {
    int N = r->N;
    while (r->dense && r->o < r->last && r->t_out[r->o] - r->t <= 1e-12 * fmax(1.0, fabs(r->t_out[r->o]))) {
        memcpy(r->out + (size_t)r->o * N, r->cur, sizeof(double) * N);
        r->o++;
    }
}

/* Steps from the current time to t_target: the watch, the integrator's step,
 * the chart or the projection, then the step taken. */
static grb_status steps_to(run *r, double t_target, grb_failure *why) {
    const grb_settings *st = r->st;
    grb_status status;
    while (t_target - r->t > 1e-12 * fmax(1.0, fabs(t_target))) {
        double step;
        int have_new_f;
        watch_before_step(r);
        if ((status = derivative_at_current(r, why)) != GRB_OK) return status;
        status = r->tab->adaptive ? adaptive_step(r, t_target, &step, &have_new_f, why)
                                  : fixed_step(r, t_target, &step, &have_new_f, why);
        if (status != GRB_OK) return status;
        int charted = follow_chart(r, step, &have_new_f);
        if (!charted && st->project && r->p.md->n_closures > 0 &&
            (status = project_step(r, &have_new_f, why)) != GRB_OK)
            return status;
        accept_step(r, step, have_new_f);
        if (r->steps > st->max_steps) return fail(why, GRB_TOO_MANY_STEPS, t_target, (double)st->max_steps);
        outputs_at_step_end(r);
    }
    r->t = t_target;
    memcpy(r->out + (size_t)r->o * r->N, r->cur, sizeof(double) * r->N);
    r->o++;
    return GRB_OK;
}

/* The run's end state into y, f and the clock (only after success: all or nothing). */
static void run_finish(run *r, grb_clock *clock, double *y, double *f) {
    memcpy(y, r->cur, sizeof(double) * r->N);
    if (r->have_f) memcpy(f, r->der, sizeof(double) * r->N);
    if (r->passing) grb_chart_save(&r->chart);
    clock->t = r->t;
    clock->h = r->tab->adaptive ? r->h : clock->h;
    clock->have_f = r->have_f;
    clock->steps += r->steps;
    clock->rejected += r->rejected;
    clock->evals += r->evals;
    clock->passages += r->passages;
    clock->charts += r->charts;
    clock->kappa_seen = r->kappa_seen;
}

static grb_status advance(const grb_model *md, const grb_settings *st, grb_clock *clock, double *y, double *f,
                          const double *t_out, int n_out, double *out, double *work, double *stepper,
                          grb_failure *why) {
    run r;
    grb_status status = request_ok(grb_tableau(st->tableau), st, clock, t_out, n_out, why);
    if (status != GRB_OK) return status;
    if ((status = run_start(&r, md, st, clock, y, f, t_out, n_out, out, work, stepper)) != GRB_OK)
        return fail(why, status, clock->t, 0.0);
    /* with a continuous extension the steps aim at the last time and the
     * others are interpolated; without, each time is a step's end */
    while (r.o <= r.last)
        if ((status = steps_to(&r, r.dense ? t_out[r.last] : t_out[r.o], why)) != GRB_OK) return status;
    run_finish(&r, clock, y, f);
    return GRB_OK;
}

grb_status grb_advance(const grb_model *md, const grb_settings *st, grb_clock *clock, double *y, double *f,
                       const double *t_out, int n_out, double *out, double *work, double *stepper,
                       grb_failure *why) {
    grb_status status = advance(md, st, clock, y, f, t_out, n_out, out, work, stepper, why);
    /* the evaluations and projections leave the tables at no one state */
    if (work && work[WORK_TAG] == GRB_WORK_TAG) work[WORK_FILLED] = GRB_FILLED_NOTHING;
    return status;
}
