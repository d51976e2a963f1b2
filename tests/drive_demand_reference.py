"""The drive demand as the library computed it before the kernel did: numpy, one sample at a time,
over the kernel's assembly, closure rows and inverse-dynamics residual.  It shares those equations
with the kernel's grb_drive_demand but none of its code (the change-point test by numpy's SVD, the
accelerations and the effort by numpy's lstsq, the secant predictor in Python), so it holds that
the C function is the computation it replaced."""

from __future__ import annotations

import numpy as np

from grubler.mechanism.assembly import SINGULAR_RCOND, assemble
from grubler.mechanism.dynamics import Inputs, inverse_dynamics
from grubler.mechanism.kinematics import chain_kinematics, closure_kinematics


def numpy_drive_demand(model, pos, vel, acc, loads, z_guess=None):
    """(torque, z, zd, zdd, closing_force) along the samples; ValueError at a change point."""
    n = len(pos)
    d = model.free_index(model.drive)
    dep = [i for i in range(model.n_free) if i != d]
    z = model.z_from_q(model.q_ref) if z_guess is None else np.array(z_guess, float)
    out_z, out_zd, out_zdd = (np.empty((n, model.n_free)) for _ in range(3))
    tau, force = np.empty(n), np.zeros((n, 2))
    for k in range(n):
        z = z.copy()
        if k >= 2 and pos[k - 1] != pos[k - 2]:
            z = out_z[k - 1] + (out_z[k - 1] - out_z[k - 2]) * ((pos[k] - pos[k - 1]) / (pos[k - 1] - pos[k - 2]))
        z[d] = pos[k]
        zd = np.zeros(model.n_free)
        zd[d] = vel[k]
        z, zd = assemble(model, z, zd)
        zdd = np.zeros(model.n_free)
        zdd[d] = acc[k]
        ck = closure_kinematics(model, chain_kinematics(model, z, zd))
        if model.n_constraints:
            sv = np.linalg.svd(ck.J[:, dep], compute_uv=False)
            if sv[-1] <= SINGULAR_RCOND * sv[0]:
                raise ValueError(f"change point at sample {k}")
            zdd[dep] = np.linalg.lstsq(ck.J[:, dep], ck.gamma - ck.J[:, d] * acc[k], rcond=None)[0]
        tau[k], lam = inverse_dynamics(model, z, zd, zdd, Inputs(0.0, float(loads[k])))
        if model.closures:
            force[k] = ck.force_dir[0] @ lam[:2]
        out_z[k], out_zd[k], out_zdd[k] = z, zd, zdd
    return tau, out_z, out_zd, out_zdd, force
