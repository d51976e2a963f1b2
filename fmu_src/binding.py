"""The one place Python calls the compiled kernel: ctypes declarations of grubler.h.

The kernel (``fmu_src/kernel/*.c``, and the motor model in ``motors/kernel``) is
built into the extension ``grubler._kernel`` by ``pip install -e .``; this module
loads that file with ctypes and declares each function's argument types once.
Arrays cross as the addresses of numpy buffers the caller owns (float64,
C-contiguous): no copies, and no Python call inside the kernel's loops, except
a drive effort the user gave as a Python function of time.

Examples
--------
>>> import numpy as np
>>> x, rank = lstsq(np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]), np.array([1.0, 2.0]), 1e-8)
>>> rank, bool(np.allclose(x, np.linalg.lstsq([[1, 0, 1], [0, 1, 1]], [1, 2], rcond=None)[0]))
(2, True)
"""

from __future__ import annotations

import ctypes
import functools
import importlib.util
from dataclasses import dataclass
from ctypes import POINTER, c_double, c_int, c_long, c_size_t, c_void_p

import numpy as np

# grb_status (grubler.h)
(OK, SINGULAR, NONFINITE_DERIVATIVE, STEP_UNDERFLOW, TOO_MANY_STEPS, NONFINITE_FIXED_STEP, BRANCH_JUMP,
 BAD_ARGUMENT, NOT_CLOSED) = range(9)
TABLEAU_CODE = {"dop853": 0, "rk45": 1, "rk4": 2}
DRIVE_FN = ctypes.CFUNCTYPE(c_double, c_void_p, c_double)


class KernelMissing(ImportError):
    """The compiled kernel is not built (run ``pip install -e .`` with a C compiler)."""


class Model(ctypes.Structure):
    """``grb_model``: the model's two number tables and its scalars."""

    _fields_ = [("n_links", c_int), ("n_closures", c_int), ("links", c_void_p), ("closures", c_void_p),
                ("theta1", c_double), ("gravity", c_double), ("drive", c_int), ("load", c_int),
                ("drive_inertia", c_double), ("n_actuators", c_int), ("actuators", c_void_p), ("n_forces", c_int),
                ("forces", c_void_p)]


class Settings(ctypes.Structure):
    """``grb_settings``: how a run is integrated."""

    _fields_ = [("tableau", c_int), ("method", c_int), ("project", c_int), ("scale", c_double),
                ("rtol", c_double), ("atol", c_double), ("h_max", c_double), ("h_fixed", c_double),
                ("max_steps", c_long), ("tau_drive", c_double), ("tau_load", c_double), ("drive_fn", DRIVE_FN),
                ("drive_ctx", c_void_p), ("passage_log", c_void_p), ("passage_capacity", c_int)]


class Clock(ctypes.Structure):
    """``grb_clock``: the integrator's state besides y and f."""

    _fields_ = [("t", c_double), ("h", c_double), ("have_f", c_int), ("steps", c_long), ("rejected", c_long),
                ("evals", c_long), ("passages", c_long), ("kappa_seen", c_double), ("charts", c_long)]


class Failure(ctypes.Structure):
    _fields_ = [("where", c_double), ("limit", c_double)]


class TableauData(ctypes.Structure):
    """``grb_tableau_data`` (kernel/tableaus.h), read by the tests."""

    _fields_ = [("name", ctypes.c_char_p), ("stages", c_int), ("adaptive", c_int), ("error_order", c_int),
                ("A", POINTER(c_double)), ("lda", c_int), ("b", POINTER(c_double)), ("c", POINTER(c_double)),
                ("e", POINTER(c_double)), ("e3", POINTER(c_double)), ("dense_stages", c_int),
                ("dense_a", POINTER(c_double)), ("dense_c", POINTER(c_double)), ("dense_rows", c_int),
                ("dense_d", POINTER(c_double))]


class MasterFmu(ctypes.Structure):
    """``grb_fmu`` (system/c/master.c): one FMU instance as the master's stepping loop drives it."""

    _fields_ = [("instance", c_void_p), ("set_real", c_void_p), ("get_real", c_void_p), ("do_step", c_void_p),
                ("n_in", c_size_t), ("in_vr", c_void_p), ("in_slot", c_void_p), ("in_buf", c_void_p),
                ("n_conn", c_size_t), ("n_read", c_size_t), ("read_vr", c_void_p), ("read_buf", c_void_p),
                ("out_slot", c_void_p), ("seconds", c_void_p), ("in_mode", c_void_p), ("sampled", c_int),
                ("get_state", c_void_p), ("set_state", c_void_p), ("free_state", c_void_p), ("state", c_void_p)]


class MasterRun(ctypes.Structure):
    """``grb_run`` (system/c/master.c): the master, its clock, and where recorded rows go."""

    _fields_ = [("scheme", c_int), ("t0", c_double), ("step", c_double), ("t_end", c_double),
                ("n_steps", c_long), ("record_every", c_long), ("n_columns", c_size_t), ("column_fmu", c_void_p),
                ("column_index", c_void_p), ("times", c_void_p), ("data", c_void_p), ("n_slots", c_size_t),
                ("start", c_void_p), ("prev", c_void_p), ("tol", c_double), ("work", c_void_p), ("adapt", c_void_p),
                ("newton", c_void_p)]


class MasterAdapt(ctypes.Structure):
    """``grb_adapt`` (system/c/master.c): the adaptive master's sub-step clock and counts."""

    _fields_ = [("h", c_double), ("h_prev", c_double), ("substeps", c_long), ("rejected", c_long),
                ("worst", c_double), ("worst_slot", c_long)]


class MasterNewton(ctypes.Structure):
    """``grb_newton`` (system/c/master.c): the Newton master's unknowns, work and counts."""

    _fields_ = [("tol", c_double), ("max_iter", c_long), ("n_unknown", c_size_t), ("unknown_slot", c_void_p),
                ("index", c_void_p), ("work", c_void_p), ("pivot", c_void_p), ("have_jacobian", c_int),
                ("steps", c_long), ("evaluations", c_long), ("jacobians", c_long), ("unconverged", c_long),
                ("worst", c_double), ("worst_slot", c_long)]


class MasterFailure(ctypes.Structure):
    """``grb_failure`` (system/c/master.c): the FMU, the call (0 setReal, 1 doStep, 2 getReal, 3 get/set FMU
    state, 4 the tolerance not met), its status, t."""

    _fields_ = [("fmu", c_int), ("call", c_int), ("status", c_int), ("t", c_double)]


class Problem(ctypes.Structure):
    """``grb_problem`` (kernel/grb_scene.h): one refusal, the field at fault and the reason."""

    _fields_ = [("field", ctypes.c_char * 64), ("reason", ctypes.c_char * 256)]


# columns of a link row as grb_scene_check reads it (GRB_SK_*): joint (1 revolute, 2 prismatic), parent
# (thesis numbering, 1 the ground), a, p, q, m, I, damping
SCENE_LINK_COLUMNS = 8
SCENE_CLOSURE_COLUMNS = 11  # GRB_SC_*: type (1 revolute, 2 prismatic), link, to_link (thesis), ...
SCENE_ACTUATOR_COLUMNS = 6  # GRB_A_*: from_link, from x, y, to_link, to x, y (thesis)
FORCE_COLUMNS = 19  # GRB_F_*: a force element's row (grubler.mechanism.model.F_*)
FORCE_OUTPUTS = 6  # GRB_FO_*: length, rate, force, energy, power, dissipation


class SceneView(ctypes.Structure):
    """``grb_scene_view`` (kernel/grb_scene.h): a scene as the mechanism's check reads it."""

    _fields_ = [("n_links", c_int), ("n_closures", c_int), ("n_actuators", c_int),
                ("links", c_void_p), ("link_stride", c_int), ("link_column", c_int * SCENE_LINK_COLUMNS),
                ("closures", c_void_p), ("closure_stride", c_int), ("closure_column", c_int * SCENE_CLOSURE_COLUMNS),
                ("actuators", c_void_p), ("actuator_stride", c_int),
                ("actuator_column", c_int * SCENE_ACTUATOR_COLUMNS),
                ("a1", c_double), ("theta1", c_double), ("gravity", c_double), ("q_ref", c_void_p), ("qd", c_void_p),
                ("drive", c_int), ("load", c_int), ("drive_inertia", c_double), ("actuator_names", c_void_p),
                ("drive_field", ctypes.c_char_p), ("load_field", ctypes.c_char_p),
                ("n_forces", c_int), ("forces", c_void_p), ("force_stride", c_int),
                ("force_column", c_int * FORCE_COLUMNS), ("force_names", c_void_p)]


_P = c_void_p  # a numpy buffer's address
_M = c_void_p  # a grb_model's address (ModelArrays.c): the struct may come from another import of this module
_SIGNATURES = {
    "grb_work_size": (c_size_t, [c_int, c_int]),
    "grb_work_init": (c_int, [c_int, c_int, _P, c_size_t]),
    "grb_status_message": (ctypes.c_char_p, [c_int]),
    "grb_stepper_size": (c_size_t, [c_int, c_int]),
    "grb_work_layout": (None, [c_int, c_int, _P]),
    "grb_rhs": (c_int, [_M, c_int, _P, c_double, c_double, _P, _P]),
    "grb_evaluate": (c_int, [_M, c_int, _P, c_double, c_double, _P]),
    "grb_observe": (c_int, [_M, c_int, _P, c_double, c_double, c_int, _P, _P]),
    "grb_observe_rows": (c_int, [_M, c_int, c_int, _P, _P, c_double, c_double, c_int, _P, _P]),
    "grb_set_actuator_forces": (c_int, [_M, _P, _P]),
    "grb_actuator_lines": (c_int, [_M, c_int, _P, _P, _P]),
    "grb_force_rows": (c_int, [_M, c_int, _P, _P, _P]),
    "grb_point_on_link": (c_int, [_M, _P, c_int, c_double, c_double, _P, _P]),
    "grb_link_points_rows": (c_int, [_M, c_int, _P, c_int, _P, _P, _P, _P]),
    "grb_joint_reactions": (c_int, [_M, _P, _P]),
    "grb_inverse_residual": (c_int, [_M, _P, _P, c_double, _P, _P]),
    "grb_constraint": (c_int, [_M, _P, _P, _P, _P]),
    "grb_project": (c_int, [_M, c_double, _P, _P]),
    "grb_held_coordinates": (c_int, [_M, c_int, _P, _P, POINTER(c_int), _P]),
    "grb_freedom": (c_int, [_M, _P, _P, POINTER(c_int)]),
    "grb_hold_count": (c_int, [_M, _P, _P, POINTER(c_int)]),
    "grb_assemble": (c_int, [_M, c_int, _P, c_double, _P, _P, POINTER(c_double), _P]),
    "grb_advance": (c_int, [_M, POINTER(Settings), POINTER(Clock), _P, _P, _P, c_int, _P, _P, _P,
                            POINTER(Failure)]),
    "grb_minimal_state": (c_int, [_M, c_int, _P, c_double, _P, _P]),
    "grb_drive_demand": (c_int, [_M, c_double, c_int, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, POINTER(c_int),
                                 POINTER(c_double), _P]),
    "grb_lstsq": (c_int, [_P, c_int, c_int, _P, c_double, _P, _P]),
    "grb_tableau": (POINTER(TableauData), [c_int]),
    # complex-step twins (kernel/grubler_cs.h): complex128 buffers, efforts by address
    "grb_cs_rhs_at": (c_int, [_M, c_int, _P, _P, _P, _P]),
    "grb_cs_observe_at": (c_int, [_M, c_int, _P, _P, c_int, _P, _P]),
    "grb_cs_set_actuator_forces": (c_int, [_M, _P, _P]),
    "grb_cs_minimal_state": (c_int, [_M, c_int, _P, c_double, _P, _P]),
    # scene quantities -> the tables (kernel/grb_scene.h), what the native FMU runs too
    "grb_scene_tables": (c_int, [c_int, c_int, _P, _P, _P, c_double, c_double, _P, _P, _P, _P]),
    "grb_scene_check": (c_int, [POINTER(SceneView), POINTER(Problem), c_int, POINTER(c_int)]),
    "grb_link_check": (c_int, [c_int, _P, _P, POINTER(Problem), c_int, POINTER(c_int)]),
    "grb_coordinate_check": (c_int, [c_int, c_int, ctypes.c_char_p, POINTER(Problem)]),
    # the co-simulation master's stepping loop (system/c/master.c)
    "grb_master_steps": (c_int, [POINTER(MasterFmu), c_int, _P, POINTER(MasterRun), c_long, c_long,
                                 POINTER(c_double), POINTER(c_long), POINTER(MasterFailure)]),
    "grb_master_free_states": (None, [POINTER(MasterFmu), c_int]),
}


@functools.lru_cache(maxsize=None)
def library() -> ctypes.CDLL:
    """The loaded kernel library (grubler._kernel's shared object), its functions declared."""
    spec = importlib.util.find_spec("grubler._kernel")
    if spec is None or spec.origin is None:
        raise KernelMissing("grubler's compiled kernel (grubler._kernel) is not built: run `pip install -e .` "
                            "in the project folder on a machine with a C compiler")
    return declare(ctypes.CDLL(spec.origin))


def declare(lib: ctypes.CDLL) -> ctypes.CDLL:
    """Give the kernel library's functions their C signatures.

    The complex-step twins (``grb_cs_*``) are absent from a kernel compiled
    without C99 complex arithmetic (Visual Studio's C: kernel/complex_step.h);
    everything else works there, and :func:`complex_step` says what needs them.
    """
    for name, (restype, argtypes) in _SIGNATURES.items():
        if name.startswith("grb_cs_") and not hasattr(lib, name):
            continue
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes
    return lib


def complex_step(name: str, lib: ctypes.CDLL | None = None):
    """The kernel's complex-step twin ``name`` (``grb_cs_*``: exact derivatives to rounding).

    Raises
    ------
    KernelMissing
        The kernel was compiled without C99 complex arithmetic, so it has none.
    """
    lib = library() if lib is None else lib
    if not hasattr(lib, name):
        raise KernelMissing(f"{name}: this kernel was compiled without C99 complex arithmetic (Visual Studio's C), "
                            "which linearisation, actuator derivatives and the implicit integrators' exact Jacobians "
                            "need; build it with clang or MinGW-w64 gcc")
    return getattr(lib, name)


def address(a: np.ndarray) -> int:
    """The buffer address of a C-contiguous array the kernel may write (float64, complex128 or int32)."""
    if not a.flags.c_contiguous:
        raise ValueError("kernel arrays must be C-contiguous")
    return a.ctypes.data


def model_struct(links: np.ndarray, closures: np.ndarray, theta1: float, gravity: float, drive: int, load: int,
                 drive_inertia: float, actuators: np.ndarray | None = None,
                 forces: np.ndarray | None = None) -> Model:
    """A ``grb_model`` over its tables: links, closures, actuators and force elements (the caller keeps them alive)."""
    n_act = 0 if actuators is None else actuators.shape[0]
    n_forces = 0 if forces is None else forces.shape[0]
    return Model(links.shape[0], closures.shape[0], address(links), address(closures) if closures.size else None,
                 float(theta1), float(gravity), int(drive), int(load), float(drive_inertia), n_act,
                 address(actuators) if n_act else None, n_forces, address(forces) if n_forces else None)


def set_actuator_forces(model: int, work: np.ndarray, forces) -> None:
    """Put the actuators' forces (N, positive pushing apart) into a workspace (grb_set_actuator_forces).

    ``model`` is a grb_model's address (``ModelArrays.c``); a complex workspace
    (the complex-step twin's) takes complex forces.
    """
    dtype = complex if work.dtype == complex else float
    f = np.ascontiguousarray(forces, dtype=dtype)
    fn = complex_step("grb_cs_set_actuator_forces") if dtype is complex else library().grb_set_actuator_forces
    status = fn(model, address(work), address(f) if f.size else None)
    if status != OK:
        raise ValueError(f"actuator forces: {status_message(status)}")


def scene_tables(revolute: np.ndarray, parent: np.ndarray, link_fields: np.ndarray, a1: float, theta1: float,
                 q_ref: np.ndarray, closure_fields: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """grb_scene_tables (grb_scene.h): the link and closure tables of a scene.

    The native mechanism FMU builds its tables with the same C function.
    ``revolute`` (int32, one per link), ``parent`` (int32, each link's
    predecessor as a 0-based moving-link index, -1 the ground), ``link_fields``
    (N x 6: a, p, q, m, I, damping), ``q_ref`` (2N absolute coordinates),
    ``closure_fields`` (C x 11: kind, link and to_link in thesis numbering,
    point, to_point, angle, psi, gain, damping).
    """
    n, nc = link_fields.shape[0], closure_fields.shape[0]
    rev = np.ascontiguousarray(revolute, dtype=np.int32)
    par = np.ascontiguousarray(parent, dtype=np.int32)
    fields = np.ascontiguousarray(link_fields, dtype=float)
    q = np.ascontiguousarray(q_ref, dtype=float)
    cf = np.ascontiguousarray(closure_fields, dtype=float)
    links, closures = np.zeros((n, 11)), np.zeros((nc, 11))
    status = library().grb_scene_tables(n, nc, address(rev), address(par), address(fields), float(a1), float(theta1),
                                        address(q), address(cf) if nc else None, address(links),
                                        address(closures) if nc else None)
    if status != OK:
        raise ValueError("closure or parent: a link number is out of range")
    return links, closures


def _problems(call) -> list[tuple[str, str]]:
    """The (field, reason) pairs a check writes: ``call(buffer, capacity, count)``, again if they overflowed."""
    capacity = 8
    while True:
        found, count = (Problem * capacity)(), c_int(0)
        call(found, capacity, ctypes.byref(count))
        if count.value <= capacity:
            return [(p.field.decode(), p.reason.decode()) for p in found[:count.value]]
        capacity = count.value


def scene_problems(links: np.ndarray, closures: np.ndarray, actuators: np.ndarray, a1: float, theta1: float,
                   gravity: float, q_ref: np.ndarray, qd: np.ndarray | None, drive: int, load: int,
                   drive_inertia: float, forces: np.ndarray | None = None,
                   force_names: list[str] | None = None) -> list[tuple[str, str]]:
    """grb_scene_check (grb_scene.h): every refusal of a scene's mechanism rules, as (field, reason), in order.

    The native mechanism FMU refuses its parameters with the same C function.
    ``links`` (N x 8: joint 1 revolute / 2 prismatic, parent in thesis
    numbering, a, p, q, m, I, damping), ``closures`` (C x 11: type 1 revolute /
    2 prismatic, link, to_link, point, to_point, angle, psi, gain, damping),
    ``actuators`` (A x 6: from_link, from_point, to_link, to_point, thesis
    numbering), ``q_ref`` (2N), ``qd`` (2N initial absolute rates, or None: not
    judged), ``drive`` and ``load`` (index in q, -1 none), ``forces`` (F x
    FORCE_COLUMNS, the kernel's force rows with thesis link numbers) named by
    ``force_names`` in the messages.
    """
    tables = [np.ascontiguousarray(t, dtype=float) for t in (links, closures, actuators, q_ref)]
    rates = None if qd is None else np.ascontiguousarray(qd, dtype=float)
    L, C, A, q = tables
    view = SceneView(L.shape[0], C.shape[0], A.shape[0],
                     address(L) if L.size else None, SCENE_LINK_COLUMNS, tuple(range(SCENE_LINK_COLUMNS)),
                     address(C) if C.size else None, SCENE_CLOSURE_COLUMNS, tuple(range(SCENE_CLOSURE_COLUMNS)),
                     address(A) if A.size else None, SCENE_ACTUATOR_COLUMNS, tuple(range(SCENE_ACTUATOR_COLUMNS)),
                     float(a1), float(theta1), float(gravity), address(q) if q.size else None,
                     None if rates is None else address(rates), int(drive), int(load), float(drive_inertia),
                     None, None, None)
    F = np.zeros((0, FORCE_COLUMNS)) if forces is None else np.ascontiguousarray(forces, dtype=float)
    names = [n.encode() for n in (force_names or [])]
    name_array = (ctypes.c_char_p * max(len(names), 1))(*names)
    view.n_forces, view.forces, view.force_stride = F.shape[0], address(F) if F.size else None, FORCE_COLUMNS
    view.force_column = tuple(range(FORCE_COLUMNS))
    view.force_names = ctypes.cast(name_array, c_void_p) if names else None
    return _problems(lambda found, capacity, count: library().grb_scene_check(ctypes.byref(view), found, capacity,
                                                                               count))


def link_problems(k: int, row) -> list[tuple[str, str]]:
    """grb_link_check: every refusal of link ``k`` (thesis numbering), its ``row`` as :func:`scene_problems`'s."""
    r = np.ascontiguousarray(row, dtype=float)
    columns = np.arange(SCENE_LINK_COLUMNS, dtype=np.int32)
    return _problems(lambda found, capacity, count: library().grb_link_check(int(k), address(r), address(columns),
                                                                              found, capacity, count))


def coordinate_problem(q: int, revolute: bool, field: str) -> tuple[str, str] | None:
    """grb_coordinate_check: why coordinate ``q`` (index in q) is not its pair's real joint, or None."""
    found = Problem()
    if library().grb_coordinate_check(int(q), int(bool(revolute)), field.encode(), ctypes.byref(found)) == OK:
        return None
    return found.field.decode(), found.reason.decode()


def work_size(n_links: int, n_closures: int) -> int:
    """Doubles of kernel workspace a model of this size needs (grb_work_size): what a native FMU sizes.

    Examples
    --------
    >>> work_size(3, 1) == work(3, 1).size > 0
    True
    """
    return int(library().grb_work_size(n_links, n_closures))


def work(n_links: int, n_closures: int) -> np.ndarray:
    """A workspace buffer for a model of this size, laid out for it (grb_work_init)."""
    buffer = np.zeros(work_size(n_links, n_closures))
    status = library().grb_work_init(n_links, n_closures, address(buffer), buffer.size)
    if status != OK:
        raise ValueError(f"n_links, n_closures: {status_message(status)} ({n_links} links, {n_closures} closures)")
    return buffer


@dataclass
class DriveDemandRun:
    """What grb_drive_demand returned: its status, the sample it stopped at
    (-1: none, or the model), the smallest violation assembly reached there,
    and the rows it filled (see grubler.h)."""

    status: int
    at: int
    closest: float
    z: np.ndarray
    zd: np.ndarray
    zdd: np.ndarray
    torque: np.ndarray
    closing_force: np.ndarray


def drive_demand(model, scale: float, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray,
                 load: np.ndarray, z_guess: np.ndarray) -> DriveDemandRun:
    """grb_drive_demand over the samples of a drive motion (``model``: ModelArrays)."""
    n, nc = model.links.shape[0], model.closures.shape[0]
    pos, vel, acc, tau_load = (np.ascontiguousarray(a, dtype=float) for a in (position, velocity, acceleration, load))
    guess = np.ascontiguousarray(z_guess, dtype=float)
    rows = pos.shape[0]
    if not (vel.shape == acc.shape == tau_load.shape == (rows,) and guess.shape == (n,)):
        raise ValueError("position, velocity, acceleration and load need one value per sample, z_guess one per joint")
    z, zd, zdd = (np.zeros((rows, n)) for _ in range(3))
    torque, force = np.zeros(rows), np.zeros((rows, 2))
    at, closest, buffer = c_int(-1), c_double(0.0), work(n, nc)
    status = library().grb_drive_demand(model.c, float(scale), rows, address(pos), address(vel), address(acc),
                                        address(tau_load), address(guess), address(z), address(zd), address(zdd),
                                        address(torque), address(force), ctypes.byref(at), ctypes.byref(closest),
                                        address(buffer))
    return DriveDemandRun(int(status), int(at.value), float(closest.value), z, zd, zdd, torque, force)


def status_message(status: int) -> str:
    """What a grb_status means (grb_status_message)."""
    return library().grb_status_message(int(status)).decode()


@functools.lru_cache(maxsize=64)
def layout(n_links: int, n_closures: int) -> tuple[int, ...]:
    """grb_work_layout: table offsets and column counts in a workspace."""
    out = np.zeros(12, dtype=np.int64 if ctypes.sizeof(c_long) == 8 else np.int32)
    library().grb_work_layout(n_links, n_closures, address(out))
    return tuple(int(v) for v in out)


def lstsq(J: np.ndarray, b: np.ndarray, rcond: float) -> tuple[np.ndarray, int]:
    """Minimum-norm least-squares solution of ``J x = b`` and the rank used (the kernel's solver)."""
    J = np.ascontiguousarray(J, dtype=float)
    b = np.ascontiguousarray(b, dtype=float)
    m, n = J.shape
    x = np.zeros(n)
    scratch = np.zeros((n + m) * m + 1)
    rank = library().grb_lstsq(address(J), m, n, address(b), float(rcond), address(x), address(scratch))
    return x, rank


# -- the spatial chain (kernel/spatial/grubler_spatial.h) ----------------------------------------------------------


class SpatialModel(ctypes.Structure):
    """``grs_model``: the spatial chain's link and closure tables and its gravity vector."""

    _fields_ = [("n_links", c_int), ("n_closures", c_int), ("links", c_void_p), ("closures", c_void_p),
                ("gravity", c_double * 3)]


class SpatialSettings(ctypes.Structure):
    """``grs_settings``: how a spatial run is integrated."""

    _fields_ = [("tableau", c_int), ("rtol", c_double), ("atol", c_double), ("h_max", c_double),
                ("max_steps", c_long), ("scale", c_double), ("tau", c_void_p)]


_SM = POINTER(SpatialModel)
_SPATIAL_SIGNATURES = {
    "grs_check": (c_int, [_SM, POINTER(c_int), POINTER(c_int)]),
    "grs_n_coords": (c_int, [_SM]),
    "grs_n_rows": (c_int, [_SM]),
    "grs_work_size": (c_size_t, [_SM]),
    "grs_work_init": (c_int, [_SM, _P, c_size_t]),
    "grs_rhs": (c_int, [_SM, _P, _P, _P, _P]),
    "grs_dynamics": (c_int, [_SM, _P, _P, _P, _P, _P, _P]),
    "grs_constraint": (c_int, [_SM, _P, _P, _P, _P]),
    "grs_frames": (c_int, [_SM, _P, _P, _P]),
    "grs_link_points_rows": (c_int, [_SM, c_int, _P, c_int, _P, _P, _P, _P]),
    "grs_closure_frame": (c_int, [_SM, c_int, _P]),
    "grs_reactions": (c_int, [_SM, _P, _P, _P, _P, _P]),
    "grs_determinacy": (c_int, [_SM, _P, c_double, _P, _P, POINTER(c_int)]),
    "grs_joint_determinacy": (c_int, [_SM, _P, c_double, _P, _P, POINTER(c_int)]),
    "grs_project": (c_int, [_SM, c_double, _P, _P]),
    "grs_assemble": (c_int, [_SM, c_int, _P, c_double, _P, _P, POINTER(c_double), _P]),
    "grs_stepper_size": (c_size_t, [c_int, c_int]),
    "grs_passages": (c_double, [_P, c_int, c_int]),
    "grs_advance": (c_int, [_SM, POINTER(SpatialSettings), POINTER(c_double), POINTER(c_double), POINTER(c_long),
                            _P, _P, c_int, _P, _P, _P, POINTER(c_double)]),
}


@functools.lru_cache(maxsize=None)
def spatial_library() -> ctypes.CDLL:
    """The kernel library with the spatial chain's functions (``grs_*``) declared.

    Declared apart from :func:`library`, so that a kernel compiled from the
    planar folders alone still loads for everything planar.
    """
    lib = library()
    for name, (restype, argtypes) in _SPATIAL_SIGNATURES.items():
        if not hasattr(lib, name):
            raise KernelMissing(f"{name}: this kernel was compiled without the spatial chain (fmu_src/kernel/spatial)")
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes
    return lib
