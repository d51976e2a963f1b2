"""Forward kinematics of the generalised chain and of its closures.

One pass along the chain gives, for every moving link, its angle, angular rate,
joint point and the acceleration of that point when all joint accelerations are
zero (the bias or convective term).  Any point of any link then has a position,
a Jacobian with respect to the real joint rates and a bias acceleration, so that
its acceleration is ``J @ zdd + bias``.  The closure constraints are built from
those points; nothing here is specific to four links.

Jacobian columns are the planar screw of each real joint: a revolute at O_b moves
a point r with ``k x (r - O_b)``, a slide moves it along its axis.

The passes are the compiled kernel's (``kernel/chain.c``), writing into a
workspace this module reads as tables (:func:`tables`); the classes here are
views of those tables for Python callers.

Examples
--------
>>> import numpy as np
>>> from grubler import load_scene
>>> m = load_scene("thesis-fourbar").mechanism
>>> kin = chain_kinematics(m, m.z_from_q(m.q_ref), np.zeros(3))
>>> kin.origin.shape
(3, 2)
>>> r, J, bias = point_on_link(kin, 0, (0.2, 0.0))  # the crank's tip, crank along x
>>> np.round(r, 6).tolist()
[0.2, 0.0]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grubler import binding
from grubler.mechanism.model import Mechanism

# columns of the link table K (kernel/workspace.h): angle, rate, cos, sin, joint
# point O_k, its bias acceleration, slide axis, slide and its rate; then the mass
# centre and its bias acceleration
(K_TH, K_OM, K_COS, K_SIN, K_OX, K_OY, K_BX, K_BY, K_AX, K_AY, K_SLIDE, K_RATE, K_CX, K_CY, K_CBX,
 K_CBY) = range(16)
# columns of the constraint-row table R: violation, acceleration right side, two
# solver columns, the line normal's and the closing point's component along the
# row's axis
R_PHI, R_GAMMA, R_B, R_LAM, R_NORMAL, R_POINT = range(6)


@dataclass
class Tables:
    """The kernel's workspace as named tables (views of one buffer)."""

    work: np.ndarray
    K: np.ndarray  # (N, K columns) link table
    Jc: np.ndarray  # (N, 2, N) mass-centre Jacobians
    J: np.ndarray  # (M, N) closure Jacobian
    R: np.ndarray  # (M, R columns) constraint rows
    M: np.ndarray  # (N, N) mass matrix
    zdd: np.ndarray  # (N,) joint accelerations


def tables(model: Mechanism, work: np.ndarray | None = None) -> Tables:
    """Views of a workspace (a new one when ``work`` is None) for ``model``."""
    n, c = model.n_links, len(model.closures)
    if work is None:
        work = binding.work(n, c)
    oK, oJc, oJ, oR, oM, _, _, kc, rc, mc, _, ozdd = binding.layout(n, c)
    m = 2 * c
    return Tables(work, work[oK:oK + n * kc].reshape(n, kc), work[oJc:oJc + 2 * n * n].reshape(n, 2, n),
                  work[oJ:oJ + m * n].reshape(m, n), work[oR:oR + m * rc].reshape(m, rc),
                  work[oM:oM + n * mc].reshape(n, mc), work[ozdd:ozdd + n])


def evaluate_into(model: Mechanism, tab: Tables, z, zd, method: int = 0, tau_drive: float = 0.0,
                  tau_load: float = 0.0) -> bool:
    """Fill ``tab`` at one state (kinematics, closures, dynamics); False when singular."""
    y = np.concatenate([np.asarray(z, dtype=float), np.asarray(zd, dtype=float)])
    status = binding.library().grb_evaluate(model.arrays.c, int(method), binding.address(y), float(tau_drive),
                                            float(tau_load), binding.address(tab.work))
    return status == binding.OK


@dataclass
class ChainKinematics:
    """Positions and rates of the chain at one state (data, not model).

    The fields are views of ``tables.K``, the kernel's link table.
    """

    theta: np.ndarray  # (N,) absolute angles of links 2..N+1
    omega: np.ndarray  # (N,) angular rates
    origin: np.ndarray  # (N, 2) joint point O_k of each link
    origin_bias: np.ndarray  # (N, 2) acceleration of O_k at zero joint acceleration
    axis: np.ndarray  # (N, 2) slide axis of each pair (unit), world frame
    revolute: np.ndarray  # (N,) bool, which joint of each pair is real
    zd: np.ndarray  # (N,) joint rates
    table: np.ndarray  # (N, K columns) the kernel's link table
    model: Mechanism
    tables: Tables

    @staticmethod
    def of(model: Mechanism, tab: Tables, zd: np.ndarray) -> "ChainKinematics":
        """Views of a filled workspace."""
        K = tab.K
        return ChainKinematics(K[:, K_TH], K[:, K_OM], K[:, K_OX:K_OY + 1], K[:, K_BX:K_BY + 1],
                               K[:, K_AX:K_AY + 1], model.arrays.revolute, np.asarray(zd, dtype=float), K, model,
                               tab)


def chain_kinematics(model: Mechanism, z: np.ndarray, zd: np.ndarray) -> ChainKinematics:
    """Recursive pass from ground to tip (MODEL.md section 2)."""
    tab = tables(model)
    evaluate_into(model, tab, z, zd)
    return ChainKinematics.of(model, tab, zd)


def link_frame(kin: ChainKinematics, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors e(theta_k), e_perp(theta_k) of moving link index k (0-based)."""
    c, s = kin.table[k, K_COS], kin.table[k, K_SIN]
    return np.array([c, s]), np.array([-s, c])


def point_on_link(kin: ChainKinematics, k: int, local) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, Jacobian (2 x N) and bias acceleration of a point of a moving link.

    Parameters
    ----------
    kin : ChainKinematics
    k : int
        Moving link index, 0-based (thesis link k+2).
    local : (float, float)
        The point along and perpendicular to the link vector, m.

    Returns
    -------
    r, J, bias : ndarray
        ``r`` (2,), ``J`` (2, N) with ``rdot = J @ zd``, ``bias`` (2,) with
        ``rddot = J @ zdd + bias``.
    """
    n = kin.theta.shape[0]
    J, r = np.empty((2, n)), np.empty(4)
    if binding.library().grb_point_on_link(kin.model.arrays.c, binding.address(kin.tables.work), int(k),
                                           float(local[0]), float(local[1]), binding.address(J),
                                           binding.address(r)) != binding.OK:
        raise IndexError(f"link index {k} out of range 0..{n - 1}")
    return r[:2].copy(), J, r[2:].copy()


@dataclass
class ClosureKinematics:
    """The stacked closure constraints at one state.

    ``phi`` is the violation, ``J`` its Jacobian (``phi_dot = J @ zd``) and
    ``gamma`` the right side of the acceleration constraint ``J @ zdd = gamma``.
    ``force_dir`` maps a closure's multipliers to the force (world frame) on the
    closing link, and ``application`` is where that force acts.
    """

    phi: np.ndarray
    J: np.ndarray
    gamma: np.ndarray
    force_dir: list  # per closure: (2, 2) matrix, force = force_dir @ lambda_c
    moment_row: list  # per closure: (2,) row, moment = moment_row @ lambda_c
    application: list  # per closure: (2,) world point

    @staticmethod
    def of(model: Mechanism, tab: Tables) -> "ClosureKinematics":
        """Views and lists of a filled workspace."""
        R = tab.R
        force_dir, moment_row, application = [], [], []
        for j, cl in enumerate(model.closures):
            r = 2 * j
            if cl.kind == "revolute":
                force_dir.append(np.eye(2))
                moment_row.append(np.zeros(2))
            else:
                force_dir.append(np.array([[R[r, R_NORMAL], 0.0], [R[r + 1, R_NORMAL], 0.0]]))
                moment_row.append(np.array([0.0, 1.0]))
            application.append(R[r:r + 2, R_POINT])
        return ClosureKinematics(R[:, R_PHI], tab.J, R[:, R_GAMMA], force_dir, moment_row, application)


def closure_kinematics(model: Mechanism, kin: ChainKinematics) -> ClosureKinematics:
    """Constraint rows of every closure (MODEL.md section 3), any link pair."""
    return ClosureKinematics.of(model, kin.tables)


def link_points(model: Mechanism, zs: np.ndarray, link, local) -> np.ndarray:
    """World positions of points fixed to links, at every row of a trajectory, in one kernel call.

    Parameters
    ----------
    model : Mechanism
    zs : ndarray (rows, N)
        Real joint coordinates, one row per instant.
    link : sequence of int
        Per point, its moving link index, 0-based (thesis link k+2), or -1 for
        the ground, whose frame is the world's.
    local : sequence of (float, float)
        Per point, along and across its link's vector, m (world coordinates on
        the ground).

    Returns
    -------
    ndarray (rows, points, 2)

    Examples
    --------
    >>> from grubler import load_scene
    >>> m = load_scene("thesis-fourbar").mechanism
    >>> z = m.z_from_q(m.q_ref)
    >>> link_points(m, [z, z], [0, -1], [(0.2, 0.0), (1.0, 0.0)]).round(6).tolist()
    [[[0.2, 0.0], [1.0, 0.0]], [[0.2, 0.0], [1.0, 0.0]]]
    """
    n = model.n_links
    zs = np.asarray(zs, dtype=float).reshape(-1, n)
    links = np.ascontiguousarray(link, dtype=np.int32).reshape(-1)
    loc = np.ascontiguousarray(local, dtype=float).reshape(-1, 2)
    if loc.shape[0] != links.shape[0]:
        raise ValueError(f"{links.shape[0]} links for {loc.shape[0]} points")
    y = np.ascontiguousarray(np.hstack([zs, np.zeros_like(zs)]))
    out, work = np.empty((zs.shape[0], links.shape[0], 2)), binding.work(n, len(model.closures))
    status = binding.library().grb_link_points_rows(
        model.arrays.c, zs.shape[0], binding.address(y), links.shape[0], binding.address(links),
        binding.address(loc), binding.address(work), binding.address(out))
    if status != binding.OK:
        raise IndexError(f"a link index out of range -1..{n - 1}: {links.tolist()}")
    return out
