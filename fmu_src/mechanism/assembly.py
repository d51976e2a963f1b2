"""Consistent initial assembly and the projection that keeps the loop closed.

Assembly holds the driving coordinate (and, for mobility above one, the
best-conditioned further coordinates) at the user's value and solves the
closure equations for the rest by damped Newton, starting from the user's
guess, so the branch the user sketched is the branch that is found.  The same
Gauss-Newton correction, started from an integrator step that is already closed
to the local error, is the exact method's drift control.  Both are the compiled
kernel's (``kernel/closure.c``); this module names what failed.

Examples
--------
>>> from grubler import load_scene
>>> m = load_scene("thesis-fourbar").mechanism
>>> z, zd = assemble(m, m.z_from_q(m.q_ref))
>>> bool(abs(constraint(m, z)[0]).max() < 1e-12)
True
"""

from __future__ import annotations

import ctypes

import numpy as np

from grubler import binding
from grubler.mechanism.analysis import explain_unclosable
from grubler.errors import AssemblyError
from grubler.mechanism.model import Mechanism

POSITION_TOL = 1e-12  # m (or rad): loop closure reached by assembly and projection (kernel/closure.c)


# The conditioning (smallest over largest singular value) of the closure Jacobian's
# dependent columns below which a configuration is a toggle or change point:
# linearisation and inverse dynamics refuse it.
# A toggle is a double root of the closure, so the closure's tolerance (1e-13 of the
# size) leaves the dependent angles up to sqrt(1e-13) from it: a conditioning of up
# to about 1e-6 at the toggle itself, and what a search from there concludes hangs
# on the BLAS kernel. 1e-4 sits far above that and refuses only within (1e-4 / c)^2
# rad of a toggle, the conditioning growing as c sqrt(distance) (c = 0.21 on the
# triple-rocker preset: 2e-7 rad), where the dependent coordinates' derivatives are
# some 1e4 times the independent one's.
SINGULAR_RCOND = 1e-4


def _scale(model: Mechanism) -> float:
    return max(1.0, max((abs(l.a) for l in model.links), default=1.0))


def constraint(model: Mechanism, z: np.ndarray, zd: np.ndarray | None = None):
    """Closure violation and its Jacobian at ``z``."""
    m, n = model.n_constraints, model.n_links
    z = np.ascontiguousarray(z, dtype=float)
    phi, J, work = np.empty(m), np.empty((m, n)), binding.work(n, len(model.closures))
    binding.library().grb_constraint(model.arrays.c, binding.address(z), binding.address(phi), binding.address(J),
                                     binding.address(work))
    return phi, J


def freedom(model: Mechanism, z: np.ndarray) -> int:
    """Degrees of freedom the closures leave at ``z``: the number of coordinates
    less the rank of the closure Jacobian.

    It is the Grübler/Kutzbach mobility unless closure rows are redundant, as
    with a third crank on a parallelogram's coupling rod (count 0, freedom 1).
    """
    z = np.ascontiguousarray(z, dtype=float)
    out = ctypes.c_int(0)
    work = binding.work(model.n_links, len(model.closures))  # (held: the kernel writes into it)
    binding.library().grb_freedom(model.arrays.c, binding.address(z), binding.address(work), ctypes.byref(out))
    return int(out.value)


def held_coordinates(model: Mechanism, z: np.ndarray) -> list[int]:
    """Indices in z that assembly keeps at their given values, the drive first:
    as many as the closures leave free (:func:`freedom`), at least the drive
    (the kernel's ``grb_hold_count``, which the FMU asks too)."""
    n = model.n_links
    z = np.ascontiguousarray(z, dtype=float)
    held = np.zeros(max(n, 1), dtype=np.int32)
    count = ctypes.c_int(0)
    work = binding.work(n, len(model.closures))
    n_hold = ctypes.c_int(0)
    binding.library().grb_hold_count(model.arrays.c, binding.address(z), binding.address(work), ctypes.byref(n_hold))
    binding.library().grb_held_coordinates(model.arrays.c, n_hold.value, binding.address(z),
                                           binding.address(held), ctypes.byref(count),
                                           binding.address(work))
    return [int(i) for i in held[:count.value]]


def assemble(model: Mechanism, z0: np.ndarray, zd0: np.ndarray | None = None,
             field: str = "initial") -> tuple[np.ndarray, np.ndarray]:
    """Close the loop from an initial guess, holding the driving coordinate.

    Parameters
    ----------
    model : Mechanism
    z0 : ndarray
        Initial real joint coordinates (guess for the dependent ones).
    zd0 : ndarray, optional
        Initial joint rates; the held ones are kept, the rest made consistent.

    Returns
    -------
    z, zd : ndarray
        A configuration that satisfies every closure, and consistent rates.

    Raises
    ------
    AssemblyError
        When the loop cannot close with the held coordinate at its value.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> guess = m.z_from_q(m.q_ref) + [0.0, 0.05, -0.05]   # the crank's angle is held, the rest closed
    >>> z, zd = grubler.assemble(m, guess)
    >>> z.round(4), zd
    (array([ 0.    ,  1.0472, -2.0944]), array([0., 0., 0.]))
    """
    z = np.array(z0, dtype=float)
    zd = np.zeros(model.n_free) if zd0 is None else np.array(zd0, dtype=float)
    if model.n_constraints == 0:
        return z, zd
    status, held, closest = _close(model, z, zd)
    if status != binding.OK:
        names = model.free_names
        # (a slide's coordinate is a length, a revolute's an angle)
        from grubler.mechanism.scene import coordinate_text  # (scene imports the builders, which assemble)

        # in degrees as a scene writes its angles, and in radians as the run's CSV has them
        held_txt = ", ".join(f"{names[i]} = {coordinate_text(names[i], z0[i], radians=True)} held"
                             for i in held) or "nothing held"
        unit = "m" if all(c.kind == "revolute" for c in model.closures) else "m (or rad, for a held orientation)"
        why = explain_unclosable(model, z0, held)
        if not why and len(model.closures) > 1:
            # z holds the closest configuration reached: name the loop left open there
            phi, _ = constraint(model, z)
            gaps = np.maximum(np.abs(phi[0::2]), np.abs(phi[1::2]))
            j = int(np.argmax(gaps))
            cl = model.closures[j]
            others = ", ".join(f"closure[{i}] {g:.2g}" for i, g in enumerate(gaps) if i != j)
            why = f"the loop left open is closure[{j}]'s (link{cl.link} to link{cl.to_link}; {others})"
        raise AssemblyError(
            field,
            f"the loop cannot be closed with {held_txt}: the closest the tip gets is "
            f"{closest:.3g} {unit} from its closure{'; ' + why if why else ''}",
        )
    return z, zd


def _close(model: Mechanism, z: np.ndarray, zd: np.ndarray) -> tuple[int, list[int], float]:
    """The kernel's assembly of ``z`` and ``zd`` in place: its status, the held coordinates and the closest gap."""
    kernel = _Assembly(model)
    status = kernel.close(z, zd)
    return status, [int(i) for i in kernel.held[:kernel.count.value]], kernel.closest.value


class _Assembly:
    """The kernel's assembly of one model with its buffers made once, for many starts (:func:`branches`).

    Each :meth:`close` holds what :func:`held_coordinates` would hold at its
    ``z`` and runs ``grb_assemble``, as :func:`assemble` does, without building
    the arrays and addresses again: 256 starts of a six-bar in 2 to 3 ms, not 10.
    """

    def __init__(self, model: Mechanism):
        n = model.n_links
        self.c, self.scale = model.arrays.c, _scale(model)
        self.work = binding.work(n, len(model.closures))
        self.held = np.zeros(max(n, 1), dtype=np.int32)
        self.n_hold, self.count, self.closest = ctypes.c_int(0), ctypes.c_int(0), ctypes.c_double(0.0)
        self._work, self._held = binding.address(self.work), binding.address(self.held)

    def close(self, z: np.ndarray, zd: np.ndarray) -> int:
        """Assemble ``z`` and ``zd`` (float64, contiguous) in place; the kernel's status."""
        lib, az = binding.library(), binding.address(z)
        lib.grb_hold_count(self.c, az, self._work, ctypes.byref(self.n_hold))
        lib.grb_held_coordinates(self.c, self.n_hold.value, az, self._held, ctypes.byref(self.count), self._work)
        return lib.grb_assemble(self.c, self.count.value, self._held, self.scale, az, binding.address(zd),
                                ctypes.byref(self.closest), self._work)


def project(model: Mechanism, z: np.ndarray, zd: np.ndarray, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Minimum-norm projection onto the position and velocity constraints.

    Gauss-Newton on ``phi(z) = 0`` (a step or two from an integrator step that is
    already near the manifold), then the rates onto the null space of ``J``.
    """
    y = np.concatenate([np.asarray(z, dtype=float), np.asarray(zd, dtype=float)])
    work = binding.work(model.n_links, len(model.closures))
    binding.library().grb_project(model.arrays.c, float(scale), binding.address(y),
                                  binding.address(work))
    n = model.n_links
    return y[:n], y[n:]


def branches(model: Mechanism, z0: np.ndarray, starts: int = 256, seed: int = 0) -> tuple[list[np.ndarray], int]:
    """Every assembly branch the held coordinates allow, and which one the sketch closes to.

    The assembly above, started from the scene's sketch and from ``starts``
    further sketches drawn at random (a fixed seed: the same answer every time),
    each closed to the assembly's tolerance; configurations that differ by less
    than 1e-6 (angles modulo a turn) are one branch.  Random restarts cannot
    prove that none was missed, but every branch listed is exact.

    Returns
    -------
    found : list of ndarray
        The branches' joint coordinates, the sketch's first.
    default : int
        Index of the sketch's branch in ``found`` (0), or -1 when the sketch does not close.

    Raises
    ------
    AssemblyError
        When no start closes: the reason is the sketch's.
    """
    z0 = np.asarray(z0, dtype=float)
    held = held_coordinates(model, z0)
    revolute = model.arrays.revolute
    scale = _scale(model)
    free = np.ones(model.n_free, bool)
    free[held] = False
    turns, slides = free & revolute, free & ~revolute
    # every start's sketch at once, the numbers those of rng.uniform(-pi, pi, turns) then
    # rng.uniform(-scale, scale, slides) start after start (both are low + (high - low) * random())
    u = np.random.default_rng(seed).random((starts, int(turns.sum()) + int(slides.sum())))
    sketches = np.repeat(z0[None, :], starts, axis=0)
    sketches[:, turns] = -np.pi + (np.pi - -np.pi) * u[:, :int(turns.sum())]
    sketches[:, slides] += -scale + (scale - -scale) * u[:, int(turns.sum()):]
    found = np.empty((starts + 1, model.n_free))  # the branches so far: found[:count]
    count, default, first_error = 0, -1, None
    kernel = _Assembly(model) if model.n_constraints else None
    zd = np.zeros(model.n_free)

    def new(z) -> bool:  # no branch found yet within 1e-6 of z (angles modulo a turn)
        d = found[:count] - z
        d[:, revolute] = (d[:, revolute] + np.pi) % (2 * np.pi) - np.pi
        return bool(np.all(np.max(np.abs(d), axis=1, initial=0.0) >= 1e-6))

    try:
        found[0], _ = assemble(model, z0)
        count, default = 1, 0
    except AssemblyError as exc:
        first_error = exc
    for z in sketches:
        # a random start that fails needs no reason (only the sketch's is ever reported): the kernel's status
        zd[:] = 0.0
        if kernel is not None and kernel.close(z, zd) != binding.OK:
            continue
        if new(z):
            found[count] = z
            count += 1
    if not count:
        raise first_error
    return list(found[:count]), default
