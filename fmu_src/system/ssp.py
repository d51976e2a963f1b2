"""Systems of FMUs in the ecosystem's own format: SSP 1.0 (SystemStructure.ssd).

A :class:`System` is components (an FMU each, with parameter values), their
connections, and optionally a default experiment and the plots to draw.  It is
written as a ``.ssd`` file (FMU sources relative to the file) or as a ``.ssp``
archive carrying the FMUs, and read back from either, so the same system opens in
fmpy's SSP reader and other SSP tools.  What SSP has no element for (the
communication step, the plots) goes in a ``grubler`` annotation other tools ignore;
the step is written a second time as the Open Simulation Platform's
``osp:FixedStepAlgorithm baseStepSize`` annotation of the default experiment, so
that libcosim runs the file with the step it was designed for.

Units are checked where a connection is made: a connector's unit comes from the
SSD when it declares one, else from the FMU (its declared unit, or the unit in
square brackets that ends the variable's description, the project's convention
for pythonfmu FMUs, which cannot declare units).

Examples
--------
>>> s = System("demo")
>>> s.plots.append(Plot("angle", ["a.y"]))
>>> s.components["a"] = Component("a", "A.fmu", {"gain": 2.0})
>>> s.connections.append(Connection("a", "y", "a", "u"))
>>> s.connections[0]
Connection(start_element='a', start_connector='y', end_element='a', end_connector='u')
"""

from __future__ import annotations

import io
import os
import re
import zipfile
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath, PureWindowsPath
from xml.etree import ElementTree as ET

from grubler.errors import GrublerError, InputError, SystemDescriptionError
from grubler.system.interface import FmuInterface
from grubler.limits import PATH_CHARS, brief, clip, extract_zip, number, read_bytes, remove_temp_dir, temp_dir

NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    # the Open Simulation Platform's annotations (libcosim's SSP loader reads its
    # fixed-step master's base step from them, and matches the prefix literally)
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
}
ANNOTATION_TYPE = "org.grubler.cosim"
OSP_ANNOTATION_TYPE = "com.opensimulationplatform"
FMU_TYPE = "application/x-fmu-sharedlibrary"
for _prefix, _uri in NS.items():
    ET.register_namespace(_prefix, _uri)

# SI base-unit exponents (kg, m, s, A, K, rad) of the units the project's FMUs use,
# written into the SSD's Units so that other tools can convert.
_BASE_UNITS = {
    "1": {}, "rad": {"rad": 1}, "rad/s": {"rad": 1, "s": -1}, "rad/s2": {"rad": 1, "s": -2},
    "m": {"m": 1}, "m/s": {"m": 1, "s": -1}, "m/s2": {"m": 1, "s": -2}, "s": {"s": 1},
    "N": {"kg": 1, "m": 1, "s": -2}, "N m": {"kg": 1, "m": 2, "s": -2},
    "A": {"A": 1}, "V": {"kg": 1, "m": 2, "s": -3, "A": -1}, "W": {"kg": 1, "m": 2, "s": -3},
    "J": {"kg": 1, "m": 2, "s": -2}, "Ohm": {"kg": 1, "m": 2, "s": -3, "A": -2},
    "H": {"kg": 1, "m": 2, "s": -2, "A": -2}, "degC": {"K": 1}, "K": {"K": 1},
    "kg m2": {"kg": 1, "m": 2}, "kg": {"kg": 1},
}


@dataclass
class Component:
    """One FMU in a system.

    Parameters
    ----------
    name : str
        Instance name, unique in the system.
    source : str
        The FMU: a path relative to the ``.ssd`` file (or inside the ``.ssp``).
    parameters : dict
        Start values of parameters, by variable name (float, int, bool or str).
    units : dict
        Units the SSD declares for connectors, by name (override the FMU's).

    Examples
    --------
    >>> from grubler import ssp
    >>> c = ssp.System("one").add("motor", "DCMotor.fmu", gear_ratio=50.0, supply_voltage=48.0)
    >>> c.name, c.source, c.parameters
    ('motor', 'DCMotor.fmu', {'gear_ratio': 50.0, 'supply_voltage': 48.0})
    """

    name: str
    source: str
    parameters: dict[str, float | int | bool | str] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)


@dataclass
class Connection:
    """An output of one component feeding an input of another.

    Examples
    --------
    >>> from grubler import ssp
    >>> c = ssp.Connection("motor", "shaft_torque", "mech", "motor_torque")
    >>> c.start, c.end
    ('motor.shaft_torque', 'mech.motor_torque')
    """

    start_element: str
    start_connector: str
    end_element: str
    end_connector: str

    @property
    def start(self) -> str:
        return f"{self.start_element}.{self.start_connector}"

    @property
    def end(self) -> str:
        return f"{self.end_element}.{self.end_connector}"


@dataclass
class Plot:
    """One panel of the run's plot: a title and the signals it shows.

    Parameters
    ----------
    title : str
        The panel's axis label, with the unit in square brackets.
    signals : list of str
        ``element.connector`` names.
    labels : dict
        The legend's words for a signal, by name (default: the name).
    difference : bool
        Draw one curve, the first signal minus the second (a tracking error),
        labelled ``labels["difference"]`` when given.

    Examples
    --------
    >>> from grubler import ssp
    >>> panel = ssp.Plot("crank angle [rad]", ["trajectory.position", "mechanism.theta2"],
    ...                  labels={"trajectory.position": "setpoint"})
    >>> s = ssp.System("servo", plots=[panel])
    >>> s.plots[0].title, s.plots[0].difference
    ('crank angle [rad]', False)
    """

    title: str
    signals: list[str]
    labels: dict[str, str] = field(default_factory=dict)
    difference: bool = False


@dataclass
class System:
    """Components, connections, a default experiment and plots.

    Parameters
    ----------
    name : str
    components : dict of Component, by name
    connections : list of Connection
    start_time, stop_time, step : float or None
        The default experiment (``step`` is the communication step).
    order : list of str, optional
        The components' stepping order, when the system's author knows better
        than the runner's default (see :func:`grubler.system.cosim.order`).
    plots : list of Plot
    description : str
    base : Path or None
        Folder the components' sources are relative to (set by :func:`read`).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from grubler import ssp
    >>> s = ssp.System("pair", step=1e-3, stop_time=1.0)
    >>> s.add("mech", "Mechanism.fmu", **{"link2.m": 2.0})          # FMU paths relative to the .ssd
    Component(name='mech', source='Mechanism.fmu', parameters={'link2.m': 2.0}, units={})
    >>> _ = s.add("motor", "DCMotor.fmu", gear_ratio=50.0)
    >>> s.connect("motor.shaft_torque", "mech.motor_torque")
    Connection(start_element='motor', start_connector='shaft_torque', end_element='mech', end_connector='motor_torque')
    >>> with tempfile.TemporaryDirectory() as d:
    ...     again = ssp.read(s.write(pathlib.Path(d) / "pair.ssd"))   # written and read back
    >>> list(again.components), again.components["motor"].parameters, again.step
    (['mech', 'motor'], {'gear_ratio': 50.0}, 0.001)
    """

    name: str
    components: dict[str, Component] = field(default_factory=dict)
    connections: list[Connection] = field(default_factory=list)
    start_time: float | None = None
    stop_time: float | None = None
    step: float | None = None
    plots: list[Plot] = field(default_factory=list)
    description: str = ""
    base: Path | None = None
    order: list[str] | None = None

    # -- building ------------------------------------------------------------
    def add(self, name: str, source: str | Path, **parameters) -> Component:
        """Add a component; parameters as keywords (dotted names via ``**{...}``)."""
        if name in self.components:
            raise SystemDescriptionError(f"component {brief(name)}: the name is used twice")
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise SystemDescriptionError(f"component {brief(name)}: a name is a letter then letters, digits, _")
        comp = Component(name, str(source), dict(parameters))
        self.components[name] = comp
        return comp

    def connect(self, start: str, end: str) -> Connection:
        """Connect ``'component.output'`` to ``'component.input'``."""
        conn = Connection(*_split(start, "start"), *_split(end, "end"))
        self.connections.append(conn)
        return conn

    def source_path(self, comp: Component) -> Path:
        """Where a component's FMU is on this machine."""
        path = Path(comp.source)
        if not path.is_absolute() and self.base is not None:
            path = self.base / path
        return path

    # -- writing -------------------------------------------------------------
    def to_xml(self, connectors: dict[str, list[tuple[str, str, str]]] | None = None,
               sources: dict[str, str] | None = None) -> bytes:
        """The SystemStructure.ssd text.

        ``connectors`` lists, per component, ``(name, kind, unit)`` of the
        connectors to declare (default: those the connections use, kinds guessed
        from the direction); ``sources`` overrides the components' sources.
        """
        ssd, ssc, ssv = (f"{{{NS[k]}}}" for k in ("ssd", "ssc", "ssv"))
        root = ET.Element(f"{ssd}SystemStructureDescription", {"version": "1.0", "name": self.name})
        sys_attrs = {"name": self.name}
        if self.description:
            sys_attrs["description"] = self.description
        system = ET.SubElement(root, f"{ssd}System", sys_attrs)
        elements = ET.SubElement(system, f"{ssd}Elements")
        if connectors is None:
            connectors = self.connectors()
        used_units: set[str] = set()
        for comp in self.components.values():
            src = (sources or {}).get(comp.name, comp.source)
            el = ET.SubElement(elements, f"{ssd}Component", {"name": comp.name, "type": FMU_TYPE, "source": src})
            seen = set()
            conns = ET.SubElement(el, f"{ssd}Connectors")
            for name, kind, unit in connectors.get(comp.name, []):
                if name in seen:
                    continue
                seen.add(name)
                cn = ET.SubElement(conns, f"{ssd}Connector", {"name": name, "kind": kind})
                # an FMU's "rad or m" is no SSP unit: declare only real ones, or the SSD's own
                unit = comp.units.get(name, unit if unit in _BASE_UNITS else "")
                attrs = {"unit": unit} if unit else {}
                if unit:
                    used_units.add(unit)
                ET.SubElement(cn, f"{ssc}Real", attrs)
            if not len(conns):
                el.remove(conns)
            if comp.parameters:
                binding = ET.SubElement(ET.SubElement(el, f"{ssd}ParameterBindings"), f"{ssd}ParameterBinding")
                values = ET.SubElement(binding, f"{ssd}ParameterValues")
                pset = ET.SubElement(values, f"{ssv}ParameterSet", {"version": "1.0", "name": comp.name})
                params = ET.SubElement(pset, f"{ssv}Parameters")
                for pname, value in comp.parameters.items():
                    p = ET.SubElement(params, f"{ssv}Parameter", {"name": pname})
                    ET.SubElement(p, *_ssv_value(ssv, pname, value))
        if self.connections:
            cons = ET.SubElement(system, f"{ssd}Connections")
            for c in self.connections:
                ET.SubElement(cons, f"{ssd}Connection", {
                    "startElement": c.start_element, "startConnector": c.start_connector,
                    "endElement": c.end_element, "endConnector": c.end_connector})
        if used_units:
            units = ET.SubElement(root, f"{ssd}Units")
            for u in sorted(used_units):
                unit = ET.SubElement(units, f"{ssc}Unit", {"name": u})
                ET.SubElement(unit, f"{ssc}BaseUnit", {k: str(v) for k, v in _BASE_UNITS.get(u, {}).items()})
        if self.start_time is not None or self.stop_time is not None or self.step is not None:
            exp = {}
            if self.start_time is not None:
                exp["startTime"] = repr(float(self.start_time))
            if self.stop_time is not None:
                exp["stopTime"] = repr(float(self.stop_time))
            exp_el = ET.SubElement(root, f"{ssd}DefaultExperiment", exp)
            if self.step is not None:
                # libcosim has no default step: without this it must be told one
                osp = f"{{{NS['osp']}}}"
                ann = ET.SubElement(ET.SubElement(exp_el, f"{ssd}Annotations"), f"{ssc}Annotation",
                                    {"type": OSP_ANNOTATION_TYPE})
                ET.SubElement(ET.SubElement(ann, f"{osp}Algorithm"), f"{osp}FixedStepAlgorithm",
                              {"baseStepSize": repr(float(self.step))})
        if self.step is not None or self.plots or self.order:
            ann = ET.SubElement(ET.SubElement(root, f"{ssd}Annotations"), f"{ssc}Annotation",
                                {"type": ANNOTATION_TYPE})
            attrs = {"step": repr(float(self.step))} if self.step is not None else {}
            if self.order:
                attrs["order"] = " ".join(self.order)
            cosim = ET.SubElement(ann, "Cosim", attrs)
            for p in self.plots:
                attrs = {"title": p.title, "signals": " ".join(p.signals)}
                if p.difference:
                    attrs["difference"] = "true"
                plot = ET.SubElement(cosim, "Plot", attrs)
                for name, words in p.labels.items():
                    ET.SubElement(plot, "Label", {"signal": name, "text": words})
        ET.indent(root)
        return ET.tostring(root, encoding="UTF-8", xml_declaration=True)

    def connectors(self) -> dict[str, list[tuple[str, str, str]]]:
        """The connectors the connections and plots use, ``(name, kind, unit)`` per component.

        Units come from the FMUs where they can be read (see the module's notes).
        """
        ports = {}
        for n, c in self.components.items():
            try:
                ports[n] = FmuInterface.of(self.source_path(c)).ports
            except Exception:  # noqa: BLE001 - an FMU not built yet: no units to declare
                ports[n] = {}
        out: dict[str, list] = {n: [] for n in self.components}
        ends = [(c.start_element, c.start_connector, "output") for c in self.connections]
        ends += [(c.end_element, c.end_connector, "input") for c in self.connections]
        # the plotted outputs too, so that a tool recording connectors records them
        ends += [(*sig.split(".", 1), "output") for p in self.plots for sig in p.signals if "." in sig]
        for elem, name, kind in ends:
            if elem in out:
                port = ports[elem].get(name)
                if port is not None and port.causality != kind:
                    continue  # a plotted input is declared by its connection
                out[elem].append((name, kind, port.unit if port else ""))
        return out

    def write(self, path: str | Path, connectors: dict | None = None) -> Path:
        """Write a ``.ssd`` (sources relative to it) or a ``.ssp`` archive (FMUs inside)."""
        path = Path(path)
        if path.suffix == ".ssp":
            files: dict[Path, str] = {}  # one copy of each FMU, however many instances
            for c in self.components.values():
                src = self.source_path(c).resolve()
                if src not in files:
                    stem = src.stem if src.stem not in {Path(f).stem for f in files.values()} else \
                        f"{src.stem}_{len(files)}"
                    files[src] = f"resources/{stem}.fmu"
            sources = {n: files[self.source_path(c).resolve()] for n, c in self.components.items()}
            connectors = connectors if connectors is not None else self.connectors()
            with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
                zf.writestr("SystemStructure.ssd", self.to_xml(connectors, sources))
                for src, arc in files.items():
                    zf.write(src, arc)
            return path
        if path.suffix != ".ssd":
            raise SystemDescriptionError(f"{path}: write a .ssd file or a .ssp archive")
        sources = {}
        for n, c in self.components.items():
            src = self.source_path(c).resolve()
            try:
                sources[n] = Path(os.path.relpath(src, path.parent.resolve())).as_posix()
            except ValueError:  # another drive on Windows
                sources[n] = src.as_posix()
        path.write_bytes(self.to_xml(connectors, sources))
        return path


def _split(ref: str, end: str) -> tuple[str, str]:
    element, dot, connector = str(ref).partition(".")
    if not dot or not element or not connector:
        raise SystemDescriptionError(f"connection {end} {brief(ref)}: write it as 'component.variable'")
    return element, connector


def _ssv_value(ssv: str, name: str, value) -> tuple[str, dict]:
    if isinstance(value, bool):
        return f"{ssv}Boolean", {"value": "true" if value else "false"}
    if isinstance(value, int):
        return f"{ssv}Integer", {"value": str(value)}
    if isinstance(value, float):
        return f"{ssv}Real", {"value": repr(value)}
    if isinstance(value, str):
        return f"{ssv}String", {"value": value}
    raise SystemDescriptionError(f"parameter {name!r}: {type(value).__name__} is not a Real, Integer, "
                                 "Boolean or String")


# -- reading ------------------------------------------------------------------
def read(path: str | Path) -> System:
    """Read a ``.ssd`` file or a ``.ssp`` archive.

    A ``.ssp`` is extracted, within :func:`grubler.limits.extract_zip`'s bounds,
    to a temporary folder so that the components' sources resolve to real files.
    The folder is removed at once if the archive is refused, else by
    :func:`grubler.limits.remove_temp_dirs` (which the CLI calls on every exit,
    and which runs at interpreter exit).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from grubler import ssp
    >>> s = ssp.System("lone")
    >>> _ = s.add("mech", "Mechanism.fmu", **{"link2.m": 2.0})
    >>> with tempfile.TemporaryDirectory() as d:
    ...     back = ssp.read(s.write(pathlib.Path(d) / "lone.ssd"))
    >>> back.name, back.components["mech"].parameters
    ('lone', {'link2.m': 2.0})
    """
    path = Path(path)
    where = brief(str(path), PATH_CHARS)
    if not path.is_file():
        raise SystemDescriptionError(f"{where}: no such file")
    if path.suffix == ".ssp" or zipfile.is_zipfile(path):
        tmp = temp_dir("grubler_ssp_")
        try:
            _limited(lambda: extract_zip(path, tmp, "system"))
            ssd = tmp / "SystemStructure.ssd"
            if not ssd.is_file():
                raise SystemDescriptionError(f"{where}: the archive has no SystemStructure.ssd")
            system = from_xml(_limited(lambda: read_bytes(ssd, "system")), base=tmp, where=where)
            for comp in system.components.values():
                _inside_archive(comp, tmp)
            return system
        except BaseException:
            remove_temp_dir(tmp)
            raise
    return from_xml(_limited(lambda: read_bytes(path, "system")), base=path.parent, where=where)


def _inside_archive(comp: Component, folder: Path) -> None:
    """Refuse a component of an ``.ssp`` whose FMU is not in the archive.

    Loading an FMU runs its binary: an archive that names one by an absolute
    path or climbs out with ``..`` would run code it does not carry, as a
    member named ``../x`` would write outside the extraction (both refused).
    """
    source = comp.source
    # absolute on any system (/x, C:/x, a backslash root, a UNC share) or a URI (file:///x, http://...)
    if (PurePosixPath(source).is_absolute() or PureWindowsPath(source).drive or source.startswith("\\")
            or re.match(r"[A-Za-z][A-Za-z0-9+.-]+:", source)):
        raise SystemDescriptionError(f"component {comp.name}: source {brief(source, PATH_CHARS)} is outside the "
                                     "archive (an absolute path or a URI); an .ssp carries its FMUs, named "
                                     "relative to it (e.g. resources/X.fmu)")
    root = folder.resolve()
    if not (folder / source).resolve().is_relative_to(root):
        raise SystemDescriptionError(f"component {comp.name}: source {brief(source, PATH_CHARS)} reaches outside "
                                     "the archive (through ..); an .ssp carries its FMUs, named relative to it "
                                     "(e.g. resources/X.fmu)")


def _limited(fn):
    # the limits layer names its field; here every refusal is the system description's
    try:
        return fn()
    except InputError as exc:
        raise SystemDescriptionError(exc.reason if exc.field == "system" else str(exc)) from None


def _number(text: str | None, where: str, positive: bool = False) -> float | None:
    if text is None or text == "":
        return None
    try:
        return number(text, where, low=0.0 if positive else None, low_open=positive)
    except InputError as exc:
        raise SystemDescriptionError(str(exc)) from None


def from_xml(text: bytes | str, base: Path | None = None, where: str = "SSD") -> System:
    """Parse SystemStructure.ssd text.

    Examples
    --------
    >>> from grubler import ssp
    >>> text = ssp.System("pair").to_xml()
    >>> ssp.from_xml(text).name
    'pair'
    """
    try:
        root = ET.parse(io.BytesIO(text.encode() if isinstance(text, str) else text)).getroot()
    except ET.ParseError as exc:
        raise SystemDescriptionError(f"{where}: not valid XML ({exc})") from None
    except RecursionError:
        raise SystemDescriptionError(f"{where}: not valid here: elements nested too deep") from None
    if root.tag != f"{{{NS['ssd']}}}SystemStructureDescription":
        raise SystemDescriptionError(f"{where}: the root element is {clip(root.tag)}, "
                                     "not ssd:SystemStructureDescription")
    sys_el = root.find("ssd:System", NS)
    if sys_el is None:
        raise SystemDescriptionError(f"{where}: no ssd:System element")
    if sys_el.find("ssd:Elements/ssd:System", NS) is not None:
        raise SystemDescriptionError(f"{where}: nested systems are not supported; flatten the system")
    system = System(name=root.get("name") or sys_el.get("name") or "system",
                    description=sys_el.get("description", ""), base=base)
    for el in sys_el.findall("ssd:Elements/ssd:Component", NS):
        name, source = el.get("name"), el.get("source")
        if not name or not source:
            raise SystemDescriptionError(f"{where}: a component needs a name and a source")
        comp = system.add(name, source)
        for cn in el.findall("ssd:Connectors/ssd:Connector", NS):
            real = cn.find("ssc:Real", NS)
            if not cn.get("name"):
                raise SystemDescriptionError(f"component {brief(name)}: a connector without a name")
            if real is not None and real.get("unit"):
                comp.units[cn.get("name")] = real.get("unit")
        for binding in el.findall("ssd:ParameterBindings/ssd:ParameterBinding", NS):
            if binding.get("source"):
                raise SystemDescriptionError(f"component {name!r}: parameter files (source=) are not supported; "
                                             "put the values inline")
            prefix = binding.get("prefix", "")
            for p in binding.findall("ssd:ParameterValues/ssv:ParameterSet/ssv:Parameters/ssv:Parameter", NS):
                if not p.get("name"):
                    raise SystemDescriptionError(f"component {brief(name)}: a parameter without a name")
                comp.parameters[_strip(p.get("name"), prefix, name)] = _parameter_value(p, name)
    for c in sys_el.findall("ssd:Connections/ssd:Connection", NS):
        if c.get("startElement") is None or c.get("endElement") is None:
            raise SystemDescriptionError(
                f"connection {c.get('startConnector')} -> {c.get('endConnector')}: connections to the system's "
                "own connectors are not supported; connect components directly")
        if not c.get("startConnector") or not c.get("endConnector"):
            raise SystemDescriptionError(f"connection from {brief(c.get('startElement'))} to "
                                         f"{brief(c.get('endElement'))}: both connectors must be named")
        system.connections.append(Connection(c.get("startElement"), c.get("startConnector"),
                                             c.get("endElement"), c.get("endConnector")))
    exp = root.find("ssd:DefaultExperiment", NS)
    if exp is not None:
        system.start_time = _number(exp.get("startTime"), "DefaultExperiment.startTime")
        system.stop_time = _number(exp.get("stopTime"), "DefaultExperiment.stopTime")
        # a file from OSP's tools keeps its step here only; grubler's own annotation, read below, wins
        fixed = exp.find(f"ssd:Annotations/ssc:Annotation[@type='{OSP_ANNOTATION_TYPE}']"
                         "/osp:Algorithm/osp:FixedStepAlgorithm", NS)
        if fixed is not None and fixed.get("baseStepSize") is not None:
            system.step = _number(fixed.get("baseStepSize"), "osp:FixedStepAlgorithm.baseStepSize", positive=True)
    for ann in root.findall("ssd:Annotations/ssc:Annotation", NS):
        if ann.get("type") != ANNOTATION_TYPE:
            continue
        cosim = ann.find("Cosim")
        if cosim is not None:
            if cosim.get("step") is not None:  # step="0" is refused, not read as "unset"
                system.step = _number(cosim.get("step"), "Annotation Cosim.step", positive=True)
            if cosim.get("order"):
                system.order = cosim.get("order").split()
            for p in cosim.findall("Plot"):
                labels = {lab.get("signal", ""): lab.get("text", "") for lab in p.findall("Label")}
                system.plots.append(Plot(p.get("title", ""), p.get("signals", "").split(), labels,
                                         p.get("difference", "false") == "true"))
    return system


def _strip(pname: str, prefix: str, component: str) -> str:
    # fmpy's convention names a component's parameters "component.variable"
    for head in (prefix, component + "."):
        if head and pname.startswith(head):
            return pname[len(head):]
    return pname


def _parameter_value(p: ET.Element, component: str):
    field = f"parameter {component}.{clip(p.get('name'))}"
    for tag in ("Real", "Integer"):
        v = p.find(f"ssv:{tag}", NS)
        if v is not None:
            try:
                return number(v.get("value") if v.get("value") is not None else "", field,
                              integer=tag == "Integer")
            except InputError as exc:
                raise SystemDescriptionError(f"{field}: {brief(v.get('value'))} is not a valid {tag} "
                                             f"({exc.reason})") from None
    v = p.find("ssv:String", NS)
    if v is not None:
        if v.get("value") is None:
            raise SystemDescriptionError(f"{field}: a String with no value")
        return v.get("value")
    v = p.find("ssv:Boolean", NS)
    if v is not None:
        if v.get("value") not in ("true", "1", "false", "0"):
            raise SystemDescriptionError(f"{field}: {brief(v.get('value'))} is not a Boolean (true, false)")
        return v.get("value") in ("true", "1")
    raise SystemDescriptionError(f"{field}: no Real, Integer, Boolean or String value")


__all__ = ["System", "Component", "Connection", "Plot", "SystemDescriptionError", "read", "from_xml"]
