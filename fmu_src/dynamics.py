"""Equations of motion of the generalised chain, derived from its Jacobians.

By the principle of virtual power, with ``J_c`` the Jacobian of a link's mass
centre and ``J_w`` of its angle,

    M(z) = sum_k m_k J_c^T J_c + I_k J_w^T J_w,
    h(z, zd) = sum_k m_k J_c^T a_c,bias,
    Q = sum_k m_k J_c^T g + joint torques (drive, load, -damping * rate),

and the closures add ``J_phi^T lambda``.  The two closure methods differ only in
how ``lambda`` is found: the exact method solves it from ``J_phi zdd = gamma``
(index-1 DAE, drift removed by projection in the integrator); the penalty method
is the thesis's imaginary joint, ``lambda = -G phi - C phi_dot``.

Everything is a function of (model, state, inputs): no hidden state.  The right-hand
side is one compiled kernel, :func:`accelerations`, over the model's packed tables
(``Mechanism.arrays.packed``) and a workspace of arrays it fills (:func:`workspace`);
:func:`forward_dynamics` and the other public functions wrap it for Python callers.

Examples
--------
>>> import numpy as np
>>> from grubler import load_scene
>>> m = load_scene("thesis-fourbar").mechanism
>>> from grubler.assembly import assemble
>>> z, zd = assemble(m, m.z_from_q(m.q_ref))
>>> dyn = forward_dynamics(m, z, zd, Inputs())
>>> dyn.zdd.shape, dyn.lam.shape
((3,), (2,))
>>> bool(abs(dyn.ck.J @ dyn.zdd - dyn.ck.gamma).max() < 1e-12)
True
"""

from __future__ import annotations

import itertools
import math
import weakref
from dataclasses import dataclass
from typing import Callable

import numba
import numpy as np

from .jit import jit
from .kinematics import (
    K_CBX,
    K_CBY,
    K_COLUMNS,
    K_CX,
    K_CY,
    K_OM,
    K_OX,
    K_OY,
    K_RATE,
    K_SLIDE,
    K_TH,
    R_B,
    R_COLUMNS,
    R_GAMMA,
    R_LAM,
    R_NORMAL,
    R_PHI,
    R_POINT,
    ChainKinematics,
    ClosureKinematics,
    chain_into,
    chain_kinematics,
    closure_into,
    closure_kinematics,
    point_into,
)
from .linalg import lu_solve, sym_eig
from .model import (
    CL_DAMP,
    CL_GAIN,
    CL_KIND,
    CL_LINK,
    CL_TO,
    L_A,
    L_DAMP,
    L_I,
    L_M,
    L_P,
    L_Q,
    L_REV,
    PRISMATIC_CLOSURE,
    Mechanism,
    coordinate_names,
)

EXACT = "exact"
PENALTY = "penalty"
METHODS = (EXACT, PENALTY)
METHOD_CODE = {EXACT: 0, PENALTY: 1}


@dataclass
class Inputs:
    """Joint efforts applied at one instant.

    Parameters
    ----------
    drive : float
        Motor torque (N m) or force (N, prismatic) on the model's drive joint.
    load : float
        Load torque or force on the model's load joint.
    """

    drive: float = 0.0
    load: float = 0.0


# -- drive efforts given as functions of time ----------------------------------
# A compiled integrator cannot hold a Python callable; it holds a key into this
# table and calls back into Python (numba's object mode) only when the key is set.
_DRIVES: dict[int, Callable[[float], float]] = {}
_drive_keys = itertools.count()


def register_drive(owner, fn: Callable[[float], float]) -> int:
    """Key under which the kernels find ``fn``; dropped when ``owner`` is collected."""
    key = next(_drive_keys)
    _DRIVES[key] = fn
    weakref.finalize(owner, _DRIVES.pop, key, None)
    return key


def _drive_value(key: int, t: float) -> float:
    return float(_DRIVES[key](t))


@jit(nrt=True)  # object mode needs reference counting
def drive_at(key, t, tau):
    """The drive effort at ``t``: ``tau``, or the registered function's value."""
    if key < 0:
        return tau
    with numba.objmode(value="float64"):
        value = _drive_value(key, t)
    return value


# -- compiled kernels -----------------------------------------------------------
# The workspace: K (N, K_COLUMNS) link table, Jc (N, 2, N) mass-centre Jacobians, J (m + 3, N)
# closure Jacobian (+ 3 scratch rows), R (m, 6) constraint-row table, T the
# N-row solver table and Q the m-row one.  T's columns: M, then the matrix the
# solve destroys, the right-hand sides (forces, then J^T), zdd, a scratch vector,
# and m scratch columns; Q's: the Schur complement S, scratch, eigenvectors,
# eigenvalues.
@jit
def t_columns(n, m):
    """Column offsets in T: matrix, right-hand sides, zdd, scratch vector, scratch block."""
    return n, 2 * n, 2 * n + m + 1, 2 * n + m + 2, 2 * n + m + 3


@jit(nrt=True)
def workspace(n, n_closures):
    """The tables the kernels fill, for N links and C closures (see above)."""
    m = 2 * n_closures
    return (np.zeros((n, K_COLUMNS)), np.zeros((n, 2, n)), np.zeros((m + 3, n)), np.zeros((m, R_COLUMNS)),
            np.zeros((n, 2 * n + 2 * m + 3)), np.zeros((m, 3 * m + 1)))


@jit
def mass_into(L, K, Jc):
    """Mass centres, their Jacobians ``Jc[k]`` (2 x N) and bias accelerations."""
    for k in range(L.shape[0]):
        cx, cy, bx, by = point_into(L, K, k, L[k, L_P], L[k, L_Q], Jc[k])
        K[k, K_CX] = cx
        K[k, K_CY] = cy
        K[k, K_CBX] = bx
        K[k, K_CBY] = by


@jit
def mass_matrix_into(L, Jc, drive, drive_inertia, T):
    """M = sum_k m_k Jc^T Jc + I_k Jw^T Jw (+ the drive's inertia) into ``T[:, :N]``."""
    n = L.shape[0]
    for i in range(n):
        for j in range(n):
            T[i, j] = 0.0
    for k in range(n):
        m, inertia = L[k, L_M], L[k, L_I]
        for i in range(k + 1):
            wi = inertia * L[i, L_REV]
            for j in range(i, k + 1):
                T[i, j] += m * (Jc[k, 0, i] * Jc[k, 0, j] + Jc[k, 1, i] * Jc[k, 1, j]) + wi * L[j, L_REV]
    for i in range(n):
        for j in range(i):
            T[i, j] = T[j, i]
    if drive >= 0:
        T[drive, drive] += drive_inertia


@jit
def force_into(L, Jc, K, gravity, zd, drive, load, tau_drive, tau_load, T, col):
    """Applied minus velocity-product force, ``Q - h``, into ``T[:, col]``."""
    n = L.shape[0]
    for i in range(n):
        T[i, col] = -L[i, L_DAMP] * zd[i]
    for k in range(n):
        m = L[k, L_M]
        # gravity along -y, and the bias (Coriolis, centripetal) acceleration
        fx = -m * K[k, K_CBX]
        fy = -m * (gravity + K[k, K_CBY])
        for i in range(k + 1):
            T[i, col] += Jc[k, 0, i] * fx + Jc[k, 1, i] * fy
    if drive >= 0:
        T[drive, col] += tau_drive
    if load >= 0:
        T[load, col] += tau_load


# Relative eigenvalue below which a closure direction counts as lost.  At a
# change-point linkage's aligned position the closure rows become dependent and
# their multiplier is undetermined; dropping that direction keeps the motion
# defined through it, and the projection removes the small drift it leaves.
SINGULAR_RCOND = 1e-10


@jit
def closure_multipliers(Q, R):
    """Solve ``S lam = b`` (S = ``Q[:, :m]`` symmetric, >= 0) dropping lost closure directions.

    ``b`` and ``lam`` are columns R_B and R_LAM of ``R``.
    """
    m = Q.shape[0]
    if m == 2:
        # one closure: the 2 x 2 case in closed form; det / trace^2 is the
        # eigenvalue ratio the cut-off below tests, to first order
        det = Q[0, 0] * Q[1, 1] - Q[0, 1] * Q[1, 0]
        tr = Q[0, 0] + Q[1, 1]
        if det > SINGULAR_RCOND * tr * tr:
            R[0, R_LAM] = (Q[1, 1] * R[0, R_B] - Q[0, 1] * R[1, R_B]) / det
            R[1, R_LAM] = (Q[0, 0] * R[1, R_B] - Q[1, 0] * R[0, R_B]) / det
            return
    sym_eig(Q)
    v0, w0 = 2 * m, 3 * m
    w_max = -np.inf
    for i in range(m):
        w_max = max(w_max, Q[i, w0])
    for r in range(m):
        R[r, R_LAM] = 0.0
    for i in range(m):
        if Q[i, w0] > SINGULAR_RCOND * w_max:
            coef = 0.0
            for r in range(m):
                coef += Q[r, v0 + i] * R[r, R_B]
            coef /= Q[i, w0]
            for r in range(m):
                R[r, R_LAM] += Q[r, v0 + i] * coef


@jit
def accelerations(P, method, z, zd, tau_drive, tau_load, W):
    """Joint accelerations and closure multipliers at one state, into the workspace.

    ``P`` is ``Mechanism.arrays.packed``, ``method`` 0 (exact) or 1 (penalty), ``W``
    a :func:`workspace`; zdd lands in ``T``'s zdd column, the multipliers in
    ``R[:, R_LAM]``.  Returns False (and nan accelerations) when the matrix to
    solve is singular.
    """
    L, CL, theta1, gravity, drive, load, drive_inertia = P
    K, Jc, J, R, T, Q = W
    n = L.shape[0]
    m = 2 * CL.shape[0]
    a0, x0, dd, _, _ = t_columns(n, m)
    chain_into(L, theta1, z, zd, K)
    mass_into(L, K, Jc)
    closure_into(L, CL, K, zd, J, R)
    mass_matrix_into(L, Jc, drive, drive_inertia, T)
    force_into(L, Jc, K, gravity, zd, drive, load, tau_drive, tau_load, T, x0)
    for i in range(n):
        for j in range(n):
            T[i, a0 + j] = T[i, j]
    if m > 0 and method == 1:
        # the thesis's imaginary joint: spring G and damper C on each violation
        for r in range(m):
            phidot = 0.0
            for i in range(n):
                phidot += J[r, i] * zd[i]
            lam = -CL[r // 2, CL_GAIN] * R[r, R_PHI] - CL[r // 2, CL_DAMP] * phidot
            R[r, R_LAM] = lam
            for i in range(n):
                T[i, x0] += J[r, i] * lam
    if m == 0 or method == 1:
        ok = lu_solve(T, a0, x0, 1)
        for i in range(n):
            T[i, dd] = T[i, x0] if ok else np.nan
        return ok
    # M may be singular where a real coordinate carries no inertia of its own (a
    # point-mass slider's rotation); M + a J^T J is not, and since J zdd = gamma
    # the added term changes nothing in the solution (augmented Lagrangian).
    trace = 0.0
    for i in range(n):
        trace += T[i, i]
    jj = 0.0
    for r in range(m):
        for i in range(n):
            jj += J[r, i] * J[r, i]
    a = trace / max(jj, 1e-300)
    for r in range(m):
        for i in range(n):
            T[i, x0] += a * J[r, i] * R[r, R_GAMMA]
            T[i, x0 + 1 + r] = J[r, i]
            for j in range(n):
                T[i, a0 + j] += a * J[r, i] * J[r, j]
    ok = lu_solve(T, a0, x0, m + 1)
    # the Schur complement J (M + a J^T J)^-1 J^T and what the closure still lacks
    for r in range(m):
        s = R[r, R_GAMMA]
        for i in range(n):
            s -= J[r, i] * T[i, x0]
        R[r, R_B] = s
        for c in range(m):
            s = 0.0
            for i in range(n):
                s += J[r, i] * T[i, x0 + 1 + c]
            Q[r, c] = s
    if ok:
        closure_multipliers(Q, R)
    for i in range(n):
        s = T[i, x0]
        for c in range(m):
            s += T[i, x0 + 1 + c] * R[c, R_LAM]
        T[i, dd] = s if ok else np.nan
    return ok


@jit
def rhs_into(P, method, t, y, drive_key, tau_drive, tau_load, W, out):
    """The state equation ``ydot = (zd, zdd)`` at ``y = (z, zd)``; True unless singular."""
    n = y.shape[0] // 2
    ok = accelerations(P, method, y[:n], y[n:], drive_at(drive_key, t, tau_drive), tau_load, W)
    T = W[4]
    dd = t_columns(n, 2 * P[1].shape[0])[2]
    for i in range(n):
        out[i] = y[n + i]
        out[n + i] = T[i, dd]
    return ok


@jit
def reactions_into(P, W, out, o):
    """Force and moment each link's predecessor exerts on it, after :func:`accelerations`.

    Newton-Euler from the tip back to the ground; ``out[o + 3k : o + 3k + 3]`` is
    (Fx, Fy, Mz) for the joint pair of link k+2, acting at its revolute point O_{k+2}.
    """
    L, CL, gravity = P[0], P[1], P[3]
    K, Jc, R, T = W[0], W[1], W[3], W[4]
    n = L.shape[0]
    dd = t_columns(n, 2 * CL.shape[0])[2]
    for i in range(3 * n):
        out[o + i] = 0.0
    # first the closures' forces on the links they join, about each link's origin
    for j in range(CL.shape[0]):
        r = 2 * j
        if CL[j, CL_KIND] == PRISMATIC_CLOSURE:
            fx, fy, mz = R[r, R_NORMAL] * R[r, R_LAM], R[r + 1, R_NORMAL] * R[r, R_LAM], R[r + 1, R_LAM]
        else:
            fx, fy, mz = R[r, R_LAM], R[r + 1, R_LAM], 0.0
        px, py = R[r, R_POINT], R[r + 1, R_POINT]
        for side in range(2):
            k = int(CL[j, CL_LINK]) if side == 0 else int(CL[j, CL_TO])
            if k < 0:  # the ground
                continue
            sign = 1.0 if side == 0 else -1.0
            out[o + 3 * k] += sign * fx
            out[o + 3 * k + 1] += sign * fy
            out[o + 3 * k + 2] += sign * (mz + (px - K[k, K_OX]) * fy - (py - K[k, K_OY]) * fx)
    fnx = fny = nn = 0.0
    for k in range(n - 1, -1, -1):
        ax, ay, alpha = K[k, K_CBX], K[k, K_CBY], 0.0
        for i in range(k + 1):
            ax += Jc[k, 0, i] * T[i, dd]
            ay += Jc[k, 1, i] * T[i, dd]
            alpha += L[i, L_REV] * T[i, dd]
        ix, iy = L[k, L_M] * ax, L[k, L_M] * (ay + gravity)  # m (a - g)
        fx = ix - out[o + 3 * k] + fnx
        fy = iy - out[o + 3 * k + 1] + fny
        cx, cy = K[k, K_CX] - K[k, K_OX], K[k, K_CY] - K[k, K_OY]
        nx, ny = (K[k + 1, K_OX] - K[k, K_OX], K[k + 1, K_OY] - K[k, K_OY]) if k + 1 < n else (0.0, 0.0)
        mz = L[k, L_I] * alpha + (cx * iy - cy * ix) + nn + (nx * fny - ny * fnx) - out[o + 3 * k + 2]
        out[o + 3 * k] = fx
        out[o + 3 * k + 1] = fy
        out[o + 3 * k + 2] = mz
        fnx, fny, nn = fx, fy, mz


def observation_names(n: int) -> list[str]:
    """Names of :func:`observe_into`'s entries, in order, for N links."""
    names = coordinate_names(n)
    return (names + [f"{x}_d" for x in names] + [f"{x}_dd" for x in names]
            + ["tip_x", "tip_y", "closure_error", "Fx", "Fy", "Mz", "KE", "PE", "E", "tau_drive", "P_drive"]
            + [f"R{k}_{c}" for k in range(1, n + 1) for c in ("Fx", "Fy", "Mz")])


@jit
def observe_into(P, method, zd, tau_drive, want_reactions, W, out):
    """Every output of one state (names: :func:`observation_names`), after :func:`accelerations`.

    Coordinates and rates in thesis order, their accelerations, the tip, the
    closure error, the first closure's force, the energies (kinetic, potential
    with the penalty springs' share, total), the drive's effort and power, and -
    only when ``want_reactions`` - the joint reactions.
    """
    L, CL, gravity, drive = P[0], P[1], P[3], P[4]
    K, J, R, T = W[0], W[2], W[3], W[4]
    n = L.shape[0]
    m = 2 * CL.shape[0]
    dd = t_columns(n, m)[2]
    acc = 0.0
    for k in range(n):
        revolute = L[k, L_REV] != 0.0
        out[2 * k] = K[k, K_SLIDE]
        out[2 * k + 1] = K[k, K_TH]
        out[2 * n + 2 * k] = K[k, K_RATE]
        out[2 * n + 2 * k + 1] = K[k, K_OM]
        if revolute:
            acc += T[k, dd]
        out[4 * n + 2 * k] = 0.0 if revolute else T[k, dd]
        out[4 * n + 2 * k + 1] = acc
    o = 6 * n
    out[o], out[o + 1], _, _ = point_into(L, K, n - 1, L[n - 1, L_A], 0.0, J[m:m + 2])
    err = 0.0
    for r in range(m):
        err += R[r, R_PHI] ** 2
    out[o + 2] = math.sqrt(err)
    fx = fy = mz = 0.0
    if m > 0:
        if CL[0, CL_KIND] == PRISMATIC_CLOSURE:
            fx, fy, mz = R[0, R_NORMAL] * R[0, R_LAM], R[1, R_NORMAL] * R[0, R_LAM], R[1, R_LAM]
        else:
            fx, fy = R[0, R_LAM], R[1, R_LAM]
    out[o + 3], out[o + 4], out[o + 5] = fx, fy, mz
    ke = 0.0
    for i in range(n):
        for j in range(n):
            ke += zd[i] * T[i, j] * zd[j]
    pe = 0.0
    for k in range(n):
        pe += L[k, L_M] * K[k, K_CY]
    pe *= gravity
    if method == 1:  # the penalty springs store energy too
        for r in range(m):
            pe += 0.5 * CL[r // 2, CL_GAIN] * R[r, R_PHI] ** 2
    out[o + 6], out[o + 7], out[o + 8] = 0.5 * ke, pe, 0.5 * ke + pe
    out[o + 9] = tau_drive if drive >= 0 else 0.0
    out[o + 10] = tau_drive * zd[drive] if drive >= 0 else 0.0
    if want_reactions:
        reactions_into(P, W, out, o + 11)


# -- Python interface -------------------------------------------------------------
@dataclass
class MassProperties:
    """Per-link mass-centre kinematics (data for one state)."""

    centre: np.ndarray  # (N, 2)
    Jc: np.ndarray  # (N, 2, n)
    Jw: np.ndarray  # (N, n)
    centre_bias: np.ndarray  # (N, 2)


def _angle_jacobian(model: Mechanism) -> np.ndarray:
    # d(theta_k)/dz: the real revolutes up to link k
    return np.tril(np.ones((model.n_links, model.n_links))) * model.arrays.revolute[None, :]


def _mass_properties(model: Mechanism, K: np.ndarray, Jc: np.ndarray) -> MassProperties:
    return MassProperties(K[:, K_CX:K_CY + 1], Jc, _angle_jacobian(model), K[:, K_CBX:K_CBY + 1])


def mass_properties(model: Mechanism, kin: ChainKinematics) -> MassProperties:
    """Mass centres of all links at once: the chain's Jacobian, lower triangular."""
    n = model.n_links
    K, Jc = kin.table.copy(), np.empty((n, 2, n))
    mass_into(model.arrays.links, K, Jc)
    return _mass_properties(model, K, Jc)


def mass_matrix(model: Mechanism, mp: MassProperties) -> np.ndarray:
    """Generalised mass matrix M(z), N x N."""
    M = np.empty((model.n_links, model.n_links))
    mass_matrix_into(model.arrays.links, np.ascontiguousarray(mp.Jc), model.arrays.drive,
                     model.arrays.drive_inertia, M)
    return M


def _force(model: Mechanism, mp: MassProperties, zd: np.ndarray, inputs: Inputs, gravity: float,
           bias: bool) -> np.ndarray:
    n = model.n_links
    K = np.zeros((n, K_COLUMNS))
    if bias:
        K[:, K_CBX:K_CBY + 1] = mp.centre_bias
    out = np.empty((n, 1))
    a = model.arrays
    force_into(a.links, np.ascontiguousarray(mp.Jc), K, gravity, np.ascontiguousarray(zd, dtype=float),
               a.drive, a.load, float(inputs.drive), float(inputs.load), out, 0)
    return out[:, 0]


def bias_force(model: Mechanism, mp: MassProperties) -> np.ndarray:
    """Velocity-product (Coriolis and centripetal) generalised force h."""
    n = model.n_links
    return -_force(model, mp, np.zeros(n), Inputs(), 0.0, bias=True)


def applied_force(model: Mechanism, mp: MassProperties, zd: np.ndarray, inputs: Inputs) -> np.ndarray:
    """Generalised force of gravity, joint damping, drive and load."""
    return _force(model, mp, zd, inputs, float(model.gravity), bias=False)


@dataclass
class Dynamics:
    """Everything the equations of motion give at one state."""

    kin: ChainKinematics
    mp: MassProperties
    ck: ClosureKinematics
    M: np.ndarray
    zdd: np.ndarray
    lam: np.ndarray  # closure multipliers, force on the closing link
    work: tuple = ()  # the kernels' tables these fields are views of


def forward_dynamics(
    model: Mechanism, z: np.ndarray, zd: np.ndarray, inputs: Inputs, method: str = EXACT
) -> Dynamics:
    """Joint accelerations and closure multipliers at one state.

    Parameters
    ----------
    model : Mechanism
    z, zd : ndarray
        Real joint coordinates and rates.
    inputs : Inputs
    method : {'exact', 'penalty'}

    Returns
    -------
    Dynamics

    Raises
    ------
    numpy.linalg.LinAlgError
        When the matrix to solve is singular (a real coordinate without inertia
        and without a closure to carry it).
    """
    n = model.n_links
    y = np.empty(2 * n)
    y[:n], y[n:] = z, zd
    W = workspace(n, len(model.closures))
    if not rhs_into(model.arrays.packed, METHOD_CODE[method], 0.0, y, -1, float(inputs.drive), float(inputs.load),
                    W, np.empty(2 * n)):
        raise np.linalg.LinAlgError("Singular matrix")
    K, Jc, J, R, T, _ = W
    zd = y[n:]
    zdd_column = t_columns(n, model.n_constraints)[2]
    return Dynamics(ChainKinematics.of(model, K, zd), _mass_properties(model, K, Jc),
                    ClosureKinematics.of(model, J, R), T[:, :n], T[:, zdd_column], R[:, R_LAM], W)


def joint_reactions(model: Mechanism, dyn: Dynamics, inputs: Inputs) -> np.ndarray:
    """Force and moment each link's predecessor exerts on it at its joint.

    Newton-Euler from the tip back to the ground.  Row k is (Fx, Fy, Mz) for the
    joint pair of link k+2, acting at its revolute point O_{k+2}; the moment
    includes the joint's own torque (drive, damping).

    Returns
    -------
    ndarray, shape (N, 3)
    """
    out = np.empty(3 * model.n_links)
    reactions_into(model.arrays.packed, dyn.work, out, 0)
    return out.reshape(model.n_links, 3)


def inverse_dynamics(
    model: Mechanism, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, inputs: Inputs | None = None
) -> tuple[float, np.ndarray]:
    """Drive effort and closure multipliers that produce a given motion.

    The motion must satisfy the closures (``zdd`` consistent with them).  The
    drive effort is whatever the model's drive joint must add to ``inputs``.

    Returns
    -------
    drive : float
        Effort at the drive joint, N m or N.
    lam : ndarray
        Closure multipliers (force on the closing link).
    """
    if model.drive is None:
        raise ValueError("inverse_dynamics needs a model with a drive joint")
    inputs = inputs or Inputs()
    kin = chain_kinematics(model, z, zd)
    mp = mass_properties(model, kin)
    ck = closure_kinematics(model, kin)
    M = mass_matrix(model, mp)
    residual = M @ zdd + bias_force(model, mp) - applied_force(model, mp, zd, Inputs(0.0, inputs.load))
    # residual = tau e_drive + J^T lambda
    e = np.zeros(model.n_links)
    e[model.free_index(model.drive)] = 1.0
    A = np.column_stack([e, ck.J.T])
    x, *_ = np.linalg.lstsq(A, residual, rcond=None)
    return float(x[0]), x[1:]


__all__ = [
    "EXACT",
    "PENALTY",
    "METHODS",
    "Inputs",
    "Dynamics",
    "forward_dynamics",
    "inverse_dynamics",
    "joint_reactions",
]
