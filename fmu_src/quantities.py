"""The quantities grubler reads and writes: each named once, with its unit and what it is.

Two families live here, each in one table that every surface reads:

- the mechanism's outputs (:func:`mechanism_output`): the kernel's
  observations (its coordinates, rates and accelerations, the eleven fixed
  ones of ``enum grb_observation`` in ``kernel/grubler.h``, the joint
  reactions), the other closures' forces, the drive's and the actuators'.  The
  CSV headings, plot labels, the native FMU's output variables, the app's
  menus and the sweep's metrics take their unit and words from it;
- the scene's fields (:func:`scene_field`): the numbers a scene, the native
  FMU's parameters, the app's form and a sweep's axes set.

A unit is written once, in ASCII as a reader writes it (``N m``, ``kg m^2``,
``rad/s^2``); :func:`fmi_unit` spells it as a model description declares it
(``N.m``, ``kg.m2``).  Where the joint decides the unit (an effort on a
revolute is in N m, on a slide in N) the unit reads ``N m or N``, and an FMU
declares none: the words say it.

The models beside the mechanism (motor, cylinders, laws) each declare their
variables in one table of their own (``grubler.fmi.motor``, ``grubler.fmi.cylinder``,
``grubler.controllers.native_fmu``); a co-simulation's CSV reads the units from
their model descriptions.

Examples
--------
>>> q = mechanism_output("theta3_d")
>>> q.unit, q.label
('rad/s', 'angular rate of link 3')
>>> mechanism_output("R2_Mz").unit, fmi_unit(mechanism_output("R2_Mz").unit)
('N m', 'N.m')
>>> scene_field("link2.I").unit, fmi_unit(scene_field("link2.I").unit)
('kg m^2', 'kg.m2')
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = ["RPM", "Quantity", "FIXED_OBSERVATIONS", "ACTUATOR_OUTPUTS", "FORCE_OUTPUTS", "force_field", "force_fields",
           "mechanism_output", "scene_field", "fmi_unit", "fmi_text"]


RPM = 30.0 / math.pi  # rpm per rad/s: a motor's speed is read in rpm, as on its datasheet


@dataclass(frozen=True)
class Quantity:
    """A named quantity: its unit, a few words for menus and labels, a sentence for model descriptions.

    Examples
    --------
    >>> Quantity("KE", "J", "kinetic energy", "kinetic energy").unit
    'J'
    """

    name: str
    unit: str  # SI, ASCII ('' for a word or a count; 'N m or N' where the joint decides)
    label: str
    description: str


# The kernel's fixed observations, in its order (enum grb_observation, kernel/grubler.h; a test holds the two
# together): after the 6N coordinates, rates and accelerations, before the 3N joint reactions.
FIXED_OBSERVATIONS = (
    Quantity("tip_x", "m", "tip x", "chain tip (the closing point of the last link), x"),
    Quantity("tip_y", "m", "tip y", "chain tip, y"),
    Quantity("closure_error", "m or rad", "loop closure error", "largest closure violation"),
    Quantity("Fx", "N", "closing joint force x", "force the ground exerts on the last link at the closing joint, x"),
    Quantity("Fy", "N", "closing joint force y", "force the ground exerts on the last link at the closing joint, y"),
    Quantity("Mz", "N m", "closing joint moment", "moment the ground exerts on the last link at the closing joint"),
    Quantity("KE", "J", "kinetic energy", "kinetic energy"),
    Quantity("PE", "J", "potential energy",
             "potential energy (gravity, plus the penalty springs' and the force elements' stored energy)"),
    Quantity("E", "J", "total energy", "kinetic plus potential energy"),
    Quantity("tau_drive", "N m or N", "drive torque", "drive effort at the drive joint"),
    Quantity("P_drive", "W", "drive power", "power of the drive effort"),
)
# an actuator's outputs, each column '<actuator>_<name>'
ACTUATOR_OUTPUTS = (
    Quantity("length", "m", "length", "length (its points' distance)"),
    Quantity("rate", "m/s", "rate", "rate of extension"),
    Quantity("force", "N", "force", "force along its line, positive pushing its points apart"),
    Quantity("power", "W", "power", "power it puts in"),
)
# a force element's outputs by its kind (its scene table), each column '<element>_<name>', and where the kernel
# puts each (grb_force_rows: length, rate, force, energy, power, dissipation: enum GRB_FO_* in kernel/grubler.h)
FORCE_OUTPUTS = {
    "spring": (
        (Quantity("length", "m", "length", "length (its points' distance)"), 0),
        (Quantity("rate", "m/s", "rate", "rate of extension"), 1),
        (Quantity("force", "N", "force", "force along its line (spring, damper and gas), positive pushing its "
                                         "points apart"), 2),
        (Quantity("energy", "J", "stored energy", "stored energy (spring, preload and gas; 0 at its free length)"),
         3),
        (Quantity("power", "W", "power", "power it puts in (force x rate)"), 4),
        (Quantity("dissipation", "W", "dissipated power", "power its damper dissipates"), 5),
    ),
    "joint_spring": (
        (Quantity("position", "rad or m", "joint position", "its joint's coordinate (relative angle, or slide)"), 0),
        (Quantity("speed", "rad/s or m/s", "joint speed", "its joint's rate"), 1),
        (Quantity("effort", "N m or N", "effort", "effort on its joint (spring, preload and friction)"), 2),
        (Quantity("energy", "J", "stored energy", "stored energy (spring and preload; 0 at its free position)"), 3),
        (Quantity("power", "W", "power", "power it puts in (effort x speed)"), 4),
        (Quantity("dissipation", "W", "dissipated power", "power its friction dissipates"), 5),
    ),
    "point_load": (
        (Quantity("power", "W", "power", "power it puts in (force x the point's velocity + moment x the link's "
                                         "rate)"), 4),
    ),
}
_OTHER_OUTPUTS = (
    Quantity("t", "s", "time", "time"),
    Quantity("drive_angle", "rad or m", "drive angle", "coordinate of the drive joint (relative)"),
    Quantity("drive_speed", "rad/s or m/s", "drive speed", "rate of the drive joint"),
)
_OUTPUTS = {q.name: q for q in FIXED_OBSERVATIONS + _OTHER_OUTPUTS}
_FORCE = {"Fx": ("N", "x"), "Fy": ("N", "y"), "Mz": ("N m", "")}
_ORDER = {"": 0, "_d": 1, "_dd": 2}
_PER = ("", "/s", "/s^2")


def mechanism_output(name: str, actuators=(), forces=()) -> Quantity | None:
    """The mechanism's output ``name`` (a CSV column, an FMU output), or None for a name that is none.

    ``actuators``: the scene's actuator names, whose columns are '<actuator>_length' and so on;
    ``forces``: its force elements as (name, table) pairs (``("lift", "spring")``), whose columns are
    :data:`FORCE_OUTPUTS`'s of their kind.

    Examples
    --------
    >>> mechanism_output("B2_dd").unit, mechanism_output("closure1_Fy").label
    ('m/s^2', 'closure 1 force y')
    >>> mechanism_output("lift_force", ["lift"]).description
    "actuator lift's force along its line, positive pushing its points apart"
    >>> mechanism_output("nonsense") is None
    True
    """
    if name in _OUTPUTS:
        return _OUTPUTS[name]
    m = re.fullmatch(r"(theta|B)(\d+)(_d|_dd)?", name)
    if m:
        kind, k, order = m.group(1), m.group(2), _ORDER[m.group(3) or ""]
        unit = ("rad" if kind == "theta" else "m") + _PER[order]
        # theta_k is link k's absolute angle, B_k the slide of its joint
        what = {"theta": ("angle", "angular rate", "angular acceleration"),
                "B": ("slide", "slide rate", "slide acceleration")}[kind][order]
        base = f"{kind}{k}"
        return Quantity(name, unit, f"{what} of {'link' if kind == 'theta' else 'joint'} {k}",
                        (f"{base} (absolute)", f"rate of {base}", f"acceleration of {base}")[order])
    m = re.fullmatch(r"R(\d+)_(Fx|Fy|Mz)", name)
    if m:
        k, c = int(m.group(1)), m.group(2)
        unit, axis = _FORCE[c]
        # link k+1's predecessor: link k in a serial chain, its parent in a tree
        text = (f"moment link {k + 1}'s predecessor exerts on it at its joint" if c == "Mz" else
                f"{axis}-component of the reaction link {k + 1}'s predecessor exerts on it at its joint")
        return Quantity(name, unit, f"joint {k + 1} reaction {'moment' if c == 'Mz' else 'force ' + axis}", text)
    m = re.fullmatch(r"closure(\d+)_(Fx|Fy|Mz)", name)
    if m:
        j, c = int(m.group(1)), m.group(2)
        unit, axis = _FORCE[c]
        what = "moment" if c == "Mz" else f"force, {axis}"
        return Quantity(name, unit, f"closure {j} {'moment' if c == 'Mz' else 'force ' + axis}",
                        f"{what} closure[{j}] exerts on its closing link (world axes)")
    for a in actuators:
        for q in ACTUATOR_OUTPUTS:
            if name == f"{a}_{q.name}":
                return Quantity(name, q.unit, f"actuator {a} {q.label}", f"actuator {a}'s {q.description}")
    for e, table in forces:
        for q, _ in FORCE_OUTPUTS[table]:
            if name == f"{e}_{q.name}":
                what = table.replace("_", " ")
                return Quantity(name, q.unit, f"{what} {e} {q.label}", f"{what} {e}'s {q.description}")
    return None


# -- the scene's fields ------------------------------------------------------------------------------------
ANGLE_UNIT = "rad, or '30 deg'"  # a scene's angles: a number in rad, or a string with its unit
# a field by the last part of its dotted key: (unit, unit on a slide joint or None, description)
_FIELDS = {
    "a": ("m", None, "link vector length"),
    "p": ("m", None, "mass centre along the link vector"),
    "q": ("m", None, "mass centre across the link vector"),
    "m": ("kg", None, "mass (> 0)"),
    "I": ("kg m^2", None, "centroidal moment of inertia"),
    "damping": ("N m s/rad", "N s/m", "viscous damping of its real joint"),

    "gravity": ("m/s^2", None, "gravity g, acting along -y"),
    "inertia": ("kg m^2", "kg", "inertia a motor adds at drive_joint: rotor inertia x gear ratio^2"),
    "torque": ("N m", "N", "a constant effort at the joint"),
    "t_end": ("s", None, "end time"),
    "dt_out": ("s", None, "output interval"),
    "max_step": ("s", None, "largest internal step (0: no limit)"),
    "step": ("s", None, "fixed internal step of rk4"),
    "mass_per_length": ("kg/m", None, "mass of a bar per metre"),
    "block_mass": ("kg", None, "mass of a block"),
    "slider_mass": ("kg", None, "mass of the slider"),
    "yoke_mass": ("kg", None, "mass of the yoke"),
    "disc_mass": ("kg", None, "mass of the disc"),
    "shaft_mass": ("kg", None, "mass of a shaft"),
    "disc_inertia": ("kg m^2", None, "the disc's moment of inertia"),
    "shaft_inertia": ("kg m^2", None, "a shaft's moment of inertia"),
}
# fields that are words, choices or counts: no unit
_WORDS = {"name", "description", "kind", "type", "joint", "existence", "parent", "link", "to_link", "method",
          "from_link", "rtol", "atol", "integrator", "drive_joint", "load_joint", "drive", "load"}
# a closure's penalty spring and damper act along a line or about a pin: the closure's type decides
_CLOSURE_FIELDS = {
    "gain": ("N/m or N m/rad", "penalty closure stiffness G"),
    "damping": ("N s/m or N m s/rad", "penalty closure damping C"),
}
_ANGLE = re.compile(r"(theta\d*|.*_angle|angle|psi|alpha)$")  # (theta, alpha: a spatial link's DH angles)
# a spatial scene's fields ([[link]] and [[closure]] tables, named link[j].field, closure[c].field), where they
# differ from a planar scene's of the same name; its angles (alpha, theta) and its coordinates' rates
# (initial."crank.theta_d", initial."slider.d_d") follow the rules above
_SPATIAL_FIELDS = {
    "link": {
        "a": ("m", "DH length along the parent's x axis"),
        "d": ("m", "DH offset along the joint axis"),
        "mass": ("kg", "mass"),
        "com": ("m", "mass centre, in the link's frame"),
        "inertia": ("kg m^2", "inertia tensor about the mass centre, in the link's axes"),
        "rod": ("m", "a slender rod from the link's origin to this point (its mass centre and inertia)"),
        "radius": ("m", "the rod's radius"),
        "damping": ("N m s/rad or N s/m", "viscous damping on theta and on d"),
    },
    "closure": {
        "point": ("m", "the joint's point on the closing link, in its frame"),
        "to_point": ("m", "the joint's point on the target, in its frame (the world's on the ground)"),
        "axis": ("", "the joint axis on the closing link (a direction: made unit)"),
        "to_axis": ("", "the joint axis on the target (a direction: made unit)"),
    },
}


def scene_field(key: str, on_slide: bool | None = None) -> Quantity:
    """A scene field by its dotted key (``link2.I``, ``gravity``, ``initial.theta3_d``), with its unit.

    ``on_slide``: whether the field belongs to a prismatic joint (a damping in
    N s/m, an effort in N), None where that is not known (both units, 'N m s/rad
    or N s/m').  A builder's other numbers are lengths in m.

    Examples
    --------
    >>> scene_field("link3.damping", on_slide=False).unit, scene_field("link3.damping", on_slide=True).unit
    ('N m s/rad', 'N s/m')
    >>> scene_field("link3.damping").unit
    'N m s/rad or N s/m'
    >>> scene_field("initial.theta2_d").unit, scene_field("mechanism.crank_angle").unit
    ('rad/s', "rad, or '30 deg'")
    >>> scene_field("mechanism.branch1").unit, scene_field("closure[1].gain").unit
    ('', 'N/m or N m/rad')
    >>> scene_field("link[1].inertia[0][2]").unit, scene_field("link[1].alpha").unit, scene_field("gravity[2]").unit
    ('kg m^2', "rad, or '30 deg'", 'm/s^2')
    >>> scene_field("initial.crank.theta_d").unit, scene_field("initial.slider.d_d").unit
    ('rad/s', 'm/s')
    """
    key = re.sub(r"(\[\d+\])+$", "", key)  # a vector's or a tensor's part (gravity[2], link[0].inertia[1][2])
    leaf = key.rsplit(".", 1)[-1]
    spatial = re.match(r"(link|closure)\[\d+\]\.", key)
    if spatial and leaf in _SPATIAL_FIELDS[spatial[1]]:
        return Quantity(key, *_SPATIAL_FIELDS[spatial[1]][leaf][:1], leaf, _SPATIAL_FIELDS[spatial[1]][leaf][1])
    if leaf.endswith("_d") and (_ANGLE.match(leaf[:-2]) or re.fullmatch(r"B\d+|d", leaf[:-2])):
        return Quantity(key, "rad/s" if _ANGLE.match(leaf[:-2]) else "m/s", leaf, f"initial rate of {leaf[:-2]}")
    if _ANGLE.match(leaf):
        return Quantity(key, ANGLE_UNIT, leaf, "an angle")
    if key.startswith("closure") and leaf in _CLOSURE_FIELDS:
        return Quantity(key, *_CLOSURE_FIELDS[leaf][:1], leaf, _CLOSURE_FIELDS[leaf][1])
    if leaf in _FIELDS:
        unit, slide_unit, text = _FIELDS[leaf]
        if slide_unit:
            unit = f"{unit} or {slide_unit}" if on_slide is None else slide_unit if on_slide else unit
        return Quantity(key, unit, leaf, text)
    if leaf in _WORDS or leaf.startswith("branch") or leaf.endswith("_side"):
        return Quantity(key, "", leaf, "")
    for table in _FORCE_FIELDS.values():  # a force element's field (its table's unit where tables share a name)
        if leaf in table:
            unit, text = table[leaf]
            return Quantity(key, unit, leaf, text)
    return Quantity(key, "m", leaf, "a length")


# a force element's fields by its kind (its scene table): unit and description
_FORCE_FIELDS = {
    "spring": {
        "from_link": ("", "the link carrying its first point, 1: the ground"),
        "from_point_x": ("m", "its first point, along its link's vector (world x on the ground)"),
        "from_point_y": ("m", "its first point, across its link's vector (world y on the ground)"),
        "to_link": ("", "the link carrying its second point, 1: the ground"),
        "to_point_x": ("m", "its second point, along its link's vector (world x on the ground)"),
        "to_point_y": ("m", "its second point, across its link's vector (world y on the ground)"),
        "stiffness": ("N/m", "spring stiffness"),
        "free_length": ("m", "length at rest"),
        "preload": ("N", "force at the free length, positive pushing apart"),
        "damping": ("N s/m", "viscous damping along its line"),
        "gas_force": ("N", "gas spring: its gas force at the free length, p0 A (0: no gas)"),
        "gas_column": ("m", "gas spring: its gas column at the free length, V0 / A"),
        "gas_exponent": ("", "gas spring: the polytropic exponent n (1 isothermal, 1.4 adiabatic air)"),
    },
    "joint_spring": {
        "link": ("", "the link whose real joint it acts at"),
        "stiffness": ("N m/rad or N/m", "torsion (slide: linear) spring stiffness"),
        "free": ("rad or m", "the joint coordinate where the spring is relaxed (a relative angle, or a slide)"),
        "preload": ("N m or N", "effort at the free position, along the joint's coordinate"),
        "friction": ("N m or N", "Coulomb friction"),
        "friction_speed": ("rad/s or m/s", "the rate over which friction's tanh regularisation rises"),
    },
    "point_load": {
        "link": ("", "the moving link it acts on"),
        "point_x": ("m", "its point, along the link's vector"),
        "point_y": ("m", "its point, across the link's vector"),
        "force_x": ("N", "force, world x"),
        "force_y": ("N", "force, world y"),
        "moment": ("N m", "moment, counter-clockwise"),
    },
}


def force_field(table: str, field: str, on_slide: bool | None = None) -> Quantity:
    """A force element's field (``stiffness``) by the element's kind (``spring``, ``joint_spring``, ``point_load``).

    ``on_slide``: whether a joint spring's joint is a slide (its unit then the second of 'N m/rad or N/m'),
    None where that is not known.

    Examples
    --------
    >>> force_field("spring", "stiffness").unit, force_field("joint_spring", "stiffness").unit
    ('N/m', 'N m/rad or N/m')
    >>> force_field("joint_spring", "stiffness", on_slide=True).unit
    'N/m'
    """
    unit, text = _FORCE_FIELDS[table][field]
    if on_slide is not None and " or " in unit:
        unit = unit.split(" or ")[1 if on_slide else 0]
    return Quantity(field, unit, field, text)


def force_fields(table: str) -> tuple[str, ...]:
    """A force element kind's fields, in the order the native FMU lays them out."""
    return tuple(_FORCE_FIELDS[table])


def fmi_text(q: Quantity) -> str:
    """A quantity's description as a model description gives it: with its unit in brackets where the
    joint decides the unit (the variable then declares none).

    Examples
    --------
    >>> fmi_text(mechanism_output("closure_error"))
    'largest closure violation [m or rad]'
    """
    return f"{q.description} [{q.unit}]" if q.unit and fmi_unit(q.unit) is None else q.description


def fmi_unit(unit: str) -> str | None:
    """A unit as a model description declares it (``N m`` -> ``N.m``, ``kg m^2`` -> ``kg.m2``); None where the
    joint decides it (``N m or N``) or there is none.

    Examples
    --------
    >>> fmi_unit("N m s/rad"), fmi_unit("rad/s^2"), fmi_unit("N m or N"), fmi_unit("")
    ('N.m.s/rad', 'rad/s2', None, None)
    """
    if not unit or " or " in unit or "," in unit:
        return None
    return unit.replace("^", "").replace(" ", ".")
