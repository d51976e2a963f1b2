/* The equations of chain.c over complex numbers, for complex-step derivatives
 * (real.h says why and how); every external name is grb_cs_*. */
#include "complex_step.h"
#if GRB_HAVE_COMPLEX
#define GRB_COMPLEX_STEP
#include "chain.c"
#else
typedef int grb_cs_chain_left_out; /* ISO C: a translation unit declares something */
#endif
