/* The computed-torque law file (law.h) over the mechanism kernel's drive
 * demand (grb_drive_demand, kernel/demand.c): the code
 * grubler.controllers.ComputedTorque runs through the binding.
 *
 * Parameters (slots from config.h, written by
 * grubler.controllers.native_fmu.computed_torque_spec): the law's
 * (drive_inertia, gear_ratio, efficiency, R, k_t, k_e, Ts; PARAM_*), then the
 * scene as the Mechanism FMU shows it: gravity, the ground vector, the drive
 * joint, each link's fields (SLOT_LINKS + k LINK_STRIDE + LF_*), each
 * closure's (SLOT_CLOSURES + j CLOSURE_STRIDE + CF_*) and the sketch q
 * (SLOT_Q0, 2N), whose branch the first sample closes on, and the force
 * elements' fields (SLOT_FORCES on: scene_slots.h), whose efforts the demand
 * holds as the library's and the Mechanism FMU's do.
 * Inputs: the drive's position, velocity and acceleration.  Outputs: torque,
 * motor_torque, voltage.  State: z (N), the last sample's configuration, the
 * next one's guess.  Scratch: the kernel's link, closure and force tables, then
 * its workspace (CT_WORK_SIZE doubles), overwritten by each sample and carrying
 * nothing from one to the next. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "grb_scene.h"
#include "grubler.h"
#include "law.h"
#include "scene_slots.h"

#define N N_LINKS
#define NC N_CLOSURES
#define TABLE_LINKS 0
#define TABLE_CLOSURES (N * GRB_L_COLUMNS)
#define TABLE_FORCES (TABLE_CLOSURES + NC * GRB_CL_COLUMNS)
#define TABLE_WORK (TABLE_FORCES + N_FORCES * GRB_F_COLUMNS)
typedef char force_table_fits[TABLE_FORCE_SIZE == N_FORCES * GRB_F_COLUMNS ? 1 : -1];
typedef char scratch_fits[LAW_N_SCRATCH == TABLE_WORK + CT_WORK_SIZE ? 1 : -1];
typedef char check_fits[LAW_N_CHECK == LAW_N_SCRATCH ? 1 : -1];
typedef char state_fits[LAW_N_STATE == N ? 1 : -1];
typedef char mobility_one[N - 2 * NC == 1 ? 1 : -1];
/* law_check's refusal of a mechanism rule, written into its working memory: the problem, then "field: reason" */
#define REFUSAL_LENGTH (sizeof(((grb_problem *)0)->field) + 2 + sizeof(((grb_problem *)0)->reason))
typedef char refusal_fits[LAW_N_CHECK * sizeof(double) >= sizeof(grb_problem) + REFUSAL_LENGTH ? 1 : -1];

/* index in z of the drive joint (drive_joint: 0 none, else 1 + its index in q), -1 when not a real joint */
static int drive_index(const double *p, const int *revolute) {
    int q_index[N], q = (int)p[SLOT_DRIVE_JOINT] - 1;
    grb_real_coordinates(N, revolute, q_index);
    return q >= 0 && q_index[q / 2] == q ? q / 2 : -1;
}

/* The model over the kernel's tables, and the length scale of the closure
 * tolerance (grubler.mechanism.assembly._scale: the longest link, at least 1 m). */
static void describe(const double *p, const double *links, const double *closures, const double *forces,
                     grb_model *m, double *scale) {
    int revolute[N], i;
    *scale = 1.0;
    for (i = 0; i < N; i++) {
        revolute[i] = (int)scene_link_field(p, i, LF_JOINT) == 1;
        if (fabs(scene_link_field(p, i, LF_A)) > *scale) *scale = fabs(scene_link_field(p, i, LF_A));
    }
    m->n_links = N;
    m->n_closures = NC;
    m->links = links;
    m->closures = closures;
    m->theta1 = p[SLOT_GROUND_THETA1];
    m->gravity = p[SLOT_GRAVITY];
    m->drive = drive_index(p, revolute);
    m->load = -1;
    m->drive_inertia = p[PARAM_drive_inertia];
    /* the demand is the drive's alone: no actuator pushes (the library's runs with their forces at 0) */
    m->n_actuators = 0;
    m->actuators = NULL;
    /* the force elements push as in the run: springs, joint springs and friction, loads */
    m->n_forces = N_FORCES;
    m->forces = N_FORCES > 0 ? forces : NULL;
}

/* The kernel's tables of the parameters (as the Mechanism FMU builds them) and the model over them. */
static int build(const double *p, double *tables, grb_model *m, double *scale) {
    int revolute[N], parent[N];
    if (scene_tables_of(p, revolute, parent, tables + TABLE_LINKS, tables + TABLE_CLOSURES) != GRB_OK)
        return CTL_BAD_PARAMETER;
    scene_force_rows_for_kernel(p, tables + TABLE_FORCES);
    describe(p, tables + TABLE_LINKS, tables + TABLE_CLOSURES, tables + TABLE_FORCES, m, scale);
    return CTL_OK;
}

/* The sketch's joint coordinates z (N). */
static void sketch(const double *p, double *z) {
    int revolute[N], parent[N], i;
    for (i = 0; i < N; i++) {
        revolute[i] = (int)scene_link_field(p, i, LF_JOINT) == 1;
        parent[i] = (int)scene_link_field(p, i, LF_PARENT) - 2;
    }
    grb_z_from_q(N, revolute, parent, p[SLOT_GROUND_THETA1], p + SLOT_Q0, z);
}

/* The demand of one sample from the guess z into z_out; the effort into *tau. */
static int demand(const grb_model *m, double scale, double *work, const double *z, double position, double velocity,
                  double acceleration, double *z_out, double *tau) {
    double zd[N], zdd[N], force[2], closest;
    int at;
    grb_status st = grb_drive_demand(m, scale, 1, &position, &velocity, &acceleration, NULL, z, z_out, zd, zdd, tau,
                                     force, &at, &closest, work);
    return st == GRB_OK ? CTL_OK : CTL_MECHANISM_REFUSED;
}

int law_check(const double *param, double *work, int *field, const char **why) {
    int k, i, revolute[N];
    for (k = 0; k < LAW_N_PARAMS; k++) {
        if (!isfinite(param[k])) return ctl_refuse(k, LAW_N_PARAMS, "must be finite", field, why);
        if (fabs(param[k]) > GRB_MAX_MAGNITUDE) {
            /* the scene reader's bound (the Mechanism FMU holds its parameters to it too) */
            char *bound = (char *)(void *)work;
            snprintf(bound, REFUSAL_LENGTH, "magnitude above %g is outside the supported range", GRB_MAX_MAGNITUDE);
            return ctl_refuse(k, LAW_N_PARAMS, bound, field, why);
        }
    }
    /* the library's checks (ComputedTorque, Mechanism), with its words */
    if (param[PARAM_drive_inertia] < 0) return ctl_refuse(PARAM_drive_inertia, LAW_N_PARAMS, "must be >= 0", field, why);
    if (param[PARAM_gear_ratio] == 0) return ctl_refuse(PARAM_gear_ratio, LAW_N_PARAMS, "must be non-zero", field, why);
    if (!(param[PARAM_efficiency] > 0 && param[PARAM_efficiency] <= 1))
        return ctl_refuse(PARAM_efficiency, LAW_N_PARAMS, "must be in (0, 1]", field, why);
    if (param[PARAM_R] < 0) return ctl_refuse(PARAM_R, LAW_N_PARAMS, "must be >= 0", field, why);
    if (param[PARAM_k_t] < 0) return ctl_refuse(PARAM_k_t, LAW_N_PARAMS, "must be >= 0", field, why);
    if (param[PARAM_k_e] < 0) return ctl_refuse(PARAM_k_e, LAW_N_PARAMS, "must be >= 0", field, why);
    if (param[PARAM_Ts] < 0)
        return ctl_refuse(PARAM_Ts, LAW_N_PARAMS, "sample time must be finite and >= 0", field, why);
    {
        /* the mechanism's rules: the kernel's one check, the library's and the Mechanism FMU's, in their
         * words (the refusal, field first, is written into work: it outlives the call) */
        grb_scene_view view;
        grb_problem *problem = (grb_problem *)(void *)work;
        double force_rows[(N_FORCES > 0 ? N_FORCES : 1) * GRB_F_COLUMNS];
        int found;
        char *refusal = (char *)(void *)work + sizeof(grb_problem);
        scene_view_of(param, &view);
        scene_force_view(param, &view, force_rows);
        view.drive_inertia = 0.0;  /* the law's own parameter, judged above */
        if (grb_scene_check(&view, problem, 1, &found) != GRB_OK) {
            snprintf(refusal, REFUSAL_LENGTH, "%s: %s", problem->field, problem->reason);
            *field = LAW_FIELD_IN_WHY;
            *why = refusal;
            return CTL_BAD_PARAMETER;
        }
    }
    for (i = 0; i < N; i++) revolute[i] = (int)scene_link_field(param, i, LF_JOINT) == 1;
    if (drive_index(param, revolute) < 0)
        return ctl_refuse(SLOT_DRIVE_JOINT, LAW_N_PARAMS, "must name a real joint: the drive demand needs the "
                          "joint the drive acts on", field, why);
    {
        /* the sketch must close with the drive held there, as the library's constructor asks; the
         * tables and the kernel's workspace in work (LAW_N_CHECK: the scratch's layout), whose size
         * grows with the links squared */
        double z[N], z_out[N], tau, scale;
        grb_model m;
        if (build(param, work, &m, &scale) != CTL_OK ||
            grb_work_init(N, NC, work + TABLE_WORK, CT_WORK_SIZE) != GRB_OK)
            return ctl_refuse(SLOT_CLOSURES, LAW_N_PARAMS, "a closure's link is out of range", field, why);
        sketch(param, z);
        if (demand(&m, scale, work + TABLE_WORK, z, z[m.drive], 0.0, 0.0, z_out, &tau) != CTL_OK)
            return ctl_refuse(SLOT_Q0 + 2 * m.drive + (revolute[m.drive] ? 1 : 0), LAW_N_PARAMS,
                              "the loop cannot be closed at the sketch with the drive held there (or it is a "
                              "change point)", field, why);
#if N_FORCES > 0
        {
            /* a gas spring whose column is used up there has no finite force: no demand can be met */
            double y[2 * N], force_out[N_FORCES * GRB_FO_COUNT], h, length;
            int e, st;
            for (i = 0; i < N; i++) {
                y[i] = z_out[i];
                y[N + i] = 0.0;
            }
            e = scene_used_up_gas(&m, y, work + TABLE_WORK, force_out, &h, &length, &st);
            (void)st; /* a failing evaluation leaves e = -1: the samples then meet it */
            if (e >= 0) {
                /* the refusal lives past the call: in work, before the tables (which are done with) */
                char *refusal = (char *)(void *)work;
                snprintf(refusal, REFUSAL_LENGTH, "%s.gas_column: the gas is used up at the sketch: its column "
                         "gas_column + length - free_length is %.4g m at the length %.4g m; a gas spring needs a "
                         "positive column", force_name[e], h, length);
                *field = LAW_FIELD_IN_WHY;
                *why = refusal;
                return CTL_BAD_PARAMETER;
            }
        }
#endif
    }
    return CTL_OK;
}

int law_check_state(const double *param, const double *state, int *field, const char **why) {
    int k;
    (void)param;
    for (k = 0; k < N; k++)
        if (!isfinite(state[k])) return ctl_refuse(LAW_N_PARAMS, LAW_N_PARAMS, "must be finite", field, why);
    return CTL_OK;
}

const char *law_state_name(int field) {
    (void)field;
    return "z";
}

int law_prepare(const double *param, double *scratch) {
    grb_model m;
    double scale;
    if (build(param, scratch, &m, &scale) != CTL_OK) return CTL_BAD_PARAMETER;
    return grb_work_init(N, NC, scratch + TABLE_WORK, CT_WORK_SIZE) == GRB_OK ? CTL_OK : CTL_BAD_ARGUMENT;
}

int law_start(const double *param, const double *scratch, double t0, double *state, double *out) {
    (void)scratch;
    (void)t0;
    sketch(param, state);  /* ComputedTorque.reset: the first sample starts from the sketch */
    out[0] = out[1] = out[2] = 0.0;
    return CTL_OK;
}

int law_sample(const double *param, double *scratch, double *state, double t, const double *in, double *out) {
    grb_model m;
    double z[N], tau, tau_m, voltage, n = param[PARAM_gear_ratio], eta = param[PARAM_efficiency], scale;
    double *work = scratch + TABLE_WORK;
    int i, st;
    (void)t;
    describe(param, scratch + TABLE_LINKS, scratch + TABLE_CLOSURES, scratch + TABLE_FORCES, &m, &scale);
    if ((st = demand(&m, scale, work, state, in[0], in[1], in[2], z, &tau)) != CTL_OK) return st;
    /* ComputedTorque.motor: through the gearbox, motoring or braking; the steady-current voltage */
    tau_m = tau * in[1] >= 0 ? tau / (n * eta) : tau * eta / n;
    voltage = param[PARAM_k_t] > 0 ? param[PARAM_R] * tau_m / param[PARAM_k_t] + param[PARAM_k_e] * n * in[1] : 0.0;
    if (!isfinite(tau) || !isfinite(tau_m) || !isfinite(voltage)) return CTL_NOT_FINITE;
    out[0] = tau;
    out[1] = tau_m;
    out[2] = voltage;
    for (i = 0; i < N; i++) state[i] = z[i];
    return CTL_OK;
}
