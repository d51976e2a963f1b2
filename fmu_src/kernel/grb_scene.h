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
