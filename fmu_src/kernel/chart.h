/* The change-point chart's method, one for the planar kernel (chart.c) and the
 * spatial one (spatial/sp_chart.c); chart.c's opening comment gives the
 * method.  What differs between the kernels is the branch: where its point
 * for a held coordinate lies (the closure solved with that coordinate held),
 * how well the closure is conditioned there, and whether a coordinate is a
 * slide (measured per the scale) or a rotation.  Each kernel gives those as a
 * grb_branch; the rest is here, static inline, as project.h is, so that each
 * kernel compiles its own copy of one text (the spatial FMU compiles no
 * planar chart.c: fmu_src/fmi/build.py spatial_base).
 *
 * The chart's buffer (grb_chart_size doubles, caller-owned): 3 x CHART_NODES
 * x n coefficients, 2 x CHART_NODES x n node values, 11 n scratch:
 *   0 z, 1 t, 2 z_lo, 3 t_lo, 4 z_hi, 5 t_hi   (build; 0..2 also rhs, eval)
 *   6 trial, 7 t_new, 10 predicted             (one continuation step)
 *   8 z, 9 t at the worst conditioning met      (the pinch search's start) */
#ifndef GRB_CHART_H
#define GRB_CHART_H

#include <math.h>
#include <string.h>

#include "workspace.h" /* grb_chart, CHART_NODES, GRB_OK, GRB_BRANCH_JUMP */

#define MARCH_STEPS 2000     /* continuation steps at most, each way */
#define MARCH_FIRST 1e-3     /* first continuation step, rad (or m per the scale) */
#define MARCH_SMALLEST 1e-10 /* below it the continuation gives up */
#define CHART_CHECK 1e-9     /* chart against a fresh branch point, relative to the scale */
#define CHART_REACH 0.05     /* how far past its range (in half widths) the chart may be read */
#define MARCH_LONGEST 0.1    /* longest continuation step, rad (or m per the scale) */
#define PINCH_AVOID 1e-5     /* conditioning (relative) below which no continuation step ends */
#define CHART_PI 3.14159265358979323846

/* A kernel's assembly branch: point(model, held, scale, z, t, ws) moves z onto
 * the branch with z[held] kept and leaves its tangent dz/dx in t (a non-finite
 * answer: no branch point there); conditioning(model, z, ws) is the closure's
 * conditioning at z; slides(model, ws, i) whether coordinate i is a slide. */
typedef struct grb_branch {
    double (*point)(const void *model, int held, double scale, double *z, double *t, void *ws);
    double (*conditioning)(const void *model, const double *z, void *ws);
    int (*slides)(const void *model, const void *ws, int i);
    const void *model;
    void *ws;
    double scale;
    int n;
} grb_branch;

/* doubles of the chart's buffer per coordinate */
#define CHART_PER_COORD (5 * CHART_NODES + 11)

static inline size_t grb_chart_size(int n) { return (size_t)CHART_PER_COORD * (size_t)n; }

/* the chart over the caller's buffer of grb_chart_size(n) doubles, inactive */
static inline void grb_chart_init(grb_chart *ch, int n, double *buffer) {
    memset(ch, 0, sizeof *ch);
    ch->n = n;
    ch->c = buffer;
    ch->values = buffer + 3 * CHART_NODES * n;
    ch->scratch = buffer + 5 * CHART_NODES * n;
}

/* Chebyshev polynomials T_0 .. T_{N-1} at u */
static inline void chart_chebyshev(double u, double *T) {
    T[0] = 1.0;
    T[1] = u;
    for (int k = 2; k < CHART_NODES; k++) T[k] = 2.0 * u * T[k - 1] - T[k - 2];
}

/* Coefficients c (CHART_NODES x n) of sum_k c_k T_k(u) through the values
 * (CHART_NODES x n) at the Chebyshev nodes u_j = cos(pi (j + 1/2) / N). */
static inline void chart_fit(const double *values, int n, double *c) {
    double T[CHART_NODES];
    for (int i = 0; i < CHART_NODES * n; i++) c[i] = 0.0;
    for (int j = 0; j < CHART_NODES; j++) {
        chart_chebyshev(cos(CHART_PI * (j + 0.5) / CHART_NODES), T);
        for (int k = 0; k < CHART_NODES; k++) {
            double wk = (k == 0 ? 1.0 : 2.0) / CHART_NODES;
            for (int i = 0; i < n; i++) c[k * n + i] += wk * T[k] * values[j * n + i];
        }
    }
}

/* The derivative's coefficients d of the series c, for x = mid + half u. */
static inline void chart_derivative(const double *c, int n, double half, double *d) {
    for (int i = 0; i < n; i++) {
        /* d_{k-1} = d_{k+1} + 2 k c_k, with d_0 halved for the plain sum */
        double d_next = 0.0, d_here = 0.0;
        d[(CHART_NODES - 1) * n + i] = 0.0;
        for (int k = CHART_NODES - 1; k >= 1; k--) {
            double d_prev = d_next + 2.0 * k * c[k * n + i];
            d_next = d_here;
            d_here = d_prev;
            d[(k - 1) * n + i] = d_prev;
        }
        d[i] *= 0.5;
        for (int k = 0; k < CHART_NODES; k++) d[k * n + i] /= half;
    }
}

/* z, dz/dx and d2z/dx2 (each optional) of the chart at x; 0 when x is too far
 * outside the chart's range to read it. */
static inline int grb_chart_eval(const grb_chart *ch, double x, double *z, double *dz, double *ddz) {
    int n = ch->n;
    double u = (x - ch->mid) / ch->half, T[CHART_NODES];
    if (!(fabs(u) <= 1.0 + CHART_REACH)) return 0;
    chart_chebyshev(u, T);
    double *out[3] = {z, dz, ddz};
    for (int level = 0; level < 3; level++) {
        if (!out[level]) continue;
        const double *c = ch->c + level * CHART_NODES * n;
        for (int i = 0; i < n; i++) {
            double v = 0.0;
            for (int k = CHART_NODES - 1; k >= 0; k--) v += c[k * n + i] * T[k];
            out[level][i] = v;
        }
    }
    return 1;
}

/* The held coordinate's unit: a rotation's radian, a slide's scale. */
static inline double chart_unit(const grb_branch *br, int held) {
    return br->slides(br->model, br->ws, held) ? br->scale : 1.0;
}

/* One continuation step: from the branch point z (tangent t) at x to the one
 * at x + dx, predicted along the tangent.  The correction must be small
 * against the move, or the step is refused (0: it may have left the branch).
 * A point whose closure conditioning is below kappa_floor is refused too (2):
 * right at the pinch a branch point is known only to the rounding of the
 * closure over sigma, too coarse to continue from.  The new point's
 * conditioning goes to *kappa. */
static inline int chart_continue_to(const grb_branch *br, int held, double dx, double kappa_floor, double *z,
                                    double *t, grb_chart *ch, double *kappa) {
    int n = br->n;
    double *trial = ch->scratch + 6 * n, *t_new = ch->scratch + 7 * n, *predicted = ch->scratch + 10 * n;
    double move = 0.0, corr = 0.0, scale = br->scale;
    for (int i = 0; i < n; i++) {
        trial[i] = z[i] + dx * t[i];
        move = fmax(move, fabs(dx * t[i]));
    }
    memcpy(predicted, trial, sizeof(double) * n);
    if (!isfinite(br->point(br->model, held, scale, trial, t_new, br->ws))) return 0;
    for (int i = 0; i < n; i++) corr = fmax(corr, fabs(trial[i] - predicted[i]));
    if (!(corr <= 1e-2 * move + 1e-13 * scale)) return 0;
    *kappa = br->conditioning(br->model, trial, br->ws);
    if (*kappa < kappa_floor) return 2;
    memcpy(z, trial, sizeof(double) * n);
    memcpy(t, t_new, sizeof(double) * n);
    return 1;
}

/* Continue along the branch from (z, t) at x towards direction d (+1/-1)
 * until the closure is conditioned at least `near` (relative to kappa_ref) and
 * getting better, or up to x = target when target is finite.  Tracks the
 * pinch (the worst conditioning met).  z, t end at the last point. */
static inline int chart_march(const grb_branch *br, int held, double d, double target, double kappa_ref, double near,
                              double *z, double *t, grb_chart *ch, int track) {
    int n = br->n;
    double unit = chart_unit(br, held), dx = MARCH_FIRST * unit;
    double last = br->conditioning(br->model, z, br->ws) / kappa_ref;
    for (int k = 0; k < MARCH_STEPS; k++) {
        double floor = PINCH_AVOID * kappa_ref;
        if (isfinite(target)) {
            double left = d * (target - z[held]);
            if (left <= 1e-14 * fmax(1.0, fabs(target))) return 1;
            if (dx >= left) {
                dx = left;
                floor = 0.0; /* the target itself: wherever it is */
            }
        }
        double kappa;
        int status = chart_continue_to(br, held, d * dx, floor, z, t, ch, &kappa);
        if (status == 2) {
            dx *= 2.5; /* over the pinch rather than onto it */
            continue;
        }
        if (!status) {
            dx *= 0.25;
            if (dx < MARCH_SMALLEST) return 0;
            k--;
            continue;
        }
        kappa /= kappa_ref;
        if (track && kappa < ch->pinch_kappa) {
            /* the worst point so far, its step and its branch point: the
             * pinch lies within a step of it */
            ch->pinch_kappa = kappa;
            ch->pinch = z[held];
            ch->pinch_step = 1.5 * dx;
            memcpy(ch->scratch + 8 * n, z, sizeof(double) * n);
            memcpy(ch->scratch + 9 * n, t, sizeof(double) * n);
        }
        if (!isfinite(target) && kappa >= near && kappa > last) return 1;
        last = kappa;
        dx = fmin(1.5 * dx, MARCH_LONGEST * unit);
    }
    return !isfinite(target) ? 0 : 1;
}

/* The conditioning at the branch point where the held coordinate is x, by
 * continuation from the worst point the continuation met (scratch 8, 9). */
static inline int chart_kappa_at(const grb_branch *br, int held, double kappa_ref, grb_chart *ch, double x,
                                 double *kappa) {
    int n = br->n;
    double *z = ch->scratch + 4 * n, *t = ch->scratch + 5 * n, x0 = ch->pinch;
    memcpy(z, ch->scratch + 8 * n, sizeof(double) * n);
    memcpy(t, ch->scratch + 9 * n, sizeof(double) * n);
    if (!chart_march(br, held, x > x0 ? 1.0 : -1.0, x, kappa_ref, 1.0, z, t, ch, 0)) return 0;
    *kappa = br->conditioning(br->model, z, br->ws);
    return 1;
}

/* The pinch to rounding: the worst conditioning along the branch, by golden
 * section (one new probe per narrowing) over branch points within a
 * continuation step of the worst one the continuation met (its steps only
 * bracket it).  To 1e-7 of that step: closer in, branch points are
 * ill-conditioned; where one cannot be had the bracket reached stands. */
static inline void chart_refine_pinch(const grb_branch *br, int held, double kappa_ref, grb_chart *ch) {
    double g = 0.5 * (sqrt(5.0) - 1.0), step = ch->pinch_step, k1, k2;
    double a = ch->pinch - step, b = ch->pinch + step, x1 = b - g * (b - a), x2 = a + g * (b - a);
    if (!chart_kappa_at(br, held, kappa_ref, ch, x1, &k1) || !chart_kappa_at(br, held, kappa_ref, ch, x2, &k2))
        return;
    for (int it = 0; it < 100 && b - a > 1e-7 * step; it++) {
        if (k1 < k2) { /* the minimum lies in [a, x2]: x1 becomes the upper probe */
            b = x2;
            x2 = x1;
            k2 = k1;
            x1 = b - g * (b - a);
            if (!chart_kappa_at(br, held, kappa_ref, ch, x1, &k1)) break;
        } else {
            a = x1;
            x1 = x2;
            k1 = k2;
            x2 = a + g * (b - a);
            if (!chart_kappa_at(br, held, kappa_ref, ch, x2, &k2)) break;
        }
    }
    ch->pinch = 0.5 * (a + b);
    ch->pinch_kappa = fmin(ch->pinch_kappa, fmin(k1, k2) / kappa_ref);
}

/* The chart in one held coordinate (GRB_BRANCH_JUMP when the branch is not a
 * curve in it here: it folds back in that coordinate, or the chart fails its
 * check). */
static inline int chart_build_on(const grb_branch *br, const double *y, double kappa_ref, double near, int held,
                                 grb_chart *ch) {
    int n = br->n;
    double scale = br->scale;
    double *z = ch->scratch, *t = ch->scratch + n, *z_lo = ch->scratch + 2 * n, *t_lo = ch->scratch + 3 * n;
    double *z_hi = ch->scratch + 4 * n, *t_hi = ch->scratch + 5 * n;
    ch->active = 0;
    ch->held = held;
    ch->pinch = y[held];
    ch->pinch_kappa = br->conditioning(br->model, y, br->ws) / kappa_ref;
    memcpy(z, y, sizeof(double) * n);
    if (!isfinite(br->point(br->model, held, scale, z, t, br->ws))) return GRB_BRANCH_JUMP;
    /* (the pinch may lie within the first continuation step either way) */
    ch->pinch_step = 1.5 * MARCH_FIRST * chart_unit(br, held);
    memcpy(ch->scratch + 8 * n, z, sizeof(double) * n);
    memcpy(ch->scratch + 9 * n, t, sizeof(double) * n);
    /* both ways from here to where the closure is well conditioned again */
    memcpy(z_lo, z, sizeof(double) * n);
    memcpy(t_lo, t, sizeof(double) * n);
    memcpy(z_hi, z, sizeof(double) * n);
    memcpy(t_hi, t, sizeof(double) * n);
    if (!chart_march(br, held, -1.0, INFINITY, kappa_ref, near, z_lo, t_lo, ch, 1) ||
        !chart_march(br, held, +1.0, INFINITY, kappa_ref, near, z_hi, t_hi, ch, 1))
        return GRB_BRANCH_JUMP;
    double lo = z_lo[held], hi = z_hi[held];
    chart_refine_pinch(br, held, kappa_ref, ch);
    /* no node near the pinch, where a branch point's tangent is least accurate */
    double width = hi - lo, mid = 0.5 * (lo + hi), half = 0.5 * width;
    for (int j = 0, moves = 0; j < CHART_NODES && moves < 100; j++) {
        double node = mid + half * cos(CHART_PI * (j + 0.5) / CHART_NODES);
        if (fabs(node - ch->pinch) < 0.01 * width) {
            moves++;
            hi += 3e-3 * width;
            mid = 0.5 * (lo + hi);
            half = 0.5 * (hi - lo);
            j = -1;
        }
    }
    /* branch points and tangents at the nodes, in increasing x from the low
     * end (the last node first: cos decreases with j) */
    double *values = ch->values, *tangents = ch->values + CHART_NODES * n;
    memcpy(z, z_lo, sizeof(double) * n);
    memcpy(t, t_lo, sizeof(double) * n);
    for (int j = CHART_NODES - 1; j >= 0; j--) {
        double node = mid + half * cos(CHART_PI * (j + 0.5) / CHART_NODES);
        if (!chart_march(br, held, +1.0, node, kappa_ref, near, z, t, ch, 0)) return GRB_BRANCH_JUMP;
        z[held] = node;
        memcpy(values + j * n, z, sizeof(double) * n);
        memcpy(tangents + j * n, t, sizeof(double) * n);
    }
    /* z(x) and its tangent dz/dx each through its own node values, the
     * curvature as the tangent's derivative: differentiating z's interpolant
     * twice would amplify the values' rounding by N^4 / half^2 */
    chart_fit(values, n, ch->c);
    chart_fit(tangents, n, ch->c + CHART_NODES * n);
    chart_derivative(ch->c + CHART_NODES * n, n, half, ch->c + 2 * CHART_NODES * n);
    ch->lo = lo;
    ch->hi = hi;
    ch->mid = mid;
    ch->half = half;
    /* the chart against fresh branch points and tangents halfway between
     * nodes (away from the pinch, where a fresh one would be the less exact) */
    double *check = ch->scratch + 4 * n, *dz = ch->scratch + 5 * n, t_max = 0.0;
    for (int j = 0; j < CHART_NODES * n; j++) t_max = fmax(t_max, fabs(ch->values[CHART_NODES * n + j]));
    for (int j = 1; j < CHART_NODES; j++) {
        double x = mid + half * cos(CHART_PI * j / CHART_NODES);
        if (fabs(x - ch->pinch) < 0.02 * (hi - lo)) continue;
        grb_chart_eval(ch, x, check, dz, NULL);
        check[held] = x;
        memcpy(z, check, sizeof(double) * n);
        if (!isfinite(br->point(br->model, held, scale, z, t, br->ws))) return GRB_BRANCH_JUMP;
        for (int i = 0; i < n; i++)
            if (!(fabs(z[i] - check[i]) <= CHART_CHECK * scale) || !(fabs(t[i] - dz[i]) <= 1e-7 * t_max))
                return GRB_BRANCH_JUMP;
    }
    ch->active = 1;
    return GRB_OK;
}

/* The chart of the branch through y, held in the first coordinate it is a
 * curve in: `first` (the drive; -1: none), then the coordinates by how fast
 * they move (one at a limit of its travel is no coordinate along the branch
 * there).  tried: n ints of the caller's; skip (NULL: none): 1 for a
 * coordinate never to hold (an idle one, which the branch does not move). */
static inline int chart_build(const grb_branch *br, const double *y, double kappa_ref, double near, int first,
                              const int *skip, int *tried, grb_chart *ch) {
    int n = br->n;
    for (int i = 0; i < n; i++) tried[i] = skip ? skip[i] : 0;
    for (int attempt = 0; attempt < n; attempt++) {
        int held = -1;
        if (attempt == 0 && first >= 0)
            held = first;
        else
            for (int i = 0; i < n; i++)
                if (!tried[i] && (held < 0 || fabs(y[n + i]) > fabs(y[n + held]))) held = i;
        if (held < 0) break;
        tried[held] = 1;
        if (chart_build_on(br, y, kappa_ref, near, held, ch) == GRB_OK) return GRB_OK;
    }
    return GRB_BRANCH_JUMP;
}

/* The branch orientation, for the change-point watch of either kernel: det
 * [R; zd / |zd|] (n x n), R the closure rows J (m x n, row-major) along the
 * basis's n - 1 row directions (basis (n - 1) x m), or J's own rows when basis
 * is NULL (then m = n - 1).  Along a branch it keeps its sign; it passes
 * through zero where the branch crosses another, so a step whose ends
 * disagree in sign stepped across a change point.  0 at rest.  A (n x n) is
 * scratch; the elimination pivots on the largest entry of each column. */
static inline double grb_orientation_det(int n, int m, const double *J, const double *basis, const double *zd,
                                         double *A) {
    double speed = 0.0;
    for (int i = 0; i < n; i++) speed += zd[i] * zd[i];
    if (!(speed > 0.0)) return 0.0;
    speed = sqrt(speed);
    for (int r = 0; r < n - 1; r++)
        for (int i = 0; i < n; i++) {
            double v = 0.0;
            if (basis)
                for (int k = 0; k < m; k++) v += basis[r * m + k] * J[k * n + i];
            else
                v = J[r * n + i];
            A[r * n + i] = v;
        }
    for (int i = 0; i < n; i++) A[(n - 1) * n + i] = zd[i] / speed;
    double det = 1.0;
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int r = c + 1; r < n; r++)
            if (fabs(A[r * n + c]) > fabs(A[p * n + c])) p = r;
        if (A[p * n + c] == 0.0) return 0.0;
        if (p != c) {
            for (int j = 0; j < n; j++) {
                double t = A[c * n + j];
                A[c * n + j] = A[p * n + j];
                A[p * n + j] = t;
            }
            det = -det;
        }
        det *= A[c * n + c];
        for (int r = c + 1; r < n; r++) {
            double f = A[r * n + c] / A[c * n + c];
            for (int j = c; j < n; j++) A[r * n + j] -= f * A[c * n + j];
        }
    }
    return det;
}

/* Between advances (a co-simulation step of 1 ms is one advance, and a change
 * point's zone is tens of them) the chart is kept, not rebuilt: its
 * coefficients stay in the caller's stepper buffer, and its scalars go into the
 * node-value block, which is dead once the chart is built.  A tag marks them
 * valid; resuming clears it, so a failed advance (which may have built another
 * chart over these coefficients) leaves nothing to resume. */
#define CHART_TAG 7.0397e-217 /* an unlikely value for a coordinate */
enum { SAVED_TAG, SAVED_HELD, SAVED_LO, SAVED_HI, SAVED_MID, SAVED_HALF, SAVED_PINCH, SAVED_PINCH_KAPPA,
       SAVED_COUNT };

/* keep an active chart in its buffer for the next advance, and take it up
 * there when the state y lies on it (1) */
static inline void grb_chart_save(const grb_chart *ch) {
    double *saved = ch->values;
    if (!ch->active) {
        saved[SAVED_TAG] = 0.0;
        return;
    }
    saved[SAVED_TAG] = CHART_TAG;
    saved[SAVED_HELD] = ch->held;
    saved[SAVED_LO] = ch->lo;
    saved[SAVED_HI] = ch->hi;
    saved[SAVED_MID] = ch->mid;
    saved[SAVED_HALF] = ch->half;
    saved[SAVED_PINCH] = ch->pinch;
    saved[SAVED_PINCH_KAPPA] = ch->pinch_kappa;
}

static inline int grb_chart_resume(grb_chart *ch, const double *y, double scale) {
    double *saved = ch->values, *z = ch->scratch;
    int n = ch->n, held = (int)saved[SAVED_HELD];
    ch->active = 0;
    if (saved[SAVED_TAG] != CHART_TAG || held < 0 || held >= n || !(saved[SAVED_HALF] > 0.0)) return 0;
    saved[SAVED_TAG] = 0.0;
    ch->held = held;
    ch->lo = saved[SAVED_LO];
    ch->hi = saved[SAVED_HI];
    ch->mid = saved[SAVED_MID];
    ch->half = saved[SAVED_HALF];
    ch->pinch = saved[SAVED_PINCH];
    ch->pinch_kappa = saved[SAVED_PINCH_KAPPA];
    /* the state must lie on it (the last advance put it there; a state set
     * from outside, or restored from before the chart, need not) */
    if (!(y[held] >= ch->lo && y[held] <= ch->hi) || !grb_chart_eval(ch, y[held], z, NULL, NULL)) return 0;
    for (int i = 0; i < n; i++)
        if (i != held && !(fabs(z[i] - y[i]) <= CHART_CHECK * scale)) return 0;
    ch->active = 1;
    return 1;
}

/* The state y = (z, zd) put on the chart at its held coordinate and rate. */
static inline int grb_chart_put(const grb_chart *ch, double *y) {
    int n = ch->n;
    double x = y[ch->held], xd = y[n + ch->held];
    if (!grb_chart_eval(ch, x, y, y + n, NULL)) return 0;
    for (int i = 0; i < n; i++) y[n + i] *= xd;
    y[ch->held] = x;
    y[n + ch->held] = xd;
    return 1;
}

/* The chart's point z, tangent t and curvature tx (scratch 0..2) at the held
 * coordinate of y, and the rates out[0..n) = t x'; 0 (out all nan) off the
 * chart.  The kernel then evaluates M and Q - h at (z, out) and calls
 * chart_motion. */
static inline int chart_point(const grb_chart *ch, const double *y, double *out) {
    int n = ch->n, held = ch->held;
    double *z = ch->scratch, *t = ch->scratch + n, *tx = ch->scratch + 2 * n;
    double x = y[held], xd = y[n + held];
    if (!grb_chart_eval(ch, x, z, t, tx)) {
        for (int i = 0; i < 2 * n; i++) out[i] = NAN;
        return 0;
    }
    z[held] = x;
    t[held] = 1.0;
    tx[held] = 0.0;
    for (int i = 0; i < n; i++) out[i] = t[i] * xd;
    return 1;
}

/* The one degree of freedom's Lagrange equation on the chart,
 *     (t' M t) x'' = t' (Q - h) - x'^2 t' M t_x,
 * from M (n x n, row-major) and Q - h (force) at chart_point's point, its
 * tangent t and curvature tx (scratch 1, 2) and the held rate xd: the
 * accelerations out[n..2n) = t x'' + t_x x'^2.  (The kernel takes n, t, tx
 * and xd before its mass and force call, as registers across it.) */
static inline int chart_motion(int n, const double *t, const double *tx, double xd, const double *mass,
                               const double *force, double *out) {
    double m_tt = 0.0, f_t = 0.0, bias = 0.0;
    for (int i = 0; i < n; i++) {
        double mt = 0.0, mtx = 0.0;
        for (int j = 0; j < n; j++) {
            mt += mass[i * n + j] * t[j];
            mtx += mass[i * n + j] * tx[j];
        }
        m_tt += t[i] * mt;
        bias += t[i] * mtx;
        f_t += t[i] * force[i];
    }
    double xdd = (f_t - xd * xd * bias) / m_tt;
    for (int i = 0; i < n; i++) out[n + i] = t[i] * xdd + tx[i] * xd * xd;
    return isfinite(xdd);
}

#endif
