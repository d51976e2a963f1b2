"""What a drive must deliver to move a one-degree-of-freedom mechanism along a given
motion of its drive joint: the inverse dynamics over a trajectory.

At each sample the loop is closed with the drive coordinate held at the
trajectory's position (starting from the previous solution, so the assembly
branch is the one the scene sketches), the dependent rates follow from the
closures' velocity equation, the dependent accelerations from ``J zdd = gamma``
with the drive's acceleration given, and the inverse dynamics give the drive
effort (gravity, joint damping, the drive inertia, the load and the closure
forces all included).  It is the kernel's ``grb_drive_demand`` (kernel/demand.c):
computed-torque feedforward and motor sizing are both this one computation.

Examples
--------
>>> import numpy as np
>>> from grubler import load_scene
>>> m = load_scene("thesis-fourbar").mechanism
>>> t = np.linspace(0.0, 1.0, 5)
>>> d = drive_demand(m, 2 * np.pi * t, np.full(5, 2 * np.pi), np.zeros(5))
>>> d.torque.shape, bool(np.all(np.isfinite(d.torque)))
((5,), True)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grubler import binding
from grubler.errors import AssemblyError, SceneError
from grubler.mechanism.assembly import _scale, assemble
from grubler.mechanism.model import Mechanism


@dataclass
class DriveDemand:
    """The drive joint's motion and the effort it needs, sample by sample.

    Attributes
    ----------
    position, velocity, acceleration : ndarray
        The drive joint's (rad, rad/s, rad/s2; m, m/s, m/s2 on a slide).
    torque : ndarray
        Effort at the drive joint (N m, or N on a slide).
    z, zd, zdd : ndarray, shape (n_samples, n_free)
        Every real joint's coordinates, rates and accelerations.
    closing_force : ndarray, shape (n_samples, 2)
        Force (N) of the first closure on the closing link, world frame.

    Examples
    --------
    >>> import grubler
    >>> from grubler.mechanism.inverse import drive_demand
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> d = drive_demand(m, [0.0, 0.5], [0.0, 0.0], [0.0, 0.0])   # the crank held still at 0 and 0.5 rad
    >>> d.torque.round(3), d.z.shape                               # holding torque, N m; 3 real joints
    (array([5.395, 3.5  ]), (2, 3))
    >>> d.closing_force.round(3)                                   # the ground pin's force on link 4, N
    array([[-7.08 , 26.978],
           [-7.072, 30.15 ]])
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    torque: np.ndarray
    z: np.ndarray
    zd: np.ndarray
    zdd: np.ndarray
    closing_force: np.ndarray

    @property
    def power(self) -> np.ndarray:
        """Mechanical power the drive delivers (W); negative while it brakes."""
        return self.torque * self.velocity


def drive_demand(model: Mechanism, position, velocity, acceleration, load=0.0,
                 z_guess: np.ndarray | None = None) -> DriveDemand:
    """Inverse dynamics of a one-DOF mechanism along a drive-joint trajectory.

    Parameters
    ----------
    model : Mechanism
        With a drive joint and mobility one.
    position, velocity, acceleration : array_like
        The drive joint's motion at the samples (consistent with each other).
    load : float or array_like
        Effort on the model's load joint at each sample (N m or N).
    z_guess : ndarray, optional
        Joint coordinates near the first sample's assembly (default: the
        model's sketched start).

    Returns
    -------
    DriveDemand

    Raises
    ------
    SceneError
        No drive joint, mobility other than one, or inconsistent sample counts.
    AssemblyError
        Where the loop cannot close at a sample's drive position.

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.mechanism.inverse import drive_demand
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> t = np.linspace(0.0, 1.0, 5)                     # one turn a second
    >>> d = drive_demand(m, 2 * np.pi * t, np.full(5, 2 * np.pi), np.zeros(5))
    >>> d.torque.round(3)
    array([ 2.653,  0.129, -6.991,  3.259,  2.653])
    """
    if model.drive is None:
        raise SceneError("drive.joint", "a drive demand needs the joint the drive acts on")
    if model.mobility != 1:
        raise SceneError("mechanism", f"a drive trajectory fixes one degree of freedom; this mechanism has "
                                      f"{model.mobility}")
    pos, vel, acc = (np.atleast_1d(np.asarray(x, float)) for x in (position, velocity, acceleration))
    n = len(pos)
    if not (len(vel) == len(acc) == n):
        raise SceneError("trajectory", f"position, velocity and acceleration need one value per sample "
                                       f"({n}, {len(vel)}, {len(acc)})")
    loads = np.broadcast_to(np.asarray(load, float), (n,))
    for name, arr in (("position", pos), ("velocity", vel), ("acceleration", acc), ("load", loads)):
        if not np.all(np.isfinite(arr)):
            raise SceneError(f"trajectory.{name}", "must be finite at every sample")
    if model.load is None and np.any(loads != 0.0):
        raise SceneError("load.joint", "a load needs the joint it acts on")
    z0 = model.z_from_q(model.q_ref) if z_guess is None else np.asarray(z_guess, float)
    run = binding.drive_demand(model.arrays, _scale(model), pos, vel, acc, loads, z0)
    if run.status != binding.OK:
        k = run.at
        field = f"trajectory at sample {k} (drive {pos[k]:.6g})" if k >= 0 else "mechanism"
        if run.status == binding.NOT_CLOSED:
            # z's row holds the guess the kernel started from: assembly from it says what was held and
            # which loop stays open, in the words every assembly failure uses
            zd0 = np.zeros(model.n_free)
            zd0[model.free_index(model.drive)] = vel[k]
            assemble(model, run.z[k], zd0, field=field)
            raise AssemblyError(field, f"the loop cannot be closed (closest {run.closest:.3g} from its closure)")
        if run.status == binding.SINGULAR:
            # the other joints' rates are not determined by the drive's: a least-squares answer
            # there would be one of many, and the torque from it an artefact
            raise SceneError(field, "the drive passes a change point or dead centre here (the closure Jacobian's "
                                    "dependent columns are singular: two assembly branches meet), where the other "
                                    "joints' speeds, and so the drive torque, do not follow from the drive's motion; "
                                    "give a motion that stays clear of it")
        raise SceneError(field, binding.status_message(run.status))
    if not np.all(np.isfinite(run.torque)):
        # a force element without a finite force there: a gas spring whose column the motion used up
        from grubler.mechanism.simulate import used_up_gas

        k = int(np.argmin(np.isfinite(run.torque)))
        where = f"sample {k} (drive {pos[k]:.6g})"
        used = used_up_gas(model, run.z[k])
        if used is not None:
            j, h, length = used
            raise SceneError(f"{model.force_field(j)}.gas_column",
                             f"the gas is used up at trajectory {where}: its column gas_column + length - "
                             f"free_length is {h:.4g} m at the length {length:.4g} m; a gas spring needs a "
                             "positive column")
        raise SceneError(f"trajectory at {where}", "the drive torque is not finite there")
    return DriveDemand(pos, vel, acc, run.torque, run.z, run.zd, run.zdd, run.closing_force)


__all__ = ["DriveDemand", "drive_demand"]
