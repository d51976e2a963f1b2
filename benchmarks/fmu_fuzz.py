"""The long profile of the FMU call-sequence fuzz (tests/fmu_fuzz.py) on the pythonfmu FMUs.

    python benchmarks/fmu_fuzz.py [--examples 2000] [--dist FOLDER] [NAME ...]

Builds the controller FMUs (and the tests' user-written RateLimiter law) into a
temporary folder unless ``--dist`` names one, runs ``--examples`` generated call
sequences per FMU in a child process, and prints per FMU the calls made, the
statuses answered, the slowest call, and every contract violation (a Fatal status,
a non-OK status without a logged message, a call over the time bound, or the
child dying).  Exit status 1 when there is any.  ``tests/test_fmu_contract.py``
runs the same with 60 sequences per FMU in CI.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests"


def build(folder: Path) -> None:
    sys.path[:0] = [str(ROOT), str(TESTS)]
    import build_fmu
    from controller_scenarios import RateLimiter

    from grubler.controllers.fmu import build_controller_fmu

    build_fmu.build(folder, ["PID", "CascadeController", "LinearController", "ComputedTorque", "Trajectory",
                             "Encoder"])
    build_controller_fmu(RateLimiter, folder)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=2000, help="call sequences per FMU")
    ap.add_argument("--dist", type=Path, help="folder with the FMUs already built")
    ap.add_argument("names", nargs="*", help="FMUs to fuzz (default: all)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="grubler_fuzz_") as tmp:
        dist = args.dist
        if dist is None:
            dist = Path(tmp) / "dist"
            build(dist)
        out = Path(tmp) / "out.json"
        proc = subprocess.run([sys.executable, str(TESTS / "fmu_fuzz.py"), str(dist), str(out),
                               str(args.examples), *args.names], cwd=str(TESTS))
        if not out.exists():
            print(f"the fuzz child died (exit {proc.returncode})")
            return 1
        result = json.loads(out.read_text())["result"]
    for name, got in result["fmus"].items():
        statuses = ", ".join(f"{k} {v}" for k, v in sorted(got["statuses"].items()))
        print(f"{name:18s} {got['sequences']:6d} sequences {got['calls']:7d} calls ({statuses}); "
              f"slowest call {got['slowest_call_s'] * 1e3:.1f} ms, {got['seconds']:.0f} s")
    for v in result["violations"]:
        print("VIOLATION", json.dumps(v))
    return 1 if result["violations"] else 0


if __name__ == "__main__":
    sys.exit(main())
