/* minimal.c over complex numbers, for complex-step derivatives (real.h); its names are grb_cs_*. */
#include "complex_step.h"
#if GRB_HAVE_COMPLEX
#define GRB_COMPLEX_STEP
#include "minimal.c"
#else
typedef int grb_cs_minimal_left_out; /* ISO C: a translation unit declares something */
#endif
