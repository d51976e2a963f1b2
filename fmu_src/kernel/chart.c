/* The motion near a change point, along its assembly branch.
 *
 * Where two assembly branches meet (a change point: a parallelogram's links
 * aligned, a change-point four-bar's links collinear) the closure's Jacobian
 * loses rank.  The branch itself stays a smooth curve through that position,
 * but the equations of motion in all coordinates with closure multipliers are
 * ill-conditioned near it: what is left of a closure violation comes back in
 * the accelerations amplified by about 1/sigma^3 (sigma: the Jacobian's small
 * singular value), and the projection cannot tell the branches apart.
 *
 * For a mechanism of mobility one the branch is a curve z(x) in one held
 * coordinate x (the drive, or the fastest-moving joint).  Near a change point
 * the integrator switches to that curve: a chart, the Chebyshev interpolant of
 * z(x) through branch points solved to rounding at Chebyshev nodes around the
 * pinch, reached by continuation from where the motion is (so the chart is the
 * branch the motion came along).  On the chart the motion is the one degree of
 * freedom's Lagrange equation,
 *     (t' M t) x'' = t' (Q - h) - x'^2 t' M t_x,     zd = t x',
 * with t = dz/dx and t_x = d2z/dx2 from the chart: no division by sigma, and
 * the state after each step is put on the chart exactly.
 *
 * The method is chart.h's, shared with the spatial kernel (sp_chart.c); here
 * is the planar branch (closure.c's grb_branch_point and conditioning) and the
 * planar mass matrix and force (chain.c). */
#include "chart.h"

/* the planar branch, for chart.h */
static double branch_point(const void *md, int held, double scale, double *z, double *t, void *w) {
    return grb_branch_point(md, held, scale, z, t, w);
}
static double branch_conditioning(const void *md, const double *z, void *w) {
    return grb_closure_conditioning(md, z, w);
}
static int branch_slides(const void *md, const void *w, int i) {
    (void)w;
    return !(grb_links(md)[i].revolute > 0.5);
}

int grb_chart_build(const grb_model *md, double scale, const double *y, double kappa_ref, double near,
                    grb_chart *ch, grb_ws *w) {
    int n = w->n, m = w->m;
    if (m < n - 1 || !(kappa_ref > 0.0)) return GRB_BAD_ARGUMENT;
    grb_branch br = {branch_point, branch_conditioning, branch_slides, md, w, scale, n};
    return chart_build(&br, y, kappa_ref, near, md->drive, NULL, w->index + WS_INDEX_CHART(n), ch);
}

int grb_chart_rhs(const grb_model *md, const grb_chart *ch, const double *y, double tau_drive, double tau_load,
                  grb_ws *w, double *out) {
    int n = ch->n;
    double *z = ch->scratch, *t = z + n, *tx = z + 2 * n, xd = y[n + ch->held];
    if (!chart_point(ch, y, out)) return 0;
    GRB(mass_and_force)(md, z, out, tau_drive, tau_load, w);
    return chart_motion(n, t, tx, xd, w->mass, w->force, out);
}
