"""Co-simulate the servo four-bar in a child process (run by test_servo.py).

    python servo_scenario.py FMU_DIR OUT.json T_END COUNTS STEP [STEP ...]

Writes the crank angle and motor current at every communication point for each
step, then leaves with os._exit so that a crash at interpreter exit (PythonFMU
issue 228) can neither hide nor fake a result.
"""

import dataclasses
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "examples"))

from grubler import cosim  # noqa: E402
from grubler.system.servo import servo_system  # noqa: E402

import servo_fourbar  # noqa: E402


def main() -> None:
    fmu_dir, out, t_end, counts, steps = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), sys.argv[5:]
    design = dataclasses.replace(servo_fourbar.DESIGN, encoder={"counts_per_rev": counts, "Ts": 1e-3})
    system = servo_system(design, fmu_dir)
    result = {}
    for h in steps:
        r = cosim.run(system, t_end=t_end, step=float(h), record=["mechanism.drive_angle", "motor.current"])
        result[h] = {"t": r.t.tolist(), "angle": r["mechanism.drive_angle"].tolist(),
                     "current": r["motor.current"].tolist(), "order": r.order, "wall": r.wall_time}
    Path(out).write_text(json.dumps({"done": True, "result": result}))


if __name__ == "__main__":
    try:
        main()
    finally:
        sys.stdout.flush()
        os._exit(0)
