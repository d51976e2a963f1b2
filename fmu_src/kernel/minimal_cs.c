/* minimal.c over complex numbers, for complex-step derivatives (real.h); its names are grb_cs_*. */
#define GRB_COMPLEX_STEP
#include "minimal.c"
