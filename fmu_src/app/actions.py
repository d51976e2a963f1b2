"""What the app's requests do, in the library's terms: no HTTP here, and no physics.

The server's one door to the library.  Each concept has its module: the scene
and its form (:mod:`grubler.app.scene_form`), the drawing with its drags and
analysis (:mod:`grubler.app.drawing`), a run as the page plays it
(:mod:`grubler.app.runs`), the drives (:mod:`grubler.app.drives`); this module
gathers them and holds the exports.  Every function returns plain JSON-able data.

Examples
--------
>>> data = preset_data("fourbar-crank-rocker")
>>> out = analyse(data)
>>> out["class"]["grashof"]["kind"], out["class"]["mobility"]
('crank-rocker', 1)
>>> moved = drag(data, "B", 0.6, 0.9)          # the coupler-rocker pin, dragged
>>> moved["mechanism"]["coupler"], moved["mechanism"]["rocker"]
(0.8235, 0.9849)
>>> import tomllib
>>> tomllib.loads(scene_toml(data)) == data
True
"""

from __future__ import annotations

from grubler.app.drawing import (SWEEP_STEPS, _sketch, analyse, analyse_drag, analysis_view, coil_shape, coupler_curve,
                                 default_trace, drag, drive_sweep, handles, pick_trace, run_instant)
from grubler.app.drives import (check_fmu_folder, cylinder_servo_defaults, run_cylinder_servo, run_servo, run_sizing,
                                servo_defaults)
from grubler.app import elements
from grubler.app.elements import remove_element
from grubler.app.runs import describe, plotted, result_csv, run_simulation
from grubler.app.scene_form import (catalog, choices, echoed, edit, error_of, fields, parse_scene_text, preset_data,
                                    scene_toml, unit)
from grubler.mechanism.assembly import assemble
from grubler.mechanism.scene import preset_names, scene_from_dict
from grubler.mechanism.simulate import output_columns
from grubler.app.drives import _servo_design
from grubler.errors import InputError
from grubler.limits import brief



EXPORTS = {"fmu": "the mechanism FMU (grubler export)", "ssp": "the servo system as an SSP archive",
           "pdf": "the one-page run report (grubler report)"}


def export_file(kind: str, data: dict, folder, result=None, settings: dict | None = None, fmu_dir=None):
    """Write one export into ``folder`` and return its path.

    Parameters
    ----------
    kind : {'fmu', 'ssp', 'pdf'}
        See :data:`EXPORTS`; 'pdf' needs the session's last run (``result``),
        'ssp' the servo settings and the FMUs the servo runs (``fmu_dir``).
    """
    from pathlib import Path

    from grubler.fmi.build import export, identifier_for

    folder = Path(folder)
    scene = scene_from_dict(data)
    stem = identifier_for(Path((scene.name or "mechanism").replace("-", "_")))
    if kind == "fmu":
        return export(scene, folder / f"{stem}.fmu")
    if kind == "ssp":
        from grubler.system.servo import servo_system

        check_fmu_folder(fmu_dir)
        return servo_system(_servo_design(data, settings), fmu_dir, name=f"{stem}_servo").write(
            folder / f"{stem}_servo.ssp")
    if kind == "pdf":
        from grubler.views.report import write_report
        from grubler.views.runs import read_run

        if result is None:
            raise InputError("report", "simulate first: the report is of the last run")
        # named after the scene that was run, which the page may have left since (a preset picked after it)
        stem = identifier_for(Path((result.model.name or "mechanism").replace("-", "_")))
        csv_path = folder / f"{stem}.csv"
        result_csv(result, csv_path)
        _, columns = read_run(str(csv_path), result.model)
        write_report(columns, [folder / f"{stem}-report.pdf"], result.model, source=csv_path.name)
        return folder / f"{stem}-report.pdf"
    raise InputError("export", f"must be one of {', '.join(EXPORTS)}, got {brief(kind)}")


__all__ = ["analyse", "analyse_drag", "analysis_view", "run_instant", "catalog", "choices", "drag", "edit", "echoed",
           "fields", "parse_scene_text", "preset_data", "run_simulation", "scene_toml", "describe", "plotted",
           "result_csv", "output_columns", "servo_defaults", "check_fmu_folder", "run_servo",
           "cylinder_servo_defaults", "run_cylinder_servo", "run_sizing", "export_file", "error_of", "handles",
           "pick_trace", "drive_sweep", "coupler_curve", "default_trace", "unit", "EXPORTS", "SWEEP_STEPS",
           "assemble", "preset_names", "scene_from_dict", "add_element", "remove_element", "coil_shape"]


def add_element(data: dict, kind) -> dict:
    """Scene data with a new force element of ``kind``, placed on the scene's sketch (grubler.app.elements)."""
    return elements.add_element(data, kind, _sketch)
