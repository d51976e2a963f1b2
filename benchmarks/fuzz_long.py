"""The fuzz suite's long profile: random examples, 25 times the CI profile's, and a table of outcomes.

Usage::

    python benchmarks/fuzz_long.py                 # every class (about 15 minutes here)
    python benchmarks/fuzz_long.py -k scene        # the classes whose test name matches
    python benchmarks/fuzz_long.py --json out.json # also keep the counts

It runs ``tests/test_fuzz.py`` under ``GRUBLER_FUZZ_PROFILE=long`` (see
``tests/fuzzing.py``) and prints, per class of input, how many examples were
tried and how many ended with exit 0 and exit 2; pytest's own summary says
whether any broke the contract (a failing example is shrunk and printed with a
``@reproduce_failure`` line to paste into the test).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-k", help="pytest -k expression selecting classes")
    p.add_argument("--json", help="write the outcome counts here too")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "outcomes.json"
        env = dict(os.environ, GRUBLER_FUZZ_PROFILE="long", GRUBLER_FUZZ_REPORT=str(report))
        cmd = [sys.executable, "-m", "pytest", str(ROOT / "tests" / "test_fuzz.py"), "-q", "-p", "no:cacheprovider"]
        if args.k:
            cmd += ["-k", args.k]
        t0 = time.perf_counter()
        code = subprocess.call(cmd, env=env, cwd=ROOT)
        wall = time.perf_counter() - t0
        counts = json.loads(report.read_text()) if report.exists() else {}
    print(f"\n{'class of input':<24} {'tried':>6} {'exit 0':>7} {'exit 2':>7}   ({wall:.0f} s, pytest exit {code})")
    for cls, c in sorted(counts.items()):
        print(f"{cls:<24} {c.get('tried', 0):>6} {c.get('exit 0', 0):>7} {c.get('exit 2', 0):>7}")
    if args.json:
        Path(args.json).write_text(json.dumps({"wall_seconds": wall, "pytest_exit": code, "classes": counts},
                                              indent=1, sort_keys=True))
    return code


if __name__ == "__main__":
    sys.exit(main())
