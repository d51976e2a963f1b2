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

from grubler.system.cylinder_servo import PRESET_DESIGNS, cylinder_servo_system

HERE = Path(__file__).resolve().parent

# the designs are the library's, by preset (the app's Run servo starts from them too)
DESIGNS = {preset.replace("-", "_"): design for preset, design in PRESET_DESIGNS.items()}


def main(fmu_dir: Path = HERE.parent / "dist", out_dir: Path = HERE) -> list[Path]:
    return [cylinder_servo_system(design, fmu_dir, name=name).write(out_dir / f"{name}.ssd")
            for name, design in DESIGNS.items()]


if __name__ == "__main__":
    for path in main():
        print(f"wrote {path}")
