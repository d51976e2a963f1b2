/* The spatial mechanism FMU's model: FMI variables <-> the spatial kernel
 * (kernel/spatial, grubler_spatial.h).
 *
 * No physics here.  The shape (links, their joint kinds and parents, the
 * closures' kinds and links) is fixed at export (config.h, from
 * grubler.fmi.spatial); every number is a parameter, copied into the kernel's
 * link and closure tables and judged by the kernel's own check (grs_check),
 * whose refusal is logged naming the parameter.  Initialisation closes the
 * sketch holding the drive joint (grs_assemble, as
 * SpatialMechanism.assembled_start); a communication step is one grs_advance
 * to its end (DOP853, projected onto the closures after every step), the
 * efforts held; the outputs are computed when read, by level: the state's
 * (coordinates, rates, closure violation), then the forward dynamics'
 * (accelerations, energies), then every reaction (grs_reactions).
 *
 * Memory: the persistent block holds the run (a flag, t, the next step, the
 * step count, y) and the integrator's stepper, whose stages grs_advance
 * rewrites (it recomputes the derivative at the state it starts from) but
 * which carries the change-point chart and the watch's reference conditioning
 * from one step to the next; the kernel's workspace is scratch, written before
 * it is read.  So a restored state steps on exactly as the run it came from.
 * Nothing is on the stack beyond a few scalars: the tables live in the
 * instance's scratch. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmi2_model.h"
#include "grubler_spatial.h"

#ifndef GRB_FMU_MAX_STEPS
#define GRB_FMU_MAX_STEPS 10000000L /* internal steps per communication step: a bound against a stall */
#endif

#define NL N_LINKS
#define NC N_CLOSURES
#define N N_COORDS
#define NS (2 * N_COORDS)
#define NR N_ROWS
#define NC1 (NC > 0 ? NC : 1)
#define NR1 (NR > 0 ? NR : 1)

/* The model's part of the persistent block (config.h's P_*, from grubler.fmi.spatial.run_state):
 *   P_STARTED  1: the block holds a started run (initialised or restored)
 *   P_T        time of the state
 *   P_H        the integrator's next step (0: it picks one)
 *   P_STEPS    accepted internal steps so far
 *   P_Y        y = (z, zd), 2 N
 *   P_STEPPER  the integrator's stepper (grs_stepper_size): its stages are rewritten by every advance, but
 *              it carries the change-point chart being followed and the best closure conditioning seen
 *              (the watch's reference) from one step to the next, so a restored state steps on as the run
 *              it came from did, through a change point too */

enum { LEVEL_STATE = 1, LEVEL_DYNAMICS = 2, LEVEL_REACTIONS = 3 };

/* the shape, fixed at export: read-only tables */
static const int link_column[LINK_STRIDE] = LINK_COLUMN; /* each link parameter's column in grs_link */
static const int link_revolute[NL] = LINK_REVOLUTE;
static const int link_prismatic[NL] = LINK_PRISMATIC;
static const int link_parent[NL] = LINK_PARENT;
#if NC > 0
static const int closure_kind[NC] = CLOSURE_KIND;
static const int closure_link[NC] = CLOSURE_LINK;
static const int closure_to[NC] = CLOSURE_TO;
#endif

typedef struct spatial {
    grs_model m;
    grs_settings s;
    double links[NL * GRS_L_COLUMNS];
    double closures[NC1 * GRS_CL_COLUMNS];
    /* model_check's own tables: a block is judged before it is installed */
    double check_links[NL * GRS_L_COLUMNS];
    double check_closures[NC1 * GRS_CL_COLUMNS];
    double tau[N];              /* the generalised efforts of the present inputs */
    double out[MODEL_N_OUTPUTS];
    double at[MODEL_N_OUTPUTS], moved[MODEL_N_OUTPUTS]; /* the directional derivative's two evaluations */
    double phi[NR1];
    double closure_out[NC1 * 6], joint_out[NL * 6];
    double y_end[NS];
    double seed[N];             /* the directional derivative's direction, per coordinate */
    double scale;
    int drive; /* the drive joint's coordinate */
} spatial;

/* the kernel's workspace (grs_work_size_for) after the struct; the integrator's stepper is persistent */
static size_t struct_bytes(void) { return (sizeof(spatial) + 15) & ~(size_t)15; }
static size_t work_doubles(void) { return grs_work_size_for(NL, N, NR); }
static double *work_of(const grb_instance *inst) { return (double *)((char *)inst->model + struct_bytes()); }
static double *stepper_of(const grb_instance *inst) { return inst->p + P_STEPPER; }

size_t model_persistent_size(void) { return (size_t)P_STEPPER + grs_stepper_size(GRB_DOP853, N); }
size_t model_scratch_bytes(void) { return struct_bytes() + work_doubles() * sizeof(double); }
int model_input_free_level(void) { return LEVEL_STATE; }
const double *model_outputs(const grb_instance *inst) { return ((const spatial *)inst->model)->out; }
double model_time(const grb_instance *inst) { return inst->p[P_T]; }

void model_reset(grb_instance *inst) {
    inst->p[P_STARTED] = 0.0;
    inst->p[P_T] = 0.0;
}

#define BAD(...) do { grb_log(inst, fmi2Error, __VA_ARGS__); return fmi2Error; } while (0)

/* ---- parameters ------------------------------------------------------------- */

/* the name of the variable in parameter or input slot `slot` (for messages) */
static const char *slot_name(int slot) {
    int v;
    for (v = 0; v < MODEL_N_VARIABLES; v++)
        if (model_variables[v].causality != GRB_C_OUTPUT && model_variables[v].slot == slot)
            return model_variables[v].name;
    return "?";
}

/* coordinate i's name: its initial.<name> parameter's, "initial." left off */
static const char *coordinate_name(int i) { return slot_name(SLOT_Z0 + i) + 8; }

/* the link whose joint moves coordinate i (a link's theta before its d, as the kernel counts) */
static int coordinate_link(int i) {
    int k, c = 0;
    for (k = 0; k < NL; k++) {
        c += link_revolute[k] + link_prismatic[k];
        if (i < c) return k;
    }
    return -1;
}
/* is coordinate i a slide (a link's d) rather than a rotation (its theta)? */
static int is_slide(int i) {
    int k, c = 0;
    for (k = 0; k < NL; k++) {
        if (link_revolute[k] && c++ == i) return 0;
        if (link_prismatic[k] && c++ == i) return 1;
    }
    return 0;
}

/* The kernel's tables from a block: the shape's fixed columns, the parameters in theirs, the motor's
 * reflected inertia a disc on the drive joint's axis (J about it, J/2 across: a real body's tensor);
 * and the projection's length scale as SpatialMechanism takes it. */
static void tables_of(const double *p, double *links, double *closures, double *scale) {
    int k, f, j, i, drive = (int)p[SLOT_DRIVE_JOINT], dl = coordinate_link(drive);
    double top = 0.0;
    for (k = 0; k < NL; k++) {
        double *row = links + k * GRS_L_COLUMNS;
        for (f = 0; f < GRS_L_COLUMNS; f++) row[f] = 0.0;
        row[GRS_L_REV] = link_revolute[k];
        row[GRS_L_PRIS] = link_prismatic[k];
        row[GRS_L_PARENT] = link_parent[k];
        for (f = 0; f < LINK_STRIDE; f++) row[link_column[f]] = p[SLOT_LINKS + k * LINK_STRIDE + f];
        if (fabs(row[GRS_L_A]) + fabs(row[GRS_L_D]) > top) top = fabs(row[GRS_L_A]) + fabs(row[GRS_L_D]);
    }
    if (p[SLOT_DRIVE_INERTIA] > 0.0 && dl >= 0) {
        double *I = links + dl * GRS_L_COLUMNS + GRS_L_INERTIA; /* xx, xy, xz, yy, yz, zz */
        I[0] += 0.5 * p[SLOT_DRIVE_INERTIA];
        I[3] += 0.5 * p[SLOT_DRIVE_INERTIA];
        I[5] += p[SLOT_DRIVE_INERTIA];
    }
    for (j = 0; j < NC; j++) {
        double *row = closures + j * GRS_CL_COLUMNS, point = 0.0;
#if NC > 0
        row[GRS_CL_KIND] = closure_kind[j];
        row[GRS_CL_LINK] = closure_link[j];
        row[GRS_CL_TO] = closure_to[j];
#endif
        for (i = 0; i < CLOSURE_STRIDE; i++) row[GRS_CL_POINT + i] = p[SLOT_CLOSURES + j * CLOSURE_STRIDE + i];
        for (i = 0; i < 3; i++)
            if (fabs(row[GRS_CL_POINT + i]) > point) point = fabs(row[GRS_CL_POINT + i]);
        if (point > top) top = point;
    }
    *scale = top > 1e-3 ? top : 1e-3;
}

static void model_of(grs_model *m, const double *p, const double *links, const double *closures) {
    m->n_links = NL;
    m->n_closures = NC;
    m->links = links;
    m->closures = NC > 0 ? closures : NULL;
    m->gravity[0] = p[SLOT_GRAVITY_X];
    m->gravity[1] = p[SLOT_GRAVITY_Y];
    m->gravity[2] = p[SLOT_GRAVITY_Z];
}

/* What grs_check refused, in the parameters' names: a link's column, a closure's, or gravity. */
static fmi2Status refused(grb_instance *inst, const double *rows, int row, int column) {
    static const char *const reason[GRS_L_COLUMNS] = {
        [GRS_L_M] = "a mass must be >= 0", [GRS_L_DAMP_R] = "a damping must be >= 0",
        [GRS_L_DAMP_P] = "a damping must be >= 0"};
    int f;
    if (column == -2) BAD("gravity_x, gravity_y, gravity_z: must be finite");
    if (row >= 0 && column == GRS_L_INERTIA) {
        const double *I = rows + row * GRS_L_COLUMNS + GRS_L_INERTIA;
        /* the tensor's six parameters are the link's fields 8 .. 13 (grubler.fmi.spatial.LINK_FIELDS) */
        BAD("%s .. %s: not a real body's inertia tensor about its mass centre (positive semi-definite, each "
            "principal moment at most the sum of the others), got xx %g, xy %g, xz %g, yy %g, yz %g, zz %g",
            slot_name(SLOT_LINKS + row * LINK_STRIDE + 8), slot_name(SLOT_LINKS + row * LINK_STRIDE + 13), I[0],
            I[1], I[2], I[3], I[4], I[5]);
    }
    if (row >= 0) {
        for (f = 0; f < LINK_STRIDE; f++)
            if (link_column[f] == column)
                BAD("%s: %s, got %g", slot_name(SLOT_LINKS + row * LINK_STRIDE + f),
                    reason[column] ? reason[column] : "must be a finite number", rows[row * GRS_L_COLUMNS + column]);
        BAD("link %d: the kernel refuses its row (column %d)", row, column);
    }
    {
        int j = -1 - row;
        if (column == GRS_CL_AXIS || column == GRS_CL_TO_AXIS) {
            int first = SLOT_CLOSURES + j * CLOSURE_STRIDE + (column - GRS_CL_POINT);
            BAD("%s, %s, %s: an axis must be a unit vector", slot_name(first), slot_name(first + 1),
                slot_name(first + 2));
        }
        if (column >= GRS_CL_POINT && column < GRS_CL_COLUMNS)
            BAD("%s: must be a finite number", slot_name(SLOT_CLOSURES + j * CLOSURE_STRIDE + column - GRS_CL_POINT));
        BAD("closure %d: the kernel refuses its row (column %d)", j, column);
    }
}

/* The parameters (every number finite and in range, the tolerances, the kernel's rules for the model)
 * and, when the block holds a started run, its state (finite, on the closures).  The string parameter is
 * in range here (the wrapper's value_ok). */
fmi2Status model_check(grb_instance *inst, const double *p) {
    spatial *sm = (spatial *)inst->model;
    grs_model m;
    double scale;
    int k, row = 0, column = 0, drive = (int)p[SLOT_DRIVE_JOINT];
    for (k = 0; k < SLOT_MOTOR_TORQUE; k++) /* the inputs are the step's to judge */
        if (!(fabs(p[k]) <= GRB_MAX_MAGNITUDE)) {
            if (!isfinite(p[k])) BAD("%s: must be finite, got %g", slot_name(k), p[k]);
            BAD("%s: magnitude above %g is outside the supported range, got %g", slot_name(k), GRB_MAX_MAGNITUDE,
                p[k]);
        }
    if (!(p[SLOT_RTOL] > 0)) BAD("rtol: must be positive, got %g", p[SLOT_RTOL]);
    if (!(p[SLOT_ATOL] > 0)) BAD("atol: must be positive, got %g", p[SLOT_ATOL]);
    if (!(p[SLOT_MAX_STEP] >= 0)) BAD("max_step: must be >= 0 (0: no limit), got %g", p[SLOT_MAX_STEP]);
    if (!(p[SLOT_DRIVE_INERTIA] >= 0)) BAD("drive.inertia: must be >= 0, got %g", p[SLOT_DRIVE_INERTIA]);
    if (p[SLOT_DRIVE_INERTIA] > 0 && is_slide(drive))
        BAD("drive.inertia: the drive joint %s is a slide, where a reflected inertia is a mass: set 0 and add "
            "it to the link's mass", coordinate_name(drive));
    tables_of(p, sm->check_links, sm->check_closures, &scale);
    model_of(&m, p, sm->check_links, sm->check_closures);
    if (grs_check(&m, &row, &column) != GRB_OK) return refused(inst, sm->check_links, row, column);
    /* a started run's state: what the integrator and the outputs compute with */
    if (p[P_STARTED] != 0.0 && p[P_STARTED] != 1.0) BAD("state.started: must be 0 or 1, got %g", p[P_STARTED]);
    if (p[P_STARTED] == 0.0) return fmi2OK; /* not started: initialisation computes the state */
    if (!isfinite(p[P_T])) BAD("state.t: the time must be finite, got %g", p[P_T]);
    if (!(p[P_H] >= 0.0 && isfinite(p[P_H]))) BAD("state.h: the next step must be >= 0 and finite, got %g", p[P_H]);
    if (!(p[P_STEPS] >= 0.0 && isfinite(p[P_STEPS]))) BAD("state.steps: a count must be >= 0, got %g", p[P_STEPS]);
    for (k = 0; k < NS; k++)
        if (!(fabs(p[P_Y + k]) <= GRB_MAX_MAGNITUDE))
            BAD("state.%s%s: the joint state must be finite and in range, got %g", coordinate_name(k % N),
                k < N ? "" : "_d", p[P_Y + k]);
    if (NR > 0) {
        /* on the closures, as SpatialMechanism.simulate asks of its start: a state off them is no state of
         * this mechanism (the first projection would jump) */
        double worst = 0.0;
        int st = grs_constraint(&m, p + P_Y, sm->phi, NULL, work_of(inst));
        for (k = 0; k < NR; k++)
            if (!(fabs(sm->phi[k]) <= worst)) worst = fabs(sm->phi[k]);
        if (st != GRB_OK || !(worst <= 1e-9 * scale))
            BAD("state.y: the joint state does not close the loops (violation %.3g m, allowed %.3g m): not a state "
                "of this mechanism", worst, 1e-9 * scale);
    }
    return fmi2OK;
}

/* Ready to run: the parameters checked, the model built, the integrator set, and for a run not restored
 * the start (the sketch closed holding the drive joint, the rates made consistent). */
fmi2Status model_prepare(grb_instance *inst) {
    spatial *sm = (spatial *)inst->model;
    double *p = inst->p, *y = p + P_Y, closest = 0.0;
    int i, held, st;
    fmi2Status s = model_check(inst, p);
    if (s != fmi2OK) return s;
    tables_of(p, sm->links, sm->closures, &sm->scale);
    model_of(&sm->m, p, sm->links, sm->closures);
    sm->drive = (int)p[SLOT_DRIVE_JOINT];
    memset(&sm->s, 0, sizeof sm->s);
    sm->s.tableau = GRB_DOP853;
    sm->s.rtol = p[SLOT_RTOL];
    sm->s.atol = p[SLOT_ATOL];
    sm->s.h_max = p[SLOT_MAX_STEP] > 0 ? p[SLOT_MAX_STEP] : INFINITY;
    sm->s.max_steps = GRB_FMU_MAX_STEPS;
    sm->s.scale = sm->scale;
    sm->s.tau = sm->tau;
    if (p[P_STARTED] != 0.0) return fmi2OK; /* a restored run keeps its state */
    for (i = 0; i < NS; i++) y[i] = p[SLOT_Z0 + i];
    held = sm->drive;
    st = grs_assemble(&sm->m, 1, &held, sm->scale, y, y + N, &closest, work_of(inst));
    if (st == GRB_NOT_CLOSED && closest == 2.0)
        BAD("initial: the loops close near this sketch only with a revolute or cylindrical closure's axes reversed "
            "(another joint than the model's): start the sketch nearer the intended branch");
    if (st == GRB_NOT_CLOSED)
        BAD("initial: the loops cannot be closed near this sketch with %s = %.6g held (closest violation %.3g m)",
            coordinate_name(held), p[SLOT_Z0 + held], closest);
    if (st != GRB_OK) BAD("initial: assembly failed (%s)", grb_status_message((grb_status)st));
    p[P_T] = inst->start_time;
    p[P_H] = 0.0;
    p[P_STEPS] = 0.0;
    /* a new run follows no chart and has seen no conditioning yet */
    memset(stepper_of(inst), 0, grs_stepper_size(GRB_DOP853, N) * sizeof(double));
    return fmi2OK;
}

fmi2Status model_start(grb_instance *inst) {
    inst->p[P_STARTED] = 1.0;
    return fmi2OK;
}

/* ---- outputs ----------------------------------------------------------------- */

/* the generalised efforts of inputs (effort.* plus motor_torque on the drive joint) into tau */
static void efforts_of(const spatial *sm, const double *p, double *tau) {
    int i;
    for (i = 0; i < N; i++) tau[i] = p[SLOT_EFFORTS + i];
    tau[sm->drive] += p[SLOT_MOTOR_TORQUE];
}

/* The outputs that depend on the efforts (accelerations, energies, every reaction) at the state y
 * with efforts tau, into out; level says how far. */
static int effort_outputs(grb_instance *inst, const double *y, const double *tau, int level, double *out) {
    spatial *sm = (spatial *)inst->model;
    int i, st = grs_dynamics(&sm->m, y, tau, work_of(inst), out + OUT_ZDD, NULL, out + OUT_ENERGY);
    if (st != GRB_OK || level < LEVEL_REACTIONS) return st;
    st = grs_reactions(&sm->m, y, tau, work_of(inst), sm->closure_out, sm->joint_out);
    for (i = 0; i < 6 * NC; i++) out[OUT_CLOSURES + i] = sm->closure_out[i];
    for (i = 0; i < 6 * NL; i++) out[OUT_JOINTS + i] = sm->joint_out[i];
    return st;
}

fmi2Status model_compute(grb_instance *inst, int level) {
    spatial *sm = (spatial *)inst->model;
    const double *p = inst->p, *y = p + P_Y;
    int i, st;
    if (inst->level < LEVEL_STATE) {
        double worst = 0.0;
        for (i = 0; i < NS; i++) sm->out[i] = y[i];
        sm->out[OUT_DRIVE] = y[sm->drive];
        sm->out[OUT_DRIVE + 1] = y[N + sm->drive];
        if (NR > 0) {
            st = grs_constraint(&sm->m, y, sm->phi, NULL, work_of(inst));
            for (i = 0; i < NR; i++)
                if (fabs(sm->phi[i]) > worst) worst = fabs(sm->phi[i]);
            if (st != GRB_OK) worst = NAN;
        }
        sm->out[OUT_CLOSURE_ERROR] = worst;
    }
    if (level >= LEVEL_DYNAMICS && inst->level < level) {
        efforts_of(sm, p, sm->tau);
        st = effort_outputs(inst, y, sm->tau, level, sm->out);
        if (st != GRB_OK) {
            grb_log(inst, fmi2Warning, "outputs at t = %.12g s: %s; they read as NaN", p[P_T],
                    grb_status_message((grb_status)st));
            return fmi2Warning;
        }
    }
    return fmi2OK;
}

/* ---- stepping ---------------------------------------------------------------- */

fmi2Status model_do_step(grb_instance *inst, double t_now, double h) {
    spatial *sm = (spatial *)inst->model;
    double *p = inst->p, t = p[P_T], t_out = t_now + h, where = t, step = p[P_H];
    long steps = 0;
    int i, st;
    for (i = SLOT_MOTOR_TORQUE; i < SLOT_EFFORTS + N; i++)
        if (!isfinite(p[i])) {
            grb_log(inst, fmi2Discard, "%s is %g at t = %.12g s: inputs must be finite", slot_name(i), p[i], t);
            return fmi2Discard;
        }
    efforts_of(sm, p, sm->tau);
    st = grs_advance(&sm->m, &sm->s, &t, &step, &steps, p + P_Y, &t_out, 1, sm->y_end, work_of(inst),
                     stepper_of(inst), &where);
    if (st != GRB_OK) {
        grb_log(inst, fmi2Discard, "step from t = %.12g s failed at t = %.12g s: %s; the mechanism stays at t = "
                "%.12g s", p[P_T], where, grb_status_message((grb_status)st), p[P_T]);
        return fmi2Discard;
    }
    p[P_T] = t;
    p[P_H] = step;
    p[P_STEPS] += (double)steps;
    inst->level = 0;
    return fmi2OK;
}

/* ---- directional derivatives ------------------------------------------------- */

/* At a fixed state every output is affine in the efforts: they enter only the
 * right-hand side of the forward dynamics' solve, whose matrix, pivots and
 * dropped closure directions (the minimum-norm multipliers of an
 * overconstrained loop) depend on the state alone, and the reactions are
 * linear in its solution (the planar model's fallback, mechanism_model.c,
 * argues the same).  So two evaluations a step s apart differ by s times the
 * slope; with s = 2^100 the rest of each output (gravity, the present
 * efforts' share) rounds away against the moved one, and the difference over
 * s carries the rounding of one evaluation.  The state's outputs have slope 0. */
fmi2Status model_directional_derivative(grb_instance *inst, const fmi2ValueReference unknown[], size_t n_unknown,
                                        const fmi2ValueReference known[], size_t n_known, const fmi2Real dv_known[],
                                        fmi2Real dv_unknown[]) {
    spatial *sm = (spatial *)inst->model;
    const double *p = inst->p, *y = p + P_Y;
    double s = ldexp(1.0, 100), *seed = sm->seed;
    size_t k;
    int i, st, moved_st;
    for (i = 0; i < N; i++) seed[i] = 0.0;
    for (k = 0; k < n_known; k++) {
        int slot = model_variables[known[k] - 1].slot;
        seed[slot == SLOT_MOTOR_TORQUE ? sm->drive : slot - SLOT_EFFORTS] += dv_known[k];
    }
    for (i = 0; i < MODEL_N_OUTPUTS; i++) sm->at[i] = sm->moved[i] = 0.0;
    efforts_of(sm, p, sm->tau);
    st = effort_outputs(inst, y, sm->tau, LEVEL_REACTIONS, sm->at);
    for (i = 0; i < N; i++) sm->tau[i] += s * seed[i];
    moved_st = effort_outputs(inst, y, sm->tau, LEVEL_REACTIONS, sm->moved);
    efforts_of(sm, p, sm->tau);
    /* the state's outputs and the energies: no slope */
    for (i = 0; i < OUT_ZDD; i++) sm->at[i] = sm->moved[i] = 0.0;
    sm->at[OUT_ENERGY] = sm->moved[OUT_ENERGY] = sm->at[OUT_ENERGY + 1] = sm->moved[OUT_ENERGY + 1] = 0.0;
    for (k = 0; k < n_unknown; k++) {
        int slot = model_variables[unknown[k] - 1].slot;
        dv_unknown[k] = (sm->moved[slot] - sm->at[slot]) / s;
    }
    if (st != GRB_OK || moved_st != GRB_OK) {
        grb_log(inst, fmi2Warning, "directional derivative at t = %.12g s: %s; it reads as NaN", p[P_T],
                grb_status_message((grb_status)(st != GRB_OK ? st : moved_st)));
        return fmi2Warning;
    }
    return fmi2OK;
}
