"""A second, independent spatial multibody model for the tests.

Rigid bodies in absolute (maximal) coordinates: each body's mass centre c,
its orientation as a unit quaternion, the velocity of c and the angular
velocity in world axes.  Joints are constraint equations between points and
axes fixed to the bodies: a spherical joint (two points coincide), a revolute
to the ground (a point fixed, the body's axis square to two fixed vectors), a
revolute between two bodies (the points coincide, one body's axis square to two
vectors across the other's).
The Newton-Euler equations of every body,
    m a = m g + F,   I_w alpha + w x I_w w = M,
with the joint forces as Lagrange multipliers, are solved together with the
constraints' acceleration equations and integrated by scipy (DOP853).  Nothing
is imported from grubler: no chain, no Denavit-Hartenberg rows, no existence
factors.  A test describes a mechanism to it by bodies, points and axes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rotation(q):
    """The rotation matrix of a quaternion (w, x, y, z), normalised first."""
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def quaternion(R):
    """A unit quaternion of a rotation matrix (Shepperd's method)."""
    t = np.trace(R)
    if t > 0:
        s = 2 * np.sqrt(1 + t)
        return np.array([s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s])
    i = int(np.argmax(np.diag(R)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2 * np.sqrt(1 + R[i, i] - R[j, j] - R[k, k])
    q = np.zeros(4)
    q[0] = (R[k, j] - R[j, k]) / s
    q[1 + i] = s / 4
    q[1 + j] = (R[j, i] + R[i, j]) / s
    q[1 + k] = (R[k, i] + R[i, k]) / s
    return q


@dataclass
class Body:
    mass: float
    inertia: np.ndarray  # about the mass centre, body axes
    c: np.ndarray        # initial mass centre, world
    R: np.ndarray        # initial orientation


@dataclass
class Spherical:
    """Point a (body frame, from its mass centre) of body i at point b of body j (j = -1: world point b)."""
    i: int
    a: np.ndarray
    j: int
    b: np.ndarray


@dataclass
class GroundRevolute:
    """Body i's point a (from its mass centre) fixed at world point p, its axis u (body) along world axis w."""
    i: int
    a: np.ndarray
    p: np.ndarray
    u: np.ndarray
    w: np.ndarray


@dataclass
class GroundPrismatic:
    """Body i slides along world axis w without turning: its point a (from its mass centre) stays on the line
    through p along w (two rows, across w), and its axes stay those of R0 (three rows: R e1 . R0 e2,
    R e1 . R0 e3, R e2 . R0 e3)."""
    i: int
    a: np.ndarray
    p: np.ndarray
    w: np.ndarray
    R0: np.ndarray


@dataclass
class Revolute:
    """Body i's point a and axis u (body i's frame, from its mass centre) on body j's point b and axis v
    (body j's; j = -1: the world's point b and axis v)."""
    i: int
    a: np.ndarray
    j: int
    b: np.ndarray
    u: np.ndarray
    v: np.ndarray


@dataclass
class Torque:
    """A constant moment on body i about world axis w (from the ground)."""
    i: int
    w: np.ndarray
    value: float


@dataclass
class BodySystem:
    bodies: list
    joints: list
    gravity: np.ndarray
    torques: list = field(default_factory=list)

    # -- state: per body c (3), q (4), v (3), w (3) -----------------------------------
    def state0(self, velocities=None):
        y = []
        for k, b in enumerate(self.bodies):
            v, w = (np.zeros(3), np.zeros(3)) if velocities is None else velocities[k]
            y += [b.c, quaternion(b.R), v, w]
        return np.concatenate(y)

    def unpack(self, y):
        out = []
        for k in range(len(self.bodies)):
            s = y[13 * k:13 * k + 13]
            out.append((s[:3], s[3:7], s[7:10], s[10:13]))
        return out

    def _point(self, parts, i, a):
        """World position, Jacobian block (3 x 6 over body i's (v, w)) and bias acceleration of a point."""
        c, q, v, w = parts[i]
        R = rotation(q)
        rho = R @ a
        return c + rho, np.hstack([np.eye(3), -skew(rho)]), np.cross(w, np.cross(w, rho))

    def constraints(self, parts):
        """Rows: (value, Jacobian over all bodies' (v, w), bias) lists."""
        nb = len(self.bodies)
        rows_phi, rows_J, rows_bias = [], [], []

        def block(i, J):
            full = np.zeros((J.shape[0], 6 * nb))
            full[:, 6 * i:6 * i + 6] = J
            return full

        for jt in self.joints:
            if isinstance(jt, Spherical):
                p, J, bias = self._point(parts, jt.i, jt.a)
                Jf = block(jt.i, J)
                if jt.j >= 0:
                    p2, J2, bias2 = self._point(parts, jt.j, jt.b)
                    p, Jf, bias = p - p2, Jf - block(jt.j, J2), bias - bias2
                else:
                    p = p - jt.b
                rows_phi.append(p), rows_J.append(Jf), rows_bias.append(bias)
            elif isinstance(jt, Revolute):
                p, J, bias = self._point(parts, jt.i, jt.a)
                Jf = block(jt.i, J)
                ci, qi, vi, wi = parts[jt.i]
                u = rotation(qi) @ jt.u
                if jt.j >= 0:
                    p2, J2, bias2 = self._point(parts, jt.j, jt.b)
                    p, Jf, bias = p - p2, Jf - block(jt.j, J2), bias - bias2
                    cj, qj, vj, wj = parts[jt.j]
                    Rj, wj = rotation(qj), wj
                else:
                    p, Rj, wj = p - jt.b, np.eye(3), np.zeros(3)
                rows_phi.append(p), rows_J.append(Jf), rows_bias.append(bias)
                v = Rj @ (jt.v / np.linalg.norm(jt.v))
                e = np.array([1.0, 0, 0]) if abs(v[0]) < 0.9 else np.array([0, 1.0, 0])
                n1 = e - (e @ v) * v
                n1 /= np.linalg.norm(n1)
                for n in (n1, np.cross(v, n1)):  # u . n = 0, n turning with body j
                    Jr = np.zeros((1, 6 * nb))
                    Jr[0, 6 * jt.i + 3:6 * jt.i + 6] = np.cross(u, n)
                    if jt.j >= 0:
                        Jr[0, 6 * jt.j + 3:6 * jt.j + 6] = -np.cross(u, n)
                    udot, ndot = np.cross(wi, u), np.cross(wj, n)
                    rows_phi.append(np.array([u @ n])), rows_J.append(Jr)
                    rows_bias.append(np.array([np.cross(wi, udot) @ n + 2 * udot @ ndot + u @ np.cross(wj, ndot)]))
            elif isinstance(jt, GroundPrismatic):
                p, J, bias = self._point(parts, jt.i, jt.a)
                wn = jt.w / np.linalg.norm(jt.w)
                e = np.array([1.0, 0, 0]) if abs(wn[0]) < 0.9 else np.array([0, 1.0, 0])
                n1 = e - (e @ wn) * wn
                n1 /= np.linalg.norm(n1)
                for n in (n1, np.cross(wn, n1)):  # the point on the line
                    rows_phi.append(np.array([(p - jt.p) @ n])), rows_J.append(block(jt.i, (n @ J)[None, :]))
                    rows_bias.append(np.array([bias @ n]))
                c, q, v, w = parts[jt.i]
                R = rotation(q)
                for a_, b_ in ((0, 1), (0, 2), (1, 2)):  # the axes held
                    u, n = R[:, a_], jt.R0[:, b_]
                    Jr = np.zeros((1, 6))
                    Jr[0, 3:] = np.cross(u, n)
                    rows_phi.append(np.array([u @ n])), rows_J.append(block(jt.i, Jr))
                    rows_bias.append(np.array([np.cross(w, np.cross(w, u)) @ n]))
            else:
                p, J, bias = self._point(parts, jt.i, jt.a)
                rows_phi.append(p - jt.p), rows_J.append(block(jt.i, J)), rows_bias.append(bias)
                c, q, v, w = parts[jt.i]
                u = rotation(q) @ jt.u
                wn = jt.w / np.linalg.norm(jt.w)
                e = np.array([1.0, 0, 0]) if abs(wn[0]) < 0.9 else np.array([0, 1.0, 0])
                n1 = e - (e @ wn) * wn
                n1 /= np.linalg.norm(n1)
                n2 = np.cross(wn, n1)
                for n in (n1, n2):
                    Jr = np.zeros((1, 6))
                    Jr[0, 3:] = np.cross(u, n)
                    rows_phi.append(np.array([u @ n])), rows_J.append(block(jt.i, Jr))
                    rows_bias.append(np.array([np.cross(w, np.cross(w, u)) @ n]))
        return np.concatenate(rows_phi), np.vstack(rows_J), np.concatenate(rows_bias)

    def accelerations(self, y):
        """Body accelerations (v', w' per body) and the joint forces (multipliers: on body i, world)."""
        parts = self.unpack(y)
        nb = len(self.bodies)
        M = np.zeros((6 * nb, 6 * nb))
        f = np.zeros(6 * nb)
        for k, (b, (c, q, v, w)) in enumerate(zip(self.bodies, parts)):
            R = rotation(q)
            Iw = R @ b.inertia @ R.T
            M[6 * k:6 * k + 3, 6 * k:6 * k + 3] = b.mass * np.eye(3)
            M[6 * k + 3:6 * k + 6, 6 * k + 3:6 * k + 6] = Iw
            f[6 * k:6 * k + 3] = b.mass * self.gravity
            f[6 * k + 3:6 * k + 6] = -np.cross(w, Iw @ w)
        for t in self.torques:
            f[6 * t.i + 3:6 * t.i + 6] += t.value * t.w
        _, J, bias = self.constraints(parts)
        m = J.shape[0]
        K = np.block([[M, J.T], [J, np.zeros((m, m))]])
        # least squares: an overconstrained loop's dependent rows leave K singular; the accelerations are
        # still unique (the multipliers are then the minimum-norm ones)
        sol = np.linalg.lstsq(K, np.concatenate([f, -bias]), rcond=1e-12)[0]
        return sol[:6 * nb], -sol[6 * nb:]

    def rhs(self, t, y):
        acc, _ = self.accelerations(y)
        out = np.zeros_like(y)
        for k, (c, q, v, w) in enumerate(self.unpack(y)):
            out[13 * k:13 * k + 3] = v
            wq = np.array([0.0, *w])  # qdot = 1/2 (0, w) * q with w in world axes
            out[13 * k + 3:13 * k + 7] = 0.5 * np.array([
                wq[0] * q[0] - wq[1:] @ q[1:],
                *(wq[0] * q[1:] + q[0] * wq[1:] + np.cross(wq[1:], q[1:]))])
            out[13 * k + 7:13 * k + 10] = acc[6 * k:6 * k + 3]
            out[13 * k + 10:13 * k + 13] = acc[6 * k + 3:6 * k + 6]
        return out

    def run(self, t_out, y0=None, rtol=1e-12, atol=1e-12):
        y0 = self.state0() if y0 is None else y0
        sol = solve_ivp(self.rhs, (0.0, t_out[-1]), y0, method="DOP853", t_eval=t_out, rtol=rtol, atol=atol)
        assert sol.success, sol.message
        return sol.y.T
