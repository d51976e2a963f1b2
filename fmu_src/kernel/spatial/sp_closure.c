/* Keeping the spatial loops closed: assembly, the projection that is the exact
 * method's drift control, and which closure reactions are determinate.
 *
 * The same Gauss-Newton corrections as the planar kernel's closure.c, over the
 * same minimum-norm least-squares solver (linalg.c), which is what lets an
 * overconstrained loop (dependent rows: a planar loop seen as spatial, a
 * Bennett linkage) close exactly: dependent rows drop out of the solve
 * instead of making it singular. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "chart.h" /* grb_orientation_det */
#include "project.h"
#include "sp_workspace.h"

#define POSITION_TOL 1e-12      /* m (or rad), times the scale: closure reached */
#define LSTSQ_RCOND 1e-8        /* relative singular value below which a direction is dropped */
#define PROJECTION_ITERATIONS 4
#define ASSEMBLY_ITERATIONS 100
#define ASSEMBLY_CLOSED 1e-9    /* relative to the scale: what counts as closed at all */
#define BRANCH_ROUNDING 1e-14   /* a branch point's rows closed to rounding, whatever the scale */
#define DEPENDENT_RCOND 1e-10   /* dependent rows of an overconstrained loop leave singular values at rounding */

/* scratch blocks in S: project.h's layout */
typedef grb_closure_scratch scratch;

static scratch scratch_of(grs_ws *w) { return grb_closure_scratch_in(w->S, w->n, w->m); }

/* Closure rows at z with zero rates (the rates enter neither phi nor J). */
void grs_rows_at(const grs_model *md, const double *z, grs_ws *w) {
    for (int i = 0; i < w->n; i++) w->zdd[i] = 0.0;
    grs_kinematics(md, z, w->zdd, w);
    grs_closure_rows(md, w);
}

static void rows_of(const void *md, const double *z, void *w) { grs_rows_at(md, z, w); }

/* The closure rows as project.h's solves see them. */
static grb_rows closure_rows(const grs_model *md, grs_ws *w) {
    grb_rows rows = {rows_of, md, w, w->J, &w->row[0].phi, &w->row[0].b, GRS_ROW_COLUMNS, w->n, w->m};
    return rows;
}

static double worst_violation(const grs_ws *w) { return grb_worst_row(&w->row[0].phi, GRS_ROW_COLUMNS, w->m); }

/* Minimum-norm projection of y = (z, zd) onto the closures, in place: the
 * planar kernel's routine (project.h) over the spatial rows. */
void grs_project_ws(const grs_model *md, double scale, double *y, grs_ws *w) {
    scratch s = scratch_of(w);
    grb_rows rows = closure_rows(md, w);
    grb_project_rows(&rows, POSITION_TOL * scale, LSTSQ_RCOND, PROJECTION_ITERATIONS, y, s.x, s.U, s.V);
}

grb_status grs_project(const grs_model *md, double scale, double *y, double *work) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    if (!(scale > 0.0) || !isfinite(scale)) return GRB_BAD_ARGUMENT;
    if (w.m == 0) return GRB_OK;
    grs_project_ws(md, scale, y, &w);
    for (int i = 0; i < 2 * w.n; i++)
        if (!isfinite(y[i])) return GRB_SINGULAR;
    return GRB_OK;
}

grb_status grs_constraint(const grs_model *md, const double *z, double *phi, double *J, double *work) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    grs_rows_at(md, z, &w);
    for (int r = 0; r < w.m; r++) {
        if (phi) phi[r] = w.row[r].phi;
        for (int i = 0; i < w.n && J; i++) J[r * w.n + i] = SP_J(&w, r, i);
    }
    return GRB_OK;
}

/* The closing link's axis and the target's point the same way in every
 * revolute and cylindrical closure at the last kinematic pass.  Their rows
 * (u square to n1 and n2) hold as well with u reversed, a different joint: an
 * assembly that lands there has not closed the loop the model describes. */
static int axes_agree(const grs_model *md, grs_ws *w) {
    for (int c = 0; c < md->n_closures; c++) {
        const grs_closure *cl = grs_closures(md) + c;
        if (cl->kind == GRS_SPHERICAL) continue;
        grs_direction(w, (int)cl->link, cl->axis, w->vec);
        grs_direction(w, (int)cl->to, cl->to_axis, w->vec + 1);
        double along = 0.0;
        for (int i = 0; i < 3; i++) along += w->vec[0].value[i] * w->vec[1].value[i];
        if (!(along > 0.0)) return 0;
    }
    return 1;
}

grb_status grs_assemble(const grs_model *md, int n_held, const int *held, double scale, double *z, double *zd,
                        double *closest, double *work) {
    grs_ws w;
    *closest = 0.0;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    int n = w.n, m = w.m;
    if (!(scale > 0.0) || !isfinite(scale) || n_held < 0 || n_held > n) return GRB_BAD_ARGUMENT;
    if (m == 0) return GRB_OK;
    scratch s = scratch_of(&w);
    int dep[GRS_MAX_COORDS], is_held[GRS_MAX_COORDS];
    int nd = grb_free_columns(n, held, n_held, is_held, dep);
    if (nd < 0) return GRB_BAD_ARGUMENT;
    grb_rows rows = closure_rows(md, &w);
    double best = grb_assemble_rows(&rows, dep, nd, POSITION_TOL * scale, DEPENDENT_RCOND, ASSEMBLY_ITERATIONS, z, &s);
    double err = worst_violation(&w);
    if (!(err <= ASSEMBLY_CLOSED * scale) || !axes_agree(md, &w)) {
        *closest = err <= ASSEMBLY_CLOSED * scale ? 2.0 : best; /* 2: the axes came out reversed */
        return GRB_NOT_CLOSED;
    }
    grb_held_rates_rows(&rows, held, n_held, dep, nd, DEPENDENT_RCOND, zd, &s);
    *closest = err;
    return GRB_OK;
}

/* The closure rows at z and the eigen-decomposition of their Gram matrix
 * J J^T (M x M: eigenvalues in w->eigval, eigenvectors in w->eigvec's columns);
 * returns the largest eigenvalue.  What the determinacy of the multipliers and
 * of the joint reactions both read the row space from. */
double grs_row_space_at(const grs_model *md, const double *z, grs_ws *w) {
    int n = w->n, m = w->m;
    grs_rows_at(md, z, w);
    for (int r = 0; r < m; r++)
        for (int c = 0; c < m; c++) {
            double g = 0.0;
            for (int i = 0; i < n; i++) g += SP_J(w, r, i) * SP_J(w, c, i);
            SP_SCHUR(w, r, c) = g;
        }
    grb_sym_eig(w->schur, w->eig_work, w->eigvec, w->eigval, m);
    double top = 0.0;
    for (int i = 0; i < m; i++)
        if (w->eigval[i] > top) top = w->eigval[i];
    return top;
}

/* A multiplier lambda_r is fixed by the motion exactly when e_r lies in the
 * range of J (J^T lambda is all the dynamics sees): the part of e_r in the
 * null space of J^T is free.  The range is spanned by the eigenvectors of the
 * Gram matrix J J^T whose eigenvalues are above rcond^2 of the largest. */
grb_status grs_determinacy(const grs_model *md, const double *z, double rcond, double *work, double *indeterminate,
                           int *rank) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    if (!(rcond > 0.0 && rcond < 1.0)) return GRB_BAD_ARGUMENT;
    int m = w.m;
    *rank = 0;
    if (m == 0) return GRB_OK;
    double top = grs_row_space_at(md, z, &w);
    /* summed over the null space's own eigenvectors (not 1 less the range's:
     * that difference would leave rounding's square root, 1e-8, on a
     * determinate row) */
    for (int r = 0; r < m; r++) indeterminate[r] = 0.0;
    for (int i = 0; i < m; i++) {
        if (w.eigval[i] > rcond * rcond * top) {
            (*rank)++;
            continue;
        }
        for (int r = 0; r < m; r++) indeterminate[r] += SP_EIGVEC(&w, r, i) * SP_EIGVEC(&w, r, i);
    }
    for (int r = 0; r < m; r++) indeterminate[r] = sqrt(indeterminate[r]);
    return GRB_OK;
}

/* -- change points (sp_chart.c, sp_integrate.c) ------------------------------ */

/* The eigen-decomposition of the smaller Gram matrix of the closure Jacobian
 * at the last grs_rows_at, J J^T (M x M, its eigenvectors the left singular
 * vectors) or J^T J (N x N, the right ones): the watch runs on every step, and
 * an overconstrained loop has more rows than coordinates.  Eigenvalues (the
 * squared singular values) in w->eigval, eigenvectors in w->eigvec's columns
 * (stride k), order[] their indices largest first; returns k = min(N, M).
 * Both fit the M x M eigen buffers when N <= M. */
static int gram_eig(grs_ws *w, int *order) {
    int n = w->n, m = w->m, by_rows = m <= n, k = by_rows ? m : n;
    for (int r = 0; r < k; r++)
        for (int c = r; c < k; c++) {
            double g = 0.0;
            if (by_rows)
                for (int i = 0; i < n; i++) g += SP_J(w, r, i) * SP_J(w, c, i);
            else
                for (int i = 0; i < m; i++) g += SP_J(w, i, r) * SP_J(w, i, c);
            w->schur[r * k + c] = w->schur[c * k + r] = g;
        }
    grb_sym_eig(w->schur, w->eig_work, w->eigvec, w->eigval, k);
    for (int i = 0; i < k; i++) order[i] = i;
    for (int i = 1; i < k; i++) /* insertion sort, descending: k is small */
        for (int j = i; j > 0 && w->eigval[order[j]] > w->eigval[order[j - 1]]; j--) {
            int tmp = order[j];
            order[j] = order[j - 1];
            order[j - 1] = tmp;
        }
    return k;
}

/* The (N - 1)-th singular value over the largest, from gram_eig's answer
 * (N counting the coordinates the rows see: idle ones add no singular value). */
static double conditioning_of(const grs_ws *w, const int *order, int count) {
    int active = w->n - w->n_idle;
    int k = active - 2 < count - 1 ? active - 2 : count - 1; /* the (N - 1)-th, or the last there is */
    if (k < 0) k = 0;
    double top = w->eigval[order[0]];
    if (!(top > 0.0)) return 0.0;
    return sqrt(fmax(w->eigval[order[k]], 0.0) / top);
}

/* Conditioning of the closure at z for a mechanism of mobility one, as the
 * planar kernel measures it (closure.c): the Jacobian's (N - 1)-th singular
 * value over its largest.  Dependent rows (a planar loop seen as spatial, a
 * Bennett or Bricard loop) add singular values that are zero everywhere; the
 * (N - 1)-th is the one that falls to zero where two assembly branches meet. */
double grs_closure_conditioning(const grs_model *md, const double *z, grs_ws *w) {
    int order[GRS_MAX_ROWS];
    if (w->m == 0) return 1.0;
    grs_rows_at(md, z, w);
    return conditioning_of(w, order, gram_eig(w, order));
}

/* Degrees of freedom the closures leave at z: N minus the rank of their
 * Jacobian (singular values above 1e-8 of the largest). */
int grs_closure_freedom(const grs_model *md, const double *z, grs_ws *w) {
    int n = w->n, rank = 0, order[GRS_MAX_ROWS];
    if (w->m == 0) return n;
    grs_rows_at(md, z, w);
    int count = gram_eig(w, order);
    for (int i = 0; i < count; i++)
        if (w->eigval[order[i]] > 1e-16 * w->eigval[order[0]]) rank++;
    return n - rank;
}

/* det [B J; zd / |zd|] (N x N) at the last grs_rows_at, B (N - 1) x M: the
 * branch orientation of the planar kernel (closure.c), whose sign flips where
 * the motion crosses a change point and goes on the same way.  0 at rest. */
static double orientation_of(grs_ws *w, const double *zd, const double *B) {
    /* (A: n x n over the eigen buffers: 3 M^2 + M >= (M + 1)^2 >= N^2 at mobility one) */
    if (w->n_idle == 0) return grb_orientation_det(w->n, w->m, w->J, B, zd, w->schur);
    /* over the coordinates the rows see: an idle one's column is zero, and its rate no part of the branch */
    int n = w->n, m = w->m, active = 0;
    double along = 0.0, all = 0.0;
    scratch s = scratch_of(w);
    for (int i = 0; i < n; i++) {
        all += zd[i] * zd[i];
        if (grs_is_idle(w, i)) continue;
        for (int r = 0; r < m; r++) s.Jd[r * (n - w->n_idle) + active] = SP_J(w, r, i);
        along += zd[i] * zd[i];
        s.x[active++] = zd[i];
    }
    /* at rest along the branch, only spinning: rates left by the velocity solve's rounding point nowhere */
    if (!(along > 1e-24 * all)) return 0.0;
    return grb_orientation_det(active, m, s.Jd, B, s.x, w->schur);
}

/* The change-point watch at y = (z, zd), from one evaluation of the closure
 * rows: the conditioning (grs_closure_conditioning's); into basis_out the
 * N - 1 dominant row directions at z ((N - 1) x M: the leading left singular
 * vectors of J); the orientation against the directions basis (those of the
 * state the step started from: NULL, 0) and against its own. */
void grs_closure_watch(const grs_model *md, const double *y, const double *basis, double *basis_out, double *kappa,
                       double *orientation, double *own_orientation, grs_ws *w) {
    int n = w->n, m = w->m, order[GRS_MAX_ROWS];
    grs_rows_at(md, y, w);
    int count = gram_eig(w, order);
    *kappa = conditioning_of(w, order, count);
    for (int r = 0; r < n - w->n_idle - 1; r++) {
        double *u = basis_out + (size_t)r * m;
        if (r >= count) {
            for (int i = 0; i < m; i++) u[i] = 0.0;
            continue;
        }
        int j = order[r];
        if (m <= n) /* J J^T: its eigenvectors are the left singular vectors */
            for (int i = 0; i < m; i++) u[i] = w->eigvec[i * count + j];
        else { /* J^T J: u = J v / sigma */
            double sigma = sqrt(fmax(w->eigval[j], 0.0));
            for (int i = 0; i < m; i++) {
                double v = 0.0;
                for (int c = 0; c < n; c++) v += SP_J(w, i, c) * w->eigvec[c * count + j];
                u[i] = sigma > 0.0 ? v / sigma : 0.0;
            }
        }
    }
    *orientation = basis ? orientation_of(w, y + n, basis) : 0.0;
    *own_orientation = orientation_of(w, y + n, basis_out);
}

/* The idle coordinates at z (w->coord_idle, w->n_idle; returns n_idle): a
 * rotation whose closure Jacobian column is zero at z, and stays zero at every
 * position because each closure whose point or axis it moves is fixed to its
 * own link (its turn then moves that point along its own axis: not at all, as
 * the RSSR coupler's spin moves the ball on that spin's axis).  A column that
 * is zero at z by chance, with joints between it and a closure, is not idle. */
int grs_idle_coords(const grs_model *md, const double *z, grs_ws *w) {
    int n = w->n, m = w->m;
    w->n_idle = 0;
    for (int i = 0; i < n; i++) w->coord_idle[i] = 0;
    if (m == 0) return 0;
    grs_rows_at(md, z, w);
    double top = 0.0;
    for (int j = 0; j < m * n; j++) top = fmax(top, fabs(w->J[j]));
    for (int i = 0; i < n; i++) {
        int k = w->coord_link[i], fixed = !w->coord_slide[i];
        for (int c = 0; c < md->n_closures && fixed; c++) {
            const grs_closure *cl = grs_closures(md) + c;
            int ends[2] = {(int)cl->link, (int)cl->to};
            for (int e = 0; e < 2; e++)
                if (ends[e] >= 0 && ends[e] != k && ((w->path[ends[e]] >> k) & 1u)) fixed = 0;
        }
        double column = 0.0;
        for (int r = 0; r < m; r++) column = fmax(column, fabs(SP_J(w, r, i)));
        if (fixed && column <= 1e-12 * top) {
            w->coord_idle[i] = 1;
            w->n_idle++;
        }
    }
    return w->n_idle;
}

/* The branch point where coordinate held keeps its value in z, and the
 * branch's tangent there: closure.c's grb_branch_point over the spatial rows
 * (project.h's grb_branch_point_rows), closed to rounding rather than to the
 * scale's tolerance alone: the direction rows (u.n1, u.n2) are pure numbers
 * whose rounding does not shrink with the length scale (a spherical loop,
 * every joint at one point, has the 1 mm floor of the scale, and asked 1e-15
 * of them its charts failed one passage in two). */
double grs_branch_point(const grs_model *md, int held, double scale, double *z, double *tangent, grs_ws *w) {
    int dep[GRS_MAX_COORDS];
    scratch s = scratch_of(w);
    grb_rows rows = closure_rows(md, w);
    double tol = fmax(POSITION_TOL * scale, BRANCH_ROUNDING);
    return grb_branch_point_rows(&rows, held, tol, DEPENDENT_RCOND, 3 * PROJECTION_ITERATIONS, z, tangent, dep, &s);
}
