"""The API reference: every public name documented with an example, and the builder writes them all.

Public is what :data:`grubler.apidoc.PUBLIC_MODULES` lists, each module's
``__all__``. The examples themselves run as doctests (``--doctest-modules``
over fmu_src, motors and controllers); here we check that they are there.
"""

import importlib
import inspect

import pytest

from grubler import apidoc

# the public names whose examples need the built FMUs (python3 build_fmu.py) or compile one: their
# examples are marked +SKIP; any other skipped example is a placeholder and fails. Name -> why, and
# the test that runs what the example shows (each name's behaviour is held there, not in its docstring)
NEEDS_BUILT_FMUS = {
    # tests/test_servo.py::test_sizing_predicts_the_closed_loop_current_within_10_percent (size --check)
    "grubler.studies.sizing_check.closed_loop_check": "co-simulates the servo system of the built FMUs (python3 build_fmu.py)",
    # tests/test_cylinder_sizing.py::test_the_winner_is_checked_by_co_simulation
    "grubler.studies.cylinder_sizing.cylinder_check": "co-simulates HydraulicCylinder, PID and Trajectory FMUs",
    # tests/test_container.py::test_what_the_exported_fmu_shows_and_how_its_engine_is_told (the settled starts)
    "grubler.system.cosim.initial_inputs": "instantiates and initialises every FMU: their binaries, two compiles",
    # tests/test_cylinder_systems.py::test_the_system_settles_on_its_setpoint (and the two tests after it)
    "grubler.system.cylinder_servo.cylinder_servo_system": "exports the scene's own mechanism FMU: 5 to 8 s",
    # tests/test_native_fmu.py::test_export_an_open_chain_and_run_it
    "grubler.fmi.build.export": "compiles the mechanism kernel with its complex-step twins: 5 to 8 s here",
}


def undocumented(module) -> list[str]:
    """The public names of ``module`` without a docstring or without a ``>>>`` example in it."""
    bad = []
    for name in apidoc.public_names(module):
        obj = getattr(module, name, None)
        if obj is None:
            bad.append(f"{module.__name__}.{name}: in __all__ but not defined")
        elif not (inspect.isclass(obj) or inspect.isroutine(obj)):
            # a constant has no docstring of its own: its module's examples show it
            if name not in "\n".join(line for line in (module.__doc__ or "").splitlines() if ">>>" in line):
                bad.append(f"{module.__name__}.{name}: a constant no example of the module's docstring uses")
        elif not (inspect.getdoc(obj) or "").strip():
            bad.append(f"{module.__name__}.{name}: no docstring")
        elif ">>>" not in inspect.getdoc(obj):
            bad.append(f"{module.__name__}.{name}: no example (>>>) in its docstring")
        elif "+SKIP" in inspect.getdoc(obj) and f"{obj.__module__}.{name}" not in NEEDS_BUILT_FMUS:
            bad.append(f"{module.__name__}.{name}: its example is skipped, not run")
    return bad


@pytest.mark.parametrize("module_name", apidoc.PUBLIC_MODULES)
def test_every_public_name_has_a_docstring_with_an_example(module_name):
    module = importlib.import_module(module_name)
    assert (module.__doc__ or "").strip(), f"{module_name} has no module docstring"
    assert undocumented(module) == []


def test_the_names_users_were_left_to_find_in_the_source_are_public():
    # the issue: required_drive and DutyCycle were found only by reading the source
    sizing = importlib.import_module("grubler.studies.sizing")
    assert {"required_drive", "DutyCycle"} <= set(apidoc.public_names(sizing))
    assert "grubler.studies.sizing" in apidoc.PUBLIC_MODULES


def test_the_check_names_what_is_missing():
    # a module made to break each rule: the check must say which name and why
    fake = type(importlib)("fake_public")
    fake.__doc__ = "A module.\n\n>>> fake_public.SHOWN\n1\n"

    def bare():
        pass

    def without_example():
        """Does a thing."""

    def with_example():
        """Does a thing.

        >>> with_example()
        """

    def skipped():
        """Does a thing.

        >>> skipped()  # doctest: +SKIP
        """

    fake.bare, fake.without_example, fake.with_example, fake.skipped = bare, without_example, with_example, skipped
    fake.SHOWN, fake.HIDDEN = 1, 2
    fake.__all__ = ["bare", "without_example", "with_example", "skipped", "SHOWN", "HIDDEN", "missing"]
    assert undocumented(fake) == [
        "fake_public.bare: no docstring",
        "fake_public.without_example: no example (>>>) in its docstring",
        "fake_public.skipped: its example is skipped, not run",
        "fake_public.HIDDEN: a constant no example of the module's docstring uses",
        "fake_public.missing: in __all__ but not defined",
    ]
    del fake.__all__
    with pytest.raises(ValueError, match="fake_public is a public module but declares no __all__"):
        apidoc.public_names(fake)


def test_the_builder_writes_every_public_name(tmp_path):
    assert apidoc.main(["-o", str(tmp_path)]) == 0
    index = (tmp_path / "index.md").read_text(encoding="utf-8")
    for module_name in apidoc.PUBLIC_MODULES:
        page = (tmp_path / f"{module_name}.md").read_text(encoding="utf-8")
        assert f"[`{module_name}`]({module_name}.md)" in index
        seen = {}
        for name in apidoc.public_names(importlib.import_module(module_name)):
            assert f"\n## {name}\n" in page, f"{module_name}.{name} missing from its page"
            assert f"[`{name}`]({module_name}.md#{apidoc.anchor(name, seen)})" in index
        assert "```python\n>>> " in page  # the examples come out as code


def test_two_builds_are_the_same_bytes(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    pages_a, pages_b = apidoc.build(a), apidoc.build(b)
    assert [p.name for p in pages_a] == [p.name for p in pages_b]
    for pa, pb in zip(pages_a, pages_b):
        assert pa.read_bytes() == pb.read_bytes(), pa.name
