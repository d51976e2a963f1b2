/* The minimum-norm projection onto closure rows, one routine for the planar
 * kernel (closure.c) and the spatial one (spatial/sp_closure.c): each gives
 * its own evaluation of the rows and where it leaves them.  Defined here,
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

#endif
