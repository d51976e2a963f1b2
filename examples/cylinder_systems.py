"""Three cylinder-driven linkages under position control, each an SSP system of four FMUs.

    python build_fmu.py                         # the FMUs, into dist/
    python examples/cylinder_systems.py         # writes examples/<name>.ssd

then, for each (luffing_boom, cylinder_slider_crank, toggle_clamp):

    grubler cosim examples/luffing_boom.ssd --csv boom.csv --plot boom.png
    grubler report boom.csv --scene luffing-boom --out boom-report.png
    grubler animate boom.csv --scene luffing-boom --out boom.gif \\
        --signals cylinder.pressure_a,cylinder.pressure_b,cylinder.force

A trajectory moves the setpoint of the actuator's length, a PID commands the
valve, the cylinder FMU (hydraulic or pneumatic) gives the force the mechanism
FMU takes as its actuator's input; the scenes are presets (``[[actuator]]``).
"""

from pathlib import Path

from grubler.system.cylinder_servo import CylinderServoDesign, cylinder_servo_system

HERE = Path(__file__).resolve().parent

DESIGNS = {
    # a four-bar boom, 200 kg past the head, lifted 0.1 m of cylinder stroke by a 50/28 mm hydraulic cylinder
    "luffing_boom": CylinderServoDesign(
        "luffing-boom", cylinder="hydraulic", move=0.1, speed=0.1, acceleration=0.5, t_end=4.0,
        pid={"K": 20.0, "Ts": 1e-3, "u_min": -1.0, "u_max": 1.0}),
    # the slider-crank of the second type: a 32/18 mm hydraulic cylinder pulls the rod 50 mm down its line;
    # the seals' friction changes sign over 50 mm/s, which a 1 ms coupling to a 12 kg rod can follow
    "cylinder_slider_crank": CylinderServoDesign(
        "cylinder-slider-crank", cylinder="hydraulic", move=-0.05, speed=0.1, acceleration=0.5, t_end=3.0,
        start_position=0.1, constants={"bore": 0.032, "rod": 0.018, "stroke": 0.2, "smoothing_speed": 0.05},
        pid={"K": 20.0, "Ts": 1e-3, "u_min": -1.0, "u_max": 1.0}),
    # a 32/12 mm pneumatic cylinder closes the clamp to 6 degrees short of its toggle;
    # PI(D): a pneumatic position loop needs the integral to pull through the seals' friction
    "toggle_clamp": CylinderServoDesign(
        "toggle-clamp", cylinder="pneumatic", move=0.02, speed=0.05, acceleration=0.5, t_end=4.0,
        start_position=0.02, constants={"smoothing_speed": 0.05},
        pid={"K": 20.0, "Ti": 0.3, "Td": 0.01, "N": 10.0, "Ts": 1e-3, "u_min": -1.0, "u_max": 1.0}),
}


def main(fmu_dir: Path = HERE.parent / "dist", out_dir: Path = HERE) -> list[Path]:
    return [cylinder_servo_system(design, fmu_dir, name=name).write(out_dir / f"{name}.ssd")
            for name, design in DESIGNS.items()]


if __name__ == "__main__":
    for path in main():
        print(f"wrote {path}")
