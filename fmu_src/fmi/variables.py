"""A native FMU's variables and the layout of its values: the one definition.

Both the C side (:mod:`grubler.fmi.header` writes ``config.h``) and the model
description (:mod:`grubler.fmi.description`) are written from a
:class:`ModelSpec`, so the value references, types, causalities and start values
the importer reads are, by construction, those the binary serves.

Layout of an instance's values (all doubles, the FMU state is a copy of them):
parameters and inputs each own a *slot* in one persistent block, a string or
enumeration parameter stored as the index of its value among its ``choices``;
an output's slot is its index in the model's output vector.  Value references
are 1-based positions in :attr:`ModelSpec.variables`.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, replace

# FMI 2.0 unit definitions: name -> exponents of the SI base units
# (kg, m, s, A, K, mol, cd, rad); only the units the models use.
UNITS: dict[str, dict[str, int]] = {
    "s": {"s": 1},
    "m": {"m": 1},
    "rad": {"rad": 1},
    "m/s": {"m": 1, "s": -1},
    "rad/s": {"rad": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "rad/s2": {"rad": 1, "s": -2},
    "kg": {"kg": 1},
    "kg.m2": {"kg": 1, "m": 2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "J": {"kg": 1, "m": 2, "s": -2},
    "W": {"kg": 1, "m": 2, "s": -3},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "A": {"A": 1},
    "Ohm": {"kg": 1, "m": 2, "s": -3, "A": -2},
    "H": {"kg": 1, "m": 2, "s": -2, "A": -2},
    "N.m/A": {"kg": 1, "m": 2, "s": -2, "A": -1},
    "V.s/rad": {"kg": 1, "m": 2, "s": -2, "A": -1, "rad": -1},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
    "K/W": {"K": 1, "kg": -1, "m": -2, "s": 3},
    "1/K": {"K": -1},
    "degC": {"K": 1},  # offset 273.15 (description.py)
    # fluid power
    "1": {},
    "1/s": {"s": -1},
    "m2": {"m": 2},
    "m3": {"m": 3},
    "m3/s": {"m": 3, "s": -1},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "m3/(s.Pa)": {"kg": -1, "m": 4, "s": 1},
    "N/m": {"kg": 1, "s": -2},
    "N.s/m": {"kg": 1, "s": -1},
    "K": {"K": 1},
    "kg/s": {"kg": 1, "s": -1},
    "kg/(s.Pa)": {"m": 1, "s": 1},
}
UNIT_OFFSET = {"degC": 273.15}

REAL, INTEGER, BOOLEAN, STRING, ENUMERATION = "Real", "Integer", "Boolean", "String", "Enumeration"
PARAMETER, INPUT, OUTPUT = "parameter", "input", "output"
# type codes the C side switches on (config.h)
TYPE_CODE = {REAL: 0, INTEGER: 1, ENUMERATION: 1, BOOLEAN: 2, STRING: 3}
CAUSALITY_CODE = {PARAMETER: 0, INPUT: 1, OUTPUT: 2}


@dataclass(frozen=True)
class EnumType:
    """An FMI enumeration type: items numbered 1, 2, ... in order."""

    name: str
    description: str
    items: tuple[tuple[str, str], ...]  # (name, description)


@dataclass(frozen=True)
class Variable:
    """One FMI scalar variable.

    Parameters
    ----------
    name, type, causality, description : str
    start : float, int or str
        Parameters and inputs: the start value (a string's text, an
        enumeration's item number).  Outputs: None (calculated at initialisation).
    unit : str, optional
        One of :data:`UNITS`; None where the unit depends on the scene (a joint
        that may slide or turn).
    min, max : float, optional
        Where physics bounds the value.
    choices : tuple of str
        A String parameter's accepted values (stored as the index).
    enum : EnumType, optional
        An Enumeration's type.
    level : int
        Outputs: the model's output group that computes it (the C model's
        levels, ordered by cost).
    feedthrough : bool
        Outputs: depends on the inputs at the same instant (``depends_on``
        names which; empty: all of them).
    slot : int
        Set by :class:`ModelSpec`.
    variability : str, optional
        Outputs: ``"discrete"`` for a sampled law's, held between its samples
        (piecewise constant); None: the default of the type and causality
        (a parameter fixed, a Real continuous).
    """

    name: str
    type: str
    causality: str
    description: str
    start: float | int | str | None = None
    unit: str | None = None
    min: float | None = None
    max: float | None = None
    choices: tuple[str, ...] = ()
    enum: EnumType | None = None
    level: int = 0
    feedthrough: bool = False
    slot: int = -1
    depends_on: tuple[str, ...] = ()
    variability: str | None = None

    @property
    def stored_start(self) -> float:
        """The start value as the double the C side stores."""
        if self.type == STRING:
            return float(self.choices.index(self.start))
        if self.type == BOOLEAN:
            return 1.0 if self.start else 0.0
        return float(self.start)


@dataclass(frozen=True)
class ModelSpec:
    """A native FMU's model: its variables and their layout.

    Parameters
    ----------
    identifier : str
        modelIdentifier (the binary's name) and modelName.
    description : str
    variables : sequence of Variable
        In value-reference order; parameter and input slots are assigned in the
        order :attr:`slot_order` gives (default: variable order).
    model_source : str
        The C model file (in ``grubler/fmi/c``) that serves these variables.
    defines : dict
        Extra integer constants the C model needs (sizes, slot offsets).
    n_outputs : int
        Length of the C model's output vector.
    slot_order : sequence of str, optional
        Parameter and input names in slot order (when the C model addresses
        them arithmetically, e.g. link fields with a stride).
    enums : sequence of EnumType
    state : sequence of (str, int)
        The model's own part of the persistent block, after the parameters' and
        inputs' values and their was-set flags: each field's name and length in
        doubles, in order (a last length of 0: the rest, sized by the C model).
        ``config.h`` gets each field's index as ``P_<NAME>``, so the C model, a
        state's reader and the tests share one layout.
    """

    identifier: str
    description: str
    variables: tuple[Variable, ...]
    model_source: str
    defines: dict = field(default_factory=dict)
    n_outputs: int = 0
    slot_order: tuple[str, ...] = ()
    enums: tuple[EnumType, ...] = ()
    kernel_sources: tuple = ()  # names of grubler.fmi.build's source folders, or (folder, file patterns)
    state: tuple[tuple[str, int], ...] = ()

    def __post_init__(self):
        names = [v.name for v in self.variables]
        if len(set(names)) != len(names):
            raise ValueError("duplicate variable names")
        stored = [v for v in self.variables if v.causality in (PARAMETER, INPUT)]
        order = list(self.slot_order) or [v.name for v in stored]
        if sorted(order) != sorted(v.name for v in stored):
            raise ValueError("slot_order must list every parameter and input once")
        slot = {n: k for k, n in enumerate(order)}
        variables = []
        for v in self.variables:
            s = slot[v.name] if v.causality in (PARAMETER, INPUT) else v.slot
            if v.causality == OUTPUT and not (0 <= s < self.n_outputs):
                raise ValueError(f"{v.name}: output slot {s} outside the output vector")
            variables.append(replace(v, slot=s))
        object.__setattr__(self, "variables", tuple(variables))

    @property
    def n_stored(self) -> int:
        """Doubles of the persistent block that parameters and inputs own."""
        return sum(v.causality in (PARAMETER, INPUT) for v in self.variables)

    def vr(self, name: str) -> int:
        """Value reference of a variable."""
        for k, v in enumerate(self.variables):
            if v.name == name:
                return k + 1
        raise KeyError(name)

    def slot(self, name: str) -> int:
        return self.variables[self.vr(name) - 1].slot

    def state_slot(self, name: str) -> int:
        """Index in the persistent block of a field of the model's own part (:attr:`state`)."""
        k = 2 * self.n_stored
        for field_name, length in self.state:
            if field_name == name:
                return k
            k += length
        raise KeyError(name)

    @property
    def guid(self) -> str:
        """A GUID that changes with anything the binary and the description must agree on."""
        h = hashlib.sha256()
        h.update(self.identifier.encode())
        for k, v in enumerate(self.variables):
            h.update(repr((k, v.name, v.type, v.causality, v.slot, v.stored_start if v.start is not None else None,
                           v.choices, v.level)).encode())
        h.update(repr(sorted(self.defines.items())).encode())
        h.update(repr(self.state).encode())
        d = h.hexdigest()
        return "{" + f"{d[:8]}-{d[8:12]}-{d[12:16]}-{d[16:20]}-{d[20:32]}" + "}"

