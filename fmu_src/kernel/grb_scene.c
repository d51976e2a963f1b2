/* From scene quantities to the kernel's tables: see grb_scene.h. */
#include "grb_scene.h"

int grb_real_coordinates(int n, const int *revolute, int *q_index) {
    int i;
    if (n < 1) return GRB_BAD_ARGUMENT;
    for (i = 0; i < n; i++) q_index[i] = 2 * i + (revolute[i] ? 1 : 0);
    return GRB_OK;
}

/* the predecessor of link i+2 as a 0-based moving-link index (-1 the ground) */
static int parent_of(const int *parent, int i) { return parent ? parent[i] : i - 1; }

int grb_scene_parents_ok(int n, const int *parent) {
    int i;
    if (n < 1) return GRB_BAD_ARGUMENT;
    for (i = 0; i < n; i++)
        if (parent_of(parent, i) < -1 || parent_of(parent, i) >= i) return GRB_BAD_ARGUMENT;
    return GRB_OK;
}

int grb_scene_tables(int n, int nc, const int *revolute, const int *parent, const double *link_fields, double a1,
                     double theta1, const double *q_ref, const double *closure_fields, double *links,
                     double *closures) {
    int i, j;
    if (n < 1 || nc < 0 || grb_scene_parents_ok(n, parent) != GRB_OK) return GRB_BAD_ARGUMENT;
    for (i = 0; i < n; i++) {
        const double *f = link_fields + i * GRB_SL_COLUMNS;
        double *row = links + i * GRB_L_COLUMNS;
        int p = parent_of(parent, i);
        double prev = p < 0 ? theta1 : q_ref[2 * p + 1];
        double phi = q_ref[2 * i + 1] - prev;  /* the pair's relative angle in the sketch */
        /* the locked relative angles on the path from the ground (model.py's cumsum, same order); held in the
         * theta0 column until the pass below adds theta1, so each sum is the serial chain's number */
        double locked = p < 0 ? 0.0 : links[p * GRB_L_COLUMNS + GRB_L_THETA0];
        row[GRB_L_M] = f[GRB_SL_M];
        row[GRB_L_I] = f[GRB_SL_I];
        row[GRB_L_P] = f[GRB_SL_P];
        row[GRB_L_Q] = f[GRB_SL_Q];
        row[GRB_L_A] = f[GRB_SL_A];
        row[GRB_L_APRED] = p < 0 ? a1 : link_fields[p * GRB_SL_COLUMNS + GRB_SL_A];
        row[GRB_L_DAMP] = f[GRB_SL_DAMP];
        row[GRB_L_REV] = revolute[i] ? 1.0 : 0.0;
        /* the locked part: a real slide starts from 0, a real revolute adds to the locked angle so far */
        row[GRB_L_SLIDE0] = revolute[i] ? q_ref[2 * i] : 0.0;
        if (!revolute[i]) locked += phi;
        row[GRB_L_THETA0] = locked;
        row[GRB_L_PARENT] = p;
    }
    for (i = 0; i < n; i++) links[i * GRB_L_COLUMNS + GRB_L_THETA0] += theta1;
    for (j = 0; j < nc; j++) {
        const double *f = closure_fields + j * GRB_SC_COLUMNS;
        double *row = closures + j * GRB_CL_COLUMNS;
        int link = (int)f[GRB_SC_LINK], to = (int)f[GRB_SC_TO];
        if (link < 2 || link > n + 1 || to < 1 || to > n + 1 || to == link) return GRB_BAD_ARGUMENT;
        row[GRB_CL_KIND] = f[GRB_SC_KIND];
        row[GRB_CL_LINK] = link - 2;
        row[GRB_CL_TO] = to - 2;
        row[GRB_CL_PX] = f[GRB_SC_PX];
        row[GRB_CL_PY] = f[GRB_SC_PY];
        row[GRB_CL_TX] = f[GRB_SC_TX];
        row[GRB_CL_TY] = f[GRB_SC_TY];
        row[GRB_CL_ANGLE] = f[GRB_SC_ANGLE];
        row[GRB_CL_PSI] = f[GRB_SC_PSI];
        row[GRB_CL_GAIN] = f[GRB_SC_GAIN];
        row[GRB_CL_DAMP] = f[GRB_SC_DAMP];
    }
    return GRB_OK;
}

int grb_z_from_q(int n, const int *revolute, const int *parent, double theta1, const double *q, double *z) {
    int i;
    if (grb_scene_parents_ok(n, parent) != GRB_OK) return GRB_BAD_ARGUMENT;
    for (i = 0; i < n; i++) {
        int p = parent_of(parent, i);
        double prev = p < 0 ? theta1 : q[2 * p + 1];
        z[i] = revolute[i] ? q[2 * i + 1] - prev : q[2 * i];
    }
    return GRB_OK;
}

int grb_zd_from_qd(int n, const int *revolute, const int *parent, const double *qd, double *zd) {
    int i;
    if (grb_scene_parents_ok(n, parent) != GRB_OK) return GRB_BAD_ARGUMENT;
    for (i = 0; i < n; i++) {
        int p = parent_of(parent, i);
        double prev = p < 0 ? 0.0 : qd[2 * p + 1];
        zd[i] = revolute[i] ? qd[2 * i + 1] - prev : qd[2 * i];
    }
    return GRB_OK;
}
