"""FMI 2.0 co-simulation slave of a grubler mechanism (pythonfmu).

Thin by design: it maps FMI variables to :class:`grubler.Simulator` and back and has
no physics of its own.  Parameters default to the chosen scene's values; those the
importer sets override them.  Outputs are computed when read, by group, so a step
whose forces nobody reads costs no force computation.  Errors (bad parameters,
non-finite inputs, integration failure) are logged and reported as a failed step
or initialisation, never raised into the importer.

The script's file name is unique among the project's FMUs: two pythonfmu slaves
whose scripts share a name cannot be loaded in one process.
"""

from __future__ import annotations

import math
import operator
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
from grubler.model import coordinate_names  # noqa: E402
from grubler.scene import load_scene, override, parameter  # noqa: E402
from grubler.simulate import GROUPS, Simulator, output_columns, unit_of  # noqa: E402

N_LINKS = 3  # the FMU's variables are those of a four-link mechanism
LINK_FIELDS = {"a": "link vector length [m]", "p": "mass centre along the link [m]",
               "q": "mass centre across the link [m]", "m": "mass [kg]",
               "I": "centroidal moment of inertia [kg m2]",
               "damping": "viscous damping of its real joint [N m s/rad or N s/m]"}
DEFAULT_SCENE = "thesis-fourbar"


balance_loader_reference(globals())  # pythonfmu 0.7's loader, see grubler.fmi_slave

# Outputs are computed by group, each group including the cheaper ones' work, so
# what has been computed for this state is one number: the level reached (an index
# in GROUPS).  The drive joint's coordinate and rate, what a motor and an encoder
# read every step, are no group: they come straight from the state (DRIVE).
_LEVEL = {g: k for k, g in enumerate(GROUPS)}
_STATE = _LEVEL["state"]  # groups up to here do not depend on the inputs
DRIVE = ("drive_angle", "drive_speed")
_INF = math.inf


class Mechanism(ProjectSlave):
    """A planar four-link Grübler mechanism (imaginary-joints method)."""

    author = "grubler"
    description = ("Planar four-link mechanism by the imaginary-joints method; inputs are joint efforts, "
                   "outputs the joint states and the closing joint's constraint force")
    version = grubler.__version__

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.mechanism = DEFAULT_SCENE
        self.method = "exact"
        self.integrator = "auto"
        self.rtol = 1e-9
        self.atol = 1e-9
        self.max_step = 0.0
        self.motor_torque = 0.0
        self.load_torque = 0.0
        self._overrides: dict[str, float | str] = {}
        self._scene = load_scene(DEFAULT_SCENE)
        self._error: str | None = None
        self._sim: Simulator | None = None
        self._outputs: dict[str, float] = {}
        self._level = -1  # groups computed for this state and these inputs: GROUPS[:level + 1]
        self._register()

    # -- variables -----------------------------------------------------------
    def _register(self):
        par, fixed = Fmi2Causality.parameter, Fmi2Variability.fixed
        self.register_variable(String("mechanism", causality=par, variability=fixed,
                                      description="preset name, or the content of a scene file (TOML)"))
        self.register_variable(String("method", causality=par, variability=fixed,
                                      description="closure method: exact | penalty"))
        self.register_variable(String("integrator", causality=par, variability=fixed,
                                      description="auto | dop853 | rk45 | radau | bdf (auto: dop853 for exact, "
                                                  "radau for penalty)"))
        self.register_variable(Real("rtol", causality=par, variability=fixed,
                                    description="relative tolerance of the internal integration [-]"))
        self.register_variable(Real("atol", causality=par, variability=fixed,
                                    description="absolute tolerance of the internal integration [rad, m]"))
        self.register_variable(Real("max_step", causality=par, variability=fixed,
                                    description="largest internal step [s] (0: no limit)"))
        self._param_real("gravity", "gravity g, acting along -y [m/s2]")
        for k in range(2, N_LINKS + 2):
            for f, text in LINK_FIELDS.items():
                self._param_real(f"link{k}.{f}", f"link {k}: {text}")
        self._param_real("closure.gain", "penalty closure stiffness G [N/m, N m/rad]")
        self._param_real("closure.damping", "penalty closure damping C [N s/m, N m s/rad]")
        self._param_string("drive_joint", "real joint the motor acts on (e.g. theta2)")
        self._param_string("load_joint", "real joint the load acts on ('' for none)")
        self._param_real("drive.inertia", "inertia a motor adds at drive_joint: rotor inertia x gear ratio^2 "
                                          "[kg m2, or kg on a slide]")
        for name in coordinate_names(N_LINKS):
            unit = unit_of(name)
            self._param_real(f"initial.{name}", f"initial {name} [{unit}] (a guess for the dependent ones)")
            self._param_real(f"initial.{name}_d", f"initial {name}_d [{unit}/s]")
        self._input_vr: dict[int, str] = {}
        for name, text in (("motor_torque", "drive effort at drive_joint [N m, or N on a slide]"),
                           ("load_torque", "load effort at load_joint [N m, or N on a slide]")):
            var = Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                       description=text)
            self.register_variable(var)
            self._input_vr[var.value_reference] = name
        self._output_level: dict[str, int] = {}
        self._vr_output: dict[int, str] = {}
        self._read_plan: dict[tuple, tuple] = {}  # per set of value references: (level, names)
        model = self._scene.mechanism
        for group in GROUPS:
            for col in output_columns(model, [group]):
                if col in ("t", "E", "P_drive", "tau_drive"):
                    continue
                self._add_output(col, group, f"{col} [{unit_of(col)}]")
        # what a motor and an encoder read every step: straight from the state,
        # without evaluating any output group
        for name, text in (("drive_angle", "coordinate of the drive joint (relative) [rad or m]"),
                           ("drive_speed", "rate of the drive joint [rad/s or m/s]")):
            self._add_output(name, None, text)

    def feedthrough(self) -> dict[str, list[str]]:
        """Outputs that depend on this instant's inputs; the rest are states.

        The model description declares it (grubler.fmi_slave), so a master can
        order a loop through the mechanism (angles and rates do not
        depend on the torque applied now; accelerations and forces do).
        """
        inputs = ["motor_torque", "load_torque"]
        return {n: inputs for n, level in self._output_level.items()
                if level >= 0 and GROUPS[level] in ("dynamics", "reactions")}

    def _add_output(self, name, group, text):
        self._output_level[name] = -1 if group is None else _LEVEL[group]
        var = Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                   initial=Fmi2Initial.exact, description=text, getter=lambda n=name: self._read(n))
        self.register_variable(var)
        self._vr_output[var.value_reference] = name

    def _param_real(self, name, text):
        self.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                    description=text, getter=lambda n=name: float(self._param(n)),
                                    setter=lambda v, n=name: self._overrides.__setitem__(n, float(v))))

    def _param_string(self, name, text):
        self.register_variable(String(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                      description=text, getter=lambda n=name: str(self._param(n) or ""),
                                      setter=lambda v, n=name: self._overrides.__setitem__(n, str(v))))

    def _param(self, name: str):
        if name in self._overrides:
            return self._overrides[name]
        if name.startswith("closure.") and not self._scene.mechanism.closures:
            return math.nan
        return parameter(self._scene, name)

    # -- set-up ----------------------------------------------------------------
    def _build(self) -> Simulator:
        scene = load_scene(self.mechanism)
        if scene.mechanism.n_links != N_LINKS:
            raise grubler.SceneError("mechanism", f"this FMU is built for {N_LINKS} moving links, "
                                                  f"the scene has {scene.mechanism.n_links}")
        self._scene = scene
        configured = override(scene, self._overrides)
        model = configured.mechanism
        for name in ("rtol", "atol"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise grubler.SceneError(name, f"must be positive and finite, got {v}")
        if not (self.max_step >= 0 and math.isfinite(self.max_step)):
            raise grubler.SceneError("max_step", f"must be >= 0 and finite, got {self.max_step}")
        integrator = None if self.integrator in ("", "auto") else self.integrator
        return Simulator(model, method=self.method, rtol=self.rtol, atol=self.atol, integrator=integrator,
                         zd0=configured.initial_rates, t0=self._start_time,
                         max_step=self.max_step if self.max_step > 0 else math.inf)

    def exit_initialization_mode(self):
        try:
            self._sim = self._build()
            self._error = None
        except (GrublerError, ValueError) as exc:
            self._sim = None
            # logged as an error; raising here would reach the importer as
            # fmi2Fatal, so the instance stays alive and every doStep is refused
            # (fmi2Discard) with the same message
            self._fail(f"initialisation failed: {exc}")
        self._invalidate()

    # -- stepping ----------------------------------------------------------------
    def do_step(self, current_time: float, step_size: float) -> bool:
        sim, mt, lt = self._sim, self.motor_torque, self.load_torque
        # the common case first, in as few operations as it takes (x - x == 0 is
        # a finite x): a master pays this every communication step
        if (sim is not None and self._error is None and mt - mt == 0.0 and lt - lt == 0.0
                and 0.0 < step_size < _INF and abs(current_time - sim.t) <= 1e-9 * (1.0 + abs(current_time))):
            try:
                sim.set_inputs(mt, lt)
                sim.advance_to(current_time + step_size)  # all or nothing: a failure leaves it at current_time
            except (GrublerError, ValueError, FloatingPointError, ArithmeticError) as exc:
                self.log(f"step from t = {current_time:g} s failed: {exc}", Fmi2Status.error)
                return False
            self._outputs = {}
            self._level = -1
            return True
        return self._refuse(current_time, step_size)

    def _refuse(self, current_time: float, step_size: float) -> bool:
        """Log why a step cannot be taken (fmi2Discard)."""
        if self._error is not None:
            self.log(f"cannot step: {self._error}", Fmi2Status.error)
        elif not (math.isfinite(self.motor_torque) and math.isfinite(self.load_torque)):
            name = "motor_torque" if not math.isfinite(self.motor_torque) else "load_torque"
            self.log(f"{name} is {getattr(self, name)} at t = {current_time:g} s: inputs must be finite",
                     Fmi2Status.error)
        elif not (step_size > 0 and math.isfinite(step_size)):
            self.log(f"step size must be positive and finite, got {step_size}", Fmi2Status.error)
        elif self._sim is None:
            self.log("doStep before initialisation (call exitInitializationMode first)", Fmi2Status.error)
        else:
            self.log(f"doStep at t = {current_time:.12g} s, but the mechanism is at t = {self._sim.t:.12g} s "
                     "(restore a saved FMU state to roll back)", Fmi2Status.error)
        return False

    # -- outputs ---------------------------------------------------------------
    def _invalidate(self):
        self._outputs = {}
        self._level = -1

    def set_real(self, vrs, values):
        # the inputs, every step: straight to their attributes.  A changed effort
        # makes what depends on it (accelerations, forces) stale, not the state.
        inputs = self._input_vr
        if len(vrs) == 1 and vrs[0] in inputs:  # the usual call: one effort
            name, value = inputs[vrs[0]], values[0]
            if value != getattr(self, name):
                setattr(self, name, value)
                self._level = min(self._level, _STATE)
        elif all(vr in inputs for vr in vrs):
            for vr, value in zip(vrs, values):
                setattr(self, inputs[vr], value)
            self._level = min(self._level, _STATE)
        else:
            super().set_real(vrs, values)
            self._invalidate()

    def get_real(self, vrs):
        # the importer asks for all its outputs at once: compute the costliest group
        # they need in one pass (it includes the cheaper ones' work)
        plan = self._read_plan.get(tuple(vrs))
        if plan is None:
            plan = self._read_plan[tuple(vrs)] = self._plan(vrs)
        level, drive, pick = plan
        if pick is None:  # not all outputs: every variable through its getter
            return super().get_real(vrs)
        if level > self._level:
            self._compute(level)
        if drive and "drive_angle" not in self._outputs:
            self._compute_drive()
        try:
            values = pick(self._outputs)
        except KeyError:  # nothing computed: the simulator could not be built
            return [math.nan] * len(vrs)
        return [values] if len(vrs) == 1 else list(values)

    def _plan(self, vrs) -> tuple:
        """Once per set of value references: the group level they need, whether they
        include the drive joint's values, and a picker of their values."""
        if not vrs or not all(vr in self._vr_output for vr in vrs):
            return -1, False, None
        names = [self._vr_output[vr] for vr in vrs]
        return (max(self._output_level[n] for n in names), any(n in DRIVE for n in names),
                operator.itemgetter(*names))

    def _read(self, name: str) -> float:
        level = self._output_level[name]
        if level > self._level:
            self._compute(level)
        if name in DRIVE and name not in self._outputs:
            self._compute_drive()
        return self._outputs.get(name, math.nan)

    def _simulator(self) -> Simulator | None:
        """The simulator; before initialisation, the default scene's start (for start values)."""
        if self._sim is None and self._error is None:
            try:
                self._sim = self._build()
            except (GrublerError, ValueError) as exc:
                self._fail(str(exc))
        return self._sim

    def _compute(self, level: int) -> None:
        """Compute GROUPS[self._level + 1: level + 1] (called when level > self._level)."""
        sim = self._simulator()
        if sim is None:
            return
        drive, load = self.motor_torque, self.load_torque
        if (drive, load) != (sim.inputs.drive, sim.inputs.load) and math.isfinite(drive) and math.isfinite(load):
            sim.set_inputs(drive, load)
        values = sim.outputs(GROUPS[self._level + 1: level + 1])
        if self._level < 0:  # a new state: the simulator's fresh dict, no copy
            if self._outputs:  # the drive joint's values, read already
                values.update({n: self._outputs[n] for n in DRIVE if n in self._outputs})
            self._outputs = values
        else:
            self._outputs.update(values)
        self._level = level

    def _compute_drive(self) -> None:
        sim = self._simulator()
        if sim is None:
            return
        i = sim.model.arrays.drive
        self._outputs["drive_angle"], self._outputs["drive_speed"] = sim.joint_state(i) if i >= 0 else (0.0, 0.0)

    # -- state -------------------------------------------------------------------
    def _save_state(self):
        return {"sim": None if self._sim is None else self._sim.snapshot(),
                "inputs": (self.motor_torque, self.load_torque), "error": self._error}

    def _load_state(self, state):
        if state["sim"] is not None and self._sim is not None:
            self._sim.restore(state["sim"])
        self.motor_torque, self.load_torque = state["inputs"]
        self._error = state["error"]
        self._invalidate()

