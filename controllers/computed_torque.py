"""Computed-torque feedforward: the drive torque a one-DOF mechanism needs to follow a trajectory.

Given the drive joint's position, velocity and acceleration from a trajectory,
:func:`grubler.mechanism.inverse.drive_demand` closes the loop at that drive position
(starting from the last sample's configuration, so the branch stays the one the
scene sketches), makes the dependent rates and accelerations consistent with
the closures, and gives the drive torque by the inverse dynamics (gravity,
damping, the drive inertia and the closure forces included): the kernel's
``grb_drive_demand``, the C the native ``ComputedTorque.fmu`` runs too
(:func:`grubler.controllers.native_fmu.computed_torque_spec`).

Optionally, through a gearbox of ratio ``gear_ratio`` (motor turns per drive
joint turn) and efficiency ``efficiency``, the motor torque is
``tau / (gear_ratio efficiency)`` while the motor drives the load and
``tau efficiency / gear_ratio`` while the load drives the motor; with a DC
motor's constants (winding resistance ``R``, torque constant ``k_t``, back-emf
constant ``k_e``) the voltage feedforward is the steady-current estimate
``R tau_m / k_t + k_e gear_ratio omega`` (the winding inductance neglected;
0 when ``k_t = 0``).  On a mechanism driven through a slide the units are
m, m/s, m/s2 and N instead of rad, rad/s, rad/s2 and N m.

Examples
--------
>>> ct = ComputedTorque("thesis-fourbar")
>>> tau = ct.drive_torque(0.0, 0.0, 0.0)       # holding the crank still against gravity
>>> bool(abs(tau - ct.drive_torque(0.0, 0.0, 0.0)) < 1e-12)
True
"""

from __future__ import annotations

import numpy as np

from grubler.errors import SceneError
from grubler.mechanism.inverse import DriveDemand, drive_demand
from grubler.mechanism.model import Mechanism
from grubler.mechanism.scene import Scene, load_scene

from grubler.controllers.law import Law, Parameter, check_number, check_sample_time


def _mechanism(source) -> Mechanism:
    if isinstance(source, Mechanism):
        return source
    if isinstance(source, Scene):
        return source.mechanism
    return load_scene(source).mechanism


class ComputedTorque(Law):
    """Inverse-dynamics feedforward of a one-DOF mechanism along a drive trajectory.

    Parameters
    ----------
    mechanism : str, Scene or Mechanism
        A preset name, a scene file's TOML text or path, or the model itself.
        It must have a drive joint and mobility one.
    drive_inertia : float, optional
        Inertia at the drive joint (a motor's rotor inertia times the gear ratio
        squared), kg m2; default the scene's.
    gear_ratio : float
        Motor turns per drive joint turn (non-zero).
    efficiency : float
        Gearbox efficiency, in (0, 1].
    R, k_t, k_e : float
        Motor winding resistance (ohm), torque constant (N m/A) and back-emf
        constant (V s/rad), for the voltage feedforward; ``k_t = 0`` gives none.
    Ts : float
        Sample time, s; 0 for once per communication step.

    Examples
    --------
    >>> from grubler.controllers import ComputedTorque
    >>> ff = ComputedTorque("thesis-fourbar")            # no motor: the torque at the crank
    >>> out = ff.update(0.0, {"position": 0.0, "velocity": 0.0, "acceleration": 0.0})
    >>> round(out["torque"], 3)                          # N m that holds the crank still at 0 rad
    5.395
    """

    inputs = {"position": "drive joint position from the trajectory [rad]",
              "velocity": "drive joint velocity from the trajectory [rad/s]",
              "acceleration": "drive joint acceleration from the trajectory [rad/s2]"}
    outputs = {"torque": "torque needed at the drive joint [N m]",
               "motor_torque": "torque at the motor shaft, through the gearbox [N m]",
               "voltage": "motor voltage feedforward, 0 without motor constants [V]"}
    parameters = {
        "mechanism": Parameter("thesis-fourbar", "preset name, or the content of a scene file (TOML) [1]"),
        "drive_inertia": Parameter(None, "inertia at the drive joint, rotor inertia x gear ratio^2; "
                                         "default the scene's [kg m2]", start=0.0),
        "gear_ratio": Parameter(1.0, "motor turns per drive joint turn [1]"),
        "efficiency": Parameter(1.0, "gearbox efficiency, in (0, 1] [1]"),
        "R": Parameter(0.0, "motor winding resistance [ohm]"),
        "k_t": Parameter(0.0, "motor torque constant, 0 for no voltage feedforward [N m/A]"),
        "k_e": Parameter(0.0, "motor back-emf constant [V s/rad]"),
        "Ts": Parameter(0.0, "sample time, 0 for every communication step [s]"),
    }

    def __init__(self, mechanism="thesis-fourbar", drive_inertia: float | None = None, gear_ratio: float = 1.0,
                 efficiency: float = 1.0, R: float = 0.0, k_t: float = 0.0, k_e: float = 0.0, Ts: float = 0.0):
        model = _mechanism(mechanism)
        if drive_inertia is not None:
            model = model.replace(drive_inertia=check_number(drive_inertia, "drive_inertia", low=0.0))
        self.model = model
        self.gear_ratio = check_number(gear_ratio, "gear_ratio")
        if self.gear_ratio == 0:
            raise SceneError("gear_ratio", "must be non-zero")
        self.efficiency = check_number(efficiency, "efficiency", low=0.0, high=1.0, low_open=True)
        self.R = check_number(R, "R", low=0.0)
        self.k_t = check_number(k_t, "k_t", low=0.0)
        self.k_e = check_number(k_e, "k_e", low=0.0)
        self.Ts = check_sample_time(Ts, allow_zero=True)
        self.reset()
        # a mechanism without a drive joint, with mobility other than one, or that
        # does not close at its sketched start is refused here, at initialisation
        self.demand(float(self.z[model.free_index(model.drive)]) if model.drive else 0.0, 0.0, 0.0)
        self.reset()

    def reset(self) -> None:
        """Forget the last configuration: the next one starts from the scene's."""
        self.z = self.model.z_from_q(self.model.q_ref)

    def demand(self, position: float, velocity: float, acceleration: float) -> DriveDemand:
        """The whole inverse-dynamics sample (every joint's motion, the drive torque) at one drive state.

        Raises
        ------
        AssemblyError
            When the loop cannot close at that drive position.
        """
        d = drive_demand(self.model, [position], [velocity], [acceleration], z_guess=self.z)
        self.z = d.z[0]
        return d

    def drive_torque(self, position: float, velocity: float, acceleration: float) -> float:
        """Torque at the drive joint for that motion, N m (N on a slide)."""
        return float(self.demand(position, velocity, acceleration).torque[0])

    def motor(self, tau, velocity):
        """Motor torque and voltage feedforward for a drive torque and drive velocity.

        Elementwise over arrays: motor sizing predicts what this feedforward
        leaves to the PID over a whole duty cycle with this same computation.
        """
        n, eta = self.gear_ratio, self.efficiency
        tau, velocity = np.asarray(tau, float), np.asarray(velocity, float)
        tau_m = np.where(tau * velocity >= 0, tau / (n * eta), tau * eta / n)  # motoring, else braking
        voltage = self.R * tau_m / self.k_t + self.k_e * n * velocity if self.k_t > 0 else np.zeros_like(tau_m)
        return tau_m[()], voltage[()]

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        tau = self.drive_torque(inputs["position"], inputs["velocity"], inputs["acceleration"])
        tau_m, voltage = self.motor(tau, inputs["velocity"])
        return {"torque": tau, "motor_torque": float(tau_m), "voltage": float(voltage)}

    def get_state(self):
        return self.z.copy()  # the model is constant: only the warm start moves

    def set_state(self, state) -> None:
        self.z = np.array(state, dtype=float)


__all__ = ["ComputedTorque"]
