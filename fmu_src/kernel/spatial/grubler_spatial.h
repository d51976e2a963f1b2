/* grubler spatial kernel: the imaginary-joints chain in three dimensions.
 *
 * The planar kernel's method (grubler.h) carried to space, beside it, on the
 * same conventions: the model (grs_model: number tables) apart from the data
 * (state vectors and one caller-owned workspace), no globals, no allocation,
 * every function that can fail returns a grb_status.
 *
 * Links in Denavit-Hartenberg form, the modified convention of Craig (1986),
 * which suits a tree because each link's row speaks only of its own joint: the
 * frame of link k is its parent's frame turned by alpha about the parent's x
 * axis, moved a along that x axis, turned by theta about the new z axis (the
 * joint axis) and moved d along it:
 *     T_k = T_parent Rx(alpha) Tx(a) Rz(theta) Tz(d).
 * Each link's joint is the thesis's imaginary pair on that z axis: a revolute
 * (theta) and a prismatic slide (d), with existence factors choosing the real
 * one (R, P) or both (C, cylindrical); neither (F, fixed) makes the row a
 * rigid offset, for a frame one DH row cannot reach (a slide across its
 * predecessor, then the link turned back into the plane).  A locked variable
 * keeps its table value; a real one adds its coordinate to it.  A spherical joint is three
 * revolutes on intersecting axes (the builders make it: grubler.mechanism.spatial).
 *
 * Coordinates: y = (z, zd), z the real joint variables in link order (a
 * link's theta before its d).  Closures tie a point (and an axis) of one link
 * to another link or the ground: spherical (3 rows), revolute (5),
 * cylindrical (4), solved exactly with their Lagrange multipliers; where the
 * rows are dependent (an overconstrained loop) the motion stays exact and the
 * multipliers are the minimum-norm ones (grs_determinacy says which are
 * determinate).
 */
#ifndef GRUBLER_SPATIAL_H
#define GRUBLER_SPATIAL_H

#include <stddef.h>

#include "grubler.h" /* grb_status, GRB_API */

#ifdef __cplusplus
extern "C" {
#endif

/* Columns of the link table, one row per moving link: the DH parameters, the
 * existence factors, the parent, the inertia, joint damping. */
enum { GRS_L_A, GRS_L_ALPHA, GRS_L_THETA, GRS_L_D, GRS_L_REV, GRS_L_PRIS, GRS_L_PARENT, GRS_L_M, GRS_L_COM,
       GRS_L_INERTIA = GRS_L_COM + 3, GRS_L_DAMP_R = GRS_L_INERTIA + 6, GRS_L_DAMP_P, GRS_L_COLUMNS };
/* One row of the link table by name (sp_chain.c checks the fields sit at the columns above). */
typedef struct grs_link {
    double a;          /* along the parent's x axis to this joint's axis, m */
    double alpha;      /* the joint axis's twist about the parent's x axis, rad */
    double theta;      /* the rotation about the joint axis (locked value, or what the coordinate adds to), rad */
    double d;          /* the slide along the joint axis (likewise), m */
    double revolute;   /* existence factor of the revolute: 1 real, 0 locked */
    double prismatic;  /* existence factor of the slide: 1 real, 0 locked (both 1: cylindrical) */
    double parent;     /* an earlier moving link's 0-based index, -1 the ground */
    double m;          /* mass, kg */
    double com[3];     /* the mass centre in the link's frame, m */
    double inertia[6]; /* the inertia tensor about the mass centre in the link's axes: xx, xy, xz, yy, yz, zz, kg m^2 */
    double damping_r;  /* joint damping on theta, N m s/rad */
    double damping_p;  /* joint damping on d, N s/m */
} grs_link;

/* Closure kinds and their row counts. */
enum grs_closure_kind { GRS_SPHERICAL = 0, GRS_REVOLUTE = 1, GRS_CYLINDRICAL = 2 };
/* Columns of the closure table, one row per closure. */
enum { GRS_CL_KIND, GRS_CL_LINK, GRS_CL_TO, GRS_CL_POINT, GRS_CL_AXIS = GRS_CL_POINT + 3,
       GRS_CL_TO_POINT = GRS_CL_AXIS + 3, GRS_CL_TO_AXIS = GRS_CL_TO_POINT + 3, GRS_CL_COLUMNS = GRS_CL_TO_AXIS + 3 };
/* One row of the closure table by name.  The closure's frame sits on the
 * target: origin to_point, z (v) along to_axis (the target's z for a
 * spherical joint), x (n1) the target's x axis made square to v (its y where
 * x lies almost along v), y (n2) = v x n1 (grs_closure_frame).  Rows, each a dot product
 * that is zero when closed, with d = point - to_point in the world:
 *   spherical:   d.n1, d.n2, d.v              (force along n1, n2, v)
 *   revolute:    d.n1, d.n2, d.v, u.n1, u.n2  (and moments about n2, n1)
 *   cylindrical: d.n1, d.n2, u.n1, u.n2
 * u the closing link's axis.  A multiplier is the force (moment) the target
 * exerts on the closing link through that row. */
typedef struct grs_closure {
    double kind;         /* enum grs_closure_kind */
    double link, to;     /* the closing link and its target (moving-link index, -1 the ground) */
    double point[3];     /* the closing point, in link's frame, m */
    double axis[3];      /* the closing link's joint axis, in its frame (revolute, cylindrical) */
    double to_point[3];  /* where it closes, in to's frame (the world's on the ground), m */
    double to_axis[3];   /* the target's joint axis, in to's frame */
} grs_closure;

#define GRS_MAX_LINKS 64
#define GRS_MAX_COORDS 128
#define GRS_MAX_ROWS 64

/* The model: never changes during a run. */
typedef struct grs_model {
    int n_links;            /* moving links, 1 .. GRS_MAX_LINKS */
    int n_closures;         /* closures */
    const double *links;    /* n_links x GRS_L_COLUMNS, row-major */
    const double *closures; /* n_closures x GRS_CL_COLUMNS (NULL when none) */
    double gravity[3];      /* the gravity acceleration in the world, m/s^2 */
} grs_model;

/* The model is one the kernel can run: parents earlier than their link,
 * existence factors 0 or 1 with at least one real coordinate in the model, finite numbers, an inertia
 * that is a physical one (mass >= 0, tensor positive semi-definite), closures
 * of a known kind between existing links with unit-length axes.  On
 * GRB_BAD_ARGUMENT *row says which link (>= 0) or closure (-1 - c) is at fault
 * and *column its column. */
GRB_API grb_status grs_check(const grs_model *m, int *row, int *column);
/* Real coordinates (N) and closure rows (M) of the model (grs_check it first). */
GRB_API int grs_n_coords(const grs_model *m);
GRB_API int grs_n_rows(const grs_model *m);

/* Doubles of workspace for the model, and laying a buffer out (its length checked). */
GRB_API size_t grs_work_size(const grs_model *m);
GRB_API grb_status grs_work_init(const grs_model *m, double *work, size_t length);
/* The same size from the model's shape alone (links, real coordinates, closure
 * rows; 0 outside the kernel's limits): for a caller that sizes its memory
 * before it has the tables, a native FMU whose shape is fixed at export. */
GRB_API size_t grs_work_size_for(int n_links, int n_coords, int n_rows);

/* The state equation ydot = (zd, zdd) at y with the generalised efforts tau
 * (N: a joint torque or force per coordinate; NULL none). */
GRB_API grb_status grs_rhs(const grs_model *m, const double *y, const double *tau, double *work, double *out);

/* Forward dynamics at y: accelerations zdd (N), closure multipliers lambda (M),
 * kinetic and potential energy (energy[0..1]); any output may be NULL. */
GRB_API grb_status grs_dynamics(const grs_model *m, const double *y, const double *tau, double *work, double *zdd,
                                double *lambda, double *energy);

/* Closure violation phi (M) and Jacobian J (M x N) at z. */
GRB_API grb_status grs_constraint(const grs_model *m, const double *z, double *phi, double *J, double *work);

/* The world frames of every link at z: origin (3) then rotation (9, row-major,
 * the link's axes as columns) per link: out[12 k ..]. */
GRB_API grb_status grs_frames(const grs_model *m, const double *z, double *work, double *out);

/* World positions of points fixed to links over rows states (rows x 2N):
 * out[(i * n_points + p) * 3 ..] is local[3p..] on link link[p] (-1: the world point itself). */
GRB_API grb_status grs_link_points_rows(const grs_model *m, int rows, const double *y, int n_points, const int *link,
                                        const double *local, double *work, double *out);

/* The closure frame (n1, n2, v: 9 numbers, in to's frame) of closure c. */
GRB_API grb_status grs_closure_frame(const grs_model *m, int c, double *frame);

/* Reactions after grs_dynamics at y with efforts tau (recomputed here):
 *   closures: per closure 6 numbers, the force (3) and moment (3) the target
 *     exerts on the closing link, in the closure's frame (n1, n2, v), moments
 *     about the closing point;
 *   joints: per link 6 numbers, the force and moment (about the joint origin)
 *     the parent exerts on the link through its joint, in the link's axes.
 * Either may be NULL. */
GRB_API grb_status grs_reactions(const grs_model *m, const double *y, const double *tau, double *work,
                                 double *closures, double *joints);

/* Which multipliers are determinate at z: indeterminate[r] (M) is the length
 * of the part of the unit vector e_r that lies in the null space of J^T (0:
 * determinate, 1: wholly free), *rank the rank of J (singular values above
 * rcond times the largest).  A row's multiplier is determinate exactly when
 * e_r lies in the range of J. */
GRB_API grb_status grs_determinacy(const grs_model *m, const double *z, double rcond, double *work,
                                   double *indeterminate, int *rank);

/* Which components of the joint reactions (grs_reactions' joints table) are
 * determinate at z: indeterminate[6 k + c] (L x 6) is the root-sum-square of
 * that component over the closures' internal loads, an orthonormal basis of
 * the null space of J^T (N or N m per unit multiplier; 0: determinate), *rank
 * the rank of J. */
GRB_API grb_status grs_joint_determinacy(const grs_model *m, const double *z, double rcond, double *work,
                                         double *indeterminate, int *rank);

/* Minimum-norm projection of y onto the position and velocity constraints, in place. */
GRB_API grb_status grs_project(const grs_model *m, double scale, double *y, double *work);

/* Consistent assembly: hold the coordinates listed in held, solve the others by
 * damped Newton from z (the sketch picks the branch), then their rates from
 * the velocity constraint.  GRB_NOT_CLOSED with *closest the smallest violation,
 * or 2 where the rows close with a revolute's or cylinder's axes reversed
 * (u = -v satisfies their rows too: another joint than the model's). */
GRB_API grb_status grs_assemble(const grs_model *m, int n_held, const int *held, double scale, double *z, double *zd,
                                double *closest, double *work);

/* The integrator's settings (the planar kernel's tableaus: enum grb_tableau). */
typedef struct grs_settings {
    int tableau;        /* GRB_DOP853 or GRB_RK45 (adaptive) */
    double rtol, atol;
    double h_max;       /* largest step, s */
    long max_steps;     /* per advance */
    double scale;       /* length scale of the projection's tolerance, m */
    const double *tau;  /* generalised efforts (N), constant over the advance; NULL none */
} grs_settings;

/* Doubles of stepper workspace for N coordinates.  Zeroed by the caller for a
 * new run: between advances it keeps the change-point chart being followed,
 * the best closure conditioning seen and the change points passed. */
GRB_API size_t grs_stepper_size(int tableau, int n_coords);
/* Change points the advances on this stepper have passed (the motion crossing
 * a chart's pinch) since it was zeroed. */
GRB_API double grs_passages(const double *stepper, int tableau, int n_coords);

/* Step from *t through the increasing times t_out (n_out), each one reached by
 * a step that ends on it, projecting onto the closures after every accepted
 * step; the state at each into out (n_out x 2N).  *h is the next step (0: the
 * integrator picks); *steps counts accepted steps.  y and *t change only on
 * GRB_OK; else *where says when it stopped. */
GRB_API grb_status grs_advance(const grs_model *m, const grs_settings *s, double *t, double *h, long *steps, double *y,
                               const double *t_out, int n_out, double *out, double *work, double *stepper,
                               double *where);

#ifdef __cplusplus
}
#endif
#endif
