"""A permanent-magnet DC motor with gearbox, current-limited drive and winding thermal model.

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

import math
from dataclasses import dataclass, field, replace

from grubler.errors import SceneError
from grubler.motors.motor_data import MotorData, check_number

_LIMIT_TOL = 1e-12  # relative: a current this close to I_max is at the limit


@dataclass(frozen=True)
class Gearbox:
    """A backlash-free gearbox.

    Parameters
    ----------
    ratio : float
        N >= 1: motor speed / output speed.
    efficiency : float
        eta in (0, 1], applied in the direction of power flow.
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
        T_amb [degC].
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
    """

    data: MotorData
    gear: Gearbox = field(default_factory=Gearbox)
    drive: Drive | None = None
    ambient_temperature: float = 25.0
    max_substep: float = 0.01

    def __post_init__(self):
        if not isinstance(self.data, MotorData):
            raise SceneError("motor", f"must be a MotorData, got {type(self.data).__name__}")
        if self.drive is None:
            if self.data.nominal_voltage is None:
                raise SceneError("supply_voltage", f"motor {self.data.name!r} states no nominal voltage: give a Drive")
            object.__setattr__(self, "drive", Drive(self.data.nominal_voltage))
        t = self.ambient_temperature
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise SceneError("ambient_temperature", f"must be a finite number, got {t!r}")
        object.__setattr__(self, "ambient_temperature", float(t))
        object.__setattr__(self, "max_substep", check_number("max_substep", self.max_substep))
        _check_temperature("ambient_temperature", self.data, self.ambient_temperature)

    @property
    def reflected_inertia(self) -> float:
        """J_rotor N² [kg m2]: the rotor's inertia seen at the gearbox output."""
        return self.data.rotor_inertia * self.gear.ratio ** 2


def _check_temperature(name: str, data: MotorData, temperature: float) -> None:
    if data.resistance_at(temperature) <= 0.0:
        raise SceneError(name, f"{temperature} degC is below where R(T) = R_ref (1 + alpha (T - T_ref)) vanishes")


@dataclass(frozen=True)
class MotorState:
    """What the motor remembers between steps (immutable: keep one to roll back).

    Parameters
    ----------
    current : float
        Winding current i [A].
    temperature : float
        Winding temperature T [degC].
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
    """
    if isinstance(current, bool) or not isinstance(current, (int, float)) or not math.isfinite(current):
        raise SceneError("initial_current", f"must be a finite number, got {current!r}")
    if abs(current) > motor.drive.current_limit:
        raise SceneError("initial_current", f"|{current}| A exceeds the current limit {motor.drive.current_limit} A")
    t = motor.ambient_temperature if temperature is None else temperature
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
        raise SceneError("initial_temperature", f"must be a finite number, got {t!r}")
    _check_temperature("initial_temperature", motor.data, t)
    return MotorState(float(current), float(t))


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
    """

    shaft_torque: float
    current: float
    winding_temperature: float
    electrical_power: float
    motor_speed: float
    back_emf: float
    terminal_voltage: float


# -- the drive's voltage law and the exact current solution ----------------------
def _terminal_voltage(i: float, v_cmd: float, emf: float, r: float, drive: Drive) -> tuple[float, bool]:
    """Voltage the drive applies at current i, and whether it is holding the limit."""
    vs, imax = drive.supply_voltage, drive.current_limit
    v = min(max(v_cmd, -vs), vs)
    if abs(i) >= imax * (1.0 - _LIMIT_TOL):
        s = 1.0 if i > 0 else -1.0
        if abs(i) > imax * (1.0 + _LIMIT_TOL):
            return -s * vs, False  # beyond the limit: the drive opposes with all it has
        v_hold = s * imax * r + emf
        if s * v > s * v_hold:  # the command would push the current past the limit
            if abs(v_hold) <= vs:
                return v_hold, True
            return min(max(v_hold, -vs), vs), False
    return v, False


def _mean_square(i0: float, i_ss: float, t: float, tau: float) -> float:
    """Integral of i² over [0, t] for i = i_ss + (i0 - i_ss) exp(-s / tau)."""
    c = i0 - i_ss
    e1, e2 = -math.expm1(-t / tau), -math.expm1(-2.0 * t / tau)
    return i_ss * i_ss * t + 2.0 * i_ss * c * tau * e1 + 0.5 * c * c * tau * e2


def _advance_current(i: float, v_cmd: float, emf: float, r: float, tau: float, h: float,
                     drive: Drive) -> tuple[float, float]:
    """Current after h [s] and the integral of i² over it, exact for constant v_cmd and emf.

    The step is cut where the current reaches the limit (from below, or coming
    back from above), after which the drive's voltage law changes.
    """
    imax = drive.current_limit
    t, acc = 0.0, 0.0
    for _ in range(4):  # at most: free rise, hit limit, hold; or beyond, come back, hold
        rem = h - t
        if rem <= 0.0:
            break
        v, holding = _terminal_voltage(i, v_cmd, emf, r, drive)
        if holding:
            i = math.copysign(imax, i)
            acc += i * i * rem
            break
        i_ss = (v - emf) / r
        target = None
        if imax < math.inf:  # the nearest limit the current crosses on its way to i_ss
            for lim in sorted((imax, -imax), key=lambda x: abs(i - x)):
                a, b = i - lim, i_ss - lim
                if a * b < 0.0 and abs(a) > _LIMIT_TOL * imax:
                    target = lim
                    break
        if target is not None:
            t_hit = -tau * math.log((target - i_ss) / (i - i_ss))
            if t_hit < rem:
                acc += _mean_square(i, i_ss, t_hit, tau)
                i, t = target, t + t_hit
                continue
        acc += _mean_square(i, i_ss, rem, tau)
        i = i_ss + (i - i_ss) * math.exp(-rem / tau)
        break
    return i, acc


def _advance_temperature(temp: float, i2_mean: float, h: float, motor: DCMotor) -> float:
    """Winding temperature after h [s] at mean square current i2_mean, exact for R(T) linear in T."""
    d = motor.data
    c_th = d.thermal_capacity
    p = i2_mean * d.resistance
    a = (p * d.temperature_coefficient - 1.0 / d.thermal_resistance) / c_th  # dT/dt = a T + c
    c = (p * (1.0 - d.temperature_coefficient * d.reference_temperature)
         + motor.ambient_temperature / d.thermal_resistance) / c_th
    x = a * h
    phi = math.expm1(x) / x if abs(x) > 1e-12 else 1.0 + 0.5 * x
    return temp + (a * temp + c) * h * phi


# -- public functions -----------------------------------------------------------------
def outputs(motor: DCMotor, state: MotorState, voltage: float, shaft_speed: float) -> MotorOutputs:
    """The motor's outputs in `state` with inputs `voltage` [V] and `shaft_speed` [rad/s].

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
    d, n = motor.data, motor.gear.ratio
    w = n * shaft_speed
    emf = d.back_emf_constant * w
    v, _ = _terminal_voltage(state.current, voltage, emf, d.resistance_at(state.temperature), motor.drive)
    return MotorOutputs(shaft_torque=shaft_torque(motor, state.current, w), current=state.current,
                        winding_temperature=state.temperature, electrical_power=v * state.current,
                        motor_speed=w, back_emf=emf, terminal_voltage=v)


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
    d, g = motor.data, motor.gear
    tau_m = (d.torque_constant * current - d.viscous_friction * motor_speed
             - d.coulomb_friction * math.tanh(motor_speed / d.smoothing_speed))
    direction = math.tanh(math.copysign(1.0, tau_m) * motor_speed / d.smoothing_speed)
    return g.ratio * tau_m * g.efficiency ** direction


def current_for_torque(motor: DCMotor, torque, motor_speed):
    """Winding current [A] that gives gearbox output `torque` [N m] at `motor_speed` [rad/s].

    The inverse of :func:`shaft_torque`, elementwise over arrays: the gearbox
    factor keeps the sign of the motor torque, so the direction of power flow
    is known from the output torque and the speed.

    Examples
    --------
    >>> from grubler.motors import load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(ratio=10.0, efficiency=0.8))
    >>> i = current_for_torque(m, 2.0, 500.0)
    >>> round(float(shaft_torque(m, float(i), 500.0)), 12)
    2.0
    """
    import numpy as np

    d, g = motor.data, motor.gear
    torque, w = np.asarray(torque, float), np.asarray(motor_speed, float)
    direction = np.tanh(np.sign(torque) * w / d.smoothing_speed)
    tau_m = torque / (g.ratio * g.efficiency ** direction)
    return (tau_m + d.viscous_friction * w + d.coulomb_friction * np.tanh(w / d.smoothing_speed)) / d.torque_constant


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
        Non-finite `voltage` or `shaft_speed`, or `dt` not positive and finite.

    Examples
    --------
    A stalled RE 40 at 1 V: the current settles at V / R in a few L / R (0.28 ms).

    >>> from grubler.motors import load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"))
    >>> s, out = step(m, initial_state(m), 1.0, 0.0, 0.005)
    >>> round(out.current, 6), round(1.0 / 1.16, 6)
    (0.862069, 0.862069)
    """
    for name, v in (("voltage", voltage), ("shaft_speed", shaft_speed)):
        if not math.isfinite(v):
            raise SceneError(name, f"must be finite, got {v}")
    if not (dt > 0.0 and math.isfinite(dt)):
        raise SceneError("dt", f"must be positive and finite, got {dt}")
    d = motor.data
    w = motor.gear.ratio * shaft_speed
    emf = d.back_emf_constant * w
    n = max(1, math.ceil(dt / motor.max_substep - 1e-9))
    h = dt / n
    i, temp = state.current, state.temperature
    for _ in range(n):
        r = d.resistance_at(temp)
        if r <= 0.0:
            raise SceneError("winding_temperature", f"{temp:.6g} degC: the winding's resistance model gives R <= 0")
        i, i2 = _advance_current(i, voltage, emf, r, d.inductance / r, h, motor.drive)
        temp = _advance_temperature(temp, i2 / h, h, motor)
    new = MotorState(i, temp)
    return new, outputs(motor, new, voltage, shaft_speed)


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
