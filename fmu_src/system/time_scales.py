"""What a communication step may be: the time scales a system's components declare or imply.

A component's own time (a sampled law's period, an encoder's sample time, a DC
motor's electrical time constant L/R) bounds the communication step that
co-simulates it faithfully; :func:`step_warnings` names each one a step exceeds.

Examples
--------
>>> scales = [TimeScale("pid", "sample time Ts", 0.001, "it reads its inputs once per step")]
>>> step_warnings(0.01, scales)[0][:48]
"step: 0.01 s is longer than pid's sample time Ts"
"""

from __future__ import annotations

import math
from dataclasses import dataclass


from grubler.errors import GrublerError
from grubler.system.interface import FmuInterface
from grubler.system.ssp import System


# -- what a step may be -----------------------------------------------------------------
@dataclass(frozen=True)
class TimeScale:
    """A time a component declares or implies, which a communication step should not exceed.

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
    >>> scale = time_scales(s, itf)[0]
    >>> scale.component, scale.what, scale.seconds
    ('pid', 'sample time Ts', 0.01)
    >>> tmp.cleanup()
    """

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
    >>> [(sc.component, sc.what, sc.seconds) for sc in time_scales(s, itf)]   # the PID's Ts as the system sets it
    [('pid', 'sample time Ts', 0.01)]
    >>> tmp.cleanup()
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
    """One warning line per time scale the communication step exceeds.

    Examples
    --------
    >>> scales = [TimeScale("pid", "sample time Ts", 0.01, "it reads its inputs once per step")]
    >>> step_warnings(0.01, scales)
    []
    >>> step_warnings(0.02, scales)
    ["step: 0.02 s is longer than pid's sample time Ts = 0.01 s: it reads its inputs once per step; use a step of at most 0.01 s"]
    """
    return [f"step: {step:g} s is longer than {s.component}'s {s.what} = {s.seconds:.3g} s: {s.consequence}; "
            f"use a step of at most {s.seconds:.3g} s" for s in scales if step > s.seconds * (1 + 1e-9)]


__all__ = ["TimeScale", "time_scales", "step_warnings"]
