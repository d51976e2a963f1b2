"""Dense linear algebra on the kernels' small matrices (a few rows), compiled.

The matrices here are N x N with N the number of moving links, or as large as the
number of closure rows: far too small for LAPACK's call overhead to pay, and
numba's LAPACK bindings take tens of seconds to compile.  Three classical
algorithms cover what the equations of motion and the projection need:

- :func:`lu_solve`, Gaussian elimination with partial pivoting (``gesv``);
- :func:`sym_eig`, the cyclic Jacobi method for symmetric matrices (``syev``);
- :func:`lstsq_min_norm`, the minimum-norm least-squares solution with a relative
  singular-value cut-off by one-sided (Hestenes) Jacobi SVD (``gelsd``).

Jacobi methods are as accurate as their LAPACK counterparts (more so for small
singular values) and converge in a handful of sweeps at these sizes.  They work on
blocks of columns of the caller's wide tables (see :mod:`grubler.dynamics`),
because every array a compiled function takes costs compile time.

Examples
--------
>>> import numpy as np
>>> J = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
>>> b = np.array([[1.0], [2.0]])
>>> T, V = np.zeros((3, 3)), np.zeros((2, 2))
>>> lstsq_min_norm(J, b, 0, 1e-8, T, 0, 1, V)
2
>>> bool(np.allclose(T[:, 0], np.linalg.lstsq(J, b[:, 0], rcond=None)[0]))
True
"""

from __future__ import annotations

import math

from .jit import jit

MAX_SWEEPS = 60
GRAM_CUTOFF = 1e-8  # det / trace^2 of J J^T above which lstsq_min_norm solves two rows in closed form


@jit
def lu_solve(T, a0, x0, ncols):
    """Solve ``A Y = X`` in place by Gaussian elimination with partial pivoting.

    ``A`` is the square block of ``T`` starting at column ``a0`` (destroyed), ``X``
    the ``ncols`` columns from ``x0`` (overwritten by ``Y``).  False when a pivot is
    exactly zero (the matrix is singular), as LAPACK's ``gesv`` reports it.
    """
    n = T.shape[0]
    for c in range(n):
        p = c
        big = abs(T[c, a0 + c])
        for r in range(c + 1, n):
            if abs(T[r, a0 + c]) > big:
                big = abs(T[r, a0 + c])
                p = r
        if big == 0.0:
            return False
        if p != c:
            for j in range(n):
                T[c, a0 + j], T[p, a0 + j] = T[p, a0 + j], T[c, a0 + j]
            for j in range(ncols):
                T[c, x0 + j], T[p, x0 + j] = T[p, x0 + j], T[c, x0 + j]
        for r in range(c + 1, n):
            f = T[r, a0 + c] / T[c, a0 + c]
            if f != 0.0:
                for j in range(c + 1, n):
                    T[r, a0 + j] -= f * T[c, a0 + j]
                for j in range(ncols):
                    T[r, x0 + j] -= f * T[c, x0 + j]
    for c in range(n - 1, -1, -1):
        for j in range(ncols):
            s = T[c, x0 + j]
            for k in range(c + 1, n):
                s -= T[c, a0 + k] * T[k, x0 + j]
            T[c, x0 + j] = s / T[c, a0 + c]
    return True


@jit
def _rotation(app, aqq, apq):
    """Cosine and sine of the Jacobi rotation that zeroes apq (Rutishauser's form)."""
    theta = (aqq - app) / (2.0 * apq)
    t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
    if theta < 0.0:
        t = -t
    c = 1.0 / math.sqrt(t * t + 1.0)
    return c, t * c


@jit
def sym_eig(Q):
    """Eigen-decomposition of a symmetric m x m matrix S held in ``Q`` (m x 3m+1).

    ``Q = [S | scratch | V | w]``: S (columns 0..m-1) is kept, the eigenvectors land
    in the columns of V and the eigenvalues (not sorted) in the last column.
    """
    m = Q.shape[0]
    B = Q[:, m:2 * m]
    V = Q[:, 2 * m:3 * m]
    for i in range(m):
        for j in range(m):
            B[i, j] = Q[i, j]
            V[i, j] = 1.0 if i == j else 0.0
    for _ in range(MAX_SWEEPS):
        off = 0.0
        diag = 0.0
        for i in range(m):
            diag += B[i, i] * B[i, i]
            for j in range(i + 1, m):
                off += B[i, j] * B[i, j]
        if off <= 1e-36 * diag or off == 0.0:
            break
        for p in range(m):
            for q in range(p + 1, m):
                if B[p, q] == 0.0:
                    continue
                c, s = _rotation(B[p, p], B[q, q], B[p, q])
                for k in range(m):  # columns p, q
                    bkp, bkq = B[k, p], B[k, q]
                    B[k, p] = c * bkp - s * bkq
                    B[k, q] = s * bkp + c * bkq
                for k in range(m):  # rows p, q
                    bpk, bqk = B[p, k], B[q, k]
                    B[p, k] = c * bpk - s * bqk
                    B[q, k] = s * bpk + c * bqk
                for k in range(m):
                    vkp, vkq = V[k, p], V[k, q]
                    V[k, p] = c * vkp - s * vkq
                    V[k, q] = s * vkp + c * vkq
    for i in range(m):
        Q[i, 3 * m] = B[i, i]


@jit
def lstsq_min_norm(J, B, b_col, rcond, T, x_col, u0, V):
    """Minimum-norm least-squares solution of ``J x = b`` with J (m x n).

    ``b`` is column ``b_col`` of ``B``; ``x`` lands in column ``x_col`` of ``T`` and the
    m columns of ``T`` from ``u0`` and ``V`` (m x m) are scratch.  Singular values
    below ``rcond`` times the largest count as zero, as in ``numpy.linalg.lstsq``.
    Returns the rank used.
    """
    m, n = J.shape
    if m == 2:
        # one closure, far from singular (the usual case, every integrator step):
        # x = J^T (J J^T)^-1 b in closed form.  The Gram matrix squares J's
        # condition number, so this path is kept to det / trace^2 above GRAM_CUTOFF
        # (condition of J below ~1e4), where it loses nothing that matters.
        g00 = 0.0
        g11 = 0.0
        g01 = 0.0
        for k in range(n):
            g00 += J[0, k] * J[0, k]
            g11 += J[1, k] * J[1, k]
            g01 += J[0, k] * J[1, k]
        det = g00 * g11 - g01 * g01
        tr = g00 + g11
        if det > GRAM_CUTOFF * tr * tr:
            b0 = B[0, b_col]
            b1 = B[1, b_col]
            y0 = (g11 * b0 - g01 * b1) / det
            y1 = (g00 * b1 - g01 * b0) / det
            for k in range(n):
                T[k, x_col] = J[0, k] * y0 + J[1, k] * y1
            return 2
    U = T[:, u0:u0 + m]
    # one-sided Jacobi on the columns of J^T: J^T V = U diag(sigma), J = V diag(sigma) U'^T
    for i in range(n):
        for j in range(m):
            U[i, j] = J[j, i]
    for i in range(m):
        for j in range(m):
            V[i, j] = 1.0 if i == j else 0.0
    for _ in range(MAX_SWEEPS):
        rotated = False
        for p in range(m):
            for q in range(p + 1, m):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for k in range(n):
                    alpha += U[k, p] * U[k, p]
                    beta += U[k, q] * U[k, q]
                    gamma += U[k, p] * U[k, q]
                if gamma == 0.0 or abs(gamma) <= 1e-15 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                c, s = _rotation(alpha, beta, gamma)
                for k in range(n):
                    ukp, ukq = U[k, p], U[k, q]
                    U[k, p] = c * ukp - s * ukq
                    U[k, q] = s * ukp + c * ukq
                for k in range(m):
                    vkp, vkq = V[k, p], V[k, q]
                    V[k, p] = c * vkp - s * vkq
                    V[k, q] = s * vkp + c * vkq
        if not rotated:
            break
    sigma_max = 0.0
    for j in range(m):
        s2 = 0.0
        for k in range(n):
            s2 += U[k, j] * U[k, j]
        sigma_max = max(sigma_max, math.sqrt(s2))
    for k in range(n):
        T[k, x_col] = 0.0
    rank = 0
    for j in range(m):
        s2 = 0.0
        for k in range(n):
            s2 += U[k, j] * U[k, j]
        if s2 == 0.0 or math.sqrt(s2) <= rcond * sigma_max:
            continue
        rank += 1
        # x += u_j (v_j . b) / sigma_j with u_j = U[:, j] / sigma_j
        coef = 0.0
        for i in range(m):
            coef += V[i, j] * B[i, b_col]
        coef /= s2
        for k in range(n):
            T[k, x_col] += U[k, j] * coef
    return rank
