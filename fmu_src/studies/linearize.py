"""Linear models of a mechanism about an operating point, for control design.

A closed chain of N real joints and C closures moves with n = N - 2C freedoms;
its minimal realisation has 2n states, the independent coordinates (the drive
first, as assembly holds them) and their rates.  The dependent coordinates and
rates follow from the closures (``kernel/minimal.c``), so the state equation in
minimal coordinates is ``xdot = (zd_i, zdd_i)(y(x), u)`` with ``y(x)`` the whole
state.  Its Jacobians come from the kernel's own equations compiled over complex
numbers (``grubler_cs.h``): evaluated at ``x + i h e_k`` the imaginary part of
every output over h is its exact derivative along ``e_k``, the tangent of the
constraint manifold included, with no step-size trade-off (complex-step
differentiation).  Finite differences only check them (tests/test_linearize.py).

With a DC motor (:mod:`grubler.motors`) the winding current is a third kind of
state, the input is the voltage, and the rotor's inertia joins the drive joint
(``drive.inertia`` = J_rotor N², as the servo system puts it there); the motor's
partial derivatives are the C model's own (:func:`grubler.motors.linearization`).

Examples
--------
The parallelogram swings as a simple pendulum of length 1 m (MODEL.md): its
linear model has the pendulum's frequency sqrt(g / l).

>>> import numpy as np, grubler
>>> sys = grubler.linearize("fourbar-parallelogram", at="equilibrium")
>>> sys.nstates, sys.state_labels
(2, ['theta2', 'theta2_d'])
>>> wn = np.abs(sys.poles()).max()
>>> bool(abs(wn - np.sqrt(9.81 / 1.0)) < 1e-9)
True
>>> round(float(sys.operating_point.coordinates["theta2"]), 6)     # hanging straight down
-1.570796
"""

from __future__ import annotations

import math

import numpy as np

from grubler.mechanism.dynamics import observation_names
from grubler.errors import SceneError
from grubler.mechanism.model import Mechanism
from grubler.mechanism.scene import coordinate_text
from grubler.mechanism.simulate import unit_of
from grubler.mechanism.minimal import MinimalPlant
from grubler.studies.operating_point import (DRIVE, LOAD, VOLTAGE, OperatingPoint, _accelerations, _motor_model,
                                             _operating_point, _prepared, _scene, input_unit, operating_point)
from grubler.views.bode import bode_figure, frequency_response, phase_deg, plot_bode

_INPUT_ALIASES = {"drive": DRIVE, "tau_drive": DRIVE, "torque": DRIVE, "load": LOAD, "tau_load": LOAD,
                  "load_torque": LOAD, "voltage": VOLTAGE}

def _inputs(inputs, motor, model: Mechanism) -> list[str]:
    if isinstance(inputs, str):
        inputs = [s for s in inputs.split(",") if s.strip()]
    chosen = []
    for name in inputs:
        key = _INPUT_ALIASES.get(str(name).strip())
        if key is None:
            raise SceneError("inputs", f"unknown input {name!r}; expected drive, load" + (", voltage" if motor else ""))
        if key == VOLTAGE and motor is None:
            raise SceneError("inputs", "'voltage' needs a motor (motor=...)")
        if key == DRIVE and motor is not None:
            raise SceneError("inputs", "with a motor the drive effort is the motor's: use 'voltage'")
        if key == DRIVE and model.drive is None:
            raise SceneError("inputs", "the scene has no drive joint")
        if key == LOAD and model.load is None:
            raise SceneError("inputs", "the scene has no load joint: give it a [load] joint to use 'load'")
        if key in chosen:
            raise SceneError("inputs", f"{name!r} is given twice")
        chosen.append(key)
    if not chosen:
        raise SceneError("inputs", "at least one input is needed")
    return chosen


def output_names(model: Mechanism, motor=None) -> list[str]:
    """Every output a linear model of ``model`` can have."""
    names = [c for c in observation_names(model.n_links) if c != "closure_error"]
    return names + (["current"] if motor is not None else [])


def _outputs(outputs, model: Mechanism, motor, plant: MinimalPlant) -> list[str]:
    if outputs is None:
        drive = model.drive or model.free_names[int(plant.ind[0])]
        return [drive]
    if isinstance(outputs, str):
        outputs = [s.strip() for s in outputs.split(",") if s.strip()]
    allowed = output_names(model, motor)
    chosen = []
    for name in outputs:
        if name == "closure_error":
            raise SceneError("outputs", "closure_error is zero on the constraint manifold and has no derivative "
                                        "there (it is a norm)")
        if name not in allowed:
            raise SceneError("outputs", f"unknown output {name!r}; expected one of {', '.join(allowed)}")
        chosen.append(name)
    if not chosen:
        raise SceneError("outputs", "at least one output is needed")
    return chosen


def signal_unit(name: str) -> str:
    """Unit of a state or output of the linear model."""
    return "A" if name == "current" else unit_of(name)


def linearize(scene, at="equilibrium", inputs=None, outputs=None, motor=None, *, torque=None,
              load_torque=None, near=None):
    """The mechanism's linear model about an operating point, as a python-control StateSpace.

    Parameters
    ----------
    scene : Scene or str
        A scene, or a preset name / TOML file path (exact closure).
    at : {'equilibrium', 'initial'}, str 't=T', float or dict
        The operating point (see :func:`operating_point`).
    inputs : sequence of str, optional
        'drive' (the drive effort, default), 'load' (the load effort), or with a
        motor 'voltage' (default) and 'load'.
    outputs : sequence of str, optional
        Any coordinate, rate or acceleration (``theta3``, ``theta4_d``,
        ``B3_dd``), ``tip_x``, ``tip_y``, the closing force ``Fx``, ``Fy``,
        ``Mz``, a joint reaction ``R2_Fy``, ``KE``, ``PE``, ``tau_drive``, and
        with a motor ``current``; default the drive coordinate.
    motor : grubler.motors.DCMotor, optional
        A DC motor and gearbox on the drive joint: the input is its voltage and
        its winding current a state (the winding temperature is held at ambient).
    torque, load_torque : float, optional
        Constant efforts defining the operating point (default the scene's).
    near : OperatingPoint, optional
        A nearby operating point whose assembly branch to keep (for sweeps).

    Returns
    -------
    control.StateSpace
        States: the independent coordinates, their rates, and with a motor
        ``current``; in SI units (rad, m, A).  Its ``operating_point`` attribute
        is the :class:`OperatingPoint`; the model maps deviations from it.

    Raises
    ------
    SceneError
        Naming the field: ``at`` when no equilibrium exists, it is not isolated,
        or the configuration is singular; ``inputs``, ``outputs``, ``motor``,
        ``torque``, ``method``.

    Examples
    --------
    >>> import control
    >>> from grubler.motors import DCMotor, Gearbox, load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(50.0, 0.9))
    >>> sys = linearize("thesis-fourbar", at={"theta2": 0.5}, motor=m, outputs=["theta2", "current"])
    >>> sys.state_labels, sys.input_labels
    (['theta2', 'theta2_d', 'current'], ['voltage'])
    >>> p = sorted(sys.poles(), key=abs)                # gravity tips the held crank over: one slow unstable pole
    >>> bool(p[0].real > 0), bool(p[1].real < 0), bool(p[2].real < -3000)   # the winding's R/L pole
    (True, True, True)
    >>> loop = control.feedback(50.0 * sys[0, 0], 1)       # 50 V/rad of crank error holds it
    >>> bool(all(p.real < 0 for p in loop.poles()))
    True
    """
    import control

    scene = _scene(scene)
    if motor is not None:
        motor = _motor_model(motor)
    scene = _prepared(scene, motor)
    model = scene.mechanism
    op, plant = _operating_point(scene, at, torque, load_torque, motor, near)
    in_names = _inputs(inputs if inputs is not None else [VOLTAGE if motor is not None else DRIVE], motor, model)
    out_names = _outputs(outputs, model, motor, plant)
    n, rows = plant.n, plant.rows
    y = np.concatenate([op.z, op.zd])
    F, G, Hx, Hu, T = plant.derivatives(y, op.drive, op.load)
    A, Bm = F[rows], G[rows]  # Bm columns: drive, load
    obs_index = {name: i for i, name in enumerate(observation_names(n))}
    state_names = [model.free_names[i] for i in plant.ind]
    state_names += [f"{s}_d" for s in state_names]
    if motor is None:
        Bu = {DRIVE: Bm[:, 0], LOAD: Bm[:, 1]}
        B = np.column_stack([Bu[k] for k in in_names])
        C = np.array([Hx[obs_index[o]] for o in out_names])
        D = np.array([[Hu[obs_index[o], 0 if k == DRIVE else 1] for k in in_names] for o in out_names])
    else:
        A, B, C, D = _with_motor(motor, op, plant, A, Bm, Hx, Hu, T, in_names, out_names, obs_index)
        state_names.append("current")
    sys = control.ss(A, B, C, D, states=state_names, inputs=[_input_label(k) for k in in_names],
                     outputs=out_names, name=model.name or "mechanism")
    sys.operating_point = op
    sys.motor = motor
    sys.units = {**{s: signal_unit(s) for s in state_names + out_names},
                 **{_input_label(k): input_unit(k, model) for k in in_names}}
    return sys


def _input_label(key: str) -> str:
    return {DRIVE: "tau_drive", LOAD: "tau_load", VOLTAGE: "voltage"}[key]


def _with_motor(motor, op, plant, A, Bm, Hx, Hu, T, in_names, out_names, obs_index):
    """Append the winding current: tau_drive = tau(i, w(x)), L di/dt = v - R i - k_e N w(x)."""
    from grubler.motors import MotorState, linearization

    n, drive = plant.n, plant.model.arrays.drive
    lin = linearization(motor, MotorState(op.current, motor.ambient_temperature), op.zd[drive])
    dw = T[n + drive]  # d(drive speed)/dx along the manifold
    nx = A.shape[0]
    Aa = np.zeros((nx + 1, nx + 1))
    Aa[:nx, :nx] = A + np.outer(Bm[:, 0], lin.dtau_dspeed * dw)
    Aa[:nx, nx] = Bm[:, 0] * lin.dtau_di
    Aa[nx, :nx] = lin.di_dspeed * dw
    Aa[nx, nx] = lin.di_di
    cols = {VOLTAGE: np.r_[np.zeros(nx), lin.di_dvoltage], LOAD: np.r_[Bm[:, 1], 0.0]}
    B = np.column_stack([cols[k] for k in in_names])
    C, D = [], []
    for o in out_names:
        if o == "current":
            C.append(np.r_[np.zeros(nx), 1.0])
            D.append([0.0] * len(in_names))
            continue
        i = obs_index[o]
        C.append(np.r_[Hx[i] + Hu[i, 0] * lin.dtau_dspeed * dw, Hu[i, 0] * lin.dtau_di])
        D.append([Hu[i, 1] if k == LOAD else 0.0 for k in in_names])
    return Aa, B, np.array(C), np.array(D)


# -- reports ------------------------------------------------------------------------
def summary(sys) -> str:
    """Poles, zeros, natural frequencies, damping ratios and DC gains with units, for people."""
    import control

    units = getattr(sys, "units", {})
    lines = []
    op = getattr(sys, "operating_point", None)
    if op is not None:
        at = op.kind + (f" at t = {op.time:g} s" if op.time is not None else "")
        coords = ", ".join(f"{k} = {coordinate_text(k, op.coordinates[k], radians=True)}" for k in op.independent)
        lines.append(f"operating point: {at}: {coords}; drive effort {op.drive:.6g} {op.effort_units['drive']}, "
                     f"load effort {op.load:.6g} {op.effort_units['load']}")
        if op.current is not None:
            lines.append(f"motor: {op.current:.6g} A at {op.voltage:.6g} V")
        if op.kind != "equilibrium":
            lines.append(f"  (not an equilibrium: accelerations {_accelerations(op.independent, op.acceleration)})")
    lines.append("states: " + ", ".join(f"{s} [{units.get(s, '')}]" for s in sys.state_labels))
    lines.append("poles, rad/s (natural frequency, damping ratio):")
    wn, zeta, poles = control.damp(sys, doprint=False)
    for p, w, z in sorted(zip(poles, wn, zeta), key=lambda t: abs(t[0])):
        # (+ 0.0 turns a negative zero, an undamped pole's, into a plain one)
        lines.append(f"  {p.real + 0.0:+.6g} {p.imag + 0.0:+.6g}j   wn = {w:.6g} rad/s ({w / (2 * math.pi):.6g} Hz), "
                     f"zeta = {z + 0.0:.4g}")
    for i, out in enumerate(sys.output_labels):
        for j, inp in enumerate(sys.input_labels):
            sub = sys[i, j]
            try:
                zeros = sub.zeros()
            except Exception:  # noqa: BLE001 - python-control's zero finder; report instead of failing
                zeros = None
            ztxt = "none" if zeros is not None and len(zeros) == 0 else (
                "?" if zeros is None else ", ".join(f"{z.real:+.6g}{z.imag:+.6g}j" for z in zeros) + " rad/s")
            with np.errstate(divide="ignore", invalid="ignore"):
                try:
                    g = complex(np.squeeze(sub.dcgain())).real
                except Exception:  # noqa: BLE001 - a pole at zero: the gain is infinite
                    g = math.inf
            per = units.get(inp, "")
            lines.append(f"{inp} -> {out}: zeros {ztxt}; DC gain {g:.6g} "
                         f"{units.get(out, '')}/{f'({per})' if ' ' in per else per}")
    return "\n".join(lines)

def to_json(sys) -> dict:
    """A, B, C, D (lists of rows), the names, units and the operating point."""
    op = getattr(sys, "operating_point", None)
    return {"A": np.asarray(sys.A).tolist(), "B": np.asarray(sys.B).tolist(), "C": np.asarray(sys.C).tolist(),
            "D": np.asarray(sys.D).tolist(), "states": list(sys.state_labels), "inputs": list(sys.input_labels),
            "outputs": list(sys.output_labels), "units": dict(getattr(sys, "units", {})),
            "operating_point": op.as_dict() if op is not None else None}


__all__ = ["OperatingPoint", "linearize", "operating_point", "output_names", "plot_bode", "bode_figure",
           "frequency_response", "phase_deg", "summary", "to_json",
           "input_unit", "signal_unit"]
