/* scene_slots.h: the kernel's tables from a scene held as FMU parameters, for
 * every model file that serves a scene (mechanism_model.c, computed_torque_law.c).
 *
 * config.h places the scene's parameters (grubler.fmi.mechanism): N_LINKS,
 * N_CLOSURES; link k's fields at SLOT_LINKS + k LINK_STRIDE + LF_*, closure
 * j's at SLOT_CLOSURES + j CLOSURE_STRIDE + CF_*; the ground vector at
 * SLOT_GROUND_A1 and SLOT_GROUND_THETA1; the sketch q at SLOT_Q0 (2N).
 * JointType and ClosureType count from 1: R and revolute. */
#ifndef GRB_SCENE_SLOTS_H
#define GRB_SCENE_SLOTS_H

#include <string.h>

#include "grb_scene.h"
#include "grubler.h"

static double scene_link_field(const double *p, int i, int f) { return p[SLOT_LINKS + i * LINK_STRIDE + f]; }
static double scene_closure_field(const double *p, int j, int f) {
    return p[SLOT_CLOSURES + j * CLOSURE_STRIDE + f];
}

/* Each link's joint (1: the revolute is real) and predecessor (0-based, -1 the
 * ground), and the link and closure tables (grb_scene_tables, as the library's
 * ModelArrays.of builds them): GRB_BAD_ARGUMENT for a link number or a
 * parent out of range. */
static int scene_tables_of(const double *p, int *revolute, int *parent, double *links, double *closures) {
    double lf[N_LINKS * GRB_SL_COLUMNS], cf[(N_CLOSURES > 0 ? N_CLOSURES : 1) * GRB_SC_COLUMNS];
    static const int link_column[GRB_SL_COLUMNS] = {LF_A, LF_P, LF_Q, LF_M, LF_I, LF_DAMPING};
    static const int closure_column[GRB_SC_COLUMNS] = {CF_TYPE, CF_LINK, CF_TO_LINK, CF_AT_X, CF_AT_Y, CF_POINT_X,
                                                       CF_POINT_Y, CF_ANGLE, CF_PSI, CF_GAIN, CF_DAMPING};
    int i, j;
    for (i = 0; i < N_LINKS; i++) {
        revolute[i] = (int)scene_link_field(p, i, LF_JOINT) == 1;
        parent[i] = (int)scene_link_field(p, i, LF_PARENT) - 2;
        for (j = 0; j < GRB_SL_COLUMNS; j++) lf[i * GRB_SL_COLUMNS + j] = scene_link_field(p, i, link_column[j]);
    }
    for (j = 0; j < N_CLOSURES; j++) {
        for (i = 0; i < GRB_SC_COLUMNS; i++) cf[j * GRB_SC_COLUMNS + i] = scene_closure_field(p, j, closure_column[i]);
        cf[j * GRB_SC_COLUMNS + GRB_SC_KIND] = (int)scene_closure_field(p, j, CF_TYPE) == 2 ? 1.0 : 0.0;
    }
    return grb_scene_tables(N_LINKS, N_CLOSURES, revolute, parent, lf, p[SLOT_GROUND_A1], p[SLOT_GROUND_THETA1],
                            p + SLOT_Q0, cf, links, closures);
}

/* The scene where it lies in the parameter block, as the kernel's one check
 * of a mechanism reads it (grb_scene_check, which the library runs too): the
 * links, closures, ground, gravity, sketch and drive joint, and the initial
 * rates, load joint and drive inertia where the block holds them (a model
 * file with actuators adds those).  The efforts' joints are named by their
 * variables. */
static void scene_view_of(const double *p, grb_scene_view *v) {
    static const int link_column[GRB_SK_COLUMNS] = {LF_JOINT, LF_PARENT, LF_A, LF_P, LF_Q, LF_M, LF_I, LF_DAMPING};
    static const int closure_column[GRB_SC_COLUMNS] = {CF_TYPE, CF_LINK, CF_TO_LINK, CF_AT_X, CF_AT_Y, CF_POINT_X,
                                                       CF_POINT_Y, CF_ANGLE, CF_PSI, CF_GAIN, CF_DAMPING};
    memset(v, 0, sizeof *v);
    v->n_links = N_LINKS;
    v->n_closures = N_CLOSURES;
    v->links = p + SLOT_LINKS;
    v->link_stride = LINK_STRIDE;
    memcpy(v->link_column, link_column, sizeof link_column);
    v->closures = p + SLOT_CLOSURES;
    v->closure_stride = CLOSURE_STRIDE;
    memcpy(v->closure_column, closure_column, sizeof closure_column);
    v->a1 = p[SLOT_GROUND_A1];
    v->theta1 = p[SLOT_GROUND_THETA1];
    v->gravity = p[SLOT_GRAVITY];
    v->q_ref = p + SLOT_Q0;
    v->drive = (int)p[SLOT_DRIVE_JOINT] - 1;  /* choice 0: none */
#ifdef SLOT_QD0
    v->qd = p + SLOT_QD0;
#endif
#ifdef SLOT_LOAD_JOINT
    v->load = (int)p[SLOT_LOAD_JOINT] - 1;
#else
    v->load = -1;
#endif
#ifdef SLOT_DRIVE_INERTIA
    v->drive_inertia = p[SLOT_DRIVE_INERTIA];
#endif
    v->drive_field = "drive_joint";
    v->load_field = "load_joint";
}

/* The force elements (config.h: N_FORCES, their parameters from SLOT_FORCES on,
 * FORCE_KINDS, and where each parameter goes, its element FORCE_PARAM_ELEMENT and
 * kernel column FORCE_PARAM_COLUMN; FORCE_NAMES, each element's name, the prefix
 * of its parameters: "strut" of strut.stiffness), from grubler.fmi.mechanism: a
 * table, not a branch per kind.  Every model that serves a scene computes with
 * them: the Mechanism FMU's run and the ComputedTorque FMU's demand alike. */
#ifndef N_FORCES
#define N_FORCES 0
#endif
#if N_FORCES > 0
static const int force_kind[N_FORCES] = FORCE_KINDS;
static const int force_param_element[] = FORCE_PARAM_ELEMENT;
static const int force_param_column[] = FORCE_PARAM_COLUMN;
static const char *const force_name[N_FORCES] = FORCE_NAMES;
#define N_FORCE_PARAMS ((int)(sizeof force_param_column / sizeof force_param_column[0]))
#endif

/* The force elements' rows (GRB_F_*, N_FORCES of them), links thesis-numbered
 * as the parameters give them (1 the ground), from the parameter block. */
static void scene_force_rows_of(const double *p, double *rows) {
#if N_FORCES > 0
    int i;
    for (i = 0; i < N_FORCES * GRB_F_COLUMNS; i++) rows[i] = 0.0;
    for (i = 0; i < N_FORCES; i++) rows[i * GRB_F_COLUMNS + GRB_F_KIND] = force_kind[i];
    for (i = 0; i < N_FORCE_PARAMS; i++)
        rows[force_param_element[i] * GRB_F_COLUMNS + force_param_column[i]] = p[SLOT_FORCES + i];
#else
    (void)p;
    (void)rows;
#endif
}

/* The same rows in the kernel's link numbering (0-based, -1 the ground): what grb_model.forces holds. */
static void scene_force_rows_for_kernel(const double *p, double *rows) {
    int j;
    scene_force_rows_of(p, rows);
    for (j = 0; j < N_FORCES; j++) {
        rows[j * GRB_F_COLUMNS + GRB_F_LINK] -= 2;
        rows[j * GRB_F_COLUMNS + GRB_F_TO_LINK] -= 2;
    }
}

/* The force elements into a scene view (grb_scene_check judges them, naming
 * each by its parameters' prefix); rows: N_FORCES x GRB_F_COLUMNS the caller owns. */
static void scene_force_view(const double *p, grb_scene_view *v, double *rows) {
    int k;
    scene_force_rows_of(p, rows);
    v->n_forces = N_FORCES;
    v->forces = rows;
    v->force_stride = GRB_F_COLUMNS;
    for (k = 0; k < GRB_F_COLUMNS; k++) v->force_column[k] = k;
#if N_FORCES > 0
    v->force_names = force_name;
#endif
}

/* The first gas spring whose gas column (gas_column + length - free_length)
 * is used up at the state y (2N, kernel numbering in m's rows), with that
 * column and its length; -1 when every column is positive (the library's
 * used_up_gas).  There the spring's force is not finite.  force_out:
 * N_FORCES x GRB_FO_COUNT the caller owns; *status: grb_force_rows's. */
static int scene_used_up_gas(const grb_model *m, const double *y, double *work, double *force_out, double *h,
                             double *length, int *status) {
    int i;
    *status = GRB_OK;
    if (N_FORCES == 0) return -1;
    if ((*status = grb_force_rows(m, 1, y, work, force_out)) != GRB_OK) return -1;
    for (i = 0; i < N_FORCES; i++) {
        const double *row = m->forces + i * GRB_F_COLUMNS;
        *length = force_out[i * GRB_FO_COUNT + GRB_FO_LENGTH];
        *h = row[GRB_F_GAS_COLUMN] + *length - row[GRB_F_FREE];
        if (row[GRB_F_KIND] == GRB_FORCE_SPRING && row[GRB_F_GAS_FORCE] > 0 && !(*h > 0)) return i;
    }
    return -1;
}

#endif
