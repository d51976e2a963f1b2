"""A six-bar exported as a native FMU (grubler export): valid, every link and
closure a variable, and it runs like the library."""

import numpy as np
import pytest

import grubler

fmpy = pytest.importorskip("fmpy")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

from grubler.fmi.build import export  # noqa: E402

SIX = ["watt-i", "watt-ii", "stephenson-i", "stephenson-ii", "stephenson-iii"]


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.mark.parametrize("name", SIX)
def test_a_six_bar_exports_validates_and_runs_like_the_library(name, tmp_path):
    scene = grubler.load_scene(name)
    path = tmp_path / f"{name.replace('-', '_')}.fmu"
    export(scene, path)
    assert validate_fmu(str(path)) == []
    names = {v.name for v in read_model_description(str(path)).modelVariables}
    assert {"link6.a", "link6.I", "closure[1].point_x", "closure[1].to_link", "initial.theta6", "theta5",
            "theta6", "theta6_dd", "R5_Fx", "closure_error", "closure1_Fx", "closure1_Fy", "closure1_Mz"} <= names
    coords = ["theta2", "theta3", "theta4", "theta5", "theta6"]
    forces = ["Fx", "Fy", "closure1_Fx", "closure1_Fy"]
    run = simulate_fmu(str(path), stop_time=1.0, output_interval=0.01, output=coords + forces + ["closure_error"])
    lib = grubler.simulate(scene, t_end=1.0, dt_out=0.01, torque=0.0)  # the FMU's input starts at 0
    assert np.max(run["closure_error"]) < 1e-10
    for c in coords:
        np.testing.assert_allclose(run[c], lib[c], rtol=0, atol=1e-6)
    for c in forces:  # every closure's force, the second loop's too
        assert np.ptp(lib[c]) > 0.1
        np.testing.assert_allclose(run[c], lib[c], rtol=0, atol=1e-3 * np.max(np.abs(lib[c])))
