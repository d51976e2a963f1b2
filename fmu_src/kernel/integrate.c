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
#define CHART_ROWS ((5 * CHART_NODES + 10 + 1) / 2)

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

static grb_status advance(const grb_model *md, const grb_settings *st, grb_clock *clock, double *y, double *f,
                          const double *t_out, int n_out, double *out, double *work, double *stepper,
                          grb_failure *why) {
    const grb_tableau_data *tab = grb_tableau(st->tableau);
    if (!tab || n_out < 1 || !(st->rtol > 0.0) || !(st->atol > 0.0) || !isfinite(st->rtol) ||
        !isfinite(st->atol) || !(st->h_max > 0.0) || st->max_steps < 0)
        return fail(why, GRB_BAD_ARGUMENT, clock->t, 0.0);
    if (!tab->adaptive && !(st->h_fixed > 0.0 && isfinite(st->h_fixed)))
        return fail(why, GRB_BAD_ARGUMENT, clock->t, st->h_fixed);
    for (int i = 0; i < n_out; i++) {
        double lo = i ? t_out[i - 1] : clock->t - 1e-12 * fmax(1.0, fabs(clock->t));
        if (!isfinite(t_out[i]) || !(t_out[i] >= lo)) return fail(why, GRB_BAD_ARGUMENT, t_out[i], 0.0);
    }
    problem p = {md, st, {0}, work, 2 * md->n_links, NULL};
    grb_status status = grb_ws_init(&p.ws, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return fail(why, status, clock->t, 0.0);
    int N = p.N, s = tab->stages, dense = tab->dense_stages > 0;
    rows rw = rows_of(tab);
    double *Y = stepper;
    /* change points are followed on a chart of their branch where the motion
     * has a continuous extension (DOP853), the closure is kept by projection
     * and the mechanism has one degree of freedom */
    grb_chart chart;
    int square = md->n_links == 2 * md->n_closures + 1; /* mobility one, no redundant closure rows */
    int passing = dense && st->project && md->n_closures > 0 &&
                  (square || (md->n_links <= 2 * md->n_closures && grb_closure_freedom(md, y, &p.ws) == 1));
    double kappa_seen = clock->kappa_seen;
    long passages = 0, charts = 0;
    int uncharted = 0; /* near a zone where no chart could be made */
    /* the current state's conditioning and orientation, kept from the step that
     * ended there (the projection after it moves them by rounding only) */
    double cur_kappa = 1.0, cur_orient = 0.0, nw_kappa = 1.0, nw_orient = 0.0;
    int cur_watched = 0, nw_watched = 0;
    if (passing) {
        grb_chart_init(&chart, md->n_links, ROW(Y, rw.chart));
        grb_chart_resume(&chart, y, st->scale);
        p.chart = &chart;
    }
    double *cur = ROW(Y, rw.cur), *der = ROW(Y, rw.der), *nw = ROW(Y, rw.new_), *proj = ROW(Y, rw.proj);
    memcpy(cur, y, sizeof(double) * N);
    int have_f = clock->have_f;
    if (have_f) memcpy(der, f, sizeof(double) * N);
    double t = clock->t, h = tab->adaptive ? clock->h : st->h_fixed;
    long steps = 0, rejected_total = 0, evals = 0;
    double exponent = -1.0 / (tab->error_order + 1);
    int last = n_out - 1, o = 0;
    while (o <= last) {
        /* with a continuous extension the steps aim at the last time and the
         * others are interpolated; without, each time is a step's end */
        double t_target = dense ? t_out[last] : t_out[o];
        while (t_target - t > 1e-12 * fmax(1.0, fabs(t_target))) {
            if (passing && !chart.active) {
                if (!cur_watched) watch(&p, &kappa_seen, cur, NULL, &cur_kappa, &cur_orient);
                cur_watched = 1;
                double k_cur = cur_kappa;
                if (k_cur >= CONDITIONING_NEAR)
                    uncharted = 0;
                else if (!uncharted) {
                    /* near a change point: from here on along the branch's chart.
                     * Where none can be made (the closure is ill-conditioned
                     * but no branch crosses: a joint at a limit of its travel)
                     * the ordinary steps go on, watched by the projection,
                     * until the conditioning recovers. */
                    charts++;
                    if (grb_chart_build(md, st->scale, cur, kappa_seen, CONDITIONING_NEAR, &chart, &p.ws) == GRB_OK) {
                        grb_chart_put(&chart, cur);
                        have_f = 0;
                        cur_watched = 0;
                    } else
                        uncharted = 1;
                }
            }
            if (!have_f) {
                rhs(&p, t, cur, der);
                evals++;
                if (!all_finite(der, N)) return fail(why, GRB_NONFINITE_DERIVATIVE, t, 0.0);
                have_f = 1;
            }
            memcpy(ROW(Y, 0), der, sizeof(double) * N);
            double step;
            int have_new_f;
            if (!tab->adaptive) {
                step = fmin(h, t_target - t);
                try_step(tab, &p, t, step, Y, &evals);
                if (!all_finite(nw, N)) return fail(why, GRB_NONFINITE_FIXED_STEP, t + step, step);
                have_new_f = 0;
            } else {
                if (!(h > 0.0)) {
                    h = initial_step(tab, &p, t, Y, st->h_max);
                    evals++;
                }
                double proposed = fmin(h, st->h_max);
                if (passing && chart.active) {
                    /* on a chart, a step ends a little past its far end at most
                     * (its stages may read the chart only a little beyond) */
                    double xd = cur[N / 2 + chart.held], x = cur[chart.held];
                    double room = (xd > 0.0 ? chart.hi - x : x - chart.lo) + 0.02 * chart.half;
                    if (room > 0.0 && fabs(xd) * proposed > room) proposed = room / fabs(xd);
                }
                step = fmin(proposed, t_target - t);
                int clipped = step < proposed, rejected = 0;
                double h_min = 1e-13 * fmax(1.0, fabs(t)), err;
                for (;;) {
                    /* (a nan step fails this test too: no endless rejection loop) */
                    if (!(step >= h_min)) return fail(why, GRB_STEP_UNDERFLOW, t, h_min);
                    err = try_step(tab, &p, t, step, Y, &evals);
                    if (err <= 1.0 && passing && !chart.active && !uncharted) {
                        /* a step that ends deep in a change point's zone, or
                         * steps over one (the branch orientation flips while
                         * the motion goes on the same way), is shortened so
                         * that the chart takes over at its edge */
                        const double *vc = cur + N / 2, *vn = nw + N / 2;
                        double same_way = 0.0;
                        for (int r = 0; r < N / 2; r++) same_way += vc[r] * vn[r];
                        /* (with redundant rows, along the rows' dominant
                         * directions at the step's start; the chart's buffer
                         * is free while no chart is followed) */
                        const double *basis = NULL;
                        double o_cur = cur_orient;
                        if (!square && grb_closure_row_basis(md, cur, &p.ws, chart.c) == GRB_OK) {
                            basis = chart.c;
                            o_cur = grb_branch_orientation(md, cur, basis, &p.ws);
                        }
                        watch(&p, &kappa_seen, nw, basis, &nw_kappa, &nw_orient);
                        nw_watched = basis == NULL;
                        int over = same_way > 0.0 && o_cur * nw_orient < 0.0;
                        double k_nw = nw_kappa;
                        if (over || k_nw < 0.5 * CONDITIONING_NEAR) {
                            /* aim at the zone's edge: the conditioning falls
                             * about linearly towards a change point */
                            double k_cur = cur_kappa, frac = 0.5;
                            if (!over && k_cur > k_nw)
                                frac = (k_cur - 0.75 * CONDITIONING_NEAR) / (k_cur - k_nw);
                            else if (over) /* down to the pinch and up again */
                                frac = (k_cur - 0.75 * CONDITIONING_NEAR) / (k_cur + k_nw);
                            frac = fmin(0.9, fmax(0.05, frac));
                            rejected_total++;
                            step *= frac;
                            clipped = 0;
                            continue;
                        }
                    }
                    if (err <= 1.0) break;
                    rejected_total++;
                    rejected = 1;
                    if (isfinite(err))
                        step *= fmax(MIN_FACTOR, SAFETY * pow(err, exponent));
                    else
                        step *= MIN_FACTOR;
                    clipped = 0;
                }
                double factor = err == 0.0 ? MAX_FACTOR : fmin(MAX_FACTOR, SAFETY * pow(err, exponent));
                if (rejected) factor = fmin(1.0, factor);
                /* a step shortened only to land on t_target keeps the controller's proposal */
                h = clipped ? fmax(proposed, step * factor) : step * factor;
                have_new_f = 1;
                double t_end = t + step;
                if (dense && o < last && t_out[o] < t_end - 1e-12 * fmax(1.0, fabs(t_end))) {
                    dense_stages(tab, &p, t, step, Y, &evals);
                    while (o < last && t_out[o] < t_end - 1e-12 * fmax(1.0, fabs(t_end))) {
                        double *row = out + (size_t)o * N;
                        interpolate(tab, (t_out[o] - t) / step, step, Y, N, row);
                        if (st->project) put_on_closure(&p, row);
                        o++;
                    }
                }
            }
            int charted = 0;
            if (passing && chart.active) {
                /* on the chart: the new state is put on it exactly; a passage is
                 * the motion crossing the chart's pinch */
                int held = chart.held;
                if (chart.pinch_kappa < CONDITIONING_PINCH && (cur[held] - chart.pinch) * (nw[held] - chart.pinch) < 0.0) {
                    double at = t + step * crossing(cur[held], step * cur[N / 2 + held], nw[held],
                                                    step * nw[N / 2 + held], chart.pinch);
                    if (st->passage_log && st->passage_capacity > 0)
                        st->passage_log[(clock->passages + passages) % st->passage_capacity] = at;
                    passages++;
                }
                charted = grb_chart_put(&chart, nw);
                if (charted) have_new_f = 0;
                /* off the chart (well conditioned there; beyond its reach, the
                 * projection below puts the state on the closure) */
                if (!charted || nw[held] < chart.lo || nw[held] > chart.hi) chart.active = 0;
            }
            if (!charted && st->project && md->n_closures > 0) {
                memcpy(proj, nw, sizeof(double) * N);
                grb_project_ws(md, st->scale, proj, &p.ws);
                /* a step's correction is of the order of the tolerance; one that
                 * takes a good part of the speed away means the step crossed a
                 * position where two assembly branches meet (a change point) and
                 * landed on the other: the motion would go on, closed but with
                 * energy gone.  (Relative to the speed, and far above the
                 * tolerance: a resting linkage's last 1e-9 rad/s may well go.) */
                int half = N / 2;
                double dv2 = 0.0, v2 = 0.0;
                for (int r = half; r < N; r++) {
                    dv2 += (proj[r] - nw[r]) * (proj[r] - nw[r]);
                    v2 += nw[r] * nw[r];
                }
                if (dv2 > BRANCH_JUMP * BRANCH_JUMP * v2 && dv2 > (1e3 * st->atol) * (1e3 * st->atol))
                    return fail(why, GRB_BRANCH_JUMP, t, sqrt(dv2 / v2));
                if (!all_finite(proj, N)) return fail(why, GRB_NONFINITE_DERIVATIVE, t, 0.0);
                /* a correction far below the tolerance leaves the derivative valid */
                if (have_new_f) {
                    double d = 0.0;
                    for (int r = 0; r < N; r++) {
                        double v = (proj[r] - nw[r]) / (st->atol + st->rtol * fabs(proj[r]));
                        d += v * v;
                    }
                    if (sqrt(d / N) > 1e-3) have_new_f = 0;
                }
                memcpy(nw, proj, sizeof(double) * N);
            }
            t += step;
            memcpy(cur, nw, sizeof(double) * N);
            /* what was watched at the step's end is the new current state's */
            cur_watched = nw_watched && !chart.active;
            cur_kappa = nw_kappa;
            cur_orient = nw_orient;
            nw_watched = 0;
            if (have_new_f) memcpy(der, ROW(Y, s), sizeof(double) * N);
            have_f = have_new_f;
            steps++;
            if (steps > st->max_steps) return fail(why, GRB_TOO_MANY_STEPS, t_target, (double)st->max_steps);
            /* times the step ended on (to rounding) take its projected state */
            while (dense && o < last && t_out[o] - t <= 1e-12 * fmax(1.0, fabs(t_out[o]))) {
                memcpy(out + (size_t)o * N, cur, sizeof(double) * N);
                o++;
            }
        }
        t = t_target;
        memcpy(out + (size_t)o * N, cur, sizeof(double) * N);
        o++;
    }
    memcpy(y, cur, sizeof(double) * N);
    if (have_f) memcpy(f, der, sizeof(double) * N);
    if (passing) grb_chart_save(&chart);
    clock->t = t;
    clock->h = tab->adaptive ? h : clock->h;
    clock->have_f = have_f;
    clock->steps += steps;
    clock->rejected += rejected_total;
    clock->evals += evals;
    clock->passages += passages;
    clock->charts += charts;
    clock->kappa_seen = kappa_seen;
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
