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

Everything is a function of (model, state, inputs): no hidden state.  The
right-hand side is the compiled kernel's (``kernel/chain.c``), over the model's
tables (``Mechanism.arrays``) and a workspace it fills; :func:`forward_dynamics`
and the other public functions wrap it for Python callers.

Examples
--------
>>> import numpy as np
>>> from grubler import load_scene
>>> m = load_scene("thesis-fourbar").mechanism
>>> from grubler.mechanism.assembly import assemble
>>> z, zd = assemble(m, m.z_from_q(m.q_ref))
>>> dyn = forward_dynamics(m, z, zd, Inputs())
>>> dyn.zdd.shape, dyn.lam.shape
((3,), (2,))
>>> bool(abs(dyn.ck.J @ dyn.zdd - dyn.ck.gamma).max() < 1e-12)
True
"""

from __future__ import annotations

import itertools
import weakref
from dataclasses import dataclass
from typing import Callable

import numpy as np

from grubler import binding
from grubler.mechanism.kinematics import (
    K_CBX,
    K_CBY,
    K_CX,
    K_CY,
    R_LAM,
    ChainKinematics,
    ClosureKinematics,
    Tables,
    evaluate_into,
    tables,
)
from grubler.mechanism.model import Mechanism, coordinate_names
from grubler.quantities import FIXED_OBSERVATIONS

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
    actuators : tuple of float
        Force of each of the model's actuators, in its order, N (positive
        pushing its points apart); missing ones are 0.

    Examples
    --------
    >>> import grubler
    >>> grubler.Inputs(drive=3.0)          # 3 N m on the drive joint, nothing else
    Inputs(drive=3.0, load=0.0, actuators=())
    """

    drive: float = 0.0
    load: float = 0.0
    actuators: tuple[float, ...] = ()


def actuator_forces(model: Mechanism, inputs: Inputs) -> np.ndarray:
    """The actuators' forces of ``inputs`` as an array of the model's length (missing ones 0)."""
    f = np.zeros(len(model.actuators))
    given = np.asarray(inputs.actuators, dtype=float)
    if given.size > f.size:
        raise ValueError(f"actuators: {given.size} forces for {f.size} actuators")
    f[:given.size] = given
    return f


def put_actuator_forces(model: Mechanism, work: np.ndarray, inputs: Inputs) -> None:
    """Write the actuators' forces of ``inputs`` into a kernel workspace (nothing to do without actuators)."""
    if model.actuators:
        binding.set_actuator_forces(model.arrays.c, work, actuator_forces(model, inputs))


def observation_names(n: int) -> list[str]:
    """Names of the kernel's observations (``grb_observe``), in order, for N links."""
    names = coordinate_names(n)
    return (names + [f"{x}_d" for x in names] + [f"{x}_dd" for x in names]
            + [q.name for q in FIXED_OBSERVATIONS]
            + [f"R{k}_{c}" for k in range(1, n + 1) for c in ("Fx", "Fy", "Mz")])


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


@dataclass
class Dynamics:
    """Everything the equations of motion give at one state."""

    kin: ChainKinematics
    mp: MassProperties
    ck: ClosureKinematics
    M: np.ndarray
    zdd: np.ndarray
    lam: np.ndarray  # closure multipliers, force on the closing link
    tables: Tables | None = None  # the kernel's workspace these fields are views of


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

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> z, zd = m.z_from_q(m.q_ref), [0.0, 0.0, 0.0]      # the start, at rest
    >>> dyn = grubler.forward_dynamics(m, z, zd, grubler.Inputs(drive=3.0))
    >>> dyn.zdd[:2].round(3), dyn.lam.round(3)   # crank and coupler accelerations (rad/s^2), closing force (N)
    (array([-10.359,  12.949]), array([-8.687, 28.596]))
    """
    tab = tables(model)
    put_actuator_forces(model, tab.work, inputs)
    if not evaluate_into(model, tab, z, zd, METHOD_CODE[method], float(inputs.drive), float(inputs.load)):
        raise np.linalg.LinAlgError("Singular matrix")
    K = tab.K
    mp = MassProperties(K[:, K_CX:K_CY + 1], tab.Jc, _angle_jacobian(model), K[:, K_CBX:K_CBY + 1])
    return Dynamics(ChainKinematics.of(model, tab, zd), mp, ClosureKinematics.of(model, tab), tab.M, tab.zdd,
                    tab.R[:, R_LAM], tab)


def joint_reactions(model: Mechanism, dyn: Dynamics, inputs: Inputs) -> np.ndarray:
    """Force and moment each link's predecessor exerts on it at its joint.

    Newton-Euler from the tip back to the ground.  Row k is (Fx, Fy, Mz) for the
    joint pair of link k+2, acting at its revolute point O_{k+2}; the moment
    includes the joint's own torque (drive, damping).

    Returns
    -------
    ndarray, shape (N, 3)

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> z, zd = m.z_from_q(m.q_ref), [0.0, 0.0, 0.0]
    >>> dyn = grubler.forward_dynamics(m, z, zd, grubler.Inputs(drive=3.0))
    >>> r = grubler.joint_reactions(m, dyn, grubler.Inputs(drive=3.0))   # rows: links 2, 3, 4; Fx, Fy, Mz
    >>> r.round(3) + 0.0         # a pin carries no moment but its own torque: the drive's 3 N m, then none
    array([[ 4.202, 24.567,  3.   ],
           [ 4.202, 15.792,  0.   ],
           [ 5.996, -0.72 ,  0.   ]])
    """
    out = np.empty(3 * model.n_links)
    binding.library().grb_joint_reactions(model.arrays.c, binding.address(dyn.tables.work), binding.address(out))
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

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> z, zd = m.z_from_q(m.q_ref), [0.0, 0.0, 0.0]
    >>> dyn = grubler.forward_dynamics(m, z, zd, grubler.Inputs(drive=3.0))
    >>> drive, lam = grubler.inverse_dynamics(m, z, zd, dyn.zdd)   # the torque that makes that motion
    >>> round(drive, 9)
    3.0
    """
    if model.drive is None:
        raise ValueError("inverse_dynamics needs a model with a drive joint")
    inputs = inputs or Inputs()
    tab = tables(model)
    put_actuator_forces(model, tab.work, inputs)
    y = np.concatenate([np.asarray(z, dtype=float), np.asarray(zd, dtype=float)])
    zdd = np.ascontiguousarray(zdd, dtype=float)
    residual = np.empty(model.n_links)
    binding.library().grb_inverse_residual(model.arrays.c, binding.address(y), binding.address(zdd),
                                           float(inputs.load), binding.address(tab.work), binding.address(residual))
    # residual = M zdd + h - Q = tau e_drive + J^T lambda
    e = np.zeros(model.n_links)
    e[model.free_index(model.drive)] = 1.0
    A = np.column_stack([e, tab.J.T])
    x, *_ = np.linalg.lstsq(A, residual, rcond=None)
    return float(x[0]), x[1:]


__all__ = [
    "EXACT",
    "PENALTY",
    "METHODS",
    "Inputs",
    "actuator_forces",
    "Dynamics",
    "forward_dynamics",
    "inverse_dynamics",
    "joint_reactions",
]
