/* The kernel's equations over complex numbers: complex-step differentiation.
 *
 * Each function is its grubler.h namesake (grb_rhs -> grb_cs_rhs_at) with the
 * state, efforts (passed by address), workspace and outputs complex (C99 double
 * complex, numpy's complex128).  Evaluated at y + i h e_k with h tiny (1e-30), the imaginary part
 * of every output divided by h is its exact derivative along e_k, free of
 * truncation and cancellation error; the real part is the plain value.  The
 * model's tables stay real: derivatives are with respect to state and efforts.
 * The workspace has grb_work_size() complex entries. */
#ifndef GRUBLER_CS_H
#define GRUBLER_CS_H

#include <complex.h>

#include "grubler.h"

#ifdef __cplusplus
extern "C" {
#endif

/* grb_work_init over a complex buffer */
GRB_API grb_status grb_cs_work_init(int n_links, int n_closures, double complex *work, size_t length);

/* grb_set_actuator_forces over a complex buffer: the forces complex, so that a
 * derivative can be taken along them */
GRB_API grb_status grb_cs_set_actuator_forces(const grb_model *m, double complex *work, const double complex *force);

/* efforts: (drive, load); the complex-step rules are in real.h */
GRB_API grb_status grb_cs_rhs_at(const grb_model *m, int method, const double complex *y, const double complex *efforts,
                          double complex *work, double complex *out);
GRB_API grb_status grb_cs_observe_at(const grb_model *m, int method, const double complex *y,
                              const double complex *efforts, int want_reactions, double complex *work,
                              double complex *out);

/* grb_minimal_state over complex numbers: y's real part must already be the
 * closed state (from grb_minimal_state or assembly); the iteration converges
 * the imaginary part, the derivative of the state along the independent
 * coordinates' imaginary perturbation (scale: the length scale of the tolerance). */
GRB_API grb_status grb_cs_minimal_state(const grb_model *m, int n_ind, const int *ind, double scale, double complex *y,
                                 double complex *work);

#ifdef __cplusplus
}
#endif
#endif
