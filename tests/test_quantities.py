"""One table per family of quantities: every surface that names a mechanism output or a scene field reads
its unit and words from grubler.quantities, and the kernel's fixed observations are the table's, in order."""

import re
from pathlib import Path

import pytest

import grubler
from grubler.app import actions
from grubler.fmi.mechanism import mechanism_spec
from grubler.mechanism.dynamics import observation_names
from grubler.mechanism.scene import parameter_names, preset_names
from grubler.mechanism.simulate import output_columns, unit_of
from grubler.quantities import FIXED_OBSERVATIONS, fmi_text, fmi_unit, mechanism_output, scene_field
from grubler.studies.sweep import scene_point_units

ROOT = Path(__file__).resolve().parents[1]


def test_the_kernels_fixed_observations_are_the_tables_in_its_order():
    header = (ROOT / "fmu_src" / "kernel" / "grubler.h").read_text()
    body = re.search(r"typedef enum grb_observation \{(.*?)\} grb_observation;", header, re.S).group(1)
    names = re.findall(r"\b(GRB_OBS_\w+)", re.sub(r"/\*.*?\*/", "", body, flags=re.S))
    assert names[-1] == "GRB_OBS_FIXED"
    assert names[:-1] == [f"GRB_OBS_{q.name.upper()}" for q in FIXED_OBSERVATIONS]
    n = 3
    assert observation_names(n)[6 * n:6 * n + len(FIXED_OBSERVATIONS)] == [q.name for q in FIXED_OBSERVATIONS]


@pytest.mark.parametrize("preset", ["thesis-fourbar", "thesis-slider-crank", "watt-ii", "luffing-boom",
                                    "triple-pendulum"])
def test_every_surface_reads_an_output_from_the_one_table(preset):
    scene = grubler.load_scene(preset)
    m = scene.mechanism
    columns = output_columns(m, ("state", "dynamics", "energy", "reactions", "actuators"))
    for c in columns:
        q = mechanism_output(c, m.actuator_names)
        assert q is not None, c
        assert unit_of(c) == q.unit, c  # the CSV headings and plot labels
        assert actions.describe(c, m.actuator_names).startswith(f"{q.label} ({c})"), c  # the app's menus
    declared = {v.name: v for v in mechanism_spec(scene).variables}
    published = [c for c in columns if c in declared]
    assert len(published) > 10
    for c in published + ["drive_angle", "drive_speed"]:
        q = mechanism_output(c, m.actuator_names)
        assert declared[c].unit == fmi_unit(q.unit) and declared[c].description == fmi_text(q), c  # the FMU
    for name in ("link2.I", "link2.damping", "gravity", "drive.inertia"):
        assert declared[name].unit == fmi_unit(scene_field(name).unit), name
    units = scene_point_units(scene, [p for p in parameter_names(scene) if not p.startswith("initial")])
    for name, unit in units.items():  # the sweep's headings: a link's damping as its joint decides
        k = re.match(r"link(\d+)\.", name)
        if k:
            slide = m.links[int(k.group(1)) - 2].joint != "R"
            assert unit == scene_field(name, on_slide=slide).unit, name
        elif name.startswith(("drive.", "load.", "gravity")):
            assert unit in (scene_field(name, on_slide=True).unit, scene_field(name, on_slide=False).unit), name


def test_a_unit_is_spelled_one_way_and_declared_by_one_rule():
    for preset in preset_names():
        m = grubler.load_scene(preset).mechanism
        for c in output_columns(m, ("state", "dynamics", "energy", "reactions", "actuators")):
            unit = mechanism_output(c, m.actuator_names).unit
            assert "²" not in unit and ".m" not in unit, (preset, c, unit)
    assert [fmi_unit(u) for u in ("N m", "kg m^2", "m/s^2", "N m s/rad", "rad/s^2", "N m or N")] == \
        ["N.m", "kg.m2", "m/s2", "N.m.s/rad", "rad/s2", None]
