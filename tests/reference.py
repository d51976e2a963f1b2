"""An independent reference for the tests: complex-number kinematics straight from
MODEL.md in absolute coordinates, derivatives by finite differences, and
per-link Newton-Euler free-body equations.  It shares no code with grubler's
Jacobian recursion, mass matrix or closure rows.
"""

from __future__ import annotations

import cmath

import numpy as np


class RefChain:
    """A chain read from plain parameters (not from grubler's arrays).

    links: list of dicts with joint, a, p, q, m, I, damping.
    """

    def __init__(self, links, a1=0.0, theta1=0.0, g=9.81):
        self.links = links
        self.a1, self.theta1, self.g = a1, theta1, g

    @classmethod
    def of(cls, mechanism):
        links = [dict(joint=l.joint, a=l.a, p=l.p, q=l.q, m=l.m, I=l.I, damping=l.damping)
                 for l in mechanism.links]
        return cls(links, mechanism.a1, mechanism.theta1, mechanism.gravity)

    # positions as complex numbers, q in thesis order (B1, th2, B2, th3, ...)
    def origins(self, q):
        e1 = cmath.exp(1j * self.theta1)
        o = [self.a1 * e1 + 1j * q[0] * e1]
        for k in range(1, len(self.links)):
            th = q[2 * k - 1]
            o.append(o[-1] + (self.links[k - 1]["a"] + 1j * q[2 * k]) * cmath.exp(1j * th))
        return o

    def point(self, q, k, u, v):
        """Point (u, v) of moving link k (0-based)."""
        return self.origins(q)[k] + (u + 1j * v) * cmath.exp(1j * q[2 * k + 1])

    def centre(self, q, k):
        l = self.links[k]
        return self.point(q, k, l["p"], l["q"])

    def tip(self, q):
        k = len(self.links) - 1
        return self.point(q, k, self.links[k]["a"], 0.0)

    # time derivatives along a trajectory by central differences in q
    @staticmethod
    def rate(f, q, qd, h=1e-6):
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        return (f(q + h * qd) - f(q - h * qd)) / (2 * h)

    @staticmethod
    def accel(f, q, qd, qdd, h=1e-4):
        """d2/dt2 f(q(t)) = J qdd + qd^T H qd."""
        q, qd, qdd = (np.asarray(x, float) for x in (q, qd, qdd))
        jq = (f(q + 1e-6 * qdd) - f(q - 1e-6 * qdd)) / 2e-6
        hq = (f(q + h * qd) - 2 * f(q) + f(q - h * qd)) / h**2
        return jq + hq

    def energy(self, q, qd):
        ke = pe = 0.0
        for k, l in enumerate(self.links):
            v = self.rate(lambda x: self.centre(x, k), q, qd)
            w = qd[2 * k + 1]
            ke += 0.5 * l["m"] * abs(v) ** 2 + 0.5 * l["I"] * w**2
            pe += l["m"] * self.g * self.centre(q, k).imag
        return ke, pe

    def newton_euler(self, q, qd, qdd, closure, drive_pair, drive_known=0.0):
        """Solve every link's free-body equations for the joint forces.

        closure: ('revolute', None) or ('prismatic', line_angle), at the tip,
        to the ground.  drive_pair: 0-based pair whose effort is unknown.

        Returns dict with 'drive' (effort), 'pair_force' [(Fx, Fy, M) per pair,
        on the following link at its origin] and 'closure' (Fx, Fy, M) on the
        last link from the ground, plus the residual of the least-squares solve.
        """
        n = len(self.links)
        o = self.origins(q)
        tip = self.tip(q)
        # unknowns: per pair 2 (R: Fx, Fy; P: normal force, moment), closure 2, drive 1
        nu = 2 * n + 3
        A = np.zeros((3 * n, nu))
        b = np.zeros(3 * n)
        th = [q[2 * k + 1] for k in range(n)]
        thd = [qd[2 * k + 1] for k in range(n)]

        def add_force(link, col, fvec, at, scale=1.0):
            # unknown col times (force fvec at point 'at', complex) on link
            if link < 0:
                return
            A[3 * link, col] += scale * fvec.real
            A[3 * link + 1, col] += scale * fvec.imag
            r = at - o[link]
            A[3 * link + 2, col] += scale * (r.real * fvec.imag - r.imag * fvec.real)

        def add_moment(link, col, scale=1.0):
            if link >= 0:
                A[3 * link + 2, col] += scale

        def add_known_force(link, fvec, at):
            if link < 0:
                return
            b[3 * link] -= fvec.real
            b[3 * link + 1] -= fvec.imag
            r = at - o[link]
            b[3 * link + 2] -= r.real * fvec.imag - r.imag * fvec.real

        for k in range(n):
            l = self.links[k]
            pred_angle = self.theta1 if k == 0 else th[k - 1]
            axis = 1j * cmath.exp(1j * pred_angle)
            cu, cv = 2 * k, 2 * k + 1
            if l["joint"] == "R":
                rel_rate = thd[k] - (0.0 if k == 0 else thd[k - 1])
                add_force(k, cu, 1.0, o[k])
                add_force(k - 1, cu, 1.0, o[k], -1.0)
                add_force(k, cv, 1j, o[k])
                add_force(k - 1, cv, 1j, o[k], -1.0)
                known = -l["damping"] * rel_rate + (drive_known if k == drive_pair else 0.0)
                b[3 * k + 2] -= known
                if k > 0:
                    b[3 * (k - 1) + 2] += known
                if k == drive_pair:
                    add_moment(k, nu - 1)
                    add_moment(k - 1, nu - 1, -1.0)
            else:
                rel_rate = qd[2 * k]
                normal = 1j * axis
                add_force(k, cu, normal, o[k])
                add_force(k - 1, cu, normal, o[k], -1.0)
                add_moment(k, cv)
                add_moment(k - 1, cv, -1.0)
                known = -l["damping"] * rel_rate + (drive_known if k == drive_pair else 0.0)
                add_known_force(k, known * axis, o[k])
                if k > 0:
                    add_known_force(k - 1, -known * axis, o[k])
                if k == drive_pair:
                    add_force(k, nu - 1, axis, o[k])
                    add_force(k - 1, nu - 1, axis, o[k], -1.0)
        kind, angle = closure
        if kind == "revolute":
            add_force(n - 1, 2 * n, 1.0, tip)
            add_force(n - 1, 2 * n + 1, 1j, tip)
        else:
            add_force(n - 1, 2 * n, 1j * cmath.exp(1j * angle), tip)
            add_moment(n - 1, 2 * n + 1)
        # inertia and gravity: sum of forces = m a, moment about origin = I alpha + r x m a
        for k, l in enumerate(self.links):
            a = self.accel(lambda x: self.centre(x, k), q, qd, qdd)
            c = self.centre(q, k)
            f = l["m"] * (a + 1j * self.g)  # m a - m g
            r = c - o[k]
            b[3 * k] += f.real
            b[3 * k + 1] += f.imag
            b[3 * k + 2] += l["I"] * qdd[2 * k + 1] + (r.real * f.imag - r.imag * f.real)
        x, *_ = np.linalg.lstsq(A, b, rcond=None)
        res = float(np.linalg.norm(A @ x - b))
        pair_force = []
        for k in range(n):
            l = self.links[k]
            if l["joint"] == "R":
                pair_force.append((x[2 * k], x[2 * k + 1]))
            else:
                pred_angle = self.theta1 if k == 0 else th[k - 1]
                nrm = -cmath.exp(1j * pred_angle)
                f = x[2 * k] * nrm
                pair_force.append((f.real, f.imag))
        if kind == "revolute":
            cf = (x[2 * n], x[2 * n + 1], 0.0)
        else:
            f = x[2 * n] * 1j * cmath.exp(1j * angle)
            cf = (f.real, f.imag, x[2 * n + 1])
        return {"drive": x[-1], "pair_force": pair_force, "closure": cf, "residual": res}
