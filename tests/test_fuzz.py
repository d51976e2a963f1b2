"""Property-based fuzzing of everything the CLI reads: scenes, options, systems, run CSVs.

Each test is one class of input (docs/reliability.md counts them); each
example goes through :func:`fuzzing.check_cli`, which holds it to the contract
(exit 0 with finite output or exit 2 naming the field; no stray files; an empty
temporary folder).  ``GRUBLER_FUZZ_PROFILE=long`` (benchmarks/fuzz_long.py)
runs 25 times as many, at random.
"""

import sys
import tomllib

import pytest

pytest.importorskip("hypothesis", reason="hypothesis is not installed (pip install -e .[test])")

from hypothesis import given  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from fuzzing import (NASTY_TEXT, PROFILE, check_cli, examples, nasty_value, number_text, run_csv,  # noqa: E402
                     ssd_text, ssp_archive, toml_text)
from grubler.mechanism.scene import preset_text  # noqa: E402

PRESETS = ["thesis-fourbar", "thesis-slider-crank", "elliptic-trammel", "thesis-conchoidal"]


@st.composite
def mutated_scene(draw) -> dict:
    """A preset with one to three fields replaced, deleted or added."""
    data = tomllib.loads(preset_text(draw(st.sampled_from(PRESETS))))
    for _ in range(draw(st.integers(1, 3))):
        tables = [k for k, v in data.items() if isinstance(v, dict)]
        op = draw(st.sampled_from(["set", "set", "set", "scale", "scale", "delete", "unknown", "table"]))
        if op == "table":
            data[draw(st.sampled_from(["link5", "link1", "link99", "closure", "initial", "drive"]))] = draw(
                st.dictionaries(st.sampled_from(["a", "m", "joint", "type", "theta2", "point"]), nasty_value(),
                                max_size=3))
            continue
        where = data if not tables or draw(st.integers(0, 3)) == 0 else data[draw(st.sampled_from(tables))]
        if op == "unknown":
            where[draw(st.sampled_from(["bogus", "A", "m ", "link2"]))] = draw(nasty_value())
        elif where:
            key = draw(st.sampled_from(sorted(where)))
            if op == "delete":
                del where[key]
            elif op == "scale":  # a plausible scene that is not the preset
                if (isinstance(where[key], (int, float)) and not isinstance(where[key], bool)
                        and abs(where[key]) < 1e300):
                    where[key] = where[key] * draw(st.floats(0.2, 5.0)) + draw(st.floats(-0.1, 0.1))
            elif key in ("name", "kind", "description") and where is data:
                # free text: anything goes, but not the word nan, which the finite-output check
                # would take for a number when the name is echoed
                where[key] = draw(st.one_of(nasty_value(), st.text(max_size=12)).filter(
                    lambda v: "nan" not in str(v).lower()))
            elif not isinstance(where[key], dict):
                where[key] = draw(nasty_value())
    return data


@examples(90)
@given(mutated_scene(), st.integers(0, 4))
def test_fuzz_scene_files(data, which):
    files = {"s.toml": toml_text(data).encode("utf-8", "surrogatepass")}
    if which == 0:  # a fifth of them simulated briefly, the rest read and assembled
        check_cli("scene (TOML fields)", ["simulate", "s.toml", "--t-end", "0.02", "--dt-out", "0.01",
                                          "--csv", "o.csv"], files, ("o.csv",))
    else:
        check_cli("scene (TOML fields)", ["info", "s.toml"], files)


@examples(40)
@given(st.one_of(
    st.binary(max_size=300),
    st.integers(0, 2000).map(lambda n: preset_text("thesis-fourbar")[:n].encode()),
    st.integers(1, 5000).map(lambda n: ("a = " + "[" * n + "]" * n + "\n").encode()),
    st.integers(1, 5000).map(lambda n: ("x = " + "{a = " * n + "1" + "}" * n + "\n").encode()),
    st.integers(1, 6000).map(lambda n: ("[link2]\na = 1" + "0" * n + "\n").encode()),
))
def test_fuzz_scene_bytes(content):
    check_cli("scene (raw bytes)", ["info", "s.toml"], {"s.toml": content})


@examples(60)
@given(st.lists(st.tuples(st.sampled_from(["--t-end", "--dt-out", "--rtol", "--atol", "--step", "--torque",
                                           "--method", "--integrator", "--plot", "--csv"]),
                          number_text(small=True)), max_size=4))
def test_fuzz_simulate_options(options):
    argv, outputs = ["simulate", "thesis-fourbar"], []
    opts = dict(options)
    if "--t-end" not in opts:
        argv += ["--t-end", "0.02"]  # long runs of valid length are runs, not input to fuzz
    for flag, value in opts.items():
        if flag in ("--plot", "--csv"):
            value = f"out.{value}" if flag == "--plot" else "out.csv"
            outputs.append(value)
        if flag == "--integrator" and value in ("rk4",):
            continue
        argv += [flag, value]
    check_cli("options: simulate", argv, {}, tuple(outputs))


@examples(40)
@given(st.dictionaries(st.sampled_from(["--speed", "--distance", "--v-max", "--a-max", "--j-max", "--dwell",
                                        "--load-torque", "--ratios", "--efficiency", "--supply", "--current-limit",
                                        "--ambient", "--motors"]), number_text(), max_size=4),
       st.sampled_from([[], ["--move", "trapezoid"], ["--move", "scurve"], ["--reverse", "--move", "trapezoid"]]))
def test_fuzz_size_options(options, move):
    argv = ["size", "thesis-fourbar", "--out", "s.csv"] + move
    if "--motors" not in options:
        argv += ["--motors", "maxon-re40-148877,maxon-re25-118752"]  # two data sets keep an example short
    if "--supply" not in options:
        argv += ["--supply", "48"]
    for flag, value in options.items():
        argv += [flag, value]
    check_cli("options: size", argv, {}, ("s.csv",), allow_inf=True)


@examples(30)
@given(st.lists(st.tuples(st.sampled_from(["link2.a", "link3.m", "drive.torque", "gravity", "drive_joint",
                                           "initial.theta2_d", "nosuch", ""]),
                          st.one_of(number_text(), st.sampled_from(["0.1:0.2:2", "1:2:0", "1:2:1e12", "a:b:c",
                                                                    "1,2,3", "theta2,theta3", ","]))),
                min_size=1, max_size=2),
       st.sampled_from([[], ["--scheduler", "tcp://127.0.0.1"], ["--scheduler", "nohost"], ["--workers", "0"]]))
def test_fuzz_sweep_options(axes, extra):
    argv = ["sweep", "thesis-fourbar", "--t-end", "0.02", "--workers", "1", "--out", "w.csv"] + extra
    for name, values in axes:
        argv += ["--set", f"{name}={values}"]
    check_cli("options: sweep", argv, {}, ("w.csv",))


def animate_value(flag: str) -> st.SearchStrategy[str]:
    # valid values stay small (a few frames): a long film is a long job, not bad input
    plausible = {"--fps": st.floats(0.5, 20.0), "--speed": st.floats(0.5, 5.0), "--t-end": st.floats(1e-3, 0.1),
                 "--torque": st.floats(-50, 50)}.get(flag)
    special = st.sampled_from(["tip", "link3:0.4,0", "link9:0,0", "link3:nan,0", "link3:0.4", "link2:1e300,0"])
    nasty = st.sampled_from(NASTY_TEXT)
    return st.one_of(plausible.map(repr), nasty) if plausible is not None else st.one_of(special, nasty)


@examples(25)
@given(st.sampled_from(["--fps", "--speed", "--t-end", "--torque", "--trace"]).flatmap(
    lambda flag: st.tuples(st.just(flag), animate_value(flag))).map(lambda x: [x]).flatmap(
    lambda first: st.lists(st.sampled_from(["--fps", "--speed", "--t-end", "--torque", "--trace"]).flatmap(
        lambda flag: st.tuples(st.just(flag), animate_value(flag))), max_size=2).map(lambda more: first + more)))
def test_fuzz_animate_options(options):
    options = dict(options)
    argv = ["animate", "thesis-fourbar", "--out", "a.gif"]
    if "--t-end" not in options:
        argv += ["--t-end", "0.05"]
    if "--fps" not in options:
        argv += ["--fps", "10"]
    for flag, value in options.items():
        argv += [flag, value]
    check_cli("options: animate", argv, {}, ("a.gif",))


@examples(90)
@given(ssd_text(), st.lists(st.tuples(st.sampled_from(["--t-end", "--step", "--dt-out"]), number_text()),
                            max_size=2))
def test_fuzz_ssd_files(text, options):
    argv = ["cosim", "s.ssd"]
    for flag, value in options:
        argv += [flag, value]
    check_cli("system (SSD)", argv, {"s.ssd": text.encode("utf-8", "surrogatepass"),
                                     "A.fmu": b"PK\x05\x06" + b"\0" * 18})


@examples(45)
@given(ssp_archive())
def test_fuzz_ssp_archives(data):
    check_cli("system (SSP archive)", ["cosim", "s.ssp"], {"s.ssp": data})


@examples(40)
@given(run_csv(), st.booleans())
def test_fuzz_report_csv(data, with_scene):
    argv = ["report", "r.csv", "--out", "r.png"] + (["--scene", "thesis-fourbar"] if with_scene else [])
    check_cli("run CSV: report", argv, {"r.csv": data}, ("r.png",))


@examples(25)
@given(run_csv())
def test_fuzz_animate_csv(data):
    check_cli("run CSV: animate", ["animate", "r.csv", "--scene", "thesis-fourbar", "--out", "a.gif", "--fps", "4"],
              {"r.csv": data}, ("a.gif",))


@pytest.mark.skipif(PROFILE != "ci", reason="the long profile draws the loaded modules' constants too, on purpose")
def test_what_is_drawn_does_not_depend_on_the_modules_earlier_tests_loaded(tmp_path):
    # Hypothesis takes into its pool the constants of every local module loaded in the process: a module with
    # constants of its own, loaded as if by an earlier test, must add none to what the CI profile draws from
    from hypothesis.internal.conjecture import providers

    (tmp_path / "loaded_by_an_earlier_test.py").write_text("A = 987654.3125\nB = -0.015625\nC = 31337\n")
    sys.path.insert(0, str(tmp_path))
    try:
        import loaded_by_an_earlier_test  # noqa: F401

        assert len(providers._get_local_constants()) == 0
    finally:
        sys.path.remove(str(tmp_path))
        sys.modules.pop("loaded_by_an_earlier_test", None)
