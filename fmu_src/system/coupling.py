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

Examples
--------
>>> (HELD, INTERPOLATED, EXTRAPOLATED)
(0, 1, 2)
"""

from __future__ import annotations

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
    sampled = sampled_components(system, interfaces)
    position = {name: k for k, name in enumerate(seq)}
    modes: dict[str, list[int]] = {name: [] for name in seq}
    for c in system.connections:
        source = interfaces[c.start_element].ports[c.start_connector]
        if c.end_element in sampled or source.variability == "discrete" or source.type != "Real":
            mode = HELD
        elif position[c.start_element] < position[c.end_element]:
            mode = INTERPOLATED
        else:
            mode = EXTRAPOLATED
        modes[c.end_element].append(mode)
    return modes


__all__ = ["HELD", "INTERPOLATED", "EXTRAPOLATED", "sampled_components", "input_modes"]
