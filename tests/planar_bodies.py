"""A second, independent planar multibody model for the tests.

Bodies in absolute (maximal) coordinates, each pose (x, y, phi) of its mass
centre, tied by pin joints between named points; the equations of motion by
Lagrange multipliers with Baumgarte stabilisation, integrated by scipy.  It is
written from the geometry alone: no chain, no imaginary joints, no existence
factors, nothing imported from grubler.  The tests describe a mechanism to it as
a designer would (pivots, pins and where each body's mass sits) and compare what
it computes with the library.

Also here, equally independent: the closed-form position of a revolute dyad
(two circles), a potential-energy minimisation under the pin constraints
(scipy.optimize) and the static joint forces at a rest position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares, minimize


def dyad(p, q, r_p, r_q, sign):
    """Where two links of lengths r_p (from p) and r_q (from q) meet.

    sign +1: the meeting point left of p -> q, -1: right.  None if the triangle
    (|pq|, r_p, r_q) does not exist.
    """
    p, q = np.asarray(p, float), np.asarray(q, float)
    d = float(np.hypot(*(q - p)))
    if d == 0 or d > r_p + r_q or d < abs(r_p - r_q):
        return None
    along = (r_p**2 - r_q**2 + d * d) / (2 * d)
    h = math.sqrt(max(r_p**2 - along**2, 0.0))
    u = (q - p) / d
    return p + along * u + sign * h * np.array([-u[1], u[0]])


def rot(phi):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


@dataclass
class Body:
    """A rigid body: mass, centroidal inertia, and points in its own frame.

    The frame's origin is the mass centre; ``points`` maps names to local
    coordinates (m).
    """

    name: str
    m: float
    I: float
    points: dict


@dataclass
class Pin:
    """A revolute joint: point ``a`` of body ``i`` on point ``b`` of body ``j``.

    ``j`` None means a fixed point ``b`` (world coordinates).  ``damping``
    (N m s/rad) resists the relative rotation.
    """

    i: int
    a: str
    j: int | None
    b: object
    damping: float = 0.0


@dataclass
class Bodies:
    bodies: list
    pins: list
    g: float = 9.81
    torque: dict = field(default_factory=dict)  # body index -> constant torque from the ground, N m

    @property
    def n(self):
        return 3 * len(self.bodies)

    def point(self, x, i, name):
        return x[3 * i:3 * i + 2] + rot(x[3 * i + 2]) @ np.asarray(self.bodies[i].points[name], float)

    def phi(self, x):
        out = []
        for pin in self.pins:
            pa = self.point(x, pin.i, pin.a)
            pb = np.asarray(pin.b, float) if pin.j is None else self.point(x, pin.j, pin.b)
            out += list(pa - pb)
        return np.array(out)

    def jac(self, x):
        J = np.zeros((2 * len(self.pins), self.n))
        for r, pin in enumerate(self.pins):
            for k, name, sgn in ((pin.i, pin.a, 1.0), (pin.j, pin.b, -1.0)):
                if k is None:
                    continue
                w = rot(x[3 * k + 2]) @ np.asarray(self.bodies[k].points[name], float)
                J[2 * r:2 * r + 2, 3 * k:3 * k + 2] += sgn * np.eye(2)
                J[2 * r:2 * r + 2, 3 * k + 2] += sgn * np.array([-w[1], w[0]])
        return J

    def gamma(self, x, v):
        # J xdd = gamma: the centripetal part of each pin point's acceleration
        out = np.zeros(2 * len(self.pins))
        for r, pin in enumerate(self.pins):
            for k, name, sgn in ((pin.i, pin.a, 1.0), (pin.j, pin.b, -1.0)):
                if k is None:
                    continue
                w = rot(x[3 * k + 2]) @ np.asarray(self.bodies[k].points[name], float)
                out[2 * r:2 * r + 2] += sgn * v[3 * k + 2] ** 2 * w
        return out

    def mass(self):
        return np.diag([v for b in self.bodies for v in (b.m, b.m, b.I)])

    def forces(self, x, v):
        Q = np.zeros(self.n)
        for k, b in enumerate(self.bodies):
            Q[3 * k + 1] -= b.m * self.g
        for k, tau in self.torque.items():
            Q[3 * k + 2] += tau
        for pin in self.pins:
            rel = v[3 * pin.i + 2] - (0.0 if pin.j is None else v[3 * pin.j + 2])
            Q[3 * pin.i + 2] -= pin.damping * rel
            if pin.j is not None:
                Q[3 * pin.j + 2] += pin.damping * rel
        return Q

    def potential(self, x):
        return sum(b.m * self.g * x[3 * k + 1] for k, b in enumerate(self.bodies))

    def kinetic(self, v):
        return 0.5 * v @ self.mass() @ v

    def accelerations(self, x, v, alpha=20.0):
        J, M = self.jac(x), self.mass()
        m = J.shape[0]
        A = np.block([[M, J.T], [J, np.zeros((m, m))]])
        rhs = np.concatenate([self.forces(x, v),
                              self.gamma(x, v) - 2 * alpha * (J @ v) - alpha**2 * self.phi(x)])
        sol = np.linalg.lstsq(A, rhs, rcond=None)[0]
        return sol[:self.n], -sol[self.n:]  # lambda: the pins' forces on body i

    def close(self, x0, hold=None):
        """Positions satisfying every pin from a sketch, body ``hold`` at its angle."""
        x0 = np.asarray(x0, float)

        def res(x):
            r = list(self.phi(x))
            if hold is not None:
                r.append(x[3 * hold + 2] - x0[3 * hold + 2])
            return np.array(r)

        sol = least_squares(res, x0, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        return sol.x

    def simulate(self, x0, v0, times, rtol=1e-11, atol=1e-11):
        def f(t, y):
            x, v = y[:self.n], y[self.n:]
            a, _ = self.accelerations(x, v)
            return np.concatenate([v, a])

        sol = solve_ivp(f, (times[0], times[-1]), np.concatenate([x0, v0]), method="DOP853", t_eval=times,
                        rtol=rtol, atol=atol)
        assert sol.success, sol.message
        return sol.y[:self.n].T, sol.y[self.n:].T

    def rest(self, x0):
        """Minimum potential energy under the pin constraints, from x0 (SLSQP)."""
        cons = {"type": "eq", "fun": self.phi, "jac": self.jac}
        sol = minimize(self.potential, x0, jac=lambda x: np.array(
            [0.0 if i % 3 != 1 else self.bodies[i // 3].m * self.g for i in range(self.n)]),
            constraints=[cons], method="SLSQP", options={"ftol": 1e-15, "maxiter": 1000})
        return self.close(sol.x)

    def static_forces(self, x):
        """Pin forces (on body i, world axes) holding the bodies at rest at x.

        J^T lambda + Q = 0 for lambda, Q gravity (and the constant torques).
        """
        J = self.jac(x)
        Q = self.forces(x, np.zeros(self.n))
        lam, *_ = np.linalg.lstsq(J.T, -Q, rcond=None)
        return lam.reshape(-1, 2)
