"""The mechanism FMU's variables, from a scene (served by ``c/mechanism_model.c``).

Every scene quantity is a parameter, the joint types and the closure's type,
links and points included, so one exported FMU can be re-tuned into any
mechanism with the same number of links and closures (the eight inversions of a
four-link chain are one FMU).  Parameters default to the scene's values.

Each link's predecessor is a parameter too (``linkK.parent``, structural, 1 the
ground), like a closure's links: the chain's topology is data the kernel reads,
so a tree (the Stephenson III six-bar) needs no other FMU than a serial chain
of its size.  Those parameters come last in the variable list, so that the
value references of every other variable stay what they were before the chain
could branch.

Examples
--------
>>> from grubler.mechanism.scene import load_scene
>>> spec = mechanism_spec(load_scene("thesis-fourbar"))
>>> spec.vr("link2.a") > 0, spec.defines["N_LINKS"]
(True, 3)
>>> fmu_parameters(load_scene("thesis-scotch-yoke"))["link2.joint"]  # P: item 2
2
"""

from __future__ import annotations

from grubler.mechanism.dynamics import observation_names
from grubler.errors import SceneError
from grubler.mechanism.model import FORCE_COLUMN, FORCE_KIND, PRISMATIC, Mechanism
from grubler.mechanism.scene import Scene
from grubler.mechanism.simulate import DEFAULT_ATOL, DEFAULT_RTOL, force_kinds
from grubler.quantities import FORCE_OUTPUTS, fmi_text, fmi_unit, force_field, force_fields, mechanism_output, scene_field
from grubler.fmi.variables import ENUMERATION, INPUT, INTEGER, OUTPUT, PARAMETER, REAL, STRING, EnumType, ModelSpec, Variable

JOINT = EnumType("JointType", "which joint of a link's pair is real",
                 (("R", "revolute (existence factors 0, 1)"), ("P", "prismatic slide (existence factors 1, 0)")))
CLOSURE = EnumType("ClosureType", "the joint that closes the loop",
                   (("revolute", "a point of the link pinned to a point"),
                    ("prismatic", "a point of the link sliding on a line, the link's orientation held")))
METHODS = ("exact", "penalty")
INTEGRATORS = ("auto", "dop853", "rk45", "rk4")

# output levels of the C model (mechanism_model.c): what computing one costs
LEVEL_DRIVE, LEVEL_STATE, LEVEL_OBSERVE, LEVEL_REACTIONS = 1, 2, 3, 4
# outputs of the observation vector that the FMU does not publish (derived or the input itself)
_UNPUBLISHED = {"E", "tau_drive", "P_drive"}

# per-link fields in slot order (the C model addresses them as SLOT_LINKS + k * LINK_STRIDE + field)
LINK_FIELDS = ("joint", "a", "p", "q", "m", "I", "damping", "parent")
ACTUATOR_FIELDS = ("from_link", "from_point_x", "from_point_y", "to_link", "to_point_x", "to_point_y")
CLOSURE_FIELDS = ("type", "link", "to_link", "at_x", "at_y", "point_x", "point_y", "angle", "psi", "gain",
                  "damping")
GLOBALS = ("method", "integrator", "rtol", "atol", "max_step", "step", "gravity", "ground.a1", "ground.theta1",
           "drive_joint", "load_joint", "drive.inertia")


def run_state(n_links: int, n_actuators: int = 0) -> tuple[tuple[str, int], ...]:
    """The model's own part of a mechanism FMU's persistent block (``mechanism_model.c``'s ``P_*``).

    The run's flag, time, integrator step and counters, the joint state y = (z,
    zd) and its derivative f (2 ``n_links`` each), the actuators' forces f was
    computed with (when there are actuators), then the integrator's workspace
    (sized by the kernel).
    """
    scalars = ("started", "t", "h", "have_f", "steps", "rejected", "evals", "passages", "kappa_seen",
               "drive_used", "load_used")
    forces = (("actuator_forces_used", n_actuators),) if n_actuators else ()
    return (*((f, 1) for f in scalars), ("y", 2 * n_links), ("f", 2 * n_links), *forces, ("stepper", 0))


def closure_prefix(n_closures: int, j: int) -> str:
    """A closure's variable prefix: ``closure`` for the one closure, else ``closure[j]``."""
    return "closure" if n_closures == 1 else f"closure[{j}]"


def fmu_parameters(scene: Scene) -> dict[str, float | int | str]:
    """Every parameter of a mechanism FMU that reproduces ``scene``.

    What :func:`mechanism_spec` uses as start values, and what a master sets on an
    FMU exported from another scene of the same shape to turn it into this one.

    Examples
    --------
    >>> from grubler.mechanism.scene import load_scene
    >>> p = fmu_parameters(load_scene("slider-crank"))   # set on Mechanism.fmu, it runs the slider-crank
    >>> p["method"], p["drive_joint"], p["link2.a"]
    ('exact', 'theta2', 0.1)
    """
    m: Mechanism = scene.mechanism
    p: dict[str, float | int | str] = {
        "method": scene.method, "gravity": m.gravity, "ground.a1": m.a1, "ground.theta1": m.theta1,
        "drive_joint": m.drive or "", "load_joint": m.load or "", "drive.inertia": m.drive_inertia,
    }
    for k, link in enumerate(m.links):
        p[f"link{k + 2}.joint"] = 2 if link.joint == PRISMATIC else 1
        for f in LINK_FIELDS[1:-1]:
            p[f"link{k + 2}.{f}"] = float(getattr(link, f))
        p[f"link{k + 2}.parent"] = m.parents[k]
    for j, c in enumerate(m.closures):
        pre = closure_prefix(len(m.closures), j)
        p.update({f"{pre}.type": 2 if c.kind == "prismatic" else 1, f"{pre}.link": c.link,
                  f"{pre}.to_link": c.to_link, f"{pre}.at_x": c.point[0], f"{pre}.at_y": c.point[1],
                  f"{pre}.point_x": c.to_point[0], f"{pre}.point_y": c.to_point[1], f"{pre}.angle": c.angle,
                  f"{pre}.psi": c.psi, f"{pre}.gain": c.gain, f"{pre}.damping": c.damping})
    for a in m.actuators:
        p.update({f"{a.name}.from_link": a.from_link, f"{a.name}.from_point_x": a.from_point[0],
                  f"{a.name}.from_point_y": a.from_point[1], f"{a.name}.to_link": a.to_link,
                  f"{a.name}.to_point_x": a.to_point[0], f"{a.name}.to_point_y": a.to_point[1]})
    table = m.force_table()  # thesis link numbers, as the parameters give them
    for j, e in enumerate(m.forces):
        for f in force_fields(e.table):
            value = table[j, FORCE_COLUMN[f]]
            p[f"{e.name}.{f}"] = int(value) if f.endswith("link") else float(value)
    qd = m.S @ scene.initial_rates
    for i, x in enumerate(m.coordinate_names):
        p[f"initial.{x}"] = float(m.q_ref[i])
        p[f"initial.{x}_d"] = float(qd[i])
    return p


def scene_parameters(scene: Scene) -> dict[str, float | int | str]:
    """The scene alone as FMU parameters: gravity, the ground vector, the drive
    joint, every link's and closure's fields, the sketch (``initial.*``) and
    the force elements' fields (``strut.stiffness``).

    What a model of the mechanism that does not integrate it takes (the
    ComputedTorque FMU): :func:`fmu_parameters` less the integration's and the
    run's (method, load joint, drive inertia, initial rates), in slot order.

    Examples
    --------
    >>> from grubler.mechanism.scene import load_scene
    >>> p = scene_parameters(load_scene("thesis-fourbar"))   # what ComputedTorque.fmu takes
    >>> list(p)[:4], "method" in p
    (['gravity', 'ground.a1', 'ground.theta1', 'drive_joint'], False)
    """
    m = scene.mechanism
    p = fmu_parameters(scene)
    names = ["gravity", "ground.a1", "ground.theta1", "drive_joint"]
    names += [f"link{k}.{f}" for k in range(2, m.n_links + 2) for f in LINK_FIELDS]
    names += [f"{closure_prefix(len(m.closures), j)}.{f}" for j in range(len(m.closures)) for f in CLOSURE_FIELDS]
    names += [f"initial.{x}" for x in m.coordinate_names]
    names += force_parameter_names(m)  # last: a scene without elements keeps its slots
    return {x: p[x] for x in names}


STANDARD_SCENE = "thesis-fourbar"  # the defaults of build_fmu.py's Mechanism.fmu


def same_shape(a: Mechanism, b: Mechanism) -> bool:
    """Whether one mechanism FMU serves both (same number of links, of closures and the same actuators).

    Examples
    --------
    >>> from grubler.mechanism.scene import load_scene
    >>> fourbar = load_scene("thesis-fourbar").mechanism
    >>> same_shape(load_scene("slider-crank").mechanism, fourbar), same_shape(load_scene("watt-ii").mechanism, fourbar)
    (True, False)
    """
    return ((a.n_links, len(a.closures), a.actuator_names, [(e.name, e.table) for e in a.forces])
            == (b.n_links, len(b.closures), b.actuator_names, [(e.name, e.table) for e in b.forces]))


class _Declared:
    """The FMU's variables as they are declared, in value-reference order: parameters at the scene's values,
    outputs with their slot in the model's output vector and words and units from the one table."""

    def __init__(self, scene: Scene):
        self.m = scene.mechanism
        self.start = fmu_parameters(scene)
        self.start.update({"integrator": "auto", "rtol": DEFAULT_RTOL, "atol": DEFAULT_ATOL, "max_step": 0.0,
                           "step": 1e-3})
        self.v: list[Variable] = []

    def par(self, name, type_, text, unit=None, lo=None, hi=None, choices=(), enum=None):
        self.v.append(Variable(name, type_, PARAMETER, text, self.start.get(name), unit, lo, hi, choices, enum))

    def field(self, name: str, text_prefix: str = "", lo=None):
        """A REAL parameter whose unit and words are the scene field's (grubler.quantities.scene_field)."""
        q = scene_field(name)
        self.par(name, REAL, f"{text_prefix}{fmi_text(q)}", fmi_unit(q.unit), lo)

    def output(self, name, level, feed, slot):
        q = mechanism_output(name, self.m.actuator_names, force_kinds(self.m))
        self.v.append(Variable(name, REAL, OUTPUT, fmi_text(q), unit=fmi_unit(q.unit), level=level, feedthrough=feed,
                               slot=slot))


def _run_settings(d: _Declared) -> None:
    """How the FMU integrates: the closure method, the integrator and its tolerances and steps."""
    d.par("method", STRING, "closure method: exact (index-1 DAE, projected) | penalty (the thesis's "
                            "spring-damper imaginary joint)", choices=METHODS)
    d.par("integrator", STRING, "auto | dop853 | rk45 | rk4 (auto: dop853); radau and bdf exist only in the "
                                "Python library", choices=INTEGRATORS)
    d.par("rtol", REAL, "relative tolerance of the internal integration [-]", None, 0.0)
    d.par("atol", REAL, "absolute tolerance of the internal integration [rad, m]", None, 0.0)
    d.par("max_step", REAL, "largest internal step (0: no limit)", "s", 0.0)
    d.par("step", REAL, "fixed internal step of rk4", "s", 0.0)


def _scene_parameters(d: _Declared) -> None:
    """Every scene quantity: gravity, the ground, the efforts' joints, the links, the closures, the sketch."""
    m = d.m
    n, nc, names = m.n_links, len(m.closures), m.coordinate_names
    d.field("gravity", lo=0.0)
    d.par("ground.a1", REAL, "ground vector length a1 (link 1)", "m", 0.0)
    d.par("ground.theta1", REAL, "ground vector angle theta1", "rad")
    coord_choices = ("",) + tuple(names)
    d.par("drive_joint", STRING, "real joint the motor acts on (e.g. theta2; empty: none)", choices=coord_choices)
    d.par("load_joint", STRING, "real joint the load acts on (empty: none)", choices=coord_choices)
    d.field("drive.inertia", lo=0.0)
    lowest = {"a": 0.0, "m": 0.0, "I": 0.0, "damping": 0.0}
    for k in range(2, n + 2):
        d.par(f"link{k}.joint", ENUMERATION, f"link {k}: which joint of its pair is real (structural)", enum=JOINT)
        for f in LINK_FIELDS[1:-1]:
            d.field(f"link{k}.{f}", f"link {k}: ", lowest.get(f))
    for j in range(nc):
        pre = closure_prefix(nc, j)
        d.par(f"{pre}.type", ENUMERATION, "closing joint type (structural)", enum=CLOSURE)
        d.par(f"{pre}.link", INTEGER, "link carrying the closing point (structural)", None, 2, n + 1)
        d.par(f"{pre}.to_link", INTEGER, "link carrying the target point or line, 1: the ground (structural)",
              None, 1, n + 1)
        d.par(f"{pre}.at_x", REAL, "closing point on the link, along its vector", "m")
        d.par(f"{pre}.at_y", REAL, "closing point on the link, across its vector", "m")
        d.par(f"{pre}.point_x", REAL, "target point (or a point of the line) in to_link's frame, x", "m")
        d.par(f"{pre}.point_y", REAL, "target point (or a point of the line) in to_link's frame, y", "m")
        d.par(f"{pre}.angle", REAL, "prismatic: direction of the line in to_link's frame", "rad")
        d.par(f"{pre}.psi", REAL, "prismatic: held orientation of the link relative to to_link", "rad")
        for f in ("gain", "damping"):
            d.field(f"{pre}.{f}", lo=0.0)
    for x in names:
        d.par(f"initial.{x}", REAL, f"initial {x} (a guess for the coordinates assembly solves for)",
              fmi_unit(mechanism_output(x).unit))
        d.par(f"initial.{x}_d", REAL, f"initial rate of {x} (the held coordinates' are kept)",
              fmi_unit(mechanism_output(f"{x}_d").unit))


def _observations(d: _Declared, obs: list[str]) -> None:
    """The kernel's observations the FMU publishes, the drive's coordinate and rate, the other closures' forces."""
    m = d.m
    n, nc, names = m.n_links, len(m.closures), m.coordinate_names
    index = {name: i for i, name in enumerate(obs)}
    # published in today's order: state, dynamics, energy, reactions
    order = ([*names, *(f"{x}_d" for x in names), "tip_x", "tip_y", "closure_error",
              *(f"{x}_dd" for x in names), "Fx", "Fy", "Mz", "KE", "PE"]
             + [f"R{k}_{c}" for k in range(1, n + 1) for c in ("Fx", "Fy", "Mz")])
    assert not set(order) & _UNPUBLISHED and set(order) <= set(index)
    state = {*names, *(f"{x}_d" for x in names)}
    for name in order:
        reaction = name.startswith("R") and name[1].isdigit()
        # the efforts reach the accelerations and the constraint forces at once
        feed = reaction or name in ("Fx", "Fy", "Mz") or name.endswith("_dd")
        # the coordinates and rates come from the state's kinematic pass alone (no evaluation)
        level = LEVEL_REACTIONS if reaction else LEVEL_STATE if name in state else LEVEL_OBSERVE
        d.output(name, level, feed, index[name])
    d.output("drive_angle", LEVEL_DRIVE, False, len(obs))
    d.output("drive_speed", LEVEL_DRIVE, False, len(obs) + 1)
    # the first closure's force is Fx, Fy, Mz; a chain of several loops (a
    # six-bar) publishes the others' as the library names them, closureJ_*
    for j in range(1, nc):
        for c, comp in enumerate(("Fx", "Fy", "Mz")):
            d.output(f"closure{j}_{comp}", LEVEL_REACTIONS, True, len(obs) + 2 + 3 * (j - 1) + c)


def _actuators(d: _Declared, n_out: int) -> None:
    """Each actuator's points (parameters), its force (an input) and its length and rate (outputs)."""
    n = d.m.n_links
    for j, a in enumerate(d.m.actuators):
        for end in ("from", "to"):
            d.par(f"{a.name}.{end}_link", INTEGER, f"actuator {a.name}: the link carrying its {end} point, 1: the "
                                                   "ground (structural)", None, 1, n + 1)
            for axis, words in (("x", "along"), ("y", "across")):
                d.par(f"{a.name}.{end}_point_{axis}", REAL, f"actuator {a.name}: its {end} point, {words} its "
                                                            "link's vector (world axes on the ground)", "m")
        force = mechanism_output(f"{a.name}_force", [a.name])
        d.v.append(Variable(force.name, REAL, INPUT, force.description, 0.0, fmi_unit(force.unit)))
        # kinematics: the state alone gives them, no input at the same instant
        d.output(f"{a.name}_length", LEVEL_DRIVE, False, n_out + 2 * j)
        d.output(f"{a.name}_rate", LEVEL_DRIVE, False, n_out + 2 * j + 1)


def _force_elements(d: _Declared, out_forces: int) -> tuple[list[int], list[tuple[int, int]]]:
    """Each force element's parameters (its kind's fields, grubler.quantities.force_fields) and outputs.

    Returns where each output comes from (element * GRB_FO_COUNT + the kernel's output index): the C
    model's FORCE_OUTPUT_INDEX (where each parameter goes: :func:`force_defines`).  The state alone decides
    the outputs.
    """
    n = d.m.n_links
    force_output_index = []
    for j, e in enumerate(d.m.forces):
        for f in force_fields(e.table):
            q = force_field(e.table, f)
            if f.endswith("link"):
                lo = 2 if e.table != "spring" else 1
                d.par(f"{e.name}.{f}", INTEGER, f"{e.table.replace('_', ' ')} {e.name}: {q.description} "
                                                "(structural)", None, lo, n + 1)
            else:
                d.par(f"{e.name}.{f}", REAL, f"{e.table.replace('_', ' ')} {e.name}: {fmi_text(q)}",
                      fmi_unit(q.unit))
        for q, k in FORCE_OUTPUTS[e.table]:
            d.output(f"{e.name}_{q.name}", LEVEL_DRIVE, False, out_forces + len(force_output_index))
            force_output_index.append(j * 6 + k)
    return force_output_index


def force_defines(m: Mechanism, slot_forces: int) -> dict:
    """config.h's words for the force elements whose parameters start at ``slot_forces`` (scene_slots.h reads
    them): their count, each one's kind and name, and where each parameter goes (element, kernel column).

    One table for every model that serves a scene: the Mechanism FMU and the ComputedTorque FMU.

    Examples
    --------
    >>> from grubler.mechanism.scene import load_scene
    >>> force_defines(load_scene("thesis-fourbar").mechanism, 40)
    {'N_FORCES': 0, 'SLOT_FORCES': 40}
    """
    defines = {"N_FORCES": len(m.forces), "SLOT_FORCES": slot_forces}
    if m.forces:
        params = [(j, FORCE_COLUMN[f]) for j, e in enumerate(m.forces) for f in force_fields(e.table)]
        defines["FORCE_KINDS"] = tuple(FORCE_KIND[type(e)] for e in m.forces)
        defines["FORCE_NAMES"] = tuple(e.name for e in m.forces)
        defines["FORCE_PARAM_ELEMENT"] = tuple(j for j, _ in params)
        defines["FORCE_PARAM_COLUMN"] = tuple(c for _, c in params)
    return defines


def force_parameter_names(m: Mechanism) -> list[str]:
    """The force elements' parameters in slot order: each element's fields (grubler.quantities.force_fields)."""
    return [f"{e.name}.{f}" for e in m.forces for f in force_fields(e.table)]


def _layout(m: Mechanism, n_observed: int, n_out: int, out_forces: int,
            force_output_index: list[int]) -> tuple[list[str], dict]:
    """Where each parameter lies in the C model's block (slot order) and the defines that say so (config.h)."""
    n, nc, names = m.n_links, len(m.closures), m.coordinate_names
    slot_order = [*GLOBALS]
    slot_order += [f"link{k}.{f}" for k in range(2, n + 2) for f in LINK_FIELDS]
    slot_order += [f"{closure_prefix(nc, j)}.{f}" for j in range(nc) for f in CLOSURE_FIELDS]
    slot_order += [f"initial.{x}" for x in names] + [f"initial.{x}_d" for x in names]
    slot_order += ["motor_torque", "load_torque"]
    slot_order += [f"{a.name}.{f}" for a in m.actuators for f in ACTUATOR_FIELDS]
    slot_order += [f"{a.name}_force" for a in m.actuators]
    slot_order += force_parameter_names(m)
    defines = {"N_LINKS": n, "N_CLOSURES": nc, "LINK_STRIDE": len(LINK_FIELDS),
               "CLOSURE_STRIDE": len(CLOSURE_FIELDS), "N_OBSERVED": n_observed, "N_ACTUATORS": len(m.actuators),
               "ACTUATOR_STRIDE": len(ACTUATOR_FIELDS), "OUT_ACTUATORS": n_out}
    defines.update({f"SLOT_{g.upper().replace('.', '_')}": k for k, g in enumerate(GLOBALS)})
    defines["SLOT_LINKS"] = len(GLOBALS)
    defines["SLOT_CLOSURES"] = defines["SLOT_LINKS"] + n * len(LINK_FIELDS)
    defines["SLOT_Q0"] = defines["SLOT_CLOSURES"] + nc * len(CLOSURE_FIELDS)
    defines["SLOT_QD0"] = defines["SLOT_Q0"] + 2 * n
    defines["SLOT_MOTOR_TORQUE"] = defines["SLOT_QD0"] + 2 * n
    defines["SLOT_LOAD_TORQUE"] = defines["SLOT_MOTOR_TORQUE"] + 1
    defines["SLOT_ACTUATORS"] = defines["SLOT_LOAD_TORQUE"] + 1
    defines["SLOT_ACTUATOR_FORCE"] = defines["SLOT_ACTUATORS"] + len(m.actuators) * len(ACTUATOR_FIELDS)
    defines.update({f"AF_{f.upper()}": k for k, f in enumerate(ACTUATOR_FIELDS)})
    defines.update(force_defines(m, defines["SLOT_ACTUATOR_FORCE"] + len(m.actuators)))
    defines["OUT_FORCES"] = out_forces
    defines["N_FORCE_OUTPUTS"] = len(force_output_index)
    if m.forces:
        defines["FORCE_OUTPUT_INDEX"] = tuple(force_output_index)
    defines.update({f"LF_{f.upper()}": k for k, f in enumerate(LINK_FIELDS)})
    defines.update({f"CF_{f.upper()}": k for k, f in enumerate(CLOSURE_FIELDS)})
    # fmi2GetDirectionalDerivative from the kernel's complex-step twin (grubler_cs.h)
    defines["MODEL_DIRECTIONAL_DERIVATIVE"] = 1
    return slot_order, defines


def mechanism_spec(scene: Scene, identifier: str = "Mechanism") -> ModelSpec:
    """The variables of a mechanism FMU with ``scene``'s shape and defaults.

    Declared in value-reference order, each stage a function: the run settings, the scene's quantities, the
    efforts (inputs), the observations, the links' parents, the actuators, the force elements (each group
    after the last, so an FMU without them keeps the value references it had); then the block's layout.

    Examples
    --------
    >>> from grubler.mechanism.scene import load_scene
    >>> spec = mechanism_spec(load_scene("watt-ii"), "WattII")     # build_fmu(spec, ...) compiles it
    >>> spec.identifier, spec.defines["N_LINKS"]
    ('WattII', 5)
    """
    m = scene.mechanism
    n, nc = m.n_links, len(m.closures)
    if scene.method not in METHODS:
        raise SceneError("method", f"must be one of {', '.join(METHODS)}, got {scene.method!r}")
    d = _Declared(scene)
    _run_settings(d)
    _scene_parameters(d)
    d.v.append(Variable("motor_torque", REAL, INPUT, "drive effort at drive_joint [N m, or N on a slide]", 0.0))
    d.v.append(Variable("load_torque", REAL, INPUT, "load effort at load_joint [N m, or N on a slide]", 0.0))
    obs = observation_names(n)
    _observations(d, obs)
    for k in range(2, n + 2):  # after the outputs: the value references above are those of an FMU before trees
        d.par(f"link{k}.parent", INTEGER, f"link {k}: the link its joint pair hangs from, 1: the ground "
                                          "(structural; the previous link for a serial chain)", None, 1, k - 1)
    n_out = len(obs) + 2 + 3 * max(nc - 1, 0)
    _actuators(d, n_out)
    out_forces = n_out + 2 * len(m.actuators)
    force_output_index = _force_elements(d, out_forces)
    slot_order, defines = _layout(m, len(obs), n_out, out_forces, force_output_index)
    return ModelSpec(identifier,
                     f"{m.name or 'mechanism'}: planar {n}-link chain by the imaginary-joints method"
                     f" ({m.kind or 'Grübler mechanism'}); every scene quantity is a parameter",
                     tuple(d.v), "mechanism_model.c", defines, out_forces + len(force_output_index),
                     tuple(slot_order), (JOINT, CLOSURE), ("kernel",), run_state(n, len(m.actuators)))


# the public names (the API reference's): the rest is the package's inside
__all__ = ["fmu_parameters", "scene_parameters", "same_shape", "mechanism_spec"]
