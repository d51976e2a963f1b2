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

Everything is a function of (model, state, inputs): no hidden state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kinematics import (
    ChainKinematics,
    ClosureKinematics,
    chain_kinematics,
    closure_kinematics,
    rot90,
)
from .model import Mechanism

EXACT = "exact"
PENALTY = "penalty"
METHODS = (EXACT, PENALTY)


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


@dataclass
class MassProperties:
    """Per-link mass-centre kinematics (data for one state)."""

    centre: np.ndarray  # (N, 2)
    Jc: np.ndarray  # (N, 2, n)
    Jw: np.ndarray  # (N, n)
    centre_bias: np.ndarray  # (N, 2)


def mass_properties(model: Mechanism, kin: ChainKinematics) -> MassProperties:
    """Mass centres of all links at once: the chain's Jacobian, lower triangular."""
    arrays = model.arrays
    c, s = np.cos(kin.theta), np.sin(kin.theta)
    arm = np.column_stack([arrays.p * c - arrays.q * s, arrays.p * s + arrays.q * c])
    centre = kin.origin + arm
    diff = centre[:, None, :] - kin.origin[None, :, :]  # (link, joint, xy)
    cols = np.where(arrays.revolute[None, :, None], rot90(diff), kin.axis[None, :, :])
    Jc = (cols * arrays.lower[:, :, None]).transpose(0, 2, 1)
    bias = kin.origin_bias - (kin.omega**2)[:, None] * arm
    return MassProperties(centre, Jc, arrays.Jw, bias)


def _masses(model: Mechanism) -> tuple[np.ndarray, np.ndarray]:
    return model.arrays.m, model.arrays.I


def mass_matrix(model: Mechanism, mp: MassProperties) -> np.ndarray:
    m, inertia = _masses(model)
    M = np.einsum("k,kai,kaj->ij", m, mp.Jc, mp.Jc) + np.einsum("k,ki,kj->ij", inertia, mp.Jw, mp.Jw)
    if model.arrays.drive_inertia:
        M[model.arrays.drive, model.arrays.drive] += model.arrays.drive_inertia
    return M


def bias_force(model: Mechanism, mp: MassProperties) -> np.ndarray:
    """Velocity-product (Coriolis and centripetal) generalised force h."""
    m, _ = _masses(model)
    return np.einsum("k,kai,ka->i", m, mp.Jc, mp.centre_bias)


def applied_force(model: Mechanism, mp: MassProperties, zd: np.ndarray, inputs: Inputs) -> np.ndarray:
    """Generalised force of gravity, joint damping, drive and load."""
    m, _ = _masses(model)
    Q = -model.gravity * (m @ mp.Jc[:, 1, :])
    Q -= model.arrays.damping * zd
    if model.arrays.drive >= 0:
        Q[model.arrays.drive] += inputs.drive
    if model.arrays.load >= 0:
        Q[model.arrays.load] += inputs.load
    return Q


def penalty_multipliers(model: Mechanism, ck: ClosureKinematics, zd: np.ndarray) -> np.ndarray:
    """The thesis's imaginary joint: spring G and damper C on each violation."""
    phidot = ck.J @ zd
    return -model.arrays.gain * ck.phi - model.arrays.closure_damping * phidot


@dataclass
class Dynamics:
    """Everything the equations of motion give at one state."""

    kin: ChainKinematics
    mp: MassProperties
    ck: ClosureKinematics
    M: np.ndarray
    zdd: np.ndarray
    lam: np.ndarray  # closure multipliers, force on the closing link


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
    """
    kin = chain_kinematics(model, z, zd)
    mp = mass_properties(model, kin)
    ck = closure_kinematics(model, kin)
    M = mass_matrix(model, mp)
    rhs = applied_force(model, mp, zd, inputs) - bias_force(model, mp)
    if model.n_constraints == 0:
        return Dynamics(kin, mp, ck, M, np.linalg.solve(M, rhs), np.zeros(0))
    if method == PENALTY:
        lam = penalty_multipliers(model, ck, zd)
        return Dynamics(kin, mp, ck, M, np.linalg.solve(M, rhs + ck.J.T @ lam), lam)
    # M may be singular where a real coordinate carries no inertia of its own (a
    # point-mass slider's rotation); M + a J^T J is not, and since J zdd = gamma
    # the added term changes nothing in the solution (augmented Lagrangian).
    J, gamma = ck.J, ck.gamma
    a = np.trace(M) / max(float(np.sum(J * J)), 1e-300)
    Minv = np.linalg.solve(M + a * (J.T @ J), np.column_stack([rhs + a * (J.T @ gamma), J.T]))
    Minv_rhs, Minv_JT = Minv[:, 0], Minv[:, 1:]
    lam = _closure_multipliers(J @ Minv_JT, gamma - J @ Minv_rhs)
    return Dynamics(kin, mp, ck, M, Minv_rhs + Minv_JT @ lam, lam)


# Relative eigenvalue below which a closure direction counts as lost.  At a
# change-point linkage's aligned position the closure rows become dependent and
# their multiplier is undetermined; dropping that direction keeps the motion
# defined through it, and the projection removes the small drift it leaves.
SINGULAR_RCOND = 1e-10


def _closure_multipliers(S: np.ndarray, b: np.ndarray) -> np.ndarray:
    if S.shape == (2, 2):
        # one closure: the 2 x 2 case in closed form; det / trace^2 is the
        # eigenvalue ratio the cut-off below tests, to first order
        det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
        tr = S[0, 0] + S[1, 1]
        if det > SINGULAR_RCOND * tr * tr:
            return np.array([S[1, 1] * b[0] - S[0, 1] * b[1], S[0, 0] * b[1] - S[1, 0] * b[0]]) / det
    w, V = np.linalg.eigh(S)
    keep = w > SINGULAR_RCOND * w[-1]
    return V[:, keep] @ ((V[:, keep].T @ b) / w[keep])


def closure_forces(model: Mechanism, dyn: Dynamics) -> list[tuple[np.ndarray, float]]:
    """Force (world frame) and moment that each closure's to_link exerts on its link."""
    out = []
    for j, cl in enumerate(model.closures):
        lam = dyn.lam[2 * j : 2 * j + 2]
        out.append((dyn.ck.force_dir[j] @ lam, float(dyn.ck.moment_row[j] @ lam)))
    return out


def joint_reactions(model: Mechanism, dyn: Dynamics, inputs: Inputs) -> np.ndarray:
    """Force and moment each link's predecessor exerts on it at its joint.

    Newton-Euler from the tip back to the ground.  Row k is (Fx, Fy, Mz) for the
    joint pair of link k+2, acting at its revolute point O_{k+2}; the moment
    includes the joint's own torque (drive, damping).

    Returns
    -------
    ndarray, shape (N, 3)
    """
    n = model.n_links
    kin, mp = dyn.kin, dyn.mp
    acc = np.einsum("kai,i->ka", mp.Jc, dyn.zdd) + mp.centre_bias
    alpha = mp.Jw @ dyn.zdd
    g = np.array([0.0, -model.gravity])
    ext_f = np.zeros((n, 2))
    ext_m = np.zeros(n)  # moment about each link's origin
    for cl, (force, moment), r in zip(model.closures, closure_forces(model, dyn), dyn.ck.application):
        for link, sign in ((cl.link, 1.0), (cl.to_link, -1.0)):
            if link == 1:
                continue
            k = link - 2
            ext_f[k] += sign * force
            ext_m[k] += sign * (moment + _cross(r - kin.origin[k], force))
    out = np.zeros((n, 3))
    f_next = np.zeros(2)
    n_next = 0.0
    for k in range(n - 1, -1, -1):
        link = model.links[k]
        inertial = link.m * (acc[k] - g)
        f = inertial - ext_f[k] + f_next
        arm_c = mp.centre[k] - kin.origin[k]
        arm_next = kin.origin[k + 1] - kin.origin[k] if k + 1 < n else np.zeros(2)
        mz = link.I * alpha[k] + _cross(arm_c, inertial) + n_next + _cross(arm_next, f_next) - ext_m[k]
        out[k] = (f[0], f[1], mz)
        f_next, n_next = f, mz
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def kinetic_energy(M: np.ndarray, zd: np.ndarray) -> float:
    return 0.5 * float(zd @ M @ zd)


def potential_energy(model: Mechanism, mp: MassProperties, ck: ClosureKinematics | None = None,
                     method: str = EXACT) -> float:
    """Gravity potential (zero at y = 0) plus the penalty springs' energy."""
    m, _ = _masses(model)
    pe = model.gravity * float(m @ mp.centre[:, 1])
    if method == PENALTY and ck is not None and len(ck.phi):
        pe += 0.5 * float(model.arrays.gain @ ck.phi**2)
    return pe


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
    "closure_forces",
    "kinetic_energy",
    "potential_energy",
    "rot90",
]
