/* Kinematics and dynamics of the generalised chain and its closures.
 *
 * One pass along the chain gives, for every moving link, its angle, rate, joint
 * point and the acceleration of that point when all joint accelerations are
 * zero (the bias, or convective, term).  Any point of any link then has a
 * position, a Jacobian with respect to the real joint rates and a bias
 * acceleration, so that its acceleration is J zdd + bias.  The closures are
 * rows built from such points: nothing here is specific to four links.
 *
 * The equations of motion follow by virtual power from those Jacobians,
 *   M(z) = sum_k m_k Jc^T Jc + I_k Jw^T Jw,   h = sum_k m_k Jc^T a_bias,
 *   Q = sum_k m_k Jc^T g + drive, load, -damping * rate,
 * and the closures add J^T lambda: the exact method solves lambda from
 * J zdd = gamma (index-1 DAE; the integrator projects the drift away), the
 * penalty method is the thesis's imaginary joint, lambda = -G phi - C phi_dot. */
#include <stddef.h>

#include "workspace.h"

/* The named rows sit on the tables' columns (a negative array size stops the
 * build where one does not): Python and the FMU write the tables by column. */
typedef char grb_link_columns_check[(offsetof(grb_link, revolute) == GRB_L_REV * sizeof(double) &&
                                     offsetof(grb_link, parent) == GRB_L_PARENT * sizeof(double) &&
                                     sizeof(grb_link) == GRB_L_COLUMNS * sizeof(double)) ? 1 : -1];
typedef char grb_actuator_columns_check[(offsetof(grb_actuator, to_point) == GRB_A_TO_X * sizeof(double) &&
                                         sizeof(grb_actuator) == GRB_A_COLUMNS * sizeof(double)) ? 1 : -1];
typedef char grb_force_columns_check[(offsetof(grb_force, stiffness) == GRB_F_STIFFNESS * sizeof(double) &&
                                      offsetof(grb_force, force) == GRB_F_FX * sizeof(double) &&
                                      sizeof(grb_force) == GRB_F_COLUMNS * sizeof(double)) ? 1 : -1];
typedef char grb_closure_columns_check[(offsetof(grb_closure, to_point) == GRB_CL_TX * sizeof(double) &&
                                        offsetof(grb_closure, damping) == GRB_CL_DAMP * sizeof(double) &&
                                        sizeof(grb_closure) == GRB_CL_COLUMNS * sizeof(double)) ? 1 : -1];

/* 64-bit words per row of a workspace's path table (workspace.h) */
static size_t path_words(int n) { return ((size_t)n + 63) / 64; }

/* Offsets of the tables K, Jc, J, R, T, Q, S, X in the workspace buffer
 * (after its header), and its end: off[0 .. 8]. */
static void ws_offsets(int n, int m, size_t *off) {
    size_t N = (size_t)n, M = (size_t)m;
    off[0] = WORK_HEADER;
    off[1] = off[0] + N * K_COLUMNS;
    off[2] = off[1] + 2 * N * N;
    off[3] = off[2] + (M + 3) * N;
    off[4] = off[3] + M * R_COLUMNS;
    off[5] = off[4] + N * (2 * N + M + 3); /* M, the force, the solver table, zdd */
    off[6] = off[5] + M * (3 * M + 1);
    /* assembly's scratch: U (N x M), V (M x M), a compact Jacobian (M x N),
     * four N-vectors and two M-vectors, and room to spare */
    off[7] = off[6] + 2 * (M + 3) * (N + 3) + 6 * N + 2 * M + 8 + M * M;
    /* X: the paths (a 64-bit word takes no more room than a real), a line's
     * Jacobians, the singular values, the index lists */
    off[8] = off[7] + N * path_words(n) + 5 * N + M + (4 * N + M + 2) + 2 * M;
}

/* Offsets of the dynamics' arrays within T (from off[4]): mass, force, solve, zdd. */
static void dynamics_offsets(int n, int m, const size_t *off, size_t *dyn) {
    size_t N = (size_t)n, M = (size_t)m;
    dyn[0] = off[4];
    dyn[1] = dyn[0] + N * N;
    dyn[2] = dyn[1] + N;
    dyn[3] = dyn[2] + N * (N + M + 1);
}

size_t GRB(work_size)(int n, int n_closures) {
    size_t off[9];
    ws_offsets(n, 2 * n_closures, off);
    return off[8];
}

grb_status GRB(work_init)(int n, int n_closures, real *buffer, size_t length) {
    if (n < 1 || n > GRB_MAX_LINKS || n_closures < 0 || !buffer || length < GRB(work_size)(n, n_closures))
        return GRB_BAD_ARGUMENT;
    buffer[WORK_TAG] = GRB_WORK_TAG;
    buffer[WORK_LINKS] = n;
    buffer[WORK_CLOSURES] = n_closures;
    buffer[WORK_FILLED] = GRB_FILLED_NOTHING;
    for (int a = 0; a < GRB_MAX_ACTUATORS; a++) buffer[WORK_ACTUATOR_FORCE + a] = 0.0;
    return GRB_OK;
}

grb_status GRB(ws_init)(grb_ws *w, const grb_model *md, real *buffer, grb_filled needs) {
    int n = md->n_links, n_closures = md->n_closures, m = 2 * n_closures;
    if (n < 1 || n > GRB_MAX_LINKS || n_closures < 0 || !buffer) return GRB_BAD_ARGUMENT;
    if (md->n_actuators < 0 || md->n_actuators > GRB_MAX_ACTUATORS || (md->n_actuators > 0 && !md->actuators))
        return GRB_BAD_ARGUMENT;
    if (md->n_forces < 0 || (md->n_forces > 0 && !md->forces)) return GRB_BAD_ARGUMENT;
    if (RE(buffer[WORK_TAG]) != GRB_WORK_TAG) {
        /* a buffer no call has used: the caller sized it (grb_work_size) */
        if (needs != GRB_FILLED_NOTHING) return GRB_BAD_ARGUMENT;
        buffer[WORK_TAG] = GRB_WORK_TAG;
        buffer[WORK_LINKS] = n;
        buffer[WORK_CLOSURES] = n_closures;
        for (int a = 0; a < GRB_MAX_ACTUATORS; a++) buffer[WORK_ACTUATOR_FORCE + a] = 0.0;
    } else if (RE(buffer[WORK_LINKS]) != n || RE(buffer[WORK_CLOSURES]) != n_closures ||
               RE(buffer[WORK_FILLED]) < needs)
        return GRB_BAD_ARGUMENT;
    if (needs == GRB_FILLED_NOTHING) buffer[WORK_FILLED] = GRB_FILLED_NOTHING;
    size_t off[9], dyn[4];
    ws_offsets(n, m, off);
    dynamics_offsets(n, m, off, dyn);
    w->header = buffer;
    w->actuator_force = buffer + WORK_ACTUATOR_FORCE;
    w->n = n;
    w->m = m;
    w->sc = n + m + 1;
    w->frame = (grb_frame *)(buffer + off[0]);
    w->Jc = buffer + off[1];
    w->J = buffer + off[2];
    w->row = (grb_row *)(buffer + off[3]);
    w->mass = buffer + dyn[0];
    w->force = buffer + dyn[1];
    w->solve = buffer + dyn[2];
    w->zdd = buffer + dyn[3];
    w->schur = buffer + off[5];
    w->eig_work = w->schur + (size_t)m * m;
    w->eigvec = w->eig_work + (size_t)m * m;
    w->eigval = w->eigvec + (size_t)m * m;
    w->S = buffer + off[6];
    /* X: the path table's words sit in reals' room (a real is at least 8 bytes, and as aligned) */
    size_t words = path_words(n);
    w->words = (int)words;
    w->path = (uint64_t *)(buffer + off[7]);
    w->line_jl = buffer + off[7] + (size_t)n * words;
    w->line_j0 = w->line_jl + n;
    w->line_j1 = w->line_j0 + 2 * (size_t)n;
    w->singular = (double *)(w->line_j1 + 2 * (size_t)n);
    w->index = (int *)(buffer + off[7] + (size_t)n * words + 5 * (size_t)n + (size_t)m);
    w->span = w->index + 4 * (size_t)n + (size_t)m + 2;
    /* which joints move which link is the model's structure, not the state: set here, so that a call that reads
     * a filled workspace (a point's Jacobian, the reactions) sees it as the pass that filled the tables did */
    if (words == 1) /* up to 64 links: one word a link */
        for (int k = 0; k < n; k++) {
            int pk = grb_parent(md, k);
            w->path[k] = (pk < 0 || pk >= k ? 0u : w->path[pk]) | ((uint64_t)1u << k); /* parents come first */
        }
    else
        for (int k = 0; k < n; k++) {
            int pk = grb_parent(md, k);
            uint64_t *row = w->path + (size_t)k * words;
            const uint64_t *from = pk < 0 || pk >= k ? NULL : w->path + (size_t)pk * words;
            for (size_t i = 0; i < words; i++) row[i] = from ? from[i] : 0u;
            row[k >> 6] |= (uint64_t)1u << (k & 63);
        }
    return GRB_OK;
}

/* Recursive pass from ground to tip (MODEL.md section 2) into K.  Each link
 * starts from its predecessor's row (parents come first), so a branching chain
 * costs no more than a serial one. */
void GRB(chain)(const grb_model *md, const real *z, const real *zd, grb_ws *w) {
    int n = md->n_links;
    for (int k = 0; k < n; k++) {
        /* the predecessor's frame; the ground's is its vector at theta1, at rest */
        int pk = grb_parent(md, k);
        real cp, sp, wp, z_sum, w_sum, ox, oy, bx, by;
        if (pk < 0) {
            cp = RCOS(md->theta1);
            sp = RSIN(md->theta1);
            wp = z_sum = w_sum = ox = oy = bx = by = 0.0;
        } else {
            const grb_frame *pred = &w->frame[pk];
            cp = pred->cos_theta;
            sp = pred->sin_theta;
            wp = w_sum = pred->omega;
            z_sum = pred->z_sum;
            ox = pred->o[0];
            oy = pred->o[1];
            bx = pred->o_bias[0];
            by = pred->o_bias[1];
        }
        real slide, rate;
        if (grb_links(md)[k].revolute != 0.0) {
            z_sum += z[k];
            w_sum += zd[k];
            slide = grb_links(md)[k].slide0;
            rate = 0.0;
        } else {
            slide = z[k];
            rate = zd[k];
        }
        real theta = grb_links(md)[k].theta0 + z_sum;
        /* each link hangs off its predecessor's vector end, moved along the slide
         * axis e_perp(predecessor) */
        real ax = -sp, ay = cp;
        real dx = grb_links(md)[k].a_pred * cp + slide * ax;
        real dy = grb_links(md)[k].a_pred * sp + slide * ay;
        ox += dx;
        oy += dy;
        /* d'' at zero joint acceleration: centripetal of the predecessor's turn
         * plus the Coriolis term of a slide on a turning axis */
        bx += -wp * wp * dx - 2.0 * wp * rate * cp;
        by += -wp * wp * dy - 2.0 * wp * rate * sp;
        real c = RCOS(theta), s = RSIN(theta);
        grb_frame *f = &w->frame[k];
        f->theta = theta;
        f->omega = w_sum;
        f->cos_theta = c;
        f->sin_theta = s;
        f->o[0] = ox;
        f->o[1] = oy;
        f->o_bias[0] = bx;
        f->o_bias[1] = by;
        f->axis[0] = ax;
        f->axis[1] = ay;
        f->slide = slide;
        f->rate = rate;
        f->z_sum = z_sum;
    }
}

/* Column j of a point's Jacobian (J, 2 x N): joint j moves the point at
 * (rx, ry) about O_j (a revolute) or along its slide axis. */
static inline void point_column(const grb_model *md, const grb_ws *w, int j, real rx, real ry, real *J) {
    int n = md->n_links;
    if (grb_links(md)[j].revolute != 0.0) {
        J[j] = -(ry - w->frame[j].o[1]);
        J[n + j] = rx - w->frame[j].o[0];
    } else {
        J[j] = w->frame[j].axis[0];
        J[n + j] = w->frame[j].axis[1];
    }
}

/* Position r[0..1] and bias acceleration r[2..3] of the point (lx along, ly
 * across the link vector) of moving link k; its Jacobian (rdot = J zd) into the
 * two rows of J (row stride N).  A revolute at O_j moves the point with
 * k x (r - O_j), a slide along its axis; only the joints on the path from the
 * ground to link k move it (in a serial chain, every joint up to k). */
void GRB(point)(const grb_model *md, const grb_ws *w, int k, real lx, real ly, real *J, real *r) {
    int n = md->n_links;
    real c = w->frame[k].cos_theta, s = w->frame[k].sin_theta;
    real armx = lx * c - ly * s, army = lx * s + ly * c;
    real rx = w->frame[k].o[0] + armx, ry = w->frame[k].o[1] + army;
    for (int j = 0; j < n; j++) {
        J[j] = 0.0;
        J[n + j] = 0.0;
    }
    /* the joints on the path from the ground: one word's bits up to 64 links (the common case, kept as cheap
     * as it was), the path table's row beyond */
    if (w->words == 1) {
        uint64_t bits = w->path[k];
        for (int j = 0; j <= k; j++)
            if ((bits >> j) & 1u) point_column(md, w, j, rx, ry, J);
    } else {
        for (int j = 0; j <= k; j++)
            if (grb_on_path(w, j, k)) point_column(md, w, j, rx, ry, J);
    }
    real w2 = w->frame[k].omega * w->frame[k].omega;
    r[0] = rx;
    r[1] = ry;
    r[2] = w->frame[k].o_bias[0] - w2 * armx;
    r[3] = w->frame[k].o_bias[1] - w2 * army;
}

/* A point fixed to moving link k (-1: the ground, whose points are the
 * world's): position and Jacobian (2 x N, row stride N) from the frames in w. */
static void fixed_point(const grb_model *md, const grb_ws *w, int k, const double *local, real *J, real *r) {
    if (k >= 0) {
        GRB(point)(md, w, k, local[0], local[1], J, r);
        return;
    }
    for (int j = 0; j < 2 * md->n_links; j++) J[j] = 0.0;
    r[0] = local[0];
    r[1] = local[1];
}

/* The line from point p0 of link k0 to point p1 of link k1 at the frames in w:
 * its length L, returned, the unit vector u from the first point to the
 * second, both points (ends[0..1] the first, ends[2..3] the second) and the
 * Jacobian of its length, dL/dz = u^T (J_second - J_first), into jl (N).  A
 * zero length has no direction: u and jl are then zero (assembly refuses such
 * an actuator at the start; a motion through it feels no force along it there). */
static real line_between(const grb_model *md, const grb_ws *w, int k0, const double *p0, int k1, const double *p1,
                         real *u, real *ends, real *jl) {
    int n = md->n_links;
    real *J0 = w->line_j0, *J1 = w->line_j1, r0[4], r1[4];
    fixed_point(md, w, k0, p0, J0, r0);
    fixed_point(md, w, k1, p1, J1, r1);
    real dx = r1[0] - r0[0], dy = r1[1] - r0[1];
    real length = RSQRT(dx * dx + dy * dy);
    ends[0] = r0[0];
    ends[1] = r0[1];
    ends[2] = r1[0];
    ends[3] = r1[1];
    if (RE(length) == 0.0) {
        u[0] = u[1] = 0.0;
        for (int i = 0; i < n; i++) jl[i] = 0.0;
        return length;
    }
    u[0] = dx / length;
    u[1] = dy / length;
    for (int i = 0; i < n; i++) jl[i] = u[0] * (J1[i] - J0[i]) + u[1] * (J1[n + i] - J0[n + i]);
    return length;
}

/* Actuator a's line (line_between its two points). */
static real actuator_line(const grb_model *md, const grb_ws *w, int a, real *u, real *ends, real *jl) {
    const grb_actuator *act = &grb_actuators(md)[a];
    return line_between(md, w, (int)act->from_link, act->from_point, (int)act->to_link, act->to_point, u, ends, jl);
}

/* Link k's real joint coordinate and rate (its relative angle or its slide),
 * from the frames in w: what a joint's force element reads. */
static void joint_motion(const grb_model *md, const grb_ws *w, int k, real *q, real *qd) {
    int pk = grb_parent(md, k);
    if (grb_links(md)[k].revolute != 0.0) {
        *q = w->frame[k].z_sum - (pk < 0 ? 0.0 : w->frame[pk].z_sum);
        *qd = w->frame[k].omega - (pk < 0 ? 0.0 : w->frame[pk].omega);
    } else {
        *q = w->frame[k].slide;
        *qd = w->frame[k].rate;
    }
}

/* Force element e at the frames in w (grubler.h, GRB_FORCE_*): its outputs
 * (GRB_FO_*) into val, its generalised force added to gen (N) unless gen is
 * NULL, and where it acts: a spring's two ends (ends[0..3]) and the unit
 * vector u from the first to the second; a load's point (ends[0..1]). */
static void force_element(const grb_model *md, const grb_ws *w, int e, real *val, real *gen, real *ends, real *u) {
    const grb_force *fe = &grb_forces(md)[e];
    int n = md->n_links;
    for (int o = 0; o < GRB_FO_COUNT; o++) val[o] = 0.0;
    if (fe->kind == GRB_FORCE_SPRING) {
        real *jl = w->line_jl, rate = 0.0;
        real length = line_between(md, w, (int)fe->link, fe->point, (int)fe->to_link, fe->to_point, u, ends, jl);
        for (int i = 0; i < n; i++) {
            real q, qd;
            joint_motion(md, w, i, &q, &qd);
            rate += jl[i] * qd;
        }
        real d = length - fe->free;
        real force = fe->preload - fe->stiffness * d - fe->damping * rate;
        real energy = 0.5 * fe->stiffness * d * d - fe->preload * d;
        if (fe->gas_force != 0.0) {
            /* p V^n = p0 V0^n over the gas column h = V / A; none left: no finite force */
            real h = fe->gas_column + d;
            if (RE(h) > 0.0) {
                real ratio = fe->gas_column / h;
                force += fe->gas_force * RPOW(ratio, fe->gas_exponent);
                if (fe->gas_exponent == 1.0)
                    energy += fe->gas_force * fe->gas_column * RLOG(ratio);
                else
                    energy += fe->gas_force * fe->gas_column / (fe->gas_exponent - 1.0) *
                              (RPOW(ratio, fe->gas_exponent - 1.0) - 1.0);
            } else {
                force = energy = NAN;
            }
        }
        val[GRB_FO_LENGTH] = length;
        val[GRB_FO_RATE] = rate;
        val[GRB_FO_FORCE] = force;
        val[GRB_FO_ENERGY] = energy;
        val[GRB_FO_POWER] = force * rate;
        val[GRB_FO_DISSIPATION] = fe->damping * rate * rate;
        if (gen)
            for (int i = 0; i < n; i++) gen[i] += jl[i] * force;
    } else if (fe->kind == GRB_FORCE_JOINT) {
        int k = (int)fe->link;
        real q, qd, friction = 0.0;
        joint_motion(md, w, k, &q, &qd);
        if (fe->friction != 0.0) friction = fe->friction * RTANH(qd / fe->friction_speed);
        real d = q - fe->free;
        real effort = fe->preload - fe->stiffness * d - friction;
        val[GRB_FO_LENGTH] = q;
        val[GRB_FO_RATE] = qd;
        val[GRB_FO_FORCE] = effort;
        val[GRB_FO_ENERGY] = 0.5 * fe->stiffness * d * d - fe->preload * d;
        val[GRB_FO_POWER] = effort * qd;
        val[GRB_FO_DISSIPATION] = friction * qd;
        if (gen) gen[k] += effort;
    } else if (fe->kind == GRB_FORCE_LOAD) {
        int k = (int)fe->link;
        real *J = w->line_j0, r[4], vx = 0.0, vy = 0.0;
        GRB(point)(md, w, k, fe->point[0], fe->point[1], J, r);
        for (int i = 0; i < n; i++) {
            real q, qd;
            joint_motion(md, w, i, &q, &qd);
            vx += J[i] * qd;
            vy += J[n + i] * qd;
        }
        ends[0] = r[0];
        ends[1] = r[1];
        val[GRB_FO_POWER] = fe->force[0] * vx + fe->force[1] * vy + fe->moment * w->frame[k].omega;
        if (gen)
            for (int i = 0; i < n; i++) {
                /* a moment does work through the revolutes on the link's path */
                real jw = grb_on_path(w, i, k) ? grb_links(md)[i].revolute : 0.0;
                gen[i] += J[i] * fe->force[0] + J[n + i] * fe->force[1] + jw * fe->moment;
            }
    }
}

/* Constraint rows of every closure (MODEL.md section 3), any pair of links:
 * J[:M] (phi_dot = J zd; rows M, M+1 scratch) and the row table R. */
void GRB(closure_rows)(const grb_model *md, const real *zd, grb_ws *w) {
    int n = md->n_links;
    real *tmp = w->J + w->m * n;
    for (int j = 0; j < md->n_closures; j++) {
        int r = 2 * j;
        int ka = (int)grb_closures(md)[j].link;
        int kb = (int)grb_closures(md)[j].to; /* -1: the ground, whose frame is the world's */
        real *Jr = w->J + r * n;
        real pa[4], pb[4], thb, wb;
        GRB(point)(md, w, ka, grb_closures(md)[j].point[0], grb_closures(md)[j].point[1], Jr, pa);
        if (kb >= 0) {
            GRB(point)(md, w, kb, grb_closures(md)[j].to_point[0], grb_closures(md)[j].to_point[1], tmp, pb);
            for (int i = 0; i < n; i++) {
                Jr[i] -= tmp[i];
                Jr[n + i] -= tmp[n + i];
            }
            thb = w->frame[kb].theta;
            wb = w->frame[kb].omega;
        } else {
            pb[0] = grb_closures(md)[j].to_point[0];
            pb[1] = grb_closures(md)[j].to_point[1];
            pb[2] = pb[3] = 0.0;
            thb = wb = 0.0;
        }
        w->row[r].point = pa[0];
        w->row[r + 1].point = pa[1];
        if (grb_closures(md)[j].kind == 0.0) {
            w->row[r].phi = pa[0] - pb[0];
            w->row[r + 1].phi = pa[1] - pb[1];
            w->row[r].gamma = -(pa[2] - pb[2]);
            w->row[r + 1].gamma = -(pa[3] - pb[3]);
            w->row[r].normal = 0.0;
            w->row[r + 1].normal = 0.0;
            continue;
        }
        /* the line of to_link through to_point at its angle; the link held at psi */
        real beta = thb + grb_closures(md)[j].angle;
        real alx = RCOS(beta), aly = RSIN(beta), nx = -aly, ny = alx;
        real dx = pa[0] - pb[0], dy = pa[1] - pb[1], ddx = 0.0, ddy = 0.0;
        for (int i = 0; i < n; i++) {
            ddx += Jr[i] * zd[i];
            ddy += Jr[n + i] * zd[i];
        }
        real d_normal = dx * nx + dy * ny, d_along = dx * alx + dy * aly;
        w->row[r].phi = d_normal;
        w->row[r].gamma = -(nx * (pa[2] - pb[2]) + ny * (pa[3] - pb[3]) - 2.0 * wb * (ddx * alx + ddy * aly) -
                             d_normal * wb * wb);
        w->row[r + 1].phi = w->frame[ka].theta - thb - grb_closures(md)[j].psi;
        w->row[r + 1].gamma = 0.0;
        for (int i = 0; i < n; i++) {
            /* a link's angle turns with the revolutes on its path from the ground */
            real jwa = ka >= 0 && grb_on_path(w, i, ka) ? grb_links(md)[i].revolute : 0.0;
            real jwb = kb >= 0 && grb_on_path(w, i, kb) ? grb_links(md)[i].revolute : 0.0;
            real jx = Jr[i], jy = Jr[n + i];
            /* d(normal)/d(theta_b) = -along */
            Jr[i] = nx * jx + ny * jy - d_along * jwb;
            Jr[n + i] = jwa - jwb;
        }
        w->row[r].normal = nx;
        w->row[r + 1].normal = ny;
    }
}

void GRB(row_spans)(const grb_ws *w, int rows, int *span) {
    int n = w->n;
    for (int r = 0; r < rows; r++) {
        int first = 0, last = n - 1;
        while (first < n && J_(w, r, first) == 0.0) first++;
        while (last >= first && J_(w, r, last) == 0.0) last--;
        span[2 * r] = first;
        span[2 * r + 1] = last;
    }
}

/* Mass centres, their Jacobians and bias accelerations. */
static void mass_centres(const grb_model *md, grb_ws *w) {
    for (int k = 0; k < md->n_links; k++) {
        real c[4];
        GRB(point)(md, w, k, grb_links(md)[k].p, grb_links(md)[k].q, w->Jc + 2 * k * w->n, c);
        w->frame[k].com[0] = c[0];
        w->frame[k].com[1] = c[1];
        w->frame[k].com_bias[0] = c[2];
        w->frame[k].com_bias[1] = c[3];
    }
}

/* M = sum_k m_k Jc^T Jc + I_k Jw^T Jw (+ the drive's reflected inertia).
 * Link k adds to the entries (i, j) of the joints on its path from the ground
 * (the others' Jacobian columns are zero), i <= j; each entry gets one term per
 * link, in link order, whatever order the path is walked in. */
static void mass_matrix(const grb_model *md, grb_ws *w) {
    int n = md->n_links;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) MASS_(w, i, j) = 0.0;
    for (int k = 0; k < n; k++) {
        real mk = grb_links(md)[k].m, ik = grb_links(md)[k].inertia;
        const uint64_t *path = grb_path_row(w, k);
        for (int i = 0; i <= k; i++) {
            if (!((path[i >> 6] >> (i & 63)) & 1u)) continue;
            real wi = ik * grb_links(md)[i].revolute;
            for (int j = i; j <= k; j++) {
                if (!((path[j >> 6] >> (j & 63)) & 1u)) continue;
                MASS_(w, i, j) += mk * (JC_(w, k, 0, i) * JC_(w, k, 0, j) + JC_(w, k, 1, i) * JC_(w, k, 1, j)) +
                               wi * grb_links(md)[j].revolute;
            }
        }
    }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < i; j++) MASS_(w, i, j) = MASS_(w, j, i);
    if (md->drive >= 0) MASS_(w, md->drive, md->drive) += md->drive_inertia;
}

/* Applied minus velocity-product force, Q - h. */
static void generalised_force(const grb_model *md, const real *zd, real tau_drive, real tau_load, grb_ws *w) {
    int n = md->n_links;
    real *f = w->force;
    for (int i = 0; i < n; i++) f[i] = -grb_links(md)[i].damping * zd[i];
    for (int k = 0; k < n; k++) {
        real mk = grb_links(md)[k].m;
        /* gravity along -y, and the bias (Coriolis, centripetal) acceleration */
        real fx = -mk * w->frame[k].com_bias[0], fy = -mk * (md->gravity + w->frame[k].com_bias[1]);
        if (w->words == 1) { /* as in grb_point */
            uint64_t bits = w->path[k];
            for (int i = 0; i <= k; i++)
                if ((bits >> i) & 1u) f[i] += JC_(w, k, 0, i) * fx + JC_(w, k, 1, i) * fy;
        } else {
            for (int i = 0; i <= k; i++)
                if (grb_on_path(w, i, k)) f[i] += JC_(w, k, 0, i) * fx + JC_(w, k, 1, i) * fy;
        }
    }
    if (md->drive >= 0) f[md->drive] += tau_drive;
    if (md->load >= 0) f[md->load] += tau_load;
    /* each actuator's force F along its line: virtual work F dL = F J_L dz */
    for (int a = 0; a < md->n_actuators; a++) {
        real u[2], ends[4], *jl = w->line_jl;
        real force = w->actuator_force[a];
        actuator_line(md, w, a, u, ends, jl);
        for (int i = 0; i < n; i++) f[i] += jl[i] * force;
    }
    /* and each force element's, by the same virtual work */
    for (int e = 0; e < md->n_forces; e++) {
        real val[GRB_FO_COUNT], ends[4], u[2];
        force_element(md, w, e, val, f, ends, u);
    }
}

/* Relative eigenvalue below which a closure direction counts as lost.  At a
 * change point the closure rows become dependent and their multiplier is
 * undetermined; dropping that direction keeps the motion defined through it,
 * and the projection removes the small drift it leaves. */
#define SINGULAR_RCOND 1e-10
/* Smallest Cholesky pivot, relative to the largest diagonal entry, for which
 * the multipliers of many closure rows are solved by the factor rather than by
 * the eigenvectors (a pivot bounds the smallest eigenvalue from above: the
 * margin over SINGULAR_RCOND keeps the factor away from a lost direction) */
#define CHOLESKY_RCOND 1e-6

/* Solve S lam = b (S = Q[:, :M] symmetric, >= 0) dropping lost directions. */
static void closure_multipliers(grb_ws *w) {
    int m = w->m;
    if (m == 2) {
        /* one closure in closed form; det / trace^2 is, to first order, the
         * eigenvalue ratio the cut-off below tests */
        real det = SCHUR_(w, 0, 0) * SCHUR_(w, 1, 1) - SCHUR_(w, 0, 1) * SCHUR_(w, 1, 0),
             tr = SCHUR_(w, 0, 0) + SCHUR_(w, 1, 1);
        if (RE(det) > SINGULAR_RCOND * RE(tr * tr)) {
            w->row[0].lambda = (SCHUR_(w, 1, 1) * w->row[0].b - SCHUR_(w, 0, 1) * w->row[1].b) / det;
            w->row[1].lambda = (SCHUR_(w, 0, 0) * w->row[1].b - SCHUR_(w, 1, 0) * w->row[0].b) / det;
            return;
        }
    }
    if (m > GRB_JACOBI_ROWS) {
        /* many rows: a Cholesky factor while S is well conditioned (no
         * direction near lost: the change-point chart takes over before) */
        for (int i = 0; i < m * m; i++) w->eig_work[i] = w->schur[i];
        if (GRB(cholesky)(w->eig_work, m, m, CHOLESKY_RCOND)) {
            for (int r = 0; r < m; r++) w->row[r].lambda = w->row[r].b;
            GRB(cholesky_solve)(w->eig_work, m, m, &w->row[0].lambda, R_COLUMNS);
            return;
        }
    }
    GRB(sym_eig)(w->schur, w->eig_work, w->eigvec, w->eigval, m);
    double w_max = -INFINITY;
    for (int i = 0; i < m; i++)
        if (RE(w->eigval[i]) > w_max) w_max = RE(w->eigval[i]);
    for (int r = 0; r < m; r++) w->row[r].lambda = 0.0;
    for (int i = 0; i < m; i++) {
        if (!(RE(w->eigval[i]) > SINGULAR_RCOND * w_max)) continue;
        real coef = 0.0;
        for (int r = 0; r < m; r++) coef += EIGVEC_(w, r, i) * w->row[r].b;
        coef /= w->eigval[i];
        for (int r = 0; r < m; r++) w->row[r].lambda += EIGVEC_(w, r, i) * coef;
    }
}

/* The chain's equations of motion without its closures, M zdd = Q - h: the
 * mass matrix and the force (for the closures' solve below, and for the
 * motion along an assembly branch near a change point, chart.c). */
void GRB(mass_and_force)(const grb_model *md, const real *z, const real *zd, real tau_drive, real tau_load,
                         grb_ws *w) {
    GRB(chain)(md, z, zd, w);
    mass_centres(md, w);
    mass_matrix(md, w);
    generalised_force(md, zd, tau_drive, tau_load, w);
}

/* After the solve: the multipliers, and the accelerations they give. */
static grb_status closure_accelerations(grb_status status, grb_ws *w) {
    int n = w->n, m = w->m, f = n;
    if (status == GRB_OK) closure_multipliers(w);
    for (int i = 0; i < n; i++) {
        real s = SOLVE_(w, i, f);
        for (int c = 0; c < m; c++) s += SOLVE_(w, i, f + 1 + c) * w->row[c].lambda;
        w->zdd[i] = status == GRB_OK ? s : NAN;
    }
    grb_ws_filled(w, GRB_FILLED_DYNAMICS);
    return status;
}

/* The closures' part of the solve for many rows (more than GRB_JACOBI_ROWS),
 * each row over its span of columns that are not zero (row_spans): a loop of
 * a chain of many loops reaches a few joints, and the products skip only
 * exact zeros.  The mass matrix and the force are in the solver's table. */
static grb_status wide_closure_products(const grb_model *md, real a, grb_ws *w) {
    int n = md->n_links, m = w->m, f = n, *span = w->span;
    GRB(row_spans)(w, m, span);
    for (int r = 0; r < m; r++) {
        int lo = span[2 * r], hi = span[2 * r + 1];
        for (int i = 0; i < n; i++) SOLVE_(w, i, f + 1 + r) = J_(w, r, i);
        for (int i = lo; i <= hi; i++) {
            SOLVE_(w, i, f) += a * J_(w, r, i) * w->row[r].gamma;
            for (int j = lo; j <= hi; j++) SOLVE_(w, i, j) += a * J_(w, r, i) * J_(w, r, j);
        }
    }
    grb_status status = GRB(lu_solve_banded)(w->solve, w->sc, n, 0, f, m + 1);
    for (int r = 0; r < m; r++) {
        int lo = span[2 * r], hi = span[2 * r + 1];
        real s = w->row[r].gamma;
        for (int i = lo; i <= hi; i++) s -= J_(w, r, i) * SOLVE_(w, i, f);
        w->row[r].b = s;
        for (int c = 0; c < m; c++) {
            real q = 0.0;
            for (int i = lo; i <= hi; i++) q += J_(w, r, i) * SOLVE_(w, i, f + 1 + c);
            SCHUR_(w, r, c) = q;
        }
    }
    return closure_accelerations(status, w);
}

/* Joint accelerations (zdd) and closure multipliers (lambda) at one state.
 * GRB_SINGULAR (and nan accelerations) when the matrix to solve is singular.
 * The solver's table holds the matrix in its first N columns, then the
 * right-hand sides: the force (column N, the solution's particular part when
 * solved), then J^T (columns N + 1 .., the closures' directions). */
grb_status GRB(accelerations)(const grb_model *md, int method, const real *z, const real *zd, real tau_drive,
                      real tau_load, grb_ws *w) {
    int n = md->n_links, m = w->m, f = n; /* f: the force's column */
    GRB(mass_and_force)(md, z, zd, tau_drive, tau_load, w);
    GRB(closure_rows)(md, zd, w);
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < n; j++) SOLVE_(w, i, j) = MASS_(w, i, j);
        SOLVE_(w, i, f) = w->force[i];
    }
    if (m > 0 && method == GRB_PENALTY) {
        /* the thesis's imaginary joint: spring G and damper C on each violation */
        for (int r = 0; r < m; r++) {
            real phidot = 0.0;
            for (int i = 0; i < n; i++) phidot += J_(w, r, i) * zd[i];
            real lam = -grb_closures(md)[r / 2].gain * w->row[r].phi - grb_closures(md)[r / 2].damping * phidot;
            w->row[r].lambda = lam;
            for (int i = 0; i < n; i++) SOLVE_(w, i, f) += J_(w, r, i) * lam;
        }
    }
    if (m == 0 || method == GRB_PENALTY) {
        grb_status status = GRB(lu_solve)(w->solve, w->sc, n, 0, f, 1);
        for (int i = 0; i < n; i++) w->zdd[i] = status == GRB_OK ? SOLVE_(w, i, f) : NAN;
        grb_ws_filled(w, GRB_FILLED_DYNAMICS);
        return status;
    }
    /* M may be singular where a real coordinate carries no inertia of its own (a
     * point-mass slider's rotation); M + a J^T J is not, and since J zdd = gamma
     * the added term changes nothing in the solution (augmented Lagrangian). */
    real trace = 0.0, jj = 0.0;
    for (int i = 0; i < n; i++) trace += MASS_(w, i, i);
    for (int r = 0; r < m; r++)
        for (int i = 0; i < n; i++) jj += J_(w, r, i) * J_(w, r, i);
    real a = trace / (RE(jj) > 1e-300 ? jj : 1e-300);
    /* every row over all its columns up to GRB_JACOBI_ROWS rows (the presets' sums, term for term); beyond, each
     * row over its span only (the terms left out are exact zeros: wide_closure_products) */
    if (m > GRB_JACOBI_ROWS) return wide_closure_products(md, a, w);
    for (int r = 0; r < m; r++)
        for (int i = 0; i < n; i++) {
            SOLVE_(w, i, f) += a * J_(w, r, i) * w->row[r].gamma;
            SOLVE_(w, i, f + 1 + r) = J_(w, r, i);
            for (int j = 0; j < n; j++) SOLVE_(w, i, j) += a * J_(w, r, i) * J_(w, r, j);
        }
    grb_status status = GRB(lu_solve)(w->solve, w->sc, n, 0, f, m + 1);
    /* the Schur complement J (M + a J^T J)^-1 J^T and what the closure still lacks */
    for (int r = 0; r < m; r++) {
        real s = w->row[r].gamma;
        for (int i = 0; i < n; i++) s -= J_(w, r, i) * SOLVE_(w, i, f);
        w->row[r].b = s;
        for (int c = 0; c < m; c++) {
            real q = 0.0;
            for (int i = 0; i < n; i++) q += J_(w, r, i) * SOLVE_(w, i, f + 1 + c);
            SCHUR_(w, r, c) = q;
        }
    }
    return closure_accelerations(status, w);
}

grb_status GRB(rhs)(const grb_model *md, int method, const real *y, real tau_drive, real tau_load, real *work,
            real *out) {
    grb_ws w;
    int n = md->n_links;
    grb_status status = GRB(ws_init)(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    status = GRB(accelerations)(md, method, y, y + n, tau_drive, tau_load, &w);
    for (int i = 0; i < n; i++) {
        out[i] = y[n + i];
        out[n + i] = w.zdd[i];
    }
    return status;
}

/* Force and moment each link's predecessor exerts on it, after
 * grb_accelerations: Newton-Euler from the tips back to the ground.  out[3k ..
 * 3k+2] is (Fx, Fy, Mz) for the joint pair of link k+2, at its point O_{k+2}.
 * Children come after their parent, so a link's children are done when it is;
 * it carries what they exert (in a serial chain, its one successor's). */
void GRB(reactions)(const grb_model *md, grb_ws *w, real *out) {
    int n = md->n_links;
    const real *zdd = w->zdd;
    for (int i = 0; i < 3 * n; i++) out[i] = 0.0;
    /* first the closures' forces on the links they join, about each link's origin */
    for (int j = 0; j < md->n_closures; j++) {
        int r = 2 * j;
        real fx, fy, mz;
        if (grb_closures(md)[j].kind != 0.0) {
            fx = w->row[r].normal * w->row[r].lambda;
            fy = w->row[r + 1].normal * w->row[r].lambda;
            mz = w->row[r + 1].lambda;
        } else {
            fx = w->row[r].lambda;
            fy = w->row[r + 1].lambda;
            mz = 0.0;
        }
        real px = w->row[r].point, py = w->row[r + 1].point;
        for (int side = 0; side < 2; side++) {
            int k = (int)(side == 0 ? grb_closures(md)[j].link : grb_closures(md)[j].to);
            if (k < 0) continue; /* the ground */
            real sign = side == 0 ? 1.0 : -1.0;
            out[3 * k] += sign * fx;
            out[3 * k + 1] += sign * fy;
            out[3 * k + 2] += sign * (mz + (px - w->frame[k].o[0]) * fy - (py - w->frame[k].o[1]) * fx);
        }
    }
    /* then the actuators' forces on the links they join: +F u on the second
     * point's link, -F u on the first's (the ground takes its own) */
    for (int a = 0; a < md->n_actuators; a++) {
        real u[2], ends[4], *jl = w->line_jl;
        real force = w->actuator_force[a];
        actuator_line(md, w, a, u, ends, jl);
        for (int end = 0; end < 2; end++) {
            int k = (int)(end == 0 ? grb_actuators(md)[a].from_link : grb_actuators(md)[a].to_link);
            if (k < 0) continue;
            real sign = end == 0 ? -1.0 : 1.0, fx = sign * force * u[0], fy = sign * force * u[1];
            real px = ends[2 * end], py = ends[2 * end + 1];
            out[3 * k] += fx;
            out[3 * k + 1] += fy;
            out[3 * k + 2] += (px - w->frame[k].o[0]) * fy - (py - w->frame[k].o[1]) * fx;
        }
    }
    /* and the force elements' on the links they act on: a spring as an
     * actuator; a load on its link (a joint's effort is the pair's own, which
     * the reaction of its joint carries) */
    for (int e = 0; e < md->n_forces; e++) {
        const grb_force *fe = &grb_forces(md)[e];
        real val[GRB_FO_COUNT], ends[4], u[2];
        if (fe->kind == GRB_FORCE_JOINT) continue;
        force_element(md, w, e, val, NULL, ends, u);
        for (int end = 0; end < 2; end++) {
            int k = (int)(end == 0 ? fe->link : fe->to_link);
            real fx, fy, mz = 0.0;
            if (fe->kind == GRB_FORCE_LOAD) {
                if (end == 1) break;
                fx = fe->force[0];
                fy = fe->force[1];
                mz = fe->moment;
            } else {
                real sign = end == 0 ? -1.0 : 1.0;
                fx = sign * val[GRB_FO_FORCE] * u[0];
                fy = sign * val[GRB_FO_FORCE] * u[1];
            }
            if (k < 0) continue;
            real px = ends[2 * end], py = ends[2 * end + 1];
            out[3 * k] += fx;
            out[3 * k + 1] += fy;
            out[3 * k + 2] += mz + (px - w->frame[k].o[0]) * fy - (py - w->frame[k].o[1]) * fx;
        }
    }
    for (int k = n - 1; k >= 0; k--) {
        real ax = w->frame[k].com_bias[0], ay = w->frame[k].com_bias[1], alpha = 0.0;
        for (int i = 0; i <= k; i++) { /* Jc's columns off k's path are zero */
            ax += JC_(w, k, 0, i) * zdd[i];
            ay += JC_(w, k, 1, i) * zdd[i];
            if (grb_on_path(w, i, k)) alpha += grb_links(md)[i].revolute * zdd[i];
        }
        /* what the children's joints carry: their force, and its moment about O_k */
        real fnx = 0.0, fny = 0.0, nn = 0.0, nf = 0.0;
        for (int c = k + 1; c < n; c++) {
            if (grb_parent(md, c) != k) continue;
            real nx = w->frame[c].o[0] - w->frame[k].o[0], ny = w->frame[c].o[1] - w->frame[k].o[1];
            fnx += out[3 * c];
            fny += out[3 * c + 1];
            nn += out[3 * c + 2];
            nf += nx * out[3 * c + 1] - ny * out[3 * c];
        }
        real ix = grb_links(md)[k].m * ax, iy = grb_links(md)[k].m * (ay + md->gravity); /* m (a - g) */
        real fx = ix - out[3 * k] + fnx, fy = iy - out[3 * k + 1] + fny;
        real cx = w->frame[k].com[0] - w->frame[k].o[0], cy = w->frame[k].com[1] - w->frame[k].o[1];
        real mz = grb_links(md)[k].inertia * alpha + (cx * iy - cy * ix) + nn + nf - out[3 * k + 2];
        out[3 * k] = fx;
        out[3 * k + 1] = fy;
        out[3 * k + 2] = mz;
    }
}

grb_status GRB(observe)(const grb_model *md, int method, const real *y, real tau_drive, real tau_load,
                int want_reactions, real *work, real *out) {
    grb_ws ws, *w = &ws;
    int n = md->n_links, m = 2 * md->n_closures;
    grb_status status = GRB(ws_init)(w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    const real *zd = y + n;
    status = GRB(accelerations)(md, method, y, zd, tau_drive, tau_load, w);
    for (int k = 0; k < n; k++) {
        int revolute = grb_links(md)[k].revolute != 0.0, pk = grb_parent(md, k);
        /* a link's angular acceleration: its predecessor's plus its own revolute's */
        real acc = pk >= 0 ? out[4 * n + 2 * pk + 1] : 0.0;
        out[2 * k] = w->frame[k].slide;
        out[2 * k + 1] = w->frame[k].theta;
        out[2 * n + 2 * k] = w->frame[k].rate;
        out[2 * n + 2 * k + 1] = w->frame[k].omega;
        if (revolute) acc += w->zdd[k];
        out[4 * n + 2 * k] = revolute ? 0.0 : w->zdd[k];
        out[4 * n + 2 * k + 1] = acc;
    }
    int o = 6 * n;
    real tip[4];
    GRB(point)(md, w, n - 1, grb_links(md)[n - 1].a, 0.0, w->J + m * n, tip);
    out[o + GRB_OBS_TIP_X] = tip[0];
    out[o + GRB_OBS_TIP_Y] = tip[1];
    real err = 0.0;
    for (int r = 0; r < m; r++) err += w->row[r].phi * w->row[r].phi;
    out[o + GRB_OBS_CLOSURE_ERROR] = RSQRT(err);
    real fx = 0.0, fy = 0.0, mz = 0.0;
    if (m > 0) {
        if (grb_closures(md)[0].kind != 0.0) {
            fx = w->row[0].normal * w->row[0].lambda;
            fy = w->row[1].normal * w->row[0].lambda;
            mz = w->row[1].lambda;
        } else {
            fx = w->row[0].lambda;
            fy = w->row[1].lambda;
        }
    }
    out[o + GRB_OBS_FX] = fx;
    out[o + GRB_OBS_FY] = fy;
    out[o + GRB_OBS_MZ] = mz;
    real ke = 0.0, pe = 0.0;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) ke += zd[i] * MASS_(w, i, j) * zd[j];
    for (int k = 0; k < n; k++) pe += grb_links(md)[k].m * w->frame[k].com[1];
    pe *= md->gravity;
    for (int e = 0; e < md->n_forces; e++) { /* the springs' stored energy */
        real val[GRB_FO_COUNT], ends[4], u[2];
        force_element(md, w, e, val, NULL, ends, u);
        pe += val[GRB_FO_ENERGY];
    }
    if (method == GRB_PENALTY) /* the penalty springs store energy too */
        for (int r = 0; r < m; r++) pe += 0.5 * grb_closures(md)[r / 2].gain * w->row[r].phi * w->row[r].phi;
    out[o + GRB_OBS_KE] = 0.5 * ke;
    out[o + GRB_OBS_PE] = pe;
    out[o + GRB_OBS_E] = 0.5 * ke + pe;
    out[o + GRB_OBS_TAU_DRIVE] = md->drive >= 0 ? tau_drive : 0.0;
    out[o + GRB_OBS_P_DRIVE] = md->drive >= 0 ? tau_drive * zd[md->drive] : 0.0;
    if (want_reactions) GRB(reactions)(md, w, out + o + GRB_OBS_FIXED);
    return status;
}

grb_status GRB(observe_rows)(const grb_model *md, int method, int rows, const real *y, const real *tau_drive,
                     real tau_drive_const, real tau_load, int want_reactions, real *work, real *out) {
    int n = md->n_links;
    grb_status status = GRB_OK;
    for (int i = 0; i < rows; i++) {
        real tau = tau_drive ? tau_drive[i] : tau_drive_const;
        grb_status s = GRB(observe)(md, method, y + (size_t)i * 2 * n, tau, tau_load, want_reactions, work,
                            out + (size_t)i * GRB_N_OBSERVED(n));
        if (s != GRB_OK && status == GRB_OK) status = s;
    }
    return status;
}

void GRB(work_layout)(int n, int n_closures, long *layout) {
    size_t off[9], dyn[4];
    int m = 2 * n_closures;
    ws_offsets(n, m, off);
    dynamics_offsets(n, m, off, dyn);
    for (int i = 0; i < 7; i++) layout[i] = (long)off[i];
    layout[7] = K_COLUMNS;
    layout[8] = R_COLUMNS;
    layout[9] = n;
    layout[10] = m;
    layout[11] = (long)dyn[3];
}

grb_status GRB(evaluate)(const grb_model *md, int method, const real *y, real tau_drive, real tau_load, real *work) {
    grb_ws w;
    grb_status status = GRB(ws_init)(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    return GRB(accelerations)(md, method, y, y + md->n_links, tau_drive, tau_load, &w);
}

grb_status GRB(set_actuator_forces)(const grb_model *md, real *work, const real *force) {
    grb_ws w;
    grb_status status = GRB(ws_init)(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    if (md->n_actuators > 0 && !force) return GRB_BAD_ARGUMENT;
    for (int a = 0; a < md->n_actuators; a++) w.actuator_force[a] = force[a];
    return GRB_OK;
}

#ifndef GRB_COMPLEX_STEP
/* A batch call's loop over states: for each of `rows` states y_i = (z, zd)
 * (2N each, in y), the kinematic pass at y_i and then fill's `width` values
 * for it into out + i width. */
static grb_status each_state(const grb_model *md, int rows, const double *y, double *work, double *out, int width,
                             void (*fill)(const grb_model *, grb_ws *, const double *, double *)) {
    grb_ws w;
    int n = md->n_links;
    grb_status status = grb_ws_init(&w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    if (rows < 0) return GRB_BAD_ARGUMENT;
    for (int i = 0; i < rows; i++) {
        const double *yi = y + (size_t)i * 2 * n;
        grb_chain(md, yi, yi + n, &w);
        fill(md, &w, yi, out + (size_t)i * width);
    }
    return GRB_OK;
}

/* Each actuator's length and rate (2 values) at the state y of the last pass. */
static void actuator_lines_at(const grb_model *md, grb_ws *w, const double *y, double *out) {
    int n = md->n_links;
    for (int a = 0; a < md->n_actuators; a++) {
        double u[2], ends[4], *jl = w->line_jl, rate = 0.0;
        double *o = out + (size_t)a * 2;
        o[0] = actuator_line(md, w, a, u, ends, jl);
        for (int j = 0; j < n; j++) rate += jl[j] * y[n + j];
        o[1] = rate;
    }
}

grb_status grb_actuator_lines(const grb_model *md, int rows, const double *y, double *work, double *out) {
    return each_state(md, rows, y, work, out, 2 * md->n_actuators, actuator_lines_at);
}

/* Each force element's GRB_FO_COUNT outputs at the last pass. */
static void force_rows_at(const grb_model *md, grb_ws *w, const double *y, double *out) {
    (void)y; /* the pass holds all a force element reads */
    for (int e = 0; e < md->n_forces; e++) {
        double ends[4], u[2];
        force_element(md, w, e, out + (size_t)e * GRB_FO_COUNT, NULL, ends, u);
    }
}

grb_status grb_force_rows(const grb_model *md, int rows, const double *y, double *work, double *out) {
    return each_state(md, rows, y, work, out, md->n_forces * GRB_FO_COUNT, force_rows_at);
}
#endif

grb_status GRB(point_on_link)(const grb_model *md, real *work, int k, real lx, real ly, real *J, real *r) {
    grb_ws w;
    if (k < 0 || k >= md->n_links) return GRB_BAD_ARGUMENT;
    grb_status status = GRB(ws_init)(&w, md, work, GRB_FILLED_KINEMATICS);
    if (status != GRB_OK) return status;
    GRB(point)(md, &w, k, lx, ly, J, r);
    return GRB_OK;
}

grb_status GRB(joint_reactions)(const grb_model *md, real *work, real *out) {
    grb_ws w;
    grb_status status = GRB(ws_init)(&w, md, work, GRB_FILLED_DYNAMICS);
    if (status != GRB_OK) return status;
    GRB(reactions)(md, &w, out);
    return GRB_OK;
}

grb_status GRB(inverse_residual)(const grb_model *md, const real *y, const real *zdd, real tau_load, real *work,
                         real *out) {
    grb_ws ws, *w = &ws;
    int n = md->n_links;
    grb_status status = GRB(ws_init)(w, md, work, GRB_FILLED_NOTHING);
    if (status != GRB_OK) return status;
    GRB(chain)(md, y, y + n, w);
    mass_centres(md, w);
    GRB(closure_rows)(md, y + n, w);
    grb_ws_filled(w, GRB_FILLED_KINEMATICS);
    mass_matrix(md, w);
    generalised_force(md, y + n, 0.0, tau_load, w);
    for (int i = 0; i < n; i++) {
        real s = -w->force[i];
        for (int j = 0; j < n; j++) s += MASS_(w, i, j) * zdd[j];
        out[i] = s;
    }
    return GRB_OK;
}

#ifdef GRB_COMPLEX_STEP
/* Entry points with the efforts passed by address: a complex number passed by
 * value is not something every foreign-function interface can do. */
grb_status grb_cs_rhs_at(const grb_model *md, int method, const real *y, const real *efforts, real *work, real *out) {
    return GRB(rhs)(md, method, y, efforts[0], efforts[1], work, out);
}

grb_status grb_cs_observe_at(const grb_model *md, int method, const real *y, const real *efforts, int want_reactions,
                      real *work, real *out) {
    return GRB(observe)(md, method, y, efforts[0], efforts[1], want_reactions, work, out);
}
#endif
