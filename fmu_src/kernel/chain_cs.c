/* The equations of chain.c over complex numbers, for complex-step derivatives
 * (real.h says why and how); every external name is grb_cs_*. */
#define GRB_COMPLEX_STEP
#include "chain.c"
