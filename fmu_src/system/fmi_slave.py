"""What every pythonfmu slave of the project shares: declared output dependencies,
the FMI call sequence enforced, errors logged instead of raised, its whole state
serialised as plain data for rollback, and a balanced reference count on the
slave script's namespace.

pythonfmu writes every output as depending on every input, which makes any
feedback loop through the FMU look algebraic to a master.  A slave that knows
better says so in :meth:`DeclaredDependencies.feedthrough` (output -> the inputs
it depends on at the same instant; an output it leaves out is a state), and its
model description's ModelStructure carries it.

Why nothing may raise
---------------------
pythonfmu 0.7's binary turns a Python exception in any call into fmi2Fatal and
releases the Python instance on the spot, so the importer's next call on that
instance reads freed memory.  So every entry point of a :class:`ProjectSlave`
(and of its subclasses: they are wrapped when the class is defined) catches
what it raises, logs it as fmi2Error and answers with a safe value.  The status
an importer sees is then the worst status logged during the call: the FMUs built
by :func:`grubler.controllers.fmu.build_controller_fmu` carry a thin C wrapper
around pythonfmu's binary that reports it (``controllers/status_wrapper.c``).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import threading

from pythonfmu import Boolean, Fmi2Slave, Integer, Real, String
from pythonfmu.enums import Fmi2Causality, Fmi2Status, Fmi2Variability

from grubler.system.fmu_loader import module_digest
from grubler.system.fmu_state import SlaveState, StateError, from_bytes, to_bytes


class DeclaredDependencies(Fmi2Slave):
    """A pythonfmu slave whose model description declares its outputs' dependencies."""

    def feedthrough(self) -> dict[str, list[str]]:
        """Output -> inputs it depends on at the same instant (default: none)."""
        return {}

    def to_xml(self, model_options=None):
        root = super().to_xml(model_options if model_options is not None else {})
        variables = root.findall("ModelVariables/ScalarVariable")
        index = {v.get("name"): str(k + 1) for k, v in enumerate(variables)}
        feed = self.feedthrough()
        for unknown in root.findall("ModelStructure/Outputs/Unknown"):
            deps = [index[i] for i in feed.get(variables[int(unknown.get("index")) - 1].get("name"), [])]
            unknown.set("dependencies", " ".join(deps))
            if deps:
                unknown.set("dependenciesKind", " ".join(["dependent"] * len(deps)))
        return root


# the phases of an instance, as FMI 2.0 co-simulation orders its calls
INSTANTIATED, INITIALISING, STEPPING, FAILED, TERMINATED = (
    "instantiated", "initialisation mode", "stepping", "failed initialisation", "terminated")
_BEFORE_STEPPING = (INSTANTIATED, INITIALISING)
# Not a variable: the value reference through which the status wrapper asks, right
# after fmi2DeSerializeFMUstate, whether the blob is refused (controllers/status_wrapper.c)
STATE_CHECK_VR = 0xFFFFFFFF
# the blob pythonfmu's class-level deserialisation hook saw last, per thread
_DESERIALISED = threading.local()
_KINDS = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}
# what a failed getter answers in place of a value, per type
_MISSING = {Real: math.nan, Integer: 0, Boolean: False, String: ""}
_CONVERT = {Real: float, Integer: int, Boolean: bool, String: str}


class ProjectSlave(DeclaredDependencies):
    """The base of the project's slaves.

    It enforces the FMI call sequence (a step before initialisation, after a
    failed one or after terminate is refused; a fixed parameter set after
    initialisation is refused and keeps its value; an output cannot be set),
    reports a failure recorded with :meth:`_fail` (in ``_error``) on every
    later step and output read, and owns the FMU state: a subclass returns
    its rollback payload from :meth:`_save_state` and takes it back in
    :meth:`_load_state`; the base wraps it with the instance's identity
    (model, code digest, parameter values) and serialises it with
    :mod:`grubler.system.fmu_state` (never pickle).  A state set before initialisation
    is applied when initialisation ends.

    Attributes
    ----------
    build_modules : dict
        Top-level module -> subpackages, whose content digests identify the
        code a state was taken with.
    """

    build_modules: dict[str, tuple[str, ...]] = {"grubler": ("motors", "controllers")}
    _error: str | None = None
    _start_time: float = 0.0
    _phase: str = INSTANTIATED
    _pending: SlaveState | None = None
    _entered: str | None = None  # the entry point being run (see _entry)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._fast_access: dict = {}

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        _guard(cls)

    def _fail(self, msg: str) -> None:
        self._error = msg
        self.log(msg, Fmi2Status.error)

    def _refused(self, msg: str) -> None:
        """Log a refused call (fmi2Error): the instance is unchanged."""
        self.log(msg, Fmi2Status.error)

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._start_time = float(start_time or 0.0)

    def enter_initialization_mode(self):
        pass

    def exit_initialization_mode(self):
        pass

    def do_step(self, current_time: float, step_size: float) -> bool:
        self._refused(f"{type(self).__name__} defines no do_step")
        return False

    def terminate(self):
        pass

    # -- state (subclasses) -------------------------------------------------------
    def _save_state(self):
        """Everything a rollback needs, as plain data (see :mod:`grubler.system.fmu_state`)."""
        return {}

    def _load_state(self, payload) -> None:
        """Take back what :meth:`_save_state` returned."""

    # -- identity -------------------------------------------------------------------
    def _identity(self) -> dict:
        build = hashlib.sha256()
        for name, subs in sorted(self.build_modules.items()):
            build.update(f"{name}:{module_digest(name, subs)};".encode())
        params = [(v.name, repr(v.getter())) for v in self.vars.values()
                  if v.causality == Fmi2Causality.parameter]
        return {"model": str(self.modelName), "build": build.hexdigest()[:32],
                "parameters": hashlib.sha256(json.dumps(params).encode()).hexdigest()[:32]}

    # -- pythonfmu's state hooks ------------------------------------------------------
    def _get_fmu_state(self):
        # serialised at once: a state that cannot be is refused now, in a call that can log
        try:
            return to_bytes(SlaveState(self._identity(), self._save_state()))
        except StateError as exc:
            self._refused(f"getFMUstate: {exc}")
            return b""

    def _set_fmu_state(self, state) -> None:
        try:
            restored = from_bytes(state)
        except (StateError, TypeError) as exc:
            self._refused(f"setFMUstate refused, the instance is unchanged: {exc}")
            return
        if self._phase in _BEFORE_STEPPING:
            self._pending = restored  # checked and applied when initialisation ends
            return
        try:
            restored.check(self._identity())
            self._restore(restored.payload)
        except StateError as exc:
            self._refused(f"setFMUstate refused, the instance is unchanged: {exc}")

    def _restore(self, payload) -> None:
        """:meth:`_load_state`, all or nothing: a payload that does not fit leaves the instance as it was.

        A blob's identity can be copied into a crafted one; its payload is plain
        data, so at worst it does not fit.
        """
        backup = self._save_state()
        try:
            self._load_state(payload)
        except Exception as exc:  # noqa: BLE001 - any misfit of plain data
            self._load_state(backup)
            raise StateError(f"state blob: its content does not fit this FMU ({type(exc).__name__}: {exc})") from None

    @staticmethod
    def _fmu_state_to_bytes(state) -> bytes:
        return bytes(state)  # the state is its blob already (see _get_fmu_state)

    @staticmethod
    def _fmu_state_from_bytes(state: bytes) -> bytes:
        # pythonfmu calls this on the class, which cannot log: the status wrapper
        # asks the instance next (STATE_CHECK_VR), and _set_fmu_state checks again
        _DESERIALISED.blob = bytes(state)
        return _DESERIALISED.blob

    def _check_deserialised(self) -> str:
        """Check the blob this thread last deserialised; log why it is refused ('' if it is not)."""
        blob, _DESERIALISED.blob = getattr(_DESERIALISED, "blob", None), None
        try:
            if blob is None:
                raise StateError("state blob: none was deserialised")
            restored = from_bytes(blob)
            if self._phase not in _BEFORE_STEPPING:  # before, parameters may still change
                restored.check(self._identity())
        except StateError as exc:
            self._refused(f"deSerializeFMUstate refused: {exc}")
            return str(exc)
        return ""

    # -- variables -----------------------------------------------------------------
    def _why_not_set(self, var) -> str | None:
        causality = var.causality
        if causality == Fmi2Causality.input:
            return None
        if causality == Fmi2Causality.parameter:
            if var.variability in (Fmi2Variability.fixed, None) and self._phase not in _BEFORE_STEPPING:
                return (f"{var.name} is a fixed parameter, set only before exitInitializationMode "
                        f"(the instance is {self._phase} and keeps {var.name} = {var.getter()!r})")
            return None
        what = causality.name if causality is not None else "local"
        return f"{var.name} is {'an' if what[0] in 'aeiou' else 'a'} {what} variable: only inputs and parameters can be set"

    def _fast(self, kind) -> tuple[dict, dict]:
        """Per type, once: value reference -> setter of each input, and -> getter of each variable.

        A master sets inputs and reads outputs every step: these take one
        dictionary lookup per value reference, the checks below only the rest.
        """
        tables = self._fast_access.get(kind)
        if tables is None:
            tables = self._fast_access[kind] = (
                {vr: v.setter for vr, v in self.vars.items()
                 if isinstance(v, kind) and v.causality == Fmi2Causality.input and v.setter is not None},
                {vr: v.getter for vr, v in self.vars.items() if isinstance(v, kind)})
        return tables

    def _set(self, kind, vrs, values) -> None:
        setters = self._fast(kind)[0]
        try:
            calls = [setters[vr] for vr in vrs]
        except KeyError:  # not all inputs of this type: check each, below
            pass
        else:
            for setter, value in zip(calls, values):
                setter(value)
            return
        problems = []
        for vr in vrs:
            var = self.vars.get(vr)
            if var is None:
                problems.append(f"no variable has value reference {vr}")
            elif not isinstance(var, kind):
                problems.append(f"{var.name} (value reference {vr}) is a {type(var).__name__}, not a {kind.__name__}")
            else:
                why = self._why_not_set(var) or (f"{var.name} cannot be set" if var.setter is None else None)
                if why:
                    problems.append(why)
        if problems:  # all or nothing
            self._refused(f"set{kind.__name__} refused, nothing was set: " + "; ".join(problems))
            return
        for vr, value in zip(vrs, values):
            self.vars[vr].setter(value)

    def _get(self, kind, vrs) -> list:
        convert = _CONVERT[kind]
        if self._phase != FAILED:
            getters = self._fast(kind)[1]
            try:
                calls = [getters[vr] for vr in vrs]
            except KeyError:  # an unknown reference or another type: check each, below
                pass
            else:
                return [convert(get()) for get in calls]
        out, problems = [], []
        for vr in vrs:
            var = self.vars.get(vr)
            if var is None or not isinstance(var, kind):
                problems.append(f"no {kind.__name__} variable has value reference {vr}")
                out.append(_MISSING[kind])
                continue
            if self._phase == FAILED and var.causality == Fmi2Causality.output:
                problems.append(f"{var.name} has no value: {self._error}")
                out.append(_MISSING[kind])
                continue
            try:
                out.append(convert(var.getter()))
            except Exception as exc:  # noqa: BLE001 - a getter must not take the importer down
                problems.append(f"{var.name}: {type(exc).__name__}: {exc}")
                out.append(_MISSING[kind])
        if problems:
            self._refused(f"get{kind.__name__}: " + "; ".join(problems))
        return out

    def set_real(self, vrs, values):
        self._set(Real, vrs, values)

    def set_integer(self, vrs, values):
        self._set(Integer, vrs, values)

    def set_boolean(self, vrs, values):
        self._set(Boolean, vrs, values)

    def set_string(self, vrs, values):
        self._set(String, vrs, values)

    def get_real(self, vrs):
        return self._get(Real, vrs)

    def get_integer(self, vrs):
        return self._get(Integer, vrs)

    def get_boolean(self, vrs):
        return self._get(Boolean, vrs)

    def get_string(self, vrs):
        # pythonfmu hands value references over as C ints: 0xFFFFFFFF arrives as -1
        if len(vrs) == 1 and vrs[0] & 0xFFFFFFFF == STATE_CHECK_VR:
            return [self._check_deserialised()]
        return self._get(String, vrs)


# -- the guards around every entry point pythonfmu's binary calls --------------------
def _plain(self, fn, *args):
    return fn(self, *args)


def _sequenced_do_step(self, fn, current_time, step_size):
    if self._phase != STEPPING:
        why = {INSTANTIATED: "before initialisation (call exitInitializationMode first)",
               INITIALISING: "in initialisation mode (call exitInitializationMode first)",
               TERMINATED: "after terminate",
               FAILED: f"after a failed initialisation: {self._error}"}[self._phase]
        self._refused(f"doStep refused {why}")
        return False
    return bool(fn(self, current_time, step_size))


def _sequenced_enter(self, fn):
    if self._phase != INSTANTIATED:
        self._refused(f"enterInitializationMode refused: the instance is {self._phase}")
        return None
    self._phase = INITIALISING
    return fn(self)


def _sequenced_exit(self, fn):
    if self._phase not in _BEFORE_STEPPING:
        self._refused(f"exitInitializationMode refused: the instance is {self._phase}")
        return None
    self._error = None
    try:
        fn(self)
    except Exception as exc:  # noqa: BLE001 - see the module docstring
        self._fail(f"initialisation failed: {type(exc).__name__}: {exc}")
    if self._error is None and self._pending is not None:
        pending, self._pending = self._pending, None
        try:
            pending.check(self._identity())
            self._restore(pending.payload)
        except StateError as exc:
            self._fail(f"initialisation failed: the state set before it is refused: {exc}")
    self._phase = FAILED if self._error is not None else STEPPING
    return None


def _sequenced_terminate(self, fn):
    self._phase = TERMINATED
    return fn(self)


def _nothing(self, *args):
    return None


def _missing_values(kind):
    return lambda self, vrs: [_MISSING[kind]] * len(vrs)


# entry point -> (what enforces the call sequence around it, what a failure answers)
_ENTRY_POINTS = {
    "setup_experiment": (_plain, _nothing),
    "enter_initialization_mode": (_sequenced_enter, _nothing),
    "exit_initialization_mode": (_sequenced_exit, _nothing),
    "do_step": (_sequenced_do_step, lambda self, t, h: False),
    "terminate": (_sequenced_terminate, _nothing),
    "_get_fmu_state": (_plain, lambda self: b""),
    "_set_fmu_state": (_plain, _nothing),
    **{f"set_{k.lower()}": (_plain, _nothing) for k in _KINDS},
    **{f"get_{k.lower()}": (_plain, _missing_values(v)) for k, v in _KINDS.items()},
}


def _entry(name: str, fn):
    """``fn`` behind the call sequence and a catch-all: an exception is logged as
    fmi2Error and a safe value answered.  A call made from inside another entry
    point (a subclass's ``super().get_real(...)``) runs ``fn`` as it is."""
    sequence, default = _ENTRY_POINTS[name]
    run = fn if sequence is _plain else functools.partial(_in_sequence, sequence, fn)

    @functools.wraps(fn)
    def entry(self, *args):
        if self._entered is not None:
            return fn(self, *args)
        self._entered = name
        try:
            return run(self, *args)
        except Exception as exc:  # noqa: BLE001 - raising would be fmi2Fatal and free the instance
            self.log(f"{name} failed: {type(exc).__name__}: {exc}", Fmi2Status.error)
            return default(self, *args)
        finally:
            self._entered = None

    entry._entry_point = True
    return entry


def _in_sequence(sequence, fn, self, *args):
    return sequence(self, fn, *args)


def _guard(cls) -> None:
    """Put the entry points ``cls`` defines itself behind :func:`_entry`."""
    for name in _ENTRY_POINTS:
        fn = cls.__dict__.get(name)
        if fn is not None and not getattr(fn, "_entry_point", False):
            setattr(cls, name, _entry(name, fn))


_guard(ProjectSlave)


def balance_loader_reference(namespace: dict) -> None:
    """Take the reference to a slave script's namespace that pythonfmu 0.7 gives back.

    pythonfmu 0.7's loader executes the slave script at every instantiation in
    the module's namespace and then releases a reference to that namespace it
    never took.  A script whose namespace few objects refer to (a thin slave) is
    freed under the loader by the second instance (a segfault in
    fmi2Instantiate); a larger one is merely left with a count that is too low.
    Every slave script calls this once per execution: one reference taken for
    the one released.
    """
    namespace.setdefault("_loader_references", []).append(namespace)


__all__ = ["DeclaredDependencies", "ProjectSlave", "STATE_CHECK_VR", "balance_loader_reference"]
