/* Kinematics and dynamics of the spatial chain and its closures.
 *
 * As in the planar kernel (chain.c): one pass from the ground to the tips gives
 * each link's frame, its velocities and its bias accelerations (at zero joint
 * accelerations); any point or direction fixed to a link then has a value, a
 * Jacobian with respect to the real joint rates and a bias acceleration.  The
 * equations of motion follow by virtual power over those Jacobians (the
 * Newton-Euler equations of each link projected on the joint space, Kane's
 * form):
 *   M = sum_k m_k Jv^T Jv + Jw^T I_k Jw,
 *   Q - h = sum_k Jv^T m_k (g - a_bias) - Jw^T (I_k alpha_bias + w x I_k w) + tau - damping,
 * and the closures add J^T lambda, solved exactly from J zdd = gamma. */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "sp_workspace.h"

typedef char grs_link_columns_check[(offsetof(grs_link, parent) == GRS_L_PARENT * sizeof(double) &&
                                     offsetof(grs_link, inertia) == GRS_L_INERTIA * sizeof(double) &&
                                     sizeof(grs_link) == GRS_L_COLUMNS * sizeof(double)) ? 1 : -1];
typedef char grs_closure_columns_check[(offsetof(grs_closure, to_axis) == GRS_CL_TO_AXIS * sizeof(double) &&
                                        sizeof(grs_closure) == GRS_CL_COLUMNS * sizeof(double)) ? 1 : -1];

/* -- small vector algebra ------------------------------------------------ */
static void cross(const double *a, const double *b, double *out) {
    double x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
    out[0] = x;
    out[1] = y;
    out[2] = z;
}
static double dot(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
/* out = R x (R row-major) */
static void rotate(const double *R, const double *x, double *out) {
    double y[3];
    for (int i = 0; i < 3; i++) y[i] = R[3 * i] * x[0] + R[3 * i + 1] * x[1] + R[3 * i + 2] * x[2];
    memcpy(out, y, sizeof y);
}
/* out = A B for 3 x 3 row-major matrices */
static void matmul(const double *A, const double *B, double *out) {
    double C[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
    memcpy(out, C, sizeof C);
}

/* -- the model's validity, checked in one place ---------------------------- */
static int is_flag(double x) { return x == 0.0 || x == 1.0; }

static grb_status bad(int *row, int *column, int r, int c) {
    if (row) *row = r;
    if (column) *column = c;
    return GRB_BAD_ARGUMENT;
}

/* A tensor about the mass centre is a real body's when the body's second
 * moment Sigma = int r r^T dm = (tr I / 2) E - I is positive semi-definite
 * (then so is I = tr(Sigma) E - Sigma, and each principal moment is at most
 * the sum of the other two): every principal minor of Sigma >= 0. */
static int inertia_ok(const double *I) {
    double half = 0.5 * (I[0] + I[3] + I[5]);
    double xx = half - I[0], yy = half - I[3], zz = half - I[5], xy = -I[1], xz = -I[2], yz = -I[4];
    double tol = 1e-12 * (fabs(I[0]) + fabs(I[3]) + fabs(I[5]));
    if (xx < -tol || yy < -tol || zz < -tol) return 0;
    if (xx * yy - xy * xy < -tol * tol || xx * zz - xz * xz < -tol * tol || yy * zz - yz * yz < -tol * tol) return 0;
    double det = xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * xz) + xz * (xy * yz - yy * xz);
    return det >= -tol * tol * tol;
}

grb_status grs_check(const grs_model *md, int *row, int *column) {
    if (!md || md->n_links < 1 || md->n_links > GRS_MAX_LINKS || !md->links) return bad(row, column, 0, -1);
    if (md->n_closures < 0 || (md->n_closures > 0 && !md->closures)) return bad(row, column, -1, -1);
    for (int i = 0; i < 3; i++)
        if (!isfinite(md->gravity[i])) return bad(row, column, 0, -2);
    int n = 0, m = 0;
    for (int k = 0; k < md->n_links; k++) {
        const double *r = md->links + (size_t)k * GRS_L_COLUMNS;
        for (int c = 0; c < GRS_L_COLUMNS; c++)
            if (!isfinite(r[c])) return bad(row, column, k, c);
        const grs_link *l = grs_links(md) + k;
        if (!is_flag(l->revolute)) return bad(row, column, k, GRS_L_REV);
        if (!is_flag(l->prismatic)) return bad(row, column, k, GRS_L_PRIS);
        if (l->parent != floor(l->parent) || l->parent < -1 || l->parent >= k) return bad(row, column, k, GRS_L_PARENT);
        if (l->m < 0.0) return bad(row, column, k, GRS_L_M);
        if (!inertia_ok(l->inertia)) return bad(row, column, k, GRS_L_INERTIA);
        if (l->damping_r < 0.0) return bad(row, column, k, GRS_L_DAMP_R);
        if (l->damping_p < 0.0) return bad(row, column, k, GRS_L_DAMP_P);
        n += (int)l->revolute + (int)l->prismatic;
    }
    for (int c = 0; c < md->n_closures; c++) {
        const double *r = md->closures + (size_t)c * GRS_CL_COLUMNS;
        for (int j = 0; j < GRS_CL_COLUMNS; j++)
            if (!isfinite(r[j])) return bad(row, column, -1 - c, j);
        const grs_closure *cl = grs_closures(md) + c;
        if (cl->kind != GRS_SPHERICAL && cl->kind != GRS_REVOLUTE && cl->kind != GRS_CYLINDRICAL)
            return bad(row, column, -1 - c, GRS_CL_KIND);
        if (cl->link != floor(cl->link) || cl->link < -1 || cl->link >= md->n_links)
            return bad(row, column, -1 - c, GRS_CL_LINK);
        if (cl->to != floor(cl->to) || cl->to < -1 || cl->to >= md->n_links || cl->to == cl->link)
            return bad(row, column, -1 - c, GRS_CL_TO);
        if (cl->kind != GRS_SPHERICAL) {
            if (fabs(dot(cl->axis, cl->axis) - 1.0) > 1e-9) return bad(row, column, -1 - c, GRS_CL_AXIS);
            if (fabs(dot(cl->to_axis, cl->to_axis) - 1.0) > 1e-9) return bad(row, column, -1 - c, GRS_CL_TO_AXIS);
        }
        m += grs_closure_rows_of((int)cl->kind);
    }
    if (n < 1 || n > GRS_MAX_COORDS) return bad(row, column, md->n_links - 1, GRS_L_REV);
    if (m > GRS_MAX_ROWS) return bad(row, column, -md->n_closures, GRS_CL_KIND);
    return GRB_OK;
}

int grs_n_coords(const grs_model *md) {
    int n = 0;
    for (int k = 0; k < md->n_links; k++) n += (int)grs_links(md)[k].revolute + (int)grs_links(md)[k].prismatic;
    return n;
}

int grs_n_rows(const grs_model *md) {
    int m = 0;
    for (int c = 0; c < md->n_closures; c++) m += grs_closure_rows_of((int)grs_closures(md)[c].kind);
    return m;
}

/* -- the workspace ----------------------------------------------------------- */
/* assembly's and least squares' scratch (sp_closure.c): U (N x M), V (M x M),
 * a compact Jacobian (M x N), six N-vectors, two M-vectors, a state (2N) */
size_t grs_scratch_size(int n, int m) {
    size_t N = (size_t)n, M = (size_t)m;
    return N * M + M * M + M * N + 6 * N + 2 * M + 2 * N + 8;
}

static void offsets(int L, int n, int m, size_t *off) {
    size_t N = (size_t)n, M = (size_t)m;
    off[0] = GRS_WORK_HEADER;                            /* frames */
    off[1] = off[0] + (size_t)L * GRS_FRAME_COLUMNS;     /* mass */
    off[2] = off[1] + N * N;                             /* force */
    off[3] = off[2] + N;                                 /* J */
    off[4] = off[3] + M * N;                             /* rows */
    off[5] = off[4] + M * GRS_ROW_COLUMNS;               /* solve */
    off[6] = off[5] + N * (N + M + 1);                   /* schur, eig_work, eigvec, eigval */
    off[7] = off[6] + M * (3 * M + 1);                   /* zdd */
    off[8] = off[7] + N;                                 /* four tracked vectors' Jacobians */
    off[9] = off[8] + 4 * 3 * N;                         /* S */
    off[10] = off[9] + grs_scratch_size(n, m) + 12 * (size_t)L; /* and the reactions' two 6 L tables */
    off[11] = off[10] + 2 * (size_t)(n > 1 ? n - 1 : 0) * M;      /* the change-point watch's two bases */
}

size_t grs_work_size(const grs_model *md) {
    if (grs_check(md, NULL, NULL) != GRB_OK) return 0;
    return grs_work_size_for(md->n_links, grs_n_coords(md), grs_n_rows(md));
}

size_t grs_work_size_for(int n_links, int n_coords, int n_rows) {
    size_t off[12];
    if (n_links < 1 || n_links > GRS_MAX_LINKS || n_coords < 1 || n_coords > GRS_MAX_COORDS || n_rows < 0 ||
        n_rows > GRS_MAX_ROWS)
        return 0;
    offsets(n_links, n_coords, n_rows, off);
    return off[11];
}

grb_status grs_work_init(const grs_model *md, double *buffer, size_t length) {
    if (grs_check(md, NULL, NULL) != GRB_OK || !buffer || length < grs_work_size(md)) return GRB_BAD_ARGUMENT;
    buffer[GRS_WORK_TAG] = GRS_TAG;
    buffer[GRS_WORK_LINKS] = md->n_links;
    buffer[GRS_WORK_COORDS] = grs_n_coords(md);
    buffer[GRS_WORK_ROWS] = grs_n_rows(md);
    return GRB_OK;
}

grb_status grs_ws_init(grs_ws *w, const grs_model *md, double *buffer) {
    if (!buffer || grs_check(md, NULL, NULL) != GRB_OK) return GRB_BAD_ARGUMENT;
    int L = md->n_links, n = grs_n_coords(md), m = grs_n_rows(md);
    if (buffer[GRS_WORK_TAG] != GRS_TAG) { /* a buffer no call has used: the caller sized it */
        buffer[GRS_WORK_TAG] = GRS_TAG;
        buffer[GRS_WORK_LINKS] = L;
        buffer[GRS_WORK_COORDS] = n;
        buffer[GRS_WORK_ROWS] = m;
    } else if (buffer[GRS_WORK_LINKS] != L || buffer[GRS_WORK_COORDS] != n || buffer[GRS_WORK_ROWS] != m)
        return GRB_BAD_ARGUMENT;
    size_t off[12];
    offsets(L, n, m, off);
    w->L = L;
    w->n = n;
    w->m = m;
    w->sc = n + m + 1;
    w->frame = (grs_frame *)(buffer + off[0]);
    w->mass = buffer + off[1];
    w->force = buffer + off[2];
    w->J = buffer + off[3];
    w->row = (grs_row *)(buffer + off[4]);
    w->solve = buffer + off[5];
    w->schur = buffer + off[6];
    w->eig_work = w->schur + (size_t)m * m;
    w->eigvec = w->eig_work + (size_t)m * m;
    w->eigval = w->eigvec + (size_t)m * m;
    w->zdd = buffer + off[7];
    for (int i = 0; i < 4; i++) w->vec[i].J = buffer + off[8] + (size_t)i * 3 * n;
    w->S = buffer + off[9];
    w->basis = buffer + off[10];
    w->n_idle = 0;
    int c = 0;
    for (int k = 0; k < L; k++) {
        const grs_link *l = grs_links(md) + k;
        int p = (int)l->parent;
        w->path[k] = (p >= 0 ? w->path[p] : 0ull) | (1ull << k);
        w->theta_at[k] = w->d_at[k] = -1;
        if (l->revolute != 0.0) {
            w->theta_at[k] = c;
            w->coord_link[c] = k;
            w->coord_slide[c++] = 0;
        }
        if (l->prismatic != 0.0) {
            w->d_at[k] = c;
            w->coord_link[c] = k;
            w->coord_slide[c++] = 1;
        }
    }
    return GRB_OK;
}

static int on_path(const grs_ws *w, int j, int k) { return k >= 0 && (int)((w->path[k] >> j) & 1u); }

/* -- the kinematic pass ------------------------------------------------------- */
/* Each link from its parent's frame (parents come first):
 *   R_k = R_p Rx(alpha) Rz(theta),  axis = R_p Rx(alpha) e_z,
 *   o_k = o_p + r,  r = R_p (a, 0, 0) + d axis,
 *   w_k = w_p + thetadot axis,       v_k = v_p + w_p x r + ddot axis,
 *   alpha_b = alpha_p + w_p x thetadot axis,
 *   a_b = a_p + alpha_p x r + w_p x (w_p x r) + 2 ddot w_p x axis. */
void grs_kinematics(const grs_model *md, const double *z, const double *zd, grs_ws *w) {
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const double zero[3] = {0, 0, 0};
    for (int k = 0; k < w->L; k++) {
        const grs_link *l = grs_links(md) + k;
        int p = (int)l->parent;
        const grs_frame *P = p >= 0 ? w->frame + p : NULL;
        const double *Rp = P ? P->R : identity, *op = P ? P->o : zero, *wp = P ? P->omega : zero,
                     *vp = P ? P->v : zero, *alp = P ? P->alpha_b : zero, *ap = P ? P->a_b : zero;
        grs_frame *F = w->frame + k;
        double theta = l->theta, d = l->d, thd = 0.0, dd = 0.0;
        if (w->theta_at[k] >= 0) {
            theta += z[w->theta_at[k]];
            thd = zd[w->theta_at[k]];
        }
        if (w->d_at[k] >= 0) {
            d += z[w->d_at[k]];
            dd = zd[w->d_at[k]];
        }
        double ca = cos(l->alpha), sa = sin(l->alpha), ct = cos(theta), st = sin(theta);
        double Rx[9] = {1, 0, 0, 0, ca, -sa, 0, sa, ca}, Rz[9] = {ct, -st, 0, st, ct, 0, 0, 0, 1}, Rj[9];
        matmul(Rp, Rx, Rj);
        matmul(Rj, Rz, F->R);
        for (int i = 0; i < 3; i++) F->axis[i] = Rj[3 * i + 2];
        double r[3], ax[3] = {l->a, 0.0, 0.0}, t1[3], t2[3];
        rotate(Rp, ax, r);
        for (int i = 0; i < 3; i++) {
            r[i] += d * F->axis[i];
            F->o[i] = op[i] + r[i];
            F->omega[i] = wp[i] + thd * F->axis[i];
        }
        cross(wp, r, t1);
        for (int i = 0; i < 3; i++) F->v[i] = vp[i] + t1[i] + dd * F->axis[i];
        cross(wp, F->axis, t2); /* the axis's rate */
        for (int i = 0; i < 3; i++) F->alpha_b[i] = alp[i] + thd * t2[i];
        double wr[3], wwr[3], alr[3];
        cross(wp, r, wr);
        cross(wp, wr, wwr);
        cross(alp, r, alr);
        for (int i = 0; i < 3; i++) F->a_b[i] = ap[i] + alr[i] + wwr[i] + 2.0 * dd * t2[i];
    }
}

/* A point fixed to link k (local in its frame; k = -1: a world point). */
void grs_point(const grs_ws *w, int k, const double *local, grs_vec *out) {
    int n = w->n;
    memset(out->J, 0, sizeof(double) * 3 * (size_t)n);
    if (k < 0) {
        for (int i = 0; i < 3; i++) out->value[i] = local[i], out->rate[i] = out->bias[i] = 0.0;
        return;
    }
    const grs_frame *F = w->frame + k;
    double rho[3], t[3], u[3];
    rotate(F->R, local, rho);
    for (int i = 0; i < 3; i++) out->value[i] = F->o[i] + rho[i];
    cross(F->omega, rho, t);
    for (int i = 0; i < 3; i++) out->rate[i] = F->v[i] + t[i];
    cross(F->alpha_b, rho, t);
    cross(F->omega, rho, u);
    cross(F->omega, u, u);
    for (int i = 0; i < 3; i++) out->bias[i] = F->a_b[i] + t[i] + u[i];
    for (int c = 0; c < n; c++) {
        int j = w->coord_link[c];
        if (!on_path(w, j, k)) continue;
        const grs_frame *G = w->frame + j;
        if (w->coord_slide[c]) {
            for (int i = 0; i < 3; i++) out->J[i * n + c] = G->axis[i];
        } else {
            double arm[3], col[3];
            for (int i = 0; i < 3; i++) arm[i] = out->value[i] - G->o[i];
            cross(G->axis, arm, col);
            for (int i = 0; i < 3; i++) out->J[i * n + c] = col[i];
        }
    }
}

/* A direction fixed to link k (local in its frame; k = -1: a world direction). */
void grs_direction(const grs_ws *w, int k, const double *local, grs_vec *out) {
    int n = w->n;
    memset(out->J, 0, sizeof(double) * 3 * (size_t)n);
    if (k < 0) {
        for (int i = 0; i < 3; i++) out->value[i] = local[i], out->rate[i] = out->bias[i] = 0.0;
        return;
    }
    const grs_frame *F = w->frame + k;
    double t[3], u[3];
    rotate(F->R, local, out->value);
    cross(F->omega, out->value, out->rate);
    cross(F->alpha_b, out->value, t);
    cross(F->omega, out->rate, u);
    for (int i = 0; i < 3; i++) out->bias[i] = t[i] + u[i];
    for (int c = 0; c < n; c++) {
        int j = w->coord_link[c];
        if (w->coord_slide[c] || !on_path(w, j, k)) continue;
        double col[3];
        cross(w->frame[j].axis, out->value, col);
        for (int i = 0; i < 3; i++) out->J[i * n + c] = col[i];
    }
}

/* -- closures ------------------------------------------------------------------ */
/* The closure frame on the target, in its axes: v the unit target axis (z for
 * a spherical joint), n1 the target's x axis made square to v (its y axis
 * where x lies almost along v), n2 = v x n1: for a joint along z, the
 * target's own x, y, z. */
static void closure_frame(const grs_closure *cl, double *n1, double *n2, double *v) {
    static const double ez[3] = {0, 0, 1};
    const double *a = cl->kind == GRS_SPHERICAL ? ez : cl->to_axis;
    double len = sqrt(dot(a, a));
    for (int i = 0; i < 3; i++) v[i] = a[i] / len;
    double e[3] = {1, 0, 0};
    if (fabs(v[0]) > 0.9) e[0] = 0.0, e[1] = 1.0;
    double along = dot(e, v);
    for (int i = 0; i < 3; i++) n1[i] = e[i] - along * v[i];
    len = sqrt(dot(n1, n1));
    for (int i = 0; i < 3; i++) n1[i] /= len;
    cross(v, n1, n2);
}

grb_status grs_closure_frame(const grs_model *md, int c, double *frame) {
    if (grs_check(md, NULL, NULL) != GRB_OK || c < 0 || c >= md->n_closures) return GRB_BAD_ARGUMENT;
    closure_frame(grs_closures(md) + c, frame, frame + 3, frame + 6);
    return GRB_OK;
}

/* Row r as the dot product f . g of two moving vectors: phi, its Jacobian
 * g^T Jf + f^T Jg and gamma = -(f_bias . g + 2 fdot . gdot + f . g_bias). */
static void dot_row(grs_ws *w, int r, const grs_vec *f, const grs_vec *g) {
    int n = w->n;
    w->row[r].phi = dot(f->value, g->value);
    w->row[r].gamma = -(dot(f->bias, g->value) + 2.0 * dot(f->rate, g->rate) + dot(f->value, g->bias));
    for (int c = 0; c < n; c++) {
        double s = 0.0;
        for (int i = 0; i < 3; i++) s += g->value[i] * f->J[i * n + c] + f->value[i] * g->J[i * n + c];
        SP_J(w, r, c) = s;
    }
}

/* Every closure row at the frames of the last kinematic pass. */
void grs_closure_rows(const grs_model *md, grs_ws *w) {
    int r = 0, n = w->n;
    grs_vec *d = w->vec, *t = w->vec + 1, *g = w->vec + 2, *u = w->vec + 3;
    for (int c = 0; c < md->n_closures; c++) {
        const grs_closure *cl = grs_closures(md) + c;
        int link = (int)cl->link, to = (int)cl->to, kind = (int)cl->kind;
        double axes[3][3];
        closure_frame(cl, axes[0], axes[1], axes[2]);
        /* d = point - to_point */
        grs_point(w, link, cl->point, d);
        grs_point(w, to, cl->to_point, t);
        for (int i = 0; i < 3; i++) {
            d->value[i] -= t->value[i];
            d->rate[i] -= t->rate[i];
            d->bias[i] -= t->bias[i];
        }
        for (int i = 0; i < 3 * n; i++) d->J[i] -= t->J[i];
        int positions = kind == GRS_CYLINDRICAL ? 2 : 3;
        for (int a = 0; a < positions; a++) {
            grs_direction(w, to, axes[a], g);
            dot_row(w, r++, d, g);
        }
        if (kind == GRS_SPHERICAL) continue;
        grs_direction(w, link, cl->axis, u);
        for (int a = 0; a < 2; a++) {
            grs_direction(w, to, axes[a], g);
            dot_row(w, r++, u, g);
        }
    }
}

/* -- the equations of motion ----------------------------------------------------- */
/* The inertia tensor of link k about its mass centre in the world's axes. */
static void world_inertia(const grs_link *l, const grs_frame *F, double *Iw) {
    const double *t = l->inertia;
    double I[9] = {t[0], t[1], t[2], t[1], t[3], t[4], t[2], t[4], t[5]}, RI[9], Rt[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) Rt[3 * i + j] = F->R[3 * j + i];
    matmul(F->R, I, RI);
    matmul(RI, Rt, Iw);
}

/* M and Q - h of the open tree at the frames of the last kinematic pass. */
void grs_mass_and_force(const grs_model *md, const double *zd, const double *tau, grs_ws *w) {
    int n = w->n;
    grs_vec *c = w->vec, *rot = w->vec + 1; /* rot: the angular Jacobian in rot->J */
    memset(w->mass, 0, sizeof(double) * (size_t)n * n);
    for (int i = 0; i < n; i++) {
        int k = w->coord_link[i];
        const grs_link *l = grs_links(md) + k;
        w->force[i] = (tau ? tau[i] : 0.0) - (w->coord_slide[i] ? l->damping_p : l->damping_r) * zd[i];
    }
    for (int k = 0; k < w->L; k++) {
        const grs_link *l = grs_links(md) + k;
        const grs_frame *F = w->frame + k;
        grs_point(w, k, l->com, c);
        memset(rot->J, 0, sizeof(double) * 3 * (size_t)n);
        for (int j = 0; j < n; j++)
            if (!w->coord_slide[j] && on_path(w, w->coord_link[j], k))
                for (int i = 0; i < 3; i++) rot->J[i * n + j] = w->frame[w->coord_link[j]].axis[i];
        double Iw[9], Iwo[3], Ia[3], gyro[3], lin[3], ang[3];
        world_inertia(l, F, Iw);
        rotate(Iw, F->omega, Iwo);
        rotate(Iw, F->alpha_b, Ia);
        cross(F->omega, Iwo, gyro);
        for (int i = 0; i < 3; i++) {
            lin[i] = l->m * (md->gravity[i] - c->bias[i]);
            ang[i] = -(Ia[i] + gyro[i]);
        }
        for (int a = 0; a < n; a++) {
            double fa = 0.0;
            for (int i = 0; i < 3; i++) fa += c->J[i * n + a] * lin[i] + rot->J[i * n + a] * ang[i];
            w->force[a] += fa;
            for (int b = a; b < n; b++) {
                double s = 0.0;
                for (int i = 0; i < 3; i++) {
                    s += l->m * c->J[i * n + a] * c->J[i * n + b];
                    for (int j = 0; j < 3; j++) s += rot->J[i * n + a] * Iw[3 * i + j] * rot->J[j * n + b];
                }
                SP_MASS(w, a, b) += s;
                if (b != a) SP_MASS(w, b, a) += s;
            }
        }
    }
}

#define SINGULAR_RCOND 1e-10

/* Solve S lambda = b (S symmetric, >= 0) in the minimum norm, dropping the
 * directions S loses (dependent closure rows: an overconstrained loop). */
static void closure_multipliers(grs_ws *w) {
    int m = w->m;
    grb_sym_eig(w->schur, w->eig_work, w->eigvec, w->eigval, m);
    double w_max = 0.0;
    for (int i = 0; i < m; i++)
        if (w->eigval[i] > w_max) w_max = w->eigval[i];
    for (int r = 0; r < m; r++) w->row[r].lambda = 0.0;
    for (int i = 0; i < m; i++) {
        if (!(w->eigval[i] > SINGULAR_RCOND * w_max)) continue;
        double coef = 0.0;
        for (int r = 0; r < m; r++) coef += SP_EIGVEC(w, r, i) * w->row[r].b;
        coef /= w->eigval[i];
        for (int r = 0; r < m; r++) w->row[r].lambda += SP_EIGVEC(w, r, i) * coef;
    }
}

/* Accelerations and multipliers at (z, zd), the planar kernel's exact method
 * (chain.c): M may be singular where a coordinate carries no inertia of its
 * own, M + a J^T J is not, and since J zdd = gamma the added term changes
 * nothing in the solution (augmented Lagrangian).  The solver's table holds
 * that matrix, then the force (column N), then J^T. */
grb_status grs_accelerations(const grs_model *md, const double *z, const double *zd, const double *tau, grs_ws *w) {
    int n = w->n, m = w->m, f = n;
    grs_kinematics(md, z, zd, w);
    grs_mass_and_force(md, zd, tau, w);
    grs_closure_rows(md, w);
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < n; j++) SP_SOLVE(w, i, j) = SP_MASS(w, i, j);
        SP_SOLVE(w, i, f) = w->force[i];
    }
    double trace = 0.0, jj = 0.0;
    for (int i = 0; i < n; i++) trace += SP_MASS(w, i, i);
    for (int r = 0; r < m; r++)
        for (int i = 0; i < n; i++) jj += SP_J(w, r, i) * SP_J(w, r, i);
    double a = m > 0 ? trace / (jj > 1e-300 ? jj : 1e-300) : 0.0;
    for (int r = 0; r < m; r++)
        for (int i = 0; i < n; i++) {
            SP_SOLVE(w, i, f) += a * SP_J(w, r, i) * w->row[r].gamma;
            SP_SOLVE(w, i, f + 1 + r) = SP_J(w, r, i);
            for (int j = 0; j < n; j++) SP_SOLVE(w, i, j) += a * SP_J(w, r, i) * SP_J(w, r, j);
        }
    grb_status status = grb_lu_solve(w->solve, w->sc, n, 0, f, m + 1);
    for (int r = 0; r < m; r++) {
        double s = w->row[r].gamma;
        for (int i = 0; i < n; i++) s -= SP_J(w, r, i) * SP_SOLVE(w, i, f);
        w->row[r].b = s;
        for (int c = 0; c < m; c++) {
            double q = 0.0;
            for (int i = 0; i < n; i++) q += SP_J(w, r, i) * SP_SOLVE(w, i, f + 1 + c);
            SP_SCHUR(w, r, c) = q;
        }
    }
    if (status == GRB_OK && m > 0) closure_multipliers(w);
    for (int i = 0; i < n; i++) {
        double s = SP_SOLVE(w, i, f);
        for (int c = 0; c < m; c++) s += SP_SOLVE(w, i, f + 1 + c) * w->row[c].lambda;
        w->zdd[i] = status == GRB_OK ? s : NAN;
    }
    return status;
}

/* Kinetic (1/2 zd^T M zd) and potential (-sum m g . c) energy after a pass. */
static void energies(const grs_model *md, const double *zd, grs_ws *w, double *energy) {
    int n = w->n;
    double ke = 0.0, pe = 0.0;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) ke += 0.5 * zd[i] * SP_MASS(w, i, j) * zd[j];
    for (int k = 0; k < w->L; k++) {
        const grs_link *l = grs_links(md) + k;
        double c[3];
        rotate(w->frame[k].R, l->com, c);
        for (int i = 0; i < 3; i++) pe -= l->m * md->gravity[i] * (w->frame[k].o[i] + c[i]);
    }
    energy[0] = ke;
    energy[1] = pe;
}

grb_status grs_dynamics(const grs_model *md, const double *y, const double *tau, double *work, double *zdd,
                        double *lambda, double *energy) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    status = grs_accelerations(md, y, y + w.n, tau, &w);
    for (int i = 0; i < w.n && zdd; i++) zdd[i] = w.zdd[i];
    for (int r = 0; r < w.m && lambda; r++) lambda[r] = w.row[r].lambda;
    if (energy) energies(md, y + w.n, &w, energy);
    return status;
}

grb_status grs_rhs(const grs_model *md, const double *y, const double *tau, double *work, double *out) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    status = grs_accelerations(md, y, y + w.n, tau, &w);
    for (int i = 0; i < w.n; i++) {
        out[i] = y[w.n + i];
        out[w.n + i] = w.zdd[i];
    }
    return status;
}

grb_status grs_frames(const grs_model *md, const double *z, double *work, double *out) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    double *rest = w.zdd; /* zero rates: positions only */
    for (int i = 0; i < w.n; i++) rest[i] = 0.0;
    grs_kinematics(md, z, rest, &w);
    for (int k = 0; k < w.L; k++) {
        memcpy(out + 12 * k, w.frame[k].o, 3 * sizeof(double));
        memcpy(out + 12 * k + 3, w.frame[k].R, 9 * sizeof(double));
    }
    return GRB_OK;
}

grb_status grs_link_points_rows(const grs_model *md, int rows, const double *y, int n_points, const int *link,
                                const double *local, double *work, double *out) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    if (rows < 0 || n_points < 0) return GRB_BAD_ARGUMENT;
    for (int p = 0; p < n_points; p++)
        if (link[p] < -1 || link[p] >= w.L) return GRB_BAD_ARGUMENT;
    for (int i = 0; i < rows; i++) {
        grs_kinematics(md, y + (size_t)i * 2 * w.n, y + (size_t)i * 2 * w.n + w.n, &w);
        for (int p = 0; p < n_points; p++) {
            grs_point(&w, link[p], local + 3 * p, w.vec);
            memcpy(out + ((size_t)i * n_points + p) * 3, w.vec[0].value, 3 * sizeof(double));
        }
    }
    return GRB_OK;
}

/* -- reactions ------------------------------------------------------------------- */
/* The wrenches the closures put on the links (force, moment about the world
 * origin: 6 per link, in acc), and each closure's own (target on closing link,
 * in its frame, moment about the closing point) into out when given. */
static void closure_wrenches(const grs_model *md, grs_ws *w, double *acc, double *out) {
    int r = 0;
    for (int c = 0; c < md->n_closures; c++) {
        const grs_closure *cl = grs_closures(md) + c;
        int link = (int)cl->link, to = (int)cl->to, kind = (int)cl->kind;
        double axes[3][3], g[3][3], u[3], p[3], q[3], F[3] = {0, 0, 0}, Mp[3] = {0, 0, 0};
        closure_frame(cl, axes[0], axes[1], axes[2]);
        grs_point(w, link, cl->point, w->vec);
        memcpy(p, w->vec[0].value, sizeof p);
        grs_point(w, to, cl->to_point, w->vec);
        memcpy(q, w->vec[0].value, sizeof q);
        for (int a = 0; a < 3; a++) {
            grs_direction(w, to, axes[a], w->vec);
            memcpy(g[a], w->vec[0].value, sizeof g[a]);
        }
        /* row d.g: force lambda g on the link at p, -lambda g on the target at
         * q, and the moment lambda g x d on the target as g turns with it */
        int positions = kind == GRS_CYLINDRICAL ? 2 : 3;
        double Mt[3] = {0, 0, 0}, dvec[3] = {p[0] - q[0], p[1] - q[1], p[2] - q[2]}, t[3];
        for (int a = 0; a < positions; a++) {
            double lam = w->row[r++].lambda;
            cross(g[a], dvec, t);
            for (int i = 0; i < 3; i++) {
                F[i] += lam * g[a][i];
                Mt[i] += lam * t[i];
            }
        }
        if (kind != GRS_SPHERICAL) { /* row u.g: moment lambda u x g on the link, its opposite on the target */
            grs_direction(w, link, cl->axis, w->vec);
            memcpy(u, w->vec[0].value, sizeof u);
            for (int a = 0; a < 2; a++) {
                double lam = w->row[r++].lambda;
                cross(u, g[a], t);
                for (int i = 0; i < 3; i++) {
                    Mp[i] += lam * t[i];
                    Mt[i] -= lam * t[i];
                }
            }
        }
        double pf[3], qf[3];
        cross(p, F, pf);
        cross(q, F, qf);
        if (acc && link >= 0)
            for (int i = 0; i < 3; i++) {
                acc[6 * link + i] += F[i];
                acc[6 * link + 3 + i] += Mp[i] + pf[i];
            }
        if (acc && to >= 0)
            for (int i = 0; i < 3; i++) {
                acc[6 * to + i] -= F[i];
                acc[6 * to + 3 + i] += Mt[i] - qf[i];
            }
        if (out)
            for (int a = 0; a < 3; a++) {
                out[6 * c + a] = dot(F, g[a]);
                out[6 * c + 3 + a] = dot(Mp, g[a]);
            }
    }
}

/* Newton-Euler from the tips back to the ground: the wrench the parent puts
 * on each link through its joint is what the link's motion needs, less
 * gravity and the closures' wrenches on it, plus what it passes on to its
 * children (without inertial: the closures' wrenches alone, at rest and
 * without gravity, for the determinacy of the joints' reactions).  Forces and moments about the world origin while summing, then
 * moved to the joint origin and turned into the link's axes. */
static void joint_reactions(const grs_model *md, grs_ws *w, int inertial, double *ext, double *out) {
    int n = w->n;
    double *need = ext; /* 6 per link: accumulates the wrench each joint must carry */
    for (int k = 0; k < w->L && !inertial; k++)
        for (int i = 0; i < 6; i++) need[6 * k + i] = -need[6 * k + i];
    for (int k = 0; k < w->L && inertial; k++) {
        const grs_link *l = grs_links(md) + k;
        const grs_frame *F = w->frame + k;
        double acc_c[3] = {0, 0, 0}, alpha[3], c[3], Iw[9], Iwo[3], Ia[3], gyro[3], f[3], mom[3], cf[3];
        grs_point(w, k, l->com, w->vec);
        for (int i = 0; i < 3; i++) {
            acc_c[i] = w->vec[0].bias[i];
            alpha[i] = F->alpha_b[i];
            c[i] = w->vec[0].value[i];
        }
        for (int j = 0; j < n; j++) {
            if (!on_path(w, w->coord_link[j], k)) continue;
            for (int i = 0; i < 3; i++) {
                acc_c[i] += w->vec[0].J[i * n + j] * w->zdd[j];
                if (!w->coord_slide[j]) alpha[i] += w->frame[w->coord_link[j]].axis[i] * w->zdd[j];
            }
        }
        world_inertia(l, F, Iw);
        rotate(Iw, F->omega, Iwo);
        rotate(Iw, alpha, Ia);
        cross(F->omega, Iwo, gyro);
        for (int i = 0; i < 3; i++) {
            f[i] = l->m * (acc_c[i] - md->gravity[i]);
            mom[i] = Ia[i] + gyro[i];
        }
        cross(c, f, cf);
        for (int i = 0; i < 3; i++) {
            need[6 * k + i] = f[i] - need[6 * k + i];
            need[6 * k + 3 + i] = mom[i] + cf[i] - need[6 * k + 3 + i];
        }
    }
    for (int k = w->L - 1; k >= 0; k--) {
        int p = (int)grs_links(md)[k].parent;
        if (p >= 0)
            for (int i = 0; i < 6; i++) need[6 * p + i] += need[6 * k + i];
    }
    for (int k = 0; k < w->L; k++) {
        const grs_frame *F = w->frame + k;
        double of[3], mo[3];
        cross(F->o, need + 6 * k, of);
        for (int i = 0; i < 3; i++) mo[i] = need[6 * k + 3 + i] - of[i];
        for (int a = 0; a < 3; a++) { /* into the link's axes: R^T */
            out[6 * k + a] = F->R[a] * need[6 * k] + F->R[3 + a] * need[6 * k + 1] + F->R[6 + a] * need[6 * k + 2];
            out[6 * k + 3 + a] = F->R[a] * mo[0] + F->R[3 + a] * mo[1] + F->R[6 + a] * mo[2];
        }
    }
}

grb_status grs_reactions(const grs_model *md, const double *y, const double *tau, double *work, double *closures,
                         double *joints) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    status = grs_accelerations(md, y, y + w.n, tau, &w);
    if (status != GRB_OK) return status;
    double *ext = w.S; /* 6 L doubles (the scratch has 12 L besides the solvers') */
    memset(ext, 0, sizeof(double) * 6 * (size_t)w.L);
    closure_wrenches(md, &w, ext, closures);
    if (joints) joint_reactions(md, &w, 1, ext, joints);
    return GRB_OK;
}

/* An internal load of the closures is a set of multipliers in the null space
 * of J^T: it does no work on any motion, so the motion cannot tell how much of
 * it the loop carries.  The joint reactions it alone puts in the tree are
 * the part of each reaction the motion leaves free. */
grb_status grs_joint_determinacy(const grs_model *md, const double *z, double rcond, double *work,
                                 double *indeterminate, int *rank) {
    grs_ws w;
    grb_status status = grs_ws_init(&w, md, work);
    if (status != GRB_OK) return status;
    if (!(rcond > 0.0 && rcond < 1.0)) return GRB_BAD_ARGUMENT;
    int m = w.m, L = w.L;
    for (int i = 0; i < 6 * L; i++) indeterminate[i] = 0.0;
    *rank = 0;
    if (m == 0) return GRB_OK;
    double top = grs_row_space_at(md, z, &w);
    double *ext = w.S, *load = w.S + 6 * (size_t)L;
    for (int i = 0; i < m; i++) {
        if (w.eigval[i] > rcond * rcond * top) {
            (*rank)++;
            continue;
        }
        for (int r = 0; r < m; r++) w.row[r].lambda = SP_EIGVEC(&w, r, i);
        memset(ext, 0, sizeof(double) * 6 * (size_t)L);
        closure_wrenches(md, &w, ext, NULL);
        joint_reactions(md, &w, 0, ext, load);
        for (int j = 0; j < 6 * L; j++) indeterminate[j] += load[j] * load[j];
    }
    for (int j = 0; j < 6 * L; j++) indeterminate[j] = sqrt(indeterminate[j]);
    return GRB_OK;
}
