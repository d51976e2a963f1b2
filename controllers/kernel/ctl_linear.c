/* ctl_linear: the state-space update of ctl_linear.h. */
#include "ctl_linear.h"

#include <math.h>
#include <stddef.h>

static const char *const FIELD_NAMES[] = {"x"};

const char *ctl_linear_field_name(int field)
{
    return ctl_name(FIELD_NAMES, (int)(sizeof FIELD_NAMES / sizeof FIELD_NAMES[0]), field);
}

int ctl_linear_check_state(long n, const double *x, int *field, const char **why)
{
    long k;
    if (n < 0 || (n > 0 && !x)) return CTL_BAD_ARGUMENT;
    for (k = 0; k < n; k++)
        if (!isfinite(x[k])) return ctl_refuse(CTL_LIN_X, 0, "must hold finite numbers", field, why);
    return CTL_OK;
}

int ctl_linear_sample(long n, const double *m, double *x, double r, double y, double u_ff, double *u, double *work)
{
    const double *A = m, *B = m + n * n, *C = m + n * n + n, *D = m + n * n + 2 * n;
    double e, out;
    long i, j;
    if (n < 0 || !m || !u || (n > 0 && (!x || !work))) return CTL_BAD_ARGUMENT;
    if (!isfinite(r) || !isfinite(y) || !isfinite(u_ff)) return CTL_BAD_INPUT;
    e = r - y;
    out = D[0] * e;
    for (i = 0; i < n; i++) out += C[i] * x[i];
    for (i = 0; i < n; i++) {
        double next = B[i] * e;
        for (j = 0; j < n; j++) next += A[i * n + j] * x[j];
        if (!isfinite(next)) return CTL_NOT_FINITE;
        work[i] = next;
    }
    out += u_ff;
    if (!isfinite(out)) return CTL_NOT_FINITE;
    for (i = 0; i < n; i++) x[i] = work[i];
    *u = out;
    return CTL_OK;
}
