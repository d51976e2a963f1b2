"""Work-precision of co-simulation: error against ONE monolithic simulation versus wall time, per master and step.

    python benchmarks/cosim_wp.py                      # every system, every master (~15 min on the 2-core box)
    python benchmarks/cosim_wp.py --systems servo_exact --steps 1e-3 1e-4 --masters "grubler, Gauss-Seidel"
    python benchmarks/cosim_wp.py --out docs/cosim.md --png docs/images/cosim_wp.png
    python benchmarks/cosim_wp.py --from docs/cosim.md --png docs/images/cosim_wp.png   # report a merged table again

Systems (:data:`SYSTEMS`), each with its monolithic reference written apart from the FMUs:

- ``servo``: the servo four-bar of examples/servo_fourbar.py (DC motor through 50:1, PID on a 14-bit
  encoder), 2 s, against tests/servo_reference.py; compared on the crank angle;
- ``servo_exact``: the same with the encoder's quantisation off, so that convergence can be read (with
  it on, a run whose crank crosses a count at another sample than the reference's is off by a count);
- ``luffing_boom`` and ``cylinder_slider_crank``: the hydraulic systems of examples/cylinder_systems.py
  (trajectory -> PID -> valve -> cylinder -> mechanism), against tests/cylinder_reference.py (mechanism,
  cylinder, valve and PID as one ODE); compared on the actuator's length.

Masters (:data:`MASTERS`: a name and a function ``(case, step, folder) -> (t, values, wall seconds)``, or
with a fourth item, the master's own word that the run diverged, which the table and figure show):
grubler's Gauss-Seidel, Jacobi, extrapolating (fixed step and ``--tol``) and Newton masters, ``fmpy.ssp.simulate_ssp``, the system exported as one FMU (fmpy's
container, ``grubler export``) run by ``fmpy.simulate_fmu``, and libcosim (libcosimpy) from the .ssd alone.
To add a master, add an entry; a master that fails (or raises) on a case is a row that says so.

The error is the largest difference from the reference over the reference's sample instants (every
1 ms) that the master also recorded.  Everything runs in this one process, the masters alternating in
rounds (a rotated order each round); the wall time is the median over the rounds of the run alone (the
FMUs built and unpacked before), the error that of the first round (the runs are deterministic).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "examples")]

from grubler import cosim  # noqa: E402
from grubler.system.ssp import System  # noqa: E402

STEPS = (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)  # each a multiple or a divisor of the laws' 1 ms sample
SAMPLE = 1e-3  # the references' sample period (the PID's and the encoder's)


@dataclasses.dataclass
class Case:
    """A system, the signal it is judged on, and its monolithic reference sampled every SAMPLE seconds."""

    name: str
    system: System
    signal: str
    unit: str
    t_end: float
    reference: np.ndarray  # the signal at k * SAMPLE, k = 0 .. t_end / SAMPLE
    reference_seconds: float = 0.0
    unpacked: object = None  # grubler's UnpackedFMUs, shared by its runs


# -- the systems ----------------------------------------------------------------------------------------
def servo_case(fmu_dir: Path, t_end: float, quantised: bool = True) -> Case:
    """The servo four-bar (examples/servo_fourbar.py), its encoder's quantisation on or off."""
    import servo_fourbar
    from servo_reference import monolithic

    from grubler.system.servo import servo_system

    design = servo_fourbar.DESIGN
    if not quantised:
        design = dataclasses.replace(design, encoder={**design.encoder, "counts_per_rev": 0})
    t0 = time.perf_counter()
    ref = monolithic(design, t_end)
    seconds = time.perf_counter() - t0
    name = "servo" if quantised else "servo_exact"
    return Case(name, servo_system(design, fmu_dir, name=name), "mechanism.drive_angle", "rad", t_end,
                ref["drive_angle"], seconds)


def cylinder_case(fmu_dir: Path, name: str, t_end: float) -> Case:
    """A hydraulic system of examples/cylinder_systems.py, judged on its actuator's length."""
    import cylinder_systems
    from cylinder_reference import monolithic

    from grubler.mechanism.scene import load_scene
    from grubler.system.cylinder_servo import cylinder_servo_system

    design = dataclasses.replace(cylinder_systems.DESIGNS[name], t_end=t_end)
    act = design.actuator or load_scene(design.scene).mechanism.actuator_names[0]
    t0 = time.perf_counter()
    ref = monolithic(design, t_end)
    seconds = time.perf_counter() - t0
    return Case(name, cylinder_servo_system(design, fmu_dir, name=name), f"mechanism.{act}_length", "m", t_end,
                ref["length"], seconds)


SYSTEMS: dict[str, Callable[[Path, float], Case]] = {
    "servo": lambda d, t: servo_case(d, t, quantised=True),
    "servo_exact": lambda d, t: servo_case(d, t, quantised=False),
    "luffing_boom": lambda d, t: cylinder_case(d, "luffing_boom", t),
    "cylinder_slider_crank": lambda d, t: cylinder_case(d, "cylinder_slider_crank", t),
}
T_END = {"servo": 2.0, "servo_exact": 2.0, "luffing_boom": 4.0, "cylinder_slider_crank": 3.0}
FMUS = ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory", "HydraulicCylinder"]


# -- the masters: (case, step, folder) -> (t, values of case.signal, wall seconds of the run alone) --------
def grubler_master(master: str, tol: float | None = None):
    """grubler cosim with ``master`` (and, given ``tol``, its error-controlled sub-steps: ``--tol``)."""
    def run(case: Case, h: float, tmp: Path):
        r = cosim.run(case.system, t_end=case.t_end, step=h, master=master, record=[case.signal],
                      unpacked=case.unpacked, tol=tol)
        return r.t, r[case.signal], r.wall_time, (r.diverged.message if r.diverged else "")
    return run


def fmpy_ssp(case: Case, h: float, tmp: Path):
    """fmpy's own SSP master (Jacobi), given the system's parameters: it ignores the SSD's, and sets no Strings."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet

    archive = tmp / f"{case.name}.ssp"
    if not archive.exists():
        case.system.write(archive)
    pset = ParameterSet()
    pset.parameters = [Parameter(name=f"{c}.{p}", type="Real", value=v)
                       for c, comp in case.system.components.items() for p, v in comp.parameters.items()
                       if not isinstance(v, str)]
    t0 = time.perf_counter()
    res = simulate_ssp(str(archive), stop_time=case.t_end, step_size=h, parameter_set=pset)
    wall = time.perf_counter() - t0
    return res["time"] + h, res[case.signal], wall  # fmpy stamps each step's end values with its start


def container(case: Case, h: float, tmp: Path):
    """The system as one FMU (``grubler export``: fmpy's container, fixed step h), run by fmpy.simulate_fmu."""
    from fmpy import simulate_fmu

    from grubler.system.container import export_system

    fmu = tmp / f"{case.name}_{h:g}.fmu"
    if not fmu.exists():
        export_system(dataclasses.replace(case.system, step=h), fmu)
    t0 = time.perf_counter()
    res = simulate_fmu(str(fmu), stop_time=case.t_end, step_size=h, output_interval=h, output=[case.signal])
    wall = time.perf_counter() - t0
    return res["time"], res[case.signal], wall


def libcosim(case: Case, h: float, tmp: Path):
    """OSP's libcosim from the .ssd alone (the step in its OSP annotation), a last-value observer on the signal."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    ssd = tmp / f"{case.name}_{h:g}.ssd"
    if not ssd.exists():
        dataclasses.replace(case.system, step=h).write(ssd)
    ns = round(h * 1e9)
    n = int(round(case.t_end / h))
    component, variable = case.signal.split(".", 1)
    t0 = time.perf_counter()
    ex = CosimExecution.from_ssp_file(ssp_path=str(ssd))
    index = ex.slave_index_from_instance_name(component)
    vr = {v.name.decode(): v.reference for v in ex.slave_variables(slave_index=index)}[variable]
    obs = CosimObserver.create_last_value()
    ex.add_observer(observer=obs)
    t, y = np.empty(n), np.empty(n)
    for k in range(n):
        if not ex.step(step_count=1):
            raise RuntimeError(f"libcosim: step failed at t = {k * ns / 1e9:.6g} s")
        t[k] = ex.status().current_time / 1e9
        y[k] = obs.last_real_values(slave_index=index, variable_references=[vr])[0]
    return t, y, time.perf_counter() - t0


MASTERS: dict[str, Callable] = {
    "grubler, Gauss-Seidel": grubler_master(cosim.GAUSS_SEIDEL),
    "grubler, Jacobi": grubler_master(cosim.JACOBI),
    "grubler, extrapolate": grubler_master(cosim.EXTRAPOLATE),
    "grubler, --tol 1e-6": grubler_master(cosim.EXTRAPOLATE, tol=1e-6),
    "grubler, newton": grubler_master(cosim.NEWTON),
    "fmpy.ssp.simulate_ssp": fmpy_ssp,
    "one FMU (fmpy container) in fmpy": container,
    "libcosim (libcosimpy)": libcosim,
}


# -- measuring --------------------------------------------------------------------------------------------
def error(case: Case, t: np.ndarray, values: np.ndarray) -> float:
    """Largest |values - reference| at the reference's sample instants that t hits (inf if a value is not finite)."""
    t, values = np.asarray(t, float), np.asarray(values, float)
    k = np.round(t / SAMPLE)
    on = (np.abs(t / SAMPLE - k) < 1e-6) & (k <= len(case.reference) - 1) & (k >= 0)
    if not np.any(on):
        raise ValueError(f"{case.name}: no recorded instant on the reference's {SAMPLE:g} s grid")
    diff = np.abs(values[on] - case.reference[k[on].astype(int)])
    return float(np.max(diff)) if np.all(np.isfinite(diff)) else float("inf")


@dataclasses.dataclass
class Point:
    system: str
    master: str
    step: float
    error: float = float("nan")
    walls: list = dataclasses.field(default_factory=list)
    failure: str = ""
    diverged: str = ""  # the master said so (grubler's coupling_energy), the run finished

    @property
    def wall(self) -> float:
        return statistics.median(self.walls) if self.walls else float("nan")


def measure(case: Case, master: str, h: float, tmp: Path, point: Point | None = None) -> Point:
    """One run of ``master`` on ``case`` at step ``h``, added to ``point`` (a new one if None)."""
    point = point or Point(case.name, master, h)
    if point.failure:
        return point
    try:
        t, y, wall, *said = MASTERS[master](case, h, tmp)
    except Exception as exc:  # noqa: BLE001 - a master that cannot run a case is a result too
        point.failure = " ".join(str(exc).split())[:160] or type(exc).__name__
        return point
    if not point.walls:
        point.error = error(case, t, y)
        point.diverged = said[0] if said else ""
    point.walls.append(wall)
    return point


def build(fmu_dir: Path) -> None:
    import build_fmu

    build_fmu.build(fmu_dir, FMUS)


def sweep(cases: list[Case], masters: list[str], steps, rounds: int, tmp: Path, log=print) -> list[Point]:
    """Every master on every case at every step, ``rounds`` times, the masters' order rotated each round."""
    points = {(c.name, m, h): Point(c.name, m, h) for c in cases for m in masters for h in steps}
    for r in range(rounds):
        order = masters[r % len(masters):] + masters[:r % len(masters)]
        for c in cases:
            for h in steps:
                for m in order:
                    p = measure(c, m, h, tmp, points[c.name, m, h])
                    log(f"round {r + 1} {c.name} {h:g} s {m}: "
                        + (f"failed: {p.failure}" if p.failure else f"{p.walls[-1]:.3f} s, error {p.error:.3e}"))
    return list(points.values())


# -- equal error: each master's wall time for an error, read off its work-precision curve -------------------
# the errors each system is compared at (its signal's unit)
TARGETS = {"servo": (1e-3, 3e-4), "servo_exact": (1e-4, 1e-5, 1e-6), "luffing_boom": (1e-5, 1e-6, 1e-7),
           "cylinder_slider_crank": (1e-5, 1e-6, 1e-7)}
PEERS = ("fmpy.ssp.simulate_ssp", "one FMU (fmpy container) in fmpy", "libcosim (libcosimpy)")


def time_to_reach(points: list[Point], system: str, master: str, target: float) -> tuple[float, str]:
    """The wall time ``master`` takes on ``system`` to an error of ``target``, and how it was read.

    The coarsest step whose run is within ``target`` is the one a user would take; its time is interpolated
    (log wall time linear in log error) towards the next coarser run, which misses it.  When the coarsest
    run is within it, or the coarser run took longer (a run far off, a diverging one), its time is an upper
    bound ('at most').  When no run is, the time is extrapolated along the line through the two finest runs
    ('extrapolated'), if their error still falls (by 1.5x or more) and the finer took longer: otherwise
    (a master whose error has stopped falling, Jacobi's on the servo) it is nan, 'not reached'.
    A run that failed or said it diverged is left out.

    Examples
    --------
    >>> pts = [Point("s", "m", h, e, [w]) for h, e, w in ((4e-3, 1e-3, 1.0), (2e-3, 1e-4, 2.0), (1e-3, 1e-5, 4.0))]
    >>> [(round(w, 9), how) for w, how in (time_to_reach(pts, "s", "m", e) for e in (1e-4, 1e-6))]
    [(2.0, 'interpolated'), (8.0, 'extrapolated from the two finest runs')]
    """
    pts = sorted(((p.step, p.error, p.wall) for p in points if p.system == system and p.master == master
                  and not p.failure and not p.diverged and np.isfinite(p.error) and p.error > 0), reverse=True)
    within = [k for k, (_, e, _) in enumerate(pts) if e <= target]
    if not within:
        if len(pts) >= 2 and pts[-2][1] >= 1.5 * pts[-1][1] and pts[-1][2] > pts[-2][2]:
            (_, e0, w0), (_, e1, w1) = pts[-2:]
            x = (np.log(target) - np.log(e0)) / (np.log(e1) - np.log(e0))
            return float(np.exp(np.log(w0) + x * (np.log(w1) - np.log(w0)))), "extrapolated from the two finest runs"
        return float("nan"), "not reached" + (f" (best {min(e for _, e, _ in pts):.2g} at the steps run)" if pts else "")
    k = within[0]
    h, e, w = pts[k]
    if k == 0:
        return w, f"at most (the coarsest run, {h * 1e3:g} ms, is within it)"
    _, e0, w0 = pts[k - 1]
    if w0 >= w:
        return w, f"at most (the {h * 1e3:g} ms run; the coarser one took longer)"
    x = (np.log(target) - np.log(e0)) / (np.log(e) - np.log(e0))
    return float(np.exp(np.log(w0) + x * (np.log(w) - np.log(w0)))), "interpolated"


def equal_error(cases: list[Case], points: list[Point], master: str = "grubler, newton") -> str:
    """A table: at each system's target errors, every master's time, and ``master``'s speed-up on each."""
    masters = list(dict.fromkeys(p.master for p in points))
    lines = [f"| system | error | master | wall time to reach it | {master}'s speed-up |", "|---|---|---|---|---|"]
    for c in cases:
        for target in TARGETS.get(c.name, ()):
            ours = time_to_reach(points, c.name, master, target)[0]
            for m in (m for m in masters if any(p.system == c.name and p.master == m for p in points)):
                w, how = time_to_reach(points, c.name, m, target)
                speed = f"{w / ours:.3g}x" if np.isfinite(w) and np.isfinite(ours) and m != master else ""
                shown = f"{w:.3g} s ({how})" if np.isfinite(w) else how
                lines.append(f"| {c.name} | {target:g} {c.unit} | {m} | {shown} | {speed} |")
    return "\n".join(lines)


def read_table(text: str) -> list[Point]:
    """The points of a work-precision table as :func:`table` writes it (docs/cosim.md's), to report again.

    Examples
    --------
    >>> p, q = read_table("| servo | 1 ms | grubler, newton | 0.110 s | 7.75e-05 rad |\\n"
    ...                   "| servo | 10 ms | libcosim (libcosimpy) | — | failed: step failed |")
    >>> (p.system, p.step, p.master, p.wall, p.error), q.failure
    (('servo', 0.001, 'grubler, newton', 0.11, 7.75e-05), 'step failed')
    """
    points = []
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 5 or not cells[1].endswith(" ms"):
            continue
        try:
            step = float(cells[1][:-3]) * 1e-3
        except ValueError:
            continue
        p = Point(cells[0], cells[2], step)
        if cells[4].startswith("failed: "):
            p.failure = cells[4][len("failed: "):]
        else:
            p.walls = [float(cells[3].split()[0])]
            p.error = float(cells[4].split()[0])
            if "(said: " in cells[4]:
                p.diverged = cells[4].split("(said: ", 1)[1].rstrip(")")
        points.append(p)
    return points


# -- reporting --------------------------------------------------------------------------------------------
def table(cases: list[Case], points: list[Point]) -> str:
    unit = {c.name: c.unit for c in cases}
    lines = ["| system | step | master | wall time (median) | max error |", "|---|---|---|---|---|"]
    for p in points:
        if p.failure:
            lines.append(f"| {p.system} | {p.step * 1e3:g} ms | {p.master} | — | failed: {p.failure} |")
        else:
            said = f" (said: {p.diverged[:90]})" if p.diverged else ""
            lines.append(f"| {p.system} | {p.step * 1e3:g} ms | {p.master} | {p.wall:.3f} s | "
                         f"{p.error:.2e} {unit[p.system]}{said} |")
    return "\n".join(lines)


def observed_orders(cases: list[Case], points: list[Point], master: str = "grubler, Gauss-Seidel",
                    longest: float = 1e-3) -> dict:
    """The slope of log(error) on log(step) of ``master``'s runs at steps up to ``longest``, by system."""
    out = {}
    for c in cases:
        pts = [(p.step, p.error) for p in points if p.system == c.name and p.master == master
               and p.step <= longest * (1 + 1e-9) and not p.failure and not p.diverged
               and np.isfinite(p.error) and p.error > 0]
        if len(pts) >= 2:
            h, e = np.log(np.array(pts)).T
            out[c.name] = float(np.polyfit(h, e, 1)[0])
    return out


def figure(cases: list[Case], points: list[Point], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(cases)
    cols = min(n, 2)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(6.2 * cols, 4.4 * rows), squeeze=False)
    masters = list(dict.fromkeys(p.master for p in points))
    style = {m: (f"C{i}", "osd^v<>"[i % 7]) for i, m in enumerate(masters)}
    for ax, c in zip(axes.flat, cases):
        for m in masters:
            pts = sorted((p for p in points if p.system == c.name and p.master == m and not p.failure
                          and np.isfinite(p.error)), key=lambda p: p.step)
            if not pts:
                continue
            color, marker = style[m]
            ax.loglog([p.wall for p in pts], [p.error for p in pts], marker=marker, color=color, label=m)
            said = [p for p in pts if p.diverged]
            if said:
                ax.loglog([p.wall for p in said], [p.error for p in said], "x", color="k", markersize=11,
                          label="the run said: diverged" if ax.get_legend_handles_labels()[1].count(
                              "the run said: diverged") == 0 else None)
            for p in pts:
                ax.annotate(f"{p.step * 1e3:g}", (p.wall, p.error), textcoords="offset points", xytext=(4, 3),
                            fontsize=7, color=color)
        ax.set_title(f"{c.name} ({c.t_end:g} s): {c.signal}")
        ax.set_xlabel("wall time, median [s]")
        ax.set_ylabel(f"max error vs monolithic [{c.unit}]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    fig.suptitle("Co-simulation work-precision (labels: communication step, ms; a run that failed is left out)",
                 fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def report(cases: list[Case], points: list[Point], rounds: int, command: str, png: Path | None) -> str:
    orders = observed_orders(cases, points)
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")), "?")
    refs = ", ".join(f"{c.name} {c.reference_seconds:.1f} s" for c in cases)
    return "\n".join([
        f"Error: the largest difference from the monolithic reference over its 1 ms samples; wall time: the "
        f"median of {rounds} rounds, the masters alternating. The references took {refs}.",
        "",
        table(cases, points),
        "",
        "Observed order of grubler's Gauss-Seidel (slope of log error on log step, steps of 1 ms and less): "
        + ", ".join(f"{k} {v:.2f}" for k, v in orders.items()) + ".",
        "",
        *(["At equal error: each master's wall time to an error, read off its curve above (`time_to_reach`: "
           "the coarsest step within the error, its time interpolated towards the next coarser run's).", "",
           equal_error(cases, points), ""] if any(p.master == "grubler, newton" for p in points) else []),
        *([f"![work-precision of the masters]({png})", ""] if png else []),
        f"Machine: {os.cpu_count()} cores ({cpu}), load average {os.getloadavg()[0]:.1f}, Python "
        f"{platform.python_version()}. Command: `{command}`.",
    ])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--systems", nargs="+", default=list(SYSTEMS), choices=list(SYSTEMS))
    ap.add_argument("--masters", nargs="+", default=list(MASTERS), choices=list(MASTERS))
    ap.add_argument("--steps", nargs="+", type=float, default=list(STEPS))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--t-end", type=float, help="seconds of every system (default: its own, T_END)")
    ap.add_argument("--fmus", type=Path, help="folder of built FMUs to use (default: built into a temporary one)")
    ap.add_argument("--out", type=Path, help="markdown file whose '<!-- work-precision -->' section is replaced")
    ap.add_argument("--png", type=Path, help="the figure (default: next to --out, else none)")
    ap.add_argument("--from", dest="table", type=Path, metavar="MD",
                    help="run nothing: from the work-precision table in MD (rows of several runs merged), print "
                         "the equal-error table and, with --png, draw the figure")
    args = ap.parse_args(argv)
    if args.table:
        points = read_table(args.table.read_text())
        names = list(dict.fromkeys(p.system for p in points))
        signal = {n: ("mechanism.drive_angle", "rad") if n.startswith("servo") else ("the actuator's length", "m")
                  for n in names}
        cases = [Case(n, None, signal[n][0], signal[n][1], T_END.get(n, 0.0), np.empty(0)) for n in names]
        if args.png:
            figure(cases, points, args.png)
        print(equal_error(cases, points))
        return
    command = "python benchmarks/cosim_wp.py " + " ".join(a for a in (argv or sys.argv[1:]))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        fmu_dir = args.fmus or tmp / "dist"
        if args.fmus is None:
            build(fmu_dir)
        cases = []
        for name in args.systems:
            case = SYSTEMS[name](fmu_dir, args.t_end or T_END[name])
            print(f"{name}: reference in {case.reference_seconds:.1f} s", flush=True)
            case.unpacked = cosim.UnpackedFMUs()
            cases.append(case)
        points = sweep(cases, args.masters, args.steps, args.rounds, tmp)
        for c in cases:
            c.unpacked.close()
    png = args.png
    if png is None and args.out is not None:
        png = args.out.parent / "images" / "cosim_wp.png"
    if png is not None:
        figure(cases, points, png)
    rel = os.path.relpath(png, args.out.parent) if (png and args.out) else png
    text = report(cases, points, args.rounds, command.strip(), rel)
    print(text, flush=True)
    if args.out:
        mark = "<!-- work-precision -->"
        old = args.out.read_text() if args.out.exists() else ""
        head, _, rest = old.partition(mark)
        tail = rest.split("<!-- /work-precision -->", 1)[1] if "<!-- /work-precision -->" in rest else ""
        args.out.write_text(head + mark + "\n\n" + text + "\n\n<!-- /work-precision -->" + tail)
    sys.stdout.flush()
    os._exit(0)  # FMUs and libcosim's threads ran in this process: skip the teardown


if __name__ == "__main__":
    main()
