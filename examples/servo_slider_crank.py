"""Second example: a slider-crank driven at constant speed (120 rpm) against a load.

    python build_fmu.py
    python examples/servo_slider_crank.py       # writes examples/servo_slider_crank.ssd
    grubler cosim examples/servo_slider_crank.ssd --plot slider_crank.png

The motor and gear ratio are what `grubler size` ranks for this duty cycle:

    grubler size slider-crank --speed 12.566 --load-torque -0.5 --supply 48 --current-limit 10

(maxon RE 40 48 V through 20:1, margin 2.35, bound by its continuous torque).
The PID follows a constant-speed ramp of the crank angle; the load is a constant
0.5 N m resisting torque on the crank, as a pump or a press would put on it.
"""

from pathlib import Path

from grubler.system.servo import ServoDesign, servo_system

HERE = Path(__file__).resolve().parent

DESIGN = ServoDesign(
    scene="slider-crank",
    motor="maxon-re40-148877",
    gear_ratio=20.0,
    gear_efficiency=0.9,
    supply_voltage=48.0,
    current_limit=10.0,
    trajectory={"kind": "constant", "speed": 12.566370614359172},  # 120 rpm
    pid={"K": 200.0, "Ti": 0.1, "Td": 0.01, "N": 10.0, "Ts": 1e-3, "u_min": -48.0, "u_max": 48.0},
    encoder={"counts_per_rev": 16384, "Ts": 1e-3},
    load_joint="theta2",
    load_torque=-0.5,
    t_end=3.0,
    step=1e-3,
)


def main() -> Path:
    system = servo_system(DESIGN, HERE.parent / "dist", name="servo_slider_crank")
    return system.write(HERE / "servo_slider_crank.ssd")


if __name__ == "__main__":
    print(f"wrote {main()}")
