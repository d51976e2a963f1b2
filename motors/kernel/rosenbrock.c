/* rosenbrock: ROS2 with error control, as rosenbrock.h states. */
#include "rosenbrock.h"

#include <float.h>
#include <math.h>
#include <string.h>

#define N_MAX (ROS_MAX_STATES + 1)
#define MIN_SUBSTEP 1e-14
/* Accepted sub-steps over which one Jacobian serves. */
#define JACOBIAN_REUSE 8

/* y[n] is the time within the step. */
static void f_aug(const ros_problem *pr, const double *y, double *dy)
{
    pr->rhs(pr->ctx, y[pr->n], y, dy);
    dy[pr->n] = 1.0;
}

/* LU with partial pivoting of the m x m matrix a, in place; 0 when singular. */
static int lu(int m, double a[N_MAX][N_MAX], int *piv)
{
    for (int k = 0; k < m; k++) {
        int p = k;
        for (int i = k + 1; i < m; i++)
            if (fabs(a[i][k]) > fabs(a[p][k])) p = i;
        if (a[p][k] == 0.0) return 0;
        piv[k] = p;
        if (p != k)
            for (int j = 0; j < m; j++) { double t = a[k][j]; a[k][j] = a[p][j]; a[p][j] = t; }
        for (int i = k + 1; i < m; i++) {
            a[i][k] /= a[k][k];
            for (int j = k + 1; j < m; j++) a[i][j] -= a[i][k] * a[k][j];
        }
    }
    return 1;
}

static void lu_solve(int m, double a[N_MAX][N_MAX], const int *piv, double *b)
{
    /* lu swapped whole rows, multipliers included: the interchanges all come first */
    for (int k = 0; k < m; k++) {
        double t = b[piv[k]]; b[piv[k]] = b[k]; b[k] = t;
    }
    for (int k = 0; k < m; k++)
        for (int i = k + 1; i < m; i++) b[i] -= a[i][k] * b[k];
    for (int k = m - 1; k >= 0; k--) {
        for (int j = k + 1; j < m; j++) b[k] -= a[k][j] * b[j];
        b[k] /= a[k][k];
    }
}

static void jacobian(const ros_problem *pr, const double *y, const double *f0, double J[N_MAX][N_MAX])
{
    int m = pr->n + 1;
    double yy[N_MAX], f1[N_MAX];
    memcpy(yy, y, sizeof(double) * (size_t)m);
    for (int j = 0; j < m; j++) {
        double typical = j == pr->n ? 1e-6 : pr->scale[j] * 1e-3;
        double d = sqrt(DBL_EPSILON) * fmax(fabs(y[j]), typical);
        yy[j] = y[j] + d;
        d = yy[j] - y[j];
        f_aug(pr, yy, f1);
        for (int i = 0; i < m; i++) J[i][j] = (f1[i] - f0[i]) / d;
        yy[j] = y[j];
    }
}

static int all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

int ros_advance(const ros_problem *pr, double *state, double dt, double *substep)
{
    const double gamma = 1.0 + 1.0 / sqrt(2.0);
    const int n = pr->n, m = n + 1;
    double y[N_MAX], J[N_MAX][N_MAX];
    memcpy(y, state, sizeof(double) * (size_t)n);
    y[n] = 0.0;
    double h = *substep > 0.0 ? *substep : dt * 1e-3, h_used = h;
    long steps = 0;
    int fresh = 0, since = JACOBIAN_REUSE; /* J taken at this y? accepted steps since it was taken */
    while (y[n] < dt) {
        if (++steps > ROS_MAX_SUBSTEPS || h < MIN_SUBSTEP) return 1;
        int last = y[n] + h >= dt * (1.0 - 1e-12);
        double hh = last ? dt - y[n] : h;
        double f0[N_MAX], W[N_MAX][N_MAX], k1[N_MAX], k2[N_MAX], y1[N_MAX], ynew[N_MAX];
        int piv[N_MAX];
        f_aug(pr, y, f0);
        /* ROS2 keeps its order with any matrix in W, so the Jacobian is reused
         * over a few accepted steps and taken afresh after a rejected one */
        if (since >= JACOBIAN_REUSE) {
            jacobian(pr, y, f0, J);
            fresh = 1;
            since = 0;
        }
        for (int i = 0; i < m; i++)
            for (int j = 0; j < m; j++) W[i][j] = (i == j) - gamma * hh * J[i][j];
        if (!lu(m, W, piv)) { h *= 0.25; since = JACOBIAN_REUSE; continue; }
        memcpy(k1, f0, sizeof(double) * (size_t)m);
        lu_solve(m, W, piv, k1);
        for (int i = 0; i < m; i++) y1[i] = y[i] + hh * k1[i];
        f_aug(pr, y1, k2);
        for (int i = 0; i < m; i++) k2[i] -= 2.0 * k1[i];
        lu_solve(m, W, piv, k2);
        double err = 0.0;
        for (int i = 0; i < m; i++) {
            ynew[i] = y[i] + hh * (1.5 * k1[i] + 0.5 * k2[i]);
            if (i < n) {
                double sc = pr->tolerance * fmax(pr->scale[i], fmax(fabs(y[i]), fabs(ynew[i])));
                double e = 0.5 * hh * (k1[i] + k2[i]) / sc;
                err += e * e;
            }
        }
        err = sqrt(err / n);
        int finite = all_finite(ynew, m);
        if (pr->lower)
            for (int i = 0; i < n; i++)
                if (ynew[i] < pr->lower[i]) ynew[i] = pr->lower[i];
        int ok = finite && err <= 1.0;
        double grow = err > 0.0 ? 0.9 / sqrt(err) : 5.0;
        grow = finite && isfinite(grow) ? fmin(5.0, fmax(0.2, grow)) : 0.25;
        if (ok) {
            memcpy(y, ynew, sizeof(double) * (size_t)m);
            if (last) y[n] = dt;    /* the step ends exactly at dt */
            else h_used = hh;
            since++;
            fresh = 0;              /* y moved on */
        } else if (!fresh) {
            since = JACOBIAN_REUSE; /* retry with a Jacobian taken here */
            continue;               /* and the same step size */
        }
        h = hh * grow;
    }
    memcpy(state, y, sizeof(double) * (size_t)n);
    *substep = h_used;
    return 0;
}
