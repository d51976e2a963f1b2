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

/* the spatial branch, for chart.h */
static double branch_point(const void *md, int held, double scale, double *z, double *t, void *w) {
    return grs_branch_point(md, held, scale, z, t, w);
}
static double branch_conditioning(const void *md, const double *z, void *w) {
    return grs_closure_conditioning(md, z, w);
}
static int branch_slides(const void *md, const void *w, int i) {
    (void)md;
    return ((const grs_ws *)w)->coord_slide[i];
}

int grs_chart_build(const grs_model *md, double scale, const double *y, double kappa_ref, double near,
                    grs_chart *ch, grs_ws *w) {
    int n = w->n, m = w->m, tried[GRS_MAX_COORDS];
    if (m < n - 1 || n > GRS_MAX_COORDS || !(kappa_ref > 0.0)) return GRB_BAD_ARGUMENT;
    grb_branch br = {branch_point, branch_conditioning, branch_slides, md, w, scale, n};
    /* the spatial model names no drive: the fastest-moving joint first */
    return chart_build(&br, y, kappa_ref, near, -1, tried, ch);
}

int grs_chart_rhs(const grs_model *md, const grs_chart *ch, const double *y, const double *tau, grs_ws *w,
                  double *out) {
    int n = ch->n;
    double *z = ch->scratch, *t = z + n, *tx = z + 2 * n, xd = y[n + ch->held];
    if (!chart_point(ch, y, out)) return 0;
    grs_kinematics(md, z, out, w);
    grs_mass_and_force(md, out, tau, w);
    return chart_motion(n, t, tx, xd, w->mass, w->force, out);
}
