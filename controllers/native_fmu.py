"""Native FMUs of the shipped control laws: PID, cascade, encoder, tachometer, current sensor, trajectory,
computed torque, and any linear controller (by default a discrete PI).

Each is the law's C (``controllers/kernel``) behind a law file
(``grubler/fmi/c/pid_law.c``, ``cascade_law.c``, ...), the generic sampled-law model
(``law_model.c``: the sample-and-hold clock of :mod:`grubler.controllers.law`)
and the one FMI wrapper every native grubler FMU uses: no Python at run time.
The variables are the law's own declaration (its ``inputs``, ``outputs`` and
``parameters``), in the order of the C structures, so the library's class, its
pythonfmu FMU (:func:`grubler.controllers.fmu.build_controller_fmu`) and its
native FMU show the same names, units and defaults.

Examples
--------
>>> spec = pid_spec()
>>> [v.name for v in spec.variables if v.causality == "input"]
['setpoint', 'measurement', 'feedforward']
>>> spec.variables[spec.vr("anti_windup") - 1].choices
('back-calculation', 'conditional', 'none')
"""

from __future__ import annotations

import ctypes
import math
import re
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

from grubler import binding
from grubler.controllers import native
from grubler.controllers.cascade import CascadeController
from grubler.controllers.encoder import Encoder
from grubler.controllers.law import Law, Parameter
from grubler.controllers.linear import LinearController
from grubler.controllers.pid import ANTI_WINDUP, PID
from grubler.controllers.sensors import AnalogSensor, CurrentSensor, Tachometer
from grubler.controllers.trajectory import KINDS, Trajectory, read_profile
from grubler.errors import SceneError
from grubler.fmi.build import C_DIR, BuildError, build_fmu, check_destination, computed_torque_fmu, identifier_for
from grubler.limits import brief, clip
from grubler.fmi.variables import BOOLEAN, INPUT, INTEGER, OUTPUT, PARAMETER, REAL, STRING, UNITS, ModelSpec, Variable

# readings the Encoder FMU's delay line holds (its state grows with it: 80 kB):
# a delay of up to 9999 samples, 10 s at 1 kHz
ENCODER_CAPACITY = 10_000
INT_MAX = 2**31 - 1


def _unit(description: str) -> str | None:
    """The FMI unit of a description ending in ``[unit]`` (None for ``[any]`` and units FMI is not told)."""
    m = re.search(r"\[([^\]]*)\]\s*$", description)
    unit = m[1].replace(" ", ".") if m else None
    return unit if unit in UNITS else None


def _type(value) -> str:
    for py, fmi in ((bool, BOOLEAN), (int, INTEGER), (float, REAL), (str, STRING)):
        if isinstance(value, py):
            return fmi
    raise TypeError(f"parameter default {value!r}: an FMU parameter is a float, int, bool or str")


def law_spec(law: type[Law], identifier: str, model_source: str, n_state: int, n_scratch: int = 0,
             choices: dict | None = None, bounds: dict | None = None, leave_out: tuple[str, ...] = (),
             extra: tuple[Variable, ...] = (), defines: dict | None = None) -> ModelSpec:
    """The ModelSpec of a native law FMU from the law's declaration.

    Parameters
    ----------
    law : type
        The :class:`Law` whose ``parameters`` (in the order of its C
        structure), ``inputs`` and ``outputs`` the FMU shows.
    identifier, model_source : str
        The modelIdentifier and the law file in ``grubler/fmi/c`` (law.h).
    n_state, n_scratch : int
        Doubles of the law's saved state and of its derived constants.
    choices : dict, optional
        A String parameter's accepted values (stored as the index, the C enum).
    bounds : dict, optional
        An Integer parameter's (min, max).
    leave_out : tuple of str
        Parameters the native FMU does not show.
    extra : tuple of Variable
        Parameters after the law's (a table's points).
    """
    choices, bounds = choices or {}, bounds or {}
    v = []
    for name, par in law.parameters.items():
        if name in leave_out:
            continue
        kind = _type(par.fmu_start)
        lo, hi = bounds.get(name, (None, None))
        unit = _unit(par.description) if kind == REAL else None  # FMI gives units to Reals only
        v.append(Variable(name, kind, PARAMETER, par.description, par.fmu_start, unit, lo, hi,
                          choices=tuple(choices.get(name, ()))))
    v += list(extra)
    n_params = len(v)
    for name, text in law.inputs.items():
        v.append(Variable(name, REAL, INPUT, text, 0.0, _unit(text)))
    # a sampled law's outputs are held between samples: discrete, changing only at its sample instants
    held = None if law.continuous else "discrete"
    for k, (name, text) in enumerate(law.outputs.items()):
        v.append(Variable(name, REAL, OUTPUT, text, unit=_unit(text), level=1, slot=k, variability=held))
    state = (("started", 1), ("t0", 1), ("t", 1), ("samples", 1), ("out", len(law.outputs)), ("law", n_state),
             ("end", 0))
    lines = (law.__doc__ or law.__name__).strip().splitlines()
    # the clock: a law of time alone, or the parameter that holds the sample time
    clock = {"LAW_CONTINUOUS": 1} if law.continuous else {"LAW_CONTINUOUS": 0,
                                                          "LAW_TS_SLOT": [x.name for x in v].index("Ts")}
    return ModelSpec(identifier, lines[0].rstrip("."), tuple(v), model_source,
                     {"LAW_N_PARAMS": n_params, "LAW_N_INPUTS": len(law.inputs), "LAW_N_STATE": n_state,
                      "LAW_N_SCRATCH": n_scratch, **clock, **(defines or {})},
                     len(law.outputs), (), (), ("controllers", "law"), state)


def pid_spec(identifier: str = "PID") -> ModelSpec:
    """PID.fmu: :class:`~grubler.controllers.pid.PID` over ``ctl_pid.c``."""
    return law_spec(PID, identifier, "pid_law.c", ctypes.sizeof(native.PidState) // 8,
                    choices={"anti_windup": ANTI_WINDUP})


def cascade_spec(identifier: str = "CascadeController") -> ModelSpec:
    """CascadeController.fmu: :class:`~grubler.controllers.cascade.CascadeController` over ``ctl_cascade.c``."""
    return law_spec(CascadeController, identifier, "cascade_law.c", ctypes.sizeof(native.CascadeState) // 8)


def encoder_spec(identifier: str = "Encoder") -> ModelSpec:
    """Encoder.fmu: :class:`~grubler.controllers.encoder.Encoder` over ``ctl_encoder.c``."""
    return law_spec(Encoder, identifier, "encoder_law.c", ctypes.sizeof(native.EncoderState) // 8 + ENCODER_CAPACITY,
                    bounds={"counts_per_rev": (0, INT_MAX), "seed": (0, INT_MAX), "delay": (0, ENCODER_CAPACITY - 1)},
                    defines={"ENCODER_CAPACITY": ENCODER_CAPACITY})


def linear_spec(controller: LinearController, identifier: str = "Linear") -> ModelSpec:
    """The native FMU of one :class:`~grubler.controllers.linear.LinearController`.

    Its matrices, discretised as the library discretises them, are the FMU's
    parameters ``A[i,j]``, ``B[i]``, ``C[i]``, ``D`` (indices from 1), after
    ``Ts``, the sample time they are discrete at (change them together).
    """
    n = controller.A.shape[0]
    m = controller.matrices
    names = ([f"A[{i + 1},{j + 1}]" for i in range(n) for j in range(n)] + [f"B[{i + 1}]" for i in range(n)]
             + [f"C[{i + 1}]" for i in range(n)] + ["D"])
    params = {"Ts": Parameter(float(controller.Ts), "sample time the matrices are discrete at [s]")}
    params.update({name: Parameter(float(x), f"x_k+1 = A x_k + B e_k, u_k = C x_k + D e_k + u_ff: {name} [1]")
                   for name, x in zip(names, m)})
    law = type(identifier, (Law,), {"inputs": LinearController.inputs, "outputs": LinearController.outputs,
                                    "parameters": params, "__doc__": f"A discrete linear controller of order {n}."})
    return law_spec(law, identifier, "linear_law.c", n, defines={"LINEAR_ORDER": n})


# The controller dist/LinearController.fmu starts as (docs/control.md): the PI of
# examples/pi_law.c, C(s) = K (1 + 1/(Ti s)) with K = 2 V/rad and Ti = 0.1 s
# (without its clamp), discretised by Tustin at Ts = 1 ms.
LINEAR_DEFAULT = {"num": (2.0, 20.0), "den": (1.0, 0.0), "Ts": 1e-3, "method": "tustin"}


def linear_default() -> LinearController:
    """The default LinearController FMU's controller: :data:`LINEAR_DEFAULT`, a discrete PI.

    Examples
    --------
    >>> ctl = linear_default()
    >>> ctl.A.shape, float(ctl.Ts)
    ((1, 1), 0.001)
    """
    import control

    d = LINEAR_DEFAULT
    return LinearController(control.tf(list(d["num"]), list(d["den"])), d["Ts"], d["method"])


def sensor_spec(law: type[AnalogSensor], identifier: str | None = None) -> ModelSpec:
    """Tachometer.fmu or CurrentSensor.fmu: an :class:`~grubler.controllers.sensors.AnalogSensor` over ``ctl_sensor.c``."""
    return law_spec(law, identifier or law.__name__, "sensor_law.c", ctypes.sizeof(native.SensorState) // 8,
                    bounds={"seed": (0, INT_MAX)})


# what a trajectory drives -> the unit of its positions (speeds, accelerations, limits: per s, s2, s3)
QUANTITIES = {"angle": "rad", "length": "m"}


def _in_quantity(spec: ModelSpec, quantity: str) -> ModelSpec:
    """A trajectory's variables in the unit of what it drives: rad for an angle (the law's own), m for a length."""
    if quantity not in QUANTITIES:
        raise SceneError("quantity", f"a trajectory drives an {' or a '.join(QUANTITIES)}, got {brief(quantity)}")
    to = QUANTITIES[quantity]

    def convert(v: Variable) -> Variable:
        if not v.description.rstrip().endswith("]"):
            return v
        old = v.description[v.description.rindex("[") + 1:v.description.rindex("]")]
        if not old.startswith("rad"):
            return v
        new = to + old[3:]
        return replace(v, description=v.description[:v.description.rindex("[")] + f"[{new}]",
                       unit=new if new in UNITS else None)

    return spec if to == "rad" else replace(spec, variables=tuple(convert(v) for v in spec.variables))


def trajectory_spec(identifier: str = "Trajectory", times=None, positions=None, quantity: str = "angle") -> ModelSpec:
    """Trajectory.fmu: :class:`~grubler.controllers.trajectory.Trajectory` over ``ctl_trajectory.c``.

    Without ``times`` the kinds are constant, trapezoid, scurve and sine; with
    them the FMU serves 'table' too, its points parameters ``times[k]`` and
    ``positions[k]`` (k from 1) starting at these values.  ``quantity`` (a key
    of :data:`QUANTITIES`) is what it drives: an ``angle`` (rad, rad/s, ...) or
    a ``length`` (a cylinder's: m, m/s, ...), the unit of its positions.
    """
    n = 0 if times is None else len(times)
    extra = ()
    if n:
        extra = tuple(Variable(f"times[{k + 1}]", REAL, PARAMETER, "table: time of a point [s]", float(x), "s")
                      for k, x in enumerate(times))
        extra += tuple(Variable(f"positions[{k + 1}]", REAL, PARAMETER, "table: position at that time [rad]",
                                float(x), "rad") for k, x in enumerate(positions))
    plan = (ctypes.sizeof(native.Move) + 7) // 8
    return _in_quantity(law_spec(Trajectory, identifier, "trajectory_law.c", 0, plan + 2 * n,
                                 choices={"kind": KINDS if n else KINDS[:-1]}, bounds={"repeat": (0, INT_MAX)},
                                 leave_out=("times", "positions"), extra=extra, defines={"TRAJECTORY_POINTS": n}),
                        quantity)


def computed_torque_spec(scene=None, identifier: str = "ComputedTorque") -> ModelSpec:
    """ComputedTorque.fmu: :class:`~grubler.controllers.computed_torque.ComputedTorque` over the kernel's drive demand.

    The law's parameters, then the scene's as the Mechanism FMU shows them
    (:func:`grubler.fmi.mechanism.mechanism_spec`: gravity, the ground vector,
    ``drive_joint``, every link's and closure's fields, the sketch
    ``initial.*`` and the force elements' fields), starting at ``scene``'s
    values (default the thesis four-bar): one FMU serves every mechanism of
    that shape.  The demand holds the force elements' efforts, as the
    library's does.

    Raises
    ------
    SceneError
        A scene without a drive joint or of mobility other than one.
    """
    from grubler.controllers.computed_torque import ComputedTorque
    from grubler.fmi.mechanism import (CLOSURE, CLOSURE_FIELDS, JOINT, LINK_FIELDS, STANDARD_SCENE, closure_prefix,
                                       force_defines, force_parameter_names, mechanism_spec, scene_parameters)
    from grubler.mechanism.scene import Scene, load_scene

    scene = scene if isinstance(scene, Scene) else load_scene(scene or STANDARD_SCENE)
    m = scene.mechanism
    if m.drive is None:
        raise SceneError("drive.joint", "computed torque needs the joint the drive acts on")
    if m.mobility != 1:
        raise SceneError("mechanism", f"computed torque follows one drive coordinate; this mechanism has mobility "
                                      f"{m.mobility}")
    n, nc = m.n_links, len(m.closures)
    plant = {v.name: v for v in mechanism_spec(scene).variables}
    scene_names = list(scene_parameters(scene))
    law_names = [x for x in ComputedTorque.parameters if x != "mechanism"]
    slot = {x: k for k, x in enumerate(law_names + scene_names)}
    defines = {f"PARAM_{x}": slot[x] for x in law_names}
    defines.update({"N_LINKS": n, "N_CLOSURES": nc, "LINK_STRIDE": len(LINK_FIELDS),
                    "CLOSURE_STRIDE": len(CLOSURE_FIELDS), "SLOT_GRAVITY": slot["gravity"],
                    "SLOT_GROUND_A1": slot["ground.a1"], "SLOT_GROUND_THETA1": slot["ground.theta1"],
                    "SLOT_DRIVE_JOINT": slot["drive_joint"], "SLOT_LINKS": slot["link2.joint"],
                    "SLOT_CLOSURES": slot[f"{closure_prefix(nc, 0)}.type"] if nc else len(slot),
                    "SLOT_Q0": slot[f"initial.{m.coordinate_names[0]}"],
                    "CT_WORK_SIZE": binding.work_size(n, nc)})
    defines.update({f"LF_{f.upper()}": k for k, f in enumerate(LINK_FIELDS)})
    defines.update({f"CF_{f.upper()}": k for k, f in enumerate(CLOSURE_FIELDS)})
    # the force elements, as the Mechanism FMU and the library compute with them: the demand holds their efforts
    defines.update(force_defines(m, slot[force_parameter_names(m)[0]] if m.forces else len(slot)))
    defines["TABLE_FORCE_SIZE"] = m.force_table().size
    tables = m.arrays.links.size + m.arrays.closures.size + defines["TABLE_FORCE_SIZE"]
    # as every control FMU's, a description ends in its unit ([1]: none, or a joint's that slides or turns)
    extra = tuple(v if v.description.endswith("]") else replace(v, description=f"{v.description} [{v.unit or '1'}]")
                  for v in (plant[x] for x in scene_names))
    # the scratch (the kernel's tables and workspace) and, of the same layout, law_check's own working memory:
    # the workspace grows with the links squared (400 kB at 63 links), too much for an importer's thread stack
    defines["LAW_N_CHECK"] = tables + defines["CT_WORK_SIZE"]
    spec = law_spec(ComputedTorque, identifier, "computed_torque_law.c", n, defines["LAW_N_CHECK"],
                    leave_out=("mechanism",), extra=extra, defines=defines)
    variables = tuple(replace(v, start=float(m.drive_inertia)) if v.name == "drive_inertia" else v
                      for v in spec.variables)
    return replace(spec, variables=variables, enums=(JOINT, CLOSURE),
                   kernel_sources=("kernel", *spec.kernel_sources))


def export_computed_torque(scene, fmu_dir) -> tuple[Path, dict]:
    """The ComputedTorque FMU that serves ``scene`` (:func:`grubler.fmi.build.computed_torque_fmu`), built
    into ``fmu_dir`` when the scene's shape is not ``ComputedTorque.fmu``'s; and the scene's parameters."""
    path, params = computed_torque_fmu(scene, fmu_dir)
    if path.name != "ComputedTorque.fmu":
        build_fmu(computed_torque_spec(scene, path.stem), path)
    return path, params


# -- a law written as one C function (grubler_law.h) -----------------------------------
_DECLARATION = re.compile(r"^[ \t]*GRUBLER_(\w+)\s*\((.*)\)\s*;?\s*$")
_QUOTED = r'"((?:[^"\\\n]|\\.)*)"'
_FORMS = {"PARAMETER": re.compile(r"^\s*([A-Za-z_]\w*)\s*,\s*([^,]+?)\s*,\s*" + _QUOTED + r"\s*$"),
          "INPUT": re.compile(r"^\s*([A-Za-z_]\w*)\s*,\s*" + _QUOTED + r"\s*$"),
          "OUTPUT": re.compile(r"^\s*([A-Za-z_]\w*)\s*,\s*" + _QUOTED + r"\s*$"),
          "STATE": re.compile(r"^\s*(\d+)\s*$")}
_USAGE = {"PARAMETER": 'GRUBLER_PARAMETER(name, start, "description [unit]")',
          "INPUT": 'GRUBLER_INPUT(name, "description [unit]")', "OUTPUT": 'GRUBLER_OUTPUT(name, "description [unit]")',
          "STATE": "GRUBLER_STATE(count)"}
MAX_LAW_STATE = 100_000  # doubles a C law may keep: 800 kB of FMU state
# C's escapes in a string literal: simple, hexadecimal, octal, universal
_ESCAPE = re.compile(r"\\(?:([\\\"'?abfnrtv])|x([0-9A-Fa-f]+)|([0-7]{1,3})|u([0-9A-Fa-f]{4})|U([0-9A-Fa-f]{8})|(.?))",
                     re.S)
_SIMPLE = {"\\": "\\", '"': '"', "'": "'", "?": "?", "a": "\a", "b": "\b", "f": "\f", "n": "\n", "r": "\r",
           "t": "\t", "v": "\v"}
# comments and literals, blanked (newlines kept) before the source is searched for definitions
_NOT_CODE = re.compile(r"//[^\n]*|/\*.*?\*/|\"(?:\\.|[^\"\\\n])*\"|'(?:\\.|[^'\\\n])*'", re.S)
_DEFINITION = re.compile(r"\b([A-Za-z_]\w*)\s*\((?:[^()]|\([^()]*\))*\)\s*\{")


def _c_text(raw: str, where: str, name: str) -> str:
    """A description as the C string literal ``raw`` spells it, or a SceneError naming the declaration.

    Its escapes read as C reads them (a ``\\x`` or octal escape is a byte, the
    bytes UTF-8); it must be one line of text an FMU's modelDescription.xml can
    carry: no control character (XML 1.0 has no NUL, and attributes turn tabs
    and line breaks into spaces), no surrogate, no U+FFFE or U+FFFF.
    """
    import unicodedata

    out, pos = bytearray(), 0
    for m in _ESCAPE.finditer(raw):
        out += raw[pos:m.start()].encode("utf-8", "surrogatepass")
        pos = m.end()
        simple, hexa, octal, u4, u8, other = m.groups()
        if simple:
            out += _SIMPLE[simple].encode()
        elif hexa or octal:
            value = int(hexa, 16) if hexa else int(octal, 8)
            if value > 0xFF:
                raise SceneError("law", f"{where}: the description of {name}: the escape {m[0][:12]!r} is more "
                                        "than a byte")
            out.append(value)
        elif u4 or u8:
            code = int(u4 or u8, 16)
            if code > 0x10FFFF:
                raise SceneError("law", f"{where}: the description of {name}: {m[0]!r} is no Unicode character")
            out += chr(code).encode("utf-8", "surrogatepass")
        else:
            raise SceneError("law", f"{where}: the description of {name}: {m[0]} is no C escape (write \\\\ for "
                                    "a backslash)")
    out += raw[pos:].encode("utf-8", "surrogatepass")
    try:
        text = out.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError("law", f"{where}: the description of {name}: its escapes make byte 0x{out[exc.start]:02x}, "
                                "which is not UTF-8 text") from None
    bad = next((c for c in text if unicodedata.category(c) in ("Cc", "Cs") or c in "\ufffe\uffff"), None)
    if bad is not None:
        raise SceneError("law", f"{where}: the description of {name} holds U+{ord(bad):04X}, a character an FMU's "
                                "modelDescription.xml cannot carry; a description is one line of text")
    return text


def _reserved_names() -> set[str]:
    """What law.h declares for the FMU's own law file (user_law.c): a law defines law_step, not these."""
    header = (C_DIR / "law.h").read_text()
    return set(re.findall(r"\b(law_\w+)\s*\(", _NOT_CODE.sub("", header))) - {"law_step"}


def _blank(match: re.Match) -> str:
    return re.sub(r"[^\n]", " ", match[0])


def _check_reserved(text: str, field: str) -> None:
    """Refuse a definition of a name the FMU's code defines: the FMI functions and law.h's contract.

    Checked here, before compiling, so the answer names the line; the linker
    answers for the rest (:func:`_diagnostic`).
    """
    code = _NOT_CODE.sub(_blank, text)
    reserved = _reserved_names()
    for m in _DEFINITION.finditer(code):
        name = m[1]
        if not (name in reserved or name.startswith(("fmi2", "fmi3"))):
            continue
        head = code[max(code.rfind(";", 0, m.start()), code.rfind("}", 0, m.start())) + 1:m.start()]
        if re.search(r"\bstatic\b", head):  # a file's own function: no clash
            continue
        line = code.count("\n", 0, m.start(1)) + 1
        raise SceneError("law", f"{field}:{line}: defines {name}, a name the FMU's own code defines (the FMI "
                                "functions and law.h's); a law defines law_step: rename it, or make it static")


def _diagnostic(log: str, source: str, text: str) -> str | None:
    """The first real diagnostic of a failed build, in the user's terms: file:line: reason.

    A compiler error (``file:line:col: error: message``; in a file the law
    includes, with the line that includes it), or a linker's duplicate or
    missing symbol, mapped to the first line of the law that names it.
    """
    def ours(path: str) -> str:  # the staged copy is the user's file; the FMU's own files by their names
        if path.endswith("law_step.c"):
            return source
        return Path(path).name if re.search(r"grubler_native_[^/\\]*[/\\]sources[/\\]", path) else path

    included = None
    for line in log.splitlines():
        inc = re.match(r"^\s*(?:In file included from|from) (.*?):(\d+)[:,]", line)
        if inc and inc[1].endswith("law_step.c"):
            included = f"{source}:{inc[2]}"
        m = re.match(r"^(.*?):(\d+):(\d+): (?:fatal )?error: (.*)$", line)
        if m:
            at = f"{ours(m[1])}:{m[2]}:{m[3]}: {m[4].strip()}"
            return at if m[1].endswith("law_step.c") or included is None else f"{at} (included at {included})"
        m = (re.search(r"multiple definition of [`'‘\"]?([A-Za-z_]\w*)", line)
             or re.search(r"duplicate symbol: ([A-Za-z_]\w*)", line))
        if m:
            return f"{source}:{_line_of(m[1], text)}: defines {m[1]}, a name the FMU's own code defines; rename " \
                   "it, or make it static"
        m = (re.search(r"undefined reference to [`'‘\"]?([A-Za-z_]\w*)", line)
             or re.search(r"undefined symbol: ([A-Za-z_]\w*)", line))
        if m:
            return f"{source}:{_line_of(m[1], text)}: uses {m[1]}, which nothing defines (an FMU links the C " \
                   "library and its maths, nothing else)"
    return None


def _line_of(name: str, text: str) -> int:
    """The first line of ``text`` whose code names ``name`` (1 if none does)."""
    code = _NOT_CODE.sub(_blank, text)
    m = re.search(rf"\b{re.escape(name)}\b", code)
    return code.count("\n", 0, m.start()) + 1 if m else 1


def _law_text(source: str | Path) -> str:
    """The law's C, read as every input file is (:func:`grubler.limits.read_text`: regular, capped, UTF-8)."""
    from grubler.errors import InputError
    from grubler.limits import read_text

    try:
        return read_text(source, "law")
    except InputError as exc:  # the law's own field, as every other refusal of the file
        raise SceneError(exc.field, exc.reason) from None


def read_c_law(source: str | Path, text: str | None = None) -> type[Law]:
    """The Law declared by a C law file's GRUBLER_* lines (grubler_law.h), for its FMU's variables.

    ``text`` is the file's content when already read.

    Raises
    ------
    SceneError
        Naming the file and line of a declaration that cannot be read, or
        what the law lacks (an output, the parameter Ts, law_step).
    """
    path = Path(source)
    field = str(path)
    text = _law_text(path) if text is None else text
    found = {"PARAMETER": {}, "INPUT": {}, "OUTPUT": {}}
    n_state, state_at = 0, None
    names: set[str] = set()
    for number, line in enumerate(text.splitlines(), start=1):
        if "GRUBLER_" not in line or line.lstrip().startswith(("#", "//", "*", "/*")):
            continue
        m = _DECLARATION.match(line)
        kind = m[1] if m else None
        form = _FORMS.get(kind) if m else None
        parts = form.match(m[2]) if form else None
        where = f"{field}:{number}"
        if parts is None:
            usage = f"; write {_USAGE[kind]}" if kind in _USAGE else \
                f"; the declarations are {', '.join(_USAGE.values())}, each on a line of its own"
            raise SceneError("law", f"{where}: cannot read {brief(line.strip())}{usage}")
        if kind == "STATE":
            if state_at is not None:
                raise SceneError("law", f"{where}: GRUBLER_STATE declared again (first at line {state_at}); "
                                        "declare it once")
            digits = parts[1].lstrip("0") or "0"
            if len(digits) > len(str(MAX_LAW_STATE)) or int(digits) > MAX_LAW_STATE:
                raise SceneError("law", f"{where}: GRUBLER_STATE({clip(digits, 24)}): at most "
                                        f"{MAX_LAW_STATE} doubles")
            n_state, state_at = int(digits), number
            continue
        name = parts[1]
        if name in names:
            raise SceneError("law", f"{where}: {name} is declared twice")
        names.add(name)
        text_at = _c_text(parts[len(parts.groups())], where, name)
        if kind == "PARAMETER":
            try:
                start = float(parts[2])
            except ValueError:
                raise SceneError("law", f"{where}: the start of {name} must be a number, got {brief(parts[2])}") \
                    from None
            if not math.isfinite(start):
                raise SceneError("law", f"{where}: the start of {name} must be finite, got {brief(parts[2])}")
            found[kind][name] = Parameter(start, text_at)
        else:
            found[kind][name] = text_at
    if not found["OUTPUT"]:
        raise SceneError("law", f'{field}: declares no output; add GRUBLER_OUTPUT(name, "description [unit]")')
    if "Ts" not in found["PARAMETER"]:
        raise SceneError("law", f'{field}: declares no sample time; add GRUBLER_PARAMETER(Ts, 1e-3, '
                                f'"sample time [s]") (0: once per communication step)')
    if not re.search(r"\bint\s+law_step\s*\(", text):
        raise SceneError("law", f"{field}: defines no law_step; write int law_step(const double *param, "
                                "double *state, double t, const double *in, double *out)")
    _check_reserved(text, field)
    attrs = {"inputs": found["INPUT"], "outputs": found["OUTPUT"], "parameters": found["PARAMETER"],
             "n_state": n_state, "__doc__": f"A control law written in C ({path.name})."}
    return type(identifier_for(path), (Law,), attrs)


def export_law(source: str | Path, dest: str | Path | None = None, field: str = "output") -> Path:
    """Build a native FMU of a control law written as one C function (``grubler export-law``).

    Parameters
    ----------
    source : path
        The C file: GRUBLER_* declarations and ``law_step`` (grubler_law.h, in
        ``grubler/fmi/c``, documents them; docs/control.md has a complete example).
    dest : path, optional
        The ``.fmu`` to write (default: the source's name with ``.fmu``); its
        name is the model identifier.
    field : str
        The name a refused ``dest`` is reported under (the CLI's option).

    Returns
    -------
    Path

    Raises
    ------
    SceneError
        A declaration that cannot be read, or C the compiler or linker
        refused, naming the file and line (and the symbol); a destination that
        is the source itself.
    BuildError
        The compiler failed elsewhere (its first error attached).
    """
    text = _law_text(source)
    dest = Path(dest) if dest is not None else Path(Path(source).with_suffix(".fmu").name)
    if dest.suffix != ".fmu":
        raise SceneError(field, f"an FMU's file name ends in .fmu, got {dest.name!r}")
    if dest.resolve() == Path(source).resolve():
        raise SceneError(field, f"{brief(str(dest))} is the law's source: writing the FMU there would destroy it; "
                                "name another file")
    check_destination(dest, field)
    law = read_c_law(source, text)
    defines = {f"PARAM_{n}": k for k, n in enumerate(law.parameters)}
    defines.update({f"INPUT_{n}": k for k, n in enumerate(law.inputs)})
    defines.update({f"OUTPUT_{n}": k for k, n in enumerate(law.outputs)})
    with tempfile.TemporaryDirectory(prefix="grubler_law_") as tmp:
        staged = Path(tmp) / "law_step.c"  # a fixed name: the user's cannot shadow one of the FMU's own files
        staged.write_text(text, encoding="utf-8")  # what was read and checked, not the file as it is now
        # the scratch: user_law.c's working copy of the state and the outputs (not on the stack)
        spec = law_spec(law, identifier_for(dest), "user_law.c", law.n_state, law.n_state + len(law.outputs),
                        defines=defines)
        spec = replace(spec, kernel_sources=(*spec.kernel_sources, "user_law", (Path(tmp), ("law_step.c",))))
        try:
            return build_fmu(spec, dest)
        except BuildError as exc:
            found = _diagnostic(str(exc), str(source), text)
            if found is None:
                raise BuildError(re.sub(r"\S*law_step\.c", str(source), str(exc).splitlines()[-1]).strip()) \
                    from None
            raise SceneError("law", found) from None


def export_profile(profile, dest: str | Path, field: str = "output", quantity: str = "angle") -> Path:
    """A native Trajectory FMU of kind 'table' whose points are a CSV profile's (:func:`~grubler.controllers.trajectory.read_profile`).

    The points become the FMU's parameters ``times[k]``, ``positions[k]``; its
    ``kind`` starts at 'table'; ``quantity``: what it drives (:func:`trajectory_spec`).
    """
    times, positions = read_profile(profile)
    return export_table(times, positions, dest, field, quantity)


def export_table(times, positions, dest: str | Path, field: str = "output", quantity: str = "angle") -> Path:
    """A native Trajectory FMU of kind 'table' through the points (``times`` [s], ``positions``).

    The points become the FMU's parameters ``times[k]``, ``positions[k]``; its
    ``kind`` starts at 'table'; ``quantity``: what it drives, an ``angle``
    (positions in rad) or a ``length`` (in m: a cylinder's), :func:`trajectory_spec`.
    """
    dest = Path(dest)
    check_destination(dest, field)
    spec = trajectory_spec(identifier_for(dest), times, positions, quantity)
    spec = replace(spec, variables=tuple(replace(v, start="table") if v.name == "kind" else v for v in spec.variables))
    return build_fmu(spec, dest)


SPECS = {"PID": pid_spec, "CascadeController": cascade_spec, "Encoder": encoder_spec,
         "Tachometer": lambda: sensor_spec(Tachometer), "CurrentSensor": lambda: sensor_spec(CurrentSensor),
         "Trajectory": trajectory_spec, "ComputedTorque": computed_torque_spec,
         "LinearController": lambda: linear_spec(linear_default(), "LinearController")}


def build_native_law(name: str, dest: str | Path) -> Path:
    """Build the native FMU of a shipped law (a key of :data:`SPECS`) at ``dest``."""
    dest = Path(dest)
    target = dest if dest.suffix == ".fmu" else dest / f"{name}.fmu"
    return build_fmu(SPECS[name](), target)


__all__ = ["ENCODER_CAPACITY", "LINEAR_DEFAULT", "QUANTITIES", "SPECS", "build_native_law", "cascade_spec",
           "computed_torque_spec", "export_computed_torque", "encoder_spec", "export_law", "export_profile",
           "linear_default", "linear_spec",
           "read_c_law", "law_spec", "pid_spec", "sensor_spec",
           "trajectory_spec"]
