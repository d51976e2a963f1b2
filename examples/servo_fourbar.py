"""The main example: a DC motor with a gearbox drives the crank of the thesis four-bar
under PID position control, with an encoder, as a co-simulation of five FMUs.

    python build_fmu.py                     # the FMUs, into dist/
    python examples/servo_fourbar.py        # writes examples/servo_fourbar.ssd

then run it from the command line (what the README's first command does):

    grubler cosim examples/servo_fourbar.ssd --csv servo_fourbar.csv --plot servo_fourbar.png

The .ssd is SSP 1.0: fmpy and other SSP tools open it too.  Edit the design
below (motor, gear ratio, gains, move) and run this script again to rewrite it.
"""

from pathlib import Path

from grubler.system.servo import ServoDesign, servo_system

HERE = Path(__file__).resolve().parent

DESIGN = ServoDesign(
    scene="thesis-fourbar",
    motor="maxon-re40-148877",  # 150 W, 48 V
    gear_ratio=50.0,
    gear_efficiency=0.9,
    supply_voltage=48.0,
    current_limit=10.0,
    # half a turn of the crank and back, 0.5 s rest at each end, endlessly
    trajectory={"kind": "trapezoid", "distance": 3.141592653589793, "v_max": 6.283185307179586, "a_max": 20.0,
                "dwell": 0.5, "repeat": 0, "reverse": True},
    pid={"K": 300.0, "Ti": 0.2, "Td": 0.02, "N": 10.0, "Ts": 1e-3, "u_min": -48.0, "u_max": 48.0},
    encoder={"counts_per_rev": 16384, "Ts": 1e-3},  # 14 bits on the crank
    t_end=10.0,
    step=1e-3,
)


def main() -> Path:
    system = servo_system(DESIGN, HERE.parent / "dist", name="servo_fourbar")
    return system.write(HERE / "servo_fourbar.ssd")


if __name__ == "__main__":
    print(f"wrote {main()}")
