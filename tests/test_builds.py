"""The suite's build cache (tests/builds.py): a rerun reuses a build, a changed source does not."""

import shutil
import zipfile
from pathlib import Path

import pytest

import builds


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    """A copy of what goes into an FMU (builds.PACKAGE_SOURCES), to change byte by byte."""
    root = tmp_path_factory.mktemp("checkout")
    for rel in builds.PACKAGE_SOURCES:
        src = builds.ROOT / rel
        if src.is_file():
            shutil.copy2(src, root / rel)
        else:
            shutil.copytree(src, root / rel, ignore=shutil.ignore_patterns("__pycache__", "*.so", "*.pyc"))
    return root


def test_the_key_is_the_sources_not_where_they_lie(package):
    assert builds.tree_digest(package) == builds.tree_digest(builds.ROOT)


# a C source, a header, the exporter that writes modelDescription.xml, a preset, the build script
@pytest.mark.parametrize("rel", ["fmu_src/kernel/integrate.c", "fmu_src/kernel/grubler.h", "fmu_src/fmi/description.py",
                                 "fmu_src/fmi/c/fmi2_wrapper.c",
                                 "fmu_src/presets/thesis-fourbar.toml", "motors/kernel/dc_motor.c",
                                 "controllers/kernel/ctl_pid.c", "build_fmu.py"])
def test_a_changed_source_misses_the_cache(package, rel):
    path = package / rel
    assert path.is_file(), f"{rel} is gone: name another file of its kind here"
    before, text = builds.tree_digest(package), path.read_bytes()
    try:
        path.write_bytes(text + b"\n")
        assert builds.tree_digest(package) != before
    finally:
        path.write_bytes(text)
    assert builds.tree_digest(package) == before


def test_a_new_or_renamed_source_misses_the_cache(package):
    before = builds.tree_digest(package)
    extra = package / "fmu_src" / "kernel" / "extra.c"
    extra.write_text("int x;\n")
    try:
        assert builds.tree_digest(package) != before
        extra.rename(extra.with_name("other.c"))
        assert builds.tree_digest(package) not in (before, builds.tree_digest(package.parent / "nothing"))
    finally:
        for name in ("extra.c", "other.c"):
            (package / "fmu_src" / "kernel" / name).unlink(missing_ok=True)
    assert builds.tree_digest(package) == before


def test_build_products_beside_the_sources_are_not_sources(package):
    before = builds.tree_digest(package)
    (package / "fmu_src" / "_kernel.cpython-311-x86_64-linux-gnu.so").write_bytes(b"\x7fELF")
    (package / "fmu_src" / "__pycache__").mkdir(exist_ok=True)
    (package / "fmu_src" / "__pycache__" / "cli.cpython-311.pyc").write_bytes(b"pyc")
    assert builds.tree_digest(package) == before


def test_other_compiler_flags_miss_the_cache(monkeypatch):
    from grubler.fmi import build

    before = builds.toolchain()
    monkeypatch.setattr(build, "CFLAGS", [*build.CFLAGS, "-ffast-math"])
    builds.toolchain.cache_clear()
    try:
        assert builds.toolchain() != before
    finally:
        monkeypatch.undo()
        builds.toolchain.cache_clear()
    assert builds.toolchain() == before
    assert builds.host_key(2, ("-O2",)) != builds.host_key(2, ("-O1",)) != builds.host_key(3, ("-O1",))


def test_a_changed_file_in_an_fmus_sources_misses_the_sanitizer_cache(tmp_path):
    (tmp_path / "model.c").write_text("int f(void) { return 1; }\n")
    (tmp_path / "model.h").write_text("int f(void);\n")
    before = builds.folder_digest(tmp_path)
    (tmp_path / "model.h").write_text("int f(void); \n")
    assert builds.folder_digest(tmp_path) != before


def test_a_key_is_built_once_then_reused_and_another_key_is_built_afresh(tmp_path, monkeypatch):
    monkeypatch.setattr(builds, "CACHE", tmp_path / "cache")
    made = []

    def make(d: Path) -> Path:
        made.append(d)
        (d / "M.fmu").write_text(f"build {len(made)}")
        return d / "M.fmu"

    first = builds.cached("M-fmi2", builds.digest("sources 1"), make)
    again = builds.cached("M-fmi2", builds.digest("sources 1"), make)
    assert first == again and first.read_text() == "build 1" and len(made) == 1
    other = builds.cached("M-fmi2", builds.digest("sources 2"), make)
    assert other != first and other.read_text() == "build 2" and len(made) == 2


def test_a_failed_build_leaves_no_entry(tmp_path, monkeypatch):
    monkeypatch.setattr(builds, "CACHE", tmp_path / "cache")

    def fail(d: Path) -> Path:
        (d / "M.fmu").write_text("half")
        raise RuntimeError("cc failed")

    with pytest.raises(RuntimeError, match="cc failed"):
        builds.cached("M-fmi2", builds.digest("sources"), fail)
    assert list((tmp_path / "cache").iterdir()) == []


def test_only_the_newest_keys_of_a_kind_are_kept(tmp_path, monkeypatch):
    import os

    monkeypatch.setattr(builds, "CACHE", tmp_path / "cache")
    for k in range(builds.KEEP + 2):
        path = builds.cached("M-fmi2", builds.digest(k), lambda d: d / "M.fmu")
        os.utime(path.parent, (k * 1000, k * 1000))  # in the order they were built
    builds.cached("Other-fmi2", builds.digest(0), lambda d: d / "O.fmu")
    builds.prune("M-fmi2")
    kept = sorted(p.name for p in (tmp_path / "cache").iterdir())
    assert kept == sorted([f"M-fmi2-{builds.digest(k)[:24]}" for k in range(2, builds.KEEP + 2)]
                          + [f"Other-fmi2-{builds.digest(0)[:24]}"])


def test_dist_gives_what_build_fmu_gives(tmp_path):
    # the cached Mechanism.fmu, copied where build_fmu.build would have written it
    (path,) = builds.dist(tmp_path / "dist", ["Mechanism"])
    assert path == tmp_path / "dist" / "Mechanism.fmu" and path.read_bytes() == builds.fmu("Mechanism").read_bytes()
    with pytest.raises(SystemExit, match="no FMU named Nope"):
        builds.dist(tmp_path / "dist", ["Nope"])
    # build_fmu's LinearController is native now: its FMI 3.0 build is one too (it was refused, pythonfmu being FMI 2)
    (linear,) = builds.dist(tmp_path / "fmi3", ["LinearController"], fmi=3)
    assert 'fmiVersion="3.0"' in zipfile.ZipFile(linear).read("modelDescription.xml").decode()


# the optional test dependencies (pyproject's test extra) a checkout may lack
OPTIONAL = ("hypothesis", "playwright", "libcosimpy", "dask", "distributed", "pyarrow")
WITHOUT_OPTIONAL = f"""
import importlib.abc, sys
class Absent(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {OPTIONAL!r}:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
sys.meta_path.insert(0, Absent())
import pytest
sys.exit(pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", "tests"]))
"""


def test_the_suite_collects_without_the_optional_test_dependencies():
    # --doctest-modules imports every module under tests/: the helpers that import
    # hypothesis or libcosimpy at the top are no tests (conftest.collect_ignore)
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1"}  # hypothesis' own pytest plugin is absent too
    proc = subprocess.run([sys.executable, "-c", WITHOUT_OPTIONAL], capture_output=True, text=True, timeout=600,
                          cwd=builds.ROOT, env=env)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]  # 2: errors during collection
    # test_fuzz.py collects no test (its skip, with -rs, says why in the summary)
    assert "tests/test_builds.py: " in proc.stdout and "tests/test_fuzz.py: " not in proc.stdout
