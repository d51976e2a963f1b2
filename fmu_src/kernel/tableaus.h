/* Butcher tableaus of the explicit integrators, as data the stepper reads. */
#ifndef GRUBLER_TABLEAUS_H
#define GRUBLER_TABLEAUS_H

#include "grubler.h"

/* Stage derivatives live in rows 0..s-1 of the stepper's table, the derivative
 * at the step's end (first-same-as-last) in row s, a continuous extension's
 * extra stages after it. */
typedef struct grb_tableau_data {
    const char *name;
    int stages;          /* s */
    int adaptive;        /* error control (0: fixed step) */
    int error_order;     /* of the embedded estimate: the step factor uses 1/(order+1) */
    const double *A;     /* A[i * lda + j], rows 0..s-1 */
    int lda;
    const double *b;     /* s weights of the propagated solution */
    const double *c;     /* s nodes */
    const double *e;     /* s + 1 weights of the error estimate (NULL: none) */
    const double *e3;    /* DOP853's second, 3rd-order estimate (NULL: none) */
    int dense_stages;    /* extra stages of the continuous extension (0: none) */
    const double *dense_a; /* their A rows, over s + 1 + dense_stages derivatives, stride lda */
    const double *dense_c;
    int dense_rows;      /* rows of the interpolant's D (stride lda) */
    const double *dense_d;
} grb_tableau_data;

/* The tableau for enum grb_tableau, NULL for an unknown one. */
GRB_API const grb_tableau_data *grb_tableau(int tableau);

#endif
