"""``modelDescription.xml`` (FMI 2.0 or 3.0 co-simulation) of a native FMU, from its :class:`ModelSpec`.

Units are FMI unit definitions (a unit on every variable that has one), bounds
where physics sets them, and the model structure is complete: every output with
the inputs it depends on at the same instant (none for a state-like output), and
every output among the initial unknowns.  The C sources are listed, so an
importer (or ``fmpy.build.build_platform_binary``) can compile the FMU for its
own platform (FMI 3.0 lists them in ``sources/buildDescription.xml``).

The FMI 3.0 description declares the same variables under FMI 3.0's types
(Float64, Int32, Boolean, String, Enumeration), with the independent variable
``time`` at value reference 0, and neither event mode nor early return: a
communication step carries the motion through a change point with its outputs
continuous, so there is no event to report (``docs/fmi.md``).
"""

from __future__ import annotations

import datetime
import xml.etree.ElementTree as ET

from grubler._version import __version__
from grubler.fmi.variables import (BOOLEAN, ENUMERATION, INPUT, INTEGER, OUTPUT, PARAMETER, REAL, STRING, UNIT_OFFSET,
                                   UNITS, ModelSpec)

LOG_CATEGORIES = {
    "logStatusWarning": "warnings: an output that could not be computed",
    "logStatusDiscard": "a communication step refused: non-finite input or integration failure",
    "logStatusError": "errors: a bad parameter, call or FMU state, a loop that cannot close",
    "logStatusFatal": "fatal errors (never raised by this FMU)",
    "logAll": "every message, including debug ones",
}


def _num(x) -> str:
    if isinstance(x, bool):  # xs:boolean
        return "true" if x else "false"
    return repr(float(x)) if not isinstance(x, int) else str(x)


def described(v) -> str:
    """A variable's description, ending with its unit in brackets (the project's
    convention, which masters that read no FMI units fall back on)."""
    text = v.description.rstrip()
    if v.unit and not text.endswith("]"):
        text += f" [{v.unit.replace('.', ' ')}]"
    return text


def model_description(spec: ModelSpec, sources: list[str]) -> bytes:
    """The model description's XML text.

    Parameters
    ----------
    spec : ModelSpec
    sources : list of str
        The C files to compile, relative to the FMU's ``sources/`` folder.
    """
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": spec.identifier, "guid": spec.guid, **_about(spec),
        "numberOfEventIndicators": "0"})
    cs = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": spec.identifier, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true", "canInterpolateInputs": "false",
        "maxOutputDerivativeOrder": "0", "canRunAsynchronuously": "false", "canBeInstantiatedOnlyOncePerProcess":
        "false", "canNotUseMemoryManagementFunctions": "false", "canGetAndSetFMUstate": "true",
        "canSerializeFMUstate": "true", "providesDirectionalDerivative": "true" if spec.defines.get("MODEL_DIRECTIONAL_DERIVATIVE") else "false",
    })
    if sources:  # (a binary-only FMU has none, and FMI 2's SourceFiles holds at least one File)
        files = ET.SubElement(cs, "SourceFiles")
        for s in sources:
            if s.endswith(".c"):
                ET.SubElement(files, "File", {"name": s})

    _units(root, spec)

    if spec.enums:
        types = ET.SubElement(root, "TypeDefinitions")
        for e in spec.enums:
            st = ET.SubElement(types, "SimpleType", {"name": e.name, "description": e.description})
            en = ET.SubElement(st, "Enumeration")
            for k, (item, text) in enumerate(e.items, start=1):
                ET.SubElement(en, "Item", {"name": item, "value": str(k), "description": text})

    _log_categories_and_experiment(root, spec)

    mv = ET.SubElement(root, "ModelVariables")
    for k, v in enumerate(spec.variables, start=1):
        attrs = {"name": v.name, "valueReference": str(k), "description": described(v), "causality": v.causality,
                 "variability": "fixed" if v.causality == PARAMETER else v.variability or "continuous"}
        if v.causality == PARAMETER:
            attrs["initial"] = "exact"
        elif v.causality == OUTPUT:
            attrs["initial"] = "calculated"
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        tattrs = {}
        if v.type == ENUMERATION:
            tattrs["declaredType"] = v.enum.name
        if v.unit:
            tattrs["unit"] = v.unit
        if v.min is not None:
            tattrs["min"] = _num(v.min)
        if v.max is not None:
            tattrs["max"] = _num(v.max)
        if v.start is not None and v.causality in (PARAMETER, INPUT):
            tattrs["start"] = str(v.start) if v.type == STRING else _num(v.start)
        ET.SubElement(sv, v.type, tattrs)

    ms = ET.SubElement(root, "ModelStructure")
    outs = ET.SubElement(ms, "Outputs")
    init = ET.SubElement(ms, "InitialUnknowns")
    for k, deps in _outputs(spec):
        ET.SubElement(outs, "Unknown", {"index": str(k), **_dependencies(deps)})
        # at initialisation an output depends on the parameters (the assembly) and,
        # if it is feed-through, the inputs: all the knowns, which no attribute says
        ET.SubElement(init, "Unknown", {"index": str(k)})
    return _text(root)


def _about(spec: ModelSpec) -> dict:
    return {"description": spec.description, "generationTool": f"grubler {__version__} (grubler.fmi)",
            "generationDateAndTime": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "variableNamingConvention": "structured", "version": __version__}


def _units(root, spec: ModelSpec, also: set = frozenset()) -> None:
    used = sorted({v.unit for v in spec.variables if v.unit} | set(also))
    units = ET.SubElement(root, "UnitDefinitions")
    for u in used:
        unit = ET.SubElement(units, "Unit", {"name": u})
        base = {k: str(e) for k, e in UNITS[u].items()}
        if u in UNIT_OFFSET:
            base["offset"] = _num(UNIT_OFFSET[u])
        ET.SubElement(unit, "BaseUnit", base)


def sample_time(spec: ModelSpec) -> float | None:
    """A sampled law's sample time at its start (its parameter at LAW_TS_SLOT, Ts), None for any other model
    or a law sampled once per communication step (Ts = 0)."""
    if spec.defines.get("LAW_CONTINUOUS", 1) or "LAW_TS_SLOT" not in spec.defines:
        return None
    ts = next(float(v.start) for v in spec.variables if v.causality == PARAMETER and v.slot == spec.defines["LAW_TS_SLOT"])
    return ts if ts > 0 else None


def _log_categories_and_experiment(root, spec: ModelSpec) -> None:
    cats = ET.SubElement(root, "LogCategories")
    for name, text in LOG_CATEGORIES.items():
        ET.SubElement(cats, "Category", {"name": name, "description": text})
    # a sampled law's default communication step is its sample time: an importer that takes the default
    # (fmpy's simulate_fmu and fmusim read stepSize) steps once per sample (docs/fmi.md)
    ts = sample_time(spec)
    ET.SubElement(root, "DefaultExperiment", {"startTime": "0.0", "stopTime": "1.0",
                                              "stepSize": _num(ts) if ts is not None else "0.001"})


def _outputs(spec: ModelSpec):
    """Each output's value reference and those of the inputs it depends on at the same instant
    (FMI 2.0's indices are the value references: variable k has reference k)."""
    inputs = {v.name: str(k) for k, v in enumerate(spec.variables, start=1) if v.causality == INPUT}
    for k, v in enumerate(spec.variables, start=1):
        if v.causality == OUTPUT:
            yield k, ([inputs[n] for n in (v.depends_on or inputs)] if v.feedthrough else [])


def _dependencies(deps: list[str]) -> dict:
    a = {"dependencies": " ".join(deps)}
    if deps:
        a["dependenciesKind"] = " ".join(["dependent"] * len(deps))
    return a


def _text(root) -> bytes:
    ET.indent(root)
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


# FMI 3.0's element for each of the spec's types
FMI3_TYPE = {REAL: "Float64", INTEGER: "Int32", BOOLEAN: "Boolean", STRING: "String", ENUMERATION: "Enumeration"}


def fmi3_model_description(spec: ModelSpec) -> bytes:
    """The FMI 3.0 co-simulation model description's XML text.

    Parameters
    ----------
    spec : ModelSpec
    """
    directional = "true" if spec.defines.get("MODEL_DIRECTIONAL_DERIVATIVE") else "false"
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": spec.identifier, "instantiationToken": spec.guid, **_about(spec)})
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": spec.identifier, "needsExecutionTool": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false", "canGetAndSetFMUState": "true",
        "canSerializeFMUState": "true", "providesDirectionalDerivatives": directional,
        "providesAdjointDerivatives": "false", "providesPerElementDependencies": "false",
        "canHandleVariableCommunicationStepSize": "true", "maxOutputDerivativeOrder": "0",
        "providesIntermediateUpdate": "false", "mightReturnEarlyFromDoStep": "false",
        "canReturnEarlyAfterIntermediateUpdate": "false", "hasEventMode": "false",
        "providesEvaluateDiscreteStates": "false",
    })
    _units(root, spec, {"s"})  # (time's)
    if spec.enums:
        types = ET.SubElement(root, "TypeDefinitions")
        for e in spec.enums:
            et = ET.SubElement(types, "EnumerationType", {"name": e.name, "description": e.description})
            for k, (item, text) in enumerate(e.items, start=1):
                ET.SubElement(et, "Item", {"name": item, "value": str(k), "description": text})
    _log_categories_and_experiment(root, spec)

    mv = ET.SubElement(root, "ModelVariables")
    ET.SubElement(mv, "Float64", {"name": "time", "valueReference": "0", "causality": "independent",
                                  "variability": "continuous", "description": "Simulation time [s]", "unit": "s"})
    for k, v in enumerate(spec.variables, start=1):
        attrs = {"name": v.name, "valueReference": str(k), "description": described(v), "causality": v.causality,
                 "variability": "fixed" if v.causality == PARAMETER else
                 (v.variability or "continuous" if v.type == REAL else "discrete")}
        if v.type == ENUMERATION:
            attrs["declaredType"] = v.enum.name
        if v.unit and v.type == REAL:  # (FMI 3.0 gives only floats a unit)
            attrs["unit"] = v.unit
        if v.min is not None and v.type in (REAL, INTEGER, ENUMERATION):
            attrs["min"] = _num(v.min)
        if v.max is not None and v.type in (REAL, INTEGER, ENUMERATION):
            attrs["max"] = _num(v.max)
        if v.causality == PARAMETER:
            attrs["initial"] = "exact"
        elif v.causality == OUTPUT:
            attrs["initial"] = "calculated"
        start = v.start is not None and v.causality in (PARAMETER, INPUT)
        if start and v.type == BOOLEAN:
            attrs["start"] = "true" if v.start else "false"
        elif start and v.type != STRING:
            attrs["start"] = _num(v.start)
        var = ET.SubElement(mv, FMI3_TYPE[v.type], attrs)
        if start and v.type == STRING:
            ET.SubElement(var, "Start", {"value": str(v.start)})

    ms = ET.SubElement(root, "ModelStructure")
    for k, deps in _outputs(spec):
        ET.SubElement(ms, "Output", {"valueReference": str(k), **_dependencies(deps)})
    for k, _ in _outputs(spec):  # (FMI 3.0 lists every Output before every InitialUnknown)
        ET.SubElement(ms, "InitialUnknown", {"valueReference": str(k)})
    return _text(root)


def fmi3_build_description(spec: ModelSpec, sources: list[str]) -> bytes:
    """``sources/buildDescription.xml``: the C files an importer compiles into the FMU's binary (FMI 3.0).

    Parameters
    ----------
    spec : ModelSpec
    sources : list of str
        The C files to compile, relative to the FMU's ``sources/`` folder.
    """
    root = ET.Element("fmiBuildDescription", {"fmiVersion": "3.0"})
    config = ET.SubElement(root, "BuildConfiguration", {"modelIdentifier": spec.identifier})
    files = ET.SubElement(config, "SourceFileSet", {"language": "C99"})
    for s in sources:
        if s.endswith(".c"):
            ET.SubElement(files, "SourceFile", {"name": s})
    return _text(root)
