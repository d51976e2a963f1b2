"""Forward kinematics of the generalised chain and of its closures.

One pass along the chain gives, for every moving link, its angle, angular rate,
joint point and the acceleration of that point when all joint accelerations are zero
(the bias or convective term).  Any point of any link then has a position, a
Jacobian with respect to the real joint rates and a bias acceleration, so that its
acceleration is ``J @ zdd + bias``.  The closure constraints are built from those
points; nothing here is specific to four links.

Jacobian columns are the planar screw of each real joint: a revolute at O_b moves a
point r with ``k x (r - O_b)``, a slide moves it along its axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import Mechanism


def rot90(v: np.ndarray) -> np.ndarray:
    """k x v for planar vectors (last axis of length 2)."""
    out = np.empty_like(v)
    out[..., 0] = -v[..., 1]
    out[..., 1] = v[..., 0]
    return out


@dataclass
class ChainKinematics:
    """Positions and rates of the chain at one state (data, not model)."""

    theta: np.ndarray  # (N,) absolute angles of links 2..N+1
    omega: np.ndarray  # (N,) angular rates
    origin: np.ndarray  # (N, 2) joint point O_k of each link
    origin_bias: np.ndarray  # (N, 2) acceleration of O_k at zero joint acceleration
    axis: np.ndarray  # (N, 2) slide axis of each pair (unit), world frame
    revolute: np.ndarray  # (N,) bool, which joint of each pair is real
    zd: np.ndarray  # (N,) joint rates


def chain_kinematics(model: Mechanism, z: np.ndarray, zd: np.ndarray) -> ChainKinematics:
    """Recursive pass from ground to tip (MODEL.md section 2)."""
    q = model.q_from_z(z)
    qd = model.S @ zd
    theta = q[1::2]
    omega = qd[1::2]
    slide = q[0::2]
    slide_rate = qd[0::2]
    # each link hangs off its predecessor's vector end, moved along the slide axis
    # e_perp(predecessor); link 2's predecessor is the ground vector (a1, theta1)
    pred_angle = np.concatenate(([model.theta1], theta[:-1]))
    pred_omega = np.concatenate(([0.0], omega[:-1]))
    c, s = np.cos(pred_angle), np.sin(pred_angle)
    e = np.column_stack([c, s])
    axis = np.column_stack([-s, c])
    d = model.arrays.a_pred[:, None] * e + slide[:, None] * axis
    origin = np.cumsum(d, axis=0)
    # d'' at zero joint acceleration: centripetal of the predecessor's turn plus
    # the Coriolis term of a slide on a turning axis
    origin_bias = np.cumsum(-(pred_omega**2)[:, None] * d - (2.0 * pred_omega * slide_rate)[:, None] * e, axis=0)
    return ChainKinematics(theta, omega, origin, origin_bias, axis, model.joint_is_revolute(), zd)


def link_frame(kin: ChainKinematics, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors e(theta_k), e_perp(theta_k) of moving link index k (0-based)."""
    c, s = np.cos(kin.theta[k]), np.sin(kin.theta[k])
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
    e, e_perp = link_frame(kin, k)
    arm = local[0] * e + local[1] * e_perp
    r = kin.origin[k] + arm
    n = kin.theta.shape[0]
    J = np.zeros((2, n))
    upto = slice(0, k + 1)
    J[:, upto] = np.where(kin.revolute[upto, None], rot90(r - kin.origin[upto]), kin.axis[upto]).T
    bias = kin.origin_bias[k] - kin.omega[k] ** 2 * arm
    return r, J, bias


def _point(model: Mechanism, kin: ChainKinematics, link: int, local):
    """Point of link ``link`` (thesis numbering; 1 is the ground, world frame)."""
    n = model.n_links
    if link == 1:
        return np.asarray(local, dtype=float), np.zeros((2, n)), np.zeros(2), 0.0, np.zeros(n), 0.0
    k = link - 2
    r, J, bias = point_on_link(kin, k, local)
    return r, J, bias, kin.theta[k], model.arrays.Jw[k], kin.omega[k]


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


def closure_kinematics(model: Mechanism, kin: ChainKinematics) -> ClosureKinematics:
    """Constraint rows of every closure (MODEL.md section 3), any link pair."""
    m = model.n_constraints
    n = model.n_links
    phi = np.zeros(m)
    J = np.zeros((m, n))
    gamma = np.zeros(m)
    force_dir, moment_row, application = [], [], []
    row = 0
    zd = kin.zd
    for cl in model.closures:
        ra, Ja, ba, tha, Jwa, wa = _point(model, kin, cl.link, cl.point)
        if cl.kind == "revolute":
            # target point of to_link, in its frame
            if cl.to_link == 1:
                rb, Jb, bb = np.asarray(cl.to_point, float), np.zeros((2, n)), np.zeros(2)
            else:
                rb, Jb, bb = point_on_link(kin, cl.to_link - 2, cl.to_point)
            phi[row : row + 2] = ra - rb
            J[row : row + 2] = Ja - Jb
            gamma[row : row + 2] = -(ba - bb)
            force_dir.append(np.eye(2))
            moment_row.append(np.zeros(2))
        else:
            # line of to_link through to_point with direction angle; link held at psi
            if cl.to_link == 1:
                p0, Jp, bp = np.asarray(cl.to_point, float), np.zeros((2, n)), np.zeros(2)
                thb, Jwb, wb = 0.0, np.zeros(n), 0.0
            else:
                kb = cl.to_link - 2
                p0, Jp, bp = point_on_link(kin, kb, cl.to_point)
                thb, Jwb, wb = kin.theta[kb], model.arrays.Jw[kb], kin.omega[kb]
            beta = thb + cl.angle
            along = np.array([np.cos(beta), np.sin(beta)])
            normal = np.array([-along[1], along[0]])
            d = ra - p0
            Jd = Ja - Jp
            dd = Jd @ zd
            phi[row] = d @ normal
            # d(normal)/d(theta_b) = -along
            J[row] = normal @ Jd - (d @ along) * Jwb
            gamma[row] = -(normal @ (ba - bp) - 2.0 * wb * (dd @ along) - (d @ normal) * wb**2)
            phi[row + 1] = tha - thb - cl.psi
            J[row + 1] = Jwa - Jwb
            gamma[row + 1] = 0.0
            force_dir.append(np.column_stack([normal, np.zeros(2)]))
            moment_row.append(np.array([0.0, 1.0]))
        application.append(ra)
        row += 2
    return ClosureKinematics(phi, J, gamma, force_dir, moment_row, application)
