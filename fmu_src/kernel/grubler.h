/* grubler kernel: the imaginary-joints planar chain, its closures and integrators.
 *
 * One C99 implementation (libm only) that the Python library calls through
 * ctypes (grubler/binding.py) and the native FMU (grubler/fmi/) runs.
 *
 * Conventions, as the Reference FMUs and pinocchio keep them:
 *   - the model (grb_model: geometry, inertia, closures as two number tables) is
 *     separate from the data (state vectors, a workspace); the kernel keeps no
 *     globals and allocates nothing: every buffer belongs to the caller;
 *   - every function that can fail returns a grb_status.
 *
 * Coordinates: y = (z, zd), z the N real joint variables (a slide's B, or a
 * revolute's angle relative to its predecessor), in chain order.  The chain may
 * branch: each link's predecessor is any earlier link or the ground (a tree),
 * and a joint moves its own subtree.
 */
#ifndef GRUBLER_H
#define GRUBLER_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32) && defined(GRB_SHARED)
#define GRB_API __declspec(dllexport)
#else
#define GRB_API
#endif

typedef enum grb_status {
    GRB_OK = 0,
    GRB_SINGULAR,              /* the matrix to solve is singular */
    GRB_NONFINITE_DERIVATIVE,  /* where: time */
    GRB_STEP_UNDERFLOW,        /* where: time, limit: smallest step */
    GRB_TOO_MANY_STEPS,        /* where: target time, limit: steps allowed */
    GRB_NONFINITE_FIXED_STEP,  /* where: time, limit: step */
    GRB_BRANCH_JUMP,           /* where: time, limit: fraction of the speeds removed */
    GRB_BAD_ARGUMENT,          /* a time, tolerance or size out of range */
    GRB_NOT_CLOSED             /* assembly: limit: the closest violation reached */
} grb_status;

/* The status in words (a static string). */
GRB_API const char *grb_status_message(grb_status status);

/* Columns of the link table, one row per moving link (model.py's L_*):
 * mass, centroidal inertia, mass centre along and across the link vector, the
 * vector's length, the predecessor's vector length (a1 for link 2), joint
 * damping, 1 if the revolute is the real joint (0: the slide), the locked
 * slide and absolute angle that the real joints add to (q_locked), and the
 * predecessor (parent): the 0-based index of the moving link the pair hangs
 * from, -1 the ground.  A serial chain has parent k - 1; any earlier link makes
 * the chain a tree (a Stephenson III six-bar needs one).  The kernel trusts the
 * table as grb_scene_tables builds it: -1 <= parent < k for row k. */
enum { GRB_L_M, GRB_L_I, GRB_L_P, GRB_L_Q, GRB_L_A, GRB_L_APRED, GRB_L_DAMP, GRB_L_REV, GRB_L_SLIDE0,
       GRB_L_THETA0, GRB_L_PARENT, GRB_L_COLUMNS };
/* One row of the link table by name (the kernel reads the table through it;
 * chain.c checks that its fields sit at the columns above). */
typedef struct grb_link {
    double m;        /* mass, kg */
    double inertia;  /* centroidal moment of inertia, kg m^2 */
    double p, q;     /* mass centre along and across the link vector, m */
    double a;        /* the link vector's length, m */
    double a_pred;   /* the predecessor's vector length (a1 for a link on the ground), m */
    double damping;  /* joint damping, N m s/rad (N s/m on a slide) */
    double revolute; /* 1: the revolute is the real joint, 0: the slide */
    double slide0;   /* the locked slide a revolute joint keeps, m */
    double theta0;   /* the locked absolute angle the real relative angles add to, rad */
    double parent;   /* the predecessor: an earlier moving link's index, -1 the ground */
} grb_link;
/* Columns of the closure table, one row per closure: kind (0 revolute,
 * 1 prismatic), closing link and target link (0-based moving-link index, -1 the
 * ground), point, target point, line angle, held orientation psi, penalty gain
 * and damping. */
enum { GRB_CL_KIND, GRB_CL_LINK, GRB_CL_TO, GRB_CL_PX, GRB_CL_PY, GRB_CL_TX, GRB_CL_TY, GRB_CL_ANGLE,
       GRB_CL_PSI, GRB_CL_GAIN, GRB_CL_DAMP, GRB_CL_COLUMNS };
/* One row of the closure table by name. */
typedef struct grb_closure {
    double kind;         /* 0 revolute (a pin), 1 prismatic (a point on a line, the link held at psi) */
    double link, to;     /* the closing link and the link it closes on (moving-link index, -1 the ground) */
    double point[2];     /* the closing point, in link's frame (along, across its vector), m */
    double to_point[2];  /* where it closes: in to's frame, or the world's on the ground, m */
    double angle;        /* a prismatic closure's line angle in to's frame, rad */
    double psi;          /* the orientation a prismatic closure holds, rad */
    double gain, damping; /* the penalty method's spring, N/m, and damper, N s/m */
} grb_closure;

/* Columns of the actuator table, one row per linear actuator (a cylinder, a
 * solenoid, a strut): the link carrying its first point (0-based moving-link
 * index, -1 the ground) and that point in the link's frame (along, across its
 * vector; the world's on the ground), then the same of its second point. */
enum { GRB_A_FROM_LINK, GRB_A_FROM_X, GRB_A_FROM_Y, GRB_A_TO_LINK, GRB_A_TO_X, GRB_A_TO_Y, GRB_A_COLUMNS };
/* One row of the actuator table by name.  The actuator's force acts along the
 * line through its two points, positive pushing them apart: on the to-link
 * +F u at to_point, on the from-link -F u at from_point, u the unit vector from
 * the first point to the second.  Its generalised force is F J_L^T, J_L the
 * Jacobian of its length L = |to - from|.  The forces are inputs: they live in
 * the workspace (grb_set_actuator_forces), not in the model. */
typedef struct grb_actuator {
    double from_link;     /* the link of the first point (moving-link index, -1 the ground) */
    double from_point[2]; /* the first point, in from_link's frame, m */
    double to_link;       /* the link of the second point */
    double to_point[2];   /* the second point, in to_link's frame, m */
} grb_actuator;
/* The most actuators a model may have (their forces sit in the workspace's header). */
#define GRB_MAX_ACTUATORS 16

/* Columns of the force-element table, one row per element: the springs,
 * dampers, joint springs, friction and constant loads a scene holds, model data
 * beside the actuators (whose forces are inputs).  Each row's kind says which
 * columns it reads:
 *   GRB_FORCE_SPRING: a spring-damper between a point of link and a point of
 *     to_link (moving-link index, -1 the ground; points in the link's frame, the
 *     world's on the ground).  Its force along the line through them, positive
 *     pushing them apart, at length L and rate Ld:
 *       F = preload - stiffness (L - free) - damping Ld + F_gas,
 *       F_gas = gas_force (gas_column / h)^gas_exponent, h = gas_column + L - free,
 *     the polytropic law p V^n = const of a gas spring of bore area A: gas_force
 *     = p0 A, its force at the free length, where the gas column (V / A) is
 *     gas_column; F_gas is 0 when gas_force is 0, and not finite once h <= 0.
 *     Stored energy: stiffness (L - free)^2 / 2 - preload (L - free) + the gas's
 *     (0 at the free length);
 *   GRB_FORCE_JOINT: at the real joint of link `link` (its coordinate z: the
 *     angle relative to its predecessor, or the slide), the effort
 *       Q = preload - stiffness (z - free) - friction tanh(zd / friction_speed)
 *     (N m, or N on a slide): a torsion or linear spring with Coulomb friction
 *     regularised over the rate scale friction_speed (the joint's viscous
 *     damping is the link table's);
 *   GRB_FORCE_LOAD: a constant force (world axes) and moment on link `link` at
 *     point. */
enum { GRB_F_KIND, GRB_F_LINK, GRB_F_X, GRB_F_Y, GRB_F_TO_LINK, GRB_F_TO_X, GRB_F_TO_Y, GRB_F_STIFFNESS,
       GRB_F_FREE, GRB_F_PRELOAD, GRB_F_DAMPING, GRB_F_GAS_FORCE, GRB_F_GAS_COLUMN, GRB_F_GAS_EXPONENT,
       GRB_F_FRICTION, GRB_F_FRICTION_SPEED, GRB_F_FX, GRB_F_FY, GRB_F_MZ, GRB_F_COLUMNS };
enum grb_force_kind { GRB_FORCE_SPRING = 0, GRB_FORCE_JOINT = 1, GRB_FORCE_LOAD = 2 };
/* One row of the force-element table by name. */
typedef struct grb_force {
    double kind;            /* enum grb_force_kind */
    double link;            /* the (first) link: moving-link index, -1 the ground */
    double point[2];        /* spring, load: the (first) point in link's frame, m */
    double to_link;         /* spring: the second point's link */
    double to_point[2];     /* spring: the second point in to_link's frame, m */
    double stiffness;       /* N/m (N m/rad at a revolute) */
    double free;            /* free length, m (joint: the free angle, rad, or slide, m) */
    double preload;         /* the force at the free length, N (N m), positive pushing apart (joint: along +z) */
    double damping;         /* spring: viscous damping along the line, N s/m */
    double gas_force;       /* spring: p0 A, the gas force at the free length, N (0: no gas) */
    double gas_column;      /* spring: V0 / A, the gas column at the free length, m */
    double gas_exponent;    /* spring: the polytropic exponent n (1 isothermal, 1.4 adiabatic air) */
    double friction;        /* joint: Coulomb friction, N m (N on a slide) */
    double friction_speed;  /* joint: the rate over which friction's tanh rises, rad/s (m/s) */
    double force[2];        /* load: the force, world axes, N */
    double moment;          /* load: the moment, N m */
} grb_force;
/* What grb_force_rows gives for each element, in order: its length (a joint:
 * its coordinate, a load: 0), rate, force (a joint: its effort; a load: 0),
 * stored energy, the power it puts into the mechanism, and the power its damper
 * and friction dissipate (>= 0). */
enum { GRB_FO_LENGTH, GRB_FO_RATE, GRB_FO_FORCE, GRB_FO_ENERGY, GRB_FO_POWER, GRB_FO_DISSIPATION, GRB_FO_COUNT };

enum grb_method { GRB_EXACT = 0, GRB_PENALTY = 1 };
enum grb_tableau { GRB_DOP853 = 0, GRB_RK45 = 1, GRB_RK4 = 2 };

/* The most moving links a chain may have.  Every table a chain needs is in the
 * caller's workspace (grb_work_size grows as N^2, a step's cost as N^3), so the
 * bound is a sanity limit, not a layout: 1024 links with 512 closures need a
 * workspace of some 100 MB and seconds per step. */
#define GRB_MAX_LINKS 1024

/* The model: never changes during a run. */
typedef struct grb_model {
    int n_links;              /* N moving links (N real joints), 1 .. GRB_MAX_LINKS */
    int n_closures;           /* C closures, 2 constraint rows each */
    const double *links;      /* N x GRB_L_COLUMNS, row-major */
    const double *closures;   /* C x GRB_CL_COLUMNS, row-major */
    double theta1;            /* ground vector angle, rad */
    double gravity;           /* g along -y, m/s^2 */
    int drive, load;          /* index in z of the drive and load joints, -1 none */
    double drive_inertia;     /* reflected rotor inertia on z[drive] */
    int n_actuators;          /* A linear actuators, 0 .. GRB_MAX_ACTUATORS */
    const double *actuators;  /* A x GRB_A_COLUMNS, row-major (NULL when A = 0) */
    int n_forces;             /* F force elements (0: none, and the kernel's work is as without them) */
    const double *forces;     /* F x GRB_F_COLUMNS, row-major (NULL when F = 0) */
} grb_model;

/* The fixed outputs of grb_observe, in order after the coordinates, rates and
 * accelerations (6N), before the joint reactions (3N).  grubler.quantities
 * (FIXED_OBSERVATIONS) names, units and describes them; a test holds the two
 * lists together. */
typedef enum grb_observation {
    GRB_OBS_TIP_X,         /* the chain's tip (last link's closing point), m */
    GRB_OBS_TIP_Y,
    GRB_OBS_CLOSURE_ERROR, /* largest closure violation, m or rad */
    GRB_OBS_FX,            /* the first closure's force on the closing link, N */
    GRB_OBS_FY,
    GRB_OBS_MZ,            /* ... and moment, N m */
    GRB_OBS_KE,            /* kinetic energy, J */
    GRB_OBS_PE,            /* potential energy (gravity, penalty springs, the force elements'), J */
    GRB_OBS_E,             /* KE + PE, J */
    GRB_OBS_TAU_DRIVE,     /* the drive effort, N m or N */
    GRB_OBS_P_DRIVE,       /* its power, W */
    GRB_OBS_FIXED          /* their count */
} grb_observation;

/* Number of outputs of grb_observe for N links: coordinates, rates and
 * accelerations in thesis order (2N each), the fixed outputs above, the joint
 * reactions (3N). */
#define GRB_N_OBSERVED(n) (9 * (n) + GRB_OBS_FIXED)

/* The data (pinocchio's Data beside its Model): every table the kernel fills
 * for one model, in one caller-owned buffer of grb_work_size doubles.  Its
 * first entries say which sizes it is laid out for and how far it is filled
 * (kernel/workspace.h), so that each call below can refuse (GRB_BAD_ARGUMENT)
 * a buffer laid out for another model's sizes, and grb_point_on_link and
 * grb_joint_reactions one that grb_evaluate has not filled.  grb_work_init
 * lays a buffer out, checking its length; a buffer no call has used yet (all
 * zeros, say) is laid out by the first call, which must trust its length. */
GRB_API size_t grb_work_size(int n_links, int n_closures);
GRB_API grb_status grb_work_init(int n_links, int n_closures, double *work, size_t length);

/* The actuators' forces (N, positive pushing their points apart: A of them),
 * held in the workspace until set again: an input like the drive effort, read
 * by every evaluation that uses this buffer (grb_rhs, grb_observe, grb_advance,
 * grb_joint_reactions ...).  A buffer grb_work_init laid out holds zeros. */
GRB_API grb_status grb_set_actuator_forces(const grb_model *m, double *work, const double *force);

/* Length (m) and rate (m/s) of every actuator over rows states y (rows x 2N):
 * out[(i * A + a) * 2 + 0..1] for actuator a in row i.  Kinematics only (the
 * forces are not read); the workspace is left holding no dynamics. */
GRB_API grb_status grb_actuator_lines(const grb_model *m, int rows, const double *y, double *work, double *out);

/* Each force element's outputs (GRB_FO_*) over rows states y (rows x 2N):
 * out[((i * F + e) * GRB_FO_COUNT + o] for element e in row i.  The state alone
 * decides them (no input).  The workspace is left holding no dynamics. */
GRB_API grb_status grb_force_rows(const grb_model *m, int rows, const double *y, double *work, double *out);

/* The state equation ydot = (zd, zdd) at y; out may alias nothing in work.
 * GRB_SINGULAR (and nan accelerations) when the matrix to solve is singular. */
GRB_API grb_status grb_rhs(const grb_model *m, int method, const double *y, double tau_drive, double tau_load,
                    double *work, double *out);

/* Every output of one state (after the forward dynamics it runs itself), into
 * out[GRB_N_OBSERVED(n)]; the reactions only when want_reactions (else left as is). */
GRB_API grb_status grb_observe(const grb_model *m, int method, const double *y, double tau_drive, double tau_load,
                        int want_reactions, double *work, double *out);

/* grb_observe over rows states y (rows x 2N), efforts per row (tau_drive may be
 * NULL: then tau_drive_const), into out (rows x GRB_N_OBSERVED(n)). */
GRB_API grb_status grb_observe_rows(const grb_model *m, int method, int rows, const double *y, const double *tau_drive,
                             double tau_drive_const, double tau_load, int want_reactions, double *work, double *out);

/* World positions of points fixed to links over rows states y (rows x 2N; the
 * rates are not used): out[(i * n_points + p) * 2 + 0..1] is point p of row i,
 * local[2p] along and local[2p + 1] across the vector of moving link link[p]
 * (0-based), or the ground point local[2p..2p+1] itself where link[p] < 0.
 * GRB_BAD_ARGUMENT for a link index past the chain.  For drawing a trajectory. */
GRB_API grb_status grb_link_points_rows(const grb_model *m, int rows, const double *y, int n_points, const int *link,
                                 const double *local, double *work, double *out);

/* Closure violation phi (2C) and its Jacobian J (2C x N, row-major) at z. */
GRB_API grb_status grb_constraint(const grb_model *m, const double *z, double *phi, double *J, double *work);

/* Minimum-norm projection of y = (z, zd) onto the position and velocity
 * constraints, in place (scale: the length scale of the position tolerance). */
GRB_API grb_status grb_project(const grb_model *m, double scale, double *y, double *work);

/* Consistent assembly: hold the n_held coordinates listed in held, solve the
 * closures for the others by damped Newton from z (the user's sketch picks the
 * branch), then the rates of the others from the velocity constraint.  z and zd
 * are updated in place.  GRB_NOT_CLOSED with *closest the smallest violation
 * reached when the loop cannot close. */
GRB_API grb_status grb_assemble(const grb_model *m, int n_held, const int *held, double scale, double *z, double *zd,
                         double *closest, double *work);

/* Degrees of freedom the closures leave at z: N minus the rank of their
 * Jacobian (singular values above 1e-8 of the largest).  It exceeds the
 * Grübler count N - 2C where closure rows are redundant (a third crank on a
 * parallelogram's coupling rod); assembly holds that many coordinates. */
GRB_API grb_status grb_freedom(const grb_model *m, const double *z, double *work, int *freedom);

/* How many coordinates assembly holds at the sketch z: the closures' freedom
 * there, no fewer than the Grübler count N - 2C, and at least the drive (a
 * sketch that does not close shows no redundancy; the drive is the motion's
 * own coordinate all the same).  The library and the FMU both ask this. */
GRB_API grb_status grb_hold_count(const grb_model *m, const double *z, double *work, int *count);

/* Which coordinates assembly holds: the drive (if any), then, up to the
 * mobility n_hold, the columns of the closure Jacobian that a column-pivoted QR
 * leaves out of the best-conditioned dependent set.  Returns the count in *n_held. */
GRB_API grb_status grb_held_coordinates(const grb_model *m, int n_hold, const double *z, int *held, int *n_held,
                                 double *work);

/* -- the workspace as tables, for callers that read intermediate results ----
 * grb_evaluate fills the whole workspace at one state: the kinematic pass, the
 * mass centres, the closure rows, the mass matrix, the accelerations and the
 * closure multipliers (GRB_SINGULAR when the solve fails; the kinematics are
 * still filled).  grb_work_layout says where each table starts:
 * layout[0..6] offsets of K, Jc, J, R, M (the mass matrix), the closures'
 * Schur complement and S; layout[7..10] the columns of K, R, M and the Schur
 * complement; layout[11] the offset of the accelerations zdd (N). */
GRB_API void grb_work_layout(int n_links, int n_closures, long *layout);
GRB_API grb_status grb_evaluate(const grb_model *m, int method, const double *y, double tau_drive, double tau_load,
                         double *work);
/* Position r[0..1], bias acceleration r[2..3] and Jacobian J (2 x N) of the
 * point (lx along, ly across the link vector) of moving link k, from a
 * workspace grb_evaluate (or grb_inverse_residual) filled. */
GRB_API grb_status grb_point_on_link(const grb_model *m, double *work, int k, double lx, double ly, double *J, double *r);
/* Joint reactions (3N: Fx, Fy, Mz of each link's predecessor (parent) on it) from a
 * workspace grb_evaluate filled. */
GRB_API grb_status grb_joint_reactions(const grb_model *m, double *work, double *out);
/* Inverse dynamics residual M zdd + h - Q at (z, zd) with no drive effort:
 * what the drive and the closures must supply.  Leaves the closure rows in the
 * workspace. */
GRB_API grb_status grb_inverse_residual(const grb_model *m, const double *y, const double *zdd, double tau_load,
                                 double *work, double *out);
/* Minimum-norm least-squares solution of J x = b, J m x n row-major, with a
 * relative singular-value cut-off; returns the rank (scratch: (n + m) * m). */
GRB_API int grb_lstsq(const double *J, int m, int n, const double *b, double rcond, double *x, double *scratch);

/* Minimal coordinates (minimal.c): the whole state y = (z, zd) of a closed
 * chain from its n_ind = N - 2C independent coordinates ind[] and their rates,
 * which y holds on entry together with a nearby closed configuration of the
 * others (their branch).  Newton on the closures for the dependent
 * coordinates, then their rates from J zd = 0; y is updated in place.
 * GRB_SINGULAR when the dependent columns of J are singular (the independent
 * set does not parametrise the motion there), GRB_NOT_CLOSED when Newton does
 * not converge, GRB_BAD_ARGUMENT for a wrong count or a repeated index.  Its
 * complex twin (grubler_cs.h) carries the tangent of the constraint manifold. */
GRB_API grb_status grb_minimal_state(const grb_model *m, int n_ind, const int *ind, double scale, double *y, double *work);

/* The conditioning (smallest over largest singular value) of the closure
 * Jacobian's dependent columns below which a configuration is a change point
 * or dead centre (two assembly branches meet): linearisation and the drive
 * demand refuse it (grubler.mechanism.assembly.SINGULAR_RCOND, the same). */
#define GRB_CHANGE_POINT_RCOND 1e-4

/* The drive demand (demand.c): what the drive of a mechanism of mobility one
 * (N = 2C + 1, with a drive joint) must deliver to move its drive joint along
 * rows samples of position, velocity and acceleration, with load[k] on the
 * load joint (NULL: none).  At sample k the loop is closed with the drive held
 * at position[k], by Newton from the last sample's configuration (z_guess for
 * the first; from the third on, a secant through the last two where the
 * position moved, so that a passage through a change point keeps its branch),
 * the other rates follow from J zd = 0 and the accelerations from
 * J zdd = gamma, and the effort from the inverse dynamics
 * M zdd + h - Q = tau e_drive + J^T lambda.  Out, rows x N each: z, zd, zdd;
 * torque (rows) the drive's effort, N m or N; closing_force (rows x 2) the
 * first closure's force on its closing link, world frame, N.
 * GRB_BAD_ARGUMENT for a model that is not of that kind (*at = -1) or a
 * non-finite sample (*at = k); GRB_NOT_CLOSED when the loop cannot close at
 * sample *at (z's row there holds the guess Newton started from, *closest the
 * smallest violation reached); GRB_SINGULAR when sample *at is at a change point (the dependent
 * columns' conditioning at or below GRB_CHANGE_POINT_RCOND).  Rows before *at
 * are filled all the same. */
GRB_API grb_status grb_drive_demand(const grb_model *m, double scale, int rows, const double *position,
                                    const double *velocity, const double *acceleration, const double *load,
                                    const double *z_guess, double *z, double *zd, double *zdd, double *torque,
                                    double *closing_force, int *at, double *closest, double *work);

/* A drive effort given as a function of time (NULL: the constant tau_drive). */
typedef double (*grb_drive_fn)(void *ctx, double t);

/* How to integrate: fixed for a run (the efforts may change between advances). */
typedef struct grb_settings {
    int tableau;              /* enum grb_tableau */
    int method;               /* enum grb_method */
    int project;              /* project onto the closures after every step */
    double scale;             /* length scale of the projection's tolerance, m */
    double rtol, atol;        /* adaptive tableaus */
    double h_max;             /* largest step, s (inf: none) */
    double h_fixed;           /* rk4's step, s */
    long max_steps;           /* steps allowed per grb_advance */
    double tau_drive, tau_load;
    grb_drive_fn drive_fn;
    void *drive_ctx;
    double *passage_log;      /* where the times of change-point passages go (NULL: nowhere) */
    int passage_capacity;     /* its length; passage k goes to passage_log[k % capacity] */
} grb_settings;

/* The integrator's own state besides y and its derivative f (plain data). */
typedef struct grb_clock {
    double t;                 /* time of y */
    double h;                 /* next step (0: the integrator picks one) */
    int have_f;               /* f holds ydot at (t, y) */
    long steps, rejected, evals;
    long passages;            /* change points passed (see grb_advance) */
    double kappa_seen;        /* best closure conditioning seen so far (0: none yet) */
    long charts;              /* change-point charts built (a chart is kept from one advance to the next) */
} grb_clock;

/* Where and why an advance stopped. */
typedef struct grb_failure {
    double where, limit;
} grb_failure;

/* Doubles of integrator workspace (stages, dense output) for 2N states. */
GRB_API size_t grb_stepper_size(int tableau, int n_states);

/* Step the state equation from clock->t through the increasing times t_out,
 * recording the state at each into out (n_out x 2N).  All or nothing: y, f and
 * the clock change only when it returns GRB_OK; otherwise *why says where.
 *
 * Change points (DOP853 with the projection): where the closure's Jacobian
 * loses rank, two assembly branches meet and the equations of motion are
 * ill-conditioned, though the motion along its branch stays smooth.  A step
 * that would enter that zone is shortened to end at its edge; the zone is then
 * crossed in one step of a two-point Hermite-Obreschkoff formula, implicit in
 * the state at the far edge, whose only evaluations are at the two
 * well-conditioned edges; the far state, found by fixed-point iteration from a
 * Taylor prediction and projected onto the closure, is the one on the branch
 * the motion came along (continuity of position, velocity and acceleration).
 * Each passage is counted in the clock and its time logged.
 * work: grb_work_size doubles, stepper: grb_stepper_size doubles.  The stepper
 * also keeps the chart being followed through a change point from one advance
 * to the next (taken up again only where y lies on it): keep it, and save it
 * with y, f and the clock, as a rollback must replay the same steps. */
GRB_API grb_status grb_advance(const grb_model *m, const grb_settings *s, grb_clock *clock, double *y, double *f,
                        const double *t_out, int n_out, double *out, double *work, double *stepper,
                        grb_failure *why);

#ifdef __cplusplus
}
#endif
#endif
