/* The mechanism FMU's model: FMI variables <-> grubler kernel calls.
 *
 * No physics here: the scene's parameters become the kernel's tables
 * (grb_scene_tables), initialisation assembles the loop (grb_held_coordinates,
 * grb_assemble) as the library's Simulator does, a communication step is one
 * grb_advance (internal sub-steps to the tolerance), and the outputs are
 * grb_observe's, computed when read, by level: the drive joint's coordinate and
 * rate straight from the state (with the actuators' lines and the force
 * elements'), then every coordinate and rate from the kernel's kinematic pass,
 * then one forward-dynamics evaluation for the accelerations, forces and
 * energies, then the joint reactions.
 *
 * The parameters are validated here, with the library's messages naming the
 * field, because the library's checks are Python (grubler.mechanism.model) and the FMU
 * runs without it.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmi2_model.h"
#include "grb_scene.h"
#include "grubler.h"
#include "complex_step.h"
#include "scene_slots.h"
#include "workspace.h"  /* the kinematic pass (grb_chain) and its frame table, as grb_observe reads them */
#if MODEL_DIRECTIONAL_DERIVATIVE && GRB_HAVE_COMPLEX
#include <complex.h>

#include "grubler_cs.h"  /* the kernel over complex numbers: exact directional derivatives */
#endif

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
/* internal steps allowed per communication step: a bound against a stall, far
 * above what any tolerance needs for a step of seconds */
#ifndef GRB_FMU_MAX_STEPS
#define GRB_FMU_MAX_STEPS 10000000L  /* the library's Integrator.advance_to default */
#endif

#define N N_LINKS
#define NC N_CLOSURES
#define NS (2 * N_LINKS)
#define NA N_ACTUATORS
#define NF N_FORCES

/* The model's part of the persistent block, after the parameter and input
 * slots: its fields' indices P_* come with config.h, from the ModelSpec's state
 * layout (grubler.fmi.mechanism.run_state):
 *   P_STARTED     1: the block holds a started run (initialised or restored)
 *   P_T           time of the state
 *   P_H           the integrator's next step
 *   P_HAVE_F      f holds ydot at (t, y)
 *   P_STEPS, P_REJECTED, P_EVALS, P_PASSAGES (change points passed): counts
 *   P_KAPPA_SEEN  the best closure conditioning the run has seen (grb_clock)
 *   P_DRIVE_USED, P_LOAD_USED  the efforts f was computed with
 *   P_Y           y = (z, zd), 2N
 *   P_F           f = ydot, 2N
 *   P_ACTUATOR_FORCES_USED  the actuators' forces f was computed with (NA; only with actuators)
 *   P_STEPPER     the integrator's own workspace (written before it is read) */

/* what an output read costs: the drive's coordinate and rate (what a coupling reads each step) copied from the
 * state, with the actuators' lines and the force elements' outputs; every coordinate and rate, one kinematic
 * pass; the rest, one forward-dynamics evaluation; the reactions, that and the reaction pass */
enum { LEVEL_DRIVE = 1, LEVEL_STATE = 2, LEVEL_OBSERVE = 3, LEVEL_REACTIONS = 4 };

typedef struct mech {
    grb_model m;
    grb_settings s;
    double links[N * GRB_L_COLUMNS];
    double closures[(NC > 0 ? NC : 1) * GRB_CL_COLUMNS];
    double actuators[(NA > 0 ? NA : 1) * GRB_A_COLUMNS];
    double forces[(NF > 0 ? NF : 1) * GRB_F_COLUMNS];    /* the force elements' rows (kernel numbering) */
    double force_out[(NF > 0 ? NF : 1) * GRB_FO_COUNT];  /* their outputs at the state (grb_force_rows) */
    int revolute[N];
    int parent[N];              /* each link's predecessor, 0-based (-1 the ground) */
    int q_index[N];             /* index in q of each pair's real coordinate */
    double out[MODEL_N_OUTPUTS];
    double y_end[NS];
    double passage_log[16];     /* times of the change points one step passed, for the log */
    int held[N];
    int n_hold;
    double scale;
    double work[1];             /* grb_work_size doubles follow */
} mech;

static size_t stepper_doubles(void) {
    size_t a = grb_stepper_size(GRB_DOP853, NS), b = grb_stepper_size(GRB_RK45, NS),
           c = grb_stepper_size(GRB_RK4, NS);
    size_t m = a > b ? a : b;
    return m > c ? m : c;
}

size_t model_persistent_size(void) { return (size_t)P_STEPPER + stepper_doubles(); }
/* Scratch: the mech struct and the kernel's workspace, then (with directional
 * derivatives) the complex-step workspace, state and outputs, 16-byte aligned. */
static size_t complex_offset(void) {
    return (sizeof(mech) + grb_work_size(N, NC) * sizeof(double) + 15) & ~(size_t)15;
}
size_t model_scratch_bytes(void) {
    return complex_offset() + (MODEL_DIRECTIONAL_DERIVATIVE ? 2 * sizeof(double) * (grb_work_size(N, NC) + NS +
                                                                                     MODEL_N_OUTPUTS) : 0);
}
int model_input_free_level(void) { return LEVEL_STATE; }
const double *model_outputs(const grb_instance *inst) { return ((const mech *)inst->model)->out; }
double model_time(const grb_instance *inst) { return inst->p[P_T]; }

void model_reset(grb_instance *inst) {
    inst->p[P_STARTED] = 0.0;
    inst->p[P_T] = 0.0;
}

/* ---- parameters ------------------------------------------------------------- */

static double link_field(const double *p, int i, int f) { return p[SLOT_LINKS + i * LINK_STRIDE + f]; }
static double closure_field(const double *p, int j, int f) { return p[SLOT_CLOSURES + j * CLOSURE_STRIDE + f]; }
static double actuator_field(const double *p, int a, int f) { return p[SLOT_ACTUATORS + a * ACTUATOR_STRIDE + f]; }
/* the name of the variable in parameter or input slot `slot` (for messages) */
static const char *slot_name(int slot) {
    int v;
    for (v = 0; v < MODEL_N_VARIABLES; v++)
        if (model_variables[v].causality != GRB_C_OUTPUT && model_variables[v].slot == slot)
            return model_variables[v].name;
    return "?";
}

static const char *coordinate_name(int index, char *buf, size_t size) {
    if (index % 2 == 0)
        snprintf(buf, size, "B%d", index / 2 + 1);
    else
        snprintf(buf, size, "theta%d", index / 2 + 2);
    return buf;
}

#define BAD(...) do { grb_log(inst, fmi2Error, __VA_ARGS__); return fmi2Error; } while (0)

#if NF > 0
/* where each element's outputs come from (the kinds, parameters and names: scene_slots.h) */
static const int force_output_index[] = FORCE_OUTPUT_INDEX;
#endif

/* The scene's parameters where they lie in the block (scene_slots.h's view)
 * with the actuators, each named by its variables' prefix ("lift" of
 * lift.to_link), and the force elements, each by its parameters' prefix
 * ("strut" of strut.stiffness). */
static void mechanism_view_of(const double *p, grb_scene_view *v, char (*names)[48], const char **name_of,
                              double *force_rows) {
    static const int actuator_column[GRB_A_COLUMNS] = {AF_FROM_LINK, AF_FROM_POINT_X, AF_FROM_POINT_Y, AF_TO_LINK,
                                                       AF_TO_POINT_X, AF_TO_POINT_Y};
    int k;
    scene_view_of(p, v);
    v->n_actuators = NA;
    v->actuators = p + SLOT_ACTUATORS;
    v->actuator_stride = ACTUATOR_STRIDE;
    memcpy(v->actuator_column, actuator_column, sizeof actuator_column);
    for (k = 0; k < NA; k++) {
        char *dot;
        snprintf(names[k], 48, "%s", slot_name(SLOT_ACTUATORS + k * ACTUATOR_STRIDE + AF_TO_LINK));
        dot = strrchr(names[k], '.');
        if (dot) *dot = '\0';
        name_of[k] = names[k];
    }
    v->actuator_names = NA > 0 ? name_of : NULL;
    scene_force_view(p, v, force_rows);
}

/* The mechanism's rules (the kernel's grb_scene_check, the library's), the
 * FMU's own parameters (tolerances, steps: the library judges its runs'
 * elsewhere), then those of a started run's state.  The integer and string
 * parameters are in range here (the wrapper's value_ok, on both paths), so
 * their casts to int are safe. */
fmi2Status model_check(grb_instance *inst, const double *p) {
    int revolute[N], q_index[N];
    int i, k;
    /* every parameter a number the scene reader would take: finite, and within its bound (an actuator's
     * point at 1e300 made its length inf); the inputs are the step's to judge */
    for (k = 0; k < MODEL_N_STORED; k++)
        if (!(fabs(p[k]) <= GRB_MAX_MAGNITUDE) && k != SLOT_MOTOR_TORQUE && k != SLOT_LOAD_TORQUE &&
            !(k >= SLOT_ACTUATOR_FORCE && k < SLOT_ACTUATOR_FORCE + NA)) {
            int v;
            for (v = 0; v < MODEL_N_VARIABLES; v++)
                if (model_variables[v].causality == GRB_C_PARAMETER && model_variables[v].slot == k) {
                    if (!isfinite(p[k])) BAD("%s: must be finite, got %g", model_variables[v].name, p[k]);
                    BAD("%s: magnitude above %g is outside the supported range, got %g", model_variables[v].name,
                        GRB_MAX_MAGNITUDE, p[k]);
                }
        }
    if (!(p[SLOT_RTOL] > 0)) BAD("rtol: must be positive and finite, got %g", p[SLOT_RTOL]);
    if (!(p[SLOT_ATOL] > 0)) BAD("atol: must be positive and finite, got %g", p[SLOT_ATOL]);
    if (!(p[SLOT_MAX_STEP] >= 0)) BAD("max_step: must be >= 0 and finite, got %g", p[SLOT_MAX_STEP]);
    if ((int)p[SLOT_INTEGRATOR] == 3 && !(p[SLOT_STEP] > 0)) BAD("step: rk4's step must be positive, got %g",
                                                                  p[SLOT_STEP]);
    {
        /* the mechanism's rules: the kernel's, which the library runs too (grb_scene_check) */
        grb_scene_view view;
        grb_problem problem;
        char names[NA > 0 ? NA : 1][48];
        const char *name_of[NA > 0 ? NA : 1];
        double force_rows[(NF > 0 ? NF : 1) * GRB_F_COLUMNS];
        int found;
        mechanism_view_of(p, &view, names, name_of, force_rows);
        if (grb_scene_check(&view, &problem, 1, &found) != GRB_OK) BAD("%s: %s", problem.field, problem.reason);
    }
    for (i = 0; i < N; i++) revolute[i] = (int)link_field(p, i, LF_JOINT) == 1;
    grb_real_coordinates(N, revolute, q_index);
    /* a started run's state: what the integrator and the outputs compute with */
    if (p[P_STARTED] != 0.0 && p[P_STARTED] != 1.0) BAD("state.started: must be 0 or 1, got %g", p[P_STARTED]);
    if (p[P_STARTED] == 0.0) return fmi2OK;  /* not started: initialisation computes the state */
    if (!isfinite(p[P_T])) BAD("state.t: the time must be finite, got %g", p[P_T]);
    if (!(p[P_H] >= 0.0 && isfinite(p[P_H]))) BAD("state.h: the next step must be >= 0 and finite, got %g", p[P_H]);
    if (p[P_HAVE_F] != 0.0 && p[P_HAVE_F] != 1.0) BAD("state.have_f: must be 0 or 1, got %g", p[P_HAVE_F]);
    {
        static const char *const count[4] = {"steps", "rejected", "evals", "passages"};
        for (k = 0; k < 4; k++)
            if (!(p[P_STEPS + k] >= 0.0 && isfinite(p[P_STEPS + k])))
                BAD("state.%s: a count must be >= 0 and finite, got %g", count[k], p[P_STEPS + k]);
    }
    if (!(p[P_KAPPA_SEEN] >= 0.0 && isfinite(p[P_KAPPA_SEEN])))
        BAD("state.kappa_seen: a conditioning must be >= 0 and finite, got %g", p[P_KAPPA_SEEN]);
    if (!isfinite(p[P_DRIVE_USED])) BAD("state.drive_used: must be finite, got %g", p[P_DRIVE_USED]);
    if (!isfinite(p[P_LOAD_USED])) BAD("state.load_used: must be finite, got %g", p[P_LOAD_USED]);
    for (k = 0; k < NS; k++) {
        char buf[32];
        coordinate_name(q_index[k % N], buf, sizeof buf);
        if (!isfinite(p[P_Y + k]))
            BAD("state.%s%s: the joint state must be finite, got %g", buf, k < N ? "" : "_d", p[P_Y + k]);
        if (p[P_HAVE_F] != 0.0 && !isfinite(p[P_F + k]))
            BAD("state.f: the derivative of %s%s must be finite, got %g", buf, k < N ? "" : "_d", p[P_F + k]);
    }
    return fmi2OK;
}

/* index in z of the real joint a drive_joint / load_joint choice names (0: none -> -1);
 * model_check made sure it is a real joint */
static int joint_index(int choice) { return choice == 0 ? -1 : (choice - 1) / 2; }

static const char *status_text(int status) { return grb_status_message((grb_status)status); }

/* The kernel's model from the parameters: the scene's tables, the actuators'
 * and force elements' rows in the kernel's link numbering, the efforts' joints. */
static fmi2Status build_model(grb_instance *inst) {
    mech *mm = (mech *)inst->model;
    double *p = inst->p;
    int j, st = scene_tables_of(p, mm->revolute, mm->parent, mm->links, mm->closures);
    if (st != GRB_OK) BAD("closure: a link number is out of range");
    grb_real_coordinates(N, mm->revolute, mm->q_index);
    for (j = 0; j < NA; j++) {  /* thesis numbering to the kernel's 0-based links (-1 the ground) */
        double *row = mm->actuators + j * GRB_A_COLUMNS;
        row[GRB_A_FROM_LINK] = actuator_field(p, j, AF_FROM_LINK) - 2;
        row[GRB_A_FROM_X] = actuator_field(p, j, AF_FROM_POINT_X);
        row[GRB_A_FROM_Y] = actuator_field(p, j, AF_FROM_POINT_Y);
        row[GRB_A_TO_LINK] = actuator_field(p, j, AF_TO_LINK) - 2;
        row[GRB_A_TO_X] = actuator_field(p, j, AF_TO_POINT_X);
        row[GRB_A_TO_Y] = actuator_field(p, j, AF_TO_POINT_Y);
    }
    mm->m.n_actuators = NA;
    mm->m.actuators = NA > 0 ? mm->actuators : NULL;
    scene_force_rows_for_kernel(p, mm->forces);
    mm->m.n_forces = NF;
    mm->m.forces = NF > 0 ? mm->forces : NULL;
    mm->m.n_links = N;
    mm->m.n_closures = NC;
    mm->m.links = mm->links;
    mm->m.closures = mm->closures;
    mm->m.theta1 = p[SLOT_GROUND_THETA1];
    mm->m.gravity = p[SLOT_GRAVITY];
    mm->m.drive_inertia = p[SLOT_DRIVE_INERTIA];
    mm->m.drive = joint_index((int)p[SLOT_DRIVE_JOINT]);
    mm->m.load = joint_index((int)p[SLOT_LOAD_JOINT]);
    return fmi2OK;
}

/* How to integrate: what grubler.mechanism.simulate.Simulator sets up. */
static void integration_settings(mech *mm, const double *p) {
    int i, method = (int)p[SLOT_METHOD] == 1 ? GRB_PENALTY : GRB_EXACT;
    int tableau = (int)p[SLOT_INTEGRATOR] == 2 ? GRB_RK45 : (int)p[SLOT_INTEGRATOR] == 3 ? GRB_RK4 : GRB_DOP853;
    mm->scale = 1.0;
    for (i = 0; i < N; i++)
        if (fabs(link_field(p, i, LF_A)) > mm->scale) mm->scale = fabs(link_field(p, i, LF_A));
    memset(&mm->s, 0, sizeof mm->s);
    mm->s.tableau = tableau;
    mm->s.method = method;
    mm->s.project = method == GRB_EXACT && NC > 0;
    mm->s.scale = mm->scale;
    mm->s.rtol = p[SLOT_RTOL];
    mm->s.atol = p[SLOT_ATOL];
    mm->s.h_max = p[SLOT_MAX_STEP] > 0 ? p[SLOT_MAX_STEP] : INFINITY;
    mm->s.h_fixed = p[SLOT_STEP];
    mm->s.max_steps = GRB_FMU_MAX_STEPS;
    mm->s.drive_fn = NULL;
    mm->s.drive_ctx = NULL;
    mm->s.passage_log = mm->passage_log;
    mm->s.passage_capacity = (int)(sizeof mm->passage_log / sizeof mm->passage_log[0]);
    mm->n_hold = N - 2 * NC;  /* Grübler/Kutzbach mobility with one-DOF joints (>= 0: model_check) */
}

/* The sketch assembled (exact closure) holding the drive, into y. */
static fmi2Status assemble_start(grb_instance *inst, double *z, double *zd) {
    mech *mm = (mech *)inst->model;
    double closest = 0.0;
    char names[256];
    size_t used = 0;
    int i, n_held = 0, st = grb_hold_count(&mm->m, z, mm->work, &mm->n_hold);
    if (st != GRB_OK) BAD("initial: cannot count the coordinates to hold (%s)", status_text(st));
    st = grb_held_coordinates(&mm->m, mm->n_hold, z, mm->held, &n_held, mm->work);
    if (st != GRB_OK) BAD("initial: cannot choose the coordinates to hold (%s)", status_text(st));
    names[0] = '\0';
    for (i = 0; i < n_held && used + 40 < sizeof names; i++) {
        char buf[32];
        int w = snprintf(names + used, sizeof names - used, "%s%s = %.6g", i ? ", " : "",
                         coordinate_name(mm->q_index[mm->held[i]], buf, sizeof buf), z[mm->held[i]]);
        if (w > 0) used += (size_t)w;
    }
    st = grb_assemble(&mm->m, n_held, mm->held, mm->scale, z, zd, &closest, mm->work);
    if (st == GRB_NOT_CLOSED)
        BAD("initial: the loop cannot be closed with %s held: the closest the tip gets is %.3g from its "
            "closure", n_held ? names : "nothing", closest);
    if (st != GRB_OK) BAD("initial: assembly failed (%s)", status_text(st));
    return fmi2OK;
}

/* The penalty springs act through inertia: every real coordinate needs some
 * (grubler.simulate's check, which names the link from M's eigenvectors). */
static fmi2Status penalty_can_move(grb_instance *inst, const double *y) {
    mech *mm = (mech *)inst->model;
    double yd[NS];
    int k, finite = 1, st = grb_rhs(&mm->m, GRB_PENALTY, y, 0.0, 0.0, mm->work, yd);
    for (k = 0; k < NS; k++) finite = finite && isfinite(yd[k]);
    if (st != GRB_OK || !finite)
        BAD("method: the penalty closure cannot move the mechanism: a real coordinate carries no inertia "
            "(a link with I = 0 and its mass centre on its joint), so the imaginary joint's spring would "
            "accelerate it without bound; give that link a positive I or use the exact closure");
    return fmi2OK;
}

/* What the start state decides of the actuators and force elements (the library's checks): an actuator's
 * two points apart, a gas spring's column not used up. */
static fmi2Status elements_at_start_ok(grb_instance *inst, const double *y) {
#if N_ACTUATORS > 0 || NF > 0
    mech *mm = (mech *)inst->model;
    int i, st;
#endif
#if N_ACTUATORS > 0
    {
        double lines[2 * NA];
        st = grb_actuator_lines(&mm->m, 1, y, mm->work, lines);
        if (st != GRB_OK) BAD("actuators: %s", status_text(st));
        for (i = 0; i < NA; i++)
            if (!(lines[2 * i] > 1e-9 * mm->scale))
                BAD("%s: the actuator's two points coincide at the start (length %.3g m): its force has no line "
                    "to act along; move from_point or to_point",
                    slot_name(SLOT_ACTUATORS + i * ACTUATOR_STRIDE + AF_TO_POINT_X), lines[2 * i]);
    }
#endif
#if NF > 0
    {
        double h, length;
        i = scene_used_up_gas(&mm->m, y, mm->work, mm->force_out, &h, &length, &st);
        if (st != GRB_OK) BAD("force elements: %s", status_text(st));
        if (i >= 0)
            BAD("%s.gas_column: the gas is used up at the start: its column gas_column + length - free_length is "
                "%.4g m at the start's length %.4g m; a gas spring needs a positive column", force_name[i], h, length);
    }
#endif
#if !(N_ACTUATORS > 0 || NF > 0)
    (void)inst;
    (void)y;
#endif
    return fmi2OK;
}

/* Ready to run: the parameters checked, the model built, the integration set up
 * and, for a run not restored, the start state (the sketch, closed) and a fresh clock. */
fmi2Status model_prepare(grb_instance *inst) {
    mech *mm = (mech *)inst->model;
    double *p = inst->p, *y = p + P_Y;
    fmi2Status s;
    if ((s = model_check(inst, p)) != fmi2OK || (s = build_model(inst)) != fmi2OK) return s;
    integration_settings(mm, p);
    if (p[P_STARTED] != 0.0) return fmi2OK;  /* a restored run keeps its state */
    grb_z_from_q(N, mm->revolute, mm->parent, p[SLOT_GROUND_THETA1], p + SLOT_Q0, y);
    grb_zd_from_qd(N, mm->revolute, mm->parent, p + SLOT_QD0, y + N);
    if (mm->s.method == GRB_EXACT && NC > 0 && (s = assemble_start(inst, y, y + N)) != fmi2OK) return s;
    if (mm->s.method == GRB_PENALTY && NC > 0 && (s = penalty_can_move(inst, y)) != fmi2OK) return s;
    if ((s = elements_at_start_ok(inst, y)) != fmi2OK) return s;
    p[P_T] = inst->start_time;
    p[P_H] = 0.0;
    p[P_HAVE_F] = 0.0;
    p[P_STEPS] = p[P_REJECTED] = p[P_EVALS] = p[P_PASSAGES] = p[P_KAPPA_SEEN] = 0.0;
    p[P_DRIVE_USED] = p[P_LOAD_USED] = 0.0;
    return fmi2OK;
}

fmi2Status model_start(grb_instance *inst) {
    inst->p[P_STARTED] = 1.0;
    return fmi2OK;
}

/* ---- outputs ----------------------------------------------------------------- */

#if N_CLOSURES > 1
/* Force and moment of closures 1 .. NC-1 on their closing links (closure 0's are
 * grb_observe's Fx, Fy, Mz), into out[3 (j - 1) ..]: from the multipliers the
 * forward dynamics grb_observe just ran left in the workspace's constraint-row
 * table (grb_work_layout; its columns lambda and the line normal are the
 * kernel's R_LAM and R_NORMAL, as grubler.mechanism.simulate.closure_forces reads them). */
enum { ROW_LAM = 3, ROW_NORMAL = 4 };

/* over real numbers from grb_observe's workspace, and (with directional
 * derivatives) over complex numbers from grb_cs_observe_at's, which has the same
 * layout in complex entries: one text, two scalar types */
#define CLOSURE_FORCES(name, real)                                                                             \
    static void name(const mech *mm, const real *work, real *out) {                                            \
        long layout[12];                                                                                       \
        grb_work_layout(N, NC, layout);                                                                        \
        const real *R = work + layout[3];                                                                      \
        long rc = layout[8];                                                                                   \
        for (int j = 1; j < NC; j++) {                                                                         \
            const real *r0 = R + 2 * j * rc, *r1 = r0 + rc;                                                    \
            real *o = out + 3 * (j - 1);                                                                       \
            if (mm->closures[j * GRB_CL_COLUMNS + GRB_CL_KIND] != 0.0) { /* a line: normal force, moment */   \
                o[0] = r0[ROW_NORMAL] * r0[ROW_LAM];                                                           \
                o[1] = r1[ROW_NORMAL] * r0[ROW_LAM];                                                           \
                o[2] = r1[ROW_LAM];                                                                            \
            } else { /* a pin */                                                                               \
                o[0] = r0[ROW_LAM];                                                                            \
                o[1] = r1[ROW_LAM];                                                                            \
                o[2] = 0.0;                                                                                    \
            }                                                                                                  \
        }                                                                                                      \
    }
CLOSURE_FORCES(closure_forces, double)
#if MODEL_DIRECTIONAL_DERIVATIVE && GRB_HAVE_COMPLEX
CLOSURE_FORCES(closure_forces_cs, double complex)
#endif
#endif

fmi2Status model_compute(grb_instance *inst, int level) {
    mech *mm = (mech *)inst->model;
    const double *p = inst->p, *y = p + P_Y;
    int d = mm->m.drive, st;
    if (inst->level < LEVEL_DRIVE) {
        mm->out[N_OBSERVED] = d >= 0 ? y[d] : 0.0;
        mm->out[N_OBSERVED + 1] = d >= 0 ? y[N + d] : 0.0;
#if N_ACTUATORS > 0
        /* the actuators' lengths and rates: kinematics of the state, no input */
        st = grb_actuator_lines(&mm->m, 1, y, mm->work, mm->out + OUT_ACTUATORS);
        if (st != GRB_OK) {
            grb_log(inst, fmi2Warning, "actuators at t = %.12g s: %s", p[P_T], status_text(st));
            return fmi2Warning;
        }
#endif
#if NF > 0
        {
            /* the force elements' outputs: the state alone decides them */
            int i;
            st = grb_force_rows(&mm->m, 1, y, mm->work, mm->force_out);
            if (st != GRB_OK) {
                grb_log(inst, fmi2Warning, "force elements at t = %.12g s: %s", p[P_T], status_text(st));
                return fmi2Warning;
            }
            for (i = 0; i < N_FORCE_OUTPUTS; i++) mm->out[OUT_FORCES + i] = mm->force_out[force_output_index[i]];
        }
#endif
    }
    if (level == LEVEL_STATE && inst->level < LEVEL_STATE) {
        /* the coordinates and rates, in grb_observe's places, from the same kinematic pass it runs first (so
         * the same numbers; a level above has grb_observe write them) without evaluating the dynamics */
        grb_ws ws;
        int k;
        st = grb_ws_init(&ws, &mm->m, mm->work, GRB_FILLED_NOTHING);
        if (st != GRB_OK) {
            grb_log(inst, fmi2Warning, "coordinates at t = %.12g s: %s", p[P_T], status_text(st));
            return fmi2Warning;
        }
        grb_chain(&mm->m, y, y + N, &ws);
        for (k = 0; k < N; k++) {
            mm->out[2 * k] = ws.frame[k].slide;
            mm->out[2 * k + 1] = ws.frame[k].theta;
            mm->out[2 * N + 2 * k] = ws.frame[k].rate;
            mm->out[2 * N + 2 * k + 1] = ws.frame[k].omega;
        }
    }
    if (level >= LEVEL_OBSERVE && inst->level < level) {
#if N_ACTUATORS > 0
        st = grb_set_actuator_forces(&mm->m, mm->work, p + SLOT_ACTUATOR_FORCE);
        if (st != GRB_OK) {
            grb_log(inst, fmi2Warning, "actuator forces at t = %.12g s: %s", p[P_T], status_text(st));
            return fmi2Warning;
        }
#endif
        st = grb_observe(&mm->m, mm->s.method, y, p[SLOT_MOTOR_TORQUE], p[SLOT_LOAD_TORQUE],
                         level >= LEVEL_REACTIONS, mm->work, mm->out);
        if (st != GRB_OK) {
            grb_log(inst, fmi2Warning, "outputs at t = %.12g s: %s; they read as NaN", p[P_T], status_text(st));
            return fmi2Warning;
        }
#if N_CLOSURES > 1
        if (level >= LEVEL_REACTIONS) closure_forces(mm, mm->work, mm->out + N_OBSERVED + 2);
#endif
    }
    return fmi2OK;
}

/* ---- stepping ---------------------------------------------------------------- */

fmi2Status model_do_step(grb_instance *inst, double t_now, double h) {
    mech *mm = (mech *)inst->model;
    double *p = inst->p, t = p[P_T], t_out = t_now + h;  /* the library's advance_to(t + h) */
    double drive = p[SLOT_MOTOR_TORQUE], load = p[SLOT_LOAD_TORQUE];
    grb_clock clock;
    grb_failure why = {0.0, 0.0};
    int st;
    if (!isfinite(drive) || !isfinite(load)) {
        const char *name = !isfinite(drive) ? "motor_torque" : "load_torque";
        grb_log(inst, fmi2Discard, "%s is %g at t = %.12g s: inputs must be finite", name,
                !isfinite(drive) ? drive : load, t);
        return fmi2Discard;
    }
    /* the state derivative held depends on the efforts it was computed with */
    if (drive != p[P_DRIVE_USED] || load != p[P_LOAD_USED]) {
        p[P_HAVE_F] = 0.0;
        p[P_DRIVE_USED] = drive;
        p[P_LOAD_USED] = load;
    }
#if N_ACTUATORS > 0
    {
        int a;
        for (a = 0; a < NA; a++) {
            double force = p[SLOT_ACTUATOR_FORCE + a];
            if (!isfinite(force)) {
                grb_log(inst, fmi2Discard, "%s is %g at t = %.12g s: inputs must be finite",
                        slot_name(SLOT_ACTUATOR_FORCE + a), force, t);
                return fmi2Discard;
            }
            if (force != p[P_ACTUATOR_FORCES_USED + a]) {
                p[P_HAVE_F] = 0.0;
                p[P_ACTUATOR_FORCES_USED + a] = force;
            }
        }
        st = grb_set_actuator_forces(&mm->m, mm->work, p + SLOT_ACTUATOR_FORCE);
        if (st != GRB_OK) {
            grb_log(inst, fmi2Discard, "actuator forces at t = %.12g s: %s", t, status_text(st));
            return fmi2Discard;
        }
    }
#endif
    mm->s.tau_drive = drive;
    mm->s.tau_load = load;
    /* as grubler.mechanism.integrators.Integrator._advance: the counts are per advance */
    clock.t = t;
    clock.h = mm->s.tableau == GRB_RK4 ? 0.0 : p[P_H];
    clock.have_f = p[P_HAVE_F] != 0.0;
    clock.steps = clock.rejected = clock.evals = clock.passages = clock.charts = 0;
    clock.kappa_seen = p[P_KAPPA_SEEN];
    st = grb_advance(&mm->m, &mm->s, &clock, p + P_Y, p + P_F, &t_out, 1, mm->y_end, mm->work, p + P_STEPPER, &why);
    if (st != GRB_OK) {
        grb_log(inst, fmi2Discard, "step from t = %.12g s failed at t = %.12g s: %s (limit %g); the mechanism stays "
                "at t = %.12g s", t, why.where, status_text(st), why.limit, t);
        return fmi2Discard;
    }
    p[P_T] = clock.t;
    if (mm->s.tableau != GRB_RK4) p[P_H] = clock.h;
    p[P_HAVE_F] = clock.have_f ? 1.0 : 0.0;
    p[P_STEPS] += (double)clock.steps;
    p[P_REJECTED] += (double)clock.rejected;
    p[P_EVALS] += (double)clock.evals;
    p[P_KAPPA_SEEN] = clock.kappa_seen;
    if (clock.passages > 0) {
        /* the exact closure carried the motion through a change point on its
         * branch: say when (the log keeps the last ones of a long step) */
        long k, cap = mm->s.passage_capacity, first = clock.passages > cap ? clock.passages - cap : 0;
        for (k = first; k < clock.passages; k++)
            grb_log(inst, fmi2OK, "passed a change point (two assembly branches meet) at t = %.9g s, staying on "
                    "the branch it came along (change point %.0f of the run)", mm->passage_log[k % cap],
                    p[P_PASSAGES] + (double)(k + 1));
        p[P_PASSAGES] += (double)clock.passages;
    }
    inst->level = 0;
    return fmi2OK;
}

/* ---- directional derivatives ------------------------------------------------- */

#if MODEL_DIRECTIONAL_DERIVATIVE
#if GRB_HAVE_COMPLEX
/* Complex step: any tiny h gives the exact slope (kernel/real.h). */
#define CS_STEP 1e-30

/* The slope of every output along the efforts' direction seed: the kernel's
 * observations compiled over complex numbers (grb_cs_observe_at, the same
 * equations grb_observe runs) at the present state, with the efforts moved by
 * i h times the seed, and the other closures' forces from its multipliers as
 * model_compute takes them; the imaginary parts over h are the exact
 * derivatives. */
static int output_slopes(grb_instance *inst, const double seed[2 + NA], double *slope) {
    mech *mm = (mech *)inst->model;
    const double *p = inst->p, *y = p + P_Y;
    double complex *cwork = (double complex *)((char *)inst->model + complex_offset());
    double complex *cy = cwork + grb_work_size(N, NC), *cout = cy + NS, efforts[2];
    int i, st;
    for (i = 0; i < NS; i++) cy[i] = y[i];
    efforts[0] = p[SLOT_MOTOR_TORQUE] + I * (CS_STEP * seed[0]);
    efforts[1] = p[SLOT_LOAD_TORQUE] + I * (CS_STEP * seed[1]);
#if N_ACTUATORS > 0
    {
        double complex forces[NA];
        for (i = 0; i < NA; i++) forces[i] = p[SLOT_ACTUATOR_FORCE + i] + I * (CS_STEP * seed[2 + i]);
        st = grb_cs_set_actuator_forces(&mm->m, cwork, forces);
        if (st != GRB_OK) return st;
    }
#endif
    st = grb_cs_observe_at(&mm->m, mm->s.method, cy, efforts, 1, cwork, cout);
    cout[N_OBSERVED] = cout[N_OBSERVED + 1] = 0.0;  /* drive_angle, drive_speed: states */
    for (i = 0; i < 2 * NA; i++) cout[OUT_ACTUATORS + i] = 0.0;  /* the actuators' lengths and rates: states */
    for (i = 0; i < N_FORCE_OUTPUTS; i++) cout[OUT_FORCES + i] = 0.0;  /* the force elements': states */
#if N_CLOSURES > 1
    closure_forces_cs(mm, cwork, cout + N_OBSERVED + 2);
#endif
    for (i = 0; i < MODEL_N_OUTPUTS; i++) slope[i] = cimag(cout[i]) / CS_STEP;
    return st;
}
#else
/* Without C99 complex arithmetic (Visual Studio's C): at a fixed state every
 * output is affine in the efforts, since they enter only the right-hand side
 * of the forward dynamics' linear solve, whose matrix, pivots and dropped
 * closure directions depend on the state alone, and the reactions, forces and
 * power are linear in its solution.  So two evaluations a step s apart differ
 * by s times the slope; with s = 2^100, the rest of each output (gravity, the
 * present efforts' share) rounds away against the moved one and the
 * difference over s carries the rounding of one evaluation, as the complex
 * step's imaginary part does.  The scratch that holds the complex workspace
 * holds the real one and both evaluations' outputs. */
static int output_slopes(grb_instance *inst, const double seed[2 + NA], double *slope) {
    mech *mm = (mech *)inst->model;
    const double *p = inst->p, *y = p + P_Y;
    double *work = (double *)((char *)inst->model + complex_offset());
    double *at = work + grb_work_size(N, NC), *moved = at + MODEL_N_OUTPUTS, s = ldexp(1.0, 100);
    int i, st, moved_st;
#if N_ACTUATORS > 0
    double forces[NA];
    st = grb_set_actuator_forces(&mm->m, work, p + SLOT_ACTUATOR_FORCE);
    if (st != GRB_OK) return st;
#endif
    st = grb_observe(&mm->m, mm->s.method, y, p[SLOT_MOTOR_TORQUE], p[SLOT_LOAD_TORQUE], 1, work, at);
#if N_CLOSURES > 1
    closure_forces(mm, work, at + N_OBSERVED + 2);
#endif
#if N_ACTUATORS > 0
    for (i = 0; i < NA; i++) forces[i] = p[SLOT_ACTUATOR_FORCE + i] + s * seed[2 + i];
    moved_st = grb_set_actuator_forces(&mm->m, work, forces);
    if (moved_st != GRB_OK) return moved_st;
#endif
    moved_st = grb_observe(&mm->m, mm->s.method, y, p[SLOT_MOTOR_TORQUE] + s * seed[0],
                           p[SLOT_LOAD_TORQUE] + s * seed[1], 1, work, moved);
#if N_CLOSURES > 1
    closure_forces(mm, work, moved + N_OBSERVED + 2);
#endif
    /* states: the drive joint's angle and speed, the actuators' lengths and rates */
    at[N_OBSERVED] = at[N_OBSERVED + 1] = moved[N_OBSERVED] = moved[N_OBSERVED + 1] = 0.0;
    for (i = 0; i < 2 * NA; i++) at[OUT_ACTUATORS + i] = moved[OUT_ACTUATORS + i] = 0.0;
    for (i = 0; i < N_FORCE_OUTPUTS; i++) at[OUT_FORCES + i] = moved[OUT_FORCES + i] = 0.0;
    for (i = 0; i < MODEL_N_OUTPUTS; i++) slope[i] = (moved[i] - at[i]) / s;
    return st != GRB_OK ? st : moved_st;
}
#endif

/* d(outputs)/d(motor_torque, load_torque, actuator forces) along the seed
 * (output_slopes); the drive joint's angle and speed and the actuators' lengths
 * and rates are states, with slope zero. */
fmi2Status model_directional_derivative(grb_instance *inst, const fmi2ValueReference unknown[], size_t n_unknown,
                                        const fmi2ValueReference known[], size_t n_known, const fmi2Real dv_known[],
                                        fmi2Real dv_unknown[]) {
    const double *p = inst->p;
    double seed[2 + NA], slope[MODEL_N_OUTPUTS];  /* motor_torque, load_torque, then each actuator's force */
    size_t k;
    int i, st;
    for (i = 0; i < 2 + NA; i++) seed[i] = 0.0;
    for (k = 0; k < n_known; k++) {
        int slot = model_variables[known[k] - 1].slot;
        seed[slot == SLOT_MOTOR_TORQUE ? 0 : slot == SLOT_LOAD_TORQUE ? 1 : 2 + (slot - SLOT_ACTUATOR_FORCE)] +=
            dv_known[k];
    }
    st = output_slopes(inst, seed, slope);
    for (k = 0; k < n_unknown; k++) dv_unknown[k] = slope[model_variables[unknown[k] - 1].slot];
    if (st != GRB_OK) {
        grb_log(inst, fmi2Warning, "directional derivative at t = %.12g s: %s; it reads as NaN", p[P_T],
                status_text(st));
        return fmi2Warning;
    }
    return fmi2OK;
}
#endif
