/* ctl_linear: a discrete linear SISO controller of grubler.controllers.linear
 * (controllers/linear.py's docstring) as a state-space update on the error
 * e = r - y:
 *
 *     u_k = C x_k + D e_k + u_ff,k,        x_k+1 = A x_k + B e_k.
 *
 * The matrices are the caller's (row-major A n x n, B n, C n, D 1), already
 * discrete at the sample time (python-control discretises them, in the library
 * and when a native FMU of the controller is exported).
 *
 *   ctl_linear_check_state(n, x, &field, &why)       a state set from outside: finite;
 *   ctl_linear_sample(n, matrices, x, r, y, u_ff, &u, work)   one sample
 *       (work: n doubles; x is updated only on success).
 */
#ifndef CTL_LINEAR_H
#define CTL_LINEAR_H

#include "ctl_law.h"

#ifdef __cplusplus
extern "C" {
#endif

/* the matrices in one array: A (n x n, row-major), then B (n), C (n), D (1) */
#define CTL_LINEAR_SIZE(n) ((n) * (n) + 2 * (n) + 1)

enum ctl_linear_field { CTL_LIN_X };

CTL_API const char *ctl_linear_field_name(int field);
CTL_API int ctl_linear_check_state(long n, const double *x, int *field, const char **why);
CTL_API int ctl_linear_sample(long n, const double *matrices, double *x, double r, double y, double u_ff, double *u,
                              double *work);

#ifdef __cplusplus
}
#endif
#endif
