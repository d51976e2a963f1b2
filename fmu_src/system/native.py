"""A whole system as one native FMU: its components' models and the master's loop in one binary.

When every FMU of an SSP system is a native grubler FMU, ``grubler export
SYSTEM.ssd`` compiles the models those FMUs were built from (the C in each
one's ``sources/``) with the master's stepping loop (``system/c/master.c``, the
C that ``grubler cosim`` steps FMUs with) into one source FMU: one binary, no
nested FMUs, nothing unpacked or loaded at run time.

How the models share one binary
    Each model keeps its own ``config.h``, variable table and copy of the
    wrapper's ``fmi_common.c``, in a folder of its own in ``sources/``; a
    generated ``symbols.h`` renames every symbol that model layer defines
    under a prefix of its own (``grb_m0_model_do_step``, ...), so two models,
    or a model and the system, never meet.  The kernels they call (the
    mechanism's, the laws', the drives') are shared: one copy of each file,
    which must be the same in every FMU that brought it.

What it runs
    ``fmi/c/system_model.c``: the components in ``grubler cosim``'s stepping
    order, initialised as cosim initialises them, stepped by master.c's
    loop with the master and tolerance its parameters name (Gauss-Seidel,
    Jacobi, extrapolating, with error-controlled sub-steps, Newton); it matches
    ``grubler cosim`` with the same step and settings (to rounding:
    tests/test_system_fmu.py).

Its variables
    ``communication_step`` [s] (a doStep of the importer's is made of equal
    steps no longer), ``master`` and ``tol``, the coupling ``grubler cosim``'s
    ``--master`` and ``--tol`` choose (fixed parameters: the scheme decides the
    stepping order and what the FMU state carries), then every component's parameters, unconnected inputs
    and outputs as ``component.name``, with their types, units, bounds and
    enumerations; the system's values are their defaults.  Its model
    identifier is the FMU's file name; its FMU state is the components' states
    together.

When it cannot
    An FMU that is not a native grubler FMU of this version (a pythonfmu
    controller, another tool's FMU, one built by another grubler) has no
    model this build can compile in: :func:`why_not_native` says why, and
    ``grubler export`` falls back to fmpy's container
    (:mod:`grubler.system.container`), which nests the FMUs as they are
    (Jacobi coupling, no FMU state, binaries for fewer platforms).

Examples
--------
>>> from grubler.system.ssp import System
>>> why_not_native(System("empty"))
'it has no components'
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import shutil
from dataclasses import dataclass
from pathlib import Path

from grubler.errors import SystemDescriptionError
from grubler.fmi.build import C_DIR, WRAPPER, build_fmu, check_destination, identifier_for, stage_sources
from grubler.fmi.header import TableRow, read_variables_source
from grubler.fmi.variables import (BOOLEAN, ENUMERATION, INPUT, INTEGER, OUTPUT, PARAMETER, REAL, STRING, UNITS,
                                   EnumType, ModelSpec, Variable)
from grubler.limits import brief
from grubler.system import cosim
from grubler.system.container import exposed_variables
from grubler.system.coupling import (NEWTON_MAX_ITER, NEWTON_TOL, adaptive_plan, input_modes, newton_plan,
                                     sampled_components)
from grubler.system.ssp import System, read

MASTER_DIR = Path(__file__).resolve().parent / "c"
# a built FMU's files that are its FMI side, never part of a system's model
ADAPTERS = {"fmi2_wrapper.c", "fmi3_wrapper.c"}
FMI_HEADER = re.compile(r"fmi[23](Functions|FunctionTypes|TypesPlatform|PlatformTypes)\.h")
INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"', re.M)
# a definition or declaration with external linkage at the start of a line (the model layer's style)
EXTERNAL = re.compile(r"^(?!static\b|typedef\b|extern\b|struct\b|enum\b|union\b|return\b)[A-Za-z_][\w \t*]*?"
                      r"\b([A-Za-z_]\w*)\s*[(\[]", re.M)
# the system's own parameters, slots 0, 1, 2 before the components' variables
SYSTEM_PARAMETERS = ("communication_step", "master", "tol")
# the masters a system FMU runs: grubler cosim's, in the order of master.c's grb_scheme (cosim._SCHEME)
SYSTEM_MASTERS = tuple(sorted(cosim._SCHEME, key=cosim._SCHEME.get))
assert [cosim._SCHEME[m] for m in SYSTEM_MASTERS] == list(range(len(SYSTEM_MASTERS)))
TOL_RANGE = (1e-14, 0.5)  # grubler cosim --tol's


def coupling_settings(master: str | None, tol: float | None) -> tuple[str, float]:
    """The system FMU's ``master`` and ``tol`` (0: no error control) as ``grubler cosim`` reads ``--master`` and
    ``--tol``: extrapolate by default with a tolerance, Gauss-Seidel without; a tolerance only with extrapolate.

    Examples
    --------
    >>> coupling_settings(None, 1e-6)
    ('extrapolate', 1e-06)
    >>> coupling_settings("jacobi", 1e-6)
    Traceback (most recent call last):
    ...
    grubler.errors.SystemDescriptionError: tol: the adaptive step is the extrapolating master's (master 'extrapolate'), got master 'jacobi'
    """
    if tol is not None and not (isinstance(tol, (int, float)) and math.isfinite(tol)
                                and TOL_RANGE[0] <= tol <= TOL_RANGE[1]):
        raise SystemDescriptionError(f"tol: must be a number from {TOL_RANGE[0]:g} to {TOL_RANGE[1]:g}, "
                                     f"got {brief(tol)}")
    master = master if master is not None else (cosim.EXTRAPOLATE if tol is not None else cosim.GAUSS_SEIDEL)
    if master not in SYSTEM_MASTERS:
        raise SystemDescriptionError(f"master: a system FMU runs {', '.join(SYSTEM_MASTERS)}, got {brief(master)}")
    if tol is not None and master != cosim.EXTRAPOLATE:
        raise SystemDescriptionError(f"tol: the adaptive step is the extrapolating master's (master "
                                     f"'{cosim.EXTRAPOLATE}'), got master {brief(master)}")
    return master, float(tol or 0.0)


@dataclass
class ComponentModel:
    """The model a native FMU was built from, as its ``sources/`` holds it."""

    fmu: Path
    identifier: str
    guid: str
    sources: Path
    layer: list[str]          # the files that include config.h (the model layer), config.h among them
    kernel: list[str]         # the rest: the kernels it calls
    table: list[TableRow]

    @property
    def n_stored(self) -> int:
        return sum(r.causality in (0, 1) for r in self.table)

    def row(self, name: str) -> TableRow:
        return next(r for r in self.table if r.name == name)

    @property
    def directional(self) -> bool:
        """Its model gives its outputs' derivatives along its inputs (providesDirectionalDerivative)."""
        return re.search(r"^#define MODEL_DIRECTIONAL_DERIVATIVE 1$", (self.sources / "config.h").read_text(),
                         re.M) is not None

    @property
    def law_state_used(self) -> bool:
        """Its law says how much of its state a run uses (defines law.h's law_state_used): a system backs up
        only that part before each step."""
        return any(re.search(r"^long law_state_used\([^;{]*\{", (self.sources / f).read_text(encoding="utf-8"), re.M)
                   for f in self.layer if f.endswith(".c"))


def _includes(folder: Path) -> dict[str, set[str]]:
    return {f.name: set(INCLUDE.findall(f.read_text(encoding="utf-8", errors="replace")))
            for f in folder.iterdir() if f.suffix in (".c", ".h", ".inc")}


def _model_layer(includes: dict[str, set[str]]) -> set[str]:
    """The files that include config.h, directly or through another file: those a model's constants shape."""
    layer = {"config.h"}
    grew = True
    while grew:
        grew = False
        for name, inc in includes.items():
            if name not in layer and inc & layer:
                layer.add(name)
                grew = True
    return layer


def component_model(fmu: Path, folder: Path) -> ComponentModel | str:
    """The model of the FMU unpacked in ``folder``, or why it has none this build can compile in."""
    md = (folder / "modelDescription.xml")
    try:
        text = md.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return f"{fmu.name} has no model description"
    tool = re.search(r'generationTool="([^"]*)"', text)
    if not tool or not tool.group(1).startswith("grubler"):
        return f"{fmu.name} is not a native grubler FMU (generated by {tool.group(1) if tool else 'an unknown tool'})"
    src = folder / "sources"
    if not (src / "config.h").is_file() or not (src / "model_variables.c").is_file():
        return f"{fmu.name} carries no model sources (a pythonfmu FMU?)"
    for name in WRAPPER:
        if not (src / name).is_file() or (src / name).read_bytes() != (C_DIR / name).read_bytes():
            return f"{fmu.name} was built by another grubler version ({name} differs: build it again)"
    try:
        table = read_variables_source((src / "model_variables.c").read_text(encoding="utf-8"))
    except ValueError as exc:
        return f"{fmu.name}: {exc}"
    if any(r.causality == 2 and r.type != 0 for r in table):
        return f"{fmu.name} has outputs that are not Real"
    includes = {k: v for k, v in _includes(src).items() if k not in ADAPTERS and not FMI_HEADER.fullmatch(k)}
    layer = _model_layer(includes)
    ident = re.search(r"^#define MODEL_IDENTIFIER (\w+)$", (src / "config.h").read_text(), re.M)
    guid = re.search(r'^#define MODEL_GUID "([^"]+)"$', (src / "config.h").read_text(), re.M)
    if not ident or not guid:
        return f"{fmu.name}: its config.h names no model"
    return ComponentModel(fmu, ident.group(1), guid.group(1), src, sorted(layer),
                          sorted(set(includes) - layer), table)


def _defined_symbols(model: ComponentModel) -> list[str]:
    """Every name the model layer gives external linkage (functions, the variable table, the starts)."""
    names: set[str] = set()
    for f in model.layer:
        if f != "config.h":
            names |= set(EXTERNAL.findall((model.sources / f).read_text(encoding="utf-8", errors="replace")))
    return sorted(names)


def why_not_native(system: System | str | Path, unpacked: "cosim.UnpackedFMUs | None" = None) -> str | None:
    """Why ``system`` cannot be one native FMU (None: it can), in a few words.

    Every FMU must be a native grubler FMU built by this grubler (its model's
    C in ``sources/``, its wrapper files this version's), with Real outputs,
    and two FMUs that carry a kernel file must carry the same one.  A system
    that cannot run at all is not this function's to judge (None: the
    export names its problems).

    Examples
    --------
    >>> from grubler.system.ssp import System
    >>> why_not_native(System("empty"))
    'it has no components'
    """
    if not isinstance(system, System):
        system = read(system)
    if not system.components:
        return "it has no components"
    own = unpacked is None
    unpacked = unpacked or cosim.UnpackedFMUs()
    try:
        try:
            interfaces = cosim.interfaces_of(system, unpacked)
        except SystemDescriptionError:
            return None  # not a question of models: the export reports the system's problems itself
        models = {}
        for name in system.components:
            path = interfaces[name].path
            if path not in models:
                models[path] = component_model(path, unpacked[path])
            if isinstance(models[path], str):
                return f"component {name}: {models[path]}"
        return _kernel_clash(list(models.values()))
    finally:
        if own:
            unpacked.close()


def _kernel_clash(models: list[ComponentModel]) -> str | None:
    seen: dict[str, ComponentModel] = {}
    for m in models:
        for f in m.kernel:
            first = seen.setdefault(f, m)
            if first is not m and (first.sources / f).read_bytes() != (m.sources / f).read_bytes():
                return f"{first.fmu.name} and {m.fmu.name} carry different {f} (build them with one grubler)"
    return None


# -- the system's ModelSpec --------------------------------------------------------------
_PY = {REAL: float, INTEGER: int, ENUMERATION: int, STRING: str}


def _value(value, fmi_type: str):
    if fmi_type == BOOLEAN:
        return value if isinstance(value, bool) else str(value).strip().lower() in ("true", "1")
    return _PY[fmi_type](value)


def _enum(var, enums: dict[str, EnumType], owner: str) -> EnumType:
    t = var.declaredType
    e = EnumType(t.name, t.description or t.name, tuple((i.name, i.description or i.name)
                                                       for i in sorted(t.items, key=lambda i: int(i.value))))
    if enums.get(e.name, e) != e:  # two models name different enumerations alike
        e = EnumType(f"{owner}_{t.name}", e.description, e.items)
    return enums.setdefault(e.name, e)


def system_spec(system: System, interfaces, models: dict[Path, ComponentModel], seq: list[str],
                identifier: str, step: float, master: str = cosim.GAUSS_SEIDEL,
                tol: float = 0.0) -> tuple[ModelSpec, list[dict]]:
    """The system FMU's ModelSpec and each component's wiring (in stepping order) for system_components.c."""
    variables = [Variable("communication_step", REAL, PARAMETER,
                          "the longest coupling step: an importer's doStep is made of equal communication steps no "
                          "longer, as grubler cosim --step makes them", start=float(step), unit="s", min=0.0),
                 Variable("master", STRING, PARAMETER,
                          "the coupling, as grubler cosim --master: gauss-seidel (each component steps on the "
                          "outputs of those before it), jacobi (all on the last step's values), extrapolate "
                          "(continuous inputs at the step's midpoint, second order; with tol, error-controlled "
                          "sub-steps), newton (each step iterated to its fixed point, rolled back through the "
                          "components' states, a Newton update of the coupled values)", start=master,
                          choices=SYSTEM_MASTERS),
                 Variable("tol", REAL, PARAMETER,
                          "error control, as grubler cosim --tol: the continuous components sub-step, each "
                          "sub-step's coupling error estimate (step doubling) within tol relative to max(1, |value|); "
                          f"0: none (else {TOL_RANGE[0]:g} to {TOL_RANGE[1]:g}, with master extrapolate)",
                          start=float(tol), unit="1", min=0.0, max=TOL_RANGE[1])]
    enums: dict[str, EnumType] = {}
    n_out = 0
    for e in exposed_variables(system, interfaces):
        comp, _, var = e.name.partition(".")
        md_var = next(v for v in interfaces[comp].model_description.modelVariables if v.name == var)
        row = models[interfaces[comp].path].row(var)
        unit = md_var.unit if md_var.unit in UNITS else None
        common = dict(description=e.description, unit=unit)
        if e.causality == OUTPUT:
            variables.append(Variable(e.name, REAL, OUTPUT, level=1 + row.level, slot=n_out, feedthrough=True,
                                      variability=md_var.variability if md_var.variability == "discrete" else None,
                                      **common))
            n_out += 1
            continue
        if e.type != REAL and e.causality == INPUT:
            raise SystemDescriptionError(f"input {e.name}: a {e.type} input; a system FMU takes Real inputs")
        start = _value(e.start, e.type)
        if e.type == STRING and start not in row.choices:
            raise SystemDescriptionError(f"parameter {e.name}: {brief(start)} is not one of its values "
                                         f"({', '.join(repr(c) for c in row.choices)})")
        bounds = {}
        if e.type == REAL:
            bounds = {k: float(x) for k, x in (("min", md_var.min), ("max", md_var.max)) if x is not None}
        elif e.type == INTEGER and (row.min or row.max):
            bounds = {"min": row.min, "max": row.max}
        variables.append(Variable(e.name, e.type, e.causality, start=start, choices=row.choices,
                                  enum=_enum(md_var, enums, comp) if e.type == ENUMERATION else None,
                                  **bounds, **common))
    connected_slot = cosim._slots(system)
    # the extrapolating master's input modes in the stepping order, and with tol in the adaptive order
    # (the sampled components first) that grubler cosim --tol steps in
    adaptive_seq = adaptive_plan(system, interfaces, seq, step, TOL_RANGE[1])[0]
    sampled = sampled_components(system, interfaces)
    modes, adaptive_modes = input_modes(system, interfaces, seq), input_modes(system, interfaces, adaptive_seq)
    # the Newton master's plan (cosim's): its order and input modes are the adaptive ones (the sampled components
    # first), its unknowns the slots of the outputs its iterated components' moving inputs read, in cosim's order
    plan = newton_plan(system, interfaces, seq)[0]
    assert plan is not None and plan.order == adaptive_seq and plan.modes == adaptive_modes
    unknowns = [connected_slot[u] for u in plan.unknowns]
    wiring, n_in, n_conn, n_free = [], 0, 0, 0
    for name in seq:
        itf, model, given = interfaces[name], models[interfaces[name].path], system.components[name].parameters
        mine = [v for v in variables if v.name.startswith(name + ".")]
        conn_out = list(dict.fromkeys(c.start_connector for c in system.connections if c.start_element == name))
        w = {"name": name, "model": list(models).index(itf.path), "n_stored": model.n_stored,
             "bound": [(v.name, model.row(v.name[len(name) + 1:]).slot, v.name[len(name) + 1:] in given)
                       for v in mine if v.causality in (PARAMETER, INPUT)],
             "free": [(itf.ports[v.name[len(name) + 1:]].vr, v.name) for v in mine if v.causality == INPUT],
             "in": [(itf.ports[c.end_connector].vr, connected_slot[c.start]) for c in system.connections
                    if c.end_element == name],
             "conn": [(itf.ports[o].vr, connected_slot[f"{name}.{o}"]) for o in conn_out],
             "out": [(itf.ports[v.name[len(name) + 1:]].vr, v.name) for v in mine if v.causality == OUTPUT],
             "sampled": name in sampled, "mode": modes[name], "adaptive_mode": adaptive_modes[name],
             "adaptive_position": adaptive_seq.index(name)}
        n_in, n_conn, n_free = n_in + len(w["in"]), n_conn + len(w["conn"]), max(n_free, len(w["free"]))
        wiring.append(w)
    # directional derivatives of the outputs along the system's inputs: an input moves only its own
    # component's outputs at an instant (the connections carry the values of the last communication point),
    # so the system gives them when every component with an unconnected input gives its own
    owners = [models[interfaces[w["name"]].path] for w in wiring if w["free"]]
    directional = {"MODEL_DIRECTIONAL_DERIVATIVE": 1} if owners and all(m.directional for m in owners) else {}
    parts = hashlib.sha256(repr([(m.identifier, m.guid) for m in models.values()]).encode()).hexdigest()
    spec = ModelSpec(identifier, system.description or f"the system {system.name} as one FMU", tuple(variables),
                     "system_model.c",
                     defines={"SYSTEM_N_COMPONENTS": len(seq), "SYSTEM_N_VALUES": len(connected_slot),
                              "SYSTEM_N_IN": n_in, "SYSTEM_N_CONN": n_conn, "SYSTEM_N_FREE": n_free,
                              "SYSTEM_N_OUT_MAX": max([len(w["out"]) for w in wiring] + [0]),
                              "SYSTEM_N_UNKNOWN": len(unknowns), "SYSTEM_NEWTON_MAX_ITER": NEWTON_MAX_ITER,
                              "SYSTEM_SLOT_STEP": 0, "SYSTEM_SLOT_MASTER": 1, "SYSTEM_SLOT_TOL": 2,
                              # the component models' GUIDs: the system's GUID changes with any of them
                              "SYSTEM_MODELS": int(parts[:12], 16), **directional},
                     n_outputs=n_out, enums=tuple(enums.values()),
                     kernel_sources=((MASTER_DIR, ("master.c",)), (C_DIR, ("system_model.h",))),
                     state=(("started", 1), ("t", 1), ("values", len(connected_slot)),
                            # the extrapolating master's history: the values at the last step's start and the
                            # point before, that step's length (0: no past point), the adaptive sub-step clock
                            ("start", len(connected_slot)), ("prev", len(connected_slot)), ("h_last", 1),
                            ("substep", 1), ("substep_prev", 1),
                            # the Newton master's Jacobian, kept from step to step as cosim keeps it: factored
                            # (LU), its row pivots, and whether it is usable (0: made again at the next step)
                            ("jacobian", len(unknowns) ** 2), ("pivot", len(unknowns)), ("have_jacobian", 1),
                            ("components", 0)))
    assert [spec.slot(n) for n in SYSTEM_PARAMETERS] == [0, 1, 2]
    return spec, wiring, unknowns


# -- sources/ ----------------------------------------------------------------------------
def _c_array(ctype: str, name: str, items: list) -> tuple[str, str]:
    """A static array's definition and the expression that names it (NULL when empty: C has no empty arrays)."""
    if not items:
        return "", "NULL"
    return f"static const {ctype} {name}[] = {{{', '.join(str(x) for x in items)}}};", name


def components_source(spec: ModelSpec, wiring: list[dict], n_models: int, value_names: list[str],
                      unknowns: list[int]) -> str:
    """Text of ``system_components.c``: the component table system_model.c steps, the adaptive stepping order,
    each connection value's name (its source output, for messages), and the Newton master's unknowns (their
    slots, each slot's unknown or -1) and its tolerance (cosim's NEWTON_TOL, written exactly)."""
    lines = [f"/* {spec.identifier}: generated by grubler.system.native; do not edit. */", '#include "system_model.h"',
             ""]
    lines += [f"extern const grb_component_calls grb_m{m}_calls;" for m in range(n_models)]
    adaptive = sorted(range(len(wiring)), key=lambda k: wiring[k]["adaptive_position"])
    lines += ["", f"const int system_adaptive_order[SYSTEM_N_COMPONENTS] = {{{', '.join(map(str, adaptive))}}};",
              f"const char *const system_value_names[SYSTEM_N_VALUES + 1] = "
              f"{{{', '.join(json.dumps(n) for n in value_names + [''])}}};",
              f"const int system_newton_unknowns[SYSTEM_N_UNKNOWN + 1] = {{{', '.join(map(str, unknowns + [0]))}}};",
              f"const int system_newton_index[SYSTEM_N_VALUES + 1] = "
              f"{{{', '.join(str(unknowns.index(j) if j in unknowns else -1) for j in range(len(value_names) + 1))}}};",
              f"const double system_newton_tol = {NEWTON_TOL!r};"]
    rows = []
    for k, w in enumerate(wiring):
        bound = [f"{{{spec.slot(n)}, {slot}, {int(given)}}}" for n, slot, given in w["bound"]]
        arrays = [_c_array("grb_binding", f"bound_{k}", bound),
                  _c_array("unsigned int", f"free_vr_{k}", [f"{vr}u" for vr, _ in w["free"]]),
                  _c_array("int", f"free_slot_{k}", [spec.slot(n) for _, n in w["free"]]),
                  _c_array("unsigned int", f"in_vr_{k}", [f"{vr}u" for vr, _ in w["in"]]),
                  _c_array("int", f"in_slot_{k}", [s for _, s in w["in"]]),
                  _c_array("unsigned int", f"conn_vr_{k}", [f"{vr}u" for vr, _ in w["conn"]]),
                  _c_array("int", f"out_slot_{k}", [s for _, s in w["conn"]]),
                  _c_array("unsigned int", f"out_vr_{k}", [f"{vr}u" for vr, _ in w["out"]]),
                  _c_array("int", f"out_level_{k}", [spec.variables[spec.vr(n) - 1].level for _, n in w["out"]]),
                  _c_array("int", f"in_mode_{k}", w["mode"]),
                  _c_array("int", f"in_mode_adaptive_{k}", w["adaptive_mode"])]
        lines += [d for d, _ in arrays if d]
        names = [n for _, n in arrays]
        base = spec.slot(w["out"][0][1]) if w["out"] else 0
        rows.append(f"    {{{json.dumps(w['name'])}, &grb_m{w['model']}_calls, {w['n_stored']}, "
                    f"{len(w['bound'])}, {names[0]}, {len(w['free'])}, {names[1]}, {names[2]}, "
                    f"{len(w['in'])}, {names[3]}, {names[4]}, {len(w['conn'])}, {names[5]}, {names[6]}, "
                    f"{len(w['out'])}, {names[7]}, {base}, {names[8]}, {int(w['sampled'])}, {names[9]}, "
                    f"{names[10]}}},")
    lines += ["", "const grb_component system_components[SYSTEM_N_COMPONENTS] = {", *rows, "};", ""]
    return "\n".join(lines)


GLUE = """
/* ---- the system's calls of this model (system_model.h), generated by grubler.system.native ---- */
#include "../system_model.h"

static void glue_fresh(grb_instance *ci) { fresh_block(ci); }
static int glue_block_ok(grb_instance *ci, const char *call, const double *block) { return block_ok(ci, call, block); }
static grb_fmi_status glue_prepare(grb_instance *ci) { return ready(ci, 0); }
static int glue_set_real(void *ci, const unsigned int *vr, size_t n, const double *value) {
    return (int)grb_set_real((grb_instance *)ci, "setReal", vr, n, value);
}
static int glue_get_real(void *ci, const unsigned int *vr, size_t n, double *value) {
    return (int)grb_get_real((grb_instance *)ci, "getReal", vr, n, value);
}
static int glue_do_step(void *ci, double t, double h, int no_set_fmu_state_prior) {
    (void)no_set_fmu_state_prior;
    return (int)grb_do_step((grb_instance *)ci, "doStep", t, h);
}
static int glue_directional(void *ci, const unsigned int *unknown, size_t n_unknown, const unsigned int *known,
                            size_t n_known, const double *seed, double *sensitivity) {
    return (int)grb_directional_derivative((grb_instance *)ci, "getDirectionalDerivative", unknown, n_unknown, known,
                                           n_known, seed, sensitivity);
}

LIVE
const grb_component_calls PREFIXcalls = {
    model_persistent_size, model_scratch_bytes, glue_fresh, glue_block_ok, glue_prepare, grb_exit_initialization,
    glue_set_real, glue_get_real, glue_do_step, glue_directional, glue_live_size
};
"""

# The glue's live_size: a law model's block ends in the law's state (law_model.c: P_LAW to P_END), of which a
# law that defines law_state_used (law.h) uses only a part; any other model, the whole block.
LIVE_WHOLE = """static size_t glue_live_size(const double *block) { (void)block; return model_persistent_size(); }
"""
LIVE_LAW = """long law_state_used(const double *param);
static size_t glue_live_size(const double *block) {
    long used = law_state_used(block);  /* (the law's parameters are the block's first slots) */
    return used >= 0 && used < LAW_N_STATE ? (size_t)P_LAW + (size_t)used : model_persistent_size();
}
"""


def stage_system(models: list[ComponentModel], wiring: list[dict], value_names: list[str], unknowns: list[int]):
    """The ``stage`` of :func:`grubler.fmi.build.build_fmu` for a system: the system model's own sources,
    each component model in a folder of its own under its prefix, the kernels once."""

    def stage(spec: ModelSpec, sources: Path, fmi: int) -> list[str]:
        files = [f for f in stage_sources(spec, sources, fmi) if f != "master.c"]  # (system_model.c includes it)
        (sources / "system_components.c").write_text(
            components_source(spec, wiring, len(models), value_names, unknowns))
        files.append("system_components.c")
        for m in models:
            for f in m.kernel:
                if not (sources / f).exists():
                    shutil.copy2(m.sources / f, sources / f)
                    if f.endswith(".c"):
                        files.append(f)
        for k, m in enumerate(models):
            folder, prefix = f"m{k}_{m.identifier}", f"grb_m{k}_"
            (sources / folder).mkdir()
            for f in m.layer:
                shutil.copy2(m.sources / f, sources / folder / f)
            (sources / folder / "symbols.h").write_text(
                f"/* {m.identifier}'s model under the prefix {prefix}: generated by grubler.system.native */\n"
                + "".join(f"#define {s} {prefix}{s}\n" for s in _defined_symbols(m)))
            for f in m.layer:
                if not f.endswith(".c"):
                    continue
                unit = f"unit_{f}"
                text = f'/* {f} of {m.identifier} under its prefix */\n#include "symbols.h"\n#include "{f}"\n'
                if f == "fmi_common.c":
                    live = LIVE_LAW if m.law_state_used else LIVE_WHOLE
                    text += GLUE.replace("PREFIX", prefix).replace("LIVE", live)
                (sources / folder / unit).write_text(text)
                files.append(f"{folder}/{unit}")
        return sorted(files)

    return stage


def export_native_system(system: System | str | Path, dest: str | Path | None = None, platforms=None, fmi: int = 2,
                         field: str = "output", master: str | None = None, tol: float | None = None,
                         sources: bool = True) -> Path:
    """Export an SSP system of native grubler FMUs as one native FMU (its models and master.c compiled together).

    Parameters
    ----------
    system : System or path of a .ssd / .ssp
        Its step (the SSD's annotation, else 1 ms) is the FMU's
        ``communication_step``, its stepping order the FMU's.
    dest : path, optional
        The ``.fmu`` to write (default: ``<system name>.fmu``); its name is the model identifier.
    platforms : str or list of str, optional
        The binaries to ship (:func:`grubler.fmi.build.build_fmu`).
    fmi : {2, 3}
    master, tol : optional
        The start values of the FMU's ``master`` and ``tol`` parameters, as
        ``grubler cosim``'s ``master`` and ``tol`` (:func:`coupling_settings`).
    sources : bool
        Ship ``sources/`` (default); without, a binary-only FMU for deployment
        (:func:`grubler.fmi.build.build_fmu`): it starts faster, runs only where
        its binaries do, and cannot be compiled into another system FMU.

    Raises
    ------
    SystemDescriptionError
        A system that cannot run (every problem named, as ``grubler cosim``
        names them), or one with an FMU that is not a native grubler FMU
        (:func:`why_not_native` says which: export it with
        :func:`grubler.system.container.export_system`).

    Examples
    --------
    Compiling the servo four-bar's five models takes 10 to 20 s, so it is not
    run here (``tests/test_system_fmu.py`` exports and runs it:
    ``export_native_system("examples/servo_fourbar.ssd", "ServoFourbar.fmu")``);
    a system that cannot be one FMU is refused before any compiling:

    >>> from grubler.system.ssp import System
    >>> export_native_system(System("empty"))
    Traceback (most recent call last):
    ...
    grubler.errors.SystemDescriptionError: system 'empty': has no components
    """
    if not isinstance(system, System):
        system = read(system)
    if not system.components:
        raise SystemDescriptionError(f"system {brief(system.name)}: has no components")
    dest = Path(dest) if dest is not None else Path(f"{system.name or 'system'}.fmu")
    check_destination(dest, field)
    master, tol = coupling_settings(master, tol)
    step = system.step if system.step is not None else 1e-3
    with cosim.UnpackedFMUs() as unpacked:
        interfaces = cosim.interfaces_of(system, unpacked)
        seq = cosim._stepping_order(system, interfaces, None)
        why = why_not_native(system, unpacked)
        if why is not None:
            raise SystemDescriptionError(f"system {brief(system.name)}: cannot be one native FMU: {why}")
        models: dict[Path, ComponentModel] = {}
        for name in system.components:
            path = interfaces[name].path
            if path not in models:
                models[path] = component_model(path, unpacked[path])
        spec, wiring, unknowns = system_spec(system, interfaces, models, seq, identifier_for(dest), step, master, tol)
        slot = cosim._slots(system)
        return build_fmu(spec, dest, platforms, fmi,
                         stage=stage_system(list(models.values()), wiring, sorted(slot, key=slot.get), unknowns),
                         sources=sources)


__all__ = ["export_native_system", "why_not_native", "coupling_settings"]
