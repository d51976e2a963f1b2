"""The compiled small-matrix solvers against numpy's LAPACK."""

import numpy as np
import pytest

from grubler.binding import lstsq


def _solve(J, b, rcond=1e-8):
    return lstsq(J, b, rcond)


@pytest.mark.parametrize("n", [2, 3, 6])
def test_two_rows_well_conditioned_match_lapack(n):
    # the closed form for one closure (two rows), the path of every projection
    rng = np.random.default_rng(n)
    for _ in range(50):
        J, b = rng.normal(size=(2, n)), rng.normal(size=2)
        x, rank = _solve(J, b)
        assert rank == 2
        np.testing.assert_allclose(x, np.linalg.lstsq(J, b, rcond=None)[0], rtol=1e-10, atol=1e-12)


def test_two_rows_ill_conditioned_keep_their_accuracy():
    # condition 1e6: beyond the closed form's cut-off, solved by the Jacobi SVD
    rng = np.random.default_rng(7)
    u = rng.normal(size=3)
    J = np.vstack([u, u + 1e-6 * rng.normal(size=3)])
    b = J @ rng.normal(size=3)
    x, rank = _solve(J, b)
    assert rank == 2
    np.testing.assert_allclose(J @ x, b, rtol=0, atol=1e-9)
    np.testing.assert_allclose(x, np.linalg.lstsq(J, b, rcond=1e-8)[0], rtol=1e-6)


def test_dependent_rows_drop_a_direction_like_lapack():
    # a change point: the two closure rows are parallel, the minimum-norm solution
    # of the consistent part is returned
    J = np.array([[1.0, 2.0, 0.5], [2.0, 4.0, 1.0]])
    b = np.array([1.0, 2.0])
    x, rank = _solve(J, b)
    assert rank == 1
    np.testing.assert_allclose(x, np.linalg.lstsq(J, b, rcond=1e-8)[0], rtol=1e-12, atol=1e-14)


def test_three_and_four_rows_match_lapack():
    rng = np.random.default_rng(3)
    for m in (3, 4):
        J, b = rng.normal(size=(m, 6)), rng.normal(size=m)
        x, rank = _solve(J, b)
        assert rank == m
        np.testing.assert_allclose(x, np.linalg.lstsq(J, b, rcond=None)[0], rtol=1e-9, atol=1e-12)


# -- many rows (more than GRB_JACOBI_ROWS = 8): Gaussian elimination (square) or the Cholesky-factored normal
# equations, each kept only where it finds the matrix regular; the Jacobi SVD past that

@pytest.mark.parametrize("m, n", [(9, 9), (20, 20), (80, 80), (9, 12), (30, 41), (80, 81)])
def test_many_rows_well_conditioned_match_lapack(m, n):
    rng = np.random.default_rng(m * 100 + n)
    J, b = rng.normal(size=(m, n)), rng.normal(size=m)
    x, rank = _solve(J, b, rcond=1e-13)
    assert rank == m
    np.testing.assert_allclose(x, np.linalg.lstsq(J, b, rcond=None)[0], rtol=1e-9, atol=1e-11)


@pytest.mark.parametrize("m, n", [(12, 12), (12, 15)])
def test_many_rows_rank_deficient_fall_back_to_the_minimum_norm_svd(m, n):
    # a repeated row: elimination meets a zero pivot, the Gram matrix is singular; both hand the system to the
    # SVD, whose answer is the minimum-norm one (the fast paths would give none, or a wrong one)
    rng = np.random.default_rng(m + n)
    J = rng.normal(size=(m, n))
    J[-1] = J[0]
    b = J @ rng.normal(size=n)
    x, rank = _solve(J, b, rcond=1e-12)
    assert rank == m - 1
    np.testing.assert_allclose(x, np.linalg.lstsq(J, b, rcond=1e-12)[0], rtol=1e-8, atol=1e-10)


def test_many_rows_near_singular_keep_the_cutoff():
    # one singular value at 1e-11 of the largest, below rcond 1e-8: the fast paths would solve it (and blow the
    # answer up by 1e11 along that direction); the cut-off drops it as numpy's lstsq does
    rng = np.random.default_rng(3)
    U, _ = np.linalg.qr(rng.normal(size=(10, 10)))
    V, _ = np.linalg.qr(rng.normal(size=(10, 10)))
    s = np.linspace(1.0, 0.5, 10)
    s[-1] = 1e-11
    J = U @ np.diag(s) @ V.T
    b = rng.normal(size=10)
    x, rank = _solve(J, b, rcond=1e-8)
    assert rank == 9
    np.testing.assert_allclose(x, np.linalg.lstsq(J, b, rcond=1e-8)[0], rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("m", [9, 10, 40, 80])
def test_eigenvalues_of_many_rows_match_lapack(m):
    # grb_sym_eigenvalues (tridiagonal QL: the closures' conditioning and rank beyond 8 rows) on Gram matrices
    # J J^T as the kernel forms them: full rank, and rank-deficient with a cluster of zeros (A02's pinch)
    import ctypes

    from grubler.binding import address, library

    fn = library().grb_sym_eigenvalues
    fn.restype, fn.argtypes = None, [ctypes.c_void_p] * 4 + [ctypes.c_int]
    rng = np.random.default_rng(m)
    for rank in (m, m // 2):
        J = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, m + 1))
        G = np.ascontiguousarray(J @ J.T)
        B, v, values = np.zeros(m * m), np.zeros(m), np.zeros(m)
        fn(address(G), address(B), address(v), address(values), m)
        expected = np.linalg.eigvalsh(G)
        np.testing.assert_allclose(np.sort(values), expected, rtol=0, atol=1e-12 * expected[-1])


@pytest.mark.parametrize("m, band", [(9, 2), (40, 3), (80, 3), (80, 20)])
def test_eigenvalues_of_a_banded_matrix_match_lapack(m, band):
    # a narrow band (a chain of many small loops: A02's J J^T has half bandwidth 3) goes to tridiagonal form by
    # Givens rotations and bulge chasing instead of Householder reflections
    import ctypes

    from grubler.binding import address, library

    fn = library().grb_sym_eigenvalues
    fn.restype, fn.argtypes = None, [ctypes.c_void_p] * 4 + [ctypes.c_int]
    rng = np.random.default_rng(m + band)
    A = rng.normal(size=(m, m))
    G = np.ascontiguousarray(np.triu(np.tril(A + A.T, band), -band))
    B, v, values = np.zeros(m * m), np.zeros(m), np.zeros(m)
    fn(address(G), address(B), address(v), address(values), m)
    expected = np.linalg.eigvalsh(G)
    np.testing.assert_allclose(np.sort(values), expected, rtol=0, atol=1e-13 * np.max(np.abs(expected)))
