"""A whole system as one FMU: its FMUs nested in fmpy's container FMU.

``export_system("servo_fourbar.ssd", "ServoFourbar.fmu")`` packs every FMU of
an SSP system, with the system's parameters and connections, into one FMU whose
binary is the container FMU that fmpy ships compiled (Rust; linux, windows,
darwin).  Any FMI importer then runs the system as one model: fmpy, fmusim,
Simulink, Dymola, a C host.

What the container runs
    A fixed-step Jacobi coupling: every nested FMU steps over the communication
    step on the inputs of its start, then each connection copies its output to
    its input (``doFixedStep`` and ``updateConnections`` in fmpy's
    ``native/container-fmu``).  The connections are written in an order that
    reads each output before the inputs it depends on are set, so every step
    is :func:`grubler.system.cosim.run`'s ``master="jacobi"`` exactly.  The
    container knows no Gauss-Seidel order: a loop through it costs the step of
    delay that Jacobi costs everywhere (see docs/cosim.md for how much).

How it differs from fmpy's own writer (``fmpy.container_fmu``, 0.3.32)
    - connections and variables carry FMI 3 type names (``Float64``, ``Int32``),
      which the engine needs: fmpy's writer keeps FMI 2's ``Real`` for
      connections, which the engine refuses ("unknown variant `Real`");
    - value references start at 1: the engine reads reference k as its
      variable k - 1 and keeps 0 for the time (fmpy's writer numbers from 0, so
      an FMI 2 container's first variable cannot be set: fmi2SetReal fails);
      an FMI 3 container declares ``time`` at 0 as its independent variable;
    - the engine propagates the connections once when initialisation ends,
      where a master settles them: the export settles them once (every FMU
      instantiated and initialised here, as a run does) and gives each
      connected input that value as its start, so the one propagation lands
      where :func:`~grubler.system.cosim.run` starts.  A host that changes a
      parameter of the exported FMU which moves that start gets one
      propagation from the old values (export again with the parameter set in
      the system to keep it exact).

Examples
--------
>>> sorted(CONTAINER_TYPES)
['Boolean', 'Enumeration', 'Integer', 'Real', 'String']
"""

from __future__ import annotations

import datetime
import json
import math
import shutil
import uuid
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from grubler._version import __version__
from grubler.errors import InputError, SystemDescriptionError
from grubler.limits import brief, remove_temp_dir, temp_dir
from grubler.system import cosim
from grubler.system.interface import FmuInterface
from grubler.system.ssp import System, read

# a nested FMU's FMI 2 type -> the engine's type name and the FMI 2 / FMI 3 element of the container's variable
CONTAINER_TYPES = {
    "Real": ("Float64", "Real", "Float64"),
    "Integer": ("Int32", "Integer", "Int32"),
    "Enumeration": ("Int32", "Integer", "Int32"),
    "Boolean": ("Boolean", "Boolean", "Boolean"),
    "String": ("String", "String", "String"),
}

# the engine's binaries in fmpy: its folder (the FMI 3 platform), the FMI 2 platform folder, the file
BINARIES = (
    ("x86_64-linux", "linux64", "container_fmu.so"),
    ("x86_64-windows", "win64", "container_fmu.dll"),
    ("x86_64-darwin", "darwin64", "container_fmu.dylib"),
    ("aarch64-darwin", None, "container_fmu.dylib"),  # FMI 2 has one darwin64 folder, given to x86_64
)
FMI2_PLATFORMS = {"x86_64-linux": "linux64", "x86_64-windows": "win64", "x86_64-darwin": "darwin64",
                  "aarch64-darwin": "darwin64"}
IDENTIFIER = "container_fmu"  # the engine's binary name, hence every container's model identifier


class ContainerError(InputError):
    """A system that cannot become one FMU, or an fmpy without the container engine (field, reason).

    Examples
    --------
    >>> import pathlib
    >>> from grubler.system.ssp import System
    >>> s = System("one")
    >>> _ = s.add("move", "Trajectory.fmu")
    >>> try:
    ...     export_system(s, pathlib.Path("one.fmu"), fmi_version=4)
    ... except ContainerError as exc:                 # an InputError: a field and a reason
    ...     print(exc.field, "|", exc.reason)
    fmi_version | must be 2 or 3, got 4
    """


@dataclass(frozen=True)
class Exposed:
    """One variable of the exported FMU: a nested FMU's parameter, unconnected input or output."""

    name: str  # component.variable
    component: int
    vr: int  # the nested FMU's value reference
    type: str  # the nested FMU's FMI 2 type
    causality: str
    variability: str
    start: object  # None for an output
    description: str


def engine() -> tuple[Path, str]:
    """fmpy's container engine: the folder of its binaries and the version its configuration names.

    Raises
    ------
    ContainerError
        When the installed fmpy has no container engine (this module is tested
        with fmpy 0.3.32's).

    Examples
    --------
    >>> folder, version = engine()                 # fmpy's compiled container, for linux, windows and darwin
    >>> (folder / "x86_64-linux").is_dir(), isinstance(version, str)
    (True, True)
    """
    try:
        import fmpy.container_fmu as cf
    except ImportError:
        raise ContainerError("fmpy", "has no container FMU here: exporting a system needs fmpy 0.3.32 or later "
                                     "(pip install -U fmpy)") from None
    folder = Path(cf.__file__).parent / "binaries"
    if not (folder / BINARIES[0][0] / BINARIES[0][2]).is_file() or not hasattr(cf, "__version__"):
        raise ContainerError("fmpy", f"its container FMU binaries are missing from {brief(str(folder))}: "
                                     "exporting a system needs fmpy 0.3.32 or later from PyPI")
    return folder, cf.__version__


def _settable_start(system: System, name: str, var) -> object:
    """A parameter's or an input's value: the system's, else the nested FMU's start."""
    given = system.components[name].parameters.get(var.name)
    return given if given is not None else var.start


def exposed_variables(system: System, interfaces: dict[str, FmuInterface]) -> list[Exposed]:
    """What the exported FMU shows, in the system's order: every parameter, unconnected input and output.

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.system.ssp import System
    >>> from grubler.system.interface import FmuInterface
    >>> from grubler.controllers.native_fmu import pid_spec, trajectory_spec
    >>> from grubler.fmi.description import model_description as description
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> for spec in (pid_spec("PID"), trajectory_spec("Trajectory")):  # their model descriptions are what is read
    ...     with zipfile.ZipFile(d / f"{spec.identifier}.fmu", "w") as z:
    ...         z.writestr("modelDescription.xml", description(spec, []))
    >>> s = System("follow", base=d)
    >>> _ = s.add("pid", "PID.fmu", K=2.0, Ts=0.01)
    >>> _ = s.add("move", "Trajectory.fmu", kind="trapezoid")
    >>> _ = s.connect("move.position", "pid.setpoint")
    >>> itf = {name: FmuInterface.of(d / f"{file}.fmu") for name, file in (("pid", "PID"), ("move", "Trajectory"))}
    >>> shown = {e.name: e for e in exposed_variables(s, itf)}
    >>> shown["pid.K"].causality, shown["pid.K"].start      # the system's value is the exported FMU's default
    ('parameter', 2.0)
    >>> "pid.setpoint" in shown, "pid.measurement" in shown  # a connected input is not shown, a free one is
    (False, True)
    >>> tmp.cleanup()
    """
    connected = {c.end for c in system.connections}
    out = []
    for k, name in enumerate(system.components):
        md = interfaces[name].model_description
        for v in md.modelVariables:
            full = f"{name}.{v.name}"
            if v.type not in CONTAINER_TYPES or v.causality not in ("parameter", "input", "output") or \
                    full in connected:
                continue
            start = None if v.causality == "output" else _settable_start(system, name, v)
            variability = v.variability or ("fixed" if v.causality == "parameter" else "continuous")
            if v.causality == "input" and start is None:
                start = {"Real": 0.0, "Boolean": False, "String": ""}.get(v.type, 0)
            out.append(Exposed(full, k, v.valueReference, v.type, v.causality, variability, start,
                               f"{name}: {v.description}" if v.description else name))
    return out


def _text(value, fmi_type: str) -> str:
    """A start value as the engine parses it (Rust's ``str::parse``) and the XML states it."""
    if fmi_type == "Real":
        x = float(value)
        return repr(x) if math.isfinite(x) else ("NaN" if math.isnan(x) else ("INF" if x > 0 else "-INF"))
    if fmi_type == "Boolean":
        return "true" if (value if isinstance(value, bool) else str(value).lower() in ("true", "1")) else "false"
    if fmi_type in ("Integer", "Enumeration"):
        return str(int(value))
    return str(value)


def execution_tools(system: System) -> list[str]:
    """The components whose FMU needs an execution tool where it runs (a pythonfmu FMU: a Python).

    The exported FMU then needs one too (its ``needsExecutionTool``).

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.system.ssp import System
    >>> from grubler.system.interface import FmuInterface
    >>> from grubler.controllers.native_fmu import pid_spec, trajectory_spec
    >>> from grubler.fmi.description import model_description as description
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> for spec in (pid_spec("PID"), trajectory_spec("Trajectory")):  # their model descriptions are what is read
    ...     with zipfile.ZipFile(d / f"{spec.identifier}.fmu", "w") as z:
    ...         z.writestr("modelDescription.xml", description(spec, []))
    >>> s = System("follow", base=d)
    >>> _ = s.add("pid", "PID.fmu", K=2.0, Ts=0.01)
    >>> _ = s.add("move", "Trajectory.fmu", kind="trapezoid")
    >>> _ = s.connect("move.position", "pid.setpoint")
    >>> itf = {name: FmuInterface.of(d / f"{file}.fmu") for name, file in (("pid", "PID"), ("move", "Trajectory"))}
    >>> execution_tools(s)                  # native FMUs: the exported FMU needs no Python where it runs
    []
    >>> tmp.cleanup()
    """
    return [name for name, comp in system.components.items()
            if FmuInterface.of(system.source_path(comp)).model_description.coSimulation.needsExecutionTool]


def shared_platforms(resources: Path, folders: list[str]) -> set[str]:
    """The platforms (FMI 3 names) on which every nested FMU has a binary: the container's, no others.

    A container binary for a platform where a nested FMU has none would load
    there and fail to instantiate it.
    """
    out = set()
    for platform, fmi2 in FMI2_PLATFORMS.items():
        if all((resources / f / "binaries" / fmi2).is_dir() or (resources / f / "binaries" / platform).is_dir()
               for f in folders):
            out.add(platform)
    return out


def connection_order(system: System, interfaces: dict[str, FmuInterface]) -> list:
    """The connections in an order that reads every output before the inputs it depends on now are set.

    The engine copies the connections one by one after its FMUs stepped, so
    an output read after an input it depends on would be the next instant's
    (a Gauss-Seidel step through it); read before, every output is the one
    the step ended with, as :func:`~grubler.system.cosim.run`'s Jacobi reads it.

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.system.ssp import System
    >>> from grubler.system.interface import FmuInterface
    >>> from grubler.controllers.native_fmu import pid_spec, trajectory_spec
    >>> from grubler.fmi.description import model_description as description
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> for spec in (pid_spec("PID"), trajectory_spec("Trajectory")):  # their model descriptions are what is read
    ...     with zipfile.ZipFile(d / f"{spec.identifier}.fmu", "w") as z:
    ...         z.writestr("modelDescription.xml", description(spec, []))
    >>> s = System("follow", base=d)
    >>> _ = s.add("pid", "PID.fmu", K=2.0, Ts=0.01)
    >>> _ = s.add("move", "Trajectory.fmu", kind="trapezoid")
    >>> _ = s.connect("move.position", "pid.setpoint")
    >>> itf = {name: FmuInterface.of(d / f"{file}.fmu") for name, file in (("pid", "PID"), ("move", "Trajectory"))}
    >>> _ = s.connect("pid.u", "move.delay")                 # not a real loop, only an order to find
    >>> [f"{c.start} -> {c.end}" for c in connection_order(s, itf)]
    ['move.position -> pid.setpoint', 'pid.u -> move.delay']
    >>> tmp.cleanup()
    """
    conns = list(system.connections)

    def feeds_now(c) -> set[str]:  # the inputs (component.input) that c's output depends on at the same instant
        itf = interfaces[c.start_element]
        deps = itf.feedthrough.get(c.start_connector)
        if deps is None:
            deps = {p.name for p in itf.ports.values() if p.causality == "input"}
        return {f"{c.start_element}.{d}" for d in deps}

    before = {i: {j for j, d in enumerate(conns) if d.end in feeds_now(c)} for i, c in enumerate(conns)}
    placed: list[int] = []
    left = list(range(len(conns)))
    while left:
        # the next connection is one that no other unplaced connection must come before
        ready = [i for i in left if not any(i in before[j] for j in left if j != i)]
        if not ready:
            loop = "; ".join(f"{conns[i].start} -> {conns[i].end}" for i in left)
            raise SystemDescriptionError(f"algebraic loop: every output on it depends on an input at the same "
                                         f"instant: {loop}")
        placed.append(ready[0])
        left.remove(ready[0])
    return [conns[i] for i in placed]


def configuration(system: System, interfaces: dict[str, FmuInterface], exposed: list[Exposed], step: float,
                  paths: dict[str, str], token: str, version: str, initial: dict[str, float]) -> dict:
    """The engine's ``resources/container.json``.

    Parameters
    ----------
    paths : dict
        Each component's folder under ``resources/``.
    initial : dict
        The settled values of the connected inputs (:func:`grubler.system.cosim.initial_inputs`):
        given as starts of variables the model description does not show, after its own.

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.system.ssp import System
    >>> from grubler.system.interface import FmuInterface
    >>> from grubler.controllers.native_fmu import pid_spec, trajectory_spec
    >>> from grubler.fmi.description import model_description as description
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> for spec in (pid_spec("PID"), trajectory_spec("Trajectory")):  # their model descriptions are what is read
    ...     with zipfile.ZipFile(d / f"{spec.identifier}.fmu", "w") as z:
    ...         z.writestr("modelDescription.xml", description(spec, []))
    >>> s = System("follow", base=d)
    >>> _ = s.add("pid", "PID.fmu", K=2.0, Ts=0.01)
    >>> _ = s.add("move", "Trajectory.fmu", kind="trapezoid")
    >>> _ = s.connect("move.position", "pid.setpoint")
    >>> itf = {name: FmuInterface.of(d / f"{file}.fmu") for name, file in (("pid", "PID"), ("move", "Trajectory"))}
    >>> exposed = exposed_variables(s, itf)
    >>> cfg = configuration(s, itf, exposed, 0.01, {"pid": "PID", "move": "Trajectory"}, "{token}", "0.3.32",
    ...                     initial={"pid.setpoint": 0.0})
    >>> cfg["fixedStepSize"], [c["name"] for c in cfg["components"]]
    (0.01, ['pid', 'move'])
    >>> cfg["connections"]               # move (component 1) position -> pid (component 0) setpoint
    [{'variableType': 'Float64', 'srcComponent': 1, 'srcValueReferences': [14], 'dstComponent': 0, 'dstValueReferences': [12], 'size': 1}]
    >>> cfg["variables"][-1]             # the connected input starts where initialisation settled it
    {'variableType': 'Float64', 'mappings': [[0, 12]], 'start': ['0.0']}
    >>> tmp.cleanup()
    """
    names = list(system.components)
    variables = []
    for e in exposed:
        v = {"variableType": CONTAINER_TYPES[e.type][0], "mappings": [[e.component, e.vr]]}
        if e.start is not None:
            v["start"] = [_text(e.start, e.type)]
        variables.append(v)
    for c in system.connections:
        port = interfaces[c.end_element].ports[c.end_connector]
        if c.end in initial and port.type == "Real":
            variables.append({"variableType": "Float64", "mappings": [[names.index(c.end_element), port.vr]],
                              "start": [_text(initial[c.end], "Real")]})
    connections = []
    for c in connection_order(system, interfaces):
        a = interfaces[c.start_element].ports[c.start_connector]
        b = interfaces[c.end_element].ports[c.end_connector]
        connections.append({"variableType": CONTAINER_TYPES[a.type][0],
                            "srcComponent": names.index(c.start_element), "srcValueReferences": [a.vr],
                            "dstComponent": names.index(c.end_element), "dstValueReferences": [b.vr], "size": 1})
    components = []
    for name in names:
        md = interfaces[name].model_description  # FMI 2.0: the master that settles the inputs refuses others
        components.append({"fmiMajorVersion": md.fmiVersion[0], "name": name, "path": paths[name],
                           "modelIdentifier": md.coSimulation.modelIdentifier,
                           "instantiationToken": md.guid})
    return {"containerVersion": version, "instantiationToken": token, "fixedStepSize": step,
            "parallelDoStep": False, "components": components, "variables": variables, "connections": connections}


def model_description(system: System, interfaces: dict[str, FmuInterface], exposed: list[Exposed], step: float,
                      t0: float, t_end: float, token: str, fmi_version: int) -> bytes:
    """The exported FMU's ``modelDescription.xml`` (FMI 2.0 or 3.0 co-simulation).

    Value reference k + 1 is ``exposed[k]``; an FMI 3 FMU has ``time`` at 0.
    An output is declared to depend at the same instant on the unconnected
    inputs of its own component it depends on (the engine copies nothing
    between its FMUs when an input is set).

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.system.ssp import System
    >>> from grubler.system.interface import FmuInterface
    >>> from grubler.controllers.native_fmu import pid_spec, trajectory_spec
    >>> from grubler.fmi.description import model_description as description
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> for spec in (pid_spec("PID"), trajectory_spec("Trajectory")):  # their model descriptions are what is read
    ...     with zipfile.ZipFile(d / f"{spec.identifier}.fmu", "w") as z:
    ...         z.writestr("modelDescription.xml", description(spec, []))
    >>> s = System("follow", base=d)
    >>> _ = s.add("pid", "PID.fmu", K=2.0, Ts=0.01)
    >>> _ = s.add("move", "Trajectory.fmu", kind="trapezoid")
    >>> _ = s.connect("move.position", "pid.setpoint")
    >>> itf = {name: FmuInterface.of(d / f"{file}.fmu") for name, file in (("pid", "PID"), ("move", "Trajectory"))}
    >>> import xml.etree.ElementTree as ET
    >>> exposed = exposed_variables(s, itf)
    >>> root = ET.fromstring(model_description(s, itf, exposed, 0.01, 0.0, 1.0, "{token}", fmi_version=2))
    >>> root.find("CoSimulation").get("modelIdentifier"), root.find("DefaultExperiment").get("stepSize")
    ('container_fmu', '0.01')
    >>> first = root.find("ModelVariables")[0]
    >>> first.get("name"), first.get("valueReference")          # value references from 1: the engine keeps 0
    ('pid.K', '1')
    >>> tmp.cleanup()
    """
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    words = system.description or f"the system {system.name} as one FMU"
    common = {"modelName": system.name or "system", "description": words,
              "generationTool": f"grubler {__version__} (grubler.system.container, fmpy's container FMU)",
              "generationDateAndTime": stamp, "variableNamingConvention": "structured"}
    tool = "true" if any(i.model_description.coSimulation.needsExecutionTool for i in interfaces.values()) else "false"
    cs = {"modelIdentifier": IDENTIFIER, "needsExecutionTool": tool,
          "canHandleVariableCommunicationStepSize": "false", "canGetAndSetFMUstate": "false",
          "canSerializeFMUstate": "false", "providesDirectionalDerivative" if fmi_version == 2 else
          "providesDirectionalDerivatives": "false"}
    index = {e.name: k + 1 for k, e in enumerate(exposed)}

    def depends(e: Exposed) -> list[int]:
        comp, var = e.name.split(".", 1)
        deps = interfaces[comp].feedthrough.get(var)
        if deps is None:
            deps = {p.name for p in interfaces[comp].ports.values() if p.causality == "input"}
        return sorted(index[f"{comp}.{d}"] for d in deps if f"{comp}.{d}" in index)

    if fmi_version == 2:
        root = ET.Element("fmiModelDescription", {"fmiVersion": "2.0", "guid": token, **common,
                                                  "numberOfEventIndicators": "0"})
        ET.SubElement(root, "CoSimulation", {**cs, "canInterpolateInputs": "false", "maxOutputDerivativeOrder": "0",
                                             "canRunAsynchronuously": "false",
                                             "canBeInstantiatedOnlyOncePerProcess": "false",
                                             "canNotUseMemoryManagementFunctions": "true"})
    else:
        root = ET.Element("fmiModelDescription", {"fmiVersion": "3.0", "instantiationToken": token, **common})
        ET.SubElement(root, "CoSimulation", {**cs, "fixedInternalStepSize": repr(step),
                                             "canReturnEarlyAfterIntermediateUpdate": "false"})
    ET.SubElement(root, "DefaultExperiment", {"startTime": repr(t0), "stopTime": repr(t_end), "stepSize": repr(step)})
    mv = ET.SubElement(root, "ModelVariables")
    if fmi_version == 3:
        ET.SubElement(mv, "Float64", {"name": "time", "valueReference": "0", "causality": "independent",
                                      "variability": "continuous", "description": "simulation time [s]"})
    for k, e in enumerate(exposed):
        attrs = {"name": e.name, "valueReference": str(k + 1), "description": e.description,
                 "causality": e.causality, "variability": e.variability}
        start = {} if e.start is None else {"start": _text(e.start, e.type)}
        if fmi_version == 2:
            if e.causality == "parameter":
                attrs["initial"] = "exact"
            sv = ET.SubElement(mv, "ScalarVariable", attrs)
            ET.SubElement(sv, CONTAINER_TYPES[e.type][1], start)
        else:
            if e.type == "String":
                var = ET.SubElement(mv, "String", attrs)
                if start:
                    ET.SubElement(var, "Start", {"value": start["start"]})
            else:
                ET.SubElement(mv, CONTAINER_TYPES[e.type][2], {**attrs, **start})
    ms = ET.SubElement(root, "ModelStructure")
    outputs = [(k + 1, e) for k, e in enumerate(exposed) if e.causality == "output"]
    if fmi_version == 2:
        for tag in ("Outputs", "InitialUnknowns"):
            group = ET.SubElement(ms, tag)
            for k, e in outputs:
                ET.SubElement(group, "Unknown", {"index": str(k), "dependencies": " ".join(map(str, depends(e)))})
    else:
        for tag in ("Output", "InitialUnknown"):
            for k, e in outputs:
                ET.SubElement(ms, tag, {"valueReference": str(k),
                                        "dependencies": " ".join(map(str, depends(e)))})
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def export_system(system: System | str | Path, dest: str | Path | None = None, fmi_version: int = 2,
                  field: str = "output") -> Path:
    """Export an SSP system as one co-simulation FMU (fmpy's container FMU around its FMUs).

    Parameters
    ----------
    system : System or path of a .ssd / .ssp
        Its step (the SSD's annotation, else 1 ms) is the container's fixed
        step: a host's communication step must be a whole multiple of it.
    dest : path, optional
        The ``.fmu`` to write (default: ``<system name>.fmu`` in the working folder).
    fmi_version : {2, 3}
        The exported FMU's FMI version (the nested FMUs keep theirs).
    field : str
        The name a refused ``dest`` is reported under (the CLI's option).

    Returns
    -------
    Path

    Raises
    ------
    SystemDescriptionError
        A system that cannot run (every problem named, as ``grubler cosim`` names them).
    ContainerError
        An fmpy without the container engine, an FMI version other than 2 or 3.

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.system.ssp import System
    >>> from grubler.controllers.native_fmu import trajectory_spec
    >>> from grubler.fmi.build import build_fmu, host_target
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> _ = build_fmu(trajectory_spec("Trajectory"), d / "Trajectory.fmu", host_target().fmi2)  # compiles: ~2 s
    >>> s = System("move", base=d, step=0.01)
    >>> _ = s.add("move", "Trajectory.fmu", kind="sine", amplitude=0.5, frequency=1.0)
    >>> fmu = export_system(s, d / "Move.fmu")
    >>> names = zipfile.ZipFile(fmu).namelist()
    >>> "resources/container.json" in names, "resources/Trajectory/modelDescription.xml" in names
    (True, True)
    >>> from fmpy import simulate_fmu                    # any importer runs the system as one FMU
    >>> r = simulate_fmu(str(fmu), stop_time=0.25, output_interval=0.01, output=["move.position"])
    >>> round(float(r["move.position"][-1]), 6)          # 0.5 sin(2 pi 0.25)
    0.5
    >>> tmp.cleanup()
    """
    from grubler.fmi.build import check_destination, pack_fmu

    if fmi_version not in (2, 3):
        raise ContainerError("fmi_version", f"must be 2 or 3, got {brief(fmi_version)}")
    if not isinstance(system, System):
        system = read(system)
    if not system.components:
        raise SystemDescriptionError(f"system {brief(system.name)}: has no components")
    dest = Path(dest) if dest is not None else Path(f"{system.name or 'system'}.fmu")
    check_destination(dest, field)
    binaries, version = engine()
    step = system.step if system.step is not None else 1e-3
    t0 = system.start_time or 0.0
    t_end = system.stop_time if system.stop_time is not None else t0 + 1.0
    token = "{%s}" % uuid.uuid4()
    root = temp_dir("grubler_container_")
    try:
        with cosim.UnpackedFMUs() as unpacked:
            interfaces = cosim.interfaces_of(system, unpacked)
            cosim.order(system, interfaces)  # an algebraic loop is refused as a run refuses it
            exposed = exposed_variables(system, interfaces)
            initial = cosim.initial_inputs(system, interfaces, unpacked, t0)
            paths: dict[str, str] = {}
            folders: dict[Path, str] = {}  # one copy of each FMU file, whatever uses it
            for name in system.components:
                fmu = interfaces[name].path
                if fmu not in folders:
                    stem = fmu.stem
                    folders[fmu] = stem if stem not in folders.values() else f"{stem}_{len(folders)}"
                    shutil.copytree(unpacked[fmu], root / "resources" / folders[fmu])
                paths[name] = folders[fmu]
        config = configuration(system, interfaces, exposed, step, paths, token, version, initial)
        (root / "resources" / "container.json").write_text(json.dumps(config, indent=1), encoding="utf-8")
        (root / "modelDescription.xml").write_bytes(
            model_description(system, interfaces, exposed, step, t0, t_end, token, fmi_version))
        # never empty: every FMU was instantiated here, so all have this machine's binary
        platforms = shared_platforms(root / "resources", list(folders.values()))
        for platform, fmi2_folder, library in BINARIES:
            folder = fmi2_folder if fmi_version == 2 else platform
            if folder is not None and platform in platforms:
                (root / "binaries" / folder).mkdir(parents=True, exist_ok=True)
                shutil.copyfile(binaries / platform / library, root / "binaries" / folder / library)
        pack_fmu(root, dest)
    finally:
        remove_temp_dir(root)
    return dest


__all__ = ["export_system", "execution_tools", "exposed_variables", "connection_order", "configuration", "model_description",
           "engine", "ContainerError", "CONTAINER_TYPES"]
