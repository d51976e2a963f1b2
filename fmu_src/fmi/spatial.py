"""The spatial mechanism FMU's variables, from a :class:`~grubler.mechanism.spatial.SpatialMechanism`
(served by ``c/spatial_model.c`` over ``kernel/spatial/``).

The shape is fixed at export: the links, each link's joint kind (R, P, C, F)
and parent, the closures' kinds and the links they join.  Every number of the
model is a parameter: each link's DH row (``crank.dh.a``, ``crank.dh.alpha``,
``crank.dh.theta``, ``crank.dh.d``), mass, mass centre, inertia tensor and
damping; each closure's points and axes; gravity; the sketch the run starts
from (``initial.<coordinate>``) and its rates.  The kernel's own check
(``grs_check``) judges them in the FMU as in the library, and a refusal names
the parameter.

Inputs: a generalised effort on every real coordinate (``effort.crank.theta``,
N m; ``effort.slider.d``, N) and ``motor_torque`` on the drive joint (the
motor FMU's shaft torque), summed.  Outputs: every coordinate, rate and
acceleration, the drive joint's angle and speed (the planar FMU's names, so a
servo system wires either alike), the largest closure violation, kinetic and
potential energy, and every reaction: per closure the force and moment the
target exerts on the closing link in the closure's frame (``closure.Fx`` ..
``closure.Mz``), per link the force and moment its parent exerts on it through
its joint, about the joint origin in the link's axes (``crank.Fx`` ..
``crank.Mz``).

Examples
--------
>>> from grubler.mechanism.spatial import rssr
>>> spec = spatial_spec(rssr(), "RSSR")
>>> spec.variables[spec.vr("crank.Mz") - 1].unit, spec.variables[spec.vr("effort.crank.theta") - 1].unit
('N.m', 'N.m')
>>> spec.defines["N_COORDS"], spec.defines["N_ROWS"]
(5, 3)
"""

from __future__ import annotations

import numpy as np

from grubler.errors import InputError
from grubler.fmi.variables import INPUT, OUTPUT, PARAMETER, REAL, STRING, ModelSpec, Variable
from grubler.mechanism.spatial import CLOSURE_KINDS, REACTION_NAMES, SpatialMechanism

# per-link parameters in slot order, each with its kernel column (grs_link) and unit; the C model copies
# slot SLOT_LINKS + k LINK_STRIDE + f into column LINK_COLUMN[f]
LINK_FIELDS = (("dh.a", 0, "m", "DH a: along the parent's x axis to this joint's axis"),
               ("dh.alpha", 1, "rad", "DH alpha: the joint axis's twist about the parent's x axis"),
               ("dh.theta", 2, "rad", "DH theta: the rotation about the joint axis (a revolute's coordinate adds "
                                      "to it)"),
               ("dh.d", 3, "m", "DH d: the slide along the joint axis (a slide's coordinate adds to it)"),
               ("mass", 7, "kg", "mass"),
               ("com_x", 8, "m", "mass centre in the link's frame, x"),
               ("com_y", 9, "m", "mass centre in the link's frame, y"),
               ("com_z", 10, "m", "mass centre in the link's frame, z"),
               ("I_xx", 11, "kg.m2", "inertia tensor about the mass centre in the link's axes, xx"),
               ("I_xy", 12, "kg.m2", "inertia tensor, xy"),
               ("I_xz", 13, "kg.m2", "inertia tensor, xz"),
               ("I_yy", 14, "kg.m2", "inertia tensor, yy"),
               ("I_yz", 15, "kg.m2", "inertia tensor, yz"),
               ("I_zz", 16, "kg.m2", "inertia tensor, zz"),
               ("damping_r", 17, "N.m.s/rad", "viscous damping on the joint's rotation"),
               ("damping_p", 18, "N.s/m", "viscous damping on the joint's slide"))
# per-closure parameters in slot order (kernel columns 3 .. 14 of grs_closure, in that order)
CLOSURE_FIELDS = tuple(f"{v}_{c}" for v in ("point", "axis", "to_point", "to_axis") for c in "xyz")
_CLOSURE_WORDS = {"point": ("m", "the closing point in the closing link's frame"),
                  "axis": ("1", "the closing link's joint axis in its frame (unit; revolute, cylindrical)"),
                  "to_point": ("m", "where it closes, in the target's frame (the world's on the ground)"),
                  "to_axis": ("1", "the target's joint axis in its frame (unit; revolute, cylindrical)")}
GLOBALS = ("rtol", "atol", "max_step", "gravity_x", "gravity_y", "gravity_z", "drive_joint", "drive.inertia")
# the output levels of spatial_model.c: what computing one costs
LEVEL_STATE, LEVEL_DYNAMICS, LEVEL_REACTIONS = 1, 2, 3
DEFAULT_RTOL = DEFAULT_ATOL = 1e-10  # SpatialMechanism.simulate's


def run_state(n_coords: int) -> tuple[tuple[str, int], ...]:
    """The model's own part of the persistent block: the run's flag, time, next step, step count,
    y = (z, zd), then the integrator's stepper (sized by the kernel: the last field's length 0 means "the
    rest"), which carries the change-point chart being followed and the best closure conditioning seen from
    one step to the next (as the planar mechanism FMU's state carries its stepper and kappa_seen)."""
    return (("started", 1), ("t", 1), ("h", 1), ("steps", 1), ("y", 2 * n_coords), ("stepper", 0))


def _unit(slide: bool, rad: str, m: str) -> str:
    return m if slide else rad


def closure_prefix(n_closures: int, j: int) -> str:
    """A closure's variable prefix: ``closure`` for the one closure, else ``closure[j]``."""
    return "closure" if n_closures == 1 else f"closure[{j}]"


def spatial_parameters(mechanism: SpatialMechanism, y0=None) -> dict[str, float | str]:
    """Every parameter of a spatial FMU that reproduces ``mechanism`` started from ``y0`` (default: the
    preset's sketch closed, at rest; a mechanism without one starts from zeros).

    Examples
    --------
    >>> from grubler.mechanism.spatial import spherical_fourbar
    >>> p = spatial_parameters(spherical_fourbar())
    >>> round(p["coupler.dh.alpha"], 6), p["drive_joint"], p["gravity_z"]
    (0.436332, 'crank.theta', -9.81)
    """
    m = mechanism
    if y0 is None:
        y0 = m.assembled_start() if m.n_rows else np.concatenate([getattr(m, "sketch", np.zeros(m.n_coords)),
                                                                  np.zeros(m.n_coords)])
    y0 = m._state(y0, 2 * m.n_coords, "y0")
    p: dict[str, float | str] = {"rtol": DEFAULT_RTOL, "atol": DEFAULT_ATOL, "max_step": 0.0,
                                 "gravity_x": float(m.gravity[0]), "gravity_y": float(m.gravity[1]),
                                 "gravity_z": float(m.gravity[2]), "drive_joint": m.coordinate_names[0],
                                 "drive.inertia": 0.0}
    for k, link in enumerate(m.links):
        row = m._links[k]
        for name, column, _, _ in LINK_FIELDS:
            p[f"{link.name}.{name}"] = float(row[column])
    for j, c in enumerate(m.closures):
        row = m._closures[j]
        for i, name in enumerate(CLOSURE_FIELDS):
            p[f"{closure_prefix(len(m.closures), j)}.{name}"] = float(row[3 + i])
    for i, x in enumerate(m.coordinate_names):
        p[f"initial.{x}"] = float(y0[i])
        p[f"initial.{x}_d"] = float(y0[m.n_coords + i])
    return p


def spatial_spec(mechanism: SpatialMechanism, identifier: str = "Spatial", y0=None, name: str = "") -> ModelSpec:
    """The variables of a native FMU of ``mechanism`` (its shape fixed, its numbers parameters defaulting to
    its own; the run starts from ``y0``, :func:`spatial_parameters`).

    Raises
    ------
    InputError
        Two links of one name (their variables would clash).
    """
    m = mechanism
    names = [l.name for l in m.links]
    if len(set(names)) != len(names):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise InputError("links", f"link names must differ (each names its FMU variables): {', '.join(twice)} twice")
    start = spatial_parameters(m, y0)
    coords = m.coordinate_names
    slide = [x.endswith(".d") for x in coords]
    n, nc, L = m.n_coords, len(m.closures), len(m.links)
    v: list[Variable] = []

    def par(key, type_, text, unit=None, lo=None, choices=()):
        v.append(Variable(key, type_, PARAMETER, text, start[key], unit, lo, None, choices))

    par("rtol", REAL, "relative tolerance of the internal integration (DOP853) [-]", None, 0.0)
    par("atol", REAL, "absolute tolerance of the internal integration [rad, m]", None, 0.0)
    par("max_step", REAL, "largest internal step (0: no limit)", "s", 0.0)
    for c in "xyz":
        par(f"gravity_{c}", REAL, f"gravity acceleration in the world, {c}", "m/s2")
    par("drive_joint", STRING, "the real joint motor_torque acts on and drive_angle, drive_speed read (its first "
                               "coordinate is held when the start is assembled)", choices=coords)
    par("drive.inertia", REAL, "reflected inertia of the motor on a revolute drive joint (J_rotor N^2), a disc on "
                               "its axis: J about it, J/2 across", "kg.m2", 0.0)
    for link in m.links:
        for fname, _, unit, text in LINK_FIELDS:
            lo = 0.0 if fname in ("mass", "damping_r", "damping_p") else None
            par(f"{link.name}.{fname}", REAL, f"{link.name} ({link.joint}): {text}", unit if unit != "1" else None,
                lo)
    for j in range(nc):
        pre = closure_prefix(nc, j)
        kind = m.closures[j].kind
        for fname in CLOSURE_FIELDS:
            unit, text = _CLOSURE_WORDS[fname[:-2]]
            par(f"{pre}.{fname}", REAL, f"{kind} closure: {text}, {fname[-1]}", None if unit == "1" else unit)
    for x, s in zip(coords, slide):
        par(f"initial.{x}", REAL, f"initial {x} (a sketch: assembly closes the loops holding the drive joint)",
            _unit(s, "rad", "m"))
    for x, s in zip(coords, slide):
        par(f"initial.{x}_d", REAL, f"initial rate of {x} (made consistent with the closures)",
            _unit(s, "rad/s", "m/s"))
    v.append(Variable("motor_torque", REAL, INPUT, "drive effort on drive_joint [N m, or N on a slide]", 0.0))
    for x, s in zip(coords, slide):
        v.append(Variable(f"effort.{x}", REAL, INPUT, f"generalised effort on {x} ({'force' if s else 'torque'})",
                          0.0, _unit(s, "N.m", "N")))
    out = 0

    def output(key, text, unit, level, feed=False):
        nonlocal out
        v.append(Variable(key, REAL, OUTPUT, text, unit=unit, level=level, feedthrough=feed, slot=out))
        out += 1

    for x, s in zip(coords, slide):
        output(x, f"joint coordinate {x}", _unit(s, "rad", "m"), LEVEL_STATE)
    for x, s in zip(coords, slide):
        output(f"{x}_d", f"rate of {x}", _unit(s, "rad/s", "m/s"), LEVEL_STATE)
    output("drive_angle", "coordinate of the drive joint", None, LEVEL_STATE)
    output("drive_speed", "rate of the drive joint", None, LEVEL_STATE)
    output("closure_error", "largest closure violation (m; an axis row's in rad)", "m", LEVEL_STATE)
    for x, s in zip(coords, slide):
        output(f"{x}_dd", f"acceleration of {x}", _unit(s, "rad/s2", "m/s2"), LEVEL_DYNAMICS, True)
    output("KE", "kinetic energy", "J", LEVEL_DYNAMICS)
    output("PE", "potential energy (gravity)", "J", LEVEL_DYNAMICS)
    axes = {"F": ("force", "N"), "M": ("moment", "N.m")}
    for j in range(nc):
        pre = closure_prefix(nc, j)
        for comp in REACTION_NAMES:
            what, unit = axes[comp[0]]
            output(f"{pre}.{comp}", f"{what} the target exerts on the closing link, along the closure frame's "
                                    f"{comp[1]} (n1, n2, v){' about the closing point' if what == 'moment' else ''}",
                   unit, LEVEL_REACTIONS, True)
    for link in m.links:
        for comp in REACTION_NAMES:
            what, unit = axes[comp[0]]
            output(f"{link.name}.{comp}", f"{what} its parent exerts on {link.name} through its joint, along the "
                                          f"link's {comp[1]} axis{' (about the joint origin)' if what == 'moment' else ''}",
                   unit, LEVEL_REACTIONS, True)
    slot_order = [*GLOBALS]
    slot_order += [f"{l.name}.{f}" for l in m.links for f, *_ in LINK_FIELDS]
    slot_order += [f"{closure_prefix(nc, j)}.{f}" for j in range(nc) for f in CLOSURE_FIELDS]
    slot_order += [f"initial.{x}" for x in coords] + [f"initial.{x}_d" for x in coords]
    slot_order += ["motor_torque"] + [f"effort.{x}" for x in coords]
    rows = m._links
    defines = {"N_LINKS": L, "N_CLOSURES": nc, "N_COORDS": n, "N_ROWS": m.n_rows,
               "LINK_STRIDE": len(LINK_FIELDS), "CLOSURE_STRIDE": len(CLOSURE_FIELDS),
               "LINK_COLUMN": tuple(c for _, c, _, _ in LINK_FIELDS),
               "LINK_REVOLUTE": tuple(int(r[4]) for r in rows), "LINK_PRISMATIC": tuple(int(r[5]) for r in rows),
               "LINK_PARENT": tuple(int(r[6]) for r in rows)}
    if nc:
        defines.update({"CLOSURE_KIND": tuple(CLOSURE_KINDS[c.kind][0] for c in m.closures),
                        "CLOSURE_LINK": tuple(int(c.link) for c in m.closures),
                        "CLOSURE_TO": tuple(int(c.to) for c in m.closures)})
    defines.update({f"SLOT_{g.upper().replace('.', '_')}": k for k, g in enumerate(GLOBALS)})
    defines["SLOT_LINKS"] = len(GLOBALS)
    defines["SLOT_CLOSURES"] = defines["SLOT_LINKS"] + L * len(LINK_FIELDS)
    defines["SLOT_Z0"] = defines["SLOT_CLOSURES"] + nc * len(CLOSURE_FIELDS)
    defines["SLOT_ZD0"] = defines["SLOT_Z0"] + n
    defines["SLOT_MOTOR_TORQUE"] = defines["SLOT_ZD0"] + n
    defines["SLOT_EFFORTS"] = defines["SLOT_MOTOR_TORQUE"] + 1
    defines["OUT_DRIVE"] = 2 * n
    defines["OUT_CLOSURE_ERROR"] = 2 * n + 2
    defines["OUT_ZDD"] = 2 * n + 3
    defines["OUT_ENERGY"] = 3 * n + 3
    defines["OUT_CLOSURES"] = 3 * n + 5
    defines["OUT_JOINTS"] = 3 * n + 5 + 6 * nc
    # fmi2GetDirectionalDerivative: the outputs are affine in the efforts at a state (spatial_model.c)
    defines["MODEL_DIRECTIONAL_DERIVATIVE"] = 1
    assert out == defines["OUT_JOINTS"] + 6 * L
    text = (f"{name or 'spatial mechanism'}: a spatial {L}-link chain by the imaginary-joints method "
            f"(Denavit-Hartenberg links, {n} coordinates, {nc} closure{'s' if nc != 1 else ''}); every number of "
            "the model is a parameter")
    return ModelSpec(identifier, text, tuple(v), "spatial_model.c", defines, out, tuple(slot_order), (),
                     ("spatial", "spatial_base"), run_state(m.n_coords))


# the public names (the API reference's): the rest is the package's inside
__all__ = ["spatial_parameters", "spatial_spec"]


def spatial_preset(name: str) -> SpatialMechanism | None:
    """The spatial preset called ``name`` (a key of :data:`grubler.mechanism.spatial.PRESETS`, the one list
    of them, ``_`` read as ``-``), named so, or None.

    Examples
    --------
    >>> spatial_preset("spherical_fourbar").n_coords, spatial_preset("rssr").name
    (3, 'rssr')
    >>> spatial_preset("thesis-fourbar") is None
    True
    """
    from grubler.mechanism.spatial import PRESETS

    key = str(name).replace("_", "-")
    if key not in PRESETS:
        return None
    m = PRESETS[key]()
    m.name = key
    return m


def fmu_name(preset: str) -> str:
    """The name (and model identifier) a spatial preset's FMU has by default: a mechanism named by its
    joints in capitals, another in CamelCase.

    Examples
    --------
    >>> fmu_name("rssr"), fmu_name("spherical_fourbar")
    ('RSSR', 'SphericalFourbar')
    """
    key = str(preset).replace("-", "_")
    if key and set(key) <= set("rspcu"):  # the joints' letters: revolute, spherical, prismatic, ...
        return key.upper()
    return "".join(part.title() for part in key.split("_"))


__all__ += ["spatial_preset", "fmu_name"]
