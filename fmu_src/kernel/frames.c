/* Where points fixed to links are over a whole trajectory, in one call: what a
 * drawing of every frame needs (joint centres, link ends, coupler points), from
 * the same kinematic pass the dynamics use (GRB(chain), GRB(point) in chain.c).
 * Positions only, so it is compiled once, over double. */
#include "workspace.h"

grb_status grb_link_points_rows(const grb_model *md, int rows, const double *y, int n_points, const int *link,
                         const double *local, double *work, double *out) {
    int n = md->n_links;
    grb_ws ws, *w = &ws;
    if (rows < 0 || n_points < 0) return GRB_BAD_ARGUMENT;
    for (int p = 0; p < n_points; p++)
        if (link[p] >= n) return GRB_BAD_ARGUMENT;
    grb_status status = grb_ws_init(w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    /* GRB(point) writes a Jacobian we do not need: the closure Jacobian's scratch rows */
    double *scratch = w->J + w->m * n, r[4];
    for (int i = 0; i < rows; i++) {
        const double *yi = y + (size_t)i * 2 * n;
        double *oi = out + (size_t)i * 2 * n_points;
        grb_chain(md, yi, yi + n, w);
        for (int p = 0; p < n_points; p++) {
            if (link[p] < 0) { /* the ground's frame is the world's */
                oi[2 * p] = local[2 * p];
                oi[2 * p + 1] = local[2 * p + 1];
                continue;
            }
            grb_point(md, w, link[p], local[2 * p], local[2 * p + 1], scratch, r);
            oi[2 * p] = r[0];
            oi[2 * p + 1] = r[1];
        }
    }
    return GRB_OK;
}
