/* The Gauss-Newton solves on closure rows, one text for the planar kernel
 * (closure.c) and the spatial one (spatial/sp_closure.c): the minimum-norm
 * projection, assembly, and the branch point of the change-point chart
 * (chart.h).  Each
 * kernel gives its own evaluation of the rows and where it leaves them, its
 * own tolerances and its own scratch.  Defined here,
 * static inline, so that each kernel's compiler sees its own row evaluation
 * through the pointer and the planar kernel's projection compiles to what it
 * was before it was shared (benchmarks/bit_identity.py, compare_versions.py). */
#ifndef GRB_PROJECT_H
#define GRB_PROJECT_H

#include <math.h>

#include "workspace.h" /* grb_lstsq_min_norm (linalg.c) */

/* A kernel's closure rows: at(model, z, ws) evaluates them at the coordinates
 * z, leaving the Jacobian in J (m x n, row-major) and the violations in
 * phi[r * stride]; b[r * stride] is the caller's room for a right side. */
typedef struct grb_rows {
    void (*at)(const void *model, const double *z, void *ws);
    const void *model;
    void *ws;
    const double *J;
    const double *phi;
    double *b;
    int stride;
    int n, m;
} grb_rows;

/* The largest |phi[r * stride]| of m rows (a nan wins: it is never closed). */
static inline double grb_worst_row(const double *phi, int stride, int m) {
    double worst = 0.0;
    for (int r = 0; r < m; r++)
        if (!(fabs(phi[r * stride]) <= worst)) worst = fabs(phi[r * stride]);
    return worst;
}

/* y = (z, zd) projected onto the rows in place: at most `iterations`
 * Gauss-Newton steps on phi(z) = 0 until the worst row is within tol, then
 * the rates onto the null space of J, each step the minimum-norm least-squares
 * solution (grb_lstsq_min_norm, singular values below rcond of the largest
 * dropped).  x (n), U (n x m) and V (m x m) are scratch. */
static inline void grb_project_rows(const grb_rows *rows, double tol, double rcond, int iterations, double *y,
                                    double *x, double *U, double *V) {
    int n = rows->n, m = rows->m, stride = rows->stride;
    double *z = y, *zd = y + n;
    for (int it = 0; it < iterations; it++) {
        rows->at(rows->model, z, rows->ws);
        if (grb_worst_row(rows->phi, stride, m) <= tol) break;
        grb_lstsq_min_norm(rows->J, n, m, n, rows->phi, stride, rcond, x, U, V);
        for (int i = 0; i < n; i++) z[i] -= x[i];
    }
    for (int r = 0; r < m; r++) {
        double v = 0.0;
        for (int i = 0; i < n; i++) v += rows->J[r * n + i] * zd[i];
        rows->b[r * stride] = v;
    }
    grb_lstsq_min_norm(rows->J, n, m, n, rows->b, stride, rcond, x, U, V);
    for (int i = 0; i < n; i++) zd[i] -= x[i];
}

/* The blocks of a kernel's assembly scratch S (both kernels lay it out alike):
 * U (n x m) and V (m x m) for the least-squares solver, a compact Jacobian
 * Jd (m x n), the n-vectors x, trial and step, the m-vectors phi and b. */
typedef struct grb_closure_scratch {
    double *U, *V, *Jd, *x, *trial, *step, *phi, *b;
} grb_closure_scratch;

static inline grb_closure_scratch grb_closure_scratch_in(double *S, int n, int m) {
    grb_closure_scratch s;
    s.U = S;
    s.V = s.U + n * m;
    s.Jd = s.V + m * m;
    s.x = s.Jd + m * n;
    s.trial = s.x + n;
    s.step = s.trial + n;
    s.phi = s.step + n;
    s.b = s.phi + m;
    return s;
}

/* x (nc) = the minimum-norm least-squares solution of J[:, cols] x = rhs, J
 * the m x n Jacobian (row-major): the columns cols gathered into s->Jd, whose
 * singular values below rcond of the largest are dropped (s->U, s->V). */
static inline void grb_solve_columns(const double *J, int n, int m, const int *cols, int nc, const double *rhs,
                                     double rcond, double *x, grb_closure_scratch *s) {
    for (int r = 0; r < m; r++)
        for (int c = 0; c < nc; c++) s->Jd[r * nc + c] = J[r * n + cols[c]];
    grb_lstsq_min_norm(s->Jd, nc, m, nc, rhs, 1, rcond, x, s->U, s->V);
}

/* The coordinates that are not held (held: n_held indices), in order, into
 * dep (room for n); is_held (n) is scratch.  Returns how many, or -1 where a
 * held index is not one of the n coordinates. */
static inline int grb_free_columns(int n, const int *held, int n_held, int *is_held, int *dep) {
    int nd = 0;
    for (int i = 0; i < n; i++) is_held[i] = 0;
    for (int i = 0; i < n_held; i++) {
        if (held[i] < 0 || held[i] >= n) return -1;
        is_held[held[i]] = 1;
    }
    for (int i = 0; i < n; i++)
        if (!is_held[i]) dep[nd++] = i;
    return nd;
}

/* Assembly's damped Newton: the coordinates dep (nd of them) of z moved from
 * the user's sketch in z, in place, so that the branch the user drew is the
 * branch found.  Each of at most `iterations` steps solves over the columns
 * dep with rcond (grb_solve_columns) and takes the largest of 1, 1/2, ..,
 * 1/16 of it that lowers the worst row; it stops within tol, or where no
 * fraction helps.  The rows are left evaluated at the z returned; returns the
 * least worst row seen on the way (what was closest, when it did not close). */
static inline double grb_assemble_rows(const grb_rows *rows, const int *dep, int nd, double tol, double rcond,
                                       int iterations, double *z, grb_closure_scratch *s) {
    int n = rows->n, m = rows->m, stride = rows->stride;
    double best = INFINITY;
    for (int it = 0; it < iterations; it++) {
        rows->at(rows->model, z, rows->ws);
        double err = grb_worst_row(rows->phi, stride, m);
        if (err < best) best = err;
        if (err < tol) break;
        for (int r = 0; r < m; r++) s->phi[r] = -rows->phi[r * stride];
        grb_solve_columns(rows->J, n, m, dep, nd, s->phi, rcond, s->step, s);
        int moved = 0;
        for (double frac = 1.0; frac >= 0.0625; frac *= 0.5) {
            for (int i = 0; i < n; i++) s->trial[i] = z[i];
            for (int c = 0; c < nd; c++) s->trial[dep[c]] += frac * s->step[c];
            rows->at(rows->model, s->trial, rows->ws);
            if (grb_worst_row(rows->phi, stride, m) < err) {
                for (int i = 0; i < n; i++) z[i] = s->trial[i];
                moved = 1;
                break;
            }
        }
        if (!moved) break;
    }
    rows->at(rows->model, z, rows->ws);
    return best;
}

/* The rates of an assembled state (the rows evaluated at its z): the held
 * ones (n_held of them) kept in zd, the columns dep solved from the velocity
 * constraint J zd = 0 (grb_solve_columns with rcond). */
static inline void grb_held_rates_rows(const grb_rows *rows, const int *held, int n_held, const int *dep, int nd,
                                       double rcond, double *zd, grb_closure_scratch *s) {
    int n = rows->n, m = rows->m;
    for (int r = 0; r < m; r++) {
        double v = 0.0;
        for (int i = 0; i < n_held; i++) v -= rows->J[r * n + held[i]] * zd[held[i]];
        s->b[r] = v;
    }
    grb_solve_columns(rows->J, n, m, dep, nd, s->b, rcond, s->x, s);
    for (int c = 0; c < nd; c++) zd[dep[c]] = s->x[c];
}

/* The point of an assembly branch where coordinate `held` keeps its value in
 * z: Newton on the other coordinates (dep, n - 1 of them: the caller's room)
 * from the guess in z, in place, for at most `iterations` steps and for as
 * long as the worst row still halves (to rounding: near a change point what
 * is left of it would be amplified); then the branch's tangent there,
 * dz/dz[held], into tangent (when not NULL; tangent[held] = 1).  Each step
 * solves over the columns dep with rcond (grb_solve_columns).  Returns the
 * violation left, or infinity where it is not within tol (the caller's idea
 * of closed) or held is not a coordinate. */
static inline double grb_branch_point_rows(const grb_rows *rows, int held, double tol, double rcond, int iterations,
                                           double *z, double *tangent, int *dep, grb_closure_scratch *s) {
    int n = rows->n, m = rows->m, stride = rows->stride, nd = 0;
    if (held < 0 || held >= n) return INFINITY;
    for (int i = 0; i < n; i++)
        if (i != held) dep[nd++] = i;
    double previous = INFINITY, err = INFINITY;
    for (int it = 0; it < iterations; it++) {
        rows->at(rows->model, z, rows->ws);
        err = grb_worst_row(rows->phi, stride, m);
        if (!(err < 0.5 * previous) || err == 0.0) break;
        previous = err;
        for (int r = 0; r < m; r++) s->phi[r] = -rows->phi[r * stride];
        grb_solve_columns(rows->J, n, m, dep, nd, s->phi, rcond, s->step, s);
        for (int c = 0; c < nd; c++) z[dep[c]] += s->step[c];
    }
    rows->at(rows->model, z, rows->ws);
    err = grb_worst_row(rows->phi, stride, m);
    if (!(err <= tol)) return INFINITY;
    if (tangent) {
        for (int r = 0; r < m; r++) s->b[r] = -rows->J[r * n + held];
        grb_solve_columns(rows->J, n, m, dep, nd, s->b, rcond, s->x, s);
        for (int c = 0; c < nd; c++) tangent[dep[c]] = s->x[c];
        tangent[held] = 1.0;
    }
    return err;
}

#endif
