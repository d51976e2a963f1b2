"""The power at each mechanical connection of a co-simulation, the energy its coupling makes, and divergence.

A mechanical connection between two components is a power bond: one gives an
effort (a torque, N m, or a force, N) that the other takes as an input, and the
other gives back the matching flow (a speed, rad/s, or a velocity, m/s).  Over a
communication step each side holds the other's value: the effort's giver A sees
the flow held, the taker B sees the effort held.  So the energy A gives,

    E_A = sum over steps of h * f_held_by_A * (e(t_k) + e(t_k+1)) / 2,

and the energy B receives,

    E_B = sum over steps of h * e_held_by_B * (f(t_k) + f(t_k+1)) / 2,

differ; in one monolithic simulation they are the same.  E_B - E_A is the
energy the coupling makes (positive: energy appeared from nothing), the measure
of Sadjina et al.'s energy-conservation-based co-simulation (ECCO), from the
values at the communication points.  What a side holds follows the master:
under Jacobi the value of the step's start; under Gauss-Seidel that of the
step's end when the giver steps first, else the start's.

A run diverged when a recorded value is not finite, when a bond's coupling
energy is more than :data:`ENERGY_FRACTION` of the energy that passed through
it, or when its giver took in net energy that its taker says it received
(:data:`CONTRADICTION_FRACTION`); a coupling energy under :data:`ENERGY_FLOOR`
never counts.  :func:`check` returns what it finds; ``cosim.run`` puts the
lines in the result's warnings and ``grubler cosim`` exits 2 on a divergence,
naming the connection.

Examples
--------
>>> from grubler.system.ssp import System
>>> s = System("drive")
>>> _ = s.add("motor", "m.fmu"), s.add("load", "l.fmu")
>>> _ = s.connect("motor.torque", "load.torque_in"), s.connect("load.speed", "motor.speed_in")
>>> [b.name for b in power_bonds(s.connections, {"motor.torque": "N.m", "load.speed": "rad/s or m/s"})]
['motor.torque -> load.torque_in with load.speed -> motor.speed_in']
>>> unit_kind("N.m", "rad/s"), unit_kind("N", "m/s"), unit_kind("N", "rad/s")
('rotational', 'translational', None)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grubler.system.interface import _unit_alternatives
from grubler.system.ssp import Connection

ENERGY_FRACTION = 0.05
"""A bond whose coupling energy exceeds this fraction of the energy it passed (the larger of the two
sides' integrals of |power|) made energy from nothing: the run diverged.  Measured: runs that hold
(Gauss-Seidel at 0.1 to 10 ms on the servo four-bar, 1 ms on the cylinder systems; Jacobi at 1 ms)
stay under 0.6 %; runs that end with forces tens of times the physical ones (the cylinder
slider-crank under Gauss-Seidel at 3 ms, the luffing boom under Jacobi at 2 and 5 ms) and the servo
under Jacobi at 10 ms, 1.3 rad off, are at 11 to 30 %."""
CONTRADICTION_FRACTION = 1e-3
"""A bond whose giver took in net energy while its taker received net energy from it made that energy,
whatever its share of what passed, once that share is above this (the two sides' nets are not round-off
apart).  Measured: the cylinder slider-crank under Gauss-Seidel at 2 ms rings at the step with forces of
46 kN where 150 N are right, the cylinder taking in 25.7 J while the mechanism receives 61.4 J (0.33 % of
what passed); no run that holds has the two nets of opposite signs."""
ENERGY_FLOOR = 1e-3
"""J: a coupling energy below this is never reported (a bond at rest passes almost nothing)."""

_PAIRS = {("N m", "rad/s"): "rotational", ("N", "m/s"): "translational"}


def unit_kind(effort_unit: str, flow_unit: str) -> str | None:
    """'rotational' (N m with rad/s), 'translational' (N with m/s), or None when the units make no power."""
    e, f = _unit_alternatives(effort_unit or ""), _unit_alternatives(flow_unit or "")
    for (ue, uf), kind in _PAIRS.items():
        if ue in e and uf in f:
            return kind
    return None


@dataclass
class PowerBond:
    """A mechanical connection: ``effort`` runs from ``giver`` to ``taker``, ``flow`` back."""

    effort: Connection
    flow: Connection
    kind: str

    @property
    def giver(self) -> str:
        return self.effort.start_element

    @property
    def taker(self) -> str:
        return self.effort.end_element

    @property
    def name(self) -> str:
        return f"{self.effort.start} -> {self.effort.end} with {self.flow.start} -> {self.flow.end}"


def power_bonds(connections: list[Connection], units: dict[str, str]) -> list[PowerBond]:
    """The power bonds among ``connections``: an effort one way and the matching flow back between the
    same two components, by their units (``units``: by ``component.variable``, a connection's output's
    unit first, its input's where the output's is unknown)."""
    def unit(c: Connection) -> str:
        return units.get(c.start) or units.get(c.end, "")

    bonds = []
    for e in connections:
        for f in connections:
            if f.start_element == e.end_element and f.end_element == e.start_element:
                kind = unit_kind(unit(e), unit(f))
                if kind:
                    bonds.append(PowerBond(e, f, kind))
                    break
    return bonds


@dataclass
class BondEnergy:
    """What passed through a bond over a run: J given, received, made by the coupling, and the peak power."""

    bond: PowerBond
    given: float
    received: float
    passed: float  # the larger of the two sides' integrals of |power|
    peak_power: float

    @property
    def coupling(self) -> float:
        return self.received - self.given

    def line(self) -> str:
        return (f"{self.bond.name}: {self.bond.giver} gave {self.given:.4g} J, {self.bond.taker} received "
                f"{self.received:.4g} J; the coupling made {self.coupling:.3g} J "
                f"({_fraction(self.coupling, self.passed)} of the {self.passed:.4g} J that passed), peak "
                f"power {self.peak_power:.4g} W")


def _fraction(x: float, of: float) -> str:
    return f"{abs(x) / of:.2%}" if of > 0 else "all"


def bond_energy(bond: PowerBond, t: np.ndarray, effort: np.ndarray, flow: np.ndarray, master: str,
                order: list[str]) -> BondEnergy:
    """The energies of one bond from its effort and flow at consecutive communication points ``t``."""
    h = np.diff(t)
    gauss_seidel = master == "gauss-seidel"
    first = order.index(bond.giver) < order.index(bond.taker)
    # what each side held over step k: the step's end value if its source stepped before it (Gauss-Seidel)
    effort_held = effort[1:] if (gauss_seidel and first) else effort[:-1]
    flow_held = flow[1:] if (gauss_seidel and not first) else flow[:-1]
    p_given = flow_held * (effort[:-1] + effort[1:]) / 2
    p_received = effort_held * (flow[:-1] + flow[1:]) / 2
    with np.errstate(all="ignore"):
        return BondEnergy(bond, float(np.sum(h * p_given)), float(np.sum(h * p_received)),
                          float(max(np.sum(h * np.abs(p_given)), np.sum(h * np.abs(p_received)))),
                          float(np.max(np.abs(effort * flow))) if len(t) else 0.0)


@dataclass
class Finding:
    """One thing wrong with a run: ``diverged`` ones make ``grubler cosim`` exit 2."""

    message: str
    connection: str
    diverged: bool


def check(result, consecutive: bool = True) -> tuple[list[BondEnergy], list[Finding]]:
    """The bonds' energies and what went wrong in a :class:`CosimResult` (its connected inputs are recorded).

    ``consecutive``: the rows are every communication point (``record_every`` 1); otherwise the
    energies are not measured (a held value is not among the rows), only divergence.
    """
    t, data, columns = result.t, result.data, result.columns
    system = result.system
    findings: list[Finding] = []
    col = {c: i for i, c in enumerate(columns)}
    for c in system.connections:  # a non-finite value on a connection first: it is where it entered
        if c.end in col and not np.all(np.isfinite(data[:, col[c.end]])):
            k = int(np.argmax(~np.isfinite(data[:, col[c.end]])))
            findings.append(Finding(f"diverged at {c.start} -> {c.end}: it is {data[k, col[c.end]]} at "
                                    f"t = {t[k]:.6g} s", f"{c.start} -> {c.end}", True))
            break
    if not findings:
        bad = [c for c in columns if not np.all(np.isfinite(data[:, col[c]]))]
        if bad:
            k = int(np.argmax(~np.isfinite(data[:, col[bad[0]]])))
            findings.append(Finding(f"diverged: {bad[0]} is {data[k, col[bad[0]]]} at t = {t[k]:.6g} s", bad[0],
                                    True))
    energies: list[BondEnergy] = []
    if consecutive and len(t) > 2:
        for bond in power_bonds(system.connections, result.units):
            if bond.effort.end in col and bond.flow.end in col:
                energies.append(bond_energy(bond, t, data[:, col[bond.effort.end]], data[:, col[bond.flow.end]],
                                            result.master, result.order))
    for en in energies:
        b = en.bond
        advice = "shorten the step" + (" or use Gauss-Seidel" if result.master == "jacobi" else "")
        where = f"diverged at {b.effort.start} -> {b.effort.end}: the coupling made {en.coupling:.3g} J from nothing"
        if not math.isfinite(en.coupling) or en.coupling <= ENERGY_FLOOR:
            continue
        if en.coupling > ENERGY_FRACTION * en.passed:
            findings.append(Finding(
                f"{where}, {_fraction(en.coupling, en.passed)} of the {en.passed:.3g} J that passed (with "
                f"{b.flow.start} -> {b.flow.end}; peak power {en.peak_power:.3g} W); {advice}",
                f"{b.effort.start} -> {b.effort.end}", True))
        elif en.given < 0 < en.received and en.coupling > CONTRADICTION_FRACTION * en.passed:
            # the two sides disagree on the direction of the net energy: a limit cycle the coupling feeds
            findings.append(Finding(
                f"{where}: {b.giver} took in {-en.given:.3g} J while {b.taker} received {en.received:.3g} J from it "
                f"(with {b.flow.start} -> {b.flow.end}; peak power {en.peak_power:.3g} W); {advice}",
                f"{b.effort.start} -> {b.effort.end}", True))
    return energies, findings


def judge(result, consecutive: bool = True) -> None:
    """Put :func:`check`'s bond energies in ``result.power`` and its findings in ``result.findings``, their
    lines in ``result.warnings`` (``cosim.run``'s hook, after the last step)."""
    result.power, result.findings = check(result, consecutive)
    result.warnings.extend(f.message for f in result.findings)


def diagnosis(result, consecutive: bool = True) -> str:
    """What the rows of a run that failed show went wrong at a connection first, or '' (``cosim.run`` puts it
    before the error).  A value that is not finite in a component's own output is the failure itself: the
    FMU's message says it."""
    try:
        _, findings = check(result, consecutive)
    except Exception:  # noqa: BLE001 - the failure itself is what the user must see; this only adds to it
        return ""
    at_connection = [f for f in findings if f.message.startswith("diverged at ")]
    return at_connection[0].message if at_connection else ""


__all__ = ["PowerBond", "BondEnergy", "Finding", "power_bonds", "bond_energy", "check", "judge", "diagnosis",
           "unit_kind",
           "ENERGY_FRACTION", "CONTRADICTION_FRACTION", "ENERGY_FLOOR"]
