"""A permanent-magnet DC motor with gearbox, current-limited drive and winding thermal model.

The equations below run in C (``motors/kernel/dc_motor.c``, called through
:mod:`grubler.motors.native`), the same code the native DCMotor.fmu runs; this
module checks what users give it, naming the field at fault, and wraps the
results in immutable records.

The motor is one side of a co-simulation coupling: the rotor's inertia lives in
the mechanism's mass matrix (``drive.inertia`` = J_rotor N², see
:attr:`DCMotor.reflected_inertia`), so the motor does not integrate speed.  It
takes the gearbox output's speed as an input, holds it over a step, advances its
own state -- the winding current and temperature -- and outputs the gearbox
output torque, without the rotor's inertia torque.

Equations (motor side, omega_m = N omega_shaft)
-----------------------------------------------
* winding: ``L di/dt = v - R(T) i - k_e omega_m``, solved exactly over each
  sub-step with v and omega_m constant, so the electrical pole R/L (1e3 to 1e4
  rad/s) needs no small steps.  R(T) = R_ref (1 + alpha (T - T_ref)) is held at
  its value at the sub-step's start.
* drive: the commanded voltage is clamped to ±V_supply.  The current limiter
  works as a drive's current loop does: when the current reaches ±I_max and the
  command would push it further, the drive lowers its output to the voltage that
  holds di/dt = 0 at the limit, ``v = ±R I_max + k_e omega_m``.  The switch-over
  instant inside a step is found exactly.  The limit holds whenever the supply can
  hold it, ``R I_max + |k_e omega_m| <= V_supply``; a motor back-driven faster than
  that generates more than the bridge can oppose, and, as through a real bridge's
  freewheeling diodes, its current then exceeds the limit while the drive applies
  the full opposing voltage.
* torque at the motor shaft: ``tau_m = k_t i - b omega_m - tau_c tanh(omega_m / omega_s)``.
* gearbox (ratio N >= 1, efficiency eta, no backlash): the output torque is
  ``N eta tau_m`` when the motor drives (tau_m omega_m > 0) and ``N tau_m / eta``
  when the load drives the motor, blended as ``N tau_m eta**tanh(sign(tau_m) omega_m / omega_s)``
  so that the torque stays continuous through zero speed (lossless at standstill).
* winding temperature, one node: ``C_th dT/dt = i² R(T) - (T - T_amb) / R_th``,
  C_th = tau_th / R_th, solved exactly over each sub-step with i² replaced by its
  exact mean over the sub-step.  Only copper loss heats the winding.

Coupling limits (for the master)
--------------------------------
With the speed held over a communication step h the back-EMF acts on the
mechanism as a damper of N² k_t k_e / R, and the dry friction as one of up to
N² tau_c / omega_s: an explicit coupling is stable for ``h < 2 J R / (k_t k_e)``
(twice the mechanical time constant, J the total inertia at the motor) and free
of friction chatter for ``h tau_c / (omega_s J_rotor) < 2``.
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass, field, replace

import numpy as np

from grubler.errors import InputError, SceneError
from grubler.limits import number
from grubler.motors import native
from grubler.motors.motor_data import AMBIENT_RANGE, MotorData, check_number


@dataclass(frozen=True)
class Gearbox:
    """A backlash-free gearbox.

    Parameters
    ----------
    ratio : float
        N >= 1: motor speed / output speed.
    efficiency : float
        eta in (0, 1], applied in the direction of power flow.

    Examples
    --------
    >>> from grubler.motors import Gearbox
    >>> Gearbox(ratio=50.0, efficiency=0.9), Gearbox()
    (Gearbox(ratio=50.0, efficiency=0.9), Gearbox(ratio=1.0, efficiency=1.0))
    """

    ratio: float = 1.0
    efficiency: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "ratio", check_number("gear_ratio", self.ratio))
        if self.ratio < 1.0:
            raise SceneError("gear_ratio", f"must be >= 1 (a reduction), got {self.ratio}")
        object.__setattr__(self, "efficiency", check_number("gear_efficiency", self.efficiency))
        if self.efficiency > 1.0:
            raise SceneError("gear_efficiency", f"must be in (0, 1], got {self.efficiency}")


@dataclass(frozen=True)
class Drive:
    """The motor's power stage.

    Parameters
    ----------
    supply_voltage : float
        V_supply [V]: the terminal voltage is clamped to ±V_supply.
    current_limit : float
        I_max [A] of the current limiter (``math.inf``: none).

    Examples
    --------
    >>> from grubler.motors import Drive
    >>> Drive(24.0)                                   # 24 V supply, no current limit
    Drive(supply_voltage=24.0, current_limit=inf)
    """

    supply_voltage: float
    current_limit: float = math.inf

    def __post_init__(self):
        object.__setattr__(self, "supply_voltage", check_number("supply_voltage", self.supply_voltage))
        object.__setattr__(self, "current_limit", check_number("current_limit", self.current_limit, allow_inf=True))


@dataclass(frozen=True)
class DCMotor:
    """A DC motor with its gearbox, drive and surroundings: the constants of a step.

    Parameters
    ----------
    data : MotorData
    gear : Gearbox
    drive : Drive
        Default: the motor's nominal voltage, no current limit.
    ambient_temperature : float
        T_amb [degC], within :data:`~grubler.motors.motor_data.AMBIENT_RANGE`.
    max_substep : float
        Longest internal step [s].  The current is exact for any step; sub-steps
        only refresh R(T) and the thermal coupling, which change on the thermal
        time scale (seconds), so 10 ms is plenty.

    Examples
    --------
    >>> from grubler.motors import load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(ratio=10.0, efficiency=0.9))
    >>> round(m.reflected_inertia, 10)           # J_rotor N², for the mechanism's drive.inertia
    0.00134
    >>> m.drive.supply_voltage
    48.0
    >>> from grubler.motors import DCMotor, Drive, Gearbox, load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(ratio=50.0, efficiency=0.9), Drive(48.0, current_limit=10.0))
    >>> round(m.reflected_inertia, 4)                 # J_rotor N^2, kg m2: the mechanism's drive.inertia
    0.0335
    """

    data: MotorData
    gear: Gearbox = field(default_factory=Gearbox)
    drive: Drive | None = None
    ambient_temperature: float = 25.0
    max_substep: float = 0.01
    _params: native.Params = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        if not isinstance(self.data, MotorData):
            raise SceneError("motor", f"must be a MotorData, got {type(self.data).__name__}")
        if self.drive is None:
            if self.data.nominal_voltage is None:
                raise SceneError("supply_voltage", f"motor {self.data.name!r} states no nominal voltage: give a Drive")
            object.__setattr__(self, "drive", Drive(self.data.nominal_voltage))
        lo, hi = AMBIENT_RANGE
        try:
            t = number(self.ambient_temperature, "ambient_temperature", low=lo, high=hi, unit="degC")
        except InputError as exc:
            raise SceneError(exc.field, exc.reason) from None
        object.__setattr__(self, "ambient_temperature", float(t))
        object.__setattr__(self, "max_substep", check_number("max_substep", self.max_substep))
        d, g, v = self.data, self.gear, self.drive
        params = native.Params(
            d.resistance, d.inductance, d.torque_constant, d.back_emf_constant, d.rotor_inertia,
            d.viscous_friction, d.coulomb_friction, d.smoothing_speed, d.thermal_resistance,
            d.thermal_time_constant, d.temperature_coefficient, d.reference_temperature, g.ratio, g.efficiency,
            v.supply_voltage, v.current_limit, self.ambient_temperature, self.max_substep)
        # the C model's own check is the last word: what it accepts here, it steps
        # (the rules that only a whole motor can check, such as R(T_amb) > 0, live there)
        bad = native.check("params", params)
        if bad is not None:
            name, why = bad
            raise SceneError(name, f"{why} (got {getattr(params, name)!r})")
        object.__setattr__(self, "_params", params)

    @property
    def reflected_inertia(self) -> float:
        """J_rotor N² [kg m2]: the rotor's inertia seen at the gearbox output."""
        out = ctypes.c_double()
        _call(native.functions().dcm_reflected_inertia(ctypes.byref(self._params), ctypes.byref(out)))
        return out.value

    @property
    def chatter_free_step(self) -> float:
        """Longest step [s] over which a held speed keeps the dry friction from chattering.

        2 omega_s J_rotor / tau_c (see the module's coupling limits), inf without
        dry friction.
        """
        out = ctypes.c_double()
        _call(native.functions().dcm_chatter_free_step(ctypes.byref(self._params), ctypes.byref(out)))
        return out.value


@dataclass(frozen=True)
class MotorState:
    """What the motor remembers between steps (immutable: keep one to roll back).

    Parameters
    ----------
    current : float
        Winding current i [A].
    temperature : float
        Winding temperature T [degC].

    Examples
    --------
    >>> from grubler.motors import DCMotor, MotorState, load_motor, step
    >>> m = DCMotor(load_motor("maxon-re40-148877"))
    >>> s = MotorState(current=0.0, temperature=25.0)
    >>> s2, _ = step(m, s, 12.0, 0.0, 1e-3)           # a new state; s is unchanged
    >>> s.current, round(s2.current, 3)
    (0.0, 10.037)
    """

    current: float
    temperature: float


def initial_state(motor: DCMotor, current: float = 0.0, temperature: float | None = None) -> MotorState:
    """A checked start state (temperature: ambient unless given).

    Raises
    ------
    SceneError
        ``initial_current`` beyond the current limit or not finite;
        ``initial_temperature`` not finite or below where R(T) vanishes.

    Examples
    --------
    >>> from grubler.motors import DCMotor, Drive, initial_state, load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"), drive=Drive(48.0, current_limit=10.0))
    >>> initial_state(m)                              # at rest, winding at ambient
    MotorState(current=0.0, temperature=25.0)
    >>> try:
    ...     initial_state(m, current=20.0)
    ... except Exception as e:
    ...     print(type(e).__name__, e.field)
    SceneError initial_current
    """
    t = motor.ambient_temperature if temperature is None else temperature
    for name, value in (("initial_current", current), ("initial_temperature", t)):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SceneError(name, f"must be a number, got {value!r}")
    state = MotorState(float(current), float(t))
    bad = native.check("state", motor._params, native.State(state.current, state.temperature))
    if bad is not None:
        name, why = bad
        limit = f", limit {motor.drive.current_limit} A" if name == "current" else ""
        raise SceneError(f"initial_{name}", f"{why} (got {getattr(state, name)!r}{limit})")
    return state


@dataclass(frozen=True)
class MotorOutputs:
    """The motor's outputs at one instant (SI units; torque and speed at the gearbox output unless named motor_).

    Attributes
    ----------
    shaft_torque : float
        Gearbox output torque [N m], without the rotor's inertia torque.
    current : float
        Winding current [A].
    winding_temperature : float
        [degC].
    electrical_power : float
        Terminal voltage x current [W] (negative when generating).
    motor_speed : float
        N x shaft speed [rad/s].
    back_emf : float
        k_e x motor speed [V].
    terminal_voltage : float
        The voltage the drive applies [V] (command after the clamp and the current limiter).

    Examples
    --------
    >>> from grubler.motors import DCMotor, Gearbox, initial_state, load_motor, outputs
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(50.0, 0.9))
    >>> out = outputs(m, initial_state(m), voltage=12.0, shaft_speed=1.0)
    >>> out.current, round(out.motor_speed, 1), round(out.back_emf, 3), out.terminal_voltage
    (0.0, 50.0, 3.022, 12.0)
    """

    shaft_torque: float
    current: float
    winding_temperature: float
    electrical_power: float
    motor_speed: float
    back_emf: float
    terminal_voltage: float


# -- the model, in C ------------------------------------------------------------------
# what each failure of dcm_step / dcm_observe means to the caller: the field at fault
_FAILURES = {native.BAD_VOLTAGE: "voltage", native.BAD_SHAFT_SPEED: "shaft_speed", native.BAD_STEP_SIZE: "dt",
             native.RESISTANCE_VANISHED: "winding_temperature", native.BAD_STATE: "state"}


def _call(status: int, **given) -> None:
    """Raise SceneError naming the field for a C model status other than OK."""
    if status == native.OK:
        return
    name = _FAILURES.get(status)
    if name is None:  # a NULL pointer or a wrong count: a defect of this module, not the user's input
        raise RuntimeError(f"dc_motor: {native.message(status)}")
    got = f" (got {given[name]!r})" if name in given else ""
    raise SceneError(name, native.message(status) + got)


def _record(out: native.Outputs) -> MotorOutputs:
    return MotorOutputs(out.shaft_torque, out.current, out.winding_temperature, out.electrical_power,
                        out.motor_speed, out.back_emf, out.terminal_voltage)


# -- public functions -----------------------------------------------------------------
def outputs(motor: DCMotor, state: MotorState, voltage: float, shaft_speed: float) -> MotorOutputs:
    """The motor's outputs in `state` with inputs `voltage` [V] and `shaft_speed` [rad/s].

    Raises
    ------
    SceneError
        Non-finite `voltage` or `shaft_speed`.

    Examples
    --------
    >>> from grubler.motors import load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(ratio=5.0, efficiency=0.8))
    >>> out = outputs(m, MotorState(current=2.0, temperature=25.0), 24.0, 100.0)
    >>> out.motor_speed, round(out.back_emf, 3)
    (500.0, 30.219)
    >>> tau_m = 0.0603 * 2.0 - 0.0603 * 0.069 * math.tanh(500.0 / 10.0)
    >>> abs(out.shaft_torque - 5.0 * 0.8 * tau_m) < 1e-12       # the motor drives: N eta tau_m
    True
    """
    voltage, shaft_speed = float(voltage), float(shaft_speed)
    s, out = native.State(state.current, state.temperature), native.Outputs()
    _call(native.functions().dcm_observe(ctypes.byref(motor._params), ctypes.byref(s), voltage, shaft_speed,
                                         ctypes.byref(out)), voltage=voltage, shaft_speed=shaft_speed)
    return _record(out)


def shaft_torque(motor: DCMotor, current: float, motor_speed: float) -> float:
    """Gearbox output torque [N m] at winding `current` [A] and `motor_speed` [rad/s].

    Examples
    --------
    >>> from grubler.motors import load_motor
    >>> d = load_motor("maxon-re40-148877").replace(coulomb_friction=0.0)
    >>> m = DCMotor(d, Gearbox(ratio=10.0, efficiency=0.5))
    >>> round(shaft_torque(m, 1.0, 1000.0), 6)    # driving: N eta k_t i
    0.3015
    >>> round(shaft_torque(m, 1.0, -1000.0), 6)   # back-driven: N k_t i / eta
    1.206
    """
    out = ctypes.c_double()
    _call(native.functions().dcm_shaft_torque(ctypes.byref(motor._params), float(current), float(motor_speed),
                                              ctypes.byref(out)))
    return out.value


def current_for_torque(motor: DCMotor, torque, motor_speed):
    """Winding current [A] that gives gearbox output `torque` [N m] at `motor_speed` [rad/s].

    The inverse of :func:`shaft_torque`, elementwise over arrays (broadcast
    against each other; one C loop over them): the gearbox factor keeps the sign
    of the motor torque, so the direction of power flow is known from the
    output torque and the speed.

    Examples
    --------
    >>> from grubler.motors import load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(ratio=10.0, efficiency=0.8))
    >>> i = current_for_torque(m, 2.0, 500.0)
    >>> round(float(shaft_torque(m, float(i), 500.0)), 12)
    2.0
    >>> from grubler.motors import DCMotor, Drive, Gearbox, current_for_torque, load_motor, shaft_torque
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(50.0, 0.9), Drive(48.0, 10.0))
    >>> i = current_for_torque(m, 5.0, 0.0)          # 5 N m at the gearbox output, at standstill
    >>> round(float(i), 4), round(float(shaft_torque(m, i, 0.0)), 6)
    (1.6584, 5.0)
    """
    torque, w = np.broadcast_arrays(np.asarray(torque, float), np.asarray(motor_speed, float))
    current = np.empty(torque.shape)  # before ascontiguousarray, which makes a 0-d array 1-d
    torque, w = np.ascontiguousarray(torque), np.ascontiguousarray(w)
    dp = ctypes.POINTER(ctypes.c_double)
    _call(native.functions().dcm_current_for_torque(ctypes.byref(motor._params), current.size,
                                                    torque.ctypes.data_as(dp), w.ctypes.data_as(dp),
                                                    current.ctypes.data_as(dp)))
    return current[()]


@dataclass(frozen=True)
class MotorLinearization:
    """The motor's linear model about an operating point (:func:`linearization`).

    ``di/dt = di_di i + di_dspeed w + di_dvoltage v`` and ``tau = dtau_di i +
    dtau_dspeed w``, with w the gearbox output speed and tau its torque (exact:
    the winding equation is linear; the torque law's derivatives are analytic).
    """

    di_di: float
    di_dspeed: float
    di_dvoltage: float
    dtau_di: float
    dtau_dspeed: float

    def steady_voltage(self, current: float, shaft_speed: float) -> float:
        """The voltage [V] that holds `current` [A] at `shaft_speed` [rad/s] (di/dt = 0)."""
        return -(self.di_di * current + self.di_dspeed * shaft_speed) / self.di_dvoltage


def linearization(motor: DCMotor, state: MotorState, shaft_speed: float) -> MotorLinearization:
    """Partial derivatives of the motor's equations at `state` and `shaft_speed` (dcm_linearize).

    The winding temperature is held at the state's (it moves on the thermal time
    constant) and the drive's clamp and current limiter are taken as inactive:
    the caller checks that the operating point lies inside them.

    Examples
    --------
    >>> from grubler.motors import load_motor
    >>> d = load_motor("maxon-re40-148877")
    >>> m = DCMotor(d, Gearbox(ratio=50.0, efficiency=0.9))
    >>> lin = linearization(m, initial_state(m), 0.0)
    >>> round(lin.di_di, 3) == round(-d.resistance / d.inductance, 3)      # -R/L at the reference temperature
    True
    >>> round(lin.dtau_di, 6) == round(50.0 * d.torque_constant, 6)       # N k_t at standstill
    True
    >>> from grubler.motors import DCMotor, Gearbox, initial_state, linearization, load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(50.0, 0.9))
    >>> lin = linearization(m, initial_state(m), shaft_speed=1.0)
    >>> round(lin.di_dvoltage, 1), round(lin.dtau_di, 4)      # 1/L (A/s per V), k_t N eta (N m per A)
    (3030.3, 3.35)
    """
    out = (ctypes.c_double * 5)()
    _call(native.functions().dcm_linearize(ctypes.byref(motor._params),
                                           ctypes.byref(native.State(state.current, state.temperature)),
                                           float(shaft_speed), out), shaft_speed=shaft_speed)
    return MotorLinearization(*out)


def step(motor: DCMotor, state: MotorState, voltage: float, shaft_speed: float,
         dt: float) -> tuple[MotorState, MotorOutputs]:
    """Advance the motor by `dt` [s] holding `voltage` [V] and `shaft_speed` [rad/s].

    Returns
    -------
    state : MotorState
        The state at the end of the step.
    outputs : MotorOutputs
        The outputs at the end of the step (same inputs).

    Raises
    ------
    SceneError
        Non-finite `voltage` or `shaft_speed`; `dt` not positive and finite, or
        more than 1e8 sub-steps of ``motor.max_substep``; a non-finite `state`;
        a winding cooled to where R(T) vanishes (``winding_temperature``).

    Examples
    --------
    A stalled RE 40 at 1 V: the current settles at V / R in a few L / R (0.28 ms).

    >>> from grubler.motors import load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"))
    >>> s, out = step(m, initial_state(m), 1.0, 0.0, 0.005)
    >>> round(out.current, 6), round(1.0 / 1.16, 6)
    (0.862069, 0.862069)
    >>> from grubler.motors import DCMotor, Drive, Gearbox, initial_state, load_motor, step
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(50.0, 0.9), Drive(48.0, current_limit=10.0))
    >>> state, out = step(m, initial_state(m), voltage=24.0, shaft_speed=0.0, dt=1e-3)
    >>> state.current, round(out.shaft_torque, 2)     # the current limiter holds 10 A
    (10.0, 30.15)
    """
    voltage, shaft_speed, dt = float(voltage), float(shaft_speed), float(dt)
    s, out = native.State(state.current, state.temperature), native.Outputs()
    _call(native.functions().dcm_step(ctypes.byref(motor._params), ctypes.byref(s), voltage, shaft_speed, dt,
                                      ctypes.byref(out)),
          voltage=voltage, shaft_speed=shaft_speed, dt=dt, state=state)
    return MotorState(s.current, s.temperature), _record(out)


class MotorSimulator:
    """A motor and its state, stepped in place; :meth:`snapshot` / :meth:`restore` roll it back.

    Examples
    --------
    >>> from grubler.motors import load_motor
    >>> sim = MotorSimulator(DCMotor(load_motor("maxon-re40-148877")))
    >>> saved = sim.snapshot()
    >>> first = sim.step(12.0, 50.0, 1e-3)
    >>> sim.restore(saved)
    >>> sim.step(12.0, 50.0, 1e-3) == first
    True
    """

    def __init__(self, motor: DCMotor, state: MotorState | None = None):
        self.motor = motor
        self.state = initial_state(motor) if state is None else state

    def step(self, voltage: float, shaft_speed: float, dt: float) -> MotorOutputs:
        """Advance by `dt` [s]; see :func:`step`."""
        self.state, out = step(self.motor, self.state, voltage, shaft_speed, dt)
        return out

    def outputs(self, voltage: float, shaft_speed: float) -> MotorOutputs:
        """Outputs now, for these inputs; see :func:`outputs`."""
        return outputs(self.motor, self.state, voltage, shaft_speed)

    def snapshot(self) -> MotorState:
        """The state, to :meth:`restore` later."""
        return self.state

    def restore(self, state: MotorState) -> None:
        """Return to a state from :meth:`snapshot`."""
        self.state = replace(state)
