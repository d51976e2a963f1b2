"""A co-simulation master on fmpy: runs an SSP system of FMI 2.0 co-simulation FMUs.

What it does that a bare loop does not:

- checks the system before running it: every connection's ends exist, run from
  an output to an input of the same type and a compatible unit, no input is fed
  twice, every parameter exists; each problem is reported by name;
- orders the components (Gauss-Seidel by default): a component steps after the
  components whose outputs it reads, so it sees their values at the end of the
  step.  A feedback loop is cut where an output does not depend on its
  component's inputs at the same instant (a state: the mechanism's angle and
  rate); a loop with no such output is algebraic and reported by name;
- initialises coupled inputs consistently, in that same order, during the FMUs'
  initialisation mode, instead of starting every connector at zero;
- reads the FMUs' outputs in one call per component and sets inputs through
  preallocated buffers, and makes the communication steps' FMI calls from a C
  loop (system/c/master.c), so the master's own cost per step is small;
- reports a failed step with the FMU's own logged message, and frees every FMU.

Examples
--------
>>> from grubler.system.ssp import System
>>> s = System("empty")
>>> check(s, {}) == []
True
"""

from __future__ import annotations

import csv
import ctypes
import math
import os
import re
import threading
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from grubler.errors import Cancelled, GrublerError, InputError
from grubler.limits import (MAX_STEPS, brief, check_count, check_size, clip, did_you_mean, extract_zip, remove_temp_dir,
                     temp_dir)
from grubler.system.interface import FmuInterface, Port, generic_unit, units_compatible
from grubler.system.ssp import System, SystemDescriptionError, read

GAUSS_SEIDEL = "gauss-seidel"
JACOBI = "jacobi"
MASTERS = (GAUSS_SEIDEL, JACOBI)


class CosimError(GrublerError):
    """A co-simulation that failed while running: names the component and time."""


# string parameters of the pythonfmu plant FMUs that the native ones replace by
# their quantities: what an SSD written for those should set instead
_RETIRED = {
    "mechanism": " (the native Mechanism.fmu takes the scene's quantities as parameters: "
                 "grubler.fmi.mechanism.fmu_parameters(scene) gives them; rewrite the system with grubler.system.servo "
                 "or set them)",
    "motor": " (the native DCMotor.fmu takes the data set's numbers as parameters: "
             "grubler.fmi.motor.motor_parameters(name) gives them)",
}


# -- checking and ordering -----------------------------------------------------------
def _settable(itf: FmuInterface) -> list[str]:
    """The variables a system file may set on this FMU."""
    return [k for k, v in itf.ports.items() if v.causality in ("parameter", "input")]


def check(system: System, interfaces: dict[str, FmuInterface]) -> list[str]:
    """Every reason the system cannot run, one line each (empty: it can)."""
    problems = []
    fed: dict[str, str] = {}
    for name, comp in system.components.items():
        itf = interfaces.get(name)
        if itf is None:
            continue
        for p, value in comp.parameters.items():
            port = itf.ports.get(p)
            if port is None:
                ours = (getattr(itf.model_description, "generationTool", "") or "").startswith("grubler")
                hint = (_RETIRED.get(p, "") if ours else "") or did_you_mean(p, _settable(itf))
                problems.append(f"parameter {name}.{p}: {itf.path.name} has no variable {p!r}{hint}")
            elif port.causality not in ("parameter", "input"):
                problems.append(f"parameter {name}.{p}: it is an {port.causality}, not a parameter")
        for c, unit in comp.units.items():
            if c not in itf.ports:
                problems.append(f"connector {name}.{c}: {itf.path.name} has no variable "
                                f"{c!r}{did_you_mean(c, itf.ports)}")
    for c in system.connections:
        ends = []
        for elem, conn, want, role in ((c.start_element, c.start_connector, ("output",), "start"),
                                       (c.end_element, c.end_connector, ("input",), "end")):
            if elem not in system.components:
                problems.append(f"dangling connection {c.start} -> {c.end}: no component {elem!r}")
                ends.append(None)
                continue
            itf = interfaces.get(elem)
            port = itf.ports.get(conn) if itf else None
            if itf is not None and port is None:
                choices = [k for k, v in itf.ports.items() if v.causality in want]
                problems.append(f"dangling connection {c.start} -> {c.end}: {elem} ({itf.path.name}) "
                                f"has no variable {conn!r}{did_you_mean(conn, choices)}")
            elif port is not None and port.causality not in want:
                problems.append(f"connection {c.start} -> {c.end}: {elem}.{conn} is a {port.causality}, "
                                f"the {role} of a connection must be an {want[0]}")
            ends.append(port)
        if c.end in fed:
            problems.append(f"input {c.end} is fed twice: by {fed[c.end]} and by {c.start}")
        fed[c.end] = c.start
        a, b = ends
        if a is not None and b is not None:
            if a.type != b.type:
                problems.append(f"type mismatch {c.start} -> {c.end}: {a.type} to {b.type}")
            ua = system.components[c.start_element].units.get(c.start_connector, a.unit)
            ub = system.components[c.end_element].units.get(c.end_connector, b.unit)
            if not units_compatible(ua, ub):
                problems.append(f"unit mismatch {c.start} -> {c.end}: [{ua}] to [{ub}]")
    return problems


def _depends_now(interfaces: dict[str, FmuInterface], elem: str, output: str) -> bool:
    itf = interfaces[elem]
    deps = itf.feedthrough.get(output)
    if deps is None:  # undeclared: FMI says it may depend on every input
        return any(p.causality == "input" for p in itf.ports.values())
    return bool(deps)


def order(system: System, interfaces: dict[str, FmuInterface]) -> list[str]:
    """Gauss-Seidel order: a component after those whose outputs it reads.

    Where a feedback loop leaves no component ready, the first one (in the
    system's own order) whose pending inputs all come from outputs that do not
    depend on an input at the same instant (states: the mechanism's angle, a
    sampled controller's held output) goes next, reading those outputs from the
    last communication point.  A loop with no such component is algebraic: every
    output on it depends on an input now, and it is reported by name.
    """
    names = list(system.components)
    edges = [(c.start_element, c.end_element, c.start_connector) for c in system.connections
             if c.start_element != c.end_element]
    placed: list[str] = []
    while len(placed) < len(names):
        left = [n for n in names if n not in placed]
        pending = {n: [(a, o) for a, b, o in edges if b == n and a not in placed] for n in left}
        ready = [n for n in left if not pending[n]]
        if not ready:
            ready = [n for n in left if all(not _depends_now(interfaces, a, o) for a, o in pending[n])]
        if not ready:
            loop = [f"{c.start} -> {c.end}" for c in system.connections
                    if c.start_element in left and c.end_element in left]
            raise SystemDescriptionError("algebraic loop: every output on it depends on an input at the same "
                                         "instant, so no order can break it: " + "; ".join(loop))
        placed.append(ready[0])
    return placed


# -- what a step may be -----------------------------------------------------------------
@dataclass(frozen=True)
class TimeScale:
    """A time a component declares or implies, which a communication step should not exceed."""

    component: str
    what: str  # e.g. "sample time Ts", "mechanical time constant J_rotor R / (k_t k_e)"
    seconds: float
    consequence: str  # what a longer step does to it


def _value(system: System, itf: FmuInterface, component: str, name: str) -> float | None:
    """A Real parameter's value in the system (else the FMU's start value); None if it has none."""
    v = system.components[component].parameters.get(name)
    if v is None:
        var = next((x for x in itf.model_description.modelVariables if x.name == name), None)
        v = None if var is None else var.start
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _motor_time_scales(system: System, itf: FmuInterface, name: str) -> list[TimeScale]:
    # grubler's DCMotor.fmu solves its winding exactly over any step (v and the speed
    # held), so its electrical pole L/R sets no bound; the speed it holds does
    from grubler.fmi.motor import DATA
    from grubler.motors.motor_data import MotorData

    values = {k: _value(system, itf, name, k) for k in DATA}
    if any(v is None for v in values.values()):
        return []
    try:
        data = MotorData(name=name, source="the system's parameters", **values)
    except GrublerError:
        return []  # the FMU refuses them itself, by name, when it is set up
    return [TimeScale(name, "mechanical time constant J_rotor R / (k_t k_e)", data.mechanical_time_constant,
                      "it holds the shaft speed over a step, so its back-EMF damping acts a step late and the "
                      "coupled motion can ring or diverge")]


# time scales implied by the parameters of grubler's own FMUs, by model identifier
_IMPLIED = {"DCMotor": _motor_time_scales}


def time_scales(system: System, interfaces: dict[str, FmuInterface]) -> list[TimeScale]:
    """The times the system's components declare or imply, which its communication step should not exceed.

    A parameter described as a ``sample time`` (unit s; 0 means once per step) is
    one: a component that samples faster than it is stepped reads inputs held
    over the step.  grubler's DCMotor.fmu implies its mechanical time constant.
    """
    out = []
    for name, itf in interfaces.items():
        for port in itf.ports.values():
            if port.causality == "parameter" and port.type == "Real" and \
                    port.description.lower().startswith(("sample time", "sampling time", "sample period")):
                ts = _value(system, itf, name, port.name)
                if ts is not None and ts > 0:
                    out.append(TimeScale(name, f"sample time {port.name}", ts,
                                         "it reads its inputs once per step and samples them held over it, so a "
                                         "loop through it acts on feedback as old as the step"))
        implied = _IMPLIED.get(itf.model_description.coSimulation.modelIdentifier)
        if implied is not None and (getattr(itf.model_description, "generationTool", "") or "").startswith("grubler"):
            out += implied(system, itf, name)
    return out


def step_warnings(step: float, scales: list[TimeScale]) -> list[str]:
    """One warning line per time scale the communication step exceeds."""
    return [f"step: {step:g} s is longer than {s.component}'s {s.what} = {s.seconds:.3g} s: {s.consequence}; "
            f"use a step of at most {s.seconds:.3g} s" for s in scales if step > s.seconds * (1 + 1e-9)]


# -- running -------------------------------------------------------------------------
@dataclass
class CosimResult:
    """Recorded outputs of a co-simulation.

    ``result['mechanism.theta2']`` is a column; ``columns`` lists them in order.
    ``warnings`` says, one line each, where the communication step exceeds a time
    a component declares or implies (:func:`time_scales`).
    """

    t: np.ndarray
    columns: list[str]
    data: np.ndarray  # (len(t), len(columns))
    system: System
    order: list[str]
    master: str
    step: float
    wall_time: float
    units: dict[str, str] = field(default_factory=dict)
    messages: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)  # why the result may not be trusted, one line each
    profile: dict[str, tuple[float, float, float]] = field(default_factory=dict)  # run(..., profile=True)

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "t":
            return self.t
        try:
            return self.data[:, self.columns.index(name)]
        except ValueError:
            raise KeyError(f"no recorded signal {name!r}") from None

    def to_csv(self, path: str | Path) -> None:
        """Every recorded signal, headed ``component.output [unit]`` (see :func:`grubler.records.column_heading`)."""
        from grubler.records import column_heading

        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["t [s]"] + [column_heading(c, self.units.get(c, "")) for c in self.columns])
            for t, row in zip(self.t, self.data):
                w.writerow([repr(float(t))] + [repr(float(x)) for x in row])

    def plot(self, path: str | Path) -> None:
        """Draw :meth:`panels` to ``path``, sharing the time axis."""
        from grubler.views.plotting import plot_panels

        plot_panels(self.t, self.panels(), path, title=f"{self.system.name}: {self.master}, step {self.step:g} s",
                    limits=self.limits())

    def limits(self) -> dict[str, list[tuple[str, float]]]:
        """The power stage's limits by panel title: +-supply over a motor's voltage, +-limit over its current,
        and a pneumatic cylinder's supply pressure over its chambers'.

        A motor is a component with ``supply_voltage`` and ``current_limit``
        parameters (the DC motor FMU's); a limit of 0 or less is none.  A cylinder
        given its ``supply_pressure`` (the pneumatic FMU's) has it drawn as a line.
        """
        bounds = {}
        for name, comp in self.system.components.items():
            p = comp.parameters
            for param, signals, words in (("supply_voltage", ("voltage", "terminal_voltage"), "supply voltage"),
                                          ("current_limit", ("current",), "current limit")):
                value = p.get(param)
                if isinstance(value, (int, float)) and not isinstance(value, bool) and 0 < value < math.inf:
                    unit = "V" if param == "supply_voltage" else "A"
                    for sig in signals:
                        bounds[f"{name}.{sig}"] = (f"±{value:g} {unit} {words}" + (f" ({name})" if name != "motor"
                                                                                      else ""), float(value))
        from grubler.views.plotting import BAR, supply_pressures

        for name, value in supply_pressures(self.system).items():  # a given supply: the chambers' reference
            for sig in ("pressure_a", "pressure_b"):
                bounds[f"{name}.{sig}"] = (f"{value / BAR:g} bar supply" + (f" ({name})" if name != "cylinder"
                                                                              else ""), value)
        out: dict[str, list[tuple[str, float]]] = {}
        for p in self.system.plots or _default_panels(self):
            lines = list(dict.fromkeys(bounds[s] for s in p.signals if s in bounds and not p.difference))
            if lines:
                out[p.title] = lines
        return out

    def panels(self) -> list[tuple[str, list[tuple[str, np.ndarray, str]]]]:
        """One panel per plot in the system (default: connected signals by unit).

        Each is ``(axis label, [(legend, values, unit), ...])``. Legends are the
        plots' words for their signals (default: the FMU's description of the
        variable); a difference plot has one curve, the first signal minus the
        second.
        """
        panels = self.system.plots or _default_panels(self)
        rows = []
        for p in panels:
            sig = [s for s in p.signals if s in self.columns]
            if p.difference:
                if len(sig) != 2:
                    continue  # a signal it needs was not recorded
                words = p.labels.get("difference", f"{sig[0]} - {sig[1]}")
                lines = [(words, self[sig[0]] - self[sig[1]], self.units.get(sig[0], ""))]
            else:
                lines = [(p.labels.get(s, s), self[s], self.units.get(s, "")) for s in sig]
            rows.append((p.title, lines))
        return rows


def _default_panels(res: CosimResult):
    """The connected outputs, one panel per unit, labelled by their FMUs' descriptions."""
    from grubler.system.ssp import Plot

    words: dict[str, str] = {}
    for name, comp in res.system.components.items():
        try:
            ports = FmuInterface.of(res.system.source_path(comp)).ports
        except Exception:  # noqa: BLE001 - no FMU to describe it: the legend keeps the name
            continue
        for port in ports.values():
            text = re.sub(r"\s*\[[^\]]*\]\s*$", "", port.description or "")
            if text:
                words[f"{name}.{port.name}"] = f"{text} ({name})"
    by_unit: dict[str, list[str]] = {}
    for c in res.system.connections:
        unit = res.units.get(c.start, "") or "-"
        if c.start not in by_unit.setdefault(unit, []):
            by_unit[unit].append(c.start)
    return [Plot(f"[{u}]", s, {x: words[x] for x in s if x in words}) for u, s in by_unit.items()]


_STATUS = {2: "discard", 3: "error", 4: "fatal", 5: "pending"}
_CHUNK = 1000  # communication steps per call of the C loop when nothing is to be read between steps


class _Instance:
    """One instantiated FMU with the master's preallocated buffers."""

    def __init__(self, name, itf: FmuInterface, unzipdir: str, start_time: float):
        from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

        md = itf.model_description
        self.name, self.itf, self.messages = name, itf, []
        cwd = os.getcwd()
        try:
            self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                                 modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        except Exception as exc:  # noqa: BLE001 - fmpy wraps the loader's OSError in a bare Exception
            os.chdir(cwd)  # fmpy loads from the binary's folder and stays there when that fails
            # the loader's own words (e.g. 'wrong ELF class: ELFCLASS32'), after the extraction's path
            why = str(exc.__context__ if isinstance(exc.__context__, OSError) else exc)
            why = why.rpartition(f"{Path(unzipdir).name}/binaries/")[2].partition(": ")[2] or why
            raise CosimError(f"{name}: the binary of {itf.path.name} cannot be loaded: {clip(why)}") from None

        def logger(component, instance_name, status, category, message):
            self.messages.append(f"{name}: {message.decode(errors='replace')}")

        # callbacks of its own, from instantiation on: an FMU keeps the pointer it is given
        # (fmpy's default struct is shared by every instance), and what it logs while it is
        # instantiated says why it could not be
        self._logger = fmi2CallbackLoggerTYPE(logger)  # keep a reference: C holds the pointer
        self._callbacks = fmi2CallbackFunctions(logger=self._logger, allocateMemory=defaultCallbacks.allocateMemory,
                                                freeMemory=defaultCallbacks.freeMemory)
        try:
            self.fmu.instantiate(loggingOn=True, callbacks=self._callbacks)
        except Exception:  # noqa: BLE001 - fmpy says only "Failed to instantiate model"
            raise CosimError(f"{name}: {itf.path.name} could not be instantiated" + _last_message(self)) from None
        self.fmu.setupExperiment(startTime=start_time)
        self.bind_calls()

    def set_parameters(self, params: dict):
        f, ports = self.fmu, self.itf.ports
        for p, v in params.items():
            port = ports[p]
            if port.type == "Real":
                f.setReal([port.vr], [float(v)])
            elif port.type in ("Integer", "Enumeration"):
                f.setInteger([port.vr], [int(v)])
            elif port.type == "Boolean":
                f.setBoolean([port.vr], [bool(v)])
            else:
                f.setString([port.vr], [str(v)])

    def wire(self, inputs: list[tuple[int, int]], outputs: list[tuple[int, int]], recorded: list[int]):
        """Inputs and connected outputs as (value reference, slot), the recorded value references."""
        n = len(inputs)
        self.in_vr = (ctypes.c_uint * n)(*[vr for vr, _ in inputs])
        self.in_slot = (ctypes.c_int * n)(*[s for _, s in inputs])
        self.in_buf = (ctypes.c_double * n)()
        self.n_in = n
        conn = [vr for vr, _ in outputs]
        self.out_slots = (ctypes.c_int * len(outputs))(*[s for _, s in outputs])
        reads = list(dict.fromkeys(conn + recorded))  # connected first, then the rest recorded
        self.read_vr = (ctypes.c_uint * len(reads))(*reads)
        self.read_buf = (ctypes.c_double * len(reads))()
        self.n_read = len(reads)
        self.n_conn = len(outputs)
        self.conn_vr = (ctypes.c_uint * len(outputs))(*conn)

    def bind_calls(self) -> None:
        """The FMU's C functions themselves: fmpy's wrappers cost more than a step here."""
        # the library's own function objects (ctypes keeps one per name), to which
        # fmpy gave their argument types: every fmpy since 0.3.20 does
        dll = self.fmu.dll
        self._c = self.fmu.component
        self._set, self._get, self._step = dll.fmi2SetReal, dll.fmi2GetReal, dll.fmi2DoStep

    def push(self, values: list[float]) -> None:
        if self.n_in:
            buf = self.in_buf
            for i, s in enumerate(self.in_slot):
                buf[i] = values[s]
            self._check(self._set(self._c, self.in_vr, self.n_in, buf), "fmi2SetReal")

    def pull(self, everything: bool) -> ctypes.Array:
        n = self.n_read if everything else self.n_conn
        if n:
            self._check(self._get(self._c, self.read_vr if everything else self.conn_vr, n, self.read_buf),
                        "fmi2GetReal")
        return self.read_buf

    def publish(self, values: list[float], everything: bool = False) -> None:
        """Read the outputs (and, with ``everything``, the recorded ones) into the connection slots."""
        buf = self.pull(everything)
        for i, s in enumerate(self.out_slots):
            values[s] = buf[i]

    def _check(self, status: int, what: str) -> None:
        if status > 1:
            raise self.refused(what, status)

    def refused(self, what: str, status: int) -> CosimError:
        """The error of a call this FMU refused, with the last message it logged."""
        return CosimError(f"{self.name}: {what} failed (status {_STATUS.get(status, status)})" + _last_message(self))

    def loop_view(self, seconds: int | None) -> "binding.MasterFmu":
        """This instance as the C stepping loop sees it (``seconds``: where it sums its call times, or None)."""
        from grubler import binding

        def at(fn) -> int:
            return ctypes.cast(fn, ctypes.c_void_p).value

        return binding.MasterFmu(self._c, at(self._set), at(self._get), at(self._step), self.n_in,
                                 ctypes.addressof(self.in_vr), ctypes.addressof(self.in_slot),
                                 ctypes.addressof(self.in_buf), self.n_conn, self.n_read,
                                 ctypes.addressof(self.read_vr), ctypes.addressof(self.read_buf),
                                 ctypes.addressof(self.out_slots), seconds)

    def free(self):
        for call in (self.fmu.terminate, self.fmu.freeInstance):
            try:
                call()
            except Exception:  # noqa: BLE001 - freeing must go on for the others
                pass


def run(system: System | str | Path, t_end: float | None = None, step: float | None = None,
        start_time: float | None = None, master: str = GAUSS_SEIDEL, record: list[str] | None = None,
        record_every: int = 1, step_order: list[str] | None = None, cancel=None,
        unpacked: "UnpackedFMUs | None" = None, profile: bool = False) -> CosimResult:
    """Co-simulate a system with a fixed communication step.

    Parameters
    ----------
    system : System or path of a .ssd / .ssp
    t_end, step, start_time : float, optional
        Default to the system's DefaultExperiment and grubler annotation
        (``t_end`` 1 s, ``step`` 1 ms, ``start_time`` 0 when neither says).
    master : {'gauss-seidel', 'jacobi'}
        Jacobi steps every FMU on the previous step's values (what
        ``fmpy.ssp.simulate_ssp`` does), for comparison: every connection then
        adds a step of delay, and a feedback loop through it loses accuracy
        (the servo four-bar's crank at 1 ms: 27 times further from a monolithic
        reference than Gauss-Seidel's, docs/cosim.md).  Its order does not matter.
    record : list of str, optional
        ``'component.variable'`` outputs to record (default: every output of
        every component).  Fewer recorded outputs is less work for FMUs that
        compute outputs only when read.
    record_every : int
        Record every n-th communication point (the first and last always).
    step_order : list of str, optional
        Stepping order of the components (default: the system's own, else
        :func:`order`'s).  A sampled controller reads its inputs at the start of
        a step, so it is best stepped before the components that feed it
        continuous values (the mechanism, a trajectory), and after a sampled
        component that feeds it (an encoder).
    cancel : threading.Event, optional
        Read between communication steps: once set, the run stops with
        :class:`grubler.errors.Cancelled` and every FMU is freed (an app's
        cancel button, a new run that replaces this one).
    unpacked : UnpackedFMUs, optional
        Where the FMUs are unpacked and kept for later runs (default: unpacked
        for this run alone and removed after it).
    profile : bool
        Time each component's setReal, doStep and getReal calls of the
        communication steps (the result's ``profile``: seconds by component;
        the clock readings add a little to the run).

    Returns
    -------
    CosimResult
        Its ``warnings`` name every time scale the step exceeds (:func:`time_scales`).

    Raises
    ------
    Cancelled
        When ``cancel`` was set during the run.
    """
    if not isinstance(system, System):
        system = read(system)
    t0 = start_time if start_time is not None else (system.start_time or 0.0)
    t_end = t_end if t_end is not None else (system.stop_time if system.stop_time is not None else 1.0)
    step = step if step is not None else (system.step if system.step is not None else 1e-3)
    for name, v in (("t_end", t_end), ("step", step), ("start_time", t0)):
        if not math.isfinite(v):
            raise SystemDescriptionError(f"{name}: must be finite, got {v}")
    if not step > 0:
        raise SystemDescriptionError(f"step: must be positive, got {step}")
    if t_end <= t0:
        raise SystemDescriptionError(f"t_end: {t_end} must be after the start time {t0}")
    if master not in MASTERS:
        raise SystemDescriptionError(f"master: must be one of {', '.join(MASTERS)}, got {brief(master)}")
    if not (isinstance(record_every, int) and record_every >= 1):
        raise SystemDescriptionError(f"record_every: must be a whole number >= 1, got {brief(record_every)}")
    if not system.components:
        raise SystemDescriptionError(f"system {brief(system.name)}: has no components")
    own = unpacked is None  # each FMU unpacked once, into a folder removed on the way out
    unzipped = UnpackedFMUs() if own else unpacked
    try:
        return _run(system, t0, t_end, step, master, record, int(record_every), step_order, unzipped, cancel,
                    profile)
    finally:
        if own:
            unzipped.close()


class UnpackedFMUs:
    """FMUs unpacked once and kept for the runs that follow (an app that re-runs one system).

    A run given one reuses an FMU's folder while the file is unchanged (its
    size and modification time), and unpacks it again when it changed;
    :meth:`close` removes every folder. Threads may share one.

    Examples
    --------
    >>> with UnpackedFMUs() as unpacked:
    ...     pass        # cosim.run(system, unpacked=unpacked), as often as wanted
    """

    def __init__(self):
        self._folders: dict[Path, tuple[tuple[int, int], Path]] = {}
        self._old: list[Path] = []  # replaced folders: a run may still use one, so they go at close
        self._lock = threading.Lock()

    def folder(self, path: Path, field: str, where: str) -> Path:
        """The folder holding the FMU at ``path`` unpacked (refusals name ``field``)."""
        st = path.stat()
        stamp = (st.st_size, st.st_mtime_ns)
        with self._lock:
            hit = self._folders.get(path)
        if hit is not None and hit[0] == stamp:
            return hit[1]
        folder = temp_dir("grubler_fmu_")
        extract_zip(path, folder, field, where=where)
        with self._lock:
            old = self._folders.get(path)
            self._folders[path] = (stamp, folder)
            if old is not None:
                self._old.append(old[1])
        return folder

    def __getitem__(self, path: Path) -> Path:
        return self._folders[path][1]

    def close(self) -> None:
        """Remove every folder."""
        with self._lock:
            folders = [f for _, f in self._folders.values()] + self._old
            self._folders, self._old = {}, []
        for f in folders:
            remove_temp_dir(f)

    def __enter__(self) -> "UnpackedFMUs":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def interfaces_of(system: System, unzipped: "UnpackedFMUs") -> dict[str, FmuInterface]:
    """Every component's interface, its FMU unpacked in ``unzipped``, once the system is checked.

    Raises
    ------
    SystemDescriptionError
        Naming every problem :func:`check` finds, and every FMU that is missing or unreadable.
    """
    interfaces = {}
    problems = []
    for name, comp in system.components.items():
        path = system.source_path(comp)
        if not path.is_file():
            problems.append(f"component {name}: FMU {clip(str(path), 240)} not found (run python build_fmu.py?)")
            continue
        try:
            folder = unzipped.folder(path, f"component {name}", clip(comp.source))
            if not (folder / "modelDescription.xml").is_file():
                problems.append(f"component {name}: {clip(comp.source)} is not an FMU (no modelDescription.xml)")
                continue
            itf = FmuInterface.of(path, folder)
            if itf.model_description.fmiVersion != "2.0":
                problems.append(f"component {name}: {brief(path.name)} is an FMI {itf.model_description.fmiVersion} "
                                "FMU; this master runs FMI 2.0 co-simulation FMUs (build it as FMI 2.0)")
                continue
            interfaces[name] = itf
        except InputError as exc:
            problems.append(f"component {name}: cannot read {exc.reason}")
        except Exception as exc:  # noqa: BLE001 - a broken FMU is one of the problems listed
            problems.append(f"component {name}: cannot read {brief(path.name)}: {clip(str(exc), 200)}")
    problems += check(system, interfaces)
    if problems:
        raise SystemDescriptionError(f"system {brief(system.name)}: cannot run, {len(problems)} "
                                     f"problem{'s' if len(problems) > 1 else ''}:\n  " + "\n  ".join(problems))
    return interfaces


def _run(system: System, t0: float, t_end: float, step: float, master: str, record, record_every: int,
         step_order, unzipped: "UnpackedFMUs", cancel=None, profile: bool = False) -> CosimResult:
    interfaces = interfaces_of(system, unzipped)
    seq = order(system, interfaces)  # also what finds an algebraic loop
    warnings = step_warnings(step, time_scales(system, interfaces))
    chosen = step_order if step_order is not None else system.order
    if chosen:
        chosen = list(chosen)
        if sorted(chosen) != sorted(system.components):
            raise SystemDescriptionError(f"order {' '.join(chosen)}: must name every component once "
                                         f"({' '.join(system.components)})")
        seq = chosen
    record_set = None if record is None else []
    connected_inputs = {c.end for c in system.connections}
    for r in record or ():
        el, _, var = r.partition(".")
        port = interfaces.get(el).ports.get(var) if el in interfaces else None
        if r in connected_inputs:
            continue  # recorded anyway, from the output that feeds it
        if port is None or port.causality != "output":
            raise SystemDescriptionError(f"record {r!r}: not an output of a component, nor a connected input")
        record_set.append(r)

    slot = _slots(system)
    values = (ctypes.c_double * max(1, len(slot)))()  # the C loop reads and writes them
    units = {}
    columns: list[str] = []
    col_src: list[tuple[str, int]] = []  # (component, index in its read buffer)
    wall0 = _time.perf_counter()
    insts: dict[str, _Instance] = {}
    try:
        for name in seq:
            itf = interfaces[name]
            outs = [p for p in itf.ports.values() if p.causality == "output" and p.type == "Real"]
            rec = [p.name for p in outs] if record_set is None else [
                r.split(".", 1)[1] for r in record_set if r.split(".", 1)[0] == name]
            reads = _set_up(insts, system, itf, name, unzipped, t0, slot, rec)
            for i, o in enumerate(reads):
                if o in rec:
                    columns.append(f"{name}.{o}")
                    col_src.append((name, i))
                units[f"{name}.{o}"] = system.components[name].units.get(o, itf.ports[o].unit)
        _initialise_all(insts, seq, values, t0)

        # connected inputs are recorded too: their value is the output feeding them
        for c in system.connections:
            if c.end not in units:
                columns.append(c.end)
                col_src.append(("", slot[c.start]))
                declared = system.components[c.end_element].units.get(
                    c.end_connector, interfaces[c.end_element].ports[c.end_connector].unit)
                units[c.end] = units.get(c.start, "") if generic_unit(declared) else declared
        for c in system.connections:  # a generic output (a controller's "any") is in what it feeds
            if generic_unit(units.get(c.start, "")) and not generic_unit(units.get(c.end, "")):
                units[c.start] = units[c.end]
        n_steps = check_count(math.floor((t_end - t0) / step + 1e-9), MAX_STEPS, "communication steps",
                              "t_end or step (--t-end, --step)")
        if t0 + n_steps * step < t_end - 1e-9 * step:
            n_steps += 1  # a last, shorter step lands on t_end
        n_rec = check_size(n_steps // record_every + 2, 8 * (len(columns) + 1), "the recorded table",
                           "t_end, step or record_every (--t-end, --step, --dt-out)")
        times = np.empty(n_rec)
        data = np.empty((n_rec, len(columns)))
        # the first row, after initialisation with the inputs consistent; then the C loop steps and records
        for name in seq:
            insts[name].publish(values, True)
        seq_insts = [insts[n] for n in seq]
        column_fmu = [seq.index(c) if c else -1 for c, _ in col_src]
        times[0] = t0
        for j, (c, i) in enumerate(col_src):
            data[0, j] = insts[c].read_buf[i] if c else values[i]
        loop = _Loop(seq_insts, values, master, t0, step, t_end, n_steps, record_every, column_fmu,
                     [i for _, i in col_src], times, data, profile)
        # the flag, if any, is read before each communication step; without one the
        # loop returns to Python every _CHUNK steps, where a Ctrl-C is raised
        chunk = 1 if cancel is not None else _CHUNK
        for n in range(0, n_steps, chunk):
            if cancel is not None and cancel.is_set():
                raise Cancelled("run", f"cancelled at t = {loop.t.value:.6g} s")
            loop.steps(n, chunk)
        k = loop.row.value
        wall = _time.perf_counter() - wall0
        messages = [m for inst in insts.values() for m in inst.messages]
        return CosimResult(times[:k].copy(), columns, data[:k].copy(), system, seq, master, step, wall, units,
                           messages, warnings, loop.profile(seq))
    finally:
        for inst in insts.values():
            inst.free()


def _slots(system: System) -> dict[str, int]:
    """One value slot per connected output, by ``component.output``."""
    slot: dict[str, int] = {}
    for c in system.connections:
        slot.setdefault(c.start, len(slot))
    return slot


def _set_up(insts: dict[str, _Instance], system: System, itf: FmuInterface, name: str, unzipped: "UnpackedFMUs",
            t0: float, slot: dict[str, int], recorded: list[str]) -> list[str]:
    """Instantiate ``name`` into ``insts``, set its parameters and wire it; returns the outputs it reads.

    The connected outputs come first in what it reads, then the rest of ``recorded``.
    """
    inst = insts[name] = _Instance(name, itf, str(unzipped[itf.path]), t0)  # in insts at once: freed on failure
    _call(inst, "set parameters", lambda: inst.set_parameters(system.components[name].parameters), t0)
    conn_out = list(dict.fromkeys(c.start_connector for c in system.connections if c.start_element == name))
    inputs = [(itf.ports[c.end_connector].vr, slot[c.start]) for c in system.connections if c.end_element == name]
    inst.wire(inputs, [(itf.ports[o].vr, slot[f"{name}.{o}"]) for o in conn_out], [itf.ports[o].vr for o in recorded])
    return list(dict.fromkeys(conn_out + recorded))


def _initialise_all(insts: dict[str, _Instance], seq: list[str], values, t0: float) -> None:
    """Initialisation mode from enter to exit, the coupled inputs settled in between."""
    for inst in insts.values():
        _call(inst, "enter initialisation mode", inst.fmu.enterInitializationMode, t0)
    _initialise(insts, seq, values, t0)
    for inst in insts.values():
        _call(inst, "exit initialisation mode", inst.fmu.exitInitializationMode, t0)


def initial_inputs(system: System, interfaces: dict[str, FmuInterface], unzipped: "UnpackedFMUs",
                   t0: float = 0.0) -> dict[str, float]:
    """The coupled inputs' values once initialisation settles, by ``component.input``: what a run starts from.

    Every FMU is instantiated, initialised as :func:`run` does it, and freed.
    """
    seq = order(system, interfaces)
    slot = _slots(system)
    values = (ctypes.c_double * max(1, len(slot)))()  # the C loop reads and writes them
    insts: dict[str, _Instance] = {}
    try:
        for name in seq:
            _set_up(insts, system, interfaces[name], name, unzipped, t0, slot, [])
        _initialise_all(insts, seq, values, t0)
    finally:
        for inst in insts.values():
            inst.free()
    return {c.end: values[slot[c.start]] for c in system.connections}


class _Loop:
    """The communication steps, made by the C loop (system/c/master.c) over the instances in stepping order.

    It makes the FMI calls the Python loop it replaced made, in the same order,
    with the same arithmetic for the time: the same results, bit for bit.
    """

    def __init__(self, insts: list[_Instance], values, master: str, t0: float, step: float, t_end: float,
                 n_steps: int, record_every: int, column_fmu: list[int], column_index: list[int],
                 times: np.ndarray, data: np.ndarray, profile: bool):
        from grubler import binding

        self.insts, self.values = insts, values
        self.seconds = np.zeros((len(insts), 3)) if profile else None
        self.fmus = (binding.MasterFmu * len(insts))(*[
            inst.loop_view(None if self.seconds is None else self.seconds[k].ctypes.data)
            for k, inst in enumerate(insts)])
        self._columns = (np.asarray(column_fmu, dtype=np.intc), np.asarray(column_index, dtype=np.intc))
        self.run = binding.MasterRun(master == JACOBI, t0, step, t_end, n_steps, record_every, len(column_fmu),
                                     self._columns[0].ctypes.data, self._columns[1].ctypes.data,
                                     times.ctypes.data, data.ctypes.data)
        self.t, self.row, self.failure = ctypes.c_double(t0), ctypes.c_long(1), binding.MasterFailure()
        self._steps = binding.library().grb_master_steps

    def steps(self, first: int, count: int) -> None:
        """Communication steps ``first`` .. ``first + count - 1``, each recorded row written."""
        if self._steps(self.fmus, len(self.insts), ctypes.addressof(self.values), ctypes.byref(self.run), first,
                       count, ctypes.byref(self.t), ctypes.byref(self.row), ctypes.byref(self.failure)):
            f = self.failure
            what = ("fmi2SetReal", f"doStep from t = {f.t:.6g} s", "fmi2GetReal")[f.call]
            raise self.insts[f.fmu].refused(what, f.status)

    def profile(self, seq: list[str]) -> dict[str, tuple[float, float, float]]:
        """Seconds in setReal, doStep and getReal by component (empty unless profiled)."""
        if self.seconds is None:
            return {}
        return {name: tuple(float(x) for x in self.seconds[k]) for k, name in enumerate(seq)}


def _initialise(insts: dict[str, _Instance], seq: list[str], values, t0: float) -> None:
    """Propagate outputs to inputs in step order until they settle (states first)."""
    for sweep in range(len(seq) + 2):
        change = 0.0
        for name in seq:
            inst = insts[name]
            _call(inst, "set inputs", lambda: inst.push(values), t0)
            buf = _call(inst, "get outputs", lambda: inst.pull(False), t0)
            for i, s in enumerate(inst.out_slots):
                v = buf[i]
                if not math.isfinite(v):
                    raise CosimError(f"{name}: an initial output is {v} at t = {t0:g} s"
                                     + _last_message(inst))
                scale = max(1.0, abs(v), abs(values[s]))
                change = max(change, abs(v - values[s]) / scale)
                values[s] = v
        if sweep > 0 and change < 1e-12:
            return
    raise CosimError("initial values of the coupled inputs did not settle after "
                     f"{len(seq) + 2} sweeps: an algebraic loop the FMUs do not declare?")


def _call(inst: _Instance, what: str, fn, t: float):
    try:
        return fn()
    except GrublerError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise CosimError(f"{inst.name}: {what} failed at t = {t:g} s ({exc})" + _last_message(inst)) from None


def _last_message(inst: _Instance) -> str:
    return f": {inst.messages[-1]}" if inst.messages else ""


__all__ = ["run", "UnpackedFMUs", "check", "order", "interfaces_of", "initial_inputs", "time_scales", "step_warnings", "TimeScale", "units_compatible", "CosimResult", "CosimError", "FmuInterface",
           "GAUSS_SEIDEL", "JACOBI", "MASTERS"]
