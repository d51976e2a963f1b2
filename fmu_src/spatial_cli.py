"""``grubler simulate`` and ``grubler animate`` on a spatial scene (``dimension = 3``, or a spatial preset).

:mod:`grubler.cli` hands a spatial source here; the options the spatial kernel
has no use for (a penalty closure, the implicit integrators, actuators, a planar
trace) are refused naming the option rather than ignored.
"""

from __future__ import annotations

import csv

import numpy as np

from grubler.errors import InputError
from grubler.limits import check_size, open_output
from grubler.mechanism.spatial import REACTION_NAMES
from grubler.mechanism.spatial_scene import load_spatial_scene
from grubler.records import column_heading

__all__ = ["simulate_spatial", "animate_spatial", "info_spatial", "run_table"]

_INTEGRATORS = ("dop853", "rk45")


def _refuse(args, options: dict) -> None:
    """Options the spatial run cannot honour: each refused by its name."""
    for attr, (option, why) in options.items():
        value = getattr(args, attr, None)
        if value not in (None, False, []):
            raise InputError(option, f"{why} (a spatial scene)")


def _unit(name: str, rate: bool = False) -> str:
    """A spatial coordinate's unit: a link's theta in rad, its d in m."""
    base = "rad" if name.endswith(".theta") else "m"
    return f"{base}/s" if rate else base


def run_table(res, reactions: bool = False) -> tuple[list[str], list[str], np.ndarray]:
    """A spatial run as columns: names, units, and the rows (T x columns).

    t; each coordinate and its rate (``crank.theta``, ``crank.theta_d``); KE, PE, E;
    the closure error; with ``reactions``, each closure's force and moment on its
    closing link in the closure's frame (``closure0.Fx`` ...) and each joint's, of
    the parent on the link in the link's axes (``crank.Fx`` ...).
    """
    m = res.mechanism
    names = ["t"] + list(m.coordinate_names) + [f"{n}_d" for n in m.coordinate_names] + \
        ["KE", "PE", "E", "closure_error"]
    units = ["s"] + [_unit(n) for n in m.coordinate_names] + [_unit(n, True) for n in m.coordinate_names] + \
        ["J", "J", "J", "m"]
    energy = res.energy()
    cols = [res.t[:, None], res.y, energy, energy.sum(axis=1)[:, None], res.closure_error()[:, None]]
    if reactions:
        force = ["N"] * 3 + ["N m"] * 3
        for c in range(len(m.closures)):
            names += [f"closure{c}.{r}" for r in REACTION_NAMES]
            units += force
        for link in m.links:
            names += [f"{link.name}.{r}" for r in REACTION_NAMES]
            units += force
        both = [m.reactions(y, res.tau) for y in res.y]
        cols += [np.array([np.concatenate([cl.ravel(), jt.ravel()]) for cl, jt in both])]
    return names, units, np.hstack(cols)


def simulate_spatial(args) -> int:
    _refuse(args, {"method": ("--method", "the spatial kernel closes its loops exactly, with no penalty method"),
                   "step": ("--step", "the spatial advance has no fixed-step integrator"),
                   "actuator_force": ("--actuator-force", "actuators are a planar scene's")})
    if args.integrator is not None and args.integrator not in _INTEGRATORS:
        raise InputError("--integrator", f"the spatial advance has {' and '.join(_INTEGRATORS)}, got "
                                         f"{args.integrator!r} (a spatial scene)")
    if args.reactions and not args.csv:
        raise InputError("--reactions", "adds the closures' and joints' reaction columns to the CSV: give --csv FILE")
    scene = load_spatial_scene(args.scene)
    m = scene.mechanism
    t_end = args.t_end or scene.t_end
    dt_out = args.dt_out or min(scene.dt_out, t_end)
    if dt_out > t_end:
        raise InputError("--dt-out", f"{dt_out:g} s is longer than the run ({t_end:g} s)")
    # the rows are held (state, and the table's columns) before they are written: refused past the budget
    columns = 2 * m.n_coords + 5 + (6 * (len(m.closures) + len(m.links)) if args.reactions else 0)
    check_size(t_end / dt_out + 1, 8 * (2 * m.n_coords + columns), "the run's rows", "--t-end or --dt-out")
    res = m.simulate(scene.start(), t_end, dt_out, tau=scene.tau(args.torque), rtol=args.rtol,
                     atol=args.atol or args.rtol, tableau=args.integrator or "dop853")
    names, units, rows = run_table(res, args.reactions)
    if args.csv:
        with open_output(args.csv, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([column_heading(n, u) for n, u in zip(names, units)])
            for row in rows:
                w.writerow([repr(float(x)) for x in row])
    if args.plot:
        _plot(res, names, rows, args.plot)
    e = rows[:, names.index("E")]
    print(f"{scene.name or 'spatial scene'}: {len(res.t)} points to t = {res.t[-1]:g} s, spatial kernel "
          f"{args.integrator or 'dop853'}, {res.steps} steps")
    print(f"max closure error {rows[:, names.index('closure_error')].max():.3g}; "
          f"energy {e[0]:.9g} J -> {e[-1]:.9g} J")
    if not args.csv and not args.plot:
        shown = ["t"] + list(m.coordinate_names)
        print("  ".join(f"{c:>14}" for c in shown))
        for i in np.linspace(0, len(res.t) - 1, min(len(res.t), 11)).astype(int):
            print("  ".join(f"{rows[i, names.index(c)]:14.6g}" for c in shown))
    return 0


def info_spatial(args) -> int:
    """Coordinates, closures, freedoms and the assembled start of a spatial scene, and which reactions the
    motion determines there (:meth:`~grubler.mechanism.spatial.SpatialMechanism.determinacy_report`)."""
    if args.at:
        raise InputError("--at", "sets a planar scene's drive angle; a spatial scene starts from its [initial] "
                                 "sketch (a spatial scene)")
    scene = load_spatial_scene(args.scene)
    m = scene.mechanism
    y0 = scene.start()
    z0 = y0[:m.n_coords]
    rank = m.determinacy(z0)[1] if m.n_rows else 0
    kinds = ", ".join(f"{c.kind} ({m.links[c.link].name} on {'ground' if c.to < 0 else m.links[c.to].name})"
                      for c in m.closures) or "none (an open tree)"
    print(f"{scene.name or 'spatial scene'}: {scene.description}".rstrip(": "))
    print(f"spatial chain of {len(m.links)} links, {m.n_coords} coordinates; closures: {kinds}")
    free = m.n_coords - rank
    print(f"closure rows {m.n_rows}, of rank {rank} here: {free} degree{'s' if free != 1 else ''} of freedom")
    z0 = np.where(np.abs(z0) < 1e-12, 0.0, z0)  # an assembly's rounding is not a position
    print("assembled start: " + ", ".join(
        f"{n} = {np.degrees(v) + 0.0:.6g} deg" if n.endswith(".theta") else f"{n} = {v + 0.0:.6g} m"
        for n, v in zip(m.coordinate_names, z0)))
    if m.n_rows:
        print("\n".join(m.determinacy_report(z0)))
    return 0


def _plot(res, names, rows, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = res.mechanism
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    t = rows[:, 0]
    for n in m.coordinate_names:
        axes[0].plot(t, rows[:, names.index(n)], label=f"{n} [{_unit(n)}]")
    axes[0].legend(fontsize=8, ncol=2)
    axes[0].set_title("joint coordinates")
    for n in ("KE", "PE", "E"):
        axes[1].plot(t, rows[:, names.index(n)], label=n)
    axes[1].set_ylabel("J")
    axes[1].legend(fontsize=8)
    err = rows[:, names.index("closure_error")]
    if np.any(err > 0):
        axes[2].semilogy(t, np.where(err > 0, err, np.nan))
    axes[2].set_ylabel("closure error [m]")
    axes[2].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def animate_spatial(args, source: str, camera_text: str | None) -> int:
    from grubler.views.animation import check_frames, frame_rows
    from grubler.views.perspective import SpatialSketch, parse_camera
    from grubler.views.spatial_film import FRAME_SIZE, film_camera, spatial_film

    _refuse(args, {"scene": ("--scene", "a spatial film is drawn from its scene, not from a CSV"),
                   "trace": ("--trace", "a trace is a planar film's"),
                   "signals": ("--signals", "signal strips are a planar film's")})
    view = parse_camera(camera_text) if camera_text else None  # before any work
    scene = load_spatial_scene(source)
    t_end = args.t_end or scene.t_end
    check_frames(t_end, args.fps, args.speed, 0, FRAME_SIZE)
    dt = min(0.01, args.speed / args.fps, t_end)
    res = scene.mechanism.simulate(scene.start(), t_end, dt, tau=scene.tau(args.torque))
    rows = frame_rows(res.t, args.fps, args.speed)
    sketch = SpatialSketch(scene.mechanism, res.z)
    frames = sketch.positions(res.y[rows])
    camera = film_camera(sketch, frames, view, FRAME_SIZE)
    out = args.out or f"{scene.name or 'mechanism'}.gif"
    n = spatial_film(sketch, res.t[rows], frames, out, fps=args.fps, camera=camera,
                     title=f"{scene.name}: {scene.description}".strip(": "))
    what = "a still of t = 0" if out.endswith(".png") else f"{n} frames, {res.t[-1]:g} s of motion"
    print(f"wrote {out}: {what}")
    return 0
