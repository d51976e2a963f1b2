"""How the extrapolating master couples its components: which inputs move over a step, and how.

Gauss-Seidel holds every input at one value over a communication step: the
source's latest output.  For a continuous input of a component that integrates
it (a motor reading the crank's speed, a mechanism reading the motor's torque)
that is the value at one end of the step, and the coupling is first order in
the step.  The extrapolating master (``cosim.run(..., master="extrapolate")``,
its loop in system/c/master.c) holds it at the step's midpoint value instead:
the mean of a smooth input over the step to O(h^2), so the coupling is second
order.  The midpoint is

- **interpolated** between the source's values at the step's start and end when
  the source steps before the component (it has its end value already);
- **extrapolated** linearly from the source's last two communication points
  when it steps after (a feedback loop's cut).

and after the step the inputs are set to their end values before the outputs
are read, so an output that depends on an input now is the end-of-step value.

Two kinds of input keep Gauss-Seidel's value (:data:`HELD`):

- every input of a **sampled** component (a PID, an encoder: a sample-time
  parameter, or no continuous output): it reads its inputs at the sample
  instant, the step's start, and holds what it read;
- an input fed by a **discrete** output (a sampled law's): piecewise constant
  between sample instants, so its held value is exact and a slope through two
  samples would be wrong.

The scheme asks nothing of an FMU beyond FMI 2.0's fmi2SetReal between
fmi2DoStep and fmi2GetReal, so a foreign FMU runs on it as ours do.

**With a tolerance** (``tol``) the communication step stays the sampled laws'
grid (their sample instants are communication points) and the continuous
components are coupled in sub-steps that adapt to an error estimate: each
sub-step is taken whole and as two halves from one saved FMU state (step
doubling; the halves' error is a third of the difference, second order), kept
when the estimate, relative to max(1, |value|) over every coupled value, is
within ``tol``, else rolled back and tried shorter.  The sampled components
step first, once per communication step, reading their inputs at the sample
instant; then the continuous ones sub-step in the stepping order.  Rolling back
needs every continuous component's FMU to get and set its state
(``canGetAndSetFMUstate``): when one cannot, the run is the fixed-step
extrapolating master, without error control, and a warning says which
component stopped it (:func:`adaptive_plan`).

Examples
--------
>>> (HELD, INTERPOLATED, EXTRAPOLATED)
(0, 1, 2)
"""

from __future__ import annotations

from dataclasses import dataclass

from grubler.system.interface import FmuInterface
from grubler.system.ssp import System
from grubler.system.time_scales import time_scales

# system/c/master.c's grb_input_mode
HELD, INTERPOLATED, EXTRAPOLATED = 0, 1, 2


def sampled_components(system: System, interfaces: dict[str, FmuInterface]) -> set[str]:
    """Components that read their inputs at sample instants: a sample time declared, or no continuous output.

    Examples
    --------
    >>> from grubler.system.ssp import System
    >>> sampled_components(System("empty"), {})
    set()
    """
    out = {sc.component for sc in time_scales(system, interfaces) if sc.what.startswith("sample time")}
    for name, itf in interfaces.items():
        real_outputs = [p for p in itf.ports.values() if p.causality == "output" and p.type == "Real"]
        if real_outputs and all(p.variability == "discrete" for p in real_outputs):
            out.add(name)
    return out


def input_modes(system: System, interfaces: dict[str, FmuInterface], seq: list[str]) -> dict[str, list[int]]:
    """Each component's connected inputs' modes, in the order the master wires them (the system's connections).

    ``seq`` is the stepping order: a source stepped before its reader is interpolated, one after it extrapolated.
    """
    modes: dict[str, list[int]] = {name: [] for name in seq}
    for c, mode in _connection_modes(system, interfaces, seq):
        modes[c.end_element].append(mode)
    return modes


def _connection_modes(system: System, interfaces: dict[str, FmuInterface], seq: list[str]):
    """Each connection with its input's mode (:func:`input_modes`), in the system's order."""
    sampled = sampled_components(system, interfaces)
    position = {name: k for k, name in enumerate(seq)}
    for c in system.connections:
        source = interfaces[c.start_element].ports[c.start_connector]
        if c.end_element in sampled or c.start_element in sampled or source.variability == "discrete" \
                or source.type != "Real":
            yield c, HELD
        elif position[c.start_element] < position[c.end_element]:
            yield c, INTERPOLATED
        else:
            yield c, EXTRAPOLATED


def cannot_roll_back(interfaces: dict[str, FmuInterface], names: list[str]) -> list[str]:
    """Those of ``names`` whose FMU cannot get and set its state (``canGetAndSetFMUstate``): no rollback."""
    return [name for name in names
            if not getattr(interfaces[name].model_description.coSimulation, "canGetAndSetFMUstate", False)]


def adaptive_plan(system: System, interfaces: dict[str, FmuInterface], seq: list[str], step: float,
                  tol: float) -> tuple[list[str], set[str], list[str], bool]:
    """The adaptive master's stepping order (sampled components first, each order kept), its sampled
    components, its warnings, and whether it can run (False: every continuous component cannot roll back).

    A warning says when a continuous component cannot roll back (the run falls back to the fixed-step
    extrapolating master: the caller drops ``tol``) and when a sample time is not a whole number of steps
    (its samples then fall inside a step).
    """
    sampled = sampled_components(system, interfaces)
    warnings = []
    stuck = cannot_roll_back(interfaces, [name for name in seq if name not in sampled])
    if stuck:
        warnings.append(f"tol {tol:g}: {', '.join(stuck)} cannot get and set its FMU state "
                        "(canGetAndSetFMUstate), which sub-steps with an error estimate need to roll back: "
                        f"running the extrapolating master at the fixed step {step:g} s, without error control")
    for sc in time_scales(system, interfaces):
        ratio = sc.seconds / step
        # (a step longer than the sample time has its own warning: time_scales.step_warnings)
        if sc.what.startswith("sample time") and ratio > 1 and abs(ratio - round(ratio)) > 1e-9 * ratio:
            warnings.append(f"tol {tol:g}: {sc.component}'s {sc.what} ({sc.seconds:g} s) is not a whole number "
                            f"of steps ({step:g} s): its samples fall inside a communication step")
    order = [n for n in seq if n in sampled] + [n for n in seq if n not in sampled]
    return order, sampled, warnings, not stuck


# the Newton master's iteration: a step ends when every coupled value's residual, relative to max(1, |value|), is
# within NEWTON_TOL, or after NEWTON_MAX_ITER evaluations.  1e-5 is below what the coupling's own error shows:
# on the servo four-bar (1 and 0.2 ms) and the cylinder slider-crank (10 and 1 ms) the errors against the
# monolithic references are those of 1e-7 to three digits, in 1.6 to 2.8 evaluations a step against 2.1 to 2.9
# (1e-8 is the cylinder's noise floor: the FMUs' own integration, seen through the perturbed steps)
NEWTON_TOL = 1e-5
NEWTON_MAX_ITER = 8


@dataclass
class NewtonPlan:
    """What the Newton master solves for: its stepping order (sampled components first), which components it
    iterates (rolled back and stepped again each iteration), the slots of the unknowns (the end-of-step values
    of the outputs their continuous inputs read), and the modes of each component's inputs."""

    order: list[str]
    sampled: set[str]
    iterated: set[str]
    unknowns: list[str]  # 'component.output' of each unknown
    modes: dict[str, list[int]]


def newton_plan(system: System, interfaces: dict[str, FmuInterface], seq: list[str],
                ) -> tuple[NewtonPlan | None, list[str]]:
    """The Newton master's plan, or None and a warning when a component it would iterate cannot roll back.

    A component is iterated when it is continuous (not sampled) and reads a continuous output of another
    continuous component (an input :func:`input_modes` does not hold): every such input is held over the
    step at the mean of its source's start value and the guess of its end value, and the guess iterated.
    Rolling back needs the iterated components' FMU state; without it the run is Gauss-Seidel, the most
    stable scheme that steps each FMU once (the warning says which component stopped it).

    Examples
    --------
    >>> from grubler.system.ssp import System
    >>> plan, said = newton_plan(System("empty"), {}, [])
    >>> plan.unknowns, said
    ([], [])
    """
    sampled = sampled_components(system, interfaces)
    order = [n for n in seq if n in sampled] + [n for n in seq if n not in sampled]
    modes = input_modes(system, interfaces, order)
    moving = [c for c, mode in _connection_modes(system, interfaces, order) if mode != HELD]
    iterated = {c.end_element for c in moving}
    stuck = cannot_roll_back(interfaces, [n for n in order if n in iterated])
    if stuck:
        return None, [f"master newton: {', '.join(stuck)} cannot get and set its FMU state "
                      "(canGetAndSetFMUstate), which iterating a step needs to roll back: running Gauss-Seidel, "
                      "without iteration"]
    return NewtonPlan(order, sampled, iterated, list(dict.fromkeys(c.start for c in moving)), modes), []


__all__ = ["HELD", "INTERPOLATED", "EXTRAPOLATED", "sampled_components", "input_modes", "adaptive_plan",
           "cannot_roll_back", "newton_plan", "NewtonPlan", "NEWTON_TOL", "NEWTON_MAX_ITER"]
