"""An FMU whose doStep does nothing: the floor pythonfmu and fmpy set (benchmark only)."""

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class NullSlave(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.motor_torque = 0.0
        self.theta2 = 0.0
        self.register_variable(Real("motor_torque", causality=Fmi2Causality.input,
                                    variability=Fmi2Variability.continuous))
        self.register_variable(Real("theta2", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous))

    def do_step(self, current_time, step_size):
        return True
