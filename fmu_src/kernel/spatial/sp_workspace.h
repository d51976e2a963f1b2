/* The spatial kernel's workspace, shared by its translation units (not public).
 *
 * One caller-owned buffer of grs_work_size doubles; grs_ws only points into
 * it.  Its header says which model sizes it was laid out for, so a buffer of
 * another model is refused.  Then, row-major:
 *   frame (L x GRS_FRAME_COLUMNS)  each link's frame in the kinematic pass (world)
 *   mass (N x N), force (N)        M and Q - h of the open tree
 *   J (M x N), row (M x 4)         closure Jacobian and rows (phi, gamma, b, lambda)
 *   solve (N x (N + M + 1))        the matrix a solve destroys, the force, J^T
 *   schur, eig_work, eigvec (M x M each), eigval (M), zdd (N)
 *   vec (4 tracked vectors)        scratch for one closure row's two factors
 *   S                              scratch for least squares and assembly
 *   basis (2 x (N - 1) x M)        the change-point watch's row directions (sp_integrate.c)
 * with L links, N coordinates and M closure rows. */
#ifndef GRUBLER_SP_WORKSPACE_H
#define GRUBLER_SP_WORKSPACE_H

#include "grubler_spatial.h"
#include "workspace.h" /* the planar kernel's small solvers: grb_lu_solve, grb_sym_eig, grb_lstsq_min_norm */

/* A link's frame in the kinematic pass, all in world axes. */
typedef struct grs_frame {
    double R[9];       /* rotation, row-major: the link's axes are its columns */
    double o[3];       /* the frame's origin, on the joint axis, m */
    double axis[3];    /* the joint axis (the frame's z), unit */
    double omega[3];   /* angular velocity, rad/s */
    double v[3];       /* velocity of o, m/s */
    double alpha_b[3]; /* angular acceleration at zero joint accelerations (the bias), rad/s^2 */
    double a_b[3];     /* acceleration of o at zero joint accelerations, m/s^2 */
} grs_frame;
#define GRS_FRAME_COLUMNS ((int)(sizeof(grs_frame) / sizeof(double)))

/* A closure row's value phi, acceleration right side gamma (J zdd = gamma),
 * what the closure still lacks after the unconstrained solve (b), multiplier. */
typedef struct grs_row {
    double phi, gamma, b, lambda;
} grs_row;
#define GRS_ROW_COLUMNS 4

/* A vector in the world that moves with the chain: its value, rate, bias
 * acceleration (at zero joint accelerations) and Jacobian (3 x N, row-major:
 * d value / d z = rate / zd). */
typedef struct grs_vec {
    double value[3], rate[3], bias[3];
    double *J;
} grs_vec;

enum { GRS_WORK_TAG, GRS_WORK_LINKS, GRS_WORK_COORDS, GRS_WORK_ROWS, GRS_WORK_HEADER };
#define GRS_TAG 7.31e-297 /* an unlikely value for a number the kernel computes */

typedef struct grs_ws {
    int L, n, m, sc;        /* links, coordinates, closure rows, columns of solve */
    int theta_at[GRS_MAX_LINKS], d_at[GRS_MAX_LINKS]; /* a link's coordinates' indices, -1 locked */
    int coord_link[GRS_MAX_COORDS];  /* the link a coordinate moves */
    int coord_slide[GRS_MAX_COORDS]; /* 1: a slide d, 0: a rotation theta */
    unsigned long long path[GRS_MAX_LINKS]; /* bit j: link j is link k or on its way to the ground */
    grs_frame *frame;
    double *mass, *force, *J;
    grs_row *row;
    double *solve, *schur, *eig_work, *eigvec, *eigval, *zdd;
    grs_vec vec[4];
    double *S; /* scratch: see sp_closure.c */
    double *basis; /* two (N - 1) x M tables of closure row directions (grs_closure_watch) */
    /* idle coordinates (grs_idle_coords, set by the advance; 0 elsewhere): ones no closure row sees at any
     * position, as the RSSR coupler's spin about the line through its two balls.  coord_idle is read only
     * when n_idle > 0 (grs_is_idle). */
    int n_idle;
    int coord_idle[GRS_MAX_COORDS];
} grs_ws;

static inline int grs_is_idle(const grs_ws *w, int i) { return w->n_idle > 0 && w->coord_idle[i]; }

static inline const grs_link *grs_links(const grs_model *m) { return (const grs_link *)m->links; }
static inline const grs_closure *grs_closures(const grs_model *m) { return (const grs_closure *)m->closures; }
static inline int grs_closure_rows_of(int kind) { return kind == GRS_SPHERICAL ? 3 : kind == GRS_REVOLUTE ? 5 : 4; }

#define SP_MASS(w, i, j) ((w)->mass[(i) * (w)->n + (j)])
#define SP_J(w, r, i) ((w)->J[(r) * (w)->n + (i)])
#define SP_SOLVE(w, i, c) ((w)->solve[(i) * (w)->sc + (c)])
#define SP_SCHUR(w, r, c) ((w)->schur[(r) * (w)->m + (c)])
#define SP_EIGVEC(w, r, c) ((w)->eigvec[(r) * (w)->m + (c)])

/* sp_chain.c */
grb_status grs_ws_init(grs_ws *w, const grs_model *md, double *buffer);
size_t grs_scratch_size(int n, int m);
void grs_kinematics(const grs_model *md, const double *z, const double *zd, grs_ws *w);
void grs_point(const grs_ws *w, int k, const double *local, grs_vec *out);
void grs_direction(const grs_ws *w, int k, const double *local, grs_vec *out);
void grs_closure_rows(const grs_model *md, grs_ws *w);
void grs_mass_and_force(const grs_model *md, const double *zd, const double *tau, grs_ws *w);
grb_status grs_accelerations(const grs_model *md, const double *z, const double *zd, const double *tau, grs_ws *w);
/* sp_closure.c */
void grs_rows_at(const grs_model *md, const double *z, grs_ws *w);
double grs_row_space_at(const grs_model *md, const double *z, grs_ws *w);
void grs_project_ws(const grs_model *md, double scale, double *y, grs_ws *w);
double grs_closure_conditioning(const grs_model *md, const double *z, grs_ws *w);
int grs_closure_freedom(const grs_model *md, const double *z, grs_ws *w);
void grs_closure_watch(const grs_model *md, const double *y, const double *basis, double *basis_out, double *kappa,
                       double *orientation, double *own_orientation, grs_ws *w);
double grs_branch_point(const grs_model *md, int held, double scale, double *z, double *tangent, grs_ws *w);
int grs_idle_coords(const grs_model *md, const double *z, grs_ws *w);

/* sp_chart.c: an assembly branch near a change point as a curve z(x) in one
 * held coordinate x, the planar kernel's chart (the method is chart.h's, one
 * text for both kernels; the chart is workspace.h's grb_chart) over the
 * spatial chain; its size, layout, evaluation, save and resume are chart.h's
 * grb_chart_*. */
typedef grb_chart grs_chart;
int grs_chart_build(const grs_model *md, double scale, const double *y, double kappa_ref, double near,
                    grs_chart *ch, grs_ws *w);
int grs_chart_rhs(const grs_model *md, const grs_chart *ch, const double *y, const double *tau, grs_ws *w,
                  double *out);
int grs_chart_put(const grs_chart *ch, double *y, const grs_ws *w);
int grs_chart_resume(grs_chart *ch, double *y, double scale, const grs_ws *w);

#endif
