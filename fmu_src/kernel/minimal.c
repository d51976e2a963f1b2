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

/* Solve J_dep x = b for the dependent coordinates' part x (b: m values, one
 * per closure row), into S's last column (x[c] at S[c * (nd + 1) + nd]); dep
 * are the coordinates not in ind.  With redundant closure rows (m > nd, a third
 * crank on a parallelogram's rod) the consistent system is solved by its
 * normal equations J_dep^T J_dep x = J_dep^T b, analytic like the square solve,
 * so the complex build's derivatives stay exact.  0 when singular. */
static grb_status solve_dependent(const grb_ws *w, int n_ind, const int *ind, const real *b) {
    int n = w->n, m = w->m, nd = n - n_ind;
    int *dep = w->index + WS_INDEX_FIRST(n), c = 0;
    for (int i = 0; i < n; i++)
        if (!is_independent(i, n_ind, ind)) dep[c++] = i;
    if (m == nd) {
        for (int r = 0; r < m; r++) {
            for (int k = 0; k < nd; k++) w->S[r * (nd + 1) + k] = J_(w, r, dep[k]);
            w->S[r * (nd + 1) + nd] = b[r];
        }
    } else {
        for (int a = 0; a < nd; a++) {
            for (int k = 0; k < nd; k++) {
                real g = 0.0;
                for (int r = 0; r < m; r++) g += J_(w, r, dep[a]) * J_(w, r, dep[k]);
                w->S[a * (nd + 1) + k] = g;
            }
            real v = 0.0;
            for (int r = 0; r < m; r++) v += J_(w, r, dep[a]) * b[r];
            w->S[a * (nd + 1) + nd] = v;
        }
    }
    return GRB(lu_solve)(w->S, nd + 1, nd, 0, nd, 1);
}

static void scatter_dependent(const grb_ws *w, int n_ind, const int *ind, real *v) {
    int n = w->n, nd = n - n_ind, c = 0;
    for (int i = 0; i < n; i++) {
        if (is_independent(i, n_ind, ind)) continue;
        v[i] += w->S[c * (nd + 1) + nd];
        c++;
    }
}

grb_status GRB(minimal_state)(const grb_model *md, int n_ind, const int *ind, double scale, real *y, real *work) {
    grb_ws ws, *w = &ws;
    int n = md->n_links, m = 2 * md->n_closures;
    if (n_ind < 0 || n_ind + m < n || n_ind > n || (n_ind > 0 && !ind)) return GRB_BAD_ARGUMENT;
    for (int k = 0; k < n_ind; k++)
        if (ind[k] < 0 || ind[k] >= n || is_independent(ind[k], k, ind)) return GRB_BAD_ARGUMENT;
    if (m == 0) return GRB_OK; /* an open chain: every coordinate is independent */
    grb_status status = GRB(ws_init)(w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    real *z = y, *zd = y + n;
    real *rest = w->J + (m + 2) * n; /* zero rates: they enter neither phi nor J */
    int polish = -1;
    for (int it = 0; it < MINIMAL_ITERATIONS && polish < MINIMAL_POLISH; it++) {
        for (int i = 0; i < n; i++) rest[i] = 0.0;
        GRB(chain)(md, z, rest, w);
        GRB(closure_rows)(md, rest, w);
        double worst = 0.0;
        for (int r = 0; r < m; r++)
            if (!(fabs(RE(w->row[r].phi)) <= worst)) worst = fabs(RE(w->row[r].phi)); /* a nan wins */
        if (!(worst <= MINIMAL_TOL * scale)) {
            if (polish >= 0 || !isfinite(worst)) return GRB_NOT_CLOSED; /* diverged after converging */
        } else {
            polish++;
        }
        real *b = w->S + n * (n + 1); /* after the system solve_dependent builds in S */
        for (int r = 0; r < m; r++) b[r] = -w->row[r].phi;
        if (solve_dependent(w, n_ind, ind, b) != GRB_OK) return GRB_SINGULAR;
        scatter_dependent(w, n_ind, ind, z);
    }
    if (polish < MINIMAL_POLISH) return GRB_NOT_CLOSED;
    /* the rates: J_dep zd_dep = -J_ind zd_ind, at the closed configuration */
    for (int i = 0; i < n; i++) rest[i] = 0.0;
    GRB(chain)(md, z, rest, w);
    GRB(closure_rows)(md, rest, w);
    real *b = w->S + n * (n + 1);
    for (int r = 0; r < m; r++) {
        real s = 0.0;
        for (int k = 0; k < n_ind; k++) s -= J_(w, r, ind[k]) * zd[ind[k]];
        b[r] = s;
    }
    if (solve_dependent(w, n_ind, ind, b) != GRB_OK) return GRB_SINGULAR;
    for (int i = 0; i < n; i++)
        if (!is_independent(i, n_ind, ind)) zd[i] = 0.0;
    scatter_dependent(w, n_ind, ind, zd);
    return GRB_OK;
}
