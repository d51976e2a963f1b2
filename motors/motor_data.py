"""Permanent-magnet DC motor data sets: the constants of one motor, in SI units.

A data set is a :class:`MotorData`.  Datasheets state their figures in their own
units (mNm/A, rpm/V, g cm², mH, K/W ...): :meth:`MotorData.from_datasheet` takes
them in those units, converts them, derives what the model needs and checks the
figures against each other.  The data sets shipped with grubler live in
``motors/data/*.toml``, one motor a file, written in the datasheet's units; a file
names its source and says which fields were derived.  :func:`load_motor` reads one
by name, from a path or from TOML text; :func:`list_motors` names the shipped ones.

What is derived, and how
------------------------
* back-EMF constant: k_e = 1 / k_n in V s/rad from the speed constant k_n, and
  checked against the torque constant (in SI units k_e = k_t for an ideal machine,
  which is what conserves energy).  A mismatch beyond ``KE_KT_TOLERANCE`` (2 %)
  is an error, not a warning: it means a mistyped figure (datasheet rounding is
  below 0.5 %), and a model with k_e != k_t creates or destroys power.
* Coulomb friction: k_t times the no-load current (all of the no-load loss read
  as dry friction), or the datasheet's friction torque where it gives one.
* thermal model: one node, winding to ambient.  From a two-node datasheet
  (R_th1 winding-housing, R_th2 housing-ambient, tau_w winding, tau_m motor):
  R_th = R_th1 + R_th2 keeps the steady state exact, and tau_th is the slow time
  constant of the two-node network those four constants define, which governs
  continuous operation.  The fast winding mode (tens of seconds) is lost: during the
  first minute of an overload the single node heats more slowly than the winding
  does, by up to R_th1 / (R_th1 + R_th2) of the rise.
"""

from __future__ import annotations

import math
import re
import textwrap
import tomllib
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path

from grubler.errors import SceneError
from grubler.limits import did_you_mean

KE_KT_TOLERANCE = 0.02
"""Largest accepted relative mismatch between k_e and k_t (SI units)."""

STALL_TOLERANCE = 0.05
"""Largest accepted relative mismatch between a stated stall torque and k_t U / R - friction."""

NO_LOAD_TOLERANCE = 0.03
"""Largest accepted relative mismatch between a stated no-load speed and k_n (U - R I_0)."""

NOMINAL_TOLERANCE = 0.03
"""Largest accepted relative mismatch between a stated nominal current and M_N / k_t + I_0, and
between a stated speed/torque gradient (or mechanical time constant) and R / k_t² (J R / k_t²)."""

RPM = math.pi / 30.0  # rad/s per rpm

AMBIENT_RANGE = (-50.0, 200.0)
"""Ambient temperatures [degC] a motor model accepts.  Motors are rated for about
-40 to +100 degC; the range leaves room to study beyond a rating while refusing
what no surroundings are (1e6 degC, a unit slip from kelvin is still inside)."""


def check_number(field: str, value, *, positive: bool = True, allow_inf: bool = False,
           optional: bool = False) -> float | None:
    """A finite float (positive, or >= 0), or SceneError naming `field`."""
    if value is None:
        if optional:
            return None
        raise SceneError(field, "is missing")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(field, f"must be a number, got {value!r}")
    v = float(value)
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise SceneError(field, f"must be finite, got {v}")
    if positive and not v > 0:
        raise SceneError(field, f"must be positive, got {v}")
    if not positive and v < 0:
        raise SceneError(field, f"must be >= 0, got {v}")
    return v


@dataclass(frozen=True)
class MotorData:
    """Constants of a permanent-magnet DC motor, SI units, at the motor shaft.

    Parameters
    ----------
    name : str
        Short identifier (e.g. ``maxon-re40-148877``).
    source : str
        Where the figures come from: manufacturer, series, part number, document.
    resistance : float
        Terminal (armature) resistance R_ref [Ohm] at `reference_temperature`.
    inductance : float
        Terminal inductance L [H].
    torque_constant : float
        k_t [N m/A].
    back_emf_constant : float
        k_e [V s/rad]; within 2 % of k_t.
    rotor_inertia : float
        J_rotor [kg m2].  It belongs in the mechanism's mass matrix (times N²).
    viscous_friction : float
        b [N m s/rad] at the motor shaft.
    coulomb_friction : float
        tau_c [N m] at the motor shaft.
    smoothing_speed : float
        omega_s [rad/s]: the dry friction is ``tau_c tanh(omega / omega_s)`` and the
        gearbox's efficiency changes direction over the same motor-speed scale.
        A master holding the speed over a step h is free of friction chatter when
        ``h tau_c / (omega_s J_rotor) < 2`` (worst case: nothing but the rotor on
        the shaft).
    thermal_resistance : float
        R_th winding to ambient [K/W].
    thermal_time_constant : float
        tau_th [s] of the one-node winding model (heat capacity tau_th / R_th).
    temperature_coefficient : float
        alpha [1/K] of the winding's resistance: R(T) = R_ref (1 + alpha (T - T_ref));
        0.0039 /K for copper.
    reference_temperature : float
        T_ref [degC] at which `resistance` is stated.
    notes : str
        Which fields were derived, and how.
    nominal_voltage, nominal_torque, nominal_speed, no_load_speed, stall_torque, \
max_speed, max_winding_temperature, nominal_current, min_ambient_temperature, max_ambient_temperature : \
float or None
        Datasheet figures for sizing [V, N m, rad/s, rad/s, N m, rad/s, degC, A,
        degC, degC]; None where the datasheet gives none.  ``nominal_torque`` is
        the maximum continuous torque, ``nominal_current`` its current.

    Examples
    --------
    >>> m = MotorData(name="toy", source="made up", resistance=1.0, inductance=1e-3,
    ...               torque_constant=0.05, back_emf_constant=0.05, rotor_inertia=1e-5,
    ...               thermal_resistance=5.0, thermal_time_constant=600.0)
    >>> m.electrical_time_constant
    0.001
    >>> round(m.mechanical_time_constant, 6)  # J R / (k_t k_e)
    0.004
    >>> from grubler.motors import MotorData, load_motor
    >>> d = load_motor("maxon-re40-148877")
    >>> d.resistance, d.torque_constant, d.nominal_voltage     # Ohm, N m/A, V
    (1.16, 0.0603, 48.0)
    >>> mine = MotorData.from_datasheet(name="my-motor", source="my datasheet", terminal_resistance_ohm=2.0,
    ...                                 terminal_inductance_mH=0.5, torque_constant_mNm_per_A=30.0,
    ...                                 rotor_inertia_gcm2=20.0, thermal_resistance_K_per_W=8.0,
    ...                                 thermal_time_constant_s=600.0)
    >>> mine.torque_constant, round(mine.rotor_inertia, 9)    # in SI units
    (0.03, 2e-06)
    """

    name: str
    source: str
    resistance: float
    inductance: float
    torque_constant: float
    back_emf_constant: float
    rotor_inertia: float
    thermal_resistance: float
    thermal_time_constant: float
    viscous_friction: float = 0.0
    coulomb_friction: float = 0.0
    smoothing_speed: float = 10.0
    temperature_coefficient: float = 0.0039
    reference_temperature: float = 25.0
    notes: str = ""
    nominal_voltage: float | None = None
    nominal_torque: float | None = None
    nominal_speed: float | None = None
    no_load_speed: float | None = None
    stall_torque: float | None = None
    max_speed: float | None = None
    max_winding_temperature: float | None = None
    nominal_current: float | None = None
    min_ambient_temperature: float | None = None
    max_ambient_temperature: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.strip():
            raise SceneError("name", f"must be a non-empty string, got {self.name!r}")
        if not isinstance(self.source, str) or not self.source.strip():
            raise SceneError("source", "must name where the figures come from")
        for f in ("resistance", "inductance", "torque_constant", "back_emf_constant", "rotor_inertia",
                  "thermal_resistance", "thermal_time_constant", "smoothing_speed"):
            object.__setattr__(self, f, check_number(f, getattr(self, f)))
        for f in ("viscous_friction", "coulomb_friction", "temperature_coefficient"):
            object.__setattr__(self, f, check_number(f, getattr(self, f), positive=False))
        for f in ("reference_temperature", "max_winding_temperature", "min_ambient_temperature",
                  "max_ambient_temperature"):  # degC: any sign
            t = getattr(self, f)
            if t is None and f != "reference_temperature":
                continue
            if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
                raise SceneError(f, f"must be a finite number, got {t!r}")
            object.__setattr__(self, f, float(t))
        lo, hi = self.min_ambient_temperature, self.max_ambient_temperature
        if lo is not None and hi is not None and not lo < hi:
            raise SceneError("max_ambient_temperature", f"must exceed min_ambient_temperature = {lo:g}, got {hi:g}")
        for f in ("nominal_voltage", "nominal_torque", "nominal_speed", "no_load_speed", "stall_torque",
                  "max_speed", "nominal_current"):
            object.__setattr__(self, f, check_number(f, getattr(self, f), optional=True))
        mismatch = self.back_emf_constant / self.torque_constant - 1.0
        if abs(mismatch) > KE_KT_TOLERANCE:
            raise SceneError("back_emf_constant",
                             f"{self.back_emf_constant:.6g} V s/rad differs from torque_constant "
                             f"{self.torque_constant:.6g} N m/A by {100 * mismatch:+.1f} % (at most "
                             f"{100 * KE_KT_TOLERANCE:g} %: in SI units they are the same constant)")

    # -- derived quantities -----------------------------------------------------
    @property
    def electrical_time_constant(self) -> float:
        """L / R_ref [s]."""
        return self.inductance / self.resistance

    @property
    def mechanical_time_constant(self) -> float:
        """J_rotor R_ref / (k_t k_e) [s]: the unloaded motor's speed time constant."""
        return self.rotor_inertia * self.resistance / (self.torque_constant * self.back_emf_constant)

    @property
    def thermal_capacity(self) -> float:
        """tau_th / R_th [J/K]."""
        return self.thermal_time_constant / self.thermal_resistance

    def resistance_at(self, temperature: float) -> float:
        """Winding resistance [Ohm] at `temperature` [degC].

        Examples
        --------
        >>> m = load_motor("maxon-re40-148877")
        >>> round(m.resistance_at(125.0) / m.resistance, 2)   # copper, 100 K warmer
        1.39
        """
        return self.resistance * (1.0 + self.temperature_coefficient * (temperature - self.reference_temperature))

    def replace(self, **changes) -> "MotorData":
        """A copy with `changes` applied (and checked)."""
        known = {f.name for f in fields(self)}
        for k in changes:
            if k not in known:
                raise SceneError(k, f"is not a field of MotorData (fields: {', '.join(sorted(known))})")
        return MotorData(**{**{f.name: getattr(self, f.name) for f in fields(self)}, **changes})

    # -- from a datasheet ---------------------------------------------------------
    @classmethod
    def from_datasheet(
        cls, *, name: str, source: str,
        terminal_resistance_ohm: float, terminal_inductance_mH: float,
        torque_constant_mNm_per_A: float, rotor_inertia_gcm2: float,
        speed_constant_rpm_per_V: float | None = None,
        nominal_voltage_V: float | None = None,
        no_load_current_mA: float | None = None, friction_torque_mNm: float | None = None,
        viscous_damping_uNm_per_rpm: float = 0.0,
        thermal_resistance_K_per_W: float | None = None, thermal_time_constant_s: float | None = None,
        thermal_resistance_winding_housing_K_per_W: float | None = None,
        thermal_resistance_housing_ambient_K_per_W: float | None = None,
        thermal_time_constant_winding_s: float | None = None,
        thermal_time_constant_motor_s: float | None = None,
        no_load_speed_rpm: float | None = None, nominal_speed_rpm: float | None = None,
        nominal_torque_mNm: float | None = None, stall_torque_mNm: float | None = None,
        max_speed_rpm: float | None = None, max_winding_temperature_degC: float | None = None,
        nominal_current_A: float | None = None, stall_current_A: float | None = None,
        max_efficiency_percent: float | None = None, speed_torque_gradient_rpm_per_mNm: float | None = None,
        mechanical_time_constant_ms: float | None = None,
        ambient_temperature_min_degC: float | None = None, ambient_temperature_max_degC: float | None = None,
        temperature_coefficient_per_K: float = 0.0039, reference_temperature_degC: float = 25.0,
        smoothing_speed_rad_per_s: float = 10.0, notes: str = "",
    ) -> "MotorData":
        """A data set from a datasheet's figures, in the datasheet's units.

        Parameters
        ----------
        name, source : str
            Identifier, and the document the figures come from.
        terminal_resistance_ohm : float
            Terminal resistance [Ohm] at `reference_temperature_degC`.
        terminal_inductance_mH : float
            Terminal inductance [mH].
        torque_constant_mNm_per_A : float
            Torque constant [mNm/A].
        rotor_inertia_gcm2 : float
            Rotor inertia [g cm²].
        speed_constant_rpm_per_V : float, optional
            Speed constant [rpm/V]; gives k_e (checked against k_t).  Without it
            k_e = k_t.
        nominal_voltage_V : float, optional
            Nominal voltage [V]; needed to check the stall torque and no-load speed.
        no_load_current_mA, friction_torque_mNm : float, optional
            Coulomb friction = friction torque, or k_t x no-load current; not both.
        viscous_damping_uNm_per_rpm : float
            Viscous damping [µNm/rpm] (Faulhaber states it; maxon does not).
        thermal_resistance_K_per_W, thermal_time_constant_s : float, optional
            A one-node thermal model, winding to ambient.  Or instead:
        thermal_resistance_winding_housing_K_per_W, thermal_resistance_housing_ambient_K_per_W, \
thermal_time_constant_winding_s, thermal_time_constant_motor_s : float, optional
            The two-node datasheet constants (R_th1, R_th2, tau_w, tau_m), reduced to
            one node (see the module's notes).
        no_load_speed_rpm, nominal_speed_rpm, max_speed_rpm : float, optional
            Speeds [rpm]; the no-load speed is checked against k_n (U - R I_0).
        nominal_torque_mNm, stall_torque_mNm : float, optional
            Max. continuous and stall torque [mNm]; the stall torque is checked
            against k_t U / R - friction.
        max_winding_temperature_degC : float, optional
        nominal_current_A : float, optional
            Max. continuous current [A]; checked against M_N / k_t + I_0.
        stall_current_A : float, optional
            Starting current [A]; checked against U / R.
        max_efficiency_percent : float, optional
            Kept for the record (range 0 to 100).
        speed_torque_gradient_rpm_per_mNm, mechanical_time_constant_ms : float, optional
            Checked against R / k_t² and J R / k_t² (not used otherwise).
        ambient_temperature_min_degC, ambient_temperature_max_degC : float, optional
            The ambient temperature range the motor is rated for.
        temperature_coefficient_per_K, reference_temperature_degC : float
            Copper's 0.0039 /K, and the datasheet's 25 degC.
        smoothing_speed_rad_per_s : float
            Speed scale of the friction and gearbox-direction smoothing [rad/s].
        notes : str
            Anything the data file says about the figures; the derivations are added.

        Returns
        -------
        MotorData

        Raises
        ------
        SceneError
            Naming the (datasheet) field that is missing, not positive, or
            inconsistent with the others.

        Examples
        --------
        >>> m = MotorData.from_datasheet(name="example", source="hand arithmetic",
        ...     terminal_resistance_ohm=2.0, terminal_inductance_mH=0.5,
        ...     torque_constant_mNm_per_A=50.0, speed_constant_rpm_per_V=191.0,
        ...     rotor_inertia_gcm2=20.0, no_load_current_mA=40.0,
        ...     thermal_resistance_K_per_W=10.0, thermal_time_constant_s=300.0)
        >>> m.torque_constant, m.inductance, m.rotor_inertia, round(m.coulomb_friction, 9)
        (0.05, 0.0005, 2e-06, 0.002)
        >>> round(m.back_emf_constant, 5)        # 1 / (191 rpm/V in rad/s/V)
        0.05
        """
        R = check_number("terminal_resistance_ohm", terminal_resistance_ohm)
        L = check_number("terminal_inductance_mH", terminal_inductance_mH) * 1e-3
        kt = check_number("torque_constant_mNm_per_A", torque_constant_mNm_per_A) * 1e-3
        J = check_number("rotor_inertia_gcm2", rotor_inertia_gcm2) * 1e-7
        U = check_number("nominal_voltage_V", nominal_voltage_V, optional=True)
        derived = []
        kn = check_number("speed_constant_rpm_per_V", speed_constant_rpm_per_V, optional=True)
        if kn is None:
            ke = kt
            derived.append("k_e = k_t (no speed constant given)")
        else:
            ke = 1.0 / (kn * RPM)
            mismatch = ke / kt - 1.0
            if abs(mismatch) > KE_KT_TOLERANCE:
                raise SceneError("speed_constant_rpm_per_V",
                                 f"{kn:g} rpm/V gives k_e = {ke:.5g} V s/rad, {100 * mismatch:+.1f} % off the "
                                 f"torque constant {kt:.5g} N m/A (at most {100 * KE_KT_TOLERANCE:g} %; "
                                 "k_n [rpm/V] x k_t [mNm/A] should be 30000/pi = 9549)")
            derived.append("k_e = 1/k_n in V s/rad")
        if no_load_current_mA is not None and friction_torque_mNm is not None:
            raise SceneError("friction_torque_mNm", "give the friction torque or the no-load current, not both")
        if friction_torque_mNm is not None:
            tau_c = check_number("friction_torque_mNm", friction_torque_mNm, positive=False) * 1e-3
            i0 = tau_c / kt
        elif no_load_current_mA is not None:
            i0 = check_number("no_load_current_mA", no_load_current_mA, positive=False) * 1e-3
            tau_c = kt * i0
            derived.append("Coulomb friction = k_t x no-load current")
        else:
            tau_c = i0 = 0.0
        b = check_number("viscous_damping_uNm_per_rpm", viscous_damping_uNm_per_rpm, positive=False) * 1e-6 / RPM

        one = (thermal_resistance_K_per_W, thermal_time_constant_s)
        two = (thermal_resistance_winding_housing_K_per_W, thermal_resistance_housing_ambient_K_per_W,
               thermal_time_constant_winding_s, thermal_time_constant_motor_s)
        if any(v is not None for v in one) and any(v is not None for v in two):
            raise SceneError("thermal_resistance_K_per_W",
                             "give the one-node (R_th, tau_th) or the two-node datasheet constants, not both")
        if any(v is not None for v in two):
            r1 = check_number("thermal_resistance_winding_housing_K_per_W", two[0])
            r2 = check_number("thermal_resistance_housing_ambient_K_per_W", two[1])
            tw = check_number("thermal_time_constant_winding_s", two[2])
            tm = check_number("thermal_time_constant_motor_s", two[3])
            r_th, tau_th = r1 + r2, two_node_slow_time_constant(r1, r2, tw, tm)
            derived.append(f"R_th = R_th1 + R_th2; tau_th = {tau_th:.4g} s, the slow mode of the two-node "
                           "network (R_th1, R_th2, tau_w, tau_m)")
        else:
            r_th = check_number("thermal_resistance_K_per_W", one[0])
            tau_th = check_number("thermal_time_constant_s", one[1])

        def speed(field, v):
            v = check_number(field, v, optional=True)
            return None if v is None else v * RPM

        def torque(field, v):
            v = check_number(field, v, optional=True)
            return None if v is None else v * 1e-3

        n0, n_nom, n_max = (speed("no_load_speed_rpm", no_load_speed_rpm),
                            speed("nominal_speed_rpm", nominal_speed_rpm), speed("max_speed_rpm", max_speed_rpm))
        m_nom, m_stall = torque("nominal_torque_mNm", nominal_torque_mNm), torque("stall_torque_mNm", stall_torque_mNm)
        if m_stall is not None and U is not None:
            expected = kt * U / R - tau_c
            if abs(m_stall / expected - 1.0) > STALL_TOLERANCE:
                raise SceneError("stall_torque_mNm",
                                 f"{m_stall * 1e3:g} mNm, but k_t U / R - friction = {expected * 1e3:.4g} mNm "
                                 f"(more than {100 * STALL_TOLERANCE:g} % apart: a mistyped figure?)")
        if n0 is not None and U is not None:
            expected = (U - R * i0) / ke
            if abs(n0 / expected - 1.0) > NO_LOAD_TOLERANCE:
                raise SceneError("no_load_speed_rpm",
                                 f"{no_load_speed_rpm:g} rpm, but k_n (U - R I_0) = {expected / RPM:.5g} rpm "
                                 f"(more than {100 * NO_LOAD_TOLERANCE:g} % apart: a mistyped figure?)")
        i_nom = check_number("nominal_current_A", nominal_current_A, optional=True)
        checks = []  # (field, stated, expected, what the expectation is)
        if i_nom is not None and m_nom is not None:
            checks.append(("nominal_current_A", i_nom, m_nom / kt + i0, "M_N / k_t + I_0", "A"))
        i_stall = check_number("stall_current_A", stall_current_A, optional=True)
        if i_stall is not None and U is not None:
            checks.append(("stall_current_A", i_stall, U / R, "U / R", "A"))
        grad = check_number("speed_torque_gradient_rpm_per_mNm", speed_torque_gradient_rpm_per_mNm, optional=True)
        if grad is not None:  # R / k_t² in rad/s per N m, stated in rpm per mNm
            checks.append(("speed_torque_gradient_rpm_per_mNm", grad, R / (kt * ke) / RPM * 1e-3, "R / (k_t k_e)",
                           "rpm/mNm"))
        tau_mech = check_number("mechanical_time_constant_ms", mechanical_time_constant_ms, optional=True)
        if tau_mech is not None:
            checks.append(("mechanical_time_constant_ms", tau_mech, J * R / (kt * ke) * 1e3, "J R / (k_t k_e)", "ms"))
        for field, stated, expected, what, unit in checks:
            if abs(stated / expected - 1.0) > NOMINAL_TOLERANCE:
                raise SceneError(field, f"{stated:g} {unit}, but {what} = {expected:.4g} {unit} (more than "
                                        f"{100 * NOMINAL_TOLERANCE:g} % apart: a mistyped figure?)")
        eff = check_number("max_efficiency_percent", max_efficiency_percent, optional=True)
        if eff is not None and eff > 100:
            raise SceneError("max_efficiency_percent", f"must be at most 100, got {eff:g}")
        if n_nom is not None and n0 is not None and n_nom > n0:
            raise SceneError("nominal_speed_rpm", f"{nominal_speed_rpm:g} rpm exceeds the no-load speed")
        if m_nom is not None and m_stall is not None and m_nom > m_stall:
            raise SceneError("nominal_torque_mNm", f"{nominal_torque_mNm:g} mNm exceeds the stall torque")
        smoothing = check_number("smoothing_speed_rad_per_s", smoothing_speed_rad_per_s)
        alpha = check_number("temperature_coefficient_per_K", temperature_coefficient_per_K, positive=False)
        for field, t in (("reference_temperature_degC", reference_temperature_degC),
                         ("max_winding_temperature_degC", max_winding_temperature_degC),
                         ("ambient_temperature_min_degC", ambient_temperature_min_degC),
                         ("ambient_temperature_max_degC", ambient_temperature_max_degC)):
            if t is not None and (isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t)):
                raise SceneError(field, f"must be a finite number, got {t!r}")
        all_notes = "; ".join([s for s in (notes.strip(),) if s] + derived)
        return cls(name=name, source=source, resistance=R, inductance=L, torque_constant=kt, back_emf_constant=ke,
                   rotor_inertia=J, viscous_friction=b, coulomb_friction=tau_c,
                   smoothing_speed=smoothing, thermal_resistance=r_th,
                   thermal_time_constant=tau_th, temperature_coefficient=alpha,
                   reference_temperature=reference_temperature_degC, notes=all_notes, nominal_voltage=U,
                   nominal_torque=m_nom, nominal_speed=n_nom, no_load_speed=n0, stall_torque=m_stall,
                   max_speed=n_max, max_winding_temperature=max_winding_temperature_degC,
                   nominal_current=i_nom, min_ambient_temperature=ambient_temperature_min_degC,
                   max_ambient_temperature=ambient_temperature_max_degC)


def two_node_slow_time_constant(r1: float, r2: float, tau_w: float, tau_m: float) -> float:
    """Slow time constant [s] of a two-node winding/housing thermal network.

    The winding (capacity C_w = tau_w / R_th1) couples through R_th1 to the
    housing (C_h = tau_m / R_th2), which couples through R_th2 to ambient, as in
    maxon's datasheets.  The network's two modes are the eigenvalues of
    ``[[-a, a], [b, -(b + c)]]`` with a = 1/tau_w, b = R_th2 / (R_th1 tau_m),
    c = 1/tau_m; the slow one is returned.

    Examples
    --------
    >>> round(two_node_slow_time_constant(1.93, 4.65, 41.6, 1120.0), 1)  # maxon RE 40
    1223.8
    >>> round(two_node_slow_time_constant(1.0, 1.0, 1e-6, 100.0), 3)  # a massless winding: tau_m
    100.0
    >>> from grubler.motors import two_node_slow_time_constant
    >>> round(two_node_slow_time_constant(1.65, 4.65, 41.6, 1120.0), 1)   # RE 40's datasheet figures
    1241.3
    """
    a, b, c = 1.0 / tau_w, r2 / (r1 * tau_m), 1.0 / tau_m
    trace, det = -(a + b + c), a * c
    fast = (trace - math.sqrt(trace * trace - 4.0 * det)) / 2.0
    return -fast / det  # 1 / |slow eigenvalue|, with slow = det / fast (no cancellation)


# -- data files ------------------------------------------------------------------
_DATASHEET_KEYS = {
    "terminal_resistance_ohm", "terminal_inductance_mH", "torque_constant_mNm_per_A", "rotor_inertia_gcm2",
    "speed_constant_rpm_per_V", "nominal_voltage_V", "no_load_current_mA", "friction_torque_mNm",
    "viscous_damping_uNm_per_rpm", "thermal_resistance_K_per_W", "thermal_time_constant_s",
    "thermal_resistance_winding_housing_K_per_W", "thermal_resistance_housing_ambient_K_per_W",
    "thermal_time_constant_winding_s", "thermal_time_constant_motor_s", "no_load_speed_rpm",
    "nominal_speed_rpm", "nominal_torque_mNm", "stall_torque_mNm", "max_speed_rpm",
    "max_winding_temperature_degC", "nominal_current_A", "stall_current_A", "max_efficiency_percent",
    "speed_torque_gradient_rpm_per_mNm", "mechanical_time_constant_ms", "ambient_temperature_min_degC",
    "ambient_temperature_max_degC",
}
_MODEL_KEYS = {"temperature_coefficient_per_K", "reference_temperature_degC", "smoothing_speed_rad_per_s"}
_SOURCE_KEYS = {"manufacturer", "series", "part_number", "document", "notes", "lines"}


def _data_dir():
    return resources.files("grubler.motors").joinpath("data")


def list_motors() -> list[str]:
    """Names of the shipped motor data sets.

    Examples
    --------
    >>> "maxon-re40-148877" in list_motors()
    True
    """
    return sorted(p.name[:-5] for p in _data_dir().iterdir() if p.name.endswith(".toml"))


def load_motor(spec: str | Path) -> MotorData:
    """A motor data set: a shipped name, a path to a TOML file, or TOML text.

    A file has a top-level ``name``, a ``[source]`` table (manufacturer, series,
    part_number, document, notes; optionally ``[source.lines]``, where on the
    datasheet each figure stands, then for every figure) and a ``[datasheet]``
    table whose keys are :meth:`MotorData.from_datasheet`'s datasheet-unit
    arguments; an optional
    ``[model]`` table sets the modelling choices (temperature_coefficient_per_K,
    reference_temperature_degC, smoothing_speed_rad_per_s).

    Raises
    ------
    SceneError
        Field ``motor`` for an unknown name or unreadable TOML; ``datasheet.<key>``
        (etc.) for a missing, unknown, non-positive or inconsistent figure.

    Examples
    --------
    >>> m = load_motor("maxon-re40-148877")
    >>> m.torque_constant, m.resistance
    (0.0603, 1.16)
    >>> text = '''name = "bad"
    ... [source]
    ... document = "none"
    ... [datasheet]
    ... terminal_resistance_ohm = 1.0
    ... terminal_inductance_mH = 0.1
    ... torque_constant_mNm_per_A = 20.0
    ... rotor_inertia_gcm2 = -3.0
    ... '''
    >>> load_motor(text)
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: datasheet.rotor_inertia_gcm2: must be positive, got -3.0 (motor 'bad')
    >>> from grubler.motors import load_motor
    >>> d = load_motor("maxon-re40-148877")            # a shipped data set (or a TOML file's path, or TOML text)
    >>> d.name, round(d.rotor_inertia * 1e7, 1)       # g cm2
    ('maxon-re40-148877', 134.0)
    """
    text, where = _read_spec(spec)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError("motor", f"{where} is not valid TOML: {exc}") from None
    name = doc.get("name")
    if not isinstance(name, str) or not name.strip():
        raise SceneError("name", f"{where} needs a top-level name = \"...\"")
    for key in doc:
        if key not in ("name", "source", "datasheet", "model"):
            raise SceneError(key, f"unknown table or key in {where} (expected name, [source], [datasheet], [model])")
    src, sheet, model = doc.get("source", {}), doc.get("datasheet"), doc.get("model", {})
    if sheet is None:
        raise SceneError("datasheet", f"{where} has no [datasheet] table")
    for table, allowed, tname in ((src, _SOURCE_KEYS, "source"), (sheet, _DATASHEET_KEYS, "datasheet"),
                                  (model, _MODEL_KEYS, "model")):
        if not isinstance(table, dict):
            raise SceneError(tname, "must be a table")
        for key in table:
            if key not in allowed:
                raise SceneError(f"{tname}.{key}", f"unknown key (known: {', '.join(sorted(allowed))})")
    lines = src.get("lines")
    if lines is not None:  # where on the datasheet each figure stands: every figure, and only figures
        if not isinstance(lines, dict):
            raise SceneError("source.lines", "must be a table: datasheet key = \"line and label on the sheet\"")
        for key, where_on in lines.items():
            if key not in sheet:
                raise SceneError(f"source.lines.{key}", "names no figure of the [datasheet] table")
            if not isinstance(where_on, str) or not where_on.strip():
                raise SceneError(f"source.lines.{key}", "must say where on the datasheet the figure stands")
        for key in sheet:
            if key not in lines:
                raise SceneError(f"source.lines.{key}", f"is missing: {where} traces its figures, this one too")
    if not src.get("document"):
        raise SceneError("source.document", f"{where} must name the document its figures come from")
    source = ", ".join(str(src[k]) for k in ("manufacturer", "series", "part_number", "document") if src.get(k))
    try:
        return MotorData.from_datasheet(name=name, source=source, notes=str(src.get("notes", "")),
                                        **sheet, **model)
    except SceneError as exc:
        table = "model" if exc.field in _MODEL_KEYS else "datasheet"
        raise SceneError(f"{table}.{exc.field}", f"{exc.reason} (motor {name!r})") from None
    except TypeError as exc:  # a required datasheet figure is absent
        found = re.search(r"'(\w+)'", str(exc))
        missing = found.group(1) if found else "?"
        raise SceneError(f"datasheet.{missing}", f"is missing (motor {name!r})") from None


# the key figures of a data set, in the datasheet's units: (heading, unit, MotorData field, SI -> shown)
KEY_FIGURES = (
    ("nominal voltage", "V", "nominal_voltage", 1.0),
    ("nominal torque", "mN m", "nominal_torque", 1e3),
    ("nominal speed", "rpm", "nominal_speed", 1.0 / RPM),
    ("stall torque", "mN m", "stall_torque", 1e3),
    ("torque constant", "mN m/A", "torque_constant", 1e3),
    ("terminal resistance", "Ohm", "resistance", 1.0),
    ("rotor inertia", "g cm2", "rotor_inertia", 1e7),
)


def motor_listing(names=None) -> list[str]:
    """The shipped data sets (or ``names``) as a table of key figures, each with its source.

    One row per motor in the datasheet's units (the heading's third line gives each),
    then the document its figures come from (and, for motors named, the data
    set's notes).  A figure the data set does not give shows as ``-``.

    Examples
    --------
    >>> lines = motor_listing(["maxon-re40-148877"])
    >>> lines[0].split()[:3]
    ['motor', 'nominal', 'nominal']
    >>> lines[2].split()[:3]
    ['[V]', '[mN', 'm]']
    >>> lines[3].split()[:3]
    ['maxon-re40-148877', '48', '187']
    >>> from grubler.motors import motor_listing
    >>> rows = motor_listing(["maxon-re40-148877"])
    >>> rows[3].split()[:5]                           # name, nominal voltage, torque, speed, stall torque
    ['maxon-re40-148877', '48', '187', '6920', '2500']
    """
    motors = [load_motor(n) for n in (list_motors() if names is None else names)]
    width = max([len("motor")] + [len(m.name) for m in motors])
    # three heading lines: the quantity in two words, then its unit
    heads = [(*h.split(maxsplit=1), f"[{u}]") for h, u, _, _ in KEY_FIGURES]
    cols = [max(map(len, h)) for h in heads]
    out = ["  ".join([f"{'motor' if k == 0 else '':<{width}}"] + [f"{h[k]:>{c}}" for h, c in zip(heads, cols)])
           for k in range(3)]
    for m in motors:
        values = [getattr(m, f) for _, _, f, _ in KEY_FIGURES]
        out.append("  ".join([f"{m.name:<{width}}"] + [f"{'-' if v is None else f'{v * k:.4g}':>{c}}"
                                                       for v, (_, _, _, k), c in zip(values, KEY_FIGURES, cols)]))
    out.append("")
    for m in motors:
        out += textwrap.wrap(f"{m.name}: {m.source}", 100, subsequent_indent="    ")
        if names is not None and m.notes:  # asked for by name: how far to trust each figure, too
            out += textwrap.wrap(f"notes: {m.notes}", 100, initial_indent="    ", subsequent_indent="    ")
    return out


def _read_spec(spec: str | Path) -> tuple[str, str]:
    if isinstance(spec, Path):
        return spec.read_text(), str(spec)
    if not isinstance(spec, str) or not spec.strip():
        raise SceneError("motor", f"must be a data set name, a path or TOML text, got {spec!r}")
    if "\n" in spec or "=" in spec:
        return spec, "the TOML text"
    path = Path(spec)
    if spec.endswith(".toml") and path.is_file():
        return path.read_text(), spec
    entry = _data_dir().joinpath(f"{spec}.toml")
    if entry.is_file():
        return entry.read_text(), f"data set {spec!r}"
    if spec.endswith(".toml") or "/" in spec or "\\" in spec:
        raise SceneError("motor", f"no such file: {spec!r}")
    raise SceneError("motor", f"no data set named {spec!r}{did_you_mean(spec, list_motors())} "
                              f"(known: {', '.join(list_motors())})")
