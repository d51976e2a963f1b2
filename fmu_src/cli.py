"""Command line: ``grubler presets | motors | info | simulate | animate | report | sweep | size | cosim | export |
export-law | linearize | app``.

A bad scene or option exits with status 2 and one line naming the field and the
reason; ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import signal
import sys
from typing import Sequence

import numpy as np

from grubler.mechanism.analysis import classify
from grubler.mechanism.assembly import assemble
from grubler import limits
from grubler.errors import AssemblyError, GrublerError, InputError, SceneErrors
from grubler.limits import number
from grubler.views.runs import coordinates, read_run_csv
from grubler.studies.linearize import input_unit
from grubler.views.bode import BODE_SUFFIXES
from grubler.mechanism.scene import coordinate_text, load_scene, preset_names
from grubler.mechanism.simulate import output_columns, simulate
from grubler.motors.motor_data import AMBIENT_RANGE
from grubler.studies.cylinder_sizing import CANDIDATE_DEFAULTS


def _number(name: str, **bounds):
    """An argparse type: a number through :func:`grubler.limits.number` with ``bounds``."""
    def parse(text: str) -> float:
        try:
            return number(text, name, **bounds)
        except InputError as exc:
            raise argparse.ArgumentTypeError(exc.reason) from None
    return parse


def _positive(name: str, unit: str = ""):
    return _number(name, low=0.0, low_open=True, unit=unit)


def _finite(name: str):
    return _number(name)


def _actuator_force(text: str) -> tuple[str, float]:
    """--actuator-force NAME=N: an actuator's name and its constant force."""
    name, eq, value = text.partition("=")
    if not eq or not name.strip():
        raise argparse.ArgumentTypeError(f"must be NAME=N (an actuator's name and its force in N), got {text!r}")
    try:
        return name.strip(), limits.number(value, "--actuator-force", unit="N")
    except InputError as exc:
        raise argparse.ArgumentTypeError(exc.reason) from None


def _output(name: str, kinds: tuple[str, ...] | str | None = None):
    """An argparse type for a file to write: checked before any work (folder, extension).

    Each path is noted with its option, so that a write that still fails (a
    file of /proc, a full disk) is told as that option's: :func:`_file_error`.
    """
    def parse(text: str) -> str:
        try:
            limits.output_file(text, name, kinds)
        except InputError as exc:
            raise argparse.ArgumentTypeError(exc.reason) from None
        _OUTPUTS[os.path.abspath(text)] = name
        return text
    return parse


def _file_error(exc: OSError) -> InputError:
    """An OSError about a file, as a refusal naming the option that gave the file (if one did) and the path."""
    path = os.fsdecode(exc.filename)
    option = _OUTPUTS.get(os.path.abspath(path))
    where = limits.brief(path, limits.PATH_CHARS)
    why = exc.strerror or type(exc).__name__
    if option:
        return InputError(option, f"{where}: cannot be written ({why})")
    return InputError("file", f"{where}: {why}")


def _warn(warnings) -> None:
    """What makes a result less than was asked: one ``warning:`` line each on stderr (the exit status stays)."""
    for line in warnings:
        print(f"warning: {line}", file=sys.stderr)


def cmd_presets(args) -> int:
    width = max(len(n) for n in preset_names())
    for name in preset_names():
        scene = load_scene(name)
        c = classify(scene.mechanism)
        print(f"{name:<{width}}  {c.chain:<10} {c.name}")
    from grubler.mechanism.spatial_scene import load_spatial_scene, spatial_preset_names

    for name in spatial_preset_names():
        print(f"{name:<{width}}  {'spatial':<10} {load_spatial_scene(name).description}")
    return 0


def cmd_motors(args) -> int:
    from grubler.motors import motor_listing

    print("\n".join(motor_listing(args.names or None)))
    return 0


def cmd_info(args) -> int:
    from grubler.mechanism.spatial_scene import is_spatial

    if is_spatial(args.scene):
        from grubler.spatial_cli import info_spatial

        return info_spatial(args)
    scene = load_scene(args.scene)
    m = scene.mechanism
    c = classify(m)
    at = _at_drive_angle(m, args.at)
    try:
        assemble(at, at.z_from_q(at.q_ref), scene.initial_rates)
    except AssemblyError:
        # a loop that closes nowhere at this angle: its class would only mislead, the reason comes
        # alone; one that closes on another branch than its sketch's gets the branches listed below
        from grubler.mechanism.assembly import branches

        if not (at.closures and at.drive and branches(at, at.z_from_q(at.q_ref))[0]):
            raise
    print(f"scene      {scene.name}")
    if m.description:
        print(f"           {m.description}")
    print(f"type       {c.name} ({c.chain} chain)")
    if c.chain in ("Watt", "Stephenson"):
        from grubler.mechanism.analysis import SIX_BAR_INVERSIONS

        print(f"           {SIX_BAR_INVERSIONS[c.name.removesuffix(' six-bar')]}")
    print(f"mobility   {c.mobility} (Grübler/Kutzbach: 3(n-1) - 2 j with n = {m.n_links + 1}, "
          f"j = {m.n_links + len(m.closures)})")
    if m.closures:
        from grubler.mechanism.assembly import freedom

        free = freedom(m, m.z_from_q(m.q_ref))
        if free > c.mobility:
            print(f"           {free} by the closures' rank at the start: {free - c.mobility} of their "
                  f"{m.n_constraints} equations {'is' if free - c.mobility == 1 else 'are'} redundant "
                  f"(a linkage overconstrained by its design moves all the same)")
    if len(m.closures) > 1:
        from grubler.mechanism.analysis import joint_counts

        ternary = [f"link{b}" + (" (ground)" if b == 1 else "") for b, d in joint_counts(m).items() if d >= 3]
        print(f"topology   {m.n_links + 1} links, {m.n_links + len(m.closures)} joints; ternary: "
              f"{', '.join(ternary) or 'none'}; loops closed by "
              + ", ".join(f"closure[{j}] (link{c.link} to link{c.to_link})" for j, c in enumerate(m.closures)))
    if m.is_tree:  # the chain branches: say which link hangs from which
        hangs = ", ".join(f"link{k + 2} on {'the ground' if pk == 1 else f'link{pk}'}"
                          for k, pk in enumerate(m.parents) if pk != k + 1)
        print(f"chain      a tree (a link hangs from another than the previous link): {hangs}")
    joints = ", ".join(f"link{k + 2}: {'R' if l.joint == 'R' else 'P'}" for k, l in enumerate(m.links))
    print(f"joints     {joints}; real coordinates {', '.join(m.free_names)}")
    if c.grashof:
        g = c.grashof
        lengths = ", ".join(f"{n} {v:.6g} m" for n, v in zip(("ground", "crank", "coupler", "rocker"),
                                                            c.fourbar_lengths))
        print(f"grashof    {g.kind}: s + l = {g.s_plus_l:.6g} m, p + q = {g.p_plus_q:.6g} m ({g.detail})")
        print(f"lengths    {lengths}")
    if c.slider_crank:  # Grashof's criterion for the slider-crank: crank + |offset| against the coupler
        sc = c.slider_crank
        print(f"grashof    slider-crank {sc.kind}: crank + |offset| = {sc.crank + sc.offset:.6g} m, coupler "
              f"{sc.coupler:.6g} m ({sc.detail})")
        print(f"lengths    crank {sc.crank:.6g} m, coupler {sc.coupler:.6g} m, offset {sc.offset:.6g} m, "
              f"ratio coupler/crank {sc.ratio:.4g}")
    print(f"drive      {m.drive or '-'}" + (f"  torque {scene.torque:g} {input_unit('drive', m)}" if m.drive else ""))
    if m.load:
        print(f"load       {m.load}  torque {scene.load_torque:g} {input_unit('load', m)}")
    m = at
    z0 = m.z_from_q(m.q_ref)
    if m.closures and m.drive:
        _print_branches(m, z0)
    z, zd = assemble(m, z0, scene.initial_rates)
    q = m.q_from_z(z)
    print("assembled  " + ", ".join(f"{n} = {coordinate_text(n, v, 9)}" for n, v in zip(m.coordinate_names, q)))
    moved = [(n, a, b) for n, a, b in zip(m.coordinate_names, m.q_ref, q) if abs(a - b) > 1e-9]
    if moved:
        print("           (closed from the scene's start: "
              + ", ".join(f"{n} {coordinate_text(n, a)} -> {coordinate_text(n, b)}" for n, a, b in moved) + ")")
    return 0


def _at_drive_angle(m, at):
    """The mechanism with its drive coordinate's start set to ``at`` (info's --at), or as it is."""
    if at is None:
        return m
    if not m.drive:
        raise GrublerError("--at: this scene has no drive joint whose angle it could set")
    from grubler.mechanism.scene import parse_at

    name, value = parse_at(at, m.drive)
    if name != m.drive:  # info assembles with the drive held; another coordinate is the assembly's to find
        raise InputError("--at", f"{name} is not the drive joint: info sets the drive's value ({m.drive}=VALUE, "
                                 "or the VALUE alone)")
    q_ref = list(m.q_ref)
    q_ref[m.coordinate_names.index(m.drive)] = value
    return m.replace(q_ref=tuple(q_ref))


def _turn(name: str, value: float) -> float:
    """An angle within [0, 2 pi) (a slide's length as it is): branches are told apart modulo a turn."""
    return value if name.startswith("B") else value % (2 * math.pi)


def _print_branches(m, z0) -> None:
    from grubler.mechanism.assembly import branches

    found, default = branches(m, z0)
    names = [n for n in m.free_names if n != m.drive]
    drive = m.q_from_z(z0)[m.coordinate_names.index(m.drive)]
    print(f"branches   {len(found)} with {m.drive} = {coordinate_text(m.drive, drive)} "
          f"(assembly from the scene's sketch and 256 random ones; angles modulo a turn):")
    for k, z in enumerate(found):
        q = m.q_from_z(z)
        angles = ", ".join(f"{n} {coordinate_text(n, _turn(n, q[m.coordinate_names.index(n)]))}" for n in names)
        note = "  <- the scene's (its sketch closes here; the default)" if k == default else ""
        print(f"  [{k + 1}] {angles}{note}")
    if default < 0:
        print("  (the scene's sketch closes to none of them: its assembly fails, below)")


def cmd_simulate(args) -> int:
    from grubler.mechanism.spatial_scene import is_spatial

    if is_spatial(args.scene):
        from grubler.spatial_cli import simulate_spatial

        return simulate_spatial(args)
    if args.reactions and not args.csv:  # its columns go to the CSV alone: without one it would do nothing
        raise InputError("--reactions", "adds the joints' reaction columns to the CSV: give --csv FILE (the plot and "
                                        "the printed table do not show them)")
    scene = load_scene(args.scene)
    groups = ["state", "dynamics", "energy"] + (["reactions"] if args.reactions else []) + ["actuators", "forces"]
    names = scene.mechanism.actuator_names
    for name, _ in args.actuator_force or []:
        if name not in names:
            raise InputError("--actuator-force", f"no actuator named {name!r}; {scene.name or 'the scene'}'s "
                                                 f"actuators: {', '.join(names) if names else 'none'}")
    res = simulate(scene, t_end=args.t_end, dt_out=args.dt_out, method=args.method, rtol=args.rtol,
                   atol=args.atol if args.atol else args.rtol, integrator=args.integrator, step=args.step,
                   torque=args.torque, actuator_forces=dict(args.actuator_force or []))
    _warn(res.warnings)
    if args.csv:
        res.to_csv(args.csv, groups)
    if args.plot:
        from grubler.views.plotting import coarse_sampling, plot_result

        plot_result(res, args.plot)
        _warn(filter(None, [coarse_sampling(res.t, {n: res[n] for n in res.model.coordinate_names
                                                     if n.startswith("theta")}, "--dt-out")]))
    e = res["E"]
    print(f"{scene.name}: {len(res.t)} points to t = {res.t[-1]:g} s, method {res.method}, "
          f"{res.stats['steps']} steps, {res.stats['rhs_evals']} RHS evaluations")
    print(f"max closure error {np.max(res['closure_error']):.3g}; energy {e[0]:.9g} J -> {e[-1]:.9g} J")
    passages, count = res.stats.get("passages", []), res.stats.get("passage_count", 0)
    if count:
        shown = ", ".join(f"{t:.4f}" for t in passages[:8]) + (", ..." if count > 8 else "")
        print(f"passed {count} change point{'s' if count > 1 else ''} (two assembly branches meet), "
              f"each on the branch it came along, at t = {shown} s")
    if not args.csv and not args.plot:
        cols = output_columns(res.model, ["state"])[: 1 + 2 * res.model.n_links]
        print("  ".join(f"{c:>12}" for c in cols))
        for i in np.linspace(0, len(res.t) - 1, min(len(res.t), 11)).astype(int):
            print("  ".join(f"{res[c][i]:12.6g}" for c in cols))
    return 0


def cmd_animate(args) -> int:
    from grubler.views.animation import MAX_SIGNALS, animate, check_frames, sampling_warnings
    from grubler.views.plotting import kind_words
    from grubler.views.runs import check_fits, read_run, select_signals, signal_names
    from grubler.mechanism.spatial_scene import is_spatial

    if not args.source.endswith(".csv") and is_spatial(args.source):
        from grubler.spatial_cli import animate_spatial

        return animate_spatial(args, args.source, args.camera)
    if args.camera:
        raise InputError("--camera", "sets the perspective view of a spatial scene (dimension = 3); a planar "
                                     "scene is drawn in its plane")
    if args.out and args.out.endswith(".png"):
        raise InputError("--out", f"{limits.brief(args.out)}: a planar film is a GIF or an MP4, use one of .gif, .mp4 "
                                  "(a .png still is a spatial scene's)")
    if args.source.endswith(".csv"):
        if not args.scene:
            raise InputError("--scene", "a CSV holds coordinates only; name the scene it came from "
                                        "(a preset or TOML file) to draw it")
        scene = load_scene(args.scene)
        raw, cols = read_run(args.source, scene.mechanism)
        check_fits(scene.mechanism, cols, args.source)
        t, zs = cols["t"], coordinates(cols, scene.mechanism)
        series = raw
    else:
        scene = load_scene(args.source)
        available = output_columns(scene.mechanism)  # simulate's columns: the elements' too
        n_signals = len(signal_names(args.signals, available, limit=MAX_SIGNALS)) if args.signals else 0
        check_frames(args.t_end or scene.t_end, args.fps, args.speed, n_signals)  # before simulating for them
        res = simulate(scene, t_end=args.t_end, dt_out=min(0.01, args.speed / args.fps), torque=args.torque)
        _warn(res.warnings)
        t, zs = res.t, res.z
        series = {c: res[c] for c in available} if args.signals else {}
    signals = select_signals(args.signals, series, limit=MAX_SIGNALS) if args.signals else None
    out = args.out or f"{scene.name or 'mechanism'}.gif"
    n = animate(scene.mechanism, t, zs, out, fps=args.fps, speed=args.speed, trace=args.trace,
                title=f"{scene.name}: {kind_words(scene.mechanism)}".strip(": "), signals=signals)
    _warn(sampling_warnings(scene.mechanism, t, zs, args.fps, args.speed))
    print(f"wrote {out}: {n} frames, {t[-1] - t[0]:g} s of motion")
    return 0


def cmd_report(args) -> int:
    from grubler.mechanism.simulate import unforced_warning
    from grubler.views.report import unforced_actuators, write_report
    from grubler.views.runs import check_fits, mechanism_prefix, read_run

    model = load_scene(args.scene).mechanism if args.scene else None
    raw, columns = read_run(args.csv, model)
    if model is not None:
        check_fits(model, columns, args.csv)
    _warn(unforced_warning(name, f"{name}_force") for name in unforced_actuators(columns, model))
    system = None
    if args.system:
        from grubler.system.ssp import read

        try:
            system = read(args.system)
        except GrublerError as exc:  # the reader names the file; the option names the field
            raise InputError("--system", str(exc)) from None
    outs = write_report(columns, args.out or ["report.png"], model, source=args.csv,
                        cosim=mechanism_prefix(list(raw)) is not None, system=system)
    print(f"wrote {', '.join(outs)}")
    from grubler.views.plotting import coarse_sampling

    # the record's grid is the run's: its --dt-out is what would refine it
    _warn(filter(None, [coarse_sampling(columns["t"], {c: v for c, v in columns.items()
                                                       if re.fullmatch(r"theta\d+", c)}, "--dt-out")]))
    return 0


def cmd_app(args) -> int:
    from grubler.app.server import serve

    serve(args.scene, host=args.host, port=int(args.port), open_browser=not args.no_browser)
    return 0


def cmd_export(args) -> int:
    if args.scene.lower().endswith((".ssd", ".ssp")):  # a system: one FMU of its FMUs
        from grubler.system.container import execution_tools, export_system
        from grubler.system.native import coupling_settings, export_native_system, why_not_native
        from grubler.system.ssp import read
        from grubler.fmi.build import platforms_note, select_targets

        system = read(args.scene)
        why = "--container asks for it" if args.container else why_not_native(system)
        if why is None:  # every FMU native: their models and the master compiled into one binary
            master, tol = coupling_settings(args.master, args.tol)
            platforms = [t.name for t in select_targets(args.platforms, "--platforms")]
            path = export_native_system(system, args.out, platforms, fmi=args.fmi, field="--out", master=master,
                                        tol=args.tol, sources=not args.binary_only)
            print(f"wrote {path} (one native FMU: its components' models and grubler cosim's master in one binary; "
                  f"master {master}" + (f", tol {tol:g}" if tol else "") + ": its parameters master and tol)")
            if args.platforms is None and platforms_note():
                print(platforms_note())
            return 0
        if args.binary_only:
            raise GrublerError(f"--binary-only: the system cannot be one native FMU ({why}); fmpy's container "
                               "carries its FMUs whole")
        if (args.master or args.tol) and (args.master != "jacobi" or args.tol):
            raise GrublerError(f"--{'tol' if args.tol else 'master'}: fmpy's container steps its FMUs "
                               f"as --master jacobi, without error control ({why})")
        if not args.container:
            print(f"note: {why}, so the system cannot be one native FMU: its FMUs go nested in fmpy's container "
                  "(Jacobi coupling, no FMU state; docs/cosim.md)", file=sys.stderr)
        path = export_system(system, args.out, fmi_version=args.fmi, field="--out")
        print(f"wrote {path} (fmpy's container FMU: its FMUs coupled as `grubler cosim --master jacobi` couples them)")
        tools = execution_tools(system)
        if tools:
            _warn([f"{path.name} needs an execution tool where it runs, as {', '.join(tools)} do (pythonfmu FMUs: "
                   "a Python with their packages installed); fmusim or a C host cannot run it"])
        return 0
    if args.binary_only:
        raise GrublerError("--binary-only: only a system's one native FMU (.ssd, .ssp) is exported without sources/")
    from grubler.fmi.build import export, export_spatial, platforms_note, select_targets
    from grubler.fmi.spatial import fmu_name
    from grubler.mechanism.spatial_scene import is_spatial, load_spatial_scene

    platforms = [t.name for t in select_targets(args.platforms, "--platforms")]
    if is_spatial(args.scene):  # a spatial preset (rssr, spherical-fourbar, ...) or scene file: docs/spatial.md
        scene = load_spatial_scene(args.scene)
        path = export_spatial(scene.mechanism, args.out or f"{fmu_name(scene.name)}.fmu", platforms, "--out", args.fmi,
                              y0=scene.start(), name=scene.name)
    else:
        path = export(args.scene, args.out, platforms, field="--out", fmi=args.fmi)
    print(f"wrote {path}")
    if args.platforms is None and platforms_note():
        print(platforms_note())
    return 0


def cmd_export_law(args) -> int:
    from grubler.controllers.native_fmu import export_law

    path = export_law(args.source, args.out, field="--out")
    print(f"wrote {path}")
    return 0


def cmd_cosim(args) -> int:
    from grubler.system.cosim import run

    record = args.record.split(",") if args.record else None
    step_order = args.order.split(",") if args.order else None
    every = 1
    if args.dt_out:
        from grubler.system.ssp import read

        system = read(args.system)
        h = args.step or system.step or 1e-3
        every = max(1, limits.check_count(round(args.dt_out / h) if math.isfinite(args.dt_out / h) else math.inf,
                                          limits.MAX_STEPS, "communication steps per recorded row", "--dt-out"))
        if args.dt_out < h * (1 - 1e-9):  # a row exists only where the FMUs meet: refused, not cut to the step
            raise InputError("--dt-out", f"{args.dt_out:g} s is shorter than the communication step {h:g} s: rows are "
                                         "recorded at communication points only (give a shorter --step)")
        if abs(every * h - args.dt_out) > 1e-9 * args.dt_out:
            raise InputError("--dt-out", f"{args.dt_out:g} s must be a multiple of the step {h:g} s")
        args.system = system
    res = run(args.system, t_end=args.t_end, step=args.step, master=args.master, record=record,
              step_order=step_order, record_every=every, tol=args.tol)
    steps = len(res.t) - 1
    diverged = res.diverged
    _warn(w for w in res.warnings if diverged is None or w != diverged.message)  # that one is the error below
    how = ("jacobi: all on the last step's values" if res.master == "jacobi"
           else f"{res.master}, order {' -> '.join(res.order)}")
    if "tol" in res.coupling:
        how += (f"; tol {res.coupling['tol']:g}: {res.coupling['substeps']} sub-steps, "
                f"{res.coupling['rejected']} rejected")
    elif "evaluations" in res.coupling:  # the Newton master
        how += (f"; {res.coupling['evaluations'] / max(1, res.coupling['steps']):.2f} evaluations a step, "
                f"{res.coupling['jacobians']} Jacobians")
    print(f"{res.system.name}: {res.t[-1] - res.t[0]:g} s at step {res.step:g} s ({how}): {res.wall_time:.3f} s wall")
    for bond in res.power:  # the power at each mechanical connection, where coupling makes energy
        print(f"power at {bond.line()}")
    if args.csv:
        res.to_csv(args.csv)
        print(f"wrote {args.csv}: {len(res.columns)} signals, {steps + 1} rows")
    if args.plot:
        from grubler.views.plotting import coarse_sampling

        res.plot(args.plot)
        print(f"wrote {args.plot}")
        _warn(filter(None, [coarse_sampling(res.t, {c: res[c] for c in res.columns if res.units.get(c) == "rad"},
                                            "--dt-out")]))
    if diverged is not None:  # the CSV and plot are written, to look at; the status says they are not a result
        from grubler.system.cosim import CosimError

        raise CosimError(diverged.message)
    return 0


def cmd_sweep(args) -> int:
    import functools

    from grubler.mechanism.scene import override, parameter_value
    from grubler.studies.sweep import grid, parse_axis, run_sweep, scene_point, scene_point_units

    axes = {}
    for text in args.set:
        name, values = parse_axis(text)
        if name in axes:  # two --set of one parameter: which one was meant is the user's to say
            raise InputError(f"--set {limits.clip(name)}", "given twice; put every value in one --set")
        axes[name] = values
    scene = load_scene(args.scene)
    override(scene, {k: v[0] for k, v in axes.items()})  # a misspelt parameter fails now, by name
    for name, values in axes.items():  # and so does any value that is not one (an angle for a length)
        for v in values:
            parameter_value(name, v)
    func = functools.partial(scene_point, args.scene, t_end=args.t_end, method=args.method)
    table = run_sweep(func, grid(**axes), out=args.out, workers=args.workers, scheduler=args.scheduler,
                      resume=not args.no_resume, retry_failed=args.retry_failed,
                      units=scene_point_units(scene, list(axes)))
    n = len(table.rows)
    print(f"{n} points ({table.resumed} from the journal, {len(table.failed)} failed) on {table.workers} "
          f"in {table.wall_time:.2f} s" + (f"; wrote {args.out}" if args.out else ""))
    shown = table.inputs + [c for c in ("final_drive_angle", "peak_drive_speed", "peak_closure_force")
                            if c in table.metrics] + ["status"]
    print("  ".join(f"{c[:18]:>18}" for c in shown))
    print("  ".join(f"{f'[{table.units[c]}]' if table.units.get(c) else '':>18}" for c in shown))
    for r in table.rows[:20]:
        print("  ".join(f"{r.get(c):>18.6g}" if isinstance(r.get(c), float) else f"{str(r.get(c))[:18]:>18}"
                        for c in shown))
    for r in table.failed[:5]:
        print(f"failed {', '.join(f'{k}={r[k]}' for k in table.inputs)}: {r['error']}")
    return 0


# grubler size: each kind's options and their defaults (None on the parser: given or not is known)
MOTOR_OPTIONS = {"motors": "all", "ratios": "5,10,20,35,50,75,100,150", "efficiency": 0.9, "supply": None,
                 "current_limit": math.inf, "ambient": 25.0}
CYLINDER_OPTIONS = CANDIDATE_DEFAULTS  # the study's (the app's Size takes them too)
SIZE_DEFAULTS = {**MOTOR_OPTIONS, **CYLINDER_OPTIONS}


def _size_options(args, model) -> None:
    """Refuse the other kind's options (a motor's to --cylinder, a cylinder's without it), then fill the defaults."""
    def given(options):
        return [f"--{k.replace('_', '-')}" for k in options if getattr(args, k) is not None]

    if args.cylinder:
        wrong = given(MOTOR_OPTIONS)
        if wrong:
            extra = " (a cylinder's supply pressures are --pressures, bar)" if "--supply" in wrong else ""
            raise InputError(wrong[0], f"is for motor sizing; --cylinder sizes a cylinder: drop {', '.join(wrong)}"
                                       + extra)
    else:
        wrong = given(CYLINDER_OPTIONS)
        if wrong:
            raise InputError(wrong[0], f"is for cylinder sizing: add --cylinder ACTUATOR (or drop {', '.join(wrong)})")
        if model.actuators:
            names = ", ".join(model.actuator_names)
            raise InputError("size", f"{model.name or 'the scene'} is driven by a cylinder (actuator "
                                     f"{names}), not a motor on {model.drive or 'a joint'}: size it with "
                                     f"`grubler size {args.scene} --cylinder {model.actuator_names[0]}` "
                                     "(--bores, --pressures)")
    for k, v in SIZE_DEFAULTS.items():
        if getattr(args, k) is None:
            setattr(args, k, v)


def cmd_size(args) -> int:
    from grubler.motors import list_motors, load_motor
    from grubler.studies.sizing import SUMMARY_UNITS, Control, DutyCycle, size
    from grubler.studies.sweep import parse_values

    scene = load_scene(args.scene)
    model = scene.mechanism
    _size_options(args, model)
    if args.check:
        if args.cylinder:  # before any work: the FMUs it runs are there (it builds what it needs elsewhere)
            from grubler.studies.cylinder_sizing import check_fmus

            check_fmus(args.scene, args.check, "--check")
    if args.load_torque and model.load is None:
        model = model.replace(load=model.drive)  # a load on the drive joint itself
    start = float(model.z_from_q(model.q_ref)[model.free_index(model.drive)]) if model.drive else 0.0
    if args.move:
        from grubler.controllers.trajectory import Trajectory

        traj = Trajectory(args.move, distance=args.distance, v_max=args.v_max, a_max=args.a_max, j_max=args.j_max,
                          dwell=args.dwell, repeat=2 if args.reverse else 1, reverse=args.reverse)
        period = (traj.move_time + args.dwell) * (2 if args.reverse else 1)
        cycle = DutyCycle.from_trajectory(traj, period, load=args.load_torque, start=start,
                                          name=f"{args.move} move of {args.distance:g} rad"
                                               + (" and back" if args.reverse else ""))
        trajectory = {"kind": args.move, "distance": args.distance, "v_max": args.v_max, "a_max": args.a_max,
                      "j_max": args.j_max, "dwell": args.dwell, "repeat": 0, "reverse": args.reverse}
    else:
        cycle = DutyCycle.constant_speed(args.speed, load=args.load_torque, start=start)
        trajectory = {"kind": "constant", "speed": args.speed}
    if args.cylinder:
        return _size_cylinder(args, scene, model, cycle)
    names = list_motors() if args.motors == "all" else [m.strip() for m in args.motors.split(",")]
    ratios = parse_values(args.ratios, "--ratios")
    # the currents are predicted under the servo's own position loop, the one --check co-simulates
    study = size(model, cycle, [load_motor(n) for n in names], ratios, efficiency=args.efficiency,
                 supply_voltage=args.supply, current_limit=args.current_limit, ambient=args.ambient,
                 control=Control.servo())
    d = study.demand
    print(f"{scene.name}, {cycle.name}: drive joint torque {d.torque.min():.4g} to {d.torque.max():.4g} N m, "
          f"speed up to {abs(d.velocity).max():.4g} rad/s (period {cycle.period:.4g} s)")
    print(f"{len(study.ranked)} of {len(study.assessments)} motor x ratio combinations fit; best first "
          "(currents under the servo's PID, encoder and feedforward):")
    for k, a in enumerate(study.ranked[:10]):
        r = a.summary()
        print(f"  {k + 1:2d}. {a.candidate.label:<26} margin {a.min_margin:5.2f} ({a.binding}); peak "
              f"{r['peak_current']:.3g} A, {r['peak_voltage']:.3g} V, "
              f"{r['peak_motor_speed']:.0f} {SUMMARY_UNITS['peak_motor_speed']}, "
              f"winding +{r['temperature_rise']:.3g} K")
    if len(study.ranked) > 10:
        print(f"  ... {len(study.ranked) - 10} more that fit (the table ranks them all)")
    rejected = study.rejected  # after the ranked ones: fewest broken limits first
    shown = 10 if args.verbose else 5
    for a in rejected[:shown]:
        print(f"  x  {a.candidate.label:<26} {a.failures[0]}" + (f" (+{len(a.failures) - 1} more)"
                                                               if len(a.failures) > 1 else ""))
    if len(rejected) > shown:
        print(f"  ... {len(rejected) - shown} more rejected (the table has every reason)")
    if any(a.closed_loop is not None and a.closed_loop.method == "bound" for a in study.assessments):
        print("note: the cycle is too long to step the position loop over it: the current it adds is bounded "
              "instead (grubler.studies.sizing.quantisation_bound), which overstates it")
    if args.out:
        study.write_csv(args.out)
        print(f"wrote {args.out}")
    if args.plot:
        study.plot(args.plot)
        print(f"wrote {args.plot}")
    if args.check and study.best is not None:
        from grubler.studies.sizing import closed_loop_check

        chk = closed_loop_check(study.best, cycle, args.scene, trajectory, args.check,
                                load_joint=model.load if args.load_torque else None, load_torque=args.load_torque)
        print("\n".join(chk.lines()))
    elif args.check:
        print("no combination fits: nothing to co-simulate (--check)")
    return 0


def _size_cylinder(args, scene, model, cycle) -> int:
    """grubler size --cylinder: a hydraulic cylinder's bore and supply pressure for the drive joint's cycle."""
    from grubler.studies.cylinder_sizing import cylinder_check, size_cylinder
    from grubler.studies.sweep import parse_values

    bores = parse_values(args.bores, "--bores", "mm")
    pressures = parse_values(args.pressures, "--pressures", "bar")
    study = size_cylinder(model, args.cylinder, cycle, [b * 1e-3 for b in bores], [p * 1e5 for p in pressures],
                          rod_ratio=args.rod_ratio, constants={"stroke": args.stroke})
    d = study.demand
    print(f"{scene.name}, {cycle.name}: actuator {args.cylinder} force {d.force.min() / 1e3:.4g} to "
          f"{d.force.max() / 1e3:.4g} kN, speed up to {abs(d.rate).max():.4g} m/s, length {d.length.min():.4g} to "
          f"{d.length.max():.4g} m (period {cycle.period:.4g} s)")
    print(f"{len(study.ranked)} of {len(study.assessments)} bore x pressure combinations fit; least installed "
          "power first:")
    for k, a in enumerate(study.ranked[:10]):
        print(f"  {k + 1:2d}. {a.candidate.label:<22} margin {a.min_margin:5.2f} ({a.binding}); "
              f"{a.power / 1e3:.3g} kW at the peak flow")
    shown = 10 if args.verbose else 5
    for a in study.rejected[:shown]:
        print(f"  x  {a.candidate.label:<22} {a.failures[0]}" + (f" (+{len(a.failures) - 1} more)"
                                                                 if len(a.failures) > 1 else ""))
    if len(study.rejected) > shown:
        print(f"  ... {len(study.rejected) - shown} more rejected (--verbose lists more)")
    if args.out:
        study.write_csv(args.out)
        print(f"wrote {args.out}")
    if args.plot:
        study.plot(args.plot)
        print(f"wrote {args.plot}")
    if args.check and study.best is not None:
        print("\n".join(cylinder_check(study, args.scene, args.cylinder, args.check).lines()))
    elif args.check:
        print("no combination fits: nothing to co-simulate (--check)")
    return 0


def cmd_linearize(args) -> int:
    """grubler linearize: the linear model about an operating point, printed, as JSON, as a Bode plot."""
    import json

    from grubler.errors import SceneError
    from grubler.studies.linearize import linearize, plot_bode, summary, to_json
    from grubler.mechanism.scene import parse_at

    at = args.at.strip()
    if at not in ("equilibrium", "initial") and not at.replace(" ", "").startswith("t="):
        # [COORDINATE=]VALUE, as info reads it: held there by the drive effort
        try:
            name, value = parse_at(at, load_scene(args.scene).mechanism.drive)
        except SceneError as exc:
            if exc.field != "--at" or "=" in at:
                raise
            raise SceneError("--at", f"{exc.reason}; or equilibrium, initial, t=T") from None
        at = {name: value}
    motor = None
    if args.motor:
        from grubler.motors import DCMotor, Gearbox, load_motor

        motor = DCMotor(load_motor(args.motor), Gearbox(args.ratio if args.ratio is not None else 1.0,
                                                        args.efficiency))
    elif args.ratio is not None:
        raise SceneError("--ratio", "a gear ratio needs a motor (--motor NAME)")
    sys_ = linearize(args.scene, at=at, inputs=args.input.split(",") if args.input else None,
                     outputs=args.output.split(",") if args.output else None, motor=motor, torque=args.torque,
                     load_torque=args.load_torque)
    print(f"{args.scene}: linear model with {sys_.nstates} states, inputs {', '.join(sys_.input_labels)}, "
          f"outputs {', '.join(sys_.output_labels)}")
    print(summary(sys_))
    if args.json:
        with limits.open_output(args.json, "w") as fh:
            json.dump(to_json(sys_), fh, indent=1)
        print(f"wrote {args.json}")
    if args.bode:
        plot_bode(sys_, args.bode)
        print(f"wrote {args.bode}")
    return 0


class _Parser(argparse.ArgumentParser):
    """argparse, but a bad option is one line on stderr, like every other error."""

    def error(self, message: str):
        # argparse quotes the value it refused: cut it like every other message
        self.exit(2, f"{self.prog}: error: {limits.clip(message, 400)} (see {self.prog} -h)\n")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="grubler", description="Planar four-link mechanisms by imaginary joints.")
    p.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub.add_parser("presets", help="list the shipped scenes").set_defaults(func=cmd_presets)
    mot = sub.add_parser("motors", help="the motor data sets: key figures and where they come from")
    mot.add_argument("names", nargs="*", help="data set names or TOML files (default: every shipped one)")
    mot.set_defaults(func=cmd_motors)
    info = sub.add_parser("info", help="type, mobility, Grashof class and assembled start of a scene")
    info.add_argument("scene", help="preset name or TOML file")
    info.add_argument("--at", help="drive angle to assemble at, with its unit: '120 deg', '2.1 rad', 'pi/3' or "
                                   "theta2=120deg, as linearize reads it (a slide's length in m); a bare number is "
                                   "refused (default: the scene's)")
    info.set_defaults(func=cmd_info)
    s = sub.add_parser("simulate", help="simulate a scene")
    s.add_argument("scene", help="preset name or TOML file")
    s.add_argument("--t-end", type=_positive("--t-end", "s"), help="end time, s (default: the scene's)")
    s.add_argument("--dt-out", type=_positive("--dt-out", "s"), help="output interval, s")
    s.add_argument("--method", choices=["exact", "penalty"], help="closure method (default: the scene's)")
    s.add_argument("--rtol", type=_number("--rtol", low=1e-14, high=0.1), default=1e-9,
                   help="relative tolerance (1e-14 to 0.1: below, no double-precision step can meet it)")
    s.add_argument("--atol", type=_positive("--atol"), help="absolute tolerance (default: rtol)")
    s.add_argument("--integrator", choices=["dop853", "rk45", "rk4", "radau", "bdf"],
                   help="default: dop853 (exact), radau (penalty)")
    s.add_argument("--step", type=_positive("--step", "s"),
                   help="fixed step for rk4, s (default 1e-3; cut to --dt-out when longer, with a warning)")
    s.add_argument("--torque", type=_finite("--torque"), help="drive torque, N m (N on a slide)")
    s.add_argument("--actuator-force", type=_actuator_force, action="append", metavar="NAME=N",
                   help="constant force of the scene's actuator NAME, N, positive pushing its points apart "
                        "(repeat for each; an actuator not given pushes with 0)")
    s.add_argument("--reactions", action="store_true",
                   help="add each joint's reaction columns (R1_Fx, R1_Fy, R1_Mz, ...: the force and moment a link's "
                        "predecessor exerts on it) to the --csv file; they are in the CSV only, not in the plot "
                        "or the printed table (needs --csv)")
    s.add_argument("--csv", type=_output("--csv"), help="write the trajectory to this CSV file")
    s.add_argument("--plot", type=_output("--plot", "figure"), help="write a plot to this PNG file")
    s.set_defaults(func=cmd_simulate)
    a = sub.add_parser("animate", help="draw a scene's motion (or a simulate or cosim CSV) to a GIF or MP4")
    a.add_argument("source", help="preset name, TOML scene, or a CSV written by `grubler simulate` or `cosim`")
    a.add_argument("--scene", help="the scene a CSV came from (preset or TOML)")
    a.add_argument("--out", type=_output("--out", (".gif", ".mp4", ".png")),
                   help="FILE.gif or FILE.mp4 (MP4 needs ffmpeg), or FILE.png for a spatial scene's still at t = 0; "
                        "default SCENE.gif")
    a.add_argument("--fps", type=_number("--fps", low=0.01, high=100.0), default=25.0,
                   help="frames per second of film, 0.01 to 100 (a GIF frame lasts 10 ms to 655 s)")
    a.add_argument("--speed", type=_positive("--speed"), default=1.0, help="seconds of motion per second of film")
    a.add_argument("--trace", help="trace a point: 'tip' or 'linkK:u,v' (e.g. link3:0.4,0), drawn on its link "
                                   "as a plate")
    a.add_argument("--signals", metavar="NAMES",
                   help="up to 4 columns to plot under the mechanism with a moving cursor, comma-separated, "
                        "as the CSV names them (e.g. mechanism.theta2,motor.current) or, for a scene, "
                        "simulate's columns (e.g. theta2,tau_drive,E)")
    a.add_argument("--t-end", type=_positive("--t-end", "s"), help="simulated time, s (scene sources)")
    a.add_argument("--torque", type=_finite("--torque"), help="drive torque, N m (scene sources)")
    a.add_argument("--camera", metavar="AZ,EL[,DIST]",
                   help="a spatial scene's perspective view: azimuth about the up direction (against gravity) from "
                        "world x, elevation, and distance from the motion's middle, e.g. '30 deg,20 deg,1.5 m' "
                        "(default -55 deg,25 deg, the distance that fits the motion to the picture)")
    a.set_defaults(func=cmd_animate)
    r = sub.add_parser("report", help="one-page report (PNG or PDF) of a run CSV")
    r.add_argument("csv", help="a CSV written by `grubler simulate` or `grubler cosim`")
    r.add_argument("--scene", help="the scene it came from: titles the page and draws the mechanism (refused if its "
                                   "geometry does not close the recorded loop)")
    r.add_argument("--system", help="the .ssd or .ssp a cosim CSV came from: names its motor, gearbox and "
                                    "controller")
    r.add_argument("--out", type=_output("--out", "figure"), action="append",
                   help="the page, in the format of its suffix: report.png (default) or report.pdf; "
                        "give --out twice for both")
    r.set_defaults(func=cmd_report)
    w = sub.add_parser("sweep", help="run a scene over a grid of parameters, in parallel or on Dask")
    w.add_argument("scene", help="preset name or TOML file")
    w.add_argument("--set", action="append", required=True, metavar="NAME=VALUES",
                   help="an axis: NAME=V1,V2,... or NAME=START:STOP:N (e.g. link2.a=0.15:0.25:5); repeat")
    w.add_argument("--t-end", type=_positive("--t-end", "s"), default=2.0, help="simulated time per point, s")
    w.add_argument("--method", choices=["exact", "penalty"], help="closure method (default: the scene's)")
    w.add_argument("--out", type=_output("--out", (".csv", ".parquet")),
                   help="table to write: .csv or .parquet (a journal beside it makes it resumable)")
    w.add_argument("--workers", type=_number("--workers", low=1, high=1024, integer=True),
                   help="local processes (default: all cores)")
    w.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    w.add_argument("--no-resume", action="store_true",
                   help="start afresh (an earlier journal is kept as OUT.journal.jsonl.N)")
    w.add_argument("--retry-failed", action="store_true", help="when resuming, rerun the failed points")
    w.set_defaults(func=cmd_sweep)
    z = sub.add_parser("size", help="size a motor and gear ratio for a drive duty cycle")
    z.add_argument("scene", help="preset name or TOML file (its drive joint is the one sized)")
    z.add_argument("--speed", type=_finite("--speed"), default=2 * math.pi,
                   help="constant drive speed, rad/s (default one turn per second)")
    z.add_argument("--move", choices=["trapezoid", "scurve"], help="a rest-to-rest move instead of a constant speed")
    z.add_argument("--distance", type=_finite("--distance"), default=math.pi, help="move length, rad")
    z.add_argument("--v-max", type=_positive("--v-max", "rad/s"), default=2 * math.pi, help="move speed limit, rad/s")
    z.add_argument("--a-max", type=_positive("--a-max", "rad/s2"), default=20.0, help="move acceleration limit, rad/s2")
    z.add_argument("--j-max", type=_positive("--j-max", "rad/s3"), default=400.0, help="scurve jerk limit, rad/s3")
    z.add_argument("--dwell", type=_number("--dwell", low=0.0), default=0.5, help="rest after each move, s")
    z.add_argument("--reverse", action="store_true", help="move there and back in each cycle")
    z.add_argument("--load-torque", type=_finite("--load-torque"), default=0.0,
                   help="load on the load joint (the drive joint if the scene has none), N m")
    # a motor's options and a cylinder's: their defaults (SIZE_DEFAULTS) are applied in cmd_size, so that one
    # given to the other kind of sizing is refused rather than ignored
    z.add_argument("--motors", help="motor sizing: 'all' (default) or comma-separated data sets (see `grubler motors`)")
    z.add_argument("--ratios", help=f"motor sizing: gear ratios, V1,V2,... or START:STOP:N "
                                    f"(default {SIZE_DEFAULTS['ratios']})")
    z.add_argument("--efficiency", type=_number("--efficiency", low=0.0, low_open=True, high=1.0),
                   help="motor sizing: gearbox efficiency (default 0.9)")
    z.add_argument("--supply", type=_positive("--supply", "V"),
                   help="motor sizing: supply voltage, V (default: each motor's nominal)")
    z.add_argument("--current-limit", type=_positive("--current-limit", "A"),
                   help="motor sizing: the drive's current limit, A (default none)")
    z.add_argument("--ambient", type=_number("--ambient", low=AMBIENT_RANGE[0], high=AMBIENT_RANGE[1], unit="degC"),
                   help=f"motor sizing: ambient temperature, degC ({AMBIENT_RANGE[0]:g} to {AMBIENT_RANGE[1]:g}, "
                        "default 25)")
    z.add_argument("--out", type=_output("--out"), help="write every combination's numbers and reasons to this CSV")
    z.add_argument("--plot", type=_output("--plot", "figure"),
                   help="write a figure to this PNG: a motor's envelopes and margin against ratio; a cylinder's "
                        "force over the cycle, margin and installed power against bore")
    z.add_argument("--verbose", action="store_true", help="list more rejected combinations")
    z.add_argument("--cylinder", metavar="ACTUATOR", help="size a hydraulic cylinder for the scene's actuator "
                                                         "instead of a motor (bores x supply pressures)")
    z.add_argument("--bores", help=f"cylinder sizing: bores, mm: V1,V2,... or START:STOP:N "
                                   f"(default {SIZE_DEFAULTS['bores']})")
    z.add_argument("--pressures", help=f"cylinder sizing: supply pressures, bar: V1,V2,... or START:STOP:N "
                                       f"(default {SIZE_DEFAULTS['pressures']})")
    z.add_argument("--rod-ratio", type=_number("--rod-ratio", low=0.0, high=1.0, low_open=True),
                   help="cylinder sizing: rod diameter over bore (below 1; default 0.56)")
    z.add_argument("--stroke", type=_positive("--stroke", "m"), help="cylinder sizing: stroke, m (default 0.3)")
    z.add_argument("--check", metavar="FMU_DIR", help="run the best combination in the servo co-simulation "
                                                     "(FMUs from FMU_DIR, e.g. dist, only read) and compare")
    z.set_defaults(func=cmd_size)
    c = sub.add_parser("cosim", help="co-simulate an SSP system of FMUs (a .ssd or .ssp)")
    c.add_argument("system", help="SystemStructure .ssd file or .ssp archive")
    c.add_argument("--t-end", type=_positive("--t-end", "s"), help="end time, s (default: the system's)")
    c.add_argument("--step", type=_positive("--step", "s"),
                   help="communication step, s (default: the system's); a warning says when it exceeds a "
                        "component's sample time or the motor's mechanical time constant")
    c.add_argument("--master", choices=["gauss-seidel", "jacobi", "extrapolate", "newton"],
                   help="gauss-seidel (default): each component steps on the outputs of those before it; "
                        "extrapolate (default with --tol): in that order, a continuous input held at its value at "
                        "the step's midpoint, interpolated or extrapolated (second order, but less stable on a "
                        "coupling stiff at the step: docs/cosim.md); newton: each step iterated to its fixed "
                        "point, the continuous components rolled back and stepped again (stable on stiff "
                        "couplings, second order, a few steps' work a step); jacobi: all step on the "
                        "last step's values, so every connection adds a step of delay (less accurate, for "
                        "comparison with fmpy and libcosim)")
    c.add_argument("--tol", type=_number("--tol", low=1e-14, high=0.5),
                   help="error control: the continuous components sub-step within each communication step, each "
                        "sub-step's coupling error estimate (step doubling) within TOL, relative to max(1, |value|) "
                        "(e.g. 1e-8); the sampled laws keep the step")
    c.add_argument("--record", help="comma-separated component.output to record (default: all outputs)")
    c.add_argument("--dt-out", type=_positive("--dt-out", "s"),
                   help="record every this many seconds (a multiple of the step; default every step)")
    c.add_argument("--order", help="comma-separated stepping order of the components (default: the system's)")
    c.add_argument("--csv", type=_output("--csv"), help="write every recorded output to this CSV file")
    c.add_argument("--plot", type=_output("--plot", "figure"), help="write the system's plot to this PNG file")
    c.set_defaults(func=cmd_cosim)
    ap = sub.add_parser("app", help="the browser app: edit, animate and plot a scene (local, 127.0.0.1)")
    ap.add_argument("scene", nargs="?", help="preset name or TOML file to open with")
    ap.add_argument("--port", type=_number("--port", low=0, high=65535, integer=True), default=8765,
                    help="port to listen on (0: any free one; default 8765)")
    ap.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine only)")
    ap.add_argument("--no-browser", action="store_true", help="print the URL without opening a browser")
    ap.set_defaults(func=cmd_app)
    e = sub.add_parser("export", help="a native FMI 2.0 or 3.0 co-simulation FMU of a scene (no Python needed to "
                                      "run it), or one FMU of a whole system (.ssd or .ssp)")
    e.add_argument("scene", help="preset name (a spatial one too: rssr, spherical-fourbar, bennett, ...) or "
                                 "TOML file, planar or spatial; the FMU's parameters default to its values. Or a system "
                                 "(.ssd, .ssp): when every FMU is a native grubler FMU, one native FMU of their "
                                 "models stepped as `grubler cosim` steps them; else its FMUs nested in fmpy's "
                                 "container FMU, stepped as `grubler cosim --master jacobi` steps them")
    e.add_argument("-o", "--out", type=_output("--out", (".fmu",)), help="NAME.fmu to write (default: SCENE.fmu); NAME is its model identifier")
    e.add_argument("--fmi", type=int, choices=[2, 3], default=2, help="FMI version of the FMU (default 2)")
    e.add_argument("--container", action="store_true",
                   help="a system: nest its FMUs in fmpy's container FMU (Jacobi) even when every one is a native "
                        "grubler FMU, which makes one native FMU by default")
    e.add_argument("--platforms", help="binaries to ship, comma-separated: linux64, win64, darwin64, aarch64-linux "
                                       "(default: every one this machine can build)")
    e.add_argument("--master", choices=["gauss-seidel", "jacobi", "extrapolate", "newton"],
                   help="a system's one native FMU: the start value of its parameter master, the coupling as "
                        "`grubler cosim --master` makes it (default gauss-seidel, extrapolate with --tol)")
    e.add_argument("--tol", type=_number("--tol", low=1e-14, high=0.5),
                   help="a system's one native FMU: the start value of its parameter tol, error-controlled "
                        "sub-steps as `grubler cosim --tol` makes them (default 0: none)")
    e.add_argument("--binary-only", action="store_true",
                   help="a system's one native FMU without sources/ (for deployment: it starts faster; it runs only "
                        "on the platforms it has binaries for, and cannot be compiled into another system FMU)")
    e.set_defaults(func=cmd_export)
    el = sub.add_parser("export-law", help="a native FMU of a control law written as one C function (grubler_law.h)")
    el.add_argument("source", help="the C file: GRUBLER_* declarations and law_step")
    el.add_argument("-o", "--out", type=_output("--out", (".fmu",)), help="NAME.fmu to write (default: SOURCE.fmu); NAME is its model identifier")
    el.set_defaults(func=cmd_export_law)
    lin = sub.add_parser("linearize", help="linear state-space model about an operating point (python-control)")
    lin.add_argument("scene", help="preset name or TOML file")
    lin.add_argument("--at", default="equilibrium",
                     help="equilibrium (default), initial, t=T (along the trajectory under the efforts), or "
                          "COORDINATE=VALUE (at rest there, held by the drive effort; an angle with its unit, "
                          "e.g. theta2=30deg, theta2=0.5rad or theta2=pi/6; a bare number is refused), or "
                          "VALUE alone for the drive joint's ('30 deg'), as info reads it")
    lin.add_argument("--torque", type=_finite("--torque"),
                     help="constant drive effort, N m (N on a slide; default: the scene's)")
    lin.add_argument("--load-torque", type=_finite("--load-torque"), help="constant load effort, N m (N on a slide)")
    lin.add_argument("--motor", help="DC motor data set on the drive joint (see `grubler motors`): input voltage")
    lin.add_argument("--ratio", type=_positive("--ratio"), help="its gear ratio (default 1)")
    lin.add_argument("--efficiency", type=_positive("--efficiency"), default=0.9, help="gearbox efficiency")
    lin.add_argument("--input", help="comma-separated inputs: drive, load, voltage (default: drive, or voltage)")
    lin.add_argument("--output", help="comma-separated outputs, e.g. theta2,theta4_d,Fx,current "
                                      "(default: the drive coordinate)")
    lin.add_argument("--json", type=_output("--json", (".json",)),
                     help="write A, B, C, D, the names and the operating point to this JSON file")
    lin.add_argument("--bode", type=_output("--bode", BODE_SUFFIXES),
                     help="write a Bode plot to this file: " + ", ".join(BODE_SUFFIXES))
    lin.set_defaults(func=cmd_linearize)
    return p


def _one_line(exc: BaseException) -> str:
    """An error as the CLI prints it: its lines, each cut to a readable length."""
    lines = str(exc).splitlines() or [type(exc).__name__]
    return "\n".join(limits.clip(line, 400) for line in lines[:50])


_LAST: dict = {}  # the command run() last parsed, for main()'s way out
_OUTPUTS: dict = {}  # the files the command line named to write, by absolute path: their options
_MAX_PROBLEMS = 50  # lines of one refusal: a file with hundreds of bad fields is told where to start


def run(argv: Sequence[str] | None = None) -> int:
    """The command line in this process: parse, run, and turn a refusal into exit status 2.

    What :func:`main` adds is process-wide (signals, the exit itself); tests and
    the fuzz suite call this.  Every temporary folder a command made is removed
    here, whatever the outcome.
    """
    parser = build_parser()
    _OUTPUTS.clear()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: -h (0) or a bad option (2), already printed
        return exc.code if isinstance(exc.code, int) else 2
    _LAST["command"], _LAST["check"] = args.command, getattr(args, "check", None)
    try:
        code = args.func(args)
    except KeyboardInterrupt:
        return _interrupted()
    except BaseException as exc:
        if _LAST.get("signal"):
            # Ctrl-C inside an FMU's Python (a pythonfmu do_step) reaches us as that FMU's error
            # status, or as whatever its error became: the user's interrupt is the cause
            return _interrupted()
        if args.debug or not isinstance(exc, (GrublerError, OSError, MemoryError)):
            raise
        if isinstance(exc, MemoryError):
            exc = GrublerError("out of memory: the run needs more than this machine has; make it smaller")
        if isinstance(exc, OSError) and exc.filename is not None:
            exc = _file_error(exc)
        problems = exc.problems if isinstance(exc, SceneErrors) else [exc]  # several: one line each
        for problem in problems[:_MAX_PROBLEMS]:
            print(f"grubler: error: {_one_line(problem)}", file=sys.stderr)
        if len(problems) > _MAX_PROBLEMS:
            print(f"grubler: error: ... and {len(problems) - _MAX_PROBLEMS} more problems", file=sys.stderr)
        return 2
    finally:
        limits.remove_temp_dirs()
    return _interrupted() if _LAST.get("signal") else code


def _interrupted() -> int:
    if not _LAST.get("interrupted"):  # once, whether the main thread or the watcher says it
        _LAST["interrupted"] = True
        print("grubler: interrupted", file=sys.stderr)
    return 130


def _on_signal(signum, frame):
    # noted before the KeyboardInterrupt, which an FMU's Python may swallow into an error status
    _LAST["signal"] = signum
    raise KeyboardInterrupt


def _exit_now(code: int) -> None:
    # pythonfmu FMUs that ran numpy can corrupt the heap at interpreter exit
    # (upstream PythonFMU issue 228) after correct results: leave without
    # the interpreter's teardown so that the exit status is the run's
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


_WATCHING = False


def _watch_interrupts(grace: float = 0.5) -> None:
    """Ctrl-C (or SIGTERM) ends any command within a second, with status 130 and one line.

    Python runs its SIGINT handler only between bytecodes of the main thread,
    which a long call into compiled code does not reach.  The signal's byte on
    the wakeup pipe reaches this watcher thread regardless; if the main thread
    has not ended ``grace`` seconds later, the watcher removes the temporary
    folders and leaves.  (It needs the GIL, which ctypes calls release.)
    """
    import threading

    global _WATCHING
    if _WATCHING or threading.current_thread() is not threading.main_thread():
        return  # once per process; signals are the main thread's
    _WATCHING = True
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
    signal.signal(signal.SIGINT, _on_signal)
    if hasattr(signal, "SIGTERM"):
        signal.signal(signal.SIGTERM, _on_signal)

    def watch():
        import time

        while True:
            data = os.read(read_fd, 64)
            if any(b in (signal.SIGINT, getattr(signal, "SIGTERM", -1)) for b in data):
                # noted at once: what fails in the main thread from here on (an FMU whose folder
                # is removed below, a handler the signal has not reached yet) is the interrupt
                _LAST["signal"] = True
                time.sleep(grace)
                _interrupted()
                limits.remove_temp_dirs()
                _exit_now(130)

    threading.Thread(target=watch, name="grubler-interrupt", daemon=True).start()


def main(argv: Sequence[str] | None = None) -> int:
    """The ``grubler`` command (see :func:`run`), with the process-wide parts.

    Signal handling is installed only when the command owns the process (no
    ``argv`` given: the console script, ``python -m grubler.cli``), not when a
    test or a program calls ``main([...])``.
    """
    if argv is None:
        if hasattr(signal, "SIGPIPE"):  # `grubler ... | head` ends quietly
            signal.signal(signal.SIGPIPE, signal.SIG_DFL)
        _watch_interrupts()
    _LAST.clear()
    code = run(argv)
    if _LAST.get("command") == "cosim" or _LAST.get("check") or code == 130:
        # cosim: see _exit_now; 130: sweep workers and other threads must not hold the exit
        _exit_now(code)
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

