/* The solvers of linalg.c that the dynamics use, over complex numbers (real.h). */
#define GRB_COMPLEX_STEP
#include "linalg.c"
