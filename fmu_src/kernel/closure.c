/* Keeping the loop closed: consistent assembly, and the projection that is the
 * exact method's drift control.
 *
 * Assembly holds the driving coordinate (and, for mobility above one, the
 * best-conditioned further coordinates) at the user's value and solves the
 * closure equations for the others by damped Newton from the user's sketch, so
 * that the branch the user drew is the branch found.  The same Gauss-Newton
 * correction, started from an integrator step already closed to the local
 * error, is the projection. */
#include <float.h>
#include <math.h>

#include "chart.h" /* grb_orientation_det */
#include "project.h"
#include "workspace.h"

#define POSITION_TOL 1e-12     /* m (or rad): closure reached by assembly and projection */
#define LSTSQ_RCOND 1e-8       /* relative singular value below which a direction is dropped */
#define PROJECTION_ITERATIONS 4 /* Gauss-Newton steps at most (one or two suffice after a step) */
#define ASSEMBLY_ITERATIONS 100
#define ASSEMBLY_CLOSED 1e-9   /* relative to the scale: what counts as closed at all */

/* scratch blocks in S (see grb_work_size): project.h's layout */
typedef grb_closure_scratch scratch;

static scratch scratch_of(grb_ws *w) { return grb_closure_scratch_in(w->S, w->n, w->m); }

/* Closure rows at z with zero rates (the rates enter neither phi nor J). */
static void rows_at(const grb_model *md, const double *z, grb_ws *w) {
    double *rest = w->J + (w->m + 2) * w->n;
    for (int i = 0; i < w->n; i++) rest[i] = 0.0;
    grb_chain(md, z, rest, w);
    grb_closure_rows(md, rest, w);
}

static void rows_of(const void *md, const double *z, void *w) { rows_at(md, z, w); }

/* The closure rows as project.h's solves see them. */
static grb_rows closure_rows(const grb_model *md, grb_ws *w) {
    grb_rows rows = {rows_of, md, w, w->J, &w->row[0].phi, &w->row[0].b, R_COLUMNS, w->n, w->m};
    return rows;
}

static double worst_violation(const grb_ws *w) { return grb_worst_row(&w->row[0].phi, R_COLUMNS, w->m); }

/* Minimum-norm projection of y = (z, zd) onto the closures, in place:
 * Gauss-Newton on phi(z) = 0, then the rates onto the null space of J
 * (project.h, which the spatial kernel shares). */
void grb_project_ws(const grb_model *md, double scale, double *y, grb_ws *w) {
    scratch s = scratch_of(w);
    grb_rows rows = closure_rows(md, w);
    grb_project_rows(&rows, POSITION_TOL * scale, LSTSQ_RCOND, PROJECTION_ITERATIONS, y, s.x, s.U, s.V);
}

grb_status grb_project(const grb_model *md, double scale, double *y, double *work) {
    grb_ws w;
    grb_status status = grb_ws_init(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    if (w.m == 0) return GRB_OK;
    grb_project_ws(md, scale, y, &w);
    for (int i = 0; i < 2 * w.n; i++)
        if (!isfinite(y[i])) return GRB_SINGULAR;
    return GRB_OK;
}

grb_status grb_constraint(const grb_model *md, const double *z, double *phi, double *J, double *work) {
    grb_ws w;
    grb_status status = grb_ws_init(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    rows_at(md, z, &w);
    for (int r = 0; r < w.m; r++) {
        phi[r] = w.row[r].phi;
        for (int i = 0; i < w.n; i++) J[r * w.n + i] = J_(&w, r, i);
    }
    return GRB_OK;
}

grb_status grb_freedom(const grb_model *md, const double *z, double *work, int *freedom) {
    grb_ws w;
    grb_status status = grb_ws_init(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    *freedom = grb_closure_freedom(md, z, &w);
    return GRB_OK;
}

grb_status grb_hold_count(const grb_model *md, const double *z, double *work, int *count) {
    int freedom, n = md->n_links - 2 * md->n_closures;
    grb_status status = grb_freedom(md, z, work, &freedom);
    if (status != GRB_OK) return status;
    if (freedom > n) n = freedom;
    if (md->drive >= 0 && n < 1) n = 1;
    *count = n;
    return GRB_OK;
}

grb_status grb_held_coordinates(const grb_model *md, int n_hold, const double *z, int *held, int *n_held, double *work) {
    grb_ws w;
    int n = md->n_links;
    grb_status status = grb_ws_init(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    int m = w.m, count = 0;
    if (n_hold < 0) n_hold = 0;
    if (md->drive >= 0 && n_hold > 0) held[count++] = md->drive;
    if (count >= n_hold) {
        *n_held = count;
        return GRB_OK;
    }
    /* the columns a column-pivoted QR of J[:, others] picks first are the best
     * dependent set (Businger and Golub); hold the rest, in chain order */
    scratch s = scratch_of(&w);
    rows_at(md, z, &w);
    int k = 0, *others = w.index + WS_INDEX_FIRST(n), *chosen = w.index + WS_INDEX_SECOND(n);
    for (int i = 0; i < n; i++)
        if (i != md->drive || count == 0) others[k++] = i;
    double *A = s.Jd; /* m x k */
    for (int c = 0; c < k; c++) chosen[c] = 0;
    for (int r = 0; r < m; r++)
        for (int c = 0; c < k; c++) A[r * k + c] = J_(&w, r, others[c]);
    int steps = m < k ? m : k;
    for (int st = 0; st < steps; st++) {
        int p = -1;
        double big = -1.0;
        for (int c = 0; c < k; c++) {
            if (chosen[c]) continue;
            double norm = 0.0;
            for (int r = st; r < m; r++) norm += A[r * k + c] * A[r * k + c];
            if (norm > big) {
                big = norm;
                p = c;
            }
        }
        if (p < 0) break; /* only non-finite columns left */
        chosen[p] = 1;
        /* Householder reflection zeroing column p below row st */
        double alpha = sqrt(big);
        if (alpha == 0.0) continue;
        if (A[st * k + p] > 0) alpha = -alpha;
        double *v = s.x;
        double vnorm = 0.0;
        for (int r = st; r < m; r++) {
            v[r - st] = A[r * k + p] - (r == st ? alpha : 0.0);
            vnorm += v[r - st] * v[r - st];
        }
        if (vnorm == 0.0) continue;
        for (int c = 0; c < k; c++) {
            double d = 0.0;
            for (int r = st; r < m; r++) d += v[r - st] * A[r * k + c];
            d *= 2.0 / vnorm;
            for (int r = st; r < m; r++) A[r * k + c] -= d * v[r - st];
        }
    }
    for (int c = 0; c < k && count < n_hold; c++)
        if (!chosen[c]) held[count++] = others[c];
    *n_held = count;
    return GRB_OK;
}

/* numpy.linalg.lstsq's default cut-off: machine epsilon times the larger size */
static double dependent_rcond(int m, int nd) { return DBL_EPSILON * (m > nd ? m : nd); }

grb_status grb_assemble(const grb_model *md, int n_held, const int *held, double scale, double *z, double *zd,
                 double *closest, double *work) {
    grb_ws w;
    int n = md->n_links;
    *closest = 0.0;
    grb_status status = grb_ws_init(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    int m = w.m;
    if (m == 0) return GRB_OK;
    if (n_held < 0 || n_held > n) return GRB_BAD_ARGUMENT;
    scratch s = scratch_of(&w);
    int *dep = w.index + WS_INDEX_FIRST(n), *is_held = w.index + WS_INDEX_SECOND(n);
    int nd = grb_free_columns(n, held, n_held, is_held, dep);
    if (nd < 0) return GRB_BAD_ARGUMENT;
    grb_rows rows = closure_rows(md, &w);
    double rcond = dependent_rcond(m, nd);
    double best = grb_assemble_rows(&rows, dep, nd, POSITION_TOL * scale, rcond, ASSEMBLY_ITERATIONS, z, &s);
    double err = worst_violation(&w);
    if (!(err <= ASSEMBLY_CLOSED * scale)) {
        *closest = best;
        return GRB_NOT_CLOSED;
    }
    grb_held_rates_rows(&rows, held, n_held, dep, nd, rcond, zd, &s);
    *closest = err;
    return GRB_OK;
}

/* The Gram matrix J J^T of the closure Jacobian in w (rows_at) into schur,
 * where grb_sym_eig finds its eigenvectors and eigenvalues. */
static void gram(grb_ws *w) {
    int n = w->n, m = w->m, *span = w->span;
    if (m > GRB_JACOBI_ROWS) { /* over the columns where both rows are not zero (chain.c's row_spans) */
        grb_row_spans(w, m, span);
        for (int r = 0; r < m; r++)
            for (int c = 0; c < m; c++) {
                int lo = span[2 * r] > span[2 * c] ? span[2 * r] : span[2 * c];
                int hi = span[2 * r + 1] < span[2 * c + 1] ? span[2 * r + 1] : span[2 * c + 1];
                double g = 0.0;
                for (int i = lo; i <= hi; i++) g += J_(w, r, i) * J_(w, c, i);
                SCHUR_(w, r, c) = g;
            }
        return;
    }
    for (int r = 0; r < m; r++)
        for (int c = 0; c < m; c++) {
            double g = 0.0;
            for (int i = 0; i < n; i++) g += J_(w, r, i) * J_(w, c, i);
            SCHUR_(w, r, c) = g;
        }
}

/* Squared singular values of the closure Jacobian in w (rows_at), largest
 * first, into e (m of them): the eigenvalues of the Gram matrix. */
static void squared_singular_values(grb_ws *w, double *e) {
    int m = w->m;
    double *G = w->schur;
    gram(w);
    if (m == 2) {
        double tr = G[0] + G[m + 1], det = G[0] * G[m + 1] - G[1] * G[m];
        double disc = sqrt(fmax(tr * tr / 4.0 - det, 0.0));
        e[0] = tr / 2.0 + disc;
        e[1] = det / (e[0] > 0.0 ? e[0] : 1.0); /* the small root without cancellation */
        return;
    }
    if (m > GRB_JACOBI_ROWS)
        grb_sym_eigenvalues(w->schur, w->eig_work, w->eigvec, w->eigval, m);
    else
        grb_sym_eig(w->schur, w->eig_work, w->eigvec, w->eigval, m);
    for (int i = 0; i < m; i++) e[i] = w->eigval[i];
    for (int i = 1; i < m; i++) /* insertion sort, descending: m is small */
        for (int k = i; k > 0 && e[k] > e[k - 1]; k--) {
            double tmp = e[k];
            e[k] = e[k - 1];
            e[k - 1] = tmp;
        }
}

/* Conditioning of the closure at z for a mechanism of mobility one: its
 * Jacobian's (N - 1)-th singular value over its largest (1 for an open
 * chain).  Redundant closure rows (a third coupling crank) add singular values
 * that are zero everywhere; the (N - 1)-th is the one that falls to zero where
 * two assembly branches meet (a change point, a dead centre of the loop),
 * which is where the passage logic of integrate.c takes over. */
static double conditioning_of_rows(grb_ws *w) {
    int n = w->n, m = w->m;
    double *e = w->singular;
    if (m == 0) return 1.0;
    squared_singular_values(w, e);
    int k = n - 2 < m - 1 ? n - 2 : m - 1; /* the (N - 1)-th, or the last there is */
    if (k < 0) k = 0;
    if (!(e[0] > 0.0)) return 0.0;
    return sqrt(fmax(e[k], 0.0) / e[0]);
}

double grb_closure_conditioning(const grb_model *md, const double *z, grb_ws *w) {
    if (w->m == 0) return 1.0;
    rows_at(md, z, w);
    return conditioning_of_rows(w);
}

/* Degrees of freedom the closures leave at z: N minus the rank of their
 * Jacobian (singular values above 1e-8 of the largest).  With redundant rows
 * this is more than N - M. */
int grb_closure_freedom(const grb_model *md, const double *z, grb_ws *w) {
    int n = w->n, m = w->m, rank = 0;
    double *e = w->singular;
    if (m == 0) return n;
    rows_at(md, z, w);
    squared_singular_values(w, e);
    for (int i = 0; i < m; i++)
        if (e[i] > 1e-16 * e[0]) rank++;
    return n - rank;
}

/* The N - 1 dominant directions of the closure rows at z (unit vectors of
 * length M, the Gram matrix's leading eigenvectors) into basis, for
 * grb_branch_orientation when redundant rows make J taller than N - 1. */
int grb_closure_row_basis(const grb_model *md, const double *z, grb_ws *w, double *basis) {
    int n = w->n, m = w->m, *used = w->index + WS_INDEX_FIRST(n);
    if (m < n - 1 || n < 2) return GRB_BAD_ARGUMENT;
    for (int i = 0; i < m; i++) used[i] = 0;
    rows_at(md, z, w);
    gram(w);
    grb_sym_eig(w->schur, w->eig_work, w->eigvec, w->eigval, m);
    for (int b = 0; b < n - 1; b++) {
        int best = -1;
        for (int i = 0; i < m; i++)
            if (!used[i] && (best < 0 || w->eigval[i] > w->eigval[best])) best = i;
        used[best] = 1;
        for (int r = 0; r < m; r++) basis[b * m + r] = EIGVEC_(w, r, best);
    }
    return GRB_OK;
}

/* Orientation of the motion against the closure, for a mechanism of mobility
 * one: the determinant of the closure rows (J, or its rows along basis when
 * redundant rows make it taller: see grb_closure_row_basis) stacked on the
 * direction of zd.  Along a branch it keeps its sign; it passes through zero
 * where the branch crosses another (J loses rank and zd lies in its grown null
 * space), so a step whose ends disagree in sign stepped across a change point
 * (or the motion turned back: zd changed sign).  0 when it does not apply. */
static double orientation_of_rows(grb_ws *w, const double *zd, const double *basis) {
    int n = w->n, m = w->m;
    if (m == 0 || (basis ? m < n - 1 : n != m + 1)) return 0.0;
    /* (A: n x n scratch over the closures' matrices: n^2 <= (m + 1)^2 <= m (3m + 1)) */
    return grb_orientation_det(n, m, w->J, basis, zd, w->schur);
}

double grb_branch_orientation(const grb_model *md, const double *y, const double *basis, grb_ws *w) {
    rows_at(md, y, w);
    return orientation_of_rows(w, y + w->n, basis);
}

/* Both at once, from one evaluation of the closure rows: what the integrator
 * watches after every step near a change point. */
void grb_closure_watch(const grb_model *md, const double *y, const double *basis, grb_ws *w, double *kappa,
                       double *orientation) {
    rows_at(md, y, w);
    *orientation = orientation_of_rows(w, y + w->n, basis);
    *kappa = conditioning_of_rows(w);
}

/* The point of an assembly branch where coordinate `held` has the value z[held],
 * and the branch's tangent there (project.h's grb_branch_point_rows): closed
 * to the scale's closure tolerance, each step's lstsq cut at numpy's default. */
double grb_branch_point(const grb_model *md, int held, double scale, double *z, double *tangent, grb_ws *w) {
    int n = w->n, *dep = w->index + WS_INDEX_FIRST(n);
    scratch s = scratch_of(w);
    grb_rows rows = closure_rows(md, w);
    double rcond = dependent_rcond(w->m, n - 1);
    return grb_branch_point_rows(&rows, held, POSITION_TOL * scale, rcond, 3 * PROJECTION_ITERATIONS, z, tangent, dep,
                                 &s);
}
