/* Minimal coordinates of a closed chain: the whole state from the independent part.
 *
 * A chain of N real joints closed by C closures moves with n = N - 2C freedoms.
 * Given n independent coordinates and their rates (the drive first, as
 * assembly holds them), the 2C dependent coordinates follow from the closures
 * phi(z) = 0 and their rates from J zd = 0.  Linearisation needs that map and
 * its derivative exactly: compiled over complex numbers (minimal_cs.c, real.h)
 * the same Newton iteration, started from the converged real solution, solves
 * the imaginary part too, so y(x + i h e_k) carries dy/dx_k, the tangent of the
 * constraint manifold, to the dynamics' complex twin.  Assembly (closure.c)
 * stays the way to find a configuration from a user's sketch: this is the
 * refinement of one already found. */
#include "workspace.h"
#ifdef GRB_COMPLEX_STEP
#include "grubler_cs.h"
#endif

#define MINIMAL_TOL 1e-13       /* m (or rad), times the length scale: closure reached */
#define MINIMAL_ITERATIONS 50
#define MINIMAL_POLISH 2        /* Newton steps after the real part has converged: they converge the imaginary part */

static int is_independent(int i, int n_ind, const int *ind) {
    for (int k = 0; k < n_ind; k++)
        if (ind[k] == i) return 1;
    return 0;
}

/* The dependent columns of the closure Jacobian into S (m x m, stride m + 1)
 * and rhs into S's last column; dep[c] is the c-th dependent coordinate. */
static void dependent_block(const grb_ws *w, int n_ind, const int *ind) {
    int n = w->n, m = w->m, c = 0;
    for (int i = 0; i < n; i++) {
        if (is_independent(i, n_ind, ind)) continue;
        for (int r = 0; r < m; r++) w->S[r * (m + 1) + c] = J_(w, r, i);
        c++;
    }
}

static void scatter_dependent(const grb_ws *w, int n_ind, const int *ind, real *v) {
    int n = w->n, m = w->m, c = 0;
    for (int i = 0; i < n; i++) {
        if (is_independent(i, n_ind, ind)) continue;
        v[i] += w->S[c * (m + 1) + m];
        c++;
    }
}

int GRB(minimal_state)(const grb_model *md, int n_ind, const int *ind, double scale, real *y, real *work) {
    grb_ws ws, *w = &ws;
    int n = md->n_links, m = 2 * md->n_closures;
    if (n_ind < 0 || n_ind + m != n || (n_ind > 0 && !ind)) return GRB_BAD_ARGUMENT;
    for (int k = 0; k < n_ind; k++)
        if (ind[k] < 0 || ind[k] >= n || is_independent(ind[k], k, ind)) return GRB_BAD_ARGUMENT;
    if (m == 0) return GRB_OK; /* an open chain: every coordinate is independent */
    GRB(ws_init)(w, n, md->n_closures, work);
    real *z = y, *zd = y + n;
    real *rest = w->J + (m + 2) * n; /* zero rates: they enter neither phi nor J */
    int polish = -1;
    for (int it = 0; it < MINIMAL_ITERATIONS && polish < MINIMAL_POLISH; it++) {
        for (int i = 0; i < n; i++) rest[i] = 0.0;
        GRB(chain)(md, z, rest, w);
        GRB(closure_rows)(md, rest, w);
        double worst = 0.0;
        for (int r = 0; r < m; r++)
            if (!(fabs(RE(R_(w, r, R_PHI))) <= worst)) worst = fabs(RE(R_(w, r, R_PHI))); /* a nan wins */
        if (!(worst <= MINIMAL_TOL * scale)) {
            if (polish >= 0 || !isfinite(worst)) return GRB_NOT_CLOSED; /* diverged after converging */
        } else {
            polish++;
        }
        dependent_block(w, n_ind, ind);
        for (int r = 0; r < m; r++) w->S[r * (m + 1) + m] = -R_(w, r, R_PHI);
        if (!GRB(lu_solve)(w->S, m + 1, m, 0, m, 1)) return GRB_SINGULAR;
        scatter_dependent(w, n_ind, ind, z);
    }
    if (polish < MINIMAL_POLISH) return GRB_NOT_CLOSED;
    /* the rates: J_dep zd_dep = -J_ind zd_ind, at the closed configuration */
    for (int i = 0; i < n; i++) rest[i] = 0.0;
    GRB(chain)(md, z, rest, w);
    GRB(closure_rows)(md, rest, w);
    dependent_block(w, n_ind, ind);
    for (int r = 0; r < m; r++) {
        real s = 0.0;
        for (int k = 0; k < n_ind; k++) s -= J_(w, r, ind[k]) * zd[ind[k]];
        w->S[r * (m + 1) + m] = s;
    }
    if (!GRB(lu_solve)(w->S, m + 1, m, 0, m, 1)) return GRB_SINGULAR;
    for (int i = 0; i < n; i++)
        if (!is_independent(i, n_ind, ind)) zd[i] = 0.0;
    scatter_dependent(w, n_ind, ind, zd);
    return GRB_OK;
}
