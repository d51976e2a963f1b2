"""Motor models that drive a grubler mechanism (``grubler.motors``).

:mod:`~grubler.motors.motor_data` holds a motor's constants (:class:`MotorData`,
from a datasheet or a shipped data set); :mod:`~grubler.motors.dc_motor` steps a
permanent-magnet DC motor with gearbox, current-limited drive and winding
temperature, taking the shaft speed as an input (the rotor's inertia belongs to
the mechanism: ``drive.inertia`` = :attr:`DCMotor.reflected_inertia`).

May import: the base modules (:mod:`grubler.errors`, :mod:`grubler.limits`,
:mod:`grubler.binding`, which also loads the motor's C kernel). It sits beside
:mod:`grubler.mechanism` and imports neither it nor anything above.
"""

from grubler.motors.dc_motor import (DCMotor, Drive, Gearbox, MotorOutputs, MotorSimulator, MotorState,
                                     current_for_torque, initial_state, linearization, outputs, shaft_torque,
                                     step)
from grubler.motors.motor_data import (MotorData, list_motors, load_motor, motor_listing,
                                       two_node_slow_time_constant)

__all__ = ["current_for_torque", "DCMotor", "Drive", "Gearbox", "MotorData", "MotorOutputs", "MotorSimulator", "MotorState",
           "initial_state", "linearization", "list_motors", "load_motor", "motor_listing", "outputs", "shaft_torque",
           "step", "two_node_slow_time_constant"]
