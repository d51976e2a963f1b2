"""The package's import graph: no cycles, and no layer imports one above it.

Every import statement counts, those inside functions too: a deferred import
hides a cycle from Python's loader, not from a reader. The layers, lowest
first, are the table below; docs/architecture.md draws them.
"""

import ast
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# (layer, the modules and folders in it), lowest first. A module may import its
# own folder and any lower layer; within a layer, only its own folder (the base
# and front layers are loose modules, which may import each other).
LAYERS = [
    ("base", ["grubler._version", "grubler.errors", "grubler.limits", "grubler.records", "grubler.quantities",
              "grubler.binding"]),
    ("mechanism", ["grubler.mechanism", "grubler.motors"]),
    ("views", ["grubler.views"]),
    ("fmi", ["grubler.fmi"]),
    ("system", ["grubler.system"]),
    ("controllers", ["grubler.controllers"]),
    ("studies", ["grubler.studies"]),
    ("front", ["grubler", "grubler.cli", "grubler.app"]),
]


def modules() -> dict[str, Path]:
    """Every module of the installed layout, by dotted name, from pyproject's package-dir."""
    dirs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
    found = {}
    for pkg, folder in sorted(dirs.items(), key=lambda kv: -len(kv[0])):
        for f in (ROOT / folder).rglob("*.py"):
            parts = list(f.relative_to(ROOT / folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found.setdefault(".".join([pkg, *parts]), f)
    return found


def imports(name: str, path: Path, known) -> set[str]:
    """The grubler modules ``name`` imports, wherever in the file."""
    is_pkg = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.split(".")[0] == "grubler")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_pkg else name.split(".")[:-1]
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "grubler":
                continue
            for a in node.names:  # 'from grubler.system import cosim' imports the module cosim
                out.add(f"{target}.{a.name}" if f"{target}.{a.name}" in known else target)
    return {m for m in out if m in known and m != name}


def graph():
    known = modules()
    return {name: imports(name, path, known) for name, path in known.items()}


def layer_of(name: str) -> tuple[int, str]:
    """(layer index, the folder that places it) for a module."""
    best = None
    for k, (_, members) in enumerate(LAYERS):
        for m in members:
            if (name == m or name.startswith(m + ".")) and (best is None or len(m) > len(best[1])):
                best = (k, m)
    assert best is not None, f"{name} is in no layer: add it to LAYERS"
    return best


def cycles(edges) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_every_module_is_in_a_layer():
    for name in modules():
        layer_of(name)


def test_no_import_cycles():
    assert cycles(graph()) == []


def test_no_module_imports_a_layer_above_it_or_a_sibling_folder():
    bad = []
    for src, targets in graph().items():
        (ls, fs) = layer_of(src)
        for dst in targets:
            (ld, fd) = layer_of(dst)
            # the base and front layers are loose modules; elsewhere a layer's
            # folders (mechanism and motors) stay apart
            if ld > ls or (ld == ls and fd != fs and LAYERS[ls][0] not in ("base", "front")):
                bad.append(f"{src} ({LAYERS[ls][0]}) imports {dst} ({LAYERS[ld][0]})")
    assert bad == []


def test_the_checks_catch_what_they_are_for():
    # the test's own machinery, on a graph made to break each rule
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert layer_of("grubler.views.report") > layer_of("grubler.mechanism.scene")
    assert layer_of("grubler.motors.dc_motor")[0] == layer_of("grubler.mechanism.model")[0]
    known = modules()
    src = ROOT / "fmu_src" / "mechanism" / "model.py"
    assert "grubler.errors" in imports("grubler.mechanism.model", src, known)


def test_every_folder_says_what_lives_there_and_what_it_may_import():
    for name, path in modules().items():
        if path.name == "__init__.py" and name != "grubler":
            doc = ast.get_docstring(ast.parse(path.read_text())) or ""
            assert "May import" in doc or "may import" in doc, f"{name}: its docstring names no allowed imports"


# -- who calls C ---------------------------------------------------------------------------------------------
# The compiled library (grubler._kernel) is loaded once, by grubler.binding.library.  Each family of C
# functions is declared in one module and called only by the Python face of what it computes
# (docs/architecture.md, "Who calls C", says the same and a test below holds the page to it):
C_FAMILIES = {
    "grb": ("grubler.binding", ["grubler.binding", "grubler.mechanism", "grubler.system.cosim"]),
    "dcm": ("grubler.motors.native", ["grubler.motors"]),
    "ctl": ("grubler.controllers.native", ["grubler.controllers"]),
}


def c_calls(path: Path) -> set[str]:
    """The C families a module calls: an attribute ``lib.grb_...``, or a name ``'ctl_...'`` handed to a
    ``call`` (C text a module writes, a generated file's names, is no call)."""
    import re

    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = [node.attr] if isinstance(node, ast.Attribute) else []
        if isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) \
                and getattr(node.func, "attr", getattr(node.func, "id", "")) == "call":
            names.append(str(node.args[0].value))
        for name in names:
            m = re.fullmatch(r"(grb|dcm|ctl)_[a-z0-9_]+", name)
            if m:
                out.add(m.group(1))
    return out


def test_each_c_family_is_called_only_by_its_own_face():
    bad = []
    for name, path in modules().items():
        for family in c_calls(path):
            _, callers = C_FAMILIES[family]
            if not any(name == c or name.startswith(c + ".") for c in callers):
                bad.append(f"{name} calls {family}_* functions")
    assert bad == []


def test_only_the_binding_loads_the_compiled_library():
    loaders = [name for name, path in modules().items() if 'find_spec("grubler._kernel")' in path.read_text()]
    assert loaders == ["grubler.binding"]
    for family, (declarer, _) in C_FAMILIES.items():
        assert "_SIGNATURES" in modules()[declarer].read_text(), family


def test_the_architecture_page_says_who_calls_c():
    page = " ".join((ROOT / "docs" / "architecture.md").read_text().split())
    for family, (declarer, callers) in C_FAMILIES.items():
        assert f"`{family}_*`" in page and f"`{declarer}`" in page, family
        for c in callers:
            assert f"`{c}`" in page, (family, c)
    assert "only caller of C" not in page


# fmpy keeps one process-wide logging proxy (fmpy/logging's static s_logger): simulate_fmu(logger=...) and
# instantiate_fmu(logger=...) point it at the run's own ctypes callback, which is freed when the run ends, so
# the next FMU that logs through fmpy's default callbacks calls freed memory, in whatever test comes later (a
# segmentation fault in CI's run of test_system_fmu, after test_change_points had done it). A logger goes to
# FMU2Slave.instantiate in its own callbacks (tests/fmi_child.recording_callbacks, grubler.system.instance).
PROXY_TAKERS = {"simulate_fmu", "instantiate_fmu"}


def proxy_hijacks(source: str, where: str) -> list[str]:
    """The calls in ``source`` that hand fmpy's process-wide logging proxy a callback of their own."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
        if name == "addLoggerProxy" or (name in PROXY_TAKERS and any(k.arg == "logger" for k in node.keywords)):
            found.append(f"{where}:{node.lineno} {name}")
    return found


def test_nothing_hands_fmpys_process_wide_logging_proxy_a_callback_that_dies():
    assert proxy_hijacks("import fmpy\nfmpy.simulate_fmu('a.fmu', logger=print)\n", "x") == ["x:2 simulate_fmu"]
    assert proxy_hijacks("from fmpy.logging import addLoggerProxy\naddLoggerProxy(c)\n", "x") == ["x:2 addLoggerProxy"]
    assert proxy_hijacks("fmpy.simulate_fmu('a.fmu', fmi_call_logger=print)\n", "x") == []
    bad = []
    for folder in ("fmu_src", "tests", "benchmarks", "examples", "motors", "controllers"):
        for f in sorted((ROOT / folder).rglob("*.py")):
            if f.name != "test_process_state.py":  # (it hands the proxy a run's callback to see it refused)
                bad += proxy_hijacks(f.read_text(), str(f.relative_to(ROOT)))
    assert bad == []
