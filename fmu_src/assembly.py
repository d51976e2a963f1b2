"""Consistent initial assembly and the projection that keeps the loop closed.

Assembly holds the driving coordinate (and, for mobility above one, the
best-conditioned further coordinates) at the user's value and solves the closure
equations for the rest by Newton's method, starting from the user's guess, so the
branch the user sketched is the branch that is found.  The same Gauss-Newton
correction, started from an integrator step that is already closed to the local
error, is the exact method's drift control.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from .analysis import explain_unclosable
from .dynamics import t_columns, workspace
from .errors import AssemblyError
from .jit import jit
from .linalg import lstsq_min_norm
from .kinematics import R_B, R_PHI, chain_into, chain_kinematics, closure_into, closure_kinematics
from .model import Mechanism

POSITION_TOL = 1e-12  # m (or rad): loop closure reached by assembly and projection
LSTSQ_RCOND = 1e-8  # relative singular value below which a projection direction is dropped
PROJECTION_ITERATIONS = 4  # Gauss-Newton steps at most (one or two suffice after a step)


def constraint(model: Mechanism, z: np.ndarray, zd: np.ndarray | None = None):
    """Closure violation and its Jacobian at ``z`` (rates only matter for gamma)."""
    kin = chain_kinematics(model, z, np.zeros(model.n_links) if zd is None else zd)
    ck = closure_kinematics(model, kin)
    return ck.phi, ck.J


def held_coordinates(model: Mechanism, z: np.ndarray) -> list[int]:
    """Indices in z that assembly keeps at their given values."""
    held = [] if model.drive is None else [model.free_index(model.drive)]
    n_hold = max(model.mobility, 0)
    if len(held) >= n_hold:
        return held[:n_hold] if n_hold else []
    _, J = constraint(model, z)
    others = [i for i in range(model.n_free) if i not in held]
    # the columns QR picks first are the best dependent set; hold the rest
    _, _, piv = scipy.linalg.qr(J[:, others], pivoting=True)
    dependent = [others[i] for i in piv[: model.n_constraints]]
    return held + [i for i in others if i not in dependent][: n_hold - len(held)]


def assemble(model: Mechanism, z0: np.ndarray, zd0: np.ndarray | None = None,
             field: str = "initial") -> tuple[np.ndarray, np.ndarray]:
    """Close the loop from an initial guess, holding the driving coordinate.

    Parameters
    ----------
    model : Mechanism
    z0 : ndarray
        Initial real joint coordinates (guess for the dependent ones).
    zd0 : ndarray, optional
        Initial joint rates; the held ones are kept, the rest made consistent.

    Returns
    -------
    z, zd : ndarray
        A configuration that satisfies every closure, and consistent rates.

    Raises
    ------
    AssemblyError
        When the loop cannot close with the held coordinate at its value.
    """
    z = np.array(z0, dtype=float)
    zd = np.zeros(model.n_free) if zd0 is None else np.array(zd0, dtype=float)
    if model.n_constraints == 0:
        return z, zd
    held = held_coordinates(model, z)
    dep = [i for i in range(model.n_free) if i not in held]
    scale = max(1.0, max((abs(l.a) for l in model.links), default=1.0))
    best = None
    for _ in range(100):
        phi, J = constraint(model, z)
        err = float(np.max(np.abs(phi)))
        if best is None or err < best[0]:
            best = (err, z.copy())
        if err < POSITION_TOL * scale:
            break
        step = np.linalg.lstsq(J[:, dep], -phi, rcond=None)[0]
        # damped Newton: accept the largest fraction that reduces the violation
        for frac in (1.0, 0.5, 0.25, 0.125, 0.0625):
            trial = z.copy()
            trial[dep] += frac * step
            if np.max(np.abs(constraint(model, trial)[0])) < err:
                z = trial
                break
        else:
            break
    phi, J = constraint(model, z)
    if float(np.max(np.abs(phi))) > 1e-9 * scale:
        names = model.free_names
        held_txt = ", ".join(f"{names[i]} = {z0[i]:.6g}" for i in held) or "nothing"
        why = explain_unclosable(model, z0, held)
        raise AssemblyError(
            field,
            f"the loop cannot be closed with {held_txt} held: the closest the tip gets is "
            f"{best[0]:.3g} from its closure{'; ' + why if why else ''}",
        )
    # rates: keep the held ones, solve the closure's velocity equation for the rest
    b = -J[:, held] @ zd[held] if held else np.zeros(len(phi))
    zd[dep] = np.linalg.lstsq(J[:, dep], b, rcond=None)[0]
    return z, zd


@jit
def project_into(P, scale, y, W):
    """Minimum-norm projection of ``y = (z, zd)`` onto the closures, in place.

    Gauss-Newton on ``phi(z) = 0`` (a step or two from an integrator step that is
    already near the manifold), then the rates onto the null space of ``J``.
    ``W`` is a :func:`grubler.dynamics.workspace`.
    """
    L, CL, theta1 = P[0], P[1], P[2]
    K, _, J, R, T, Q = W
    n = y.shape[0] // 2
    m = 2 * CL.shape[0]
    _, _, _, vec, block = t_columns(n, m)
    z = y[:n]
    zd = y[n:]
    rest = J[m + 2]
    rest[:] = 0.0  # the rates do not enter phi or J
    Jm = J[:m]
    V = Q[:, 2 * m:3 * m]
    for _ in range(PROJECTION_ITERATIONS):
        chain_into(L, theta1, z, rest, K)
        closure_into(L, CL, K, rest, J, R)
        worst = 0.0
        for r in range(m):
            worst = max(worst, abs(R[r, R_PHI]))
        if worst <= POSITION_TOL * scale:
            break
        lstsq_min_norm(Jm, R, R_PHI, LSTSQ_RCOND, T, vec, block, V)
        for i in range(n):
            z[i] -= T[i, vec]
    for r in range(m):
        s = 0.0
        for i in range(n):
            s += J[r, i] * zd[i]
        R[r, R_B] = s
    lstsq_min_norm(Jm, R, R_B, LSTSQ_RCOND, T, vec, block, V)
    for i in range(n):
        zd[i] -= T[i, vec]


def project(model: Mechanism, z: np.ndarray, zd: np.ndarray, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Minimum-norm projection onto the position and velocity constraints.

    Gauss-Newton on ``phi(z) = 0`` (a step or two from an integrator step that is
    already near the manifold), then the rates onto the null space of ``J``.
    """
    y = np.concatenate([np.asarray(z, dtype=float), np.asarray(zd, dtype=float)])
    project_into(model.arrays.packed, float(scale), y, workspace(model.n_links, len(model.closures)))
    n = model.n_links
    return y[:n], y[n:]
