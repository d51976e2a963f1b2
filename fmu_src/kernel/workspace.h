/* The kernel's workspace layout, shared by its translation units (not public).
 *
 * One caller-owned buffer of GRB(work_size)() doubles holds every table the
 * kernel fills; GRB(ws_init)() only points into it.  Its first entries (the
 * header) say which model's sizes it was laid out for and what it holds now,
 * so that a buffer of another model's, or one read before it was filled, is
 * refused (GRB_BAD_ARGUMENT) instead of read past or trusted.  Then the tables,
 * row-major:
 *   K  (N x K_COLUMNS)  the link table of the kinematic pass
 *   Jc (N x 2 x N)      mass-centre Jacobians
 *   J  ((M + 3) x N)    closure Jacobian, then three scratch rows
 *   R  (M x R_COLUMNS)  constraint rows
 *   T  the dynamics: the mass matrix M (N x N), the force Q - h (N), the
 *      solver's table (N x (N + M + 1): the matrix a solve destroys, then its
 *      right-hand sides, the force and J^T) and the accelerations zdd (N)
 *   Q  the closures' M x M matrices: the Schur complement (or the Gram matrix
 *      J J^T), the eigen-solver's scratch, its eigenvectors, then the M
 *      eigenvalues
 *   S  scratch for assembly (several N- and M x N-sized blocks)
 *   X  what a pass needs in proportion to N, kept here rather than on the
 *      stack so that no call's stack grows with the chain (the native FMU runs
 *      in a host's thread): the links' paths from the ground (N rows of W
 *      64-bit words), a line's Jacobians (5N), M singular values, index
 *      lists (4N + M + 2 ints) and each closure row's span (2M ints)
 * with N moving links and M = 2C closure rows. */
#ifndef GRUBLER_WORKSPACE_H
#define GRUBLER_WORKSPACE_H

#include <stdint.h>

#include "grubler.h"
#include "real.h"

/* A link's frame in the kinematic pass (one row of K, in this field order:
 * grb_work_layout publishes K's width and the library reads it as a table). */
typedef struct grb_frame {
    real theta, omega;         /* absolute angle, rad, and rate, rad/s */
    real cos_theta, sin_theta;
    real o[2];                 /* the joint point O_k, m */
    real o_bias[2];            /* its acceleration at zero joint accelerations (the bias), m/s^2 */
    real axis[2];              /* the slide axis: the predecessor's vector turned a quarter */
    real slide, rate;          /* the slide, m, and its rate, m/s */
    real com[2], com_bias[2];  /* the mass centre and its bias acceleration */
    /* the sum of the real relative angles from the ground to the link (what
     * the link's children add theirs to: kept rather than recomputed from the
     * angle so that a serial chain's sums are the same floating-point numbers
     * as before) */
    real z_sum;
} grb_frame;
#define K_COLUMNS ((int)(sizeof(grb_frame) / sizeof(real)))

/* One closure row (each closure has two; one row of R): violation phi, the
 * acceleration's right side gamma (J zdd = gamma), what the closure still
 * lacks after the unconstrained solve (b), its multiplier lambda, the line
 * normal's component along this row's axis (prismatic) and the closing
 * point's coordinate. */
typedef struct grb_row {
    real phi, gamma, b, lambda, normal, point;
} grb_row;
#define R_COLUMNS ((int)(sizeof(grb_row) / sizeof(real)))

/* The header: a tag, the links and closures the buffer is laid out for (set by
 * grb_work_init, or by the first call that uses a buffer that has none) and
 * how far it is filled at the present state. */
/* The actuators' forces (inputs, grb_set_actuator_forces) follow in the header. */
enum { WORK_TAG, WORK_LINKS, WORK_CLOSURES, WORK_FILLED, WORK_ACTUATOR_FORCE,
       WORK_HEADER = WORK_ACTUATOR_FORCE + GRB_MAX_ACTUATORS };
#define GRB_WORK_TAG 4.2347e-297 /* an unlikely value for a number the kernel computes */
/* what the tables hold (WORK_FILLED), and what a call needs them to hold */
typedef enum grb_filled {
    GRB_FILLED_NOTHING = 0,      /* scratch (or a pass at other rates: the closure rows at rest) */
    GRB_FILLED_KINEMATICS = 1,   /* the kinematic pass, mass centres and closure rows at one state */
    GRB_FILLED_DYNAMICS = 2      /* and the accelerations and multipliers there */
} grb_filled;

typedef struct grb_ws {
    int n, m;        /* links, closure rows */
    int sc;          /* columns of solve */
    grb_frame *frame; /* K: each link's frame */
    real *Jc, *J;
    grb_row *row;     /* R: the closure rows */
    real *mass;       /* M (N x N) */
    real *force;      /* Q - h (N): applied force less the velocity products */
    real *solve;      /* N x sc: the matrix a solve destroys, then the right-hand sides */
    real *zdd;        /* the joint accelerations (N) */
    real *schur;      /* M x M: J (M + a J^T J)^-1 J^T, or the Gram matrix J J^T */
    real *eig_work;   /* M x M scratch of the eigen-solver */
    real *eigvec;     /* M x M: the eigenvectors of schur, by column */
    real *eigval;     /* M: their eigenvalues (not sorted) */
    real *S;
    real *header;     /* the buffer's header (WORK_*) */
    real *actuator_force; /* the actuators' forces, in the header (A) */
    /* bit j of row k (path + k * words, bit j % 64 of word j / 64): link j's
     * joint moves link k (j is k or on its way to the ground), set from the
     * model by ws_init: the inner loops over a link's path test a bit instead
     * of walking parents */
    uint64_t *path;
    int words;        /* 64-bit words per row of path: (N + 63) / 64 */
    /* a line's scratch (line_between and the force elements): its length's
     * Jacobian (N), its two points' Jacobians (2N each) */
    real *line_jl, *line_j0, *line_j1;
    double *singular;  /* M: the closure Jacobian's squared singular values (closure.c) */
    int *index;       /* 4N + M + 2 ints of index lists (the callers of closure.c, chart.c, minimal.c, demand.c
                         each own a part: see WS_INDEX_*) */
    int *span;        /* 2M ints: the first and last column of each closure row of J that is not zero (row_spans) */
} grb_ws;
/* The parts of w->index (offsets in ints, N links, M closure rows): the held
 * coordinates a drive demand hands to assembly, the coordinates a chart build
 * has tried, and two lists (N + 1 and N) of closure.c's and minimal.c's own
 * (chart.c's build calls closure.c, demand.c calls closure.c: their parts
 * are apart). */
#define WS_INDEX_DEMAND(n) 0
#define WS_INDEX_CHART(n) (n)
#define WS_INDEX_FIRST(n) (2 * (n))
#define WS_INDEX_SECOND(n) (3 * (n) + 1)

/* Point w into buffer for model md: GRB_BAD_ARGUMENT when the buffer was laid
 * out for other sizes, or holds less than `needs` (GRB_FILLED_NOTHING: any
 * buffer of the model; the call will overwrite the tables, and the header says
 * they hold nothing until the call says otherwise). */
grb_status GRB(ws_init)(grb_ws *w, const grb_model *md, real *buffer, grb_filled needs);
/* What the call left in the tables. */
static inline void grb_ws_filled(grb_ws *w, grb_filled filled) { w->header[WORK_FILLED] = (double)filled; }

/* The model's tables by row (grb_link, grb_closure: the same numbers). */
static inline const grb_link *grb_links(const grb_model *m) { return (const grb_link *)m->links; }
static inline const grb_closure *grb_closures(const grb_model *m) { return (const grb_closure *)m->closures; }
/* the predecessor of link k: an earlier moving link, or -1 the ground */
static inline int grb_parent(const grb_model *m, int k) { return (int)grb_links(m)[k].parent; }
static inline const grb_actuator *grb_actuators(const grb_model *m) { return (const grb_actuator *)m->actuators; }
static inline const grb_force *grb_forces(const grb_model *m) { return (const grb_force *)m->forces; }

/* 1 when link j is link k or one of its predecessors (j's joint moves k). */
/* Link k's row of the path table (bit j % 64 of word j / 64: link j's joint moves k). */
static inline const uint64_t *grb_path_row(const grb_ws *w, int k) { return w->path + (size_t)k * w->words; }
static inline int grb_on_path(const grb_ws *w, int j, int k) {
    return (int)((w->path[(size_t)k * w->words + (j >> 6)] >> (j & 63)) & 1u);
}
#define MASS_(w, i, j) ((w)->mass[(i) * (w)->n + (j)])
#define SOLVE_(w, i, c) ((w)->solve[(i) * (w)->sc + (c)])
#define SCHUR_(w, r, c) ((w)->schur[(r) * (w)->m + (c)])
#define EIGVEC_(w, r, c) ((w)->eigvec[(r) * (w)->m + (c)])
#define J_(w, r, i) ((w)->J[(r) * (w)->n + (i)])
#define JC_(w, k, d, i) ((w)->Jc[((k) * 2 + (d)) * (w)->n + (i)])

/* dense linear algebra on small matrices (linalg.c); row-major with a stride;
 * the least-squares solver exists in the plain (double) build only */
grb_status GRB(lu_solve)(real *T, int stride, int n, int a0, int x0, int ncols);
grb_status GRB(lu_solve_banded)(real *T, int stride, int n, int a0, int x0, int ncols);
void GRB(sym_eig)(const real *S, real *B, real *V, real *values, int m);
/* Up to this many closure rows the symmetric eigenproblems and the minimum-norm
 * solves are the Jacobi methods' (the presets' numbers were made with them, and
 * at these sizes they take a handful of sweeps); above it, where a sweep costs
 * some 4 M^3 and a change-point passage of a chain of many loops (IFToMM A02)
 * thousands of them, the eigenvalues alone come from a tridiagonal QL and a
 * well-conditioned system from a Cholesky factor, the Jacobi method remaining
 * the answer wherever the factor finds the matrix near singular. */
#define GRB_JACOBI_ROWS 8
int GRB(cholesky)(real *A, int stride, int n, double cutoff);
void GRB(cholesky_solve)(const real *L, int stride, int n, real *b, int bstride);
void grb_sym_eigenvalues(const double *S, double *B, double *v, double *values, int m);
int grb_lstsq_min_norm(const double *J, int jstride, int m, int n, const double *b, int bstride, double rcond,
                       double *x, double *U, double *V);

/* Where each of the first `rows` rows of J is not zero: span[2r] .. span[2r + 1]
 * (an empty row: first > last).  A closure row reaches only the joints on its
 * two links' paths, a few of many in a chain of many loops: the products over
 * many rows (the Gram matrix, the Schur complement) skip the columns outside
 * both rows' spans, whose terms are exact zeros (chain.c). */
void GRB(row_spans)(const grb_ws *w, int rows, int *span);

/* the kinematic and dynamic passes (chain.c) */
void GRB(chain)(const grb_model *md, const real *z, const real *zd, grb_ws *w);
void GRB(point)(const grb_model *md, const grb_ws *w, int k, real lx, real ly, real *J, real *r);
void GRB(closure_rows)(const grb_model *md, const real *zd, grb_ws *w);
grb_status GRB(accelerations)(const grb_model *md, int method, const real *z, const real *zd, real tau_drive,
                       real tau_load, grb_ws *w);
void GRB(reactions)(const grb_model *md, grb_ws *w, real *out);
void grb_project_ws(const grb_model *md, double scale, double *y, grb_ws *w);
double grb_closure_conditioning(const grb_model *md, const double *z, grb_ws *w);
int grb_closure_freedom(const grb_model *md, const double *z, grb_ws *w);
int grb_closure_row_basis(const grb_model *md, const double *z, grb_ws *w, double *basis);
double grb_branch_orientation(const grb_model *md, const double *y, const double *basis, grb_ws *w);
void grb_closure_watch(const grb_model *md, const double *y, const double *basis, grb_ws *w, double *kappa,
                       double *orientation);
double grb_branch_point(const grb_model *md, int held, double scale, double *z, double *tangent, grb_ws *w);
/* the mass matrix M and the applied minus velocity-product force Q - h at (z, zd) (chain.c) */
void GRB(mass_and_force)(const grb_model *md, const real *z, const real *zd, real tau_drive, real tau_load, grb_ws *w);

/* An assembly branch near a change point as a curve z(x) in one held
 * coordinate x (chart.c): Chebyshev coefficients of z, dz/dx and d2z/dx2 over
 * x in [lo, hi], and where in it the closure is worst conditioned. */
#define CHART_NODES 16
typedef struct grb_chart {
    int n, active, held;
    double lo, hi, mid, half;
    double pinch, pinch_kappa;  /* x at the worst conditioning met, and that conditioning (relative) */
    double pinch_step;          /* how far from pinch the worst lies (while the chart is built) */
    double *c;                  /* 3 x CHART_NODES x n coefficients */
    double *values;             /* 2 x CHART_NODES x n: z and dz/dx at the nodes (while built; then the
                                   chart's scalars between advances: grb_chart_save) */
    double *scratch;            /* 11 n */
} grb_chart;
/* (its size, layout, evaluation, save and resume: chart.h, shared with the
 * spatial kernel) */
int grb_chart_build(const grb_model *md, double scale, const double *y, double kappa_ref, double near,
                    grb_chart *ch, grb_ws *w);
int grb_chart_rhs(const grb_model *md, const grb_chart *ch, const double *y, double tau_drive, double tau_load,
                  grb_ws *w, double *out);

#endif
