"""A mechanism's state equation in minimal coordinates, with its exact derivatives.

A closed chain of N real joints and C closures moves with n = N - 2C freedoms;
its minimal state is the independent coordinates (the drive first, as assembly
holds them) and their rates.  The dependent coordinates and rates follow from
the closures (``kernel/minimal.c``), so the state equation in minimal
coordinates is ``xdot = (zd_i, zdd_i)(y(x), u)`` with ``y(x)`` the whole state.
Its Jacobians come from the kernel's own equations compiled over complex
numbers (``grubler_cs.h``): evaluated at ``x + i h e_k`` the imaginary part of
every output over h is its exact derivative along ``e_k``, the tangent of the
constraint manifold included, with no step-size trade-off (complex-step
differentiation).  :mod:`grubler.studies.operating_point` finds where to
linearise with it, :mod:`grubler.studies.linearize` builds the linear model.

Examples
--------
>>> import numpy as np
>>> from grubler import load_scene
>>> from grubler.mechanism.assembly import assemble
>>> m = load_scene("fourbar-parallelogram").mechanism
>>> plant = MinimalPlant(m)
>>> z, zd = assemble(m, m.z_from_q(m.q_ref))
>>> plant.choose_independent(z)
>>> [m.free_names[i] for i in plant.ind]
['theta2']
>>> F, G, H, K, T = plant.derivatives(np.concatenate([z, zd]), 0.0, 0.0)
>>> F.shape, G.shape
((6, 2), (6, 2))
"""

from __future__ import annotations

import numpy as np

from grubler import binding
from grubler.errors import SceneError
from grubler.mechanism.assembly import SINGULAR_RCOND, _scale, constraint, freedom, held_coordinates
from grubler.mechanism.dynamics import observation_names
from grubler.mechanism.model import Mechanism
from grubler.mechanism.scene import coordinate_text

H_STEP = 1e-30  # complex step: any tiny h is exact; this one keeps h^2 far above underflow

# A step of the independent coordinates is walked (MinimalPlant.follow): each piece is
# predicted along the tangent and closed by Newton, and kept only when Newton's
# correction is a small part of the predicted move; else halved.  Newton from a
# far guess lands on whichever branch is nearest the guess.
FOLLOW_RATIO = 0.25  # largest correction over predicted move of one piece
FOLLOW_MOVE = 0.1  # rad (or m over the length scale): largest predicted move of a dependent coordinate
FOLLOW_FLOOR = 1e-9  # rad (or m over the length scale): a correction this small passes whatever the move
FOLLOW_SHORTEST = 1e-10  # rad (or m): a piece this short that still fails is stopped by a toggle
FOLLOW_PIECES = 2000  # pieces of one walk at most: beyond, a coordinate runs off towards an asymptote
# The search moves in whichever independent coordinates are well conditioned: a
# double-rocker's crank reaches a toggle on the way down and turns back while the
# rest swings on, as its damped release does.  It changes chart when the current
# one's conditioning falls below this fraction of the best one's.
CHART_SWITCH = 0.25

class MinimalPlant:
    """One mechanism's state equation in minimal coordinates, with complex-step derivatives."""

    def __init__(self, model: Mechanism):
        self.model = model
        self.n = model.n_links
        self.scale = _scale(model)
        self.lib = binding.library()
        self.work = binding.work(self.n, len(model.closures))
        self.cwork = np.zeros(self.work.size, dtype=complex)
        self.ind = np.zeros(0, dtype=np.int32)

    def choose_independent(self, z: np.ndarray) -> None:
        m = self.model
        # the closures' rank, not the Grübler count: a redundant closure (a third
        # crank on a parallelogram's rod) leaves a freedom the count does not see
        free = freedom(m, z) if m.n_constraints else self.n
        if free < 1:
            raise SceneError("closure", f"the mechanism has mobility {free}: nothing moves to linearise")
        ind = sorted(held_coordinates(m, z)) if m.n_constraints else list(range(self.n))
        if len(ind) != free:
            raise SceneError("closure", f"the closures leave {free} freedoms but "
                                        f"{len(ind)} independent coordinates were found")
        self.ind = np.array(ind, dtype=np.int32)

    @property
    def rows(self) -> np.ndarray:
        """Indices in (z, zd) of the minimal state (z_i, zd_i)."""
        return np.concatenate([self.ind, self.n + self.ind])

    def close(self, y: np.ndarray, where: str = "at") -> np.ndarray:
        """The whole state from its independent part (the others as a nearby guess), real."""
        y = np.ascontiguousarray(y, dtype=float).copy()
        status = self.lib.grb_minimal_state(self.model.arrays.c, len(self.ind), binding.address(self.ind),
                                            self.scale, binding.address(y), binding.address(self.work))
        self._check(status, where, y)
        return y

    def _check(self, status: int, where: str, y) -> None:
        if status == binding.OK:
            return
        names = [self.model.free_names[i] for i in self.ind]
        at = where_text(names, y, self.ind)
        if status == binding.SINGULAR:
            raise SceneError(where, f"at {at} the coordinates {', '.join(names)} do not determine the others "
                                    "(the closure Jacobian's dependent columns are singular: a dead centre or "
                                    "change point); linearise elsewhere")
        raise SceneError(where, f"the loop cannot be closed at {at}")

    def _charts(self, z: np.ndarray, ind) -> tuple[float, list[int]]:
        """How well ``ind`` determines the rest at ``z`` (the smallest singular value of the
        closures' null space restricted to it), and the best-conditioned chart's choice."""
        weight = np.where(self.model.arrays.revolute, 1.0, 1.0 / self.scale)
        _, J = constraint(self.model, z)
        _, s, vt = np.linalg.svd(J / weight, full_matrices=True)
        null = vt[len(vt) - len(ind):].T  # n x k: the closures' tangent space
        best, rest = [], null.copy()
        for _ in range(len(ind)):  # greedy pivoting: the coordinate that moves most, then the next ...
            i = int(np.argmax(np.linalg.norm(rest, axis=1)))
            best.append(i)
            v = rest[i] / np.linalg.norm(rest[i])
            rest = rest - np.outer(rest @ v, v)
        quality = lambda chosen: np.linalg.svd(null[sorted(chosen)], compute_uv=False)[-1]  # noqa: E731
        return quality(ind) / quality(best), sorted(best)

    def well_conditioned_chart(self, y: np.ndarray) -> None:
        """Move to the best-conditioned independent coordinates when the current ones near a toggle."""
        if not self.model.n_constraints:
            return
        ratio, best = self._charts(y[:self.n], list(self.ind))
        if ratio < CHART_SWITCH:
            self.ind = np.array(best, dtype=np.int32)

    def follow(self, y: np.ndarray, target: np.ndarray, where: str = "at") -> np.ndarray:
        """The closed state (at rest) with the independent coordinates at ``target``, reached from
        ``y`` by continuity: on ``y``'s assembly branch, as a simulation keeps it.

        Raises SceneError(``where``) when a dead centre or change point on the way stops the walk.
        """
        n, ind = self.n, self.ind
        y = np.array(y, dtype=float)
        y[n:] = 0.0
        start = y[ind].copy()
        delta = np.asarray(target, dtype=float) - start
        if not self.model.n_constraints:
            y[ind] = target
            return y
        weight = np.where(self.model.arrays.revolute, 1.0, 1.0 / self.scale)
        done, piece = 0.0, 1.0
        for _ in range(FOLLOW_PIECES):
            if done >= 1.0:
                break
            piece = min(piece, 1.0 - done)
            ok = False
            try:
                tangent = y.copy()
                tangent[n + ind] = piece * delta  # as rates: the dependent rates are the first-order move
                move = self.close(tangent, where)[n:]
                predicted = y.copy()
                predicted[:n] += move
                predicted[n:] = 0.0
                predicted[ind] = start + (done + piece) * delta
                if np.abs(move * weight).max() <= FOLLOW_MOVE:
                    closed = self.close(predicted, where)
                    correction = np.abs((closed[:n] - predicted[:n]) * weight).max()
                    ok = correction <= max(FOLLOW_RATIO * np.abs(move * weight).max(), FOLLOW_FLOOR)
            except SceneError:
                pass
            if ok:
                y, done, piece = closed, done + piece, 2.0 * piece
                continue
            piece /= 2.0
            if piece * np.abs(delta).max() < FOLLOW_SHORTEST:
                names = [self.model.free_names[i] for i in ind]
                raise SceneError(where, f"turning {', '.join(names)} from {where_text(names, start, range(len(ind)))} "
                                        f"towards {where_text(names, target, range(len(ind)))} stops at "
                                        f"{where_text(names, y, ind)}: a dead centre or change point there (the closure "
                                        "Jacobian's dependent columns are singular) bars the way on this branch")
        else:
            if done < 1.0:
                names = [self.model.free_names[i] for i in ind]
                raise SceneError(where, f"turning {', '.join(names)} towards {where_text(names, target, range(len(ind)))}"
                                        f" takes more than {FOLLOW_PIECES} steps from {where_text(names, y, ind)}: "
                                        "the others run off on the way")
        y[ind] = target  # exactly, not as the sum of the pieces
        return self.close(y, where)

    def check_regular(self, y: np.ndarray) -> None:
        """Refuse a configuration where the dependent coordinates barely follow from the independent ones."""
        if not self.model.n_constraints:
            return
        _, J = constraint(self.model, y[:self.n])
        dep = [i for i in range(self.n) if i not in self.ind]
        s = np.linalg.svd(J[:, dep], compute_uv=False)
        if s[-1] <= SINGULAR_RCOND * s[0]:
            self._check(binding.SINGULAR, "at", y)

    def rhs(self, y: np.ndarray, drive: float, load: float) -> np.ndarray:
        out = np.empty(2 * self.n)
        status = self.lib.grb_rhs(self.model.arrays.c, 0, binding.address(y), float(drive), float(load),
                                  binding.address(self.work), binding.address(out))
        if status != binding.OK:
            raise SceneError("at", "the equations of motion are singular at this state")
        return out

    def derivatives(self, y: np.ndarray, drive: float, load: float):
        """Exact derivatives along the minimal state and the two efforts.

        Returns
        -------
        F, G : ndarray
            d(ydot)/dx (2N x 2n) and d(ydot)/d(drive, load) (2N x 2).
        H, K : ndarray
            d(observations)/dx and d(observations)/d(drive, load).
        T : ndarray
            dy/dx, the tangent of the constraint manifold (2N x 2n).
        """
        n, rows = self.n, self.rows
        n_obs = len(observation_names(n))
        k_dirs = len(rows) + 2
        F, T, H = np.empty((2 * n, k_dirs)), np.empty((2 * n, k_dirs)), np.empty((n_obs, k_dirs))
        out, obs = np.empty(2 * n, dtype=complex), np.empty(n_obs, dtype=complex)
        m = self.model.arrays.c
        cs_minimal_state, cs_rhs, cs_observe = (binding.complex_step(f"grb_cs_{f}")
                                                for f in ("minimal_state", "rhs_at", "observe_at"))
        for k in range(k_dirs):
            yc = y.astype(complex)
            efforts = np.array([drive, load], dtype=complex)
            if k < len(rows):
                yc[rows[k]] += 1j * H_STEP
                status = cs_minimal_state(m, len(self.ind), binding.address(self.ind), self.scale,
                                          binding.address(yc), binding.address(self.cwork))
                self._check(status, "at", yc)
            else:
                efforts[k - len(rows)] += 1j * H_STEP
            s1 = cs_rhs(m, 0, binding.address(yc), binding.address(efforts),
                        binding.address(self.cwork), binding.address(out))
            s2 = cs_observe(m, 0, binding.address(yc), binding.address(efforts), 1,
                            binding.address(self.cwork), binding.address(obs))
            if s1 != binding.OK or s2 != binding.OK:
                raise SceneError("at", "the equations of motion are singular at this state")
            F[:, k], H[:, k], T[:, k] = out.imag / H_STEP, obs.imag / H_STEP, yc.imag / H_STEP
        nx = len(rows)
        return F[:, :nx], F[:, nx:], H[:, :nx], H[:, nx:], T[:, :nx]

    def observe(self, y: np.ndarray, drive: float, load: float) -> np.ndarray:
        out = np.zeros(len(observation_names(self.n)))
        self.lib.grb_observe(self.model.arrays.c, 0, binding.address(y), float(drive), float(load), 1,
                             binding.address(self.work), binding.address(out))
        return out

def where_text(names, y, ind) -> str:
    """Coordinates by name as a scene writes them: 'theta2 = 30 deg, theta3 = ...'."""
    return ", ".join(f"{nm} = {coordinate_text(nm, float(np.real(y[i])))}" for nm, i in zip(names, ind))


__all__ = ["MinimalPlant", "where_text"]
