"""Peer engines on the work-precision problems, each modelled as its users would.

- pinocchio: a serial chain (revolute/prismatic joints), the closure as Jacobian
  rows of a frame, ``pinocchio.forwardDynamics(model, data, q, v, tau, J, drift)``
  (its KKT constraint dynamics) with Baumgarte stabilisation, integrated by
  scipy's DOP853.  The multipliers are the closing joint's force.
- pydy: sympy's Kane's method in a few absolute coordinates, the loop as
  configuration constraints (dependent coordinates and speeds), pydy's Cython
  code generation, integrated by scipy's DOP853.  No constraint force.
- MuJoCo: MJCF with an equality ``connect`` closing the loop, fixed-step RK4;
  the connect is soft (solref, solimp), tuned stiff for accuracy.  Its constraint
  force is read (efc_force) where the connect is the closing joint (four-bar).

None of this is a grubler dependency: ``pip install pin mujoco pydy cython``.

Every runner returns the states on the output grid; the crank angle, the closure
violation and, where available, the closing force are computed afterwards and
are not timed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.integrate

G = 9.81


@dataclass
class PeerRun:
    """What a timed run returns: its outputs at the grid times (post-processed later)."""

    crank: np.ndarray
    closure: np.ndarray
    force: np.ndarray | None  # (n, 2), ground on the closing link, or None


# -- pinocchio ---------------------------------------------------------------

class PinocchioModel:
    """A planar chain in pinocchio, closed by Jacobian rows of its last frame."""

    def __init__(self, problem: str, torque: float):
        import pinocchio as pin

        self.pin = pin
        self.torque = torque
        m = pin.Model()
        m.gravity.linear = np.array([0.0, -G, 0.0])

        def inertia(mass, lever, izz):
            return pin.Inertia(mass, np.array([lever[0], lever[1], 0.0]), np.diag([izz, izz, izz]))

        SE3 = pin.SE3
        if problem == "four-bar":
            # joint angles are relative; q0 = (0, pi/3, -2pi/3) is the thesis start
            j = m.addJoint(0, pin.JointModelRZ(), SE3.Identity(), "crank")
            m.appendBodyToJoint(j, inertia(1.0, (0.1, 0), 0.1), SE3.Identity())
            j = m.addJoint(j, pin.JointModelRZ(), SE3(np.eye(3), np.array([0.2, 0, 0])), "coupler")
            m.appendBodyToJoint(j, inertia(2.0, (0.4, 0), 0.2), SE3.Identity())
            j = m.addJoint(j, pin.JointModelRZ(), SE3(np.eye(3), np.array([0.8, 0, 0])), "rocker")
            m.appendBodyToJoint(j, inertia(3.0, (0.4, 0), 0.3), SE3.Identity())
            self.fid = m.addFrame(pin.Frame("tip", j, 0, SE3(np.eye(3), np.array([0.8, 0, 0])), pin.FrameType.OP_FRAME))
            self.q0 = np.array([0.0, math.pi / 3, -2 * math.pi / 3])
            self.rows = ("x", "y")
            self.target = np.array([1.0, 0.0])
            self.crank_of = lambda q: q[0]
            self.crank_dof = 0
        elif problem == "slider-crank":
            # the block is a point mass at the rod's end with I = 0: it rides on the rod
            # (its held orientation carries no inertia); the line y = 0.2 is one row
            j = m.addJoint(0, pin.JointModelRZ(), SE3.Identity(), "crank")
            m.appendBodyToJoint(j, inertia(1.0, (0.25, 0), 0.0), SE3.Identity())
            j = m.addJoint(j, pin.JointModelRZ(), SE3(np.eye(3), np.array([0.25, 0, 0])), "rod")
            m.appendBodyToJoint(j, inertia(2.0 + 3.0, (1.0, 0), 0.0), SE3.Identity())
            self.fid = m.addFrame(pin.Frame("tip", j, 0, SE3(np.eye(3), np.array([1.0, 0, 0])), pin.FrameType.OP_FRAME))
            self.q0 = np.array([0.0, math.asin(0.2)])
            self.rows = ("y",)
            self.target = np.array([0.2])
            self.crank_of = lambda q: q[0]
            self.crank_dof = 0
        elif problem == "trammel":
            # slide along x, the coupler's revolute, the second block's revolute; the
            # closure holds its pin on x = 0.8 and its angle at pi
            j = m.addJoint(0, pin.JointModelPX(), SE3.Identity(), "slide")
            m.appendBodyToJoint(j, inertia(9.0, (0.01, 0), 0.0), SE3.Identity())
            j = m.addJoint(j, pin.JointModelRZ(), SE3.Identity(), "coupler")
            m.appendBodyToJoint(j, inertia(1.0, (0.4, 0), 0.0), SE3.Identity())
            j = m.addJoint(j, pin.JointModelRZ(), SE3(np.eye(3), np.array([0.8, 0, 0])), "block")
            m.appendBodyToJoint(j, inertia(1.0, (0.01, 0), 0.0), SE3.Identity())
            self.fid = m.addFrame(pin.Frame("tip", j, 0, SE3.Identity(), pin.FrameType.OP_FRAME))
            self.q0 = np.array([0.0, 0.0, math.pi])
            self.rows = ("x", "angle")
            self.target = np.array([0.8, math.pi])
            self.crank_of = lambda q: q[1]
            self.crank_dof = 1
        else:
            raise ValueError(problem)
        self.model = m
        self.data = m.createData()
        self.nq = m.nq
        self.kp, self.kd = 100.0, 20.0  # Baumgarte: critically damped at 10 rad/s
        self.set_torque(torque)

    def constraint(self, q, v):
        """Violation, Jacobian rows and drift (J'v) of the closure."""
        pin, m, d = self.pin, self.model, self.data
        pin.forwardKinematics(m, d, q, v, np.zeros(self.nq))
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        Jf = pin.getFrameJacobian(m, d, self.fid, frame)
        acc = pin.getFrameClassicalAcceleration(m, d, self.fid, frame)
        pos = d.oMf[self.fid].translation
        angle = math.atan2(d.oMf[self.fid].rotation[1, 0], d.oMf[self.fid].rotation[0, 0])
        phi, J, drift = [], [], []
        for r in self.rows:
            if r == "angle":
                phi.append(math.remainder(angle - self.target[len(phi)], 2 * math.pi))
                J.append(Jf[5])
                drift.append(acc.angular[2])
            else:
                i = "xy".index(r)
                phi.append(pos[i] - self.target[len(phi)])
                J.append(Jf[i])
                drift.append(acc.linear[i])
        return np.array(phi), np.array(J), np.array(drift)

    def accel(self, q, v):
        phi, J, drift = self.constraint(q, v)
        # J a = -drift - kd J v - kp phi
        gamma = drift + self.kd * (J @ v) + self.kp * phi
        a = self.pin.forwardDynamics(self.model, self.data, q, v, self.tau, J, gamma)
        return a, phi, J

    def set_torque(self, torque: float) -> None:
        self.tau = np.zeros(self.model.nv)
        self.tau[self.crank_dof] = torque

    def rhs(self, t, y):
        q, v = y[: self.nq], y[self.nq :]
        a, _, _ = self.accel(q, v)
        return np.concatenate([v, a])

    def run(self, tg: np.ndarray, rtol: float) -> np.ndarray:
        sol = scipy.integrate.solve_ivp(self.rhs, (0.0, tg[-1]), np.concatenate([self.q0, np.zeros(self.nq)]),
                                        method="DOP853", rtol=rtol, atol=rtol, t_eval=tg)
        if not sol.success:
            raise RuntimeError(sol.message)
        return sol.y.T

    def outputs(self, states: np.ndarray) -> PeerRun:
        crank, closure, force = [], [], []
        for y in states:
            q, v = y[: self.nq], y[self.nq :]
            a, phi, J = self.accel(q, v)
            lam = np.array(self.data.lambda_c)
            crank.append(self.crank_of(q))
            closure.append(float(np.linalg.norm(phi)))
            # rows are world x / y (force) or z (moment); force on the tip link from the ground
            f = np.zeros(2)
            for r, l in zip(self.rows, lam):
                if r != "angle":
                    f["xy".index(r)] = l
            force.append(f)
        return PeerRun(np.array(crank), np.array(closure), np.array(force))


# -- pydy ------------------------------------------------------------------

class PydyModel:
    """Kane's method with configuration constraints; pydy's Cython RHS."""

    def __init__(self, problem: str, torque: float):
        import sympy as sm
        import sympy.physics.mechanics as me
        from pydy.codegen.ode_function_generators import generate_ode_function

        t = me.dynamicsymbols._t
        N = me.ReferenceFrame("N")
        O = me.Point("O")
        O.set_vel(N, 0)
        tau = sm.Symbol("tau")
        g = sm.Symbol("g")
        bodies, loads = [], []
        if problem == "four-bar":
            q = me.dynamicsymbols("q2 q3 q4")  # absolute angles
            u = me.dynamicsymbols("u2 u3 u4")
            frames = [N.orientnew(f"A{k}", "Axis", [qk, N.z]) for k, qk in zip((2, 3, 4), q)]
            for f, uk in zip(frames, u):
                f.set_ang_vel(N, uk * N.z)
            a, p, mass, inert = (0.2, 0.8, 0.8), (0.1, 0.4, 0.4), (1.0, 2.0, 3.0), (0.1, 0.2, 0.3)
            joint = O
            for k in range(3):
                cm = joint.locatenew(f"C{k}", p[k] * frames[k].x)
                cm.v2pt_theory(joint, N, frames[k])
                nxt = joint.locatenew(f"J{k}", a[k] * frames[k].x)
                nxt.v2pt_theory(joint, N, frames[k])
                bodies.append(me.RigidBody(f"L{k}", cm, frames[k], mass[k], (me.inertia(frames[k], 0, 0, inert[k]), cm)))
                loads.append((cm, -mass[k] * g * N.y))
                joint = nxt
            tip = joint.pos_from(O)
            cons = [tip.dot(N.x) - 1.0, tip.dot(N.y)]
            q_ind, q_dep, u_ind, u_dep = [q[0]], q[1:], [u[0]], u[1:]
            loads.append((frames[0], tau * N.z))
            self.x0 = [0.0, math.pi / 3, -math.pi / 3]
            self.closure_of = lambda x: math.hypot(0.2 * math.cos(x[0]) + 0.8 * math.cos(x[1]) + 0.8 * math.cos(x[2]) - 1.0,
                                                   0.2 * math.sin(x[0]) + 0.8 * math.sin(x[1]) + 0.8 * math.sin(x[2]))
            crank = 0
        elif problem == "slider-crank":
            q = me.dynamicsymbols("q2 q3")
            u = me.dynamicsymbols("u2 u3")
            frames = [N.orientnew(f"A{k}", "Axis", [qk, N.z]) for k, qk in zip((2, 3), q)]
            for f, uk in zip(frames, u):
                f.set_ang_vel(N, uk * N.z)
            A = O.locatenew("A", 0.25 * frames[0].x)
            A.v2pt_theory(O, N, frames[0])
            B = A.locatenew("B", 1.0 * frames[1].x)
            B.v2pt_theory(A, N, frames[1])
            bodies += [me.Particle("crank", A, 1.0), me.Particle("rod", B, 2.0), me.Particle("block", B, 3.0)]
            loads += [(A, -1.0 * g * N.y), (B, -5.0 * g * N.y), (frames[0], tau * N.z)]
            cons = [B.pos_from(O).dot(N.y) - 0.2]
            q_ind, q_dep, u_ind, u_dep = [q[0]], [q[1]], [u[0]], [u[1]]
            self.x0 = [0.0, math.asin(0.2)]
            self.closure_of = lambda x: abs(0.25 * math.sin(x[0]) + math.sin(x[1]) - 0.2)
            crank = 0
        elif problem == "trammel":
            q = me.dynamicsymbols("q3 s")  # coupler angle, first slider's x
            u = me.dynamicsymbols("u3 v")
            C = N.orientnew("C", "Axis", [q[0], N.z])
            C.set_ang_vel(N, u[0] * N.z)
            O2 = O.locatenew("O2", q[1] * N.x)
            O2.set_vel(N, u[1] * N.x)
            P2 = O2.locatenew("P2", 0.01 * N.x)
            P2.set_vel(N, u[1] * N.x)
            P3 = O2.locatenew("P3", 0.4 * C.x)
            P3.v2pt_theory(O2, N, C)
            O4 = O2.locatenew("O4", 0.8 * C.x)
            O4.v2pt_theory(O2, N, C)
            P4 = O4.locatenew("P4", -0.01 * N.x)
            P4.v2pt_theory(O4, N, N)
            bodies += [me.Particle("b2", P2, 9.0), me.Particle("b3", P3, 1.0), me.Particle("b4", P4, 1.0)]
            loads += [(P2, -9.0 * g * N.y), (P3, -1.0 * g * N.y), (P4, -1.0 * g * N.y), (C, tau * N.z)]
            cons = [O4.pos_from(O).dot(N.x) - 0.8]
            q_ind, q_dep, u_ind, u_dep = [q[0]], [q[1]], [u[0]], [u[1]]
            self.x0 = [0.0, 0.0]
            self.closure_of = lambda x: abs(x[1] + 0.8 * math.cos(x[0]) - 0.8)
            crank = 0
        else:
            raise ValueError(problem)
        cons_m = sm.Matrix(cons)
        qdot = [qk.diff(t) for qk in q]
        vel = cons_m.diff(t).subs(dict(zip(qdot, u)))
        kane = me.KanesMethod(N, q_ind=q_ind, u_ind=u_ind, kd_eqs=[qd - uk for qd, uk in zip(qdot, u)],
                              q_dependent=list(q_dep), u_dependent=list(u_dep),
                              configuration_constraints=list(cons_m), velocity_constraints=list(vel))
        kane.kanes_equations(bodies, loads)
        order_q = q_ind + list(q_dep)
        order_u = u_ind + list(u_dep)
        # pydy orders the states as kane's q and u
        self.q_order = [q.index(x) for x in order_q]
        self.nq = len(q)
        self.rhs_fn = generate_ode_function(kane.forcing_full, order_q, order_u, [g, tau],
                                            mass_matrix=kane.mass_matrix_full, generator="cython")
        self.p = np.array([G, torque])  # set_torque changes it: one code generation per mechanism
        x0 = [self.x0[i] for i in self.q_order]
        self.y0 = np.array(x0 + [0.0] * self.nq)
        self.crank_index = order_q.index(q[crank])
        self._closure = self.closure_of
        # closure_of reads the coordinates in the problem's own order
        self._inverse = [order_q.index(x) for x in q]

    def set_torque(self, torque: float) -> None:
        self.p[1] = torque

    def rhs(self, t, y):
        return self.rhs_fn(y, t, self.p)

    def run(self, tg: np.ndarray, rtol: float) -> np.ndarray:
        sol = scipy.integrate.solve_ivp(self.rhs, (0.0, tg[-1]), self.y0, method="DOP853", rtol=rtol, atol=rtol,
                                        t_eval=tg)
        if not sol.success:
            raise RuntimeError(sol.message)
        return sol.y.T

    def outputs(self, states: np.ndarray) -> PeerRun:
        crank = states[:, self.crank_index]
        closure = np.array([self._closure([y[i] for i in self._inverse]) for y in states])
        return PeerRun(crank, closure, None)


# -- MuJoCo ------------------------------------------------------------------

def _mjcf(problem: str, dt: float, solref: float, integrator: str) -> tuple[str, int]:
    tiny = "1e-12"  # MuJoCo refuses a moving body without inertia; far below every other term
    head = (f'<mujoco><compiler angle="radian"/>'
            f'<option timestep="{dt!r}" integrator="{integrator}" gravity="0 0 -9.81">'
            f'<flag contact="disable"/></option><worldbody>')
    # the plane is MuJoCo's x-z; a hinge about -y turns +x towards +z (counter-clockwise)
    ax = 'axis="0 -1 0"'
    soft = f'solref="{solref!r} 1" solimp="0.9999 0.9999 0.001 0.5 2"'
    if problem == "four-bar":
        body = (f'<body name="crank"><joint type="hinge" {ax}/>'
                f'<inertial pos="0.1 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>'
                f'<body name="coupler" pos="0.2 0 0" axisangle="0 -1 0 {math.pi / 3!r}"><joint type="hinge" {ax}/>'
                f'<inertial pos="0.4 0 0" mass="2" diaginertia="0.2 0.2 0.2"/>'
                f'<body name="rocker" pos="0.8 0 0" axisangle="0 -1 0 {-2 * math.pi / 3!r}"><joint type="hinge" {ax}/>'
                f'<inertial pos="0.4 0 0" mass="3" diaginertia="0.3 0.3 0.3"/>'
                f'</body></body></body></worldbody>'
                f'<equality><connect body1="rocker" anchor="0.8 0 0" {soft}/></equality></mujoco>')
        return head + body, 0
    if problem == "slider-crank":
        t3 = math.asin(0.2)
        xb = 0.25 + math.cos(t3)
        body = (f'<body name="crank"><joint type="hinge" {ax}/>'
                f'<inertial pos="0.25 0 0" mass="1" diaginertia="{tiny} {tiny} {tiny}"/>'
                f'<body name="rod" pos="0.25 0 0" axisangle="0 -1 0 {t3!r}"><joint type="hinge" {ax}/>'
                f'<inertial pos="1 0 0" mass="2" diaginertia="{tiny} {tiny} {tiny}"/></body></body>'
                f'<body name="block" pos="{xb!r} 0 0.2"><joint type="slide" axis="1 0 0"/>'
                f'<inertial pos="0 0 0" mass="3" diaginertia="{tiny} {tiny} {tiny}"/></body></worldbody>'
                f'<equality><connect body1="rod" body2="block" anchor="1 0 0" {soft}/></equality></mujoco>')
        return head + body, 0
    if problem == "trammel":
        body = (f'<body name="slider"><joint type="slide" axis="1 0 0"/>'
                f'<inertial pos="0.01 0 0" mass="9" diaginertia="{tiny} {tiny} {tiny}"/>'
                f'<body name="coupler"><joint type="hinge" {ax}/>'
                f'<inertial pos="0.4 0 0" mass="1" diaginertia="{tiny} {tiny} {tiny}"/></body></body>'
                f'<body name="block" pos="0.8 0 0"><joint type="slide" axis="0 0 1"/>'
                f'<inertial pos="-0.01 0 0" mass="1" diaginertia="{tiny} {tiny} {tiny}"/></body></worldbody>'
                f'<equality><connect body1="coupler" body2="block" anchor="0.8 0 0" {soft}/></equality></mujoco>')
        return head + body, 1
    raise ValueError(problem)


class MujocoModel:
    """MJCF with a connect equality; fixed-step RK4, solref = 2 steps (MuJoCo's stiffest advice)."""

    def __init__(self, problem: str, torque: float, dt: float, integrator: str = "RK4"):
        import mujoco

        self.mj = mujoco
        xml, self.crank_index = _mjcf(problem, dt, 2 * dt, integrator)
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        self.problem = problem
        self.torque = torque
        self.dt = dt
        # torque on the crank hinge (the trammel's coupler hinge), as an applied joint force
        self.dof = self.crank_index

    def run(self, tg: np.ndarray, rtol=None, deadline: float = math.inf) -> np.ndarray:
        import time

        mj, m, d = self.mj, self.model, self.data
        mj.mj_resetData(m, d)
        d.qfrc_applied[self.dof] = self.torque
        every = int(round((tg[1] - tg[0]) / self.dt))
        out = np.empty((len(tg), m.nq + m.nv))
        out[0] = np.concatenate([d.qpos, d.qvel])
        for i in range(1, len(tg)):
            for _ in range(every):
                mj.mj_step(m, d)
            out[i, : m.nq] = d.qpos
            out[i, m.nq :] = d.qvel
            if time.perf_counter() > deadline:
                raise TimeoutError(f"over budget at t = {tg[i]:g} s")
        return out

    def outputs(self, states: np.ndarray) -> PeerRun:
        mj, m, d = self.mj, self.model, self.data
        crank, closure, force = [], [], []
        for y in states:
            d.qpos[:] = y[: m.nq]
            d.qvel[:] = y[m.nq :]
            d.qfrc_applied[self.dof] = self.torque
            mj.mj_forward(m, d)
            crank.append(d.qpos[self.crank_index])
            # connect residual: efc_pos of its three rows
            rows = d.efc_type == mj.mjtConstraint.mjCNSTR_EQUALITY
            closure.append(float(np.linalg.norm(d.efc_pos[rows])))
            f = d.efc_force[rows]  # on body1 at the anchor, world x, y, z
            force.append([f[0], f[2]])
        has_force = self.problem == "four-bar"  # only there is the connect the thesis's closing joint
        return PeerRun(np.array(crank), np.array(closure), np.array(force) if has_force else None)


PEERS: dict[str, Callable] = {
    "pinocchio": PinocchioModel,
    "pydy": PydyModel,
}
