"""What a fresh process pays before its first result: the native FMU in a C host, and the library.

    python benchmarks/first_use.py [--repeat 11]

- `FMU`: a new process (tests/fmi_host.c, compiled here, run with an empty
  environment) loads Mechanism.fmu's binary, instantiates, sets up, initialises
  (which assembles the loop) and frees it: the whole process, start to exit.
- `library`: a new Python process runs `import grubler` and 1 s of the thesis
  four-bar (`grubler.simulate`), start to exit.

Medians of --repeat runs, the two alternating.  Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE.parent / "tests")]

import build_fmu  # noqa: E402
from fmpy import extract, read_model_description  # noqa: E402

from c_host import compile_host  # noqa: E402

SCRIPT = "new 0 bench\nsetup 0\nenter\nexit\nterm\nfree\n"
LIBRARY = "import grubler; grubler.simulate('thesis-fourbar', t_end=1.0)"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=11)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="first_use_"))
    (fmu,) = build_fmu.build(tmp, ["Mechanism"])
    md = read_model_description(str(fmu))
    unzipped = Path(extract(str(fmu)))
    lib = unzipped / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    host = compile_host(tmp / "fmi_host")

    def fmu_run():
        out = subprocess.run([str(host), str(lib), md.guid], input=SCRIPT, capture_output=True, text=True, env={},
                             check=True).stdout
        if "exit 0" not in out:
            raise RuntimeError(f"initialisation failed: {out}")

    def library_run():
        subprocess.run([sys.executable, "-c", LIBRARY], check=True, env=dict(os.environ))

    times = {"FMU": [], "library": []}
    for _ in range(args.repeat):
        for name, fn in (("FMU", fmu_run), ("library", library_run)):
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    print(f"Command: `python benchmarks/first_use.py --repeat {args.repeat}`\n")
    print("| fresh process | median (ms) | min (ms) | max (ms) | target |")
    print("|---|---|---|---|---|")
    targets = {"FMU": "<= 50 ms: load, instantiate, initialise", "library": "< 2 s: import grubler + 1 s simulate"}
    for name, v in times.items():
        print(f"| {name} | {statistics.median(v) * 1e3:.1f} | {min(v) * 1e3:.1f} | {max(v) * 1e3:.1f} | "
              f"{targets[name]} |")


if __name__ == "__main__":
    main()
