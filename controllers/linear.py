"""Any linear SISO controller, discretised at its sample time, as a state-space update.

The controller C acts on the error ``e = r - y``: given as a python-control
``TransferFunction`` or ``StateSpace`` (continuous, or already discrete at the
sample time), it is discretised with :func:`control.sample_system` ('zoh',
'foh', 'tustin' / 'bilinear', 'euler', 'backward_diff', 'matched', ...) and
realised as

    u_k = C x_k + D e_k + u_ff,k,        x_{k+1} = A x_k + B e_k.

The update runs in C (``controllers/kernel/ctl_linear.c``), which a native FMU
of one controller (:func:`grubler.controllers.native_fmu.linear_spec`: its
discretised matrices as parameters) compiles too.  The pythonfmu FMU takes the
controller as parameters: ``num`` and ``den`` (coefficient
strings, highest power first) or ``state_space`` (TOML text with matrices
``A``, ``B``, ``C``, ``D``), with ``method`` and ``Ts``; ``method = 'none'`` says
the coefficients are already those of a discrete system in z at ``Ts``.

Examples
--------
>>> import control
>>> ctl = LinearController(control.tf([2.0, 1.0], [1.0, 0.0]), Ts=0.1, method="tustin")  # PI: 2 + 1/s
>>> [round(ctl.update(0.1 * k, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 0.0})["u"], 12)
...  for k in range(3)]
[2.05, 2.15, 2.25]
"""

from __future__ import annotations

import ctypes
import re
import tomllib

import numpy as np

from grubler.errors import SceneError
from grubler.limits import brief

from grubler.controllers import native
from grubler.controllers.law import Law, Parameter, check_sample_time

DISCRETE = "none"


# the state has the order of the controller and the update costs its square:
# a controller of higher order is a typing error, not a design
MAX_ORDER = 64


def _coefficients(text: str, field: str) -> list[float]:
    parts = [p for p in re.split(r"[\s,;]+", text.strip().strip("[]")) if p]
    if len(parts) > MAX_ORDER + 1:
        raise SceneError(field, f"{len(parts)} coefficients: a controller has order at most {MAX_ORDER} "
                                f"({MAX_ORDER + 1} coefficients)")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise SceneError(field, f"must be numbers separated by spaces or commas, got {brief(text)}") from None
    if not values or not np.all(np.isfinite(values)):
        raise SceneError(field, f"needs at least one finite coefficient, got {brief(text)}")
    return values


def _matrix(data: dict, key: str) -> np.ndarray:
    if key not in data:
        raise SceneError(f"state_space.{key}", "missing (A, B, C and D are all needed)")
    try:
        m = np.atleast_2d(np.array(data[key], dtype=float))
    except (TypeError, ValueError):
        raise SceneError(f"state_space.{key}", f"must be a matrix of numbers, got {data[key]!r}") from None
    if m.ndim != 2 or not np.all(np.isfinite(m)):
        raise SceneError(f"state_space.{key}", "must be a finite matrix (a list of rows)")
    if max(m.shape) > MAX_ORDER:
        raise SceneError(f"state_space.{key}", f"is {m.shape[0]} x {m.shape[1]}: a controller has order at most "
                                               f"{MAX_ORDER}")
    return m


def _check_discretised(system, sysd, method: str) -> None:
    """Refuse a discretisation with a number that is not finite, naming the method and why.

    'matched' scales the discrete gain to the continuous one at s = 0: a pole
    there (an integrator: any PI) makes that gain infinite, a zero there makes
    it 0, and the scale factor is then NaN.
    """
    import control

    d = control.ss(sysd) if not isinstance(sysd, control.StateSpace) else sysd
    if all(np.all(np.isfinite(np.asarray(m, dtype=float))) for m in (d.A, d.B, d.C, d.D)):
        return
    if method == "matched":
        for kind, roots in (("pole", system.poles()), ("zero", system.zeros())):
            at_zero = [r for r in np.atleast_1d(roots) if abs(r) <= 1e-12 * max(1.0, np.max(np.abs(roots)))]
            if at_zero:
                raise SceneError("method", f"'matched' cannot discretise a controller with a {kind} at s = 0 "
                                           f"(it scales the discrete gain to the continuous one at s = 0, "
                                           f"{'infinite' if kind == 'pole' else 'zero'} there); use 'tustin' or "
                                           "'zoh'")
    raise SceneError("method", f"discretising with {method!r} gives matrices that are not finite (NaN or "
                               "infinite); use another method, e.g. 'tustin'")


class LinearController(Law):
    """A linear SISO controller on the error, as a discrete state-space update.

    Parameters
    ----------
    system : control.TransferFunction or control.StateSpace
        The controller, from the error ``e = r - y`` to ``u``; continuous, or
        discrete with sample time ``Ts``.
    Ts : float
        Sample time, s.
    method : str
        Discretisation method of :func:`control.sample_system`; ignored for a
        discrete system.

    Examples
    --------
    >>> import control
    >>> from grubler.controllers import LinearController, Sampler
    >>> lag = LinearController(control.tf([1.0], [0.1, 1.0]), Ts=1e-3)    # first-order lag, 0.1 s
    >>> out = Sampler(lag).step(0.0, 0.5, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 0.0})
    >>> round(out["u"], 3)              # 1 - exp(-5) after five time constants
    0.993
    """

    inputs = {"setpoint": "setpoint r [any]", "measurement": "measured process value y [any]",
              "feedforward": "feedforward added to the output [any]"}
    outputs = {"u": "controller output [any]"}
    parameters = {
        "num": Parameter("1", "numerator coefficients, highest power first (ignored with state_space) [1]"),
        "den": Parameter("1", "denominator coefficients, highest power first [1]"),
        "state_space": Parameter("", "TOML text with matrices A, B, C, D (overrides num/den) [1]"),
        "method": Parameter("tustin", "zoh | foh | tustin | euler | backward_diff | matched | "
                                      "none (already discrete in z) [1]"),
        "Ts": Parameter(1e-3, "sample time [s]"),
    }

    def __init__(self, system, Ts: float, method: str = "tustin"):
        import control  # here, not at module level: it takes seconds to import, and most runs never need it

        self.Ts = check_sample_time(Ts)
        if not isinstance(system, (control.TransferFunction, control.StateSpace)):
            raise SceneError("system", f"must be a control.TransferFunction or StateSpace, got {type(system).__name__}")
        if system.ninputs != 1 or system.noutputs != 1:
            raise SceneError("system", f"must have one input and one output, got {system.ninputs} and "
                                       f"{system.noutputs}")
        if system.isdtime(strict=True):
            if system.dt is not True and abs(system.dt - self.Ts) > 1e-12 * self.Ts:
                raise SceneError("Ts", f"the discrete system's sample time is {system.dt}, not {self.Ts}")
            sysd = system
        else:
            try:
                with np.errstate(divide="ignore", invalid="ignore"):  # checked below, by name
                    sysd = control.sample_system(system, self.Ts, method=method)
            except (ValueError, NotImplementedError, TypeError) as exc:
                raise SceneError("method", f"cannot discretise with {method!r}: {exc}") from None
            _check_discretised(system, sysd, method)
        try:
            ss = control.ss(sysd)
        except ValueError as exc:  # an improper transfer function
            raise SceneError("system", f"has no state-space realisation: {exc}") from None
        self.method = method
        self.A, self.B, self.C, self.D = (np.asarray(m, dtype=float) for m in (ss.A, ss.B, ss.C, ss.D))
        self.system = sysd
        self._u = ctypes.c_double()
        self.reset()

    @classmethod
    def from_parameters(cls, num: str = "1", den: str = "1", state_space: str = "", method: str = "tustin",
                        Ts: float = 1e-3) -> "LinearController":
        """The controller from its FMU parameters (coefficient strings or TOML matrices)."""
        import control

        Ts = check_sample_time(Ts)
        dt = Ts if method == DISCRETE else 0
        if state_space.strip():
            try:
                data = tomllib.loads(state_space)
            except tomllib.TOMLDecodeError as exc:
                raise SceneError("state_space", f"not valid TOML: {exc}") from None
            matrices = [_matrix(data, k) for k in "ABCD"]
            try:
                system = control.ss(*matrices, dt)
            except ValueError as exc:
                raise SceneError("state_space", f"inconsistent matrices: {exc}") from None
        else:
            n, d = _coefficients(num, "num"), _coefficients(den, "den")
            if d[0] == 0:
                raise SceneError("den", "the leading coefficient must not be zero")
            if len(n) > len(d):
                raise SceneError("num", f"an improper controller: degree {len(n) - 1} over {len(d) - 1}")
            system = control.tf(n, d, dt)
        return cls(system, Ts, method)

    def reset(self) -> None:
        self.x = np.zeros(self.A.shape[0])
        self._work = np.zeros(self.A.shape[0])

    @property
    def matrices(self) -> np.ndarray:
        """A (row-major), B, C and D in one array, as ``ctl_linear.h`` and the native FMU's parameters hold them."""
        return np.concatenate([self.A.ravel(), self.B.ravel(), self.C.ravel(), self.D.ravel()])

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        if not hasattr(self, "_packed"):
            self._packed = np.ascontiguousarray(self.matrices)
        native.call("ctl_linear_sample", len(self.x), self._packed.ctypes.data_as(native.DOUBLES),
                    self.x.ctypes.data_as(native.DOUBLES), inputs["setpoint"], inputs["measurement"],
                    inputs.get("feedforward", 0.0), self._u, self._work.ctypes.data_as(native.DOUBLES))
        return {"u": self._u.value}

    def get_state(self):
        return self.x.tolist()

    def set_state(self, state) -> None:
        x = np.array(state, dtype=float)
        if x.shape != self.x.shape:
            raise ValueError(f"a state of another controller: {x.size} numbers for order {self.x.size}")
        bad = native.check("linear", len(x), x.ctypes.data_as(native.DOUBLES), state=True)
        if bad:
            raise ValueError(f"state.{bad[0]}: {bad[1]}")
        self.x = x


__all__ = ["LinearController"]
