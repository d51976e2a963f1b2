/* The spatial motion near a change point, along its assembly branch: the
 * planar kernel's chart (chart.c, whose comment gives the method) over the
 * spatial chain.
 *
 * Where two assembly branches meet (a planar parallelogram's links aligned,
 * seen as spatial; a spatial loop folded flat) the closure's Jacobian loses
 * rank: the branch stays a smooth curve through that position, but the
 * equations of motion with closure multipliers, and the projection, cannot
 * tell the branches apart there.  For a mechanism of mobility one the branch
 * is a curve z(x) in one held coordinate x (the fastest-moving joint): the
 * Chebyshev interpolant of z(x) and of its tangent through branch points
 * solved to rounding at nodes around the pinch (none near it), reached by
 * continuation from where the motion is, so that the chart is the branch the
 * motion came along.  On it the motion is the one degree of freedom's
 * Lagrange equation
 *     (t' M t) x'' = t' (Q - h) - x'^2 t' M t_x,     zd = t x',
 * with t = dz/dx, t_x = d2z/dx2, M and Q - h the open tree's
 * (grs_mass_and_force): no division by the vanishing singular value.
 *
 *
 * The method is chart.h's, one text with the planar kernel's chart.c; here is
 * the spatial branch (grs_branch_point, grs_closure_conditioning; a slide is
 * held in metres per the scale, a rotation in radians) and the open tree's
 * mass matrix and force. */
#include "chart.h"
#include "sp_workspace.h"

/* the state's rates off the chart's tangent times its held rate, relative to
 * its fastest: a chart of another branch (a projection that takes 1e-2 of the
 * speed away is a jump to another branch: sp_integrate.c's BRANCH_JUMP) */
#define CHART_RATES 1e-3

/* the spatial branch, for chart.h.  An idle coordinate (grs_idle_coords: the
 * RSSR coupler's spin) is no part of it: the rows do not see it, so it keeps
 * its value and its tangent is 0 (the least-squares solve leaves it a rounding
 * step at most); on the chart it moves by its own equation (idle_motion). */
static double branch_point(const void *md, int held, double scale, double *z, double *t, void *w) {
    const grs_ws *ws = w;
    double kept[GRS_MAX_COORDS];
    for (int i = 0; i < ws->n; i++) kept[i] = z[i];
    double err = grs_branch_point(md, held, scale, z, t, w);
    for (int i = 0; i < ws->n; i++)
        if (grs_is_idle(ws, i)) {
            z[i] = kept[i];
            if (t) t[i] = 0.0;
        }
    return err;
}
static double branch_conditioning(const void *md, const double *z, void *w) {
    return grs_closure_conditioning(md, z, w);
}
static int branch_slides(const void *md, const void *w, int i) {
    (void)md;
    return ((const grs_ws *)w)->coord_slide[i];
}

/* Whether the state y lies on the chart, rates too: the chart was made from
 * y's own branch point, but a continuation through the pinch can come back on
 * the other branch (the change-point RSSR held in its ball's first angle, whose
 * slope both branches share there), and the chart's own check, against branch
 * points solved from the chart, cannot see that. */
static int holds_the_state(const grs_chart *ch, const double *y, double scale, const grs_ws *w) {
    int n = ch->n;
    double *z = ch->scratch, *t = ch->scratch + n, xd = y[n + ch->held], speed = 0.0;
    if (!grb_chart_eval(ch, y[ch->held], z, t, NULL)) return 0;
    for (int i = 0; i < n; i++) speed = fmax(speed, fabs(y[n + i]));
    for (int i = 0; i < n; i++) {
        if (i == ch->held || grs_is_idle(w, i)) continue;
        if (!(fabs(z[i] - y[i]) <= CHART_CHECK * scale) || !(fabs(t[i] * xd - y[n + i]) <= CHART_RATES * speed))
            return 0;
    }
    return 1;
}

int grs_chart_build(const grs_model *md, double scale, const double *y, double kappa_ref, double near,
                    grs_chart *ch, grs_ws *w) {
    int n = w->n, m = w->m, tried[GRS_MAX_COORDS], skip[GRS_MAX_COORDS];
    if (m < n - w->n_idle - 1 || n > GRS_MAX_COORDS || !(kappa_ref > 0.0)) return GRB_BAD_ARGUMENT;
    grb_branch br = {branch_point, branch_conditioning, branch_slides, md, w, scale, n};
    for (int i = 0; i < n; i++) skip[i] = grs_is_idle(w, i);
    /* the spatial model names no drive: the fastest-moving joint first; one whose chart turns out another
     * branch's is not held again */
    for (int attempt = 0; attempt < n; attempt++) {
        if (chart_build(&br, y, kappa_ref, near, -1, skip, tried, ch) != GRB_OK) return GRB_BRANCH_JUMP;
        if (holds_the_state(ch, y, scale, w)) return GRB_OK;
        skip[ch->held] = 1;
        ch->active = 0;
    }
    return GRB_BRANCH_JUMP;
}

/* The motion on the chart with idle coordinates s besides the held x: the
 * tree's velocities zd = t x' + sum_j e_j s_j' span 1 + K freedoms, whose
 * Lagrange equations are chart_motion's with T = [t e_1 .. e_K] for t:
 *     (T' M T) (x'', s'') = T' (Q - h) - x'^2 T' M t_x,
 * (t is zero in the idle coordinates, and so is t_x), K + 1 unknowns solved
 * by LU in w->solve, which the chart's right side does not otherwise use. */
static int idle_motion(int n, const double *t, const double *tx, double xd, grs_ws *w, double *out) {
    int k1 = 1 + w->n_idle, stride = k1 + 1, col[GRS_MAX_COORDS + 1];
    col[0] = -1; /* the tangent; then the idle coordinates' unit vectors */
    for (int i = 0, j = 1; i < n; i++)
        if (grs_is_idle(w, i)) col[j++] = i;
    double *T = w->solve;
    for (int a = 0; a < k1; a++) {
        double rhs = 0.0;
        for (int b = 0; b < k1; b++) T[a * stride + b] = 0.0;
        for (int i = 0; i < n; i++) {
            double ta = col[a] < 0 ? t[i] : (i == col[a]) ? 1.0 : 0.0;
            if (ta == 0.0) continue;
            double mtx = 0.0;
            for (int j = 0; j < n; j++) mtx += w->mass[i * n + j] * tx[j];
            rhs += ta * (w->force[i] - xd * xd * mtx);
            for (int b = 0; b < k1; b++) {
                double mb = 0.0;
                if (col[b] < 0)
                    for (int j = 0; j < n; j++) mb += w->mass[i * n + j] * t[j];
                else
                    mb = w->mass[i * n + col[b]];
                T[a * stride + b] += ta * mb;
            }
        }
        T[a * stride + k1] = rhs;
    }
    if (grb_lu_solve(T, stride, k1, 0, k1, 1) != GRB_OK) return 0;
    double xdd = T[k1];
    for (int i = 0; i < n; i++) out[n + i] = t[i] * xdd + tx[i] * xd * xd;
    for (int a = 1; a < k1; a++) out[n + col[a]] = T[a * stride + k1];
    for (int a = 0; a < k1; a++)
        if (!isfinite(T[a * stride + k1])) return 0;
    return 1;
}

int grs_chart_rhs(const grs_model *md, const grs_chart *ch, const double *y, const double *tau, grs_ws *w,
                  double *out) {
    int n = ch->n;
    double *z = ch->scratch, *t = z + n, *tx = z + 2 * n, xd = y[n + ch->held];
    if (!chart_point(ch, y, out)) return 0;
    if (w->n_idle == 0) {
        grs_kinematics(md, z, out, w);
        grs_mass_and_force(md, out, tau, w);
        return chart_motion(n, t, tx, xd, w->mass, w->force, out);
    }
    for (int i = 0; i < n; i++) /* an idle coordinate is the state's, not the chart's */
        if (grs_is_idle(w, i)) {
            z[i] = y[i];
            out[i] = y[n + i];
        }
    grs_kinematics(md, z, out, w);
    grs_mass_and_force(md, out, tau, w);
    return idle_motion(n, t, tx, xd, w, out);
}

/* chart.h's put and resume with the idle coordinates left as the state has
 * them (the chart holds them at the value it was built with) */
int grs_chart_put(const grs_chart *ch, double *y, const grs_ws *w) {
    int n = ch->n;
    double kept[2 * GRS_MAX_COORDS];
    for (int i = 0; i < n && w->n_idle; i++) {
        kept[i] = y[i];
        kept[n + i] = y[n + i];
    }
    int on = grb_chart_put(ch, y);
    for (int i = 0; i < n; i++)
        if (grs_is_idle(w, i)) {
            y[i] = kept[i];
            y[n + i] = kept[n + i];
        }
    return on;
}

int grs_chart_resume(grs_chart *ch, double *y, double scale, const grs_ws *w) {
    int n = ch->n;
    double kept[GRS_MAX_COORDS];
    for (int i = 0; i < n; i++) /* compared with the chart's constant (its first coefficient) */
        if (grs_is_idle(w, i)) {
            kept[i] = y[i];
            y[i] = ch->c[i];
        }
    int on = grb_chart_resume(ch, y, scale);
    for (int i = 0; i < n; i++)
        if (grs_is_idle(w, i)) y[i] = kept[i];
    return on;
}
