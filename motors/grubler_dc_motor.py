"""FMI 2.0 co-simulation slave of a permanent-magnet DC motor with gearbox and drive (pythonfmu).

Thin by design: it maps FMI variables to :mod:`grubler.motors.dc_motor` and back.
The motor takes the gearbox output's speed as an input (connect the mechanism's
``drive_speed``) and outputs the gearbox output torque without the rotor's
inertia torque (connect to the mechanism's ``motor_torque``); the rotor inertia
belongs to the mechanism: set its ``drive.inertia`` parameter to this FMU's
``reflected_inertia`` output (J_rotor N²).

Parameters default to the chosen data set's values (``motor``: a shipped name or
TOML text); those the importer sets override them.  Every variable's description
ends with its unit in square brackets.  Errors (bad parameters, non-finite
inputs) are logged and reported as a failed step, never raised into the importer.

The script's file name is unique among the project's FMUs: two pythonfmu slaves
whose scripts share a name cannot be loaded in one process.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

# inside the FMU the package sits beside this script, in resources/
_here = Path(__file__).resolve().parent
if (_here / "grubler" / "__init__.py").is_file() and str(_here) not in sys.path:
    sys.path.insert(0, str(_here))

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Variability, Real, String  # noqa: E402
from pythonfmu.enums import Fmi2Status  # noqa: E402

import grubler  # noqa: E402
from grubler.fmi_slave import ProjectSlave, balance_loader_reference  # noqa: E402
from grubler.errors import GrublerError  # noqa: E402
from grubler.motors import dc_motor as dcm  # noqa: E402
from grubler.motors.motor_data import MotorData, load_motor  # noqa: E402

DEFAULT_MOTOR = "maxon-re40-148877"

# MotorData fields the importer may override: name -> description with unit
DATA_PARAMETERS = {
    "resistance": "winding resistance at reference_temperature [Ohm]",
    "inductance": "winding inductance [H]",
    "torque_constant": "torque constant k_t [N m/A]",
    "back_emf_constant": "back-EMF constant k_e, within 2 % of k_t [V s/rad]",
    "rotor_inertia": "rotor inertia J_rotor; it belongs to the mechanism (see reflected_inertia) [kg m2]",
    "viscous_friction": "viscous friction at the motor shaft [N m s/rad]",
    "coulomb_friction": "Coulomb friction at the motor shaft [N m]",
    "smoothing_speed": "motor speed over which Coulomb friction and the gearbox's efficiency direction change "
                       "sign (tanh) [rad/s]",
    "thermal_resistance": "thermal resistance winding to ambient [K/W]",
    "thermal_time_constant": "thermal time constant of the winding (one node) [s]",
    "temperature_coefficient": "temperature coefficient of the winding resistance (copper 0.0039) [1/K]",
    "reference_temperature": "temperature at which resistance is stated [degC]",
}
# drive train and surroundings: name -> (description, default or None for "from the data set")
SETUP_PARAMETERS = {
    "gear_ratio": ("gearbox ratio N >= 1, motor speed / shaft speed [1]", 1.0),
    "gear_efficiency": ("gearbox efficiency in the direction of power flow, (0, 1] [1]", 1.0),
    "supply_voltage": ("supply voltage: the terminal voltage is clamped to +-supply_voltage (default: the "
                       "motor's nominal voltage) [V]", None),
    "current_limit": ("drive's current limit; 0: none [A]", 0.0),
    "ambient_temperature": ("ambient temperature [degC]", 25.0),
    "initial_current": ("winding current at the start [A]", 0.0),
    "initial_temperature": ("winding temperature at the start (default: ambient_temperature) [degC]", None),
    "max_substep": ("longest internal step (the current is exact for any step; sub-steps refresh R(T) and the "
                    "thermal coupling) [s]", 0.01),
}
OUTPUTS = {
    "shaft_torque": "gearbox output torque, without the rotor's inertia torque [N m]",
    "current": "current through the winding [A]",
    "winding_temperature": "winding temperature [degC]",
    "electrical_power": "terminal voltage x current, negative when generating [W]",
    "motor_speed": "motor speed, gear_ratio x shaft_speed [rad/s]",
    "back_emf": "back-EMF k_e x motor_speed [V]",
    "terminal_voltage": "voltage the drive applies: the command clamped and current-limited [V]",
    "reflected_inertia": "rotor inertia seen at the shaft, J_rotor x gear_ratio^2: set the mechanism's "
                         "drive.inertia to it [kg m2]",
}


balance_loader_reference(globals())  # pythonfmu 0.7's loader, see grubler.fmi_slave

class DCMotor(ProjectSlave):
    """A permanent-magnet DC motor with gearbox, current-limited drive and winding temperature."""

    author = "grubler"
    description = ("Permanent-magnet DC motor with gearbox, supply clamp, current limiter and winding thermal "
                   "model; inputs terminal voltage and shaft speed, output shaft torque (rotor inertia excluded: "
                   "it belongs to the mechanism as drive.inertia = reflected_inertia)")
    version = grubler.__version__

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.motor = DEFAULT_MOTOR
        self.voltage = 0.0
        self.shaft_speed = 0.0
        self._overrides: dict[str, float] = {}
        self._data_cache: tuple[str, MotorData | None] = ("", None)
        self._model: dcm.DCMotor | None = None
        self._state: dcm.MotorState | None = None
        self._error: str | None = None
        self._out_key = None
        self._out: dcm.MotorOutputs | None = None
        self._chatter_warned = self._hot_warned = False
        self._register()

    # -- variables -----------------------------------------------------------
    def _register(self):
        par, fixed = Fmi2Causality.parameter, Fmi2Variability.fixed
        self.register_variable(String("motor", causality=par, variability=fixed,
                                      description="motor data set: a shipped name (maxon-re40-148877, "
                                                  "maxon-re40-148866, maxon-re30-310007, maxon-re25-118752) or "
                                                  "the content of a motor TOML file [1]"))
        for name, text in {**DATA_PARAMETERS, **{k: v[0] for k, v in SETUP_PARAMETERS.items()}}.items():
            self.register_variable(Real(name, causality=par, variability=fixed, description=text,
                                        getter=lambda n=name: self._param(n),
                                        setter=lambda v, n=name: self._overrides.__setitem__(n, float(v))))
        for name, text in (("voltage", "commanded terminal voltage [V]"),
                           ("shaft_speed", "speed of the gearbox output shaft (the mechanism's drive_speed) "
                                           "[rad/s]")):
            self.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                        description=text))
        for name, text in OUTPUTS.items():
            self.register_variable(Real(name, causality=Fmi2Causality.output,
                                        variability=Fmi2Variability.continuous, initial=Fmi2Initial.exact,
                                        description=text, getter=lambda n=name: self._read(n)))

    def feedthrough(self) -> dict[str, list[str]]:
        """Outputs that depend on this instant's inputs (the model description declares them).

        Current and winding temperature are states; the torque and speeds follow
        the shaft speed now, the terminal quantities the commanded voltage too.
        """
        return {"shaft_torque": ["shaft_speed"], "motor_speed": ["shaft_speed"], "back_emf": ["shaft_speed"],
                "terminal_voltage": ["voltage", "shaft_speed"], "electrical_power": ["voltage", "shaft_speed"]}

    def _data(self) -> MotorData | None:
        """The data set named by `motor` (cached), or None if it does not load."""
        key, data = self._data_cache
        if key != self.motor:
            try:
                data = load_motor(self.motor)
            except (GrublerError, ValueError, OSError):
                data = None
            self._data_cache = (self.motor, data)
        return data

    def _param(self, name: str) -> float:
        if name in self._overrides:
            return self._overrides[name]
        if name in DATA_PARAMETERS:
            data = self._data()
            return math.nan if data is None else float(getattr(data, name))
        default = SETUP_PARAMETERS[name][1]
        if default is not None:
            return default
        if name == "supply_voltage":
            data = self._data()
            return math.nan if data is None or data.nominal_voltage is None else data.nominal_voltage
        if name == "initial_temperature":
            return self._param("ambient_temperature")
        raise KeyError(name)

    # -- set-up ----------------------------------------------------------------
    def _build(self) -> tuple[dcm.DCMotor, dcm.MotorState]:
        data = load_motor(self.motor)
        data = data.replace(**{k: v for k, v in self._overrides.items() if k in DATA_PARAMETERS})
        p = self._param
        if math.isnan(p("supply_voltage")):
            raise grubler.SceneError("supply_voltage", f"motor {data.name!r} states no nominal voltage: set it")
        limit = p("current_limit")
        if limit < 0 or not math.isfinite(limit):
            raise grubler.SceneError("current_limit", f"must be >= 0 and finite (0: none), got {limit}")
        model = dcm.DCMotor(data, dcm.Gearbox(p("gear_ratio"), p("gear_efficiency")),
                            dcm.Drive(p("supply_voltage"), limit if limit > 0 else math.inf),
                            ambient_temperature=p("ambient_temperature"), max_substep=p("max_substep"))
        return model, dcm.initial_state(model, p("initial_current"), p("initial_temperature"))

    def exit_initialization_mode(self):
        try:
            self._model, self._state = self._build()
            self._error = None
        except Exception as exc:  # noqa: BLE001 - nothing may reach the importer as fmi2Fatal
            self._model = self._state = None
            # the instance stays alive and refuses every doStep (fmi2Discard) with the same message
            what = "" if isinstance(exc, (GrublerError, ValueError)) else f"{type(exc).__name__}: "
            self._fail(f"initialisation failed: {what}{exc}")
        self._out_key = None
        self._chatter_warned = self._hot_warned = False

    # -- stepping ----------------------------------------------------------------
    def do_step(self, current_time: float, step_size: float) -> bool:
        if self._error is not None:
            self.log(f"cannot step: {self._error}", Fmi2Status.error)
            return False
        for name in ("voltage", "shaft_speed"):
            value = getattr(self, name)
            if not math.isfinite(value):
                self.log(f"{name} is {value} at t = {current_time:g} s: inputs must be finite", Fmi2Status.error)
                return False
        if not (step_size > 0 and math.isfinite(step_size)):
            self.log(f"step size must be positive and finite, got {step_size}", Fmi2Status.error)
            return False
        if self._model is None:
            self.log("doStep before initialisation (call exitInitializationMode first)", Fmi2Status.error)
            return False
        d = self._model.data
        if not self._chatter_warned and step_size > self._model.chatter_free_step:
            self._chatter_warned = True
            self.log(f"communication step {step_size:g} s exceeds 2 smoothing_speed rotor_inertia / "
                     f"coulomb_friction = {self._model.chatter_free_step:.3g} s: "
                     "with the speed held over a step the friction torque may chatter (raise smoothing_speed)",
                     Fmi2Status.warning)
        try:
            self._state, self._out = dcm.step(self._model, self._state, self.voltage, self.shaft_speed, step_size)
        except Exception as exc:  # noqa: BLE001 - nothing may reach the importer as fmi2Fatal
            self.log(f"step from t = {current_time:g} s failed: {exc}", Fmi2Status.error)
            return False
        self._out_key = (self._state, self.voltage, self.shaft_speed)
        t_max = d.max_winding_temperature
        if t_max is not None and not self._hot_warned and self._state.temperature > t_max:
            self._hot_warned = True
            self.log(f"winding at {self._state.temperature:.1f} degC at t = {current_time + step_size:g} s exceeds "
                     f"the datasheet's maximum {t_max:g} degC", Fmi2Status.warning)
        return True

    # -- outputs ---------------------------------------------------------------
    def _read(self, name: str) -> float:
        if self._model is None:
            if self._error is not None:
                return math.nan
            try:  # before initialisation: the current parameters' start, for start values
                model, state = self._build()
            except (GrublerError, ValueError):
                return math.nan
        else:
            model, state = self._model, self._state
        if name == "reflected_inertia":
            return model.reflected_inertia
        key = (state, self.voltage, self.shaft_speed)
        if key != self._out_key or self._out is None:
            if not (math.isfinite(self.voltage) and math.isfinite(self.shaft_speed)):
                return math.nan
            self._out = dcm.outputs(model, state, self.voltage, self.shaft_speed)
            self._out_key = key if self._model is not None else None
        return getattr(self._out, name)

    # -- state -------------------------------------------------------------------
    def _get_fmu_state(self):
        s = self._state
        return {"state": None if s is None else (s.current, s.temperature),
                "inputs": (self.voltage, self.shaft_speed), "error": self._error}

    def _set_fmu_state(self, state):
        if state["state"] is not None and self._model is not None:
            self._state = dcm.MotorState(*state["state"])
        self.voltage, self.shaft_speed = state["inputs"]
        self._error = state["error"]
        self._out_key = None

