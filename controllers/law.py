"""A sampled control law, and the sample-and-hold clock that runs it in co-simulation.

Every block of :mod:`grubler.controllers` (PID, cascade, linear controller,
computed torque, trajectory, encoder) and every user-written controller is a
:class:`Law`: it declares its inputs, outputs and parameters (each description
ending with its unit in square brackets) and implements ``update(t, inputs) ->
outputs``, called once per sample.  The same declaration makes its FMU
(:mod:`grubler.controllers.fmu`), so the Python model and the FMU cannot disagree.

Sample-time semantics (:class:`Sampler`, shared by Python and the FMUs)
-------------------------------------------------------------------------
Written once, in C (``controllers/kernel/ctl_law.c``): the Sampler and every
native law FMU ask it which sample instants a step holds.

A law with sample time ``Ts > 0`` samples at ``t0 + k Ts`` (``t0`` the start
time).  A communication step from ``t`` to ``t + h`` runs every sample instant
in ``[t, t + h)``, each with the inputs as set before the step (held over the
step), and its outputs afterwards are those of the last sample run: a
zero-order hold.  So

- ``h = n Ts``: ``n`` samples per step, on inputs held over the step;
- ``h < Ts``: a sample only in the steps that contain a sample instant; in the
  others the output holds;
- ``h`` not a multiple of ``Ts``: samples stay on their own grid, not the
  communication grid.

A sample at ``t + h`` itself belongs to the next step, since it needs the inputs
at ``t + h``.  ``Ts = 0`` samples once per communication step, at its start.
Before the first sample the outputs are :meth:`Law.initial_outputs`.
A law with ``continuous = True`` (the trajectory generator, a function of time
only) instead evaluates at the end of each step, ``t + h``, as a plant does.

Examples
--------
>>> class Gain(Law):
...     inputs = {"x": "input signal [any]"}
...     outputs = {"y": "amplified signal [any]"}
...     parameters = {"k": Parameter(2.0, "gain [1]"), "Ts": Parameter(0.1, "sample time [s]")}
...     def __init__(self, k=2.0, Ts=0.1):
...         self.k = k
...         self.Ts = Ts
...     def update(self, t, inputs):
...         return {"y": self.k * inputs["x"]}
>>> s = Sampler(Gain(k=3.0), t0=0.0)
>>> s.step(0.0, 0.25, {"x": 1.0})    # samples at 0, 0.1, 0.2
{'y': 3.0}
>>> s.samples
3

A sample instant within :data:`GRID_TOL` times ``Ts`` of a step's end belongs
to the next step (communication points summed in floating point miss the grid
by a few ulps), and a step of more than :data:`MAX_SAMPLES_PER_STEP` samples
is refused:

>>> s = Sampler(Gain(Ts=0.1), t0=0.0)
>>> _ = s.step(0.0, 0.3 + GRID_TOL * 0.1 / 2, {"x": 1.0})   # ends a hair after 0.3: that sample is the next step's
>>> s.samples
3
>>> MAX_SAMPLES_PER_STEP
100000
"""

from __future__ import annotations

import copy
import ctypes
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from grubler.errors import InputError, SceneError
from grubler.limits import number

from grubler.controllers import native

# ctl_law.h's CTL_GRID_TOL and CTL_MAX_SAMPLES_PER_STEP (a test holds them equal):
# a sample instant within GRID_TOL Ts of a step's end belongs to the next step
# (communication points accumulated in floating point miss the grid by a few
# ulps), and a step holding more samples is refused rather than run for minutes.
GRID_TOL = 1e-7
MAX_SAMPLES_PER_STEP = 100_000


@dataclass(frozen=True)
class Parameter:
    """A law's parameter, as the FMU shows it.

    Parameters
    ----------
    default : float, int, str or bool, or None
        Value the law takes when the parameter is not given; its type is the
        FMU variable's type.  ``None`` means "the law decides" (e.g. from a scene);
        the FMU then shows ``start`` and passes nothing unless the importer sets it.
    description : str
        What it is, ending with its unit in square brackets, e.g. ``"gain [1]"``.
    start : float, int, str or bool, optional
        The FMU's start value when ``default`` is None.

    Examples
    --------
    >>> from grubler.controllers import Parameter
    >>> p = Parameter(12.0, "output level [V]")
    >>> p.default, p.description
    (12.0, 'output level [V]')
    """

    default: Any
    description: str
    start: Any = None

    @property
    def fmu_start(self) -> Any:
        return self.start if self.default is None else self.default


class Law:
    """Base class of a sampled control law.

    Subclasses declare the class attributes below and implement :meth:`update`.

    Attributes
    ----------
    inputs, outputs : dict of str to str
        Variable name to description; the description ends with the unit in
        square brackets (``"[rad]"``, ``"[N m]"``, ``"[1]"``, or ``"[any]"`` for
        a signal whose unit is that of what it is connected to).
    parameters : dict of str to Parameter
        Keyword arguments of the constructor that the FMU exposes.
    Ts : float
        Sample time, s (an instance attribute, usually a parameter); 0 samples
        once per communication step.
    continuous : bool
        True for a law of time alone, evaluated at the end of each step.

    Examples
    --------
    >>> from grubler.controllers import Law, Parameter, Sampler
    >>> class Bang(Law):
    ...     inputs = {"error": "position error [rad]"}
    ...     outputs = {"u": "voltage [V]"}
    ...     parameters = {"level": Parameter(12.0, "output level [V]"), "Ts": Parameter(1e-3, "sample time [s]")}
    ...     def __init__(self, level=12.0, Ts=1e-3):
    ...         self.level, self.Ts = level, Ts
    ...     def update(self, t, inputs):
    ...         return {"u": self.level if inputs["error"] > 0 else -self.level}
    >>> Bang(level=5.0).update(0.0, {"error": -0.1})
    {'u': -5.0}
    >>> Sampler(Bang()).step(0.0, 0.01, {"error": 0.2})     # ten samples in a 10 ms step, inputs held
    {'u': 12.0}
    """

    inputs: ClassVar[dict[str, str]] = {}
    outputs: ClassVar[dict[str, str]] = {}
    parameters: ClassVar[dict[str, Parameter]] = {}
    continuous: ClassVar[bool] = False
    Ts: float = 0.0

    @classmethod
    def from_parameters(cls, **values) -> "Law":
        """The law from FMU parameter values (those the importer did not set are absent)."""
        return cls(**values)

    def initial_outputs(self, t0: float) -> dict[str, float]:
        """Outputs before the first sample (default: zeros)."""
        return {name: 0.0 for name in self.outputs}

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        """One sample: read the inputs at time ``t``, advance the state, return the outputs."""
        raise NotImplementedError

    def get_state(self) -> Any:
        """Everything :meth:`set_state` needs to resume from here, as plain data.

        The default takes a copy of the instance's attributes (a random
        generator's state included) and the state of every attribute that is a
        Law itself (a cascade's inner loops).  An FMU serialises it with
        :mod:`grubler.system.fmu_state`: numbers, strings, None, lists, tuples, dicts,
        deques, numpy arrays and random Generators; override this (and
        :meth:`set_state`) when some attribute is none of these.
        """
        return {"attributes": {k: copy.deepcopy(v) for k, v in self.__dict__.items() if not isinstance(v, Law)},
                "laws": {k: v.get_state() for k, v in self.__dict__.items() if isinstance(v, Law)}}

    def set_state(self, state: Any) -> None:
        attributes, laws = state["attributes"], state["laws"]
        # a state names only attributes the law has: it cannot add one, or shadow a method
        unknown = [k for k in (*attributes, *laws) if k not in self.__dict__]
        if unknown or any(isinstance(self.__dict__[k], Law) for k in attributes) \
                or not all(isinstance(self.__dict__[k], Law) for k in laws):
            raise ValueError(f"a state of another law: attributes {sorted(map(str, (*attributes, *laws)))}")
        self.__dict__.update(copy.deepcopy(attributes))
        for name, inner in laws.items():
            self.__dict__[name].set_state(inner)


def check_sample_time(Ts: float, field: str = "Ts", allow_zero: bool = False) -> float:
    """A sample time as a float, or SceneError naming the field.

    Examples
    --------
    >>> check_sample_time("1e-3")
    0.001
    >>> check_sample_time(0)
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: Ts: sample time must be finite and > 0, got 0.0
    >>> check_sample_time(0, allow_zero=True)        # 0: once per communication step
    0.0
    """
    try:
        Ts = float(Ts)
    except (TypeError, ValueError):
        raise SceneError(field, f"must be a number, got {Ts!r}") from None
    if not math.isfinite(Ts) or Ts < 0 or (Ts == 0 and not allow_zero):
        need = ">= 0" if allow_zero else "> 0"
        raise SceneError(field, f"sample time must be finite and {need}, got {Ts}")
    return Ts


def check_number(value, field: str, low: float = -math.inf, high: float = math.inf,
                 low_open: bool = False) -> float:
    """A finite float in [low, high] (or (low, high]), or SceneError naming the field.

    The project's one gate for numbers (:func:`grubler.limits.number`), without
    its magnitude bound: a controller's limits use +-1e300 for "none".

    Examples
    --------
    >>> check_number("2.5", "K", low=0.0)
    2.5
    >>> check_number(float("nan"), "K")
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: K: must be a finite number, got nan
    >>> check_number(5, "b", 0.0, 1.0)
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: b: must be <= 1, got 5
    """
    if isinstance(value, np.generic):
        value = value.item()
    try:
        return number(value, field, low=None if low == -math.inf else low,
                      high=None if high == math.inf else high, low_open=low_open, magnitude=math.inf)
    except InputError as exc:
        raise SceneError(exc.field, exc.reason) from None


def check_count(value, field: str, limit: int) -> int:
    """A whole number in [0, limit], or SceneError naming the field and the limit.

    For a parameter that sizes a buffer: the limit keeps a mistyped value from
    allocating until the operating system ends the host process.

    Examples
    --------
    >>> check_count(16384, "counts_per_rev", 10**7)
    16384
    >>> check_count(10**9, "counts_per_rev", 10**7)
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: counts_per_rev: must be at most 10000000, got 1000000000
    """
    if isinstance(value, bool):
        raise SceneError(field, f"must be a whole number, got {value!r}")
    try:
        ok = int(value) == value
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok or value < 0:
        raise SceneError(field, f"must be a whole number >= 0, got {value!r}")
    if value > limit:
        raise SceneError(field, f"must be at most {limit}, got {value!r}")
    return int(value)


class Sampler:
    """Runs a :class:`Law` over communication steps with sample-and-hold.

    Parameters
    ----------
    law : Law
    t0 : float
        Start time, s: the first sample instant.

    Attributes
    ----------
    outputs : dict
        The held outputs (those of the last sample).
    samples : int
        Number of samples run so far.

    Examples
    --------
    >>> from grubler.controllers import PID, Sampler
    >>> s = Sampler(PID(K=2.0, Ti=0.5, Ts=1e-3))
    >>> out = s.step(0.0, 0.1, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 0.0})  # 100 samples held
    >>> round(out["u"], 3)              # 2 e + the integral 2/0.5 of e over the step's samples
    2.396
    """

    def __init__(self, law: Law, t0: float = 0.0):
        self.law = law
        self.t0 = float(t0)
        self.samples = 0
        self.outputs = dict(law.initial_outputs(self.t0))

    def step(self, t: float, h: float, inputs: dict[str, float]) -> dict[str, float]:
        """Advance from ``t`` to ``t + h`` with ``inputs`` held; return the outputs at ``t + h``.

        Raises
        ------
        ValueError
            A step that is not positive and finite, one that holds more than
            ``MAX_SAMPLES_PER_STEP`` samples, or a non-finite input.
        """
        law = self.law
        lib, due, when = native.functions(), ctypes.c_double(), ctypes.c_double()
        clock = native.Clock(self.t0, law.Ts, 1 if law.continuous else 0)
        status = lib.ctl_samples_due(ctypes.byref(clock), float(self.samples), t, h, ctypes.byref(due))
        if status == native.BAD_STEP_SIZE:
            raise ValueError(f"step size must be positive and finite, got {h}")
        for name in law.inputs:
            v = inputs[name]
            if not math.isfinite(v):
                raise ValueError(f"{name} is {v} at t = {t:g} s: inputs must be finite")
        if status == native.TOO_MANY_SAMPLES:
            raise ValueError(f"a step of {h:g} s holds {due.value:.3g} samples of Ts = {law.Ts:g} s; "
                             f"at most {MAX_SAMPLES_PER_STEP} per communication step")
        if status != native.OK:
            raise ValueError(f"ctl_samples_due: {native.message(status)}")
        first = float(self.samples)
        for i in range(int(due.value)):
            lib.ctl_sample_instant(ctypes.byref(clock), first, t, h, float(i), ctypes.byref(when))
            self._sample(when.value, inputs)
        return self.outputs

    def _sample(self, t: float, inputs: dict[str, float]) -> None:
        out = self.law.update(t, inputs)
        missing = [name for name in self.law.outputs if name not in out]
        if missing:
            raise ValueError(f"{type(self.law).__name__}.update returned no {', '.join(missing)}")
        self.outputs = out
        self.samples += 1

    def get_state(self) -> dict:
        return {"law": self.law.get_state(), "samples": self.samples, "outputs": dict(self.outputs)}

    def set_state(self, state: dict) -> None:
        self.law.set_state(state["law"])
        self.samples = state["samples"]
        self.outputs = dict(state["outputs"])


__all__ = ["Law", "Parameter", "Sampler", "check_count", "check_number", "check_sample_time", "GRID_TOL",
           "MAX_SAMPLES_PER_STEP"]
