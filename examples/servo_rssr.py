"""A DC motor with a gearbox drives the crank of the RSSR (a crank-rocker between skew shafts, the
spatial preset ``rssr``) under PID position control, with an encoder: the servo four-bar's system
(examples/servo_fourbar.py) with the native spatial FMU as its mechanism.

    python build_fmu.py                        # the motor, the laws and RSSR.fmu, into dist/
    python examples/servo_rssr.py              # writes examples/servo_rssr.ssd

then run it from the command line:

    grubler cosim examples/servo_rssr.ssd --csv servo_rssr.csv --plot servo_rssr.png

The RSSR is much lighter than the thesis four-bar: at the crank the motor's rotor (J N^2, 0.034 kg m^2
through 50:1, in the mechanism's ``drive.inertia``) outweighs it, so the four-bar's PID gains hold it too.
"""

import dataclasses
from pathlib import Path

from grubler.system.servo import ServoDesign, servo_system

HERE = Path(__file__).resolve().parent

DESIGN = dataclasses.replace(ServoDesign(), scene="rssr", t_end=3.0)


def main() -> Path:
    system = servo_system(DESIGN, HERE.parent / "dist", name="servo_rssr")
    return system.write(HERE / "servo_rssr.ssd")


if __name__ == "__main__":
    print(f"wrote {main()}")
