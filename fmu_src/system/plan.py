"""Checking and ordering a system before it runs.

:func:`check` lists every reason a system cannot run (connections whose ends do
not exist or do not match, inputs fed twice, parameters an FMU does not have);
:func:`order` gives the Gauss-Seidel stepping order: a component after those
whose outputs it reads, a feedback loop cut where an output does not depend on
its component's inputs at the same instant, and an algebraic loop named.

Examples
--------
>>> from grubler.system.ssp import System
>>> check(System("empty"), {}), order(System("empty"), {})
([], [])
"""

from __future__ import annotations



from grubler.limits import did_you_mean
from grubler.system.interface import FmuInterface, units_compatible
from grubler.system.ssp import System, SystemDescriptionError




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
    """Every reason the system cannot run, one line each (empty: it can).

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.system.ssp import System
    >>> from grubler.controllers.native_fmu import pid_spec, trajectory_spec
    >>> from grubler.fmi.description import model_description
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> for spec in (pid_spec("PID"), trajectory_spec("Trajectory")):  # a model description is all a check reads
    ...     with zipfile.ZipFile(d / f"{spec.identifier}.fmu", "w") as z:
    ...         z.writestr("modelDescription.xml", model_description(spec, []))
    >>> s = System("follow", base=d)
    >>> _ = s.add("pid", "PID.fmu", K=2.0, Ts=0.01)
    >>> _ = s.add("move", "Trajectory.fmu", kind="trapezoid")
    >>> _ = s.connect("move.position", "pid.setpoint")
    >>> from grubler.system.instance import UnpackedFMUs, interfaces_of
    >>> with UnpackedFMUs() as unpacked:
    ...     itf = interfaces_of(s, unpacked)
    >>> check(s, itf)                                # nothing stops it from running
    []
    >>> _ = s.add("pid2", "PID.fmu", Kp=1.0)
    >>> _ = s.connect("move.positon", "pid2.setpoint")
    >>> with UnpackedFMUs() as unpacked:
    ...     itf = {name: FmuInterface.of(d / "PID.fmu") for name in ("pid", "pid2")} | {"move": FmuInterface.of(d / "Trajectory.fmu")}
    >>> for line in check(s, itf):
    ...     print(line)
    parameter pid2.Kp: PID.fmu has no variable 'Kp'
    dangling connection move.positon -> pid2.setpoint: move (Trajectory.fmu) has no variable 'positon'; did you mean 'position'?
    >>> tmp.cleanup()
    """
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

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.system.ssp import System
    >>> from grubler.controllers.native_fmu import pid_spec, trajectory_spec
    >>> from grubler.fmi.description import model_description
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> for spec in (pid_spec("PID"), trajectory_spec("Trajectory")):  # a model description is all a check reads
    ...     with zipfile.ZipFile(d / f"{spec.identifier}.fmu", "w") as z:
    ...         z.writestr("modelDescription.xml", model_description(spec, []))
    >>> s = System("follow", base=d)
    >>> _ = s.add("pid", "PID.fmu", K=2.0, Ts=0.01)
    >>> _ = s.add("move", "Trajectory.fmu", kind="trapezoid")
    >>> _ = s.connect("move.position", "pid.setpoint")
    >>> itf = {"pid": FmuInterface.of(d / "PID.fmu"), "move": FmuInterface.of(d / "Trajectory.fmu")}
    >>> order(s, itf)                                 # the trajectory first: the controller reads its output
    ['move', 'pid']
    >>> tmp.cleanup()
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


__all__ = ["check", "order"]
