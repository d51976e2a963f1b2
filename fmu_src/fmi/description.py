"""``modelDescription.xml`` (FMI 2.0 co-simulation) of a native FMU, from its :class:`ModelSpec`.

Units are FMI unit definitions (a unit on every variable that has one), bounds
where physics sets them, and the model structure is complete: every output with
the inputs it depends on at the same instant (none for a state-like output), and
every output among the initial unknowns.  The C sources are listed, so an
importer (or ``fmpy.build.build_platform_binary``) can compile the FMU for its
own platform.
"""

from __future__ import annotations

import datetime
import xml.etree.ElementTree as ET

from grubler._version import __version__
from grubler.fmi.variables import ENUMERATION, INPUT, OUTPUT, PARAMETER, STRING, UNIT_OFFSET, UNITS, ModelSpec

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
        "fmiVersion": "2.0", "modelName": spec.identifier, "guid": spec.guid, "description": spec.description,
        "generationTool": f"grubler {__version__} (grubler.fmi)",
        "generationDateAndTime": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "variableNamingConvention": "structured", "numberOfEventIndicators": "0", "version": __version__,
    })
    cs = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": spec.identifier, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true", "canInterpolateInputs": "false",
        "maxOutputDerivativeOrder": "0", "canRunAsynchronuously": "false", "canBeInstantiatedOnlyOncePerProcess":
        "false", "canNotUseMemoryManagementFunctions": "false", "canGetAndSetFMUstate": "true",
        "canSerializeFMUstate": "true", "providesDirectionalDerivative": "true" if spec.defines.get("MODEL_DIRECTIONAL_DERIVATIVE") else "false",
    })
    files = ET.SubElement(cs, "SourceFiles")
    for s in sources:
        if s.endswith(".c"):
            ET.SubElement(files, "File", {"name": s})

    used = sorted({v.unit for v in spec.variables if v.unit})
    units = ET.SubElement(root, "UnitDefinitions")
    for u in used:
        unit = ET.SubElement(units, "Unit", {"name": u})
        base = {k: str(e) for k, e in UNITS[u].items()}
        if u in UNIT_OFFSET:
            base["offset"] = _num(UNIT_OFFSET[u])
        ET.SubElement(unit, "BaseUnit", base)

    if spec.enums:
        types = ET.SubElement(root, "TypeDefinitions")
        for e in spec.enums:
            st = ET.SubElement(types, "SimpleType", {"name": e.name, "description": e.description})
            en = ET.SubElement(st, "Enumeration")
            for k, (item, text) in enumerate(e.items, start=1):
                ET.SubElement(en, "Item", {"name": item, "value": str(k), "description": text})

    cats = ET.SubElement(root, "LogCategories")
    for name, text in LOG_CATEGORIES.items():
        ET.SubElement(cats, "Category", {"name": name, "description": text})

    ET.SubElement(root, "DefaultExperiment", {"startTime": "0.0", "stopTime": "1.0", "stepSize": "0.001"})

    mv = ET.SubElement(root, "ModelVariables")
    for k, v in enumerate(spec.variables, start=1):
        attrs = {"name": v.name, "valueReference": str(k), "description": described(v), "causality": v.causality,
                 "variability": "fixed" if v.causality == PARAMETER else "continuous"}
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
    inputs = {v.name: str(k) for k, v in enumerate(spec.variables, start=1) if v.causality == INPUT}
    outs = ET.SubElement(ms, "Outputs")
    init = ET.SubElement(ms, "InitialUnknowns")
    for k, v in enumerate(spec.variables, start=1):
        if v.causality != OUTPUT:
            continue
        deps = [inputs[n] for n in (v.depends_on or inputs)] if v.feedthrough else []
        a = {"index": str(k), "dependencies": " ".join(deps)}
        if deps:
            a["dependenciesKind"] = " ".join(["dependent"] * len(deps))
        ET.SubElement(outs, "Unknown", a)
        # at initialisation an output depends on the parameters (the assembly) and,
        # if it is feed-through, the inputs: all the knowns, which no attribute says
        ET.SubElement(init, "Unknown", {"index": str(k)})
    ET.indent(root)
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")
