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
