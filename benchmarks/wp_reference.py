"""Reference solutions for the work-precision benchmark, independent of grubler.

Each mechanism is written here in ONE minimal coordinate, the crank angle (the
coupler angle for the trammel), with the loop solved in closed form (circle
intersection, the slider-crank's arcsine, the trammel's explicit geometry).  The
kinematic coefficients h_k = d(theta_k)/d(theta) and the mass-centre derivatives
c_k' = dc_k/dtheta, c_k'' are differentiated by hand, so Lagrange's equation for
one coordinate,

    m(theta) theta'' + 1/2 m'(theta) theta'^2 + dV/dtheta = tau,
    m = sum_k m_k |c_k'|^2 + I_k h_k^2,   m' = 2 sum_k m_k c_k'.c_k'' + I_k h_k h_k',

is integrated by scipy's DOP853 at rtol = atol = 1e-13.  The closing joint's
force comes from Newton-Euler moment balances of free bodies, using the
accelerations c_k' theta'' + c_k'' theta'^2.  Nothing here calls grubler: the
parameters are the thesis's (MODEL.md section 4), written out again, and
:func:`check_parameters` only compares them with grubler's presets.

Sign conventions follow MODEL.md: angles absolute, counter-clockwise from +x, y up,
gravity -g y; (Fx, Fy) and Mz are what the ground exerts on the last link at the
closing joint.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np
import scipy.integrate

G = 9.81


def _e(t: float) -> complex:
    return complex(math.cos(t), math.sin(t))


def _cross(a: complex, b: complex) -> float:
    """Planar cross product of two vectors written as complex numbers."""
    return a.real * b.imag - a.imag * b.real


@dataclass
class Geometry:
    """Kinematics at one crank angle, per moving link (2, 3, 4); vectors are complex x + iy."""

    theta: tuple  # absolute link angles
    h: tuple  # d theta_k / d theta
    hp: tuple  # d2 theta_k / d theta2
    c: tuple  # mass centres
    cp: tuple  # d c / d theta
    cpp: tuple  # d2 c / d theta2
    slides: tuple  # (B1, B2, B3) thesis slide coordinates
    slides_p: tuple
    slides_pp: tuple
    closure_point: complex  # the closing joint


class OneDof:
    """A mechanism in one coordinate; subclasses give the closed-form geometry."""

    name = ""
    m = (0.0, 0.0, 0.0)
    I = (0.0, 0.0, 0.0)
    theta0 = 0.0

    def __init__(self, torque: float = 0.0):
        self.torque = float(torque)

    def geometry(self, th: float) -> Geometry:  # pragma: no cover - abstract
        raise NotImplementedError

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        th, w = y
        gm = self.geometry(th)
        mass = dmass = dv = 0.0
        for mk, Ik, cp, cpp, h, hp in zip(self.m, self.I, gm.cp, gm.cpp, gm.h, gm.hp):
            mass += mk * (cp.real * cp.real + cp.imag * cp.imag) + Ik * h * h
            dmass += 2.0 * (mk * (cp.real * cpp.real + cp.imag * cpp.imag) + Ik * h * hp)
            dv += G * mk * cp.imag
        return np.array([w, (self.torque - 0.5 * dmass * w * w - dv) / mass])

    def solve(self, t_end: float, t_eval: np.ndarray, rtol: float = 1e-13, atol: float = 1e-13):
        """Integrate from rest at theta0; returns (theta, theta_dot, evaluations) on t_eval."""
        sol = scipy.integrate.solve_ivp(self.rhs, (0.0, t_end), [self.theta0, 0.0], method="DOP853",
                                        rtol=rtol, atol=atol, t_eval=t_eval)
        if not sol.success:
            raise RuntimeError(f"{self.name}: reference integration failed: {sol.message}")
        return sol.y[0], sol.y[1], sol.nfev

    def accelerations(self, th: float, w: float):
        """theta'', the geometry, each centre's acceleration and each link's angular acceleration."""
        wdd = self.rhs(0.0, np.array([th, w]))[1]
        gm = self.geometry(th)
        acc = [cp * wdd + cpp * w * w for cp, cpp in zip(gm.cp, gm.cpp)]
        alpha = [h * wdd + hp * w * w for h, hp in zip(gm.h, gm.hp)]
        return wdd, gm, acc, alpha

    def moment(self, links, point: complex, gm: Geometry, acc, alpha) -> float:
        """sum over links of I alpha + (c - P) x m (a - g): what the other forces' moments must equal."""
        return sum(self.I[k] * alpha[k] + _cross(gm.c[k] - point, self.m[k] * (acc[k] + 1j * G)) for k in links)

    def closure_force(self, th: float, w: float) -> tuple[np.ndarray, float, float]:  # pragma: no cover
        raise NotImplementedError

    def thesis_coordinates(self, th: float, w: float):
        """(q, qd, qdd) in thesis order (B1, th2, B2, th3, B3, th4), for the Newton-Euler cross-check."""
        wdd, gm, _, _ = self.accelerations(th, w)
        q, qd, qdd = [], [], []
        for k in range(3):
            q += [gm.slides[k], gm.theta[k]]
            qd += [gm.slides_p[k] * w, gm.h[k] * w]
            qdd += [gm.slides_p[k] * wdd + gm.slides_pp[k] * w * w, gm.h[k] * wdd + gm.hp[k] * w * w]
        return np.array(q), np.array(qd), np.array(qdd)


_ZERO3 = (0.0, 0.0, 0.0)


class FourBar(OneDof):
    """Thesis four-bar: crank 0.2, coupler 0.8, rocker 0.8, ground pivots (0, 0) and (1, 0).

    The rocker is link 4, from the coupler joint B to the ground pivot D.  Link 3
    starts at pi/3 (B above the line from the crank pin to D): that branch is kept.
    """

    name = "four-bar"
    a = (0.2, 0.8, 0.8)
    p = (0.1, 0.4, 0.4)
    m = (1.0, 2.0, 3.0)
    I = (0.1, 0.2, 0.3)
    D = 1.0 + 0.0j

    def geometry(self, th: float) -> Geometry:
        a2, a3, a4 = self.a
        p2, p3, p4 = self.p
        e2 = _e(th)
        A = a2 * e2
        d = self.D - A
        L = abs(d)
        x = (a3 * a3 - a4 * a4 + L * L) / (2 * L)
        y = math.sqrt(a3 * a3 - x * x)
        B = A + (x + 1j * y) * d / L
        t3 = cmath.phase(B - A)
        t4 = cmath.phase(self.D - B)
        # velocity loop a2 e'2 + a3 h3 e'3 + a4 h4 e'4 = 0, dotted with e4 and with e3
        h3 = -a2 * math.sin(t4 - th) / (a3 * math.sin(t4 - t3))
        h4 = -a2 * math.sin(t3 - th) / (a4 * math.sin(t3 - t4))
        # its derivative, sum a_k (h_k' e'_k - h_k^2 e_k) = 0, dotted likewise
        h3p = (a2 * math.cos(th - t4) + a3 * h3 * h3 * math.cos(t3 - t4) + a4 * h4 * h4) / (a3 * math.sin(t4 - t3))
        h4p = (a2 * math.cos(th - t3) + a3 * h3 * h3 + a4 * h4 * h4 * math.cos(t3 - t4)) / (a4 * math.sin(t3 - t4))
        e3, e4 = _e(t3), _e(t4)
        n2, n3, n4 = 1j * e2, 1j * e3, 1j * e4
        r4 = a4 - p4  # rocker centre to ground pivot
        return Geometry(
            (th, t3, t4), (1.0, h3, h4), (0.0, h3p, h4p),
            (p2 * e2, A + p3 * e3, self.D - r4 * e4),
            (p2 * n2, a2 * n2 + p3 * h3 * n3, -r4 * h4 * n4),
            (-p2 * e2, -a2 * e2 + p3 * (h3p * n3 - h3 * h3 * e3), -r4 * (h4p * n4 - h4 * h4 * e4)),
            _ZERO3, _ZERO3, _ZERO3, self.D)

    def closure_force(self, th: float, w: float) -> tuple[np.ndarray, float, float]:
        """(Fx, Fy), Mz on link 4 at D, and the residual of the unused balance (whole chain about O)."""
        _, gm, acc, alpha = self.accelerations(th, w)
        A = self.a[0] * _e(th)
        B = self.D - self.a[2] * _e(gm.theta[2])
        # link 4 about B, links 3 + 4 about A: (D - P) x F = their moment
        rows, rhs = [], []
        for links, P in (((2,), B), ((1, 2), A)):
            r = self.D - P
            rows.append([-r.imag, r.real])
            rhs.append(self.moment(links, P, gm, acc, alpha))
        F = np.linalg.solve(np.array(rows), np.array(rhs))
        resid = self.moment((0, 1, 2), 0j, gm, acc, alpha) - (_cross(self.D, complex(*F)) + self.torque)
        return F, 0.0, resid


class SliderCrank(OneDof):
    """Thesis slider-crank: crank 0.25 (mass at its pin), rod 1.0 (mass at its far end),
    a 3 kg block at the rod's end sliding on y = 0.2, held at psi = pi."""

    name = "slider-crank"
    a2, a3, offset = 0.25, 1.0, 0.2
    m = (1.0, 2.0, 3.0)
    I = (0.0, 0.0, 0.0)

    def geometry(self, th: float) -> Geometry:
        a2, a3, e = self.a2, self.a3, self.offset
        s3 = (e - a2 * math.sin(th)) / a3
        t3 = math.asin(s3)  # the rod points to +x (the assembled start's branch)
        c3 = math.cos(t3)
        h3 = -a2 * math.cos(th) / (a3 * c3)
        h3p = (a2 * math.sin(th) + a3 * s3 * h3 * h3) / (a3 * c3)
        xb = a2 * math.cos(th) + a3 * c3
        xbp = -a2 * math.sin(th) - a3 * s3 * h3
        xbpp = -a2 * math.cos(th) - a3 * (c3 * h3 * h3 + s3 * h3p)
        e2 = _e(th)
        B = complex(xb, e)
        return Geometry(
            (th, t3, math.pi), (1.0, h3, 0.0), (0.0, h3p, 0.0),
            (a2 * e2, B, B), (a2 * 1j * e2, complex(xbp), complex(xbp)), (-a2 * e2, complex(xbpp), complex(xbpp)),
            _ZERO3, _ZERO3, _ZERO3, B)

    def closure_force(self, th: float, w: float) -> tuple[np.ndarray, float, float]:
        """Normal force (0, Fy) and moment on the block from the line y = 0.2.

        The block is a point mass at the pin with I = 0, so the moment is zero; the
        rod and block together about the crank pin A give Fy.  The unused balance
        (the whole chain about O, with the drive torque) is returned as a residual.
        """
        _, gm, acc, alpha = self.accelerations(th, w)
        A = self.a2 * _e(th)
        B = gm.closure_point
        fy = self.moment((1, 2), A, gm, acc, alpha) / (B - A).real
        resid = self.moment((0, 1, 2), 0j, gm, acc, alpha) - (_cross(B, 1j * fy) + self.torque)
        return np.array([0.0, fy]), 0.0, resid


class Trammel(OneDof):
    """Thesis double slider (elliptic trammel): a 9 kg block on y = 0 (centre 0.01 to
    its +x side), coupler 0.8 (centre mid-way), a 1 kg block on x = 0.8 (centre 0.01
    to its -x side, held at psi = pi).  Coordinate: the coupler angle theta3."""

    name = "trammel"
    L, pc, off2, off4, x_line = 0.8, 0.4, 0.01, 0.01, 0.8
    m = (9.0, 1.0, 1.0)
    I = (0.0, 0.0, 0.0)

    def geometry(self, th: float) -> Geometry:
        L, pc = self.L, self.pc
        c_, s_ = math.cos(th), math.sin(th)
        o2 = complex(self.x_line - L * c_)
        o4 = complex(self.x_line, L * s_)
        # thesis coordinates: O2 = B1 e_perp(pi/2) = (-B1, 0)
        return Geometry(
            (0.0, th, math.pi), (0.0, 1.0, 0.0), _ZERO3,
            (o2 + self.off2, o2 + pc * _e(th), o4 - self.off4),
            (complex(L * s_), complex((L - pc) * s_, pc * c_), complex(0.0, L * c_)),
            (complex(L * c_), complex((L - pc) * c_, -pc * s_), complex(0.0, -L * s_)),
            (-o2.real, 0.0, 0.0), (-L * s_, 0.0, 0.0), (-L * c_, 0.0, 0.0), o4)

    def closure_force(self, th: float, w: float) -> tuple[np.ndarray, float, float]:
        """(Fx, 0) and Mz on the second block from the line x = 0.8.

        Fx from the system's horizontal momentum (the only other horizontal force,
        the first slide's, is normal to a horizontal axis: none); Mz from block 4's
        moment balance about its pin.  Residual: links 3 + 4 about the first pin.
        """
        _, gm, acc, alpha = self.accelerations(th, w)
        fx = sum(mk * a.real for mk, a in zip(self.m, acc))
        o4 = gm.closure_point
        mz = self.moment((2,), o4, gm, acc, alpha)
        o2 = complex(self.x_line - self.L * math.cos(th))
        resid = self.moment((1, 2), o2, gm, acc, alpha) - (_cross(o4 - o2, complex(fx)) + mz + self.torque)
        return np.array([fx, 0.0]), mz, resid


# the thesis tunings, as grubler's preset names; the crank-angle column compared
PROBLEMS = {
    "four-bar": ("thesis-fourbar", FourBar, 0.0, "theta2"),
    "four-bar, 3 N m": ("thesis-fourbar", FourBar, 3.0, "theta2"),
    "slider-crank": ("thesis-slider-crank", SliderCrank, 0.0, "theta2"),
    "slider-crank, 9 N m": ("thesis-slider-crank", SliderCrank, 9.0, "theta2"),
    "trammel": ("thesis-double-slider", Trammel, 0.0, "theta3"),
}


def check_parameters(ref: OneDof, mechanism) -> None:
    """Assert the preset carries the masses and inertias written out here."""
    got_m = tuple(l.m for l in mechanism.links)
    got_I = tuple(l.I for l in mechanism.links)
    if not (np.allclose(got_m, ref.m) and np.allclose(got_I, ref.I)):
        raise AssertionError(f"{ref.name}: preset masses {got_m}, inertias {got_I} differ from the reference's")
