/* The solvers of linalg.c that the dynamics use, over complex numbers (real.h). */
#include "complex_step.h"
#if GRB_HAVE_COMPLEX
#define GRB_COMPLEX_STEP
#include "linalg.c"
#else
typedef int grb_cs_linalg_left_out; /* ISO C: a translation unit declares something */
#endif
