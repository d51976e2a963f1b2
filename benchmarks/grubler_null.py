"""An FMU whose doStep does nothing: the floor pythonfmu and fmpy set (benchmark only).

It has the mechanism FMU's input and the four outputs the benchmark reads, so a
master makes exactly the same FMI calls on it; ``set_real``/``get_real`` are the
leanest a pythonfmu slave can have (store the input, return the outputs), so what
remains is pythonfmu's C++ layer and fmpy's.
"""

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

OUTPUTS = ("theta2", "theta2_d", "Fx", "Fy")


def declare_variables(slave: Fmi2Slave) -> None:
    """The benchmark's interface: the motor torque in, the four outputs out."""
    slave.motor_torque = 0.0
    slave.register_variable(Real("motor_torque", causality=Fmi2Causality.input,
                                 variability=Fmi2Variability.continuous))
    for name in OUTPUTS:
        setattr(slave, name, 0.0)
        slave.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous))


class NullSlave(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        declare_variables(self)
        self._values = [0.0] * len(OUTPUTS)

    def do_step(self, current_time, step_size):
        return True

    def set_real(self, vrs, values):
        self.motor_torque = values[0]

    def get_real(self, vrs):
        return self._values
