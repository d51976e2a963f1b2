"""A co-simulation's result: the recorded signals with their units, and what to plot of them.

Examples
--------
>>> import numpy as np
>>> from grubler.system.ssp import System
>>> r = CosimResult(np.array([0.0, 1.0]), ["a.x"], np.array([[1.0], [2.0]]), System("s"), ["a"],
...                 "gauss-seidel", 1.0, 0.0, {"a.x": "m"})
>>> r["a.x"].tolist(), r.units["a.x"]
([1.0, 2.0], 'm')
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from grubler.limits import open_output
from grubler.system.interface import FmuInterface
from grubler.system.ssp import System


# -- running -------------------------------------------------------------------------
@dataclass
class CosimResult:
    """Recorded outputs of a co-simulation.

    ``result['mechanism.theta2']`` is a column; ``columns`` lists them in order.
    ``warnings`` says, one line each, where the communication step exceeds a time
    a component declares or implies (:func:`time_scales`).

    Examples
    --------
    >>> import numpy as np
    >>> from grubler.system.ssp import Plot, System
    >>> s = System("move", plots=[Plot("crank angle [rad]", ["move.position"], labels={"move.position": "setpoint"})])
    >>> r = CosimResult(t=np.array([0.0, 0.5, 1.0]), columns=["move.position"], data=np.array([[0.0], [0.5], [1.0]]),
    ...                 system=s, order=["move"], master="gauss-seidel", step=0.5, wall_time=0.0,
    ...                 units={"move.position": "rad"})              # what run() returns
    >>> r["move.position"], r["t"]
    (array([0. , 0.5, 1. ]), array([0. , 0.5, 1. ]))
    >>> r["move.speed"]
    Traceback (most recent call last):
    ...
    KeyError: "no recorded signal 'move.speed'"
    >>> [(title, [line[0] for line in lines]) for title, lines in r.panels()]   # what plot() draws: the system's plots
    [('crank angle [rad]', ['setpoint'])]
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
    coupling: dict = field(default_factory=dict)  # run(..., tol=...): tol, substeps, rejected, worst_estimate
    # the power bonds' energies (coupling_energy.BondEnergy) and what went wrong (coupling_energy.Finding)
    power: list = field(default_factory=list)
    findings: list = field(default_factory=list)

    @property
    def diverged(self):
        """The first finding that makes the run's values meaningless (a ``coupling_energy.Finding``), or None."""
        return next((f for f in self.findings if f.diverged), None)

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

        with open_output(path, "w", newline="") as fh:
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


__all__ = ["CosimResult"]
