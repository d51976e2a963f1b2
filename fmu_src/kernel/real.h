/* The number type of the kernel's equations, so that they can be compiled twice.
 *
 * The dynamics (chain.c) and the small solvers they use (linalg.c) are written
 * over `real`.  Compiled plainly, real is double.  Compiled with
 * GRB_COMPLEX_STEP (chain_cs.c, linalg_cs.c) it is double complex and every
 * external name gets the prefix grb_cs_: evaluating the same equations at
 * x + i h e_k gives the exact derivative along e_k in the imaginary part
 * (complex-step differentiation, Squire and Trapp 1998; Martins et al. 2003),
 * with no step-size trade-off, which is what linearisation needs.
 *
 * Complex-step rules the code keeps: arithmetic and cos, sin, sqrt are
 * analytic (and exp, log, tanh); a comparison or a pivot choice looks at the real part (RE), and an
 * absolute value flips the sign of the whole number (RABS), the analytic
 * continuation of |x| away from zero. */
#ifndef GRUBLER_REAL_H
#define GRUBLER_REAL_H

#include <math.h>

#ifdef GRB_COMPLEX_STEP
#include <complex.h>
typedef double complex real;
/* cos, sin and sqrt of a complex number from the real functions (C99's own
 * formulas: the same values to rounding), not ccos, csin, csqrt from the C
 * library: wine's C runtime has none, and a binary that needs only the
 * C89 maths loads wherever it is copied */
static inline real grb_ccos(real z) { return cos(creal(z)) * cosh(cimag(z)) - I * (sin(creal(z)) * sinh(cimag(z))); }
static inline real grb_csin(real z) { return sin(creal(z)) * cosh(cimag(z)) + I * (cos(creal(z)) * sinh(cimag(z))); }
/* the principal root, on the side of the cut the imaginary part's sign gives
 * (|z| without hypot, whose glibc symbol is from 2.35: overflow as the real
 * path's own squares overflow) */
static inline real grb_csqrt(real z) {
    double a = creal(z), b = cimag(z), t;
    if (a == 0.0 && b == 0.0) return z;
    t = sqrt(0.5 * (fabs(a) + sqrt(a * a + b * b)));
    return a >= 0.0 ? t + I * (0.5 * b / t) : 0.5 * fabs(b) / t + I * copysign(t, b);
}
/* exp, log and tanh likewise (the force elements' gas law and friction):
 * log on the principal branch, and tanh saturated where its real part makes
 * its slope (4 e^-2|a|) vanish against 1, before cosh and sinh overflow */
static inline real grb_cexp(real z) { return exp(creal(z)) * (cos(cimag(z)) + I * sin(cimag(z))); }
static inline real grb_clog(real z) {
    double a = creal(z), b = cimag(z);
    return 0.5 * log(a * a + b * b) + I * atan2(b, a);
}
static inline real grb_ctanh(real z) {
    double a = creal(z), b = cimag(z), d;
    if (fabs(a) > 20.0) return copysign(1.0, a);
    d = cosh(2.0 * a) + cos(2.0 * b);
    return sinh(2.0 * a) / d + I * (sin(2.0 * b) / d);
}
#define RE(x) creal(x)
#define REXP(x) grb_cexp(x)
#define RLOG(x) grb_clog(x)
#define RTANH(x) grb_ctanh(x)
#define RPOW(x, y) grb_cexp((y) * grb_clog(x))
#define RCOS(x) grb_ccos(x)
#define RSIN(x) grb_csin(x)
#define RSQRT(x) grb_csqrt(x)
#define GRB(name) grb_cs_##name
#else
typedef double real;
#define RE(x) (x)
#define REXP(x) exp(x)
#define RLOG(x) log(x)
#define RTANH(x) tanh(x)
#define RPOW(x, y) pow(x, y)
#define RCOS(x) cos(x)
#define RSIN(x) sin(x)
#define RSQRT(x) sqrt(x)
#define GRB(name) grb_##name
#endif

#define RABS(x) (RE(x) < 0.0 ? -(x) : (x))

#endif
