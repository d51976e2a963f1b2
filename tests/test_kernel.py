"""The compiled kernel's own contract: its coefficient tables, its guards, its binding."""

import math
import pickle

import numpy as np
import pytest
from scipy.integrate._ivp import dop853_coefficients as dc

import grubler
from grubler import binding
from grubler.errors import IntegrationError
from grubler.mechanism.simulate import Simulator


def _table(ptr, count):
    return np.array([ptr[i] for i in range(count)])


def test_dop853_table_is_scipys():
    # the C table was printed from scipy's copy of Hairer's coefficients: it must
    # still be that table, digit for digit
    tab = binding.library().grb_tableau(0).contents
    s, lda = tab.stages, tab.lda
    assert (s, tab.dense_stages, tab.dense_rows) == (dc.N_STAGES, dc.N_STAGES_EXTENDED - dc.N_STAGES - 1, 4)
    A = _table(tab.A, 16 * lda).reshape(16, lda)
    assert np.array_equal(A[:s, :s], dc.A[:s, :s])
    assert np.array_equal(_table(tab.b, s), dc.B)
    assert np.array_equal(_table(tab.c, s), dc.C[:s])
    assert np.array_equal(_table(tab.e, s + 1), dc.E5)
    assert np.array_equal(_table(tab.e3, s + 1), dc.E3)
    assert np.array_equal(_table(tab.dense_a, 3 * lda).reshape(3, lda), dc.A[s + 1:])
    assert np.array_equal(_table(tab.dense_c, 3), dc.C[s + 1:])
    assert np.array_equal(_table(tab.dense_d, 4 * lda).reshape(4, lda), dc.D)


def test_rk45_weights_are_consistent():
    # order conditions a reader can check by hand: rows of A sum to c, b sums to 1,
    # the error weights sum to 0
    tab = binding.library().grb_tableau(1).contents
    s = tab.stages
    A = _table(tab.A, s * tab.lda).reshape(s, tab.lda)
    np.testing.assert_allclose(A.sum(axis=1), _table(tab.c, s), atol=1e-15)
    assert abs(_table(tab.b, s).sum() - 1.0) < 1e-15
    assert abs(_table(tab.e, s + 1).sum()) < 1e-15


def test_an_absurd_tolerance_stops_instead_of_spinning():
    # rtol 1e-200 once made the error norm overflow, the step nan and the
    # rejection loop endless; now the step-size guard ends it by name
    sim = Simulator(grubler.load_scene("thesis-fourbar").mechanism, rtol=1e-200, atol=1e-300)
    with pytest.raises(IntegrationError, match="step size fell below"):
        sim.advance_to(0.01)
    assert sim.t == 0.0  # all or nothing


def test_a_failing_drive_function_raises_its_own_error():
    def torque(t):
        if t > 0.05:
            raise RuntimeError("sensor lost")
        return 1.0

    with pytest.raises(RuntimeError, match="sensor lost"):
        grubler.simulate("thesis-fourbar", t_end=0.1, torque=torque)


def test_a_model_survives_pickling_with_a_fresh_kernel_struct():
    m = grubler.load_scene("thesis-fourbar").mechanism
    copy = pickle.loads(pickle.dumps(m))
    assert copy.arrays.c != m.arrays.c  # its own tables, not the original's addresses
    a, b = Simulator(copy), Simulator(m)
    a.advance_to(0.2)
    b.advance_to(0.2)
    assert np.array_equal(a.z, b.z)


def test_kernel_refuses_times_out_of_order():
    sim = Simulator(grubler.load_scene("thesis-fourbar").mechanism)
    with pytest.raises(ValueError, match="times"):
        sim.advance_through([0.5, 0.2])
    assert math.isfinite(sim.t)


def test_complex_step_derivatives_match_central_differences():
    # the equations compiled over complex numbers give d(ydot)/dy exactly; a
    # central difference (error ~ h^2) must agree with it to its own accuracy
    from grubler.mechanism.assembly import assemble

    m = grubler.load_scene("thesis-fourbar").mechanism
    n, lib = m.n_links, binding.library()
    z, zd = assemble(m, m.z_from_q(m.q_ref), np.array([1.0, 0.0, 0.0]))
    y = np.concatenate([z, zd])
    work_r, work_c = binding.work(n, 1), np.zeros(binding.work(n, 1).size, dtype=complex)
    efforts = np.array([2.0, 0.0], dtype=complex)

    def f(yy):
        out = np.empty(2 * n)
        lib.grb_rhs(m.arrays.c, 0, binding.address(yy), 2.0, 0.0, binding.address(work_r), binding.address(out))
        return out

    for k in range(2 * n):
        yc = y.astype(complex)
        yc[k] += 1e-30j
        out = np.empty(2 * n, dtype=complex)
        lib.grb_cs_rhs_at(m.arrays.c, 0, binding.address(yc), binding.address(efforts), binding.address(work_c),
                          binding.address(out))
        assert np.array_equal(out.real, f(y))  # the real part is the plain evaluation, bit for bit
        h = 1e-5
        e = np.zeros(2 * n)
        e[k] = h
        central = (f(y + e) - f(y - e)) / (2 * h)
        np.testing.assert_allclose(out.imag / 1e-30, central, rtol=1e-6, atol=1e-6)


def test_a_workspace_laid_out_for_another_model_is_refused_not_read_past():
    # the workspace carries the sizes it was laid out for: a four-bar's buffer
    # handed to a six-bar's call (smaller than its tables) is refused by status
    lib = binding.library()
    four = grubler.load_scene("thesis-fourbar").mechanism
    six = grubler.load_scene("stephenson-iii").mechanism
    y6 = np.zeros(2 * six.n_links)
    small = binding.work(four.n_links, len(four.closures))
    before = small.copy()
    out = np.zeros(2 * six.n_links)
    status = lib.grb_rhs(six.arrays.c, 0, binding.address(y6), 0.0, 0.0, binding.address(small),
                         binding.address(out))
    assert status == binding.BAD_ARGUMENT
    assert np.array_equal(small, before)
    assert "size" in binding.status_message(status)
    # a buffer shorter than the model's tables cannot be laid out for it
    short = np.zeros(lib.grb_work_size(six.n_links, len(six.closures)) - 1)
    assert lib.grb_work_init(six.n_links, len(six.closures), binding.address(short), short.size) == \
        binding.BAD_ARGUMENT


def test_joint_reactions_need_a_workspace_the_forward_dynamics_filled():
    lib = binding.library()
    m = grubler.load_scene("thesis-fourbar").mechanism
    z, zd = grubler.assemble(m, m.z_from_q(m.q_ref), np.ones(m.n_free))
    y = np.concatenate([z, zd])
    work, out = binding.work(m.n_links, len(m.closures)), np.zeros(3 * m.n_links)
    assert lib.grb_joint_reactions(m.arrays.c, binding.address(work), binding.address(out)) == binding.BAD_ARGUMENT
    assert lib.grb_evaluate(m.arrays.c, 0, binding.address(y), 1.0, 0.0, binding.address(work)) == binding.OK
    assert lib.grb_joint_reactions(m.arrays.c, binding.address(work), binding.address(out)) == binding.OK
    assert np.all(np.isfinite(out))
    # a projection overwrites the tables: they no longer hold that evaluation
    assert lib.grb_project(m.arrays.c, 1.0, binding.address(y.copy()), binding.address(work)) == binding.OK
    assert lib.grb_joint_reactions(m.arrays.c, binding.address(work), binding.address(out)) == binding.BAD_ARGUMENT
