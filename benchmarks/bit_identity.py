"""Every preset's results from this checkout against an older commit's, byte for byte.

    python benchmarks/bit_identity.py OLD_COMMIT [--t-end 1.0] [--only NAME ...]

A change to the kernel that only renames or regroups (tables into structs, say)
must leave every floating-point result as it was.  This builds the old commit's
kernel beside the installed one (as compare_versions.py does) and, for every
preset under both closure methods, simulates it with each version and compares
the bytes of the states, rates, accelerations, energies, closure values and
joint reactions at every output time, the integrator's counts, and the complex-
step Jacobian of the state equation at the start (the kernel's complex twin).
It prints each array that differs (with its largest difference) and the count of
arrays compared; it exits 1 when any differs.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from compare_versions import load_old

METHODS = ("exact", "penalty")


def arrays(pkg, name: str, method: str, t_end: float) -> dict[str, np.ndarray]:
    """Named result arrays of one preset under one closure method (an error becomes its message)."""
    from importlib import import_module

    try:
        res = pkg.simulate(name, t_end=t_end, method=method)
        cols, table = res.table(("state", "dynamics", "energy", "reactions"))
    except Exception as exc:  # both versions must fail alike
        return {"error": np.frombuffer(f"{type(exc).__name__}: {exc}".encode(), dtype=np.uint8)}
    out = {"z": res.z, "zd": res.zd,
           "counts": np.array([res.stats["steps"], res.stats["rejected"], res.stats["rhs_evals"]])}
    out.update({c: table[:, i] for i, c in enumerate(cols)})
    integrators = import_module(pkg.__name__ + ".mechanism.integrators")  # the package layout since mechanism/
    m = res.model
    ode = integrators.StateEquation(m, method=method, drive=1.0, load=0.0)
    out["jacobian"] = ode.jacobian(0.0, np.concatenate([res.z[0], res.zd[0]]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", help="commit to compare against")
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--only", nargs="*", default=None)
    args = ap.parse_args()
    old = load_old(args.old)
    import grubler

    names = args.only or grubler.mechanism.scene.preset_names()
    compared = differ = 0
    for name in names:
        for method in METHODS:
            a, b = arrays(old, name, method, args.t_end), arrays(grubler, name, method, args.t_end)
            for key in sorted(set(a) | set(b)):
                compared += 1
                x, y = a.get(key), b.get(key)
                if x is not None and y is not None and x.dtype == y.dtype and x.shape == y.shape \
                        and np.ascontiguousarray(x).tobytes() == np.ascontiguousarray(y).tobytes():
                    continue
                differ += 1
                gap = (float(np.nanmax(np.abs(x - y))) if x is not None and y is not None and x.shape == y.shape
                       and x.dtype.kind == "f" else float("nan"))
                print(f"DIFFERS {name} {method} {key}: largest difference {gap:.3g}")
    print(f"{compared} arrays compared over {len(names)} presets x {len(METHODS)} methods, {differ} differ")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
