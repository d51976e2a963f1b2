/* What a drive must deliver to move a mechanism of mobility one along a given
 * motion of its drive joint: the inverse dynamics over a trajectory.
 *
 * At each sample the loop is closed with the drive coordinate held at the
 * trajectory's position (Newton from the previous sample's configuration, so
 * the branch is the one the motion came along), the dependent rates follow
 * from the closures' velocity equation, the dependent accelerations from
 * J zdd = gamma with the drive's acceleration given, and the drive effort and
 * closure multipliers from M zdd + h - Q = tau e_drive + J^T lambda.  The
 * library's drive_demand, its computed-torque feedforward and the native
 * ComputedTorque FMU all run this one function. */
#include <float.h>
#include <math.h>

#include "workspace.h"

/* scratch blocks in S (grb_work_size leaves room for them when N = M + 1):
 * U and V of the least-squares solver (N x N each), the dependent columns of
 * J (M x M), the state y (2N), the residual (N), a right side (M) and a
 * solution (N + 1) */
typedef struct demand_scratch {
    double *U, *V, *Jd, *y, *residual, *rhs, *x;
} demand_scratch;

static demand_scratch scratch_of(grb_ws *w) {
    demand_scratch s;
    int n = w->n, m = w->m;
    s.U = w->S;
    s.V = s.U + n * n;
    s.Jd = s.V + n * n;
    s.y = s.Jd + m * m;
    s.residual = s.y + 2 * n;
    s.rhs = s.residual + n;
    s.x = s.rhs + m;
    return s;
}

/* Squared singular values of the M x M matrix Jd (row-major), smallest over
 * largest: the eigenvalues of its Gram matrix, as closure.c finds the
 * closure's own. */
static double squared_conditioning(const double *Jd, grb_ws *w) {
    int m = w->m;
    double *G = w->schur;
    for (int r = 0; r < m; r++)
        for (int c = 0; c < m; c++) {
            double g = 0.0;
            for (int i = 0; i < m; i++) g += Jd[r * m + i] * Jd[c * m + i];
            G[r * m + c] = g;
        }
    double small, big;
    if (m == 2) {
        double tr = G[0] + G[3], det = G[0] * G[3] - G[1] * G[2];
        big = tr / 2.0 + sqrt(fmax(tr * tr / 4.0 - det, 0.0));
        small = det / (big > 0.0 ? big : 1.0); /* the small root without cancellation */
    } else {
        grb_sym_eig(G, w->eig_work, w->eigvec, w->eigval, m);
        small = big = w->eigval[0];
        for (int i = 1; i < m; i++) {
            small = fmin(small, w->eigval[i]);
            big = fmax(big, w->eigval[i]);
        }
    }
    if (!(big > 0.0)) return 0.0;
    return fmax(small, 0.0) / big;
}

/* One sample: z and zd hold the guess (the drive's position and rate set),
 * closed in place; zdd, the effort and the closing force written. */
static grb_status demand_sample(const grb_model *md, double scale, double acceleration, double load, double *z,
                                double *zd, double *zdd, double *torque, double *closing_force, double *closest,
                                double *work) {
    grb_ws w;
    int n = md->n_links, d = md->drive, *held, n_held = 0, n_hold = 0;
    grb_status status = grb_ws_init(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    held = w.index + WS_INDEX_DEMAND(n); /* the workspace's, apart from what the calls below use of it */
    status = grb_hold_count(md, z, work, &n_hold);
    if (status == GRB_OK) status = grb_held_coordinates(md, n_hold, z, held, &n_held, work);
    if (status == GRB_OK) status = grb_assemble(md, n_held, held, scale, z, zd, closest, work);
    if (status != GRB_OK) return status;
    status = grb_ws_init(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    int m = w.m;
    demand_scratch s = scratch_of(&w);
    for (int i = 0; i < n; i++) zdd[i] = 0.0;
    zdd[d] = acceleration;
    if (m > 0) {
        grb_chain(md, z, zd, &w);
        grb_closure_rows(md, zd, &w);
        /* the dependent columns (all but the drive's: N - 1 = M of them) */
        for (int r = 0; r < m; r++) {
            for (int i = 0, c = 0; i < n; i++)
                if (i != d) s.Jd[r * m + c++] = J_(&w, r, i);
            s.rhs[r] = w.row[r].gamma - J_(&w, r, d) * acceleration;
        }
        /* where they are singular two assembly branches meet: the other joints'
         * rates do not follow from the drive's, and a least-squares answer would
         * be one of many, the effort from it an artefact */
        if (squared_conditioning(s.Jd, &w) <= GRB_CHANGE_POINT_RCOND * GRB_CHANGE_POINT_RCOND) return GRB_SINGULAR;
        /* numpy.linalg.lstsq's default cut-off: machine epsilon times the larger size */
        grb_lstsq_min_norm(s.Jd, m, m, m, s.rhs, 1, DBL_EPSILON * m, s.x, s.U, s.V);
        for (int i = 0, c = 0; i < n; i++)
            if (i != d) zdd[i] = s.x[c++];
    }
    for (int i = 0; i < n; i++) {
        s.y[i] = z[i];
        s.y[n + i] = zd[i];
    }
    status = grb_inverse_residual(md, s.y, zdd, load, work, s.residual);
    if (status != GRB_OK) return status;
    /* residual = tau e_drive + J^T lambda: least squares over [e_drive, J^T]
     * (N x (M + 1)), laid out in the solver's table the residual did not use */
    double *A = w.solve;
    int stride = w.sc;
    for (int i = 0; i < n; i++) {
        A[i * stride] = i == d ? 1.0 : 0.0;
        for (int r = 0; r < m; r++) A[i * stride + 1 + r] = J_(&w, r, i);
    }
    grb_lstsq_min_norm(A, stride, n, m + 1, s.residual, 1, DBL_EPSILON * (n > m + 1 ? n : m + 1), s.x, s.U, s.V);
    *torque = s.x[0];
    closing_force[0] = closing_force[1] = 0.0;
    if (md->n_closures > 0) {
        if (grb_closures(md)[0].kind == 0.0) { /* a pin: the multipliers are the force */
            closing_force[0] = s.x[1];
            closing_force[1] = s.x[2];
        } else { /* a point on a line: the one multiplier along the line's normal */
            closing_force[0] = w.row[0].normal * s.x[1];
            closing_force[1] = w.row[1].normal * s.x[1];
        }
    }
    return GRB_OK;
}

grb_status grb_drive_demand(const grb_model *md, double scale, int rows, const double *position,
                            const double *velocity, const double *acceleration, const double *load,
                            const double *z_guess, double *z, double *zd, double *zdd, double *torque,
                            double *closing_force, int *at, double *closest, double *work) {
    int n = md->n_links;
    *at = -1;
    *closest = 0.0;
    if (md->drive < 0 || md->drive >= n || n - 2 * md->n_closures != 1 || rows < 0) return GRB_BAD_ARGUMENT;
    for (int k = 0; k < rows; k++) {
        double *zk = z + (size_t)k * n, *zdk = zd + (size_t)k * n;
        *at = k;
        if (!isfinite(position[k]) || !isfinite(velocity[k]) || !isfinite(acceleration[k]) ||
            !(load == NULL || isfinite(load[k])))
            return GRB_BAD_ARGUMENT;
        if (k == 0) {
            for (int i = 0; i < n; i++) zk[i] = z_guess[i];
        } else if (k >= 2 && position[k - 1] != position[k - 2]) {
            /* the guess continues the last two samples (a secant predictor): through
             * a change point, where the closure's Jacobian is singular and a guess
             * from the last sample alone cannot move, the motion goes on along the
             * branch it came along, as the simulator's does */
            const double *z1 = zk - n, *z2 = zk - 2 * n;
            double ratio = (position[k] - position[k - 1]) / (position[k - 1] - position[k - 2]);
            for (int i = 0; i < n; i++) zk[i] = z1[i] + (z1[i] - z2[i]) * ratio;
        } else {
            for (int i = 0; i < n; i++) zk[i] = zk[i - n];
        }
        zk[md->drive] = position[k];
        for (int i = 0; i < n; i++) zdk[i] = 0.0;
        zdk[md->drive] = velocity[k];
        /* the guess, kept in zdd's row (written only once the loop is closed) */
        double *zddk = zdd + (size_t)k * n;
        for (int i = 0; i < n; i++) zddk[i] = zk[i];
        grb_status status = demand_sample(md, scale, acceleration[k], load ? load[k] : 0.0, zk, zdk, zddk, torque + k,
                                          closing_force + 2 * (size_t)k, closest, work);
        if (status == GRB_NOT_CLOSED)
            for (int i = 0; i < n; i++) zk[i] = zddk[i]; /* for the caller to say what was held */
        if (status != GRB_OK) return status;
    }
    *at = -1;
    return GRB_OK;
}
