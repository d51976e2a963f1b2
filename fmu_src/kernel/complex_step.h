/* Whether this compiler has C99 complex arithmetic, which the kernel's
 * complex-step twins (*_cs.c, real.h) are written in.
 *
 * Visual Studio's C has none (it defines __STDC_NO_COMPLEX__ only under
 * /std:c11 and later, hence _MSC_VER too); C11 lets any compiler leave it out
 * and say so with __STDC_NO_COMPLEX__, which also forces the fallback on a
 * compiler that has it (-D__STDC_NO_COMPLEX__), to test it.  Without it the
 * twins compile to nothing and a model takes its derivatives another way. */
#ifndef GRUBLER_COMPLEX_STEP_H
#define GRUBLER_COMPLEX_STEP_H

#if defined(__STDC_NO_COMPLEX__) || defined(_MSC_VER)
#define GRB_HAVE_COMPLEX 0
#else
#define GRB_HAVE_COMPLEX 1
#endif

#endif
