"""What a co-simulation master needs to know of an FMU: its ports and their units.

Read once from the model description (fmpy's reader); the SSP writer uses it
to declare connector units, the master to check, order and connect a system.

Examples
--------
>>> units_compatible("N m", "N.m"), units_compatible("rad or m", "rad"), units_compatible("A", "V")
(True, True, False)
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from grubler.errors import SystemDescriptionError


# -- what the master needs to know of an FMU ---------------------------------------
@dataclass(frozen=True)
class Port:
    """One variable of an FMU, as the master sees it."""

    name: str
    vr: int
    causality: str
    type: str
    unit: str  # '' when unknown
    description: str
    variability: str = "continuous"  # FMI 2's default; 'discrete' for a sampled law's outputs


@dataclass
class FmuInterface:
    """The parts of a model description a master uses.

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.controllers.native_fmu import pid_spec
    >>> from grubler.fmi.description import model_description
    >>> with tempfile.TemporaryDirectory() as d:
    ...     fmu = pathlib.Path(d) / "PID.fmu"
    ...     with zipfile.ZipFile(fmu, "w") as z:          # an FMU's model description is what is read
    ...         z.writestr("modelDescription.xml", model_description(pid_spec("PID"), []))
    ...     itf = FmuInterface.of(fmu)
    >>> itf.ports["Ts"]
    Port(name='Ts', vr=7, causality='parameter', type='Real', unit='s', description='sample time [s]', variability='fixed')
    >>> itf.feedthrough                               # its output depends on no input at the same instant
    {'u': set()}
    """

    path: Path
    model_description: object
    ports: dict[str, Port]
    feedthrough: dict[str, set[str] | None]  # output -> inputs it depends on now (None: unknown = all)

    @staticmethod
    def of(path: Path, unzipdir: Path | None = None) -> "FmuInterface":
        """The interface of the FMU at ``path`` (read from ``unzipdir`` when it is unpacked there)."""
        from fmpy import read_model_description

        md = read_model_description(str(unzipdir or path), validate=False)
        if md.coSimulation is None:
            raise SystemDescriptionError(f"{path.name}: not a co-simulation FMU")
        ports = {}
        for v in md.modelVariables:
            unit = v.unit or (v.declaredType.unit if v.declaredType is not None else None) or _bracket_unit(
                v.description or "")
            ports[v.name] = Port(v.name, v.valueReference, v.causality, v.type, unit or "", v.description or "",
                                 v.variability or "continuous")
        feed = {}
        for out in md.outputs:
            deps = out.dependencies
            feed[out.variable.name] = None if deps is None else {
                d.name for d in deps if d.causality == "input"}
        return FmuInterface(path, md, ports, feed)


def _bracket_unit(description: str) -> str | None:
    # the project's convention for pythonfmu FMUs: the description ends in [unit]
    m = re.search(r"\[([^\[\]]+)\]\s*$", description)
    return m.group(1).strip() if m else None


def _unit_alternatives(unit: str) -> set[str]:
    """'rad or m' and 'N m, or N on a slide' name alternatives; normalise spellings."""
    parts = re.split(r",|\bor\b", unit)
    out = set()
    for p in parts:
        p = p.strip()
        p = re.sub(r"\bon a slide\b|\bon a prismatic joint\b", "", p).strip()
        p = p.replace("*", " ").replace(".", " ").replace("·", " ")
        p = re.sub(r"\s+", " ", p)
        if p in ("Nm",):
            p = "N m"
        if p in ("-", ""):
            p = "1" if p == "-" else ""
        if p:
            out.add(p)
    return out


def generic_unit(unit: str) -> bool:
    """No unit, or one that takes any (a controller's signal): the connection says which."""
    return not unit or "any" in _unit_alternatives(unit)


def units_compatible(a: str, b: str) -> bool:
    """True when either unit is unknown or generic (``any``), or they share a spelling.

    Examples
    --------
    >>> units_compatible("N m", "N.m"), units_compatible("rad or m", "m"), units_compatible("any", "V")
    (True, True, True)
    >>> units_compatible("A", "V")
    False
    """
    if not a or not b:
        return True
    ua, ub = _unit_alternatives(a), _unit_alternatives(b)
    if not ua or not ub or "any" in ua or "any" in ub:
        return True
    return bool(ua & ub)
