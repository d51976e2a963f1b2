/* Dense linear algebra on the kernel's small matrices (a few rows).
 *
 * Far too small for LAPACK's call overhead to pay, so three classical
 * algorithms cover what the equations of motion and the projection need:
 * Gaussian elimination with partial pivoting (gesv), the cyclic Jacobi method
 * for symmetric matrices (syev), and the minimum-norm least-squares solution by
 * one-sided (Hestenes) Jacobi SVD with a relative singular-value cut-off (gelsd).
 * Jacobi methods are as accurate as their LAPACK counterparts (more so for small
 * singular values) and converge in a handful of sweeps at these sizes. */
#include <float.h>

#include "workspace.h"

#define MAX_SWEEPS 60
/* det / trace^2 of J J^T above which two rows are solved in closed form */
#define GRAM_CUTOFF 1e-8
/* smallest pivot of Gaussian elimination, relative to the largest, for which a
 * square system of many rows is solved by it rather than by the SVD */
#define LU_CUTOFF 1e-10

/* Solve A Y = X in place: A is the n x n block of T from column a0 (destroyed),
 * X the ncols columns from x0 (overwritten by Y).  GRB_SINGULAR when a pivot
 * is exactly zero, as gesv reports it. */
/* (inlined into each of the two entries below, so that each is compiled for its
 * own `banded`: the dense one as it was) */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline grb_status lu(real *T, int stride, int n, int a0, int x0, int ncols, int banded) {
#define A(r, c) T[(r) * stride + a0 + (c)]
#define X(r, c) T[(r) * stride + x0 + (c)]
    for (int c = 0; c < n; c++) {
        int p = c;
        double big = fabs(RE(A(c, c)));
        for (int r = c + 1; r < n; r++)
            if (fabs(RE(A(r, c))) > big) {
                big = fabs(RE(A(r, c)));
                p = r;
            }
        if (big == 0.0) return GRB_SINGULAR;
        if (p != c) {
            for (int j = 0; j < n; j++) {
                real t = A(c, j);
                A(c, j) = A(p, j);
                A(p, j) = t;
            }
            for (int j = 0; j < ncols; j++) {
                real t = X(c, j);
                X(c, j) = X(p, j);
                X(p, j) = t;
            }
        }
        int last = n - 1; /* banded: the pivot row's last entry that is not zero */
        while (banded && last > c && A(c, last) == 0.0) last--;
        for (int r = c + 1; r < n; r++) {
            real f = A(r, c) / A(c, c);
            if (f != 0.0) {
                for (int j = c + 1; j <= last; j++) A(r, j) -= f * A(c, j);
                for (int j = 0; j < ncols; j++) X(r, j) -= f * X(c, j);
            }
        }
    }
    for (int c = n - 1; c >= 0; c--) {
        int last = n - 1;
        while (banded && last > c && A(c, last) == 0.0) last--;
        for (int j = 0; j < ncols; j++) {
            real s = X(c, j);
            for (int k = c + 1; k <= last; k++) s -= A(c, k) * X(k, j);
            X(c, j) = s / A(c, c);
        }
    }
    return GRB_OK;
#undef A
#undef X
}

grb_status GRB(lu_solve)(real *T, int stride, int n, int a0, int x0, int ncols) {
    return lu(T, stride, n, a0, x0, ncols, 0);
}

/* The same for a banded matrix (many closure rows: the equations of a chain of
 * many small loops): each pivot row only up to its last entry that is not
 * zero, the rest adding exact zeros, so that it costs in proportion to the
 * band; the same numbers as lu_solve but for the sign of a zero. */
grb_status GRB(lu_solve_banded)(real *T, int stride, int n, int a0, int x0, int ncols) {
    return lu(T, stride, n, a0, x0, ncols, 1);
}

/* Cholesky factor of the symmetric n x n matrix A (row stride) in place, in
 * its lower triangle: 1, or 0 when a pivot falls to or below cutoff times the
 * largest diagonal entry (too near singular for the caller's use; A is then
 * spoilt).  The solve with the factor follows. */
int GRB(cholesky)(real *A, int stride, int n, double cutoff) {
#define A(r, c) A[(r) * stride + (c)]
    double big = 0.0;
    for (int i = 0; i < n; i++) big = fmax(big, RE(A(i, i)));
    if (!(big > 0.0)) return 0;
    for (int j = 0; j < n; j++) {
        real d = A(j, j);
        for (int k = 0; k < j; k++) d -= A(j, k) * A(j, k);
        if (!(RE(d) > cutoff * big)) return 0;
        d = RSQRT(d);
        A(j, j) = d;
        for (int i = j + 1; i < n; i++) {
            real v = A(i, j);
            for (int k = 0; k < j; k++) v -= A(i, k) * A(j, k);
            A(i, j) = v / d;
        }
    }
    return 1;
#undef A
}

void GRB(cholesky_solve)(const real *L, int stride, int n, real *b, int bstride) {
    for (int i = 0; i < n; i++) {
        real v = b[i * bstride];
        for (int k = 0; k < i; k++) v -= L[i * stride + k] * b[k * bstride];
        b[i * bstride] = v / L[i * stride + i];
    }
    for (int i = n - 1; i >= 0; i--) {
        real v = b[i * bstride];
        for (int k = i + 1; k < n; k++) v -= L[k * stride + i] * b[k * bstride];
        b[i * bstride] = v / L[i * stride + i];
    }
}

/* Cosine and sine of the Jacobi rotation that zeroes apq (Rutishauser's form). */
static void rotation(real app, real aqq, real apq, real *c, real *s) {
    real theta = (aqq - app) / (2.0 * apq);
    real t = 1.0 / (RABS(theta) + RSQRT(theta * theta + 1.0));
    if (RE(theta) < 0.0) t = -t;
    *c = 1.0 / RSQRT(t * t + 1.0);
    *s = t * *c;
}

/* Columns p and q of the rows x ? matrix A (row stride) turned by (c, s). */
static void rotate_columns(real *A, int stride, int rows, int p, int q, real c, real s) {
    for (int k = 0; k < rows; k++) {
        real akp = A[k * stride + p], akq = A[k * stride + q];
        A[k * stride + p] = c * akp - s * akq;
        A[k * stride + q] = s * akp + c * akq;
    }
}

/* Eigen-decomposition of the symmetric m x m matrix S (kept): the
 * eigenvectors into V's columns, the eigenvalues (not sorted) into values; B
 * is m x m scratch.  All row-major with m columns. */
void GRB(sym_eig)(const real *S, real *B, real *V, real *values, int m) {
#define S_(i, j) S[(i) * m + (j)]
#define B(i, j) B[(i) * m + (j)]
#define V(i, j) V[(i) * m + (j)]
    for (int i = 0; i < m; i++)
        for (int j = 0; j < m; j++) {
            B(i, j) = S_(i, j);
            V(i, j) = i == j ? 1.0 : 0.0;
        }
    for (int sweep = 0; sweep < MAX_SWEEPS; sweep++) {
        double off = 0.0, diag = 0.0;
        for (int i = 0; i < m; i++) {
            diag += RE(B(i, i)) * RE(B(i, i));
            for (int j = i + 1; j < m; j++) off += RE(B(i, j)) * RE(B(i, j));
        }
        if (off <= 1e-36 * diag || off == 0.0) break;
        for (int p = 0; p < m; p++)
            for (int q = p + 1; q < m; q++) {
                if (B(p, q) == 0.0) continue;
                real c, s;
                rotation(B(p, p), B(q, q), B(p, q), &c, &s);
                rotate_columns(B, m, m, p, q, c, s);
                for (int k = 0; k < m; k++) {
                    real bpk = B(p, k), bqk = B(q, k);
                    B(p, k) = c * bpk - s * bqk;
                    B(q, k) = s * bpk + c * bqk;
                }
                rotate_columns(V, m, m, p, q, c, s);
            }
    }
    for (int i = 0; i < m; i++) values[i] = B(i, i);
#undef S_
#undef B
#undef V
}

#ifndef GRB_COMPLEX_STEP
/* The eigenvalues (not sorted) of the symmetric m x m matrix S (kept) into
 * values, B m x m scratch: Householder reduction to tridiagonal form, then the
 * implicit QL method with Wilkinson's shift (Golub and Van Loan 8.3), some
 * 4/3 m^3 operations where Jacobi's sweeps take tens of m^3.  For
 * conditioning and rank, where no eigenvector is needed.  v: m scratch. */
void grb_sym_eigenvalues(const double *S, double *B, double *v, double *values, int m) {
#define B(i, j) B[(i) * m + (j)]
    double *d = values, *e = B + (size_t)m * (m - 1); /* e: B's last row, free once the reduction is done */
    int band = 0; /* the half bandwidth: S(i, j) = 0 for |i - j| > band */
    for (int i = 0; i < m; i++)
        for (int j = 0; j < m; j++) {
            B[i * m + j] = S[i * m + j];
            if (S[i * m + j] != 0.0 && i - j > band) band = i - j;
        }
    if (band > 1 && 4 * band <= m) {
        /* a narrow band (the Gram matrix of a chain of many small loops): to
         * tridiagonal form by Givens rotations, each entry below the
         * subdiagonal zeroed against the one above it and the bulge this
         * leaves band rows further down chased off the end (Schwarz's band
         * reduction): O(m^2 band) operations where Householder's take
         * 4/3 m^3.  A rotation of rows and columns p = q - 1, q touches only
         * the entries from p - band - 1 (the bulge) to q + band. */
        for (int k = 0; k + 2 < m; k++)
            for (int i = (k + band < m - 1 ? k + band : m - 1); i >= k + 2; i--) {
                int col = k; /* zero B(q, col) against B(q - 1, col), then chase */
                for (int q = i; q < m; q += band) {
                    int p = q - 1;
                    double x = B(p, col), y = B(q, col);
                    if (y == 0.0) break;
                    double r = sqrt(x * x + y * y), c = x / r, sn = y / r;
                    int lo = p - band - 1 < 0 ? 0 : p - band - 1, hi = q + band + 1 > m - 1 ? m - 1 : q + band + 1;
                    for (int j = lo; j <= hi; j++) { /* rows p, q */
                        double bp = B(p, j), bq = B(q, j);
                        B(p, j) = c * bp + sn * bq;
                        B(q, j) = c * bq - sn * bp;
                    }
                    for (int j = lo; j <= hi; j++) { /* columns p, q */
                        double bp = B(j, p), bq = B(j, q);
                        B(j, p) = c * bp + sn * bq;
                        B(j, q) = c * bq - sn * bp;
                    }
                    B(q, col) = B(col, q) = 0.0;
                    col = p; /* the bulge the rotation left: at (q + band, p), zeroed next */
                }
            }
    } else {
        /* H = I - v v^T 2 / v^T v on rows and columns k+1 .. of B, v from column k
         * (row k: B is kept whole and symmetric, so every loop runs along rows) */
        double *p = values; /* scratch for p until the eigenvalues are written */
    for (int k = 0; k + 2 < m; k++) {
        double norm = 0.0;
        for (int i = k + 1; i < m; i++) norm += B(k, i) * B(k, i);
        if (norm == 0.0) continue;
        double alpha = B(k, k + 1) > 0.0 ? -sqrt(norm) : sqrt(norm);
        for (int i = k + 1; i < m; i++) v[i] = B(k, i);
        v[k + 1] -= alpha;
        double vv = 0.0;
        for (int i = k + 1; i < m; i++) vv += v[i] * v[i];
        if (vv == 0.0) continue;
        double beta = 2.0 / vv, vp = 0.0;
        for (int i = k + 1; i < m; i++) {
            const double *row = &B(i, 0);
            double s = 0.0;
            for (int j = k + 1; j < m; j++) s += row[j] * v[j];
            p[i] = beta * s;
            vp += v[i] * p[i];
        }
        double half = 0.5 * beta * vp;
        for (int i = k + 1; i < m; i++) p[i] -= half * v[i]; /* w = p - (beta v^T p / 2) v */
        for (int i = k + 1; i < m; i++) {
            double *row = &B(i, 0), vi = v[i], pi = p[i];
            for (int j = k + 1; j < m; j++) row[j] -= vi * p[j] + pi * v[j];
        }
        B(k + 1, k) = alpha;
        B(k, k + 1) = alpha;
        for (int i = k + 2; i < m; i++) B(i, k) = B(k, i) = 0.0;
    }
    }
    /* the tridiagonal matrix: diagonal into d, e[i] couples i and i + 1 (e in
     * B's last row, below its diagonal entry, which d takes first) */
    for (int i = 0; i < m; i++) d[i] = B(i, i);
    for (int i = 0; i + 1 < m; i++) e[i] = B(i + 1, i);
    if (m > 0) e[m - 1] = 0.0;
    for (int l = 0; l < m; l++) {
        for (int iter = 0; iter < MAX_SWEEPS; iter++) {
            int n_ = l;
            for (; n_ + 1 < m; n_++) {
                double dd = fabs(d[n_]) + fabs(d[n_ + 1]);
                if (fabs(e[n_]) <= DBL_EPSILON * dd) break;
            }
            if (n_ == l) break;
            /* Wilkinson's shift from the leading 2 x 2 block, chased up from n_ */
            double g = (d[l + 1] - d[l]) / (2.0 * e[l]);
            double r = sqrt(g * g + 1.0);
            g = d[n_] - d[l] + e[l] / (g + (g >= 0.0 ? r : -r));
            double s = 1.0, c = 1.0, shift = 0.0;
            int i, deflated = 0;
            for (i = n_ - 1; i >= l; i--) {
                double f = s * e[i], b = c * e[i];
                r = sqrt(f * f + g * g);
                e[i + 1] = r;
                if (r == 0.0) { /* underflow: split here and start over */
                    d[i + 1] -= shift;
                    e[n_] = 0.0;
                    deflated = 1;
                    break;
                }
                s = f / r;
                c = g / r;
                g = d[i + 1] - shift;
                r = (d[i] - g) * s + 2.0 * c * b;
                shift = s * r;
                d[i + 1] = g + shift;
                g = c * r - b;
            }
            if (deflated) continue;
            d[l] -= shift;
            e[l] = g;
            e[n_] = 0.0;
        }
    }
#undef B
}

/* Minimum-norm least-squares solution x (n) of J x = b with J (m x n, row
 * stride jstride) and b[r * bstride].  Singular values below rcond times the
 * largest count as zero, as in numpy.linalg.lstsq.  U (n x m) and V (m x m) are
 * scratch.  Returns the rank used. */
int grb_lstsq_min_norm(const double *J, int jstride, int m, int n, const double *b, int bstride, double rcond,
                       double *x, double *U, double *V) {
#define JJ(r, c) J[(r) * jstride + (c)]
#define UU(i, j) U[(i) * m + (j)]
#define VV(i, j) V[(i) * m + (j)]
    if (m == 2) {
        /* one closure, far from singular (every integrator step): x = J^T (J
         * J^T)^-1 b in closed form.  The Gram matrix squares J's condition
         * number, so this path is kept to det / trace^2 above GRAM_CUTOFF
         * (condition of J below ~1e4), where it loses nothing that matters. */
        double g00 = 0.0, g11 = 0.0, g01 = 0.0;
        for (int k = 0; k < n; k++) {
            g00 += JJ(0, k) * JJ(0, k);
            g11 += JJ(1, k) * JJ(1, k);
            g01 += JJ(0, k) * JJ(1, k);
        }
        double det = g00 * g11 - g01 * g01, tr = g00 + g11;
        if (det > GRAM_CUTOFF * tr * tr) {
            double b0 = b[0], b1 = b[bstride];
            double y0 = (g11 * b0 - g01 * b1) / det, y1 = (g00 * b1 - g01 * b0) / det;
            for (int k = 0; k < n; k++) x[k] = JJ(0, k) * y0 + JJ(1, k) * y1;
            return 2;
        }
    }
    if (m > GRB_JACOBI_ROWS && m == n) {
        /* many rows, square (a branch point's dependent columns): Gaussian
         * elimination with partial pivoting, kept while its pivots stay
         * within LU_CUTOFF (or a thousand times the cut-off asked for) of the
         * largest: the matrix is then regular and its solution the minimum-norm
         * one; a smaller pivot goes to the SVD below (U holds the factors) */
        double cutoff = fmax(LU_CUTOFF, 1e3 * rcond), big = 0.0, small = INFINITY;
        for (int r = 0; r < m; r++) {
            for (int c = 0; c < m; c++) UU(r, c) = JJ(r, c);
            x[r] = b[r * bstride];
        }
        int regular = 1;
        for (int c = 0; c < m && regular; c++) {
            int p = c;
            for (int r = c + 1; r < m; r++)
                if (fabs(UU(r, c)) > fabs(UU(p, c))) p = r;
            if (p != c) {
                for (int j = 0; j < m; j++) {
                    double t = UU(c, j);
                    UU(c, j) = UU(p, j);
                    UU(p, j) = t;
                }
                double t = x[c];
                x[c] = x[p];
                x[p] = t;
            }
            double pivot = fabs(UU(c, c));
            big = fmax(big, pivot);
            small = fmin(small, pivot);
            if (!(pivot > 0.0)) regular = 0;
            for (int r = c + 1; r < m && regular; r++) {
                double f = UU(r, c) / UU(c, c);
                if (f == 0.0) continue;
                for (int j = c + 1; j < m; j++) UU(r, j) -= f * UU(c, j);
                x[r] -= f * x[c];
            }
        }
        if (regular && small > cutoff * big) {
            for (int c = m - 1; c >= 0; c--) {
                double v = x[c];
                for (int k = c + 1; k < m; k++) v -= UU(c, k) * x[k];
                x[c] = v / UU(c, c);
            }
            return m;
        }
    } else if (m > GRB_JACOBI_ROWS) {
        /* many rows: the same normal equations, J J^T y = b (the Gram matrix in
         * V, y in U), by a Cholesky factor whose pivots stay above the two-row
         * form's cut-off; a Gram matrix nearer singular goes to the SVD below */
        for (int r = 0; r < m; r++)
            for (int c = 0; c <= r; c++) {
                double g = 0.0;
                for (int k = 0; k < n; k++) g += JJ(r, k) * JJ(c, k);
                VV(r, c) = VV(c, r) = g;
            }
        if (grb_cholesky(V, m, m, GRAM_CUTOFF)) {
            for (int r = 0; r < m; r++) U[r] = b[r * bstride];
            grb_cholesky_solve(V, m, m, U, 1);
            for (int k = 0; k < n; k++) {
                double v = 0.0;
                for (int r = 0; r < m; r++) v += JJ(r, k) * U[r];
                x[k] = v;
            }
            return m;
        }
    }
    /* one-sided Jacobi on the columns of J^T: J^T V = U diag(sigma) */
    for (int i = 0; i < n; i++)
        for (int j = 0; j < m; j++) UU(i, j) = JJ(j, i);
    for (int i = 0; i < m; i++)
        for (int j = 0; j < m; j++) VV(i, j) = i == j ? 1.0 : 0.0;
    for (int sweep = 0; sweep < MAX_SWEEPS; sweep++) {
        int rotated = 0;
        /* a column below rcond times the largest is dropped from the solution,
         * and turning it against the others only stirs its rounding, which
         * never settles (where J has more rows than columns, or redundant rows,
         * some columns are such noise): every pair still turns, as Jacobi needs
         * for the columns that count to come out orthogonal, but only pairs of
         * columns above the cut-off keep the sweeps going.  (Skipping the noisy
         * pairs' rotations instead left the columns that count tilted: the
         * coupling rod lost a change-point passage and 1e-2 J of its balance.) */
        double widest = 0.0;
        for (int j = 0; j < m; j++) {
            double s2 = 0.0;
            for (int k = 0; k < n; k++) s2 += UU(k, j) * UU(k, j);
            widest = fmax(widest, s2);
        }
        double negligible = rcond * rcond * widest;
        for (int p = 0; p < m; p++)
            for (int q = p + 1; q < m; q++) {
                double alpha = 0.0, beta = 0.0, gamma = 0.0;
                for (int k = 0; k < n; k++) {
                    alpha += UU(k, p) * UU(k, p);
                    beta += UU(k, q) * UU(k, q);
                    gamma += UU(k, p) * UU(k, q);
                }
                if (gamma == 0.0 || fabs(gamma) <= 1e-15 * sqrt(alpha * beta)) continue;
                if (alpha > negligible && beta > negligible) rotated = 1;
                double c, s;
                rotation(alpha, beta, gamma, &c, &s);
                rotate_columns(U, m, n, p, q, c, s);
                rotate_columns(V, m, m, p, q, c, s);
            }
        if (!rotated) break;
    }
    double sigma_max = 0.0;
    for (int j = 0; j < m; j++) {
        double s2 = 0.0;
        for (int k = 0; k < n; k++) s2 += UU(k, j) * UU(k, j);
        if (sqrt(s2) > sigma_max) sigma_max = sqrt(s2);
    }
    for (int k = 0; k < n; k++) x[k] = 0.0;
    int rank = 0;
    for (int j = 0; j < m; j++) {
        double s2 = 0.0;
        for (int k = 0; k < n; k++) s2 += UU(k, j) * UU(k, j);
        if (s2 == 0.0 || sqrt(s2) <= rcond * sigma_max) continue;
        rank++;
        /* x += u_j (v_j . b) / sigma_j with u_j = U[:, j] / sigma_j */
        double coef = 0.0;
        for (int i = 0; i < m; i++) coef += VV(i, j) * b[i * bstride];
        coef /= s2;
        for (int k = 0; k < n; k++) x[k] += UU(k, j) * coef;
    }
    return rank;
#undef JJ
#undef UU
#undef VV
}

int grb_lstsq(const double *J, int m, int n, const double *b, double rcond, double *x, double *scratch) {
    if (m < 0 || n < 0) return -1;
    return grb_lstsq_min_norm(J, n, m, n, b, 1, rcond, x, scratch, scratch + (size_t)n * m);
}
#endif
