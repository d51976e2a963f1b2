"""Work-precision of the spatial kernel against pinocchio and MuJoCo: the RSSR and the spherical four-bar.

Each engine models the preset as its users would, from the preset's geometry and its
assembled start (the same closed pose, at rest, the same drive):

- grubler: ``grubler.mechanism.spatial`` (``rssr()``, ``spherical_fourbar()``), its
  exact closure with projection, DOP853 at rtol = atol = tol.
- pinocchio: the open tree (revolutes, the RSSR's ball a ``JointModelSpherical``
  whose quaternion is integrated as q' = q (0, w) / 2), the closure as Jacobian rows
  of frames (the RSSR: the coupler's end on the rocker's pin, 3 rows; the spherical
  four-bar: the coupler's closing axis square to two directions across the rocker's,
  2 rows, as a revolute loop closure is written by hand in pinocchio: issue 2729),
  ``pinocchio.forwardDynamics(model, data, q, v, tau, J, drift)`` with Baumgarte
  stabilisation (as benchmarks/wp_peers.py), scipy's DOP853 at rtol = atol = tol.
- MuJoCo: MJCF built at the start pose, an equality ``connect`` closing the loop
  (the RSSR: the ball at the coupler's end; the spherical four-bar: a point on the
  closing axis, which with every axis through the centre holds the axes together),
  fixed-step RK4, solref = 2 steps (its stiffest advice), as wp_peers.py.

Error: the largest |crank angle - reference| over the output grid (every 0.05 s),
rad; the reference is grubler at 1e-13, and pinocchio at 1e-12 is reported against
it (the two share no code).  Time: wall time of the run alone (``perf_counter``,
best of ``--rounds``), all in this one process; models built and outputs compared
outside the timing.  "At 1e-8 rad": the cheapest run of each engine whose error is
at most 1e-8 rad.

None of this is a grubler dependency: ``pip install pin mujoco``.

    python benchmarks/wp_spatial_peers.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time

import numpy as np
import scipy.integrate
from scipy.spatial.transform import Rotation

from grubler.mechanism import spatial as sp

DT_OUT = 0.05
TARGET = 1e-8
PROBLEMS = {"rssr": dict(build=sp.rssr, torque=0.5, t_end=1.5),
            "spherical-fourbar": dict(build=sp.spherical_fourbar, torque=0.1, t_end=1.0)}


def rx(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rz(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


class Problem:
    """A preset, its assembled start (at rest) and its drive on coordinate 0."""

    def __init__(self, name: str):
        spec = PROBLEMS[name]
        self.name = name
        self.m = spec["build"]()
        self.y0 = self.m.assembled_start()
        self.z0 = self.y0[:self.m.n_coords]
        self.torque = spec["torque"]
        self.t_end = spec["t_end"]
        self.grid = np.linspace(0.0, self.t_end, int(round(self.t_end / DT_OUT)) + 1)
        self.tau = np.zeros(self.m.n_coords)
        self.tau[0] = self.torque


# -- grubler -------------------------------------------------------------------------------------------------------
class Grubler:
    def __init__(self, p: Problem):
        self.p = p

    def run(self, tol: float) -> np.ndarray:
        p = self.p
        res = p.m.simulate(p.y0, t_end=p.t_end, dt_out=DT_OUT, tau=p.tau, rtol=tol, atol=tol)
        return res.z[:, 0]


# -- pinocchio -----------------------------------------------------------------------------------------------------
class Pinocchio:
    def __init__(self, p: Problem):
        import pinocchio as pin

        self.pin = pin
        self.p = p
        m, links = pin.Model(), p.m.links
        m.gravity.linear = np.array(p.m.gravity)

        def inertia(link):
            return pin.Inertia(link.mass, np.array(link.com, float), np.array(link.inertia, float))

        def frame(name, joint, point):
            placement = pin.SE3(np.eye(3), np.asarray(point, float))
            try:
                return m.addFrame(pin.Frame(name, joint, 0, placement, pin.FrameType.OP_FRAME))
            except TypeError:  # pinocchio 3+: no parent frame argument
                return m.addFrame(pin.Frame(name, joint, placement, pin.FrameType.OP_FRAME))

        if p.name == "rssr":
            g = sp.rssr_geometry()
            crank = m.addJoint(0, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([0, 0, g.height])), "crank")
            m.appendBodyToJoint(crank, inertia(links[0]), pin.SE3.Identity())
            ball = m.addJoint(crank, pin.JointModelSpherical(), pin.SE3(np.eye(3), np.array([g.crank, 0, 0])), "ball")
            m.appendBodyToJoint(ball, inertia(links[3]), pin.SE3.Identity())
            shaft = rx(g.twist) @ np.array([0, 0, 1.0])
            rocker = m.addJoint(0, pin.JointModelRZ(), pin.SE3(rx(g.twist), np.array([g.offset, 0, 0]) + g.rocker_d * shaft),
                                "rocker")
            m.appendBodyToJoint(rocker, inertia(links[4]), pin.SE3.Identity())
            self.a = frame("tip", ball, (0, 0, g.coupler))
            self.b = frame("pin", rocker, (g.rocker, 0, 0))
            # the start: the kernel's crank and rocker angles, the ball's turn the coupler's frame in the crank's
            _, R = p.m.frames(p.z0)
            quat = Rotation.from_matrix(R[0].T @ R[3]).as_quat()  # x, y, z, w: pinocchio's order too
            self.q0 = np.array([p.z0[0], *quat, p.z0[4]])
            self.quat = slice(1, 5)
        else:
            g = sp.spherical_fourbar_geometry()
            crank = m.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "crank")
            m.appendBodyToJoint(crank, inertia(links[0]), pin.SE3.Identity())
            coupler = m.addJoint(crank, pin.JointModelRZ(), pin.SE3(rx(g.crank), np.zeros(3)), "coupler")
            m.appendBodyToJoint(coupler, inertia(links[1]), pin.SE3.Identity())
            rocker = m.addJoint(0, pin.JointModelRZ(), pin.SE3(rx(g.ground), np.zeros(3)), "rocker")
            m.appendBodyToJoint(rocker, inertia(links[2]), pin.SE3.Identity())
            self.a, self.b = frame("coupler", coupler, (0, 0, 0)), frame("rocker", rocker, (0, 0, 0))
            self.u = np.array([0, -math.sin(g.coupler), math.cos(g.coupler)])  # the closing axis, coupler's axes
            v = np.array([0, -math.sin(g.rocker), math.cos(g.rocker)])  # the same axis in the rocker's
            self.n = (np.array([1.0, 0, 0]), np.cross(v, [1.0, 0, 0]))  # square to it, fixed in the rocker
            self.q0 = p.z0.copy()
            self.quat = None
        self.model, self.data = m, m.createData()
        self.tau = np.zeros(m.nv)
        self.tau[0] = p.torque
        self.kp, self.kd = 100.0, 20.0  # Baumgarte, as wp_peers.py

    def constraint(self, q, v):
        pin, m, d = self.pin, self.model, self.data
        pin.forwardKinematics(m, d, q, v, np.zeros(m.nv))
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        Ja, Jb = pin.getFrameJacobian(m, d, self.a, world), pin.getFrameJacobian(m, d, self.b, world)
        aa = pin.getFrameClassicalAcceleration(m, d, self.a, world)
        ab = pin.getFrameClassicalAcceleration(m, d, self.b, world)
        if self.quat is not None:  # the ball: the two points coincide
            phi = d.oMf[self.a].translation - d.oMf[self.b].translation
            return phi, Ja[:3] - Jb[:3], aa.linear - ab.linear
        # the revolute: u (coupler) square to n1, n2 (rocker); (u.n)' = (w_c - w_r) . (u x n)
        u = d.oMf[self.a].rotation @ self.u
        wc = pin.getFrameVelocity(m, d, self.a, world).angular
        wr = pin.getFrameVelocity(m, d, self.b, world).angular
        phi, J, drift = [], [], []
        for n_local in self.n:
            n = d.oMf[self.b].rotation @ n_local
            un = np.cross(u, n)
            ud, nd = np.cross(wc, u), np.cross(wr, n)
            phi.append(u @ n)
            J.append(un @ (Ja[3:] - Jb[3:]))
            drift.append((np.cross(aa.angular, u) + np.cross(wc, ud)) @ n + 2 * ud @ nd
                         + u @ (np.cross(ab.angular, n) + np.cross(wr, nd)))
        return np.array(phi), np.array(J), np.array(drift)

    def rhs(self, t, y):
        m = self.model
        q, v = y[:m.nq].copy(), y[m.nq:]
        if self.quat is not None:
            q[self.quat] /= np.linalg.norm(q[self.quat])
        phi, J, drift = self.constraint(q, v)
        a = self.pin.forwardDynamics(m, self.data, q, v, self.tau, J, drift + self.kd * (J @ v) + self.kp * phi)
        if self.quat is None:
            qd = v
        else:  # the ball's quaternion (x, y, z, w) from its angular velocity in its own axes (v[1:4])
            qd = np.empty(m.nq)
            qd[0], qd[5] = v[0], v[4]
            x, w = q[1:4], q[4]
            omega = v[1:4]
            qd[1:4] = 0.5 * (w * omega + np.cross(x, omega))
            qd[4] = -0.5 * x @ omega
        return np.concatenate([qd, a])

    def run(self, tol: float) -> np.ndarray:
        y0 = np.concatenate([self.q0, np.zeros(self.model.nv)])
        sol = scipy.integrate.solve_ivp(self.rhs, (0.0, self.p.t_end), y0, method="DOP853", rtol=tol, atol=tol,
                                        t_eval=self.p.grid)
        if not sol.success:
            raise RuntimeError(sol.message)
        return sol.y[0]


# -- MuJoCo --------------------------------------------------------------------------------------------------------
def num(*values) -> str:
    """Numbers as MJCF attributes (full precision)."""
    return " ".join(repr(float(v)) for v in values)


def _body(name, R, pos, link, joint, children=""):
    x, y, z, w = Rotation.from_matrix(R).as_quat()
    I = np.array(link.inertia, float)
    return (f'<body name="{name}" pos="{num(*pos)}" quat="{num(w, x, y, z)}">{joint}'
            f'<inertial pos="{num(*link.com)}" mass="{num(link.mass)}" '
            f'fullinertia="{num(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])}"/>{children}</body>')


class Mujoco:
    def __init__(self, p: Problem, dt: float):
        import mujoco

        self.mj, self.p, self.dt = mujoco, p, dt
        links, z0 = p.m.links, p.z0
        hinge = '<joint type="hinge" axis="0 0 1"/>'
        soft = f'solref="{2 * dt!r} 1" solimp="0.9999 0.9999 0.001 0.5 2"'
        head = (f'<mujoco><compiler angle="radian"/><option timestep="{dt!r}" integrator="RK4" '
                f'gravity="{num(*p.m.gravity)}"><flag contact="disable"/></option><worldbody>')
        _, R = p.m.frames(z0)
        if p.name == "rssr":
            g = sp.rssr_geometry()
            coupler = _body("coupler", R[0].T @ R[3], (g.crank, 0, 0), links[3], '<joint type="ball"/>')
            crank = _body("crank", rz(z0[0]), (0, 0, g.height), links[0], hinge, coupler)
            shaft = rx(g.twist) @ np.array([0, 0, 1.0])
            rocker = _body("rocker", rx(g.twist) @ rz(z0[4]), np.array([g.offset, 0, 0]) + g.rocker_d * shaft,
                           links[4], hinge)
            tail = (f'</worldbody><equality><connect body1="coupler" body2="rocker" anchor="0 0 {num(g.coupler)}" '
                    f'{soft}/></equality></mujoco>')
        else:
            g = sp.spherical_fourbar_geometry()
            coupler = _body("coupler", rx(g.crank) @ rz(z0[1]), (0, 0, 0), links[1], hinge)
            crank = _body("crank", rz(z0[0]), (0, 0, 0), links[0], hinge, coupler)
            rocker = _body("rocker", rx(g.ground) @ rz(z0[2]), (0, 0, 0), links[2], hinge)
            anchor = g.radius * np.array([0, -math.sin(g.coupler), math.cos(g.coupler)])  # on the closing axis
            tail = (f'</worldbody><equality><connect body1="coupler" body2="rocker" '
                    f'anchor="{num(*anchor)}" {soft}/></equality></mujoco>')
        self.model = mujoco.MjModel.from_xml_string(head + crank + rocker + tail)
        self.data = mujoco.MjData(self.model)
        self.start = z0[0]

    def run(self, tol=None) -> np.ndarray:
        mj, m, d = self.mj, self.model, self.data
        mj.mj_resetData(m, d)
        d.qfrc_applied[0] = self.p.torque
        every = int(round(DT_OUT / self.dt))
        out = np.empty(len(self.p.grid))
        out[0] = d.qpos[0]
        for i in range(1, len(out)):
            for _ in range(every):
                mj.mj_step(m, d)
            out[i] = d.qpos[0]
        return out + self.start


# -- measuring -----------------------------------------------------------------------------------------------------
def timed(run, setting, rounds: int):
    best, out = math.inf, None
    for _ in range(rounds):
        t0 = time.perf_counter()
        out = run(setting)
        best = min(best, time.perf_counter() - t0)
    return out, best


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="timed repetitions per setting (best counts)")
    args = ap.parse_args(argv)
    print(f"# {platform.processor() or platform.machine()}, load {os.getloadavg()[0]:.1f}; error: crank angle "
          f"against grubler at 1e-13 every {DT_OUT} s, rad; time: wall, best of {args.rounds}")
    summary = []
    for name in PROBLEMS:
        p = Problem(name)
        reference = Grubler(p).run(1e-13)
        rows = []
        engine = Grubler(p)
        for tol in (1e-6, 1e-8, 1e-10, 1e-12):
            crank, wall = timed(engine.run, tol, args.rounds)
            rows.append(("grubler", f"tol {tol:.0e}", np.abs(crank - reference).max(), wall))
        engine = Pinocchio(p)
        for tol in (1e-6, 1e-8, 1e-10, 1e-12):
            crank, wall = timed(engine.run, tol, max(1, args.rounds - 2))
            rows.append(("pinocchio", f"tol {tol:.0e}", np.abs(crank - reference).max(), wall))
        for dt in (1e-3, 2e-4, 5e-5, 1e-5):
            engine = Mujoco(p, dt)
            crank, wall = timed(engine.run, None, max(1, args.rounds - 2))
            rows.append(("MuJoCo", f"dt {dt:.0e} s", np.abs(crank - reference).max(), wall))
        print(f"\n## {name} ({p.t_end:g} s, {p.torque:g} N m on the crank from rest)\n")
        print("| engine | setting | crank error (rad) | wall time (s) |")
        print("|---|---|---|---|")
        for engine_name, setting, error, wall in rows:
            print(f"| {engine_name} | {setting} | {error:.1e} | {wall:.4f} |")
        at = {}
        for engine_name in ("grubler", "pinocchio", "MuJoCo"):
            ok = [wall for e, _, error, wall in rows if e == engine_name and error <= TARGET]
            at[engine_name] = min(ok) if ok else None
        summary.append((name, at))
    print(f"\n## at {TARGET:g} rad (the cheapest run within it)\n")
    print("| problem | grubler (s) | pinocchio (s) | MuJoCo (s) | grubler / fastest peer |")
    print("|---|---|---|---|---|")
    for name, at in summary:
        peers = [t for k, t in at.items() if k != "grubler" and t is not None]
        ratio = f"{at['grubler'] / min(peers):.3f}" if peers and at["grubler"] else "-"
        cells = [f"{at[k]:.4f}" if at[k] is not None else "not reached" for k in ("grubler", "pinocchio", "MuJoCo")]
        print(f"| {name} | {' | '.join(cells)} | {ratio} |")


if __name__ == "__main__":
    main()
