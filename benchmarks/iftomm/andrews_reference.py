"""An independent reference for Andrews' squeezing mechanism, sharing no code with grubler.

The mechanism is written here in the test set's own coordinates, the seven angles
q = (beta, Theta, gamma, Phi, delta, Omega, epsilon) of Hairer & Wanner (Solving
ODEs II, VII.7) and the Bari "Test Set for IVP Solvers" (problem "andrews"), with
their data.  Every point is a sum of terms L e(c . q + phi0) (e(x) = (cos x, sin x)),
so its velocity Jacobian and its quadratic (convective) acceleration are exact
sums too.  Lagrange's equations with the six closure equations, index-reduced
to the acceleration level,

    [M  G^T] [q'']   [f]
    [G   0 ] [ l ] = [-G' q'],

are integrated by scipy's DOP853 at a tight tolerance.  Used by a03.py as a second
reference beside the published one and to say how much the published digits can
be trusted; not used by grubler itself.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

# the test set's data (SI units)
M1, M2, M3, M4, M5, M6, M7 = .04325, .00365, .02373, .00706, .07050, .00706, .05498
XA, YA, XB, YB, XC, YC = -.06934, -.00227, -.03635, .03273, .014, .072
C0, L0, MOM = 4530.0, .07785, .033
I1, I2, I3, I4, I5, I6, I7 = 2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5
D, DA, E, EA, RR, RA = 28e-3, 115e-4, 2e-2, 1421e-5, 7e-3, 92e-5
SS, SA, SB, SC, SD = 35e-3, 1874e-5, 1043e-5, 18e-3, 2e-2
TA, TB, U, UA, UB, ZF, ZT, FA = 2308e-5, 916e-5, 4e-2, 1228e-5, 449e-5, 2e-2, 4e-2, 1421e-5

# the consistent start at rest (the test set's), and its published solution at t = 0.03 s
Q0 = np.array([-0.0617138900142764496358948458001, 0.0, 0.455279819163070380255912382449,
               0.222668390165885884674473185609, 0.487364979543842550225598953530,
               -0.222668390165885884674473185609, 1.23054744454982119249735015568])
NAMES = ("beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon")

H = math.pi / 2


def _c(*idx):
    """The coefficient vector of an angle sum: _c(0, 1) is beta + Theta."""
    c = np.zeros(7)
    c[list(idx)] = 1.0
    return c


# a point: (constant vector, [(L, c, phi0), ...]) = const + sum L e(c . q + phi0)
F_ = ((0.0, 0.0), [(RR, _c(0), 0.0)])
E_CRANK = ((0.0, 0.0), [(RR, _c(0), 0.0), (-D, _c(0, 1), 0.0)])   # E through O, F
E_TRI = ((XB, YB), [(SS, _c(2), -H)])                            # E through B
E_G = ((XA, YA), [(ZT, _c(4), 0.0), (E, _c(3, 4), -H)])           # E through A, G
E_H = ((XA, YA), [(U, _c(6), -H), (ZF, _c(5, 6), 0.0)])           # E through A, H
D_ = ((XB, YB), [(SD, _c(2), 0.0), (-SC, _c(2), H)])
# the bodies: (mass, centroidal inertia, mass centre, absolute angle's coefficients)
BODIES = (
    (M1, I1, ((0.0, 0.0), [(RA, _c(0), 0.0)]), _c(0)),
    (M2, I2, ((0.0, 0.0), [(RR, _c(0), 0.0), (-DA, _c(0, 1), 0.0)]), _c(0, 1)),
    (M3, I3, ((XB, YB), [(SA, _c(2), 0.0), (SB, _c(2), H)]), _c(2)),
    (M4, I4, ((XA, YA), [(ZT, _c(4), 0.0), (E - EA, _c(3, 4), -H)]), _c(3, 4)),
    (M5, I5, ((XA, YA), [(TA, _c(4), 0.0), (TB, _c(4), H)]), _c(4)),
    (M6, I6, ((XA, YA), [(U, _c(6), -H), (ZF - FA, _c(5, 6), 0.0)]), _c(5, 6)),
    (M7, I7, ((XA, YA), [(UA, _c(6), 0.0), (UB, _c(6), H)]), _c(6)),
)
# the closures: E reached three more ways must be E reached through the crank
CLOSURES = (E_TRI, E_G, E_H)


def point(p, q):
    const, terms = p
    x, y = const
    for L, c, phi0 in terms:
        a = c @ q + phi0
        x += L * math.cos(a)
        y += L * math.sin(a)
    return np.array([x, y])


def jacobian(p, q):
    J = np.zeros((2, 7))
    for L, c, phi0 in p[1]:
        a = c @ q + phi0
        J[0] -= L * math.sin(a) * c
        J[1] += L * math.cos(a) * c
    return J


def quadratic(p, q, qd):
    """The acceleration's part that does not hold q'': -sum L (c . q')^2 e(c . q + phi0)."""
    acc = np.zeros(2)
    for L, c, phi0 in p[1]:
        a, w = c @ q + phi0, c @ qd
        acc -= L * w * w * np.array([math.cos(a), math.sin(a)])
    return acc


def accelerations(q, qd):
    M = np.zeros((7, 7))
    f = np.zeros(7)
    for m, inertia, cm, c in BODIES:
        J = jacobian(cm, q)
        M += m * J.T @ J + inertia * np.outer(c, c)
        f -= m * J.T @ quadratic(cm, q, qd)
    f[0] += MOM
    dc = point(D_, q) - np.array([XC, YC])
    length = math.hypot(*dc)
    f += jacobian(D_, q).T @ (-C0 * (length - L0) * dc / length)
    G = np.vstack([jacobian(p, q) - jacobian(E_CRANK, q) for p in CLOSURES])
    gam = np.concatenate([quadratic(p, q, qd) - quadratic(E_CRANK, q, qd) for p in CLOSURES])
    K = np.block([[M, G.T], [G, np.zeros((6, 6))]])
    return np.linalg.solve(K, np.concatenate([f, -gam]))[:7]


def residual(q):
    """The closures' residual, m (0 on the mechanism)."""
    return np.concatenate([point(p, q) - point(E_CRANK, q) for p in CLOSURES])


def solve(t_end: float = 0.03, rtol: float = 1e-13, atol: float = 1e-13):
    """The seven angles and their rates at t_end, and the closures' residual there."""
    sol = solve_ivp(lambda t, y: np.concatenate([y[7:], accelerations(y[:7], y[7:])]), (0.0, t_end),
                    np.concatenate([Q0, np.zeros(7)]), method="DOP853", rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(sol.message)
    y = sol.y[:, -1]
    return y[:7], y[7:], residual(y[:7])


if __name__ == "__main__":
    q, qd, res = solve()
    for name, v in zip(NAMES, q):
        print(f"{name:8s} {v:+.16e}")
    print("closure residual", np.max(np.abs(res)))
