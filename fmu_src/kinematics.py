"""Forward kinematics of the generalised chain and of its closures.

One pass along the chain gives, for every moving link, its angle, angular rate,
joint point and the acceleration of that point when all joint accelerations are zero
(the bias or convective term).  Any point of any link then has a position, a
Jacobian with respect to the real joint rates and a bias acceleration, so that its
acceleration is ``J @ zdd + bias``.  The closure constraints are built from those
points; nothing here is specific to four links.

Jacobian columns are the planar screw of each real joint: a revolute at O_b moves a
point r with ``k x (r - O_b)``, a slide moves it along its axis.

The passes are compiled kernels (:mod:`grubler.jit`) over the model's number
tables (:class:`grubler.model.ModelArrays`) writing into caller-owned tables, so the
integrator's loop allocates nothing; :func:`chain_kinematics`,
:func:`point_on_link` and :func:`closure_kinematics` wrap them for Python callers.
The kernels pass few, wide tables rather than many small arrays: numba's compile
time grows with every array a compiled function takes.

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

import math
from dataclasses import dataclass

import numpy as np

from .jit import jit
from .model import (
    CL_ANGLE,
    CL_KIND,
    CL_LINK,
    CL_PSI,
    CL_PX,
    CL_PY,
    CL_TO,
    CL_TX,
    CL_TY,
    L_APRED,
    L_REV,
    L_SLIDE0,
    L_THETA0,
    PRISMATIC_CLOSURE,
    Mechanism,
)

# columns of the link table K, one row per moving link: angle, rate, cos, sin,
# joint point O_k, its bias acceleration, slide axis, slide and its rate; then the
# mass centre and its bias acceleration (filled by grubler.dynamics.mass_into)
(K_TH, K_OM, K_COS, K_SIN, K_OX, K_OY, K_BX, K_BY, K_AX, K_AY, K_SLIDE, K_RATE, K_CX, K_CY, K_CBX,
 K_CBY) = range(16)
K_COLUMNS = 16
# columns of the constraint-row table R, one row per closure equation: violation,
# acceleration right side, two columns for the solver, and the components along
# this row's axis (x for a closure's first row, y for its second) of the line's
# normal (prismatic closures; 0 for revolute ones) and of the closing point
R_PHI, R_GAMMA, R_B, R_LAM, R_NORMAL, R_POINT = range(6)
R_COLUMNS = 6


@jit
def chain_into(L, theta1, z, zd, K):
    """Recursive pass from ground to tip (MODEL.md section 2) into ``K``."""
    n = L.shape[0]
    # the predecessor's frame; link 2's predecessor is the ground vector (a1, theta1)
    cp, sp, wp = math.cos(theta1), math.sin(theta1), 0.0
    z_sum = 0.0
    w_sum = 0.0
    ox = oy = bx = by = 0.0
    for k in range(n):
        if L[k, L_REV] != 0.0:
            z_sum += z[k]
            w_sum += zd[k]
            slide, rate = L[k, L_SLIDE0], 0.0
        else:
            slide, rate = z[k], zd[k]
        theta = L[k, L_THETA0] + z_sum
        # each link hangs off its predecessor's vector end, moved along the slide
        # axis e_perp(predecessor)
        ax, ay = -sp, cp
        dx = L[k, L_APRED] * cp + slide * ax
        dy = L[k, L_APRED] * sp + slide * ay
        ox += dx
        oy += dy
        # d'' at zero joint acceleration: centripetal of the predecessor's turn plus
        # the Coriolis term of a slide on a turning axis
        bx += -wp * wp * dx - 2.0 * wp * rate * cp
        by += -wp * wp * dy - 2.0 * wp * rate * sp
        c, s = math.cos(theta), math.sin(theta)
        K[k, K_TH] = theta
        K[k, K_OM] = w_sum
        K[k, K_COS] = c
        K[k, K_SIN] = s
        K[k, K_OX] = ox
        K[k, K_OY] = oy
        K[k, K_BX] = bx
        K[k, K_BY] = by
        K[k, K_AX] = ax
        K[k, K_AY] = ay
        K[k, K_SLIDE] = slide
        K[k, K_RATE] = rate
        cp, sp, wp = c, s, w_sum


@jit
def point_into(L, K, k, lx, ly, J):
    """Position and bias acceleration of a point of moving link ``k`` (0-based).

    ``(lx, ly)`` is the point along and across the link vector.  Its Jacobian
    (``rdot = J @ zd``) is written into ``J`` (2 x N).

    Returns
    -------
    rx, ry, bias_x, bias_y : float
    """
    n = L.shape[0]
    c, s = K[k, K_COS], K[k, K_SIN]
    armx = lx * c - ly * s
    army = lx * s + ly * c
    rx = K[k, K_OX] + armx
    ry = K[k, K_OY] + army
    for j in range(n):
        if j > k:
            J[0, j] = 0.0
            J[1, j] = 0.0
        elif L[j, L_REV] != 0.0:
            J[0, j] = -(ry - K[j, K_OY])
            J[1, j] = rx - K[j, K_OX]
        else:
            J[0, j] = K[j, K_AX]
            J[1, j] = K[j, K_AY]
    w2 = K[k, K_OM] * K[k, K_OM]
    return rx, ry, K[k, K_BX] - w2 * armx, K[k, K_BY] - w2 * army


@jit
def closure_into(L, CL, K, zd, J, R):
    """Constraint rows of every closure (MODEL.md section 3), any link pair.

    Fills ``J[:m]`` (``phi_dot = J @ zd``; rows m, m + 1 are scratch) and the
    row table ``R``: violation ``phi``, ``gamma`` of ``J @ zdd = gamma``, the
    line's normal (prismatic) and the closing point, where the closure's force acts.
    """
    n = L.shape[0]
    m = 2 * CL.shape[0]
    tmp = J[m:m + 2]
    for j in range(CL.shape[0]):
        r = 2 * j
        ka = int(CL[j, CL_LINK])
        kb = int(CL[j, CL_TO])  # -1: the ground, whose frame is the world frame
        rax, ray, bax, bay = point_into(L, K, ka, CL[j, CL_PX], CL[j, CL_PY], J[r:r + 2])
        if kb >= 0:
            rbx, rby, bbx, bby = point_into(L, K, kb, CL[j, CL_TX], CL[j, CL_TY], tmp)
            for i in range(n):
                J[r, i] -= tmp[0, i]
                J[r + 1, i] -= tmp[1, i]
            thb, wb = K[kb, K_TH], K[kb, K_OM]
        else:
            rbx, rby, bbx, bby = CL[j, CL_TX], CL[j, CL_TY], 0.0, 0.0
            thb, wb = 0.0, 0.0
        R[r, R_POINT] = rax
        R[r + 1, R_POINT] = ray
        if CL[j, CL_KIND] != PRISMATIC_CLOSURE:
            R[r, R_PHI] = rax - rbx
            R[r + 1, R_PHI] = ray - rby
            R[r, R_GAMMA] = -(bax - bbx)
            R[r + 1, R_GAMMA] = -(bay - bby)
            R[r, R_NORMAL] = 0.0
            R[r + 1, R_NORMAL] = 0.0
            continue
        # line of to_link through to_point with direction angle; link held at psi
        beta = thb + CL[j, CL_ANGLE]
        alx, aly = math.cos(beta), math.sin(beta)
        nx, ny = -aly, alx
        dx, dy = rax - rbx, ray - rby
        ddx = 0.0
        ddy = 0.0
        for i in range(n):
            ddx += J[r, i] * zd[i]
            ddy += J[r + 1, i] * zd[i]
        d_normal = dx * nx + dy * ny
        d_along = dx * alx + dy * aly
        R[r, R_PHI] = d_normal
        R[r, R_GAMMA] = -(nx * (bax - bbx) + ny * (bay - bby) - 2.0 * wb * (ddx * alx + ddy * aly)
                          - d_normal * wb * wb)
        R[r + 1, R_PHI] = K[ka, K_TH] - thb - CL[j, CL_PSI]
        R[r + 1, R_GAMMA] = 0.0
        for i in range(n):
            jwa = L[i, L_REV] if i <= ka else 0.0
            jwb = L[i, L_REV] if i <= kb else 0.0
            jx, jy = J[r, i], J[r + 1, i]
            # d(normal)/d(theta_b) = -along
            J[r, i] = nx * jx + ny * jy - d_along * jwb
            J[r + 1, i] = jwa - jwb
        R[r, R_NORMAL] = nx
        R[r + 1, R_NORMAL] = ny


@dataclass
class ChainKinematics:
    """Positions and rates of the chain at one state (data, not model).

    The fields are views of ``table``, the kernels' link table (columns ``K_*``).
    """

    theta: np.ndarray  # (N,) absolute angles of links 2..N+1
    omega: np.ndarray  # (N,) angular rates
    origin: np.ndarray  # (N, 2) joint point O_k of each link
    origin_bias: np.ndarray  # (N, 2) acceleration of O_k at zero joint acceleration
    axis: np.ndarray  # (N, 2) slide axis of each pair (unit), world frame
    revolute: np.ndarray  # (N,) bool, which joint of each pair is real
    zd: np.ndarray  # (N,) joint rates
    table: np.ndarray  # (N, K_COLUMNS) the kernels' link table
    links: np.ndarray  # the model's link table (ModelArrays.links)

    @staticmethod
    def of(model: Mechanism, K: np.ndarray, zd: np.ndarray) -> "ChainKinematics":
        """Views of a filled kinematics table."""
        return ChainKinematics(K[:, K_TH], K[:, K_OM], K[:, K_OX:K_OY + 1], K[:, K_BX:K_BY + 1],
                               K[:, K_AX:K_AY + 1], model.arrays.revolute, zd, K, model.arrays.links)


def chain_kinematics(model: Mechanism, z: np.ndarray, zd: np.ndarray) -> ChainKinematics:
    """Recursive pass from ground to tip (MODEL.md section 2)."""
    zd = np.ascontiguousarray(zd, dtype=float)
    K = np.empty((model.n_links, K_COLUMNS))
    chain_into(model.arrays.links, model.theta1, np.ascontiguousarray(z, dtype=float), zd, K)
    return ChainKinematics.of(model, K, zd)


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
    J = np.empty((2, kin.theta.shape[0]))
    rx, ry, bx, by = point_into(kin.links, kin.table, int(k), float(local[0]), float(local[1]), J)
    return np.array([rx, ry]), J, np.array([bx, by])


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
    def of(model: Mechanism, J: np.ndarray, R: np.ndarray) -> "ClosureKinematics":
        """Views and lists of a filled Jacobian ``J`` and row table ``R``."""
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
        m = 2 * len(model.closures)
        return ClosureKinematics(R[:, R_PHI], J[:m], R[:, R_GAMMA], force_dir, moment_row, application)


def closure_kinematics(model: Mechanism, kin: ChainKinematics) -> ClosureKinematics:
    """Constraint rows of every closure (MODEL.md section 3), any link pair."""
    m, n = model.n_constraints, model.n_links
    J, R = np.empty((m + 3, n)), np.empty((m, R_COLUMNS))
    closure_into(model.arrays.links, model.arrays.closures, kin.table, kin.zd, J, R)
    return ClosureKinematics.of(model, J, R)
