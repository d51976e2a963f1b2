"""Controllers and transducers for a grubler mechanism (``grubler.controllers``).

Each block is a sampled :class:`Law` usable directly from Python and, through
the same declaration, as its own FMU (``python build_fmu.py``; your own law:
:func:`grubler.controllers.fmu.build_controller_fmu`).  The sample-and-hold
semantics in co-simulation are documented in :mod:`grubler.controllers.law`.

- :class:`PID`: discrete PID, setpoint weights, filtered derivative, anti-windup, limits;
- :class:`CascadeController`: position (P/PI) and speed (PI) loops with speed feedforward;
- :class:`LinearController`: any python-control TF or state space, discretised;
- :class:`ComputedTorque`: inverse-dynamics feedforward of a one-DOF mechanism;
- :class:`Trajectory`: constant speed, trapezoid, S-curve, sine and table setpoints;
- :class:`Encoder`: seeded noise, quantisation, delay and a speed estimate;
- :class:`Tachometer`, :class:`CurrentSensor`: gain error, bandwidth, offset and seeded noise.

The laws run in C (``controllers/kernel``); the PID, cascade, encoder,
trajectory and the two sensors are native FMUs too (no Python at run time).

May import: the base modules (:mod:`grubler.errors`, :mod:`grubler.limits`),
:mod:`grubler.mechanism` (computed torque runs the inverse dynamics),
:mod:`grubler.motors`, and :mod:`grubler.system` for the pythonfmu slave that
makes a law an FMU (:mod:`grubler.controllers.fmu`). Not the studies or the CLI.

Examples
--------
>>> from grubler.controllers import PID, Sampler
>>> s = Sampler(PID(K=2.0, Ts=0.01))
>>> s.step(0.0, 0.05, {"setpoint": 1.0, "measurement": 0.25, "feedforward": 0.0})   # 5 samples
{'u': 1.5}
"""

from grubler.controllers.cascade import CascadeController
from grubler.controllers.computed_torque import ComputedTorque
from grubler.controllers.encoder import Encoder
from grubler.controllers.law import Law, Parameter, Sampler
from grubler.controllers.linear import LinearController
from grubler.controllers.pid import PID
from grubler.controllers.sensors import CurrentSensor, Tachometer
from grubler.controllers.trajectory import Trajectory

__all__ = ["CascadeController", "ComputedTorque", "CurrentSensor", "Encoder", "Law", "LinearController", "PID", "Parameter",
           "Sampler", "Tachometer", "Trajectory"]
