"""FMUs from control laws: the shared pythonfmu slave, and a builder for your own law.

Every controller FMU of the project is a thin :class:`LawSlave` subclass naming
its :class:`~grubler.controllers.law.Law`; the slave declares the law's inputs,
outputs and parameters as FMI variables and runs it with the
:class:`~grubler.controllers.law.Sampler` (the sample-and-hold semantics are
documented there).  It logs every error and reports it as a failed call instead
of raising into the importer, and its FMU state holds the law's whole state
(a noise generator's included), so a master can roll back.

Writing your own controller
---------------------------
Put a :class:`~grubler.controllers.law.Law` subclass in a module file (not in
``__main__``)::

    # mylaw.py
    from grubler.controllers import Law, Parameter

    class BangBang(Law):
        \"\"\"Two-level output with hysteresis.\"\"\"
        inputs = {"error": "control error [rad]"}
        outputs = {"u": "output [V]"}
        parameters = {"level": Parameter(12.0, "output level [V]"),
                      "band": Parameter(0.01, "hysteresis half-band [rad]"),
                      "Ts": Parameter(1e-3, "sample time [s]")}

        def __init__(self, level=12.0, band=0.01, Ts=1e-3):
            self.level, self.band, self.Ts = level, band, Ts
            self.on = False                      # state: saved and restored by the FMU

        def update(self, t, inputs):
            e = inputs["error"]
            if abs(e) > self.band:
                self.on = e > 0
            return {"u": self.level if self.on else -self.level}

then ``build_controller_fmu(BangBang, "dist")`` writes ``dist/BangBang.fmu``.
Descriptions end with the unit in square brackets; parameter types follow their
defaults (float: Real, int: Integer, bool: Boolean, str: String).  Errors in the
constructor (say a :class:`grubler.SceneError` naming the parameter) are
reported at initialisation; exceptions in ``update`` fail that step.  The
default ``get_state``/``set_state`` deep-copy the instance's attributes; override
them if some attribute cannot be copied.
"""

from __future__ import annotations

import hashlib
import importlib
import math
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from importlib import resources
from pathlib import Path

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Status

from grubler._version import __version__
from grubler.controllers.law import Law, Sampler
from grubler.errors import SceneError
from grubler.system.fmi_slave import ProjectSlave
from grubler.system.fmu_loader import package_files, tree_digest

_TYPES = ((bool, Boolean), (int, Integer), (float, Real), (str, String))


def _variable_type(value):
    for py, fmi in _TYPES:
        if isinstance(value, py):
            return fmi
    raise TypeError(f"parameter default {value!r}: an FMU parameter is a float, int, bool or str")


class LawSlave(ProjectSlave):
    """FMI 2.0 co-simulation slave running a :class:`Law` (subclass it and set ``law``)."""

    law: type[Law] = Law
    author = "grubler"
    version = __version__

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        law = type(self).law
        self.description = (law.__doc__ or law.__name__).strip().splitlines()[0]
        top = law.__module__.split(".")[0]
        if top not in self.build_modules and top != "__main__":  # the law's own code identifies a state too
            self.build_modules = {**self.build_modules, top: ()}
        self._inputs = {name: 0.0 for name in law.inputs}
        self._overrides: dict[str, object] = {}
        self._sampler: Sampler | None = None
        self._time = 0.0
        try:  # the defaults' initial outputs are the outputs' start values
            self._initial = Sampler(law.from_parameters(), 0.0).outputs
        except Exception:  # a law without defaults for every parameter
            self._initial = {name: 0.0 for name in law.outputs}
        par, fixed = Fmi2Causality.parameter, Fmi2Variability.fixed
        for name, p in law.parameters.items():
            kind = _variable_type(p.fmu_start)
            self.register_variable(kind(name, causality=par, variability=fixed, description=p.description,
                                        getter=lambda n=name: self._parameter(n),
                                        setter=lambda v, n=name: self._overrides.__setitem__(n, v)))
        for name, text in law.inputs.items():
            self.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                        description=text, getter=lambda n=name: self._inputs[n],
                                        setter=lambda v, n=name: self._inputs.__setitem__(n, float(v))))
        for name, text in law.outputs.items():
            self.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                        initial=Fmi2Initial.exact, description=text,
                                        getter=lambda n=name: self._output(n)))

    def feedthrough(self) -> dict[str, list[str]]:
        """Inputs each output depends on at the same instant: none.

        An output read at ``t + h`` comes from samples taken before ``t + h`` on
        the inputs held since ``t`` (see :class:`~grubler.controllers.law.Sampler`),
        so to a master every output is a state, and a feedback loop through a
        controller is never algebraic; the model description of every FMU
        built from a law says so (:class:`grubler.system.fmi_slave.DeclaredDependencies`).
        """
        return {name: [] for name in type(self).law.outputs}

    def _parameter(self, name: str):
        if name in self._overrides:
            return self._overrides[name]
        return type(self).law.parameters[name].fmu_start

    def _output(self, name: str) -> float:
        outputs = self._sampler.outputs if self._sampler is not None else self._initial
        return float(outputs.get(name, math.nan))

    # -- set-up ----------------------------------------------------------------
    def exit_initialization_mode(self):
        try:
            law = type(self).law.from_parameters(**self._overrides)
            self._sampler = Sampler(law, self._start_time)
            self._time = self._start_time
        except Exception as exc:  # noqa: BLE001 - a user's law may raise anything; the importer must not see it
            self._sampler = None
            # the instance stays alive; the base refuses every step with this message
            self._fail(f"initialisation failed: {_describe(exc)}")

    # -- stepping ----------------------------------------------------------------
    def do_step(self, current_time: float, step_size: float) -> bool:
        # the base lets a step through only after a successful initialisation
        if abs(current_time - self._time) > 1e-9 * max(1.0, abs(self._time)):
            self._refused(f"doStep at t = {current_time:.12g} s, but the controller is at t = {self._time:.12g} s "
                         "(restore a saved FMU state to roll back)")
            return False
        try:
            self._sampler.step(current_time, step_size, self._inputs)
        except Exception as exc:  # noqa: BLE001 - logged and reported as fmi2Discard, never raised
            self.log(f"step from t = {current_time:g} s failed: {_describe(exc)}", Fmi2Status.discard)
            return False
        self._time = current_time + step_size
        return True

    # -- state -------------------------------------------------------------------
    def _save_state(self):
        return {"sampler": None if self._sampler is None else self._sampler.get_state(),
                "inputs": dict(self._inputs), "time": self._time}

    def _load_state(self, state):
        # the base calls this only after initialisation, with a state of this FMU and parameters
        if state["sampler"] is not None:
            self._sampler.set_state(state["sampler"])
        self._inputs.update({name: float(v) for name, v in state["inputs"].items() if name in self._inputs})
        self._time = float(state["time"])


def _describe(exc: Exception) -> str:
    return str(exc) if isinstance(exc, (SceneError, ValueError)) else f"{type(exc).__name__}: {exc}"


# -- building -------------------------------------------------------------------
SLAVE_TEMPLATE = '''\
"""FMU slave of {module}.{name}, generated by grubler.controllers.fmu.build_controller_fmu."""

import importlib

# this FMU's own copies of the modules it runs (in resources/, first on sys.path),
# or an identical copy already loaded, never another: see grubler.system.fmu_loader
importlib.import_module({loader!r}).prepare({script!r}, {expected!r})

from grubler.controllers.fmu import LawSlave  # noqa: E402
from grubler.system.fmi_slave import balance_loader_reference  # noqa: E402
from {module} import {name} as _Law  # noqa: E402

balance_loader_reference(globals())  # pythonfmu 0.7's loader, see grubler.system.fmi_slave


class {name}(LawSlave):
    law = _Law


# pythonfmu runs this text again at every instantiation, in the namespace of the
# module it imported first, and takes the class from that module: this one
globals()[{name!r}] = {name}
'''

# grubler's subpackages that a source checkout keeps outside the package folder
SUBPACKAGES = ("motors", "controllers")


def _package_files(root=None) -> dict:
    """The files of the grubler package (motors and controllers included), by relative path."""
    import grubler.controllers
    import grubler.motors

    if root is None:
        root = Path(str(resources.files("grubler")))  # the package folder, wherever it is installed
        subs = {"motors": Path(grubler.motors.__file__).parent,
                "controllers": Path(grubler.controllers.__file__).parent}
    else:
        subs = {name: Path(root) / name for name in SUBPACKAGES}
    return package_files(root, subs)


def stage_package(folder: Path) -> Path:
    """Copy the grubler package (with its motors and controllers) into ``folder``; return its path.

    Works from a source checkout (where ``grubler.motors`` and
    ``grubler.controllers`` live in folders of their own) and from an installed
    package alike; the copy lists the same files (:func:`grubler.system.fmu_loader.package_files`),
    so it has the same content digest as the package it was copied from.
    """
    package = Path(folder) / "grubler"
    for rel, path in _package_files().items():
        target = package / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(path, target)
    return package


def compile_status_wrapper(dest: Path) -> Path:
    """Compile ``status_wrapper.c`` (beside this module) into the shared library ``dest`` (linux64).

    Raises
    ------
    SceneError
        No C compiler, or the compilation failed (its output in the message).
    """
    import fmpy

    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        raise SceneError("build", "a C compiler (cc or gcc, or $CC) is needed to build a controller FMU")
    source = Path(__file__).with_name("status_wrapper.c")
    headers = Path(fmpy.__file__).parent / "c-code"
    cmd = [cc, "-shared", "-fPIC", "-O2", "-std=c99", f"-I{headers}", str(source), "-o", str(dest), "-ldl"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SceneError("build", f"compiling {source.name} failed: {proc.stderr.strip()[:2000]}")
    return Path(dest)


def _wrap_binary(fmu: Path, model_identifier: str, tmp: Path) -> None:
    """Put the status wrapper in front of pythonfmu's linux64 binary inside ``fmu``.

    The win64 binary stays pythonfmu's own (no wrapper is built for it here:
    its statuses are pythonfmu's, fmi2OK or fmi2Fatal outside doStep).
    """
    inner = f"binaries/linux64/{model_identifier}.so"
    wrapped = f"binaries/linux64/{model_identifier}_pythonfmu.so"
    wrapper = compile_status_wrapper(tmp / "wrapper.so")
    rebuilt = tmp / "rebuilt.fmu"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(rebuilt, "w", zipfile.ZIP_DEFLATED) as dst:
        names = src.namelist()
        if inner not in names:
            raise SceneError("build", f"pythonfmu wrote no {inner} into {fmu.name}")
        for info in src.infolist():
            data = src.read(info)
            dst.writestr(wrapped if info.filename == inner else info, data)
        dst.write(wrapper, inner)
    shutil.move(str(rebuilt), str(fmu))


def build_controller_fmu(law: type[Law], dest: str | Path = "dist") -> Path:
    """Build an FMU (FMI 2.0 co-simulation) from a control law class.

    Parameters
    ----------
    law : type
        A :class:`~grubler.controllers.law.Law` subclass defined in an
        importable module file (its module is bundled into the FMU; a module
        inside a package brings its whole top-level package).
    dest : str or Path
        Folder for the FMU, or a path ending in ``.fmu``.

    Returns
    -------
    Path
        The FMU, named after the class (``dest/<ClassName>.fmu``).  Its slave
        script is ``law_<module>_<ClassName>_<digest>.py``, unique per law and
        per content of what it bundles, so FMUs of different laws load side by
        side in one process, and two builds of one law never share a module.

    Raises
    ------
    SceneError
        A class that is not a Law, or one that cannot be imported by name; no
        C compiler for the status wrapper.
    """
    from pythonfmu.builder import FmuBuilder

    if not (isinstance(law, type) and issubclass(law, Law)):
        raise SceneError("law", f"must be a subclass of grubler.controllers.Law, got {law!r}")
    module_name = law.__module__
    if module_name == "__main__":
        raise SceneError("law", f"{law.__name__} is defined in __main__; put it in a module file the FMU can import")
    module = sys.modules.get(module_name) or importlib.import_module(module_name)
    source = getattr(module, "__file__", None)
    if source is None:
        raise SceneError("law", f"module {module_name} has no file to bundle")
    top = module_name.split(".")[0]
    if "." in module_name:
        bundle = Path(sys.modules[top].__file__).parent  # the whole top-level package
    else:
        bundle = Path(source)
    dest = Path(dest)
    target = dest if dest.suffix == ".fmu" else dest / f"{law.__name__}.fmu"
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="grubler_law_") as tmp:
        tmp = Path(tmp)
        package = stage_package(tmp / "pkg")
        digest = tree_digest(_package_files(package))
        expected = {"grubler": (digest, SUBPACKAGES)}
        files = [package]
        if top != "grubler":
            expected[top] = (tree_digest(package_files(bundle)), ())
            files.insert(0, bundle)
        build = hashlib.sha256(repr(sorted(expected.items())).encode()).hexdigest()[:16]
        script = tmp / f"law_{module_name.replace('.', '_')}_{law.__name__}_{build}.py"
        loader = tmp / f"_grubler_loader_{digest[:16]}.py"
        shutil.copy2(package / "system" / "fmu_loader.py", loader)
        files.append(loader)
        script.write_text(SLAVE_TEMPLATE.format(module=module_name, name=law.__name__, loader=loader.stem,
                                                script=script.stem, expected=expected))
        path = Path(FmuBuilder.build_FMU(script, dest=target, project_files=files,
                                         canGetAndSetFMUstate=True, canSerializeFMUstate=True))
        sys.modules.pop(script.stem, None)
        _wrap_binary(path, law.__name__, tmp)
    return path


__all__ = ["LawSlave", "build_controller_fmu", "compile_status_wrapper", "stage_package", "SLAVE_TEMPLATE"]
