/* From scene quantities to the kernel's tables (model.py's ModelArrays.of and
 * Mechanism._build_structure, in C for the native FMU, which has no Python).
 *
 * A scene gives each link's joint type (which of its pair is real), its
 * geometry and inertia, the absolute coordinates q_ref (B1, theta2, ..., the
 * user's sketch) and its closures in thesis link numbering.  The fictitious joint
 * of each pair is locked at its q_ref value: a locked slide keeps its B, a locked
 * revolute its angle relative to the predecessor (q_locked).
 *
 * parent[i] is link i+2's predecessor as a 0-based moving-link index (-1 the
 * ground), an earlier link: the chain is a tree.  NULL means the serial chain
 * (parent[i] = i - 1), and gives the same tables as before the tree existed.
 */
#ifndef GRB_SCENE_H
#define GRB_SCENE_H

#include "grubler.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Columns of a scene's link fields, one row per moving link. */
enum { GRB_SL_A, GRB_SL_P, GRB_SL_Q, GRB_SL_M, GRB_SL_I, GRB_SL_DAMP, GRB_SL_COLUMNS };
/* Columns of a scene's closure fields: kind (0 revolute, 1 prismatic), closing
 * link and target link in thesis numbering (2 .. N+1; 1 the ground), point on
 * the closing link, target point, line angle, psi, penalty gain and damping. */
enum { GRB_SC_KIND, GRB_SC_LINK, GRB_SC_TO, GRB_SC_PX, GRB_SC_PY, GRB_SC_TX, GRB_SC_TY, GRB_SC_ANGLE, GRB_SC_PSI,
       GRB_SC_GAIN, GRB_SC_DAMP, GRB_SC_COLUMNS };

/* ---- the mechanism's rules, checked once (scene_check.c) -------------------
 *
 * The library (grubler.mechanism.model.Mechanism, through grubler.binding) and
 * the native mechanism FMU (model_check) both refuse a scene here, so each rule
 * and its message exist once.  A scene is read where it lies: each table is a
 * base address, a row stride and, for each of its columns below, the column it
 * sits in (the library's numpy tables and the FMU's parameter block alike), in
 * the FMU's numbering: links thesis-numbered (1 the ground, moving links 2 ..
 * N+1), joint and closure type counted from 1 (1 revolute, 2 prismatic).
 * What a parser refuses (a value of the wrong type, a number that is not
 * finite or is out of magnitude, an unknown name) is its caller's. */
enum { GRB_SK_JOINT, GRB_SK_PARENT, GRB_SK_A, GRB_SK_P, GRB_SK_Q, GRB_SK_M, GRB_SK_I, GRB_SK_DAMP,
       GRB_SK_COLUMNS };
/* The closure columns are GRB_SC_* (type counted from 1 as above), the
 * actuators' GRB_A_* and the force elements' GRB_F_* (links thesis-numbered). */

typedef struct grb_scene_view {
    int n_links, n_closures, n_actuators;
    const double *links;            /* link k = i + 2's fields at links[i * link_stride + link_column[GRB_SK_*]] */
    int link_stride, link_column[GRB_SK_COLUMNS];
    const double *closures;         /* closure j's at closures[j * closure_stride + closure_column[GRB_SC_*]] */
    int closure_stride, closure_column[GRB_SC_COLUMNS];
    const double *actuators;        /* actuator j's at actuators[j * actuator_stride + actuator_column[GRB_A_*]] */
    int actuator_stride, actuator_column[GRB_A_COLUMNS];
    double a1, theta1, gravity;     /* the ground vector, m and rad; g along -y, m/s^2 */
    const double *q_ref;            /* 2N absolute coordinates of the sketch (B1, theta2, ...) */
    const double *qd;               /* 2N initial absolute rates, or NULL: not judged */
    int drive, load;                /* index in q of the drive and load joints, -1 none */
    double drive_inertia;           /* kg m^2 (kg on a slide) */
    /* how the caller spells fields the two interfaces name differently: each
     * actuator's prefix (NULL: "actuator[j]") and the drive and load joints
     * (NULL: the scene's "drive.joint", "load.joint") */
    const char *const *actuator_names;
    const char *drive_field, *load_field;
    /* the force elements (grubler.h's GRB_F_* columns, links thesis-numbered:
     * 1 the ground), each named by force_names[j] ("force[j]" when NULL) */
    int n_forces;
    const double *forces;           /* element j's fields at forces[j * force_stride + force_column[GRB_F_*]] */
    int force_stride, force_column[GRB_F_COLUMNS];
    const char *const *force_names;
} grb_scene_view;

/* One refusal: the field at fault, as the user spells it, and the reason. */
typedef struct grb_problem {
    char field[64];
    char reason[256];
} grb_problem;

/* Every rule a mechanism obeys, in the library's order: the number of links,
 * the ground and gravity, each link (every problem of every link), the
 * closures, the actuators, the force elements, the loops (two revolutes each, no parallel slides on
 * one link, mobility >= 0), the drive inertia, the drive and load joints (real
 * ones), then the initial rates of the locked coordinates (each problem).  A
 * group with problems ends the check (what follows reads it).  Up to
 * `capacity` problems go to `found`, `*count` says how many there are (it may
 * exceed capacity).  GRB_OK for none, GRB_BAD_ARGUMENT otherwise. */
GRB_API int grb_scene_check(const grb_scene_view *scene, grb_problem *found, int capacity, int *count);

/* The rules of one link, k (thesis numbering), its fields at row[column[GRB_SK_*]]:
 * every problem, as grb_scene_check. */
GRB_API int grb_link_check(int k, const double *row, const int *column, grb_problem *found, int capacity,
                           int *count);

/* Whether coordinate q (index in q, thesis order) is the real joint of its pair
 * (revolute: 1 when that pair's real joint is the revolute): GRB_OK, or
 * GRB_BAD_ARGUMENT with the problem under `field`'s name. */
GRB_API int grb_coordinate_check(int q, int revolute, const char *field, grb_problem *found);

/* GRB_OK when every parent is the ground or an earlier link (the kernel walks
 * parents towards the ground and relies on it), else GRB_BAD_ARGUMENT. */
GRB_API int grb_scene_parents_ok(int n, const int *parent);

/* The link table (n x GRB_L_COLUMNS) and closure table (nc x GRB_CL_COLUMNS)
 * of a scene.  revolute[i] is 1 when link i+2's real joint is the revolute.
 * GRB_BAD_ARGUMENT for a closure link or a parent out of range (nothing else is
 * checked: the caller validates the scene). */
GRB_API int grb_scene_tables(int n, int nc, const int *revolute, const int *parent, const double *link_fields,
                             double a1, double theta1, const double *q_ref, const double *closure_fields,
                             double *links, double *closures);

/* Index in q (thesis order B1, theta2, B2, ...) of each pair's real coordinate. */
GRB_API int grb_real_coordinates(int n, const int *revolute, int *q_index);

/* Real joint coordinates z (n) from absolute coordinates q (2n), and real
 * joint rates zd (n) from absolute rates qd (2n, the ground fixed). */
GRB_API int grb_z_from_q(int n, const int *revolute, const int *parent, double theta1, const double *q, double *z);
GRB_API int grb_zd_from_qd(int n, const int *revolute, const int *parent, const double *qd, double *zd);

#ifdef __cplusplus
}
#endif
#endif
