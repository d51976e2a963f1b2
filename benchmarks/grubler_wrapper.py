"""The leanest FMU around the library (benchmark only): no checks, no lazy outputs.

Each step it does exactly what the benchmark's library run does (set the torque,
advance, read the state and dynamics outputs), so its cost over that run is what
pythonfmu's C++ layer and fmpy add around a slave that does real work.  That is
more than around the do-nothing slave (docs/fmu-benchmark.md: `wrapper - library`
against `null`), most likely because the library's work between the FMI calls pushes that layer's code
and data out of the processor's caches.  It imports grubler from the benchmark's
own process, which has it.
"""

from grubler_null import OUTPUTS, declare_variables  # packed beside this script
from pythonfmu import Fmi2Slave

import grubler
from grubler.simulate import Simulator


class WrapperSlave(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        declare_variables(self)
        self._sim = Simulator(grubler.load_scene("thesis-fourbar").mechanism)

    def do_step(self, current_time, step_size):
        self._sim.set_inputs(self.motor_torque)
        self._sim.advance_to(current_time + step_size)
        return True

    def set_real(self, vrs, values):
        self.motor_torque = values[0]

    def get_real(self, vrs):
        out = self._sim.outputs(["state", "dynamics"])
        return [out[name] for name in OUTPUTS]
