"""Six-bar presets against references that share no code with the library.

The reference (tests/planar_bodies.py) is a body-and-pin model in absolute
coordinates; here each preset is described to it from the preset file's own
dimensions (pivots, pin-to-pin lengths, triangles), the way the builder's
docstring says a designer draws it, with positions from closed-form dyads
(two circles) where the chain is a chain of dyads.
"""

import functools
import math
import tomllib
from importlib import resources

import numpy as np
import pytest

import grubler
from grubler.mechanism.dynamics import Inputs, forward_dynamics
from grubler.mechanism.inverse import drive_demand
from grubler.mechanism.kinematics import chain_kinematics
from grubler.mechanism.scene import override
from scipy.integrate import trapezoid  # (numpy's own came with numpy 2.0; the floor is 1.26)
from scipy.optimize import brentq

from planar_bodies import Bodies, Body, Pin, dyad

SIX = ["watt-i", "watt-ii", "stephenson-i", "stephenson-ii", "stephenson-iii"]
RHO = 1.0  # kg/m: the presets' bars


def params(name):
    text = (resources.files("grubler") / "presets" / f"{name}.toml").read_text()
    return tomllib.loads(text)["mechanism"]


def third(p, q, r_p, r_q, side):
    return dyad(p, q, r_p, r_q, 1 if side == "left" else -1)


# Each preset: its joints (where they are at a crank angle, by dyads), its bodies
# (which joints each carries, in the builder's documented chain order: the
# library's link k+2 is body k, whose joint to its predecessor comes first) and
# which joints are on the ground.
def triad(P, th, sign, near):
    """Stephenson II: the floating ternary's direction phi closes the loop through
    link_q where the miss |SQ| - link_q changes sign; the root nearest ``near``."""
    E = P["crank"] * np.array([math.cos(th), math.sin(th)])
    O6 = np.array(P["rocker_pivot"])

    def place(phi):
        w = {"O2": np.zeros(2), "O6": O6, "E": E}
        w["P"] = E + P["coupler_p"] * np.array([math.cos(phi), math.sin(phi)])
        w["Q"] = third(E, w["P"], P["coupler_q"], P["coupler_web"], P.get("coupler_side", "left"))
        w["R"] = dyad(w["P"], O6, P["link_p"], P["rocker_r"], sign)
        if w["R"] is None:
            return None, w
        w["S"] = third(O6, w["R"], P["rocker_s"], P["rocker_web"], P.get("rocker_side", "left"))
        return np.linalg.norm(w["S"] - w["Q"]) - P["link_q"], w

    grid = np.linspace(near - math.pi, near + math.pi, 2001)
    f = [place(a)[0] for a in grid]
    roots = [brentq(lambda a: place(a)[0], a, b, xtol=1e-15)
             for a, b, fa, fb in zip(grid, grid[1:], f, f[1:]) if fa is not None and fb is not None and fa * fb <= 0]
    if not roots:
        return None
    return place(min(roots, key=lambda a: abs(a - near)))[1]


def joints(name, P, th, signs, near=None):
    A = np.array([math.cos(th), math.sin(th)])
    if name == "stephenson-ii":
        return triad(P, th, signs[0], near)
    if name == "stephenson-iii":
        # the ground ternary's pivots; the floating ternary A-B-C rides on crank and rocker
        w = {"O2": np.zeros(2), "O4": np.array(P["rocker_pivot"]), "O6": np.array(P["output_pivot"])}
        w["A"] = P["crank"] * A
        w["B"] = dyad(w["A"], w["O4"], P["coupler"], P["rocker"], signs[0])
        if w["B"] is None:
            return None
        w["C"] = third(w["A"], w["B"], P["coupler_arm"], P["coupler_web"], P.get("coupler_side", "left"))
        w["D"] = dyad(w["C"], w["O6"], P["link5"], P["link6"], signs[1])
    elif name == "watt-ii":
        w = {"O2": np.zeros(2), "O4": np.array(P["rocker_pivot"]), "O6": np.array(P["output_pivot"])}
        w["A"] = P["crank"] * A
        w["B"] = dyad(w["A"], w["O4"], P["coupler"], P["rocker"], signs[0])
        if w["B"] is None:
            return None
        w["C"] = third(w["O4"], w["B"], P["rocker_arm"], P["rocker_web"], P.get("rocker_side", "left"))
        w["D"] = dyad(w["C"], w["O6"], P["coupler2"], P["output"], signs[1])
    else:
        w = {"O2": np.zeros(2), "O4": np.array(P["rocker_pivot"])}
        w["A"] = P["crank"] * A
        w["C"] = third(w["O2"], w["A"], P["crank_arm"], P["crank_web"], P.get("crank_side", "left"))
        w["B"] = dyad(w["A"], w["O4"], P["coupler"], P["rocker"], signs[0])
        if w["B"] is None:
            return None
        if name == "watt-i":
            w["E"] = third(w["A"], w["B"], P["coupler_arm"], P["coupler_web"], P.get("coupler_side", "left"))
        else:
            w["E"] = third(w["O4"], w["B"], P["rocker_arm"], P["rocker_web"], P.get("rocker_side", "left"))
        w["D"] = dyad(w["C"], w["E"], P["link5"], P["link6"], signs[1])
    return None if w["D"] is None else w


BODIES = {
    "watt-ii": [("O2", "A"), ("A", "B"), ("B", "C", "O4"), ("C", "D"), ("D", "O6")],
    "watt-i": [("O2", "C", "A"), ("C", "D"), ("D", "E"), ("E", "B", "A"), ("B", "O4")],
    "stephenson-i": [("O2", "C", "A"), ("C", "D"), ("D", "E"), ("E", "B", "O4"), ("B", "A")],
    "stephenson-ii": [("O2", "E"), ("E", "P", "Q"), ("P", "R"), ("R", "S", "O6"), ("S", "Q")],
    # a tree: links 4 (rocker) and 5 both hang from the floating ternary, link 3
    "stephenson-iii": [("O2", "A"), ("A", "B", "C"), ("B", "O4"), ("C", "D"), ("D", "O6")],
}
GROUND = {"watt-ii": ("O2", "O4", "O6"), "watt-i": ("O2", "O4"), "stephenson-i": ("O2", "O4"),
          "stephenson-ii": ("O2", "O6"), "stephenson-iii": ("O2", "O4", "O6")}


def reference(name, w, damping=0.0):
    """Bodies (bars between each body's joints, mass RHO per metre) and pins from joint positions."""
    bodies, owner = [], {}
    for k, names in enumerate(BODIES[name]):
        pts = [w[n] for n in names]
        bars = [(pts[i], pts[j]) for i in range(len(pts)) for j in range(i + 1, len(pts))]
        ms = [RHO * np.linalg.norm(b - a) for a, b in bars]
        m = sum(ms)
        c = sum(mi * (a + b) / 2 for mi, (a, b) in zip(ms, bars)) / m
        inertia = sum(mi * (np.linalg.norm(b - a) ** 2 / 12 + np.sum(((a + b) / 2 - c) ** 2))
                      for mi, (a, b) in zip(ms, bars))
        bodies.append(Body(name, m, inertia, {n: w[n] - c for n in names}))  # frame: world axes at the sketch
        for n in names:
            owner.setdefault(n, []).append(k)
    pins = []
    for n, ks in owner.items():
        if n in GROUND[name]:
            pins += [Pin(k, n, None, w[n], damping) for k in ks]
        else:
            pins.append(Pin(ks[0], n, ks[1], n, damping))
    x = np.concatenate([[*(w[BODIES[name][k][0]] - b.points[BODIES[name][k][0]]), 0.0]
                        for k, b in enumerate(bodies)])
    return Bodies(bodies, pins), x


def library_joints(model, z):
    """World positions of the library's chain joints (each link's origin)."""
    kin = chain_kinematics(model, z, np.zeros(model.n_links))
    return [np.array(kin.origin[k]) for k in range(model.n_links)]


def sketch(name):
    P = params(name)
    th = grubler.mechanism.scene.parse_angle_or_number(P["input_angle"], "input_angle")
    return P, th


@pytest.mark.parametrize("name", SIX)
def test_loop_positions_follow_the_closed_form_dyads_around_the_crank(name):
    # the Stephenson II is a triad: its reference scans the one free direction
    # and places everything else by dyads
    P, th0 = sketch(name)
    m = grubler.load_scene(name).mechanism
    z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    origins = [b[0] for b in BODIES[name]]

    def miss(w):
        return max(np.linalg.norm(a - w[n]) for a, n in zip(library_joints(m, z), origins))

    near = grubler.mechanism.scene.parse_angle_or_number(P.get("coupler_angle", 0.0), "coupler_angle")
    # which side each dyad is on at the start, read from the library's first assembly
    starts = {s: joints(name, P, th0, s, near) for s in ((1, 1), (1, -1), (-1, 1), (-1, -1))}
    signs = min((s for s in starts if starts[s] is not None), key=lambda s: miss(starts[s]))
    worst, checked = 0.0, 0
    for th in th0 + np.radians(np.arange(0, 360, 5)):
        w = joints(name, P, th, signs, near)
        z_next = z.copy()
        z_next[0] = th  # theta2 is the input angle O2A
        try:
            z_next, _ = grubler.assemble(m, z_next)
        except grubler.AssemblyError:
            assert w is None  # the library closes wherever the reference does
            continue
        z = z_next
        if w is None:
            continue
        if name == "stephenson-ii":
            near = math.atan2(*(w["P"] - w["E"])[::-1])
        worst = max(worst, miss(w))
        checked += 1
    assert checked > 20
    assert worst < 1e-10


def closed_library(name, **overrides):
    scene = grubler.load_scene(name)
    if overrides:
        scene = override(scene, overrides)
    m = scene.mechanism
    z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    return scene, m, z


def world_of(name, m, z):
    """Joint positions (every named joint) of a library configuration: each link's
    joint is its origin, the third joints are the closures' points."""
    kin = chain_kinematics(m, z, np.zeros(m.n_links))
    w = {names[0]: np.array(kin.origin[k]) for k, names in enumerate(BODIES[name])}
    for cl in m.closures:
        k = cl.link - 2
        c, s = math.cos(kin.theta[k]), math.sin(kin.theta[k])
        at = np.array(kin.origin[k]) + np.array([[c, -s], [s, c]]) @ np.array(cl.point)
        on_to = GROUND[name] if cl.to_link == 1 else BODIES[name][cl.to_link - 2]
        (joint,) = [n for n in BODIES[name][k] if n in on_to and n not in w]
        w[joint] = at
    return w


@pytest.mark.parametrize("name", SIX)
def test_undamped_undriven_six_bar_keeps_its_energy_for_ten_seconds(name):
    scene, m, z = closed_library(name)
    res = grubler.simulate(scene, t_end=10.0, dt_out=0.05, torque=0.0, rtol=1e-10, atol=1e-10)
    assert np.max(res["closure_error"]) < 1e-10
    assert np.ptp(res["theta2"]) > 0.5  # it moves
    e = res["E"]
    assert np.ptp(e) < 1e-7 * (np.max(res["KE"]) + 1e-3)
    # the energy the library starts from is the reference's, from joint positions alone
    w = world_of(name, m, z)
    ref, x = reference(name, w)
    assert abs(e[0] - ref.potential(x)) < 1e-12


@pytest.mark.parametrize("name", SIX)
def test_damped_six_bar_rests_where_the_potential_is_least_with_the_static_forces(name):
    damp = {f"link{k}.damping": 0.02 for k in range(2, 7)}
    scene, m, z = closed_library(name, **damp)
    res = grubler.simulate(scene, t_end=60.0, dt_out=0.5, torque=0.0, rtol=1e-10, atol=1e-10)
    assert np.max(np.abs(res.zd[-1])) < 1e-7  # at rest
    w = world_of(name, m, res.z[-1])
    ref, x_lib = reference(name, w)
    x_rest = ref.rest(x_lib + 0.01 * np.sin(np.arange(len(x_lib))))  # started off the library's answer
    assert np.max(np.abs(x_rest - x_lib)) < 1e-6
    # static pin forces: the reference's statics at its own rest position
    lam = ref.static_forces(x_rest)
    dyn = forward_dynamics(m, res.z[-1], np.zeros(m.n_links), Inputs())
    for j, cl in enumerate(m.closures):
        k, joint = cl.link - 2, None
        on_to = BODIES[name][cl.to_link - 2] if cl.to_link > 1 else GROUND[name]
        joint = next(n for n in BODIES[name][k] if n in on_to and n != BODIES[name][k][0])
        other = None if cl.to_link == 1 else cl.to_link - 2
        r = next(i for i, p in enumerate(ref.pins) if p.a == joint and {p.i, p.j} == {k, other})
        f = lam[r] if ref.pins[r].i == k else -lam[r]  # on the closing link
        assert np.allclose(dyn.lam[2 * j:2 * j + 2], f, atol=1e-6), (cl, dyn.lam, f)
        col = "F" if j == 0 else f"closure{j}_F"  # the Result's columns for every closure
        assert np.allclose([res[col + "x"][-1], res[col + "y"][-1]], f, atol=1e-6)
    # every chain joint's reaction (the force of link k's predecessor on link k)
    reactions = res["R1_Fx"][-1], res["R1_Fy"][-1]
    r0 = next(i for i, p in enumerate(ref.pins) if p.i == 0 and p.j is None and p.a == "O2")
    assert np.allclose(reactions, lam[r0], atol=1e-6)
    for k in range(1, m.n_links):
        joint, pred = BODIES[name][k][0], m.parents[k] - 2
        r = next(i for i, p in enumerate(ref.pins) if p.a == joint and {p.i, p.j} == {k, pred})
        f = lam[r] if ref.pins[r].i == k else -lam[r]
        assert np.allclose([res[f"R{k + 1}_Fx"][-1], res[f"R{k + 1}_Fy"][-1]], f, atol=1e-6)


@pytest.mark.parametrize("name", SIX)
def test_forward_then_inverse_dynamics_gives_back_the_applied_torque(name):
    scene, m, z = closed_library(name)

    def torque(t):
        return 0.03 * math.sin(3.0 * t)

    res = grubler.simulate(scene, t_end=1.0, dt_out=0.02, torque=torque, rtol=1e-11, atol=1e-11)
    demand = drive_demand(m, res["theta2"], res["theta2_d"], res["theta2_dd"], z_guess=res.z[0])
    applied = np.array([torque(t) for t in res.t])
    assert np.max(np.abs(demand.torque - applied)) < 1e-7


@pytest.mark.parametrize("name", SIX)
def test_ternary_links_are_drawn_as_plates_and_the_chain_is_named(name):
    from grubler.views.animation import frame_geometry

    m = grubler.load_scene(name).mechanism
    z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    geo = frame_geometry(m, z)
    ternary_moving = 1 if name in ("watt-ii", "stephenson-iii") else 2  # their other ternary is the ground
    assert len(geo.plates) == ternary_moving and all(len(p) == 3 for p in geo.plates)
    c = grubler.classify(m)
    assert c.mobility == 1
    assert c.name == {"watt-i": "Watt I", "watt-ii": "Watt II", "stephenson-i": "Stephenson I",
                      "stephenson-ii": "Stephenson II", "stephenson-iii": "Stephenson III"}[name] + " six-bar"


def test_an_input_angle_that_cannot_close_names_the_loop_and_its_triangle():
    scene = grubler.mechanism.scene.scene_from_dict({"mechanism": {
        "type": "watt-ii", "crank": 0.1, "coupler": 0.35, "rocker": 0.25, "rocker_arm": 0.2, "rocker_web": 0.3,
        "coupler2": 0.2, "output": 0.2, "rocker_pivot": [0.3, 0.0], "output_pivot": [0.35, 0.4],
        "input_angle": "30 deg"}})
    m = scene.mechanism
    q = list(m.q_ref)
    q[1] = math.radians(90)
    with pytest.raises(grubler.AssemblyError, match=r"link5-link6 .* must span the 0.43\d* m .*no triangle"):
        grubler.assemble(m, m.z_from_q(q))
    # the reference's dyad agrees that no position exists there
    w = joints("watt-ii", {"crank": 0.1, "coupler": 0.35, "rocker": 0.25, "rocker_arm": 0.2, "rocker_web": 0.3,
                           "coupler2": 0.2, "output": 0.2, "rocker_pivot": [0.3, 0.0],
                           "output_pivot": [0.35, 0.4]}, math.radians(90), (1, 1))
    assert w is None


def test_info_names_the_inversion_and_lists_the_branches(capsys):
    from grubler.cli import main

    assert main(["info", "watt-ii", "--at", "120 deg"]) == 0
    out = capsys.readouterr().out
    assert "Watt II six-bar (Watt chain)" in out and "mobility   1" in out
    branches = [line for line in out.splitlines() if line.startswith("  [")]
    assert len(branches) == 4  # two dyads, two sides each
    assert sum("the default" in line for line in branches) == 1
    # each listed branch is where the reference's dyads put it
    P = params("watt-ii")
    for line in branches:
        angles = dict((k, float(v)) for k, v, _deg in (kv.split() for kv in line[5:].split("<-")[0].split(", ")))
        candidates = [joints("watt-ii", P, math.radians(120), s) for s in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
        th3 = [math.degrees(math.atan2(*(w["B"] - w["A"])[::-1])) % 360 for w in candidates]
        assert min(abs(angles["theta3"] - a) for a in th3) < 1e-3


def test_info_at_an_angle_that_cannot_close_exits_with_the_loop_and_triangle(tmp_path, capsys):
    from grubler.cli import main

    scene = tmp_path / "tight.toml"
    scene.write_text('[mechanism]\ntype = "watt-ii"\ncrank = 0.1\ncoupler = 0.35\nrocker = 0.25\nrocker_arm = 0.2\n'
                     'rocker_web = 0.3\ncoupler2 = 0.2\noutput = 0.2\nrocker_pivot = [0.3, 0.0]\n'
                     'output_pivot = [0.35, 0.4]\ninput_angle = "30 deg"\n')
    assert main(["info", str(scene)]) == 0
    assert main(["info", str(scene), "--at", "90 deg"]) == 2
    err = capsys.readouterr().err
    assert "closure[1]" in err and "link5-link6" in err and "no triangle" in err


@pytest.mark.parametrize("name", SIX)
def test_drive_demand_over_a_turn_at_constant_speed_does_no_net_work(name):
    # sizing's demand for a six-bar: undamped, the mechanism returns every joule
    # it takes over one crank turn, and the static part is the reference's statics
    from grubler.studies.sizing import DutyCycle, required_drive

    m = grubler.load_scene(name).mechanism
    start = m.q_ref[1]
    cycle = DutyCycle.constant_speed(2 * math.pi, n=2001, start=start)
    demand = required_drive(m, cycle)
    work = trapezoid(demand.torque * demand.velocity, cycle.t)
    assert abs(work) < 1e-5 * trapezoid(np.abs(demand.torque * demand.velocity), cycle.t)
    slow = required_drive(m, DutyCycle.constant_speed(1e-4, n=73, start=start))  # quasi-static
    w = world_of(name, m, slow.z[0])
    ref, x = reference(name, w)
    J, Q = ref.jac(x), ref.forces(x, np.zeros(ref.n))
    crank = np.zeros(ref.n)
    crank[2] = 1.0  # the drive: a torque on body 0 (the crank) from the ground
    sol, *_ = np.linalg.lstsq(np.column_stack([crank, J.T]), -Q, rcond=None)
    assert abs(sol[0] - slow.torque[0]) < 1e-6


def test_several_closures_are_overridden_table_by_table_and_errors_name_the_closure():
    base = {k: v for k, v in params("watt-ii").items()}
    scene = grubler.mechanism.scene.scene_from_dict({"mechanism": base, "closure": [{}, {"gain": 5e4}]})
    assert [c.gain for c in scene.mechanism.closures] == [1e4, 5e4]
    with pytest.raises(grubler.SceneError, match=r"closure: the builder makes 2 closures"):
        grubler.mechanism.scene.scene_from_dict({"mechanism": base, "closure": {"gain": 5e4}})
    with pytest.raises(grubler.SceneError, match=r"closure\[1\]\.link: must be a moving link 2\.\.6"):
        grubler.mechanism.scene.scene_from_dict({"mechanism": base, "closure": [{}, {"link": True}]})
    with pytest.raises(grubler.SceneError, match=r"closure\[0\]\.to_link"):
        grubler.mechanism.scene.scene_from_dict({"mechanism": base, "closure": [{"to_link": 9}, {}]})
    # one tuning for every loop, as a sweep or an FMU sets it
    tuned = override(scene, {"closure.gain": 2e5})
    assert [c.gain for c in tuned.mechanism.closures] == [2e5, 2e5]


def test_a_triad_that_cannot_close_names_the_loop_left_open():
    # no dyad to blame in a Stephenson II: the message names the closure still open
    import dataclasses

    m = grubler.load_scene("stephenson-ii").mechanism
    closures = list(m.closures)
    closures[1] = dataclasses.replace(closures[1], point=(0.8, 0.0))  # link_q far too long
    m = m.replace(closures=tuple(closures))
    with pytest.raises(grubler.AssemblyError, match=r"the loop left open is closure\[1\]'s \(link6 to link3"):
        grubler.assemble(m, m.z_from_q(m.q_ref))


@functools.lru_cache(maxsize=None)
def stephenson_iii_bodies_driven():
    """The body model's run the library's stephenson-iii runs are held to (one run serves them all:
    it depends on neither the library's closure method nor its gain)."""
    name = "stephenson-iii"
    _, m, z = closed_library(name)
    ref, x0 = reference(name, world_of(name, m, z))
    ref.torque = {0: 0.05}  # the drive: on the crank, from the ground
    ref_x, _ = ref.simulate(x0, np.zeros(ref.n), np.linspace(0.0, 2.0, 41))
    ref_x.flags.writeable = False  # shared by the tests that call it
    return ref_x


def stephenson_iii_against_bodies(method="exact", gain=1e4, rtol=1e-12):
    """Library and body-model angles (from the start) over 2 s under a constant drive torque."""
    name = "stephenson-iii"
    scene, m, z = closed_library(name)
    # start both from the closed configuration (the penalty run starts there too)
    q = m.q_from_z(z)
    scene = override(scene, {"closure.gain": gain, **{f"initial.theta{k}": float(q[2 * k - 3]) for k in range(2, 7)}})
    ref_x = stephenson_iii_bodies_driven()
    times = np.linspace(0.0, 2.0, 41)
    res = grubler.simulate(scene, t_end=2.0, dt_out=0.05, torque=0.05, method=method, rtol=rtol, atol=rtol)
    assert np.allclose(res.t, times)
    lib = np.column_stack([res[f"theta{k}"] for k in range(2, 7)])
    lib -= lib[0]  # the reference's bodies start at angle 0 (world axes at the sketch)
    assert np.ptp(lib[:, 0]) > 1.0 and np.ptp(lib[:, 4]) > 0.3  # it turns, and the branch's loop moves
    return np.max(np.abs(lib - ref_x[:, 2::3])), np.max(res["closure_error"])


def test_stephenson_iii_follows_the_body_model_driven():
    # the one inversion whose chain branches (links 4 and 5 both hang from the
    # floating ternary, link 3) against bodies and pins, which know no chain
    worst, closure = stephenson_iii_against_bodies()
    assert closure < 1e-12
    assert worst < 1e-9, worst


@pytest.mark.slow
def test_stephenson_iii_penalty_closes_on_the_body_model_as_its_springs_stiffen():
    # the thesis's imaginary joint: each loop closed to force / G, so ten times
    # the gain takes the trajectory ten times closer to the rigid reference
    soft, soft_closure = stephenson_iii_against_bodies("penalty", 1e5, rtol=1e-10)
    stiff, stiff_closure = stephenson_iii_against_bodies("penalty", 1e6, rtol=1e-10)
    assert 1e-5 < stiff_closure < 1e-4 < soft_closure < 1e-3  # the springs' compliance, m
    assert 5.0 < soft / stiff < 20.0 and stiff < 5e-3, (soft, stiff)


def test_stephenson_iii_linearised_at_rest_swings_at_the_body_model_frequency():
    # the minimal coordinates and their complex-step twin on a tree: at the rest
    # position the linear model's stiffness over inertia is the reference's
    # d2PE/dphi2 over the generalised mass v^T M v, v = dx/dphi along the
    # closed configurations (phi the crank angle), by finite differences of the
    # reference's own closure
    name = "stephenson-iii"
    sys = grubler.linearize(name, torque=0.0)
    a21 = sys.A[1, 0]
    m = grubler.load_scene(name).mechanism
    slope, stiffness, inertia = crank_stiffness(name, m, sys.operating_point.z)
    assert abs(slope) < 1e-9  # the reference agrees it is at rest
    assert stiffness > 0
    assert abs(a21 + stiffness / inertia) < 1e-7 * stiffness / inertia, (a21, -stiffness / inertia)


def crank_stiffness(name, m, z, h=1e-3):
    """The reference's dPE/dphi, d2PE/dphi2 and generalised mass v^T M v at the library's pose z,
    v = dx/dphi along its own closed configurations (phi the crank's angle), by finite differences."""
    ref, x_rest = reference(name, world_of(name, m, z))

    def closed(dphi):
        x = x_rest.copy()
        x[2] += dphi  # body 0 is the crank
        return ref.close(x, hold=0)

    xs = [closed(k * h) for k in (-2, -1, 0, 1, 2)]
    pe = [ref.potential(x) for x in xs]
    stiffness = (-pe[0] + 16 * pe[1] - 30 * pe[2] + 16 * pe[3] - pe[4]) / (12 * h * h)
    v = (xs[0] - 8 * xs[1] + 8 * xs[3] - xs[4]) / (12 * h)
    return (pe[0] - 8 * pe[1] + 8 * pe[3] - pe[4]) / (12 * h), stiffness, v @ ref.mass() @ v


def test_info_names_stephenson_iii_its_tree_and_its_branches(capsys):
    from grubler.cli import main

    assert main(["info", "stephenson-iii", "--at", "120 deg"]) == 0
    out = capsys.readouterr().out
    assert "Stephenson III six-bar (Stephenson chain)" in out and "mobility   1" in out
    assert "ternary: link1 (ground), link3" in out and "chain      a tree" in out and "link5 on link3" in out
    branches = [line for line in out.splitlines() if line.startswith("  [")]
    assert len(branches) == 4 and sum("the default" in line for line in branches) == 1
    # each listed branch is one of the reference's four dyad placements
    P = params("stephenson-iii")
    candidates = [joints("stephenson-iii", P, math.radians(120), s) for s in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
    def off(angle, a, b):  # degrees between a listed angle and the direction a -> b
        d = (angle - math.degrees(math.atan2(*(b - a)[::-1]))) % 360
        return min(d, 360 - d)

    found = set()
    for line in branches:  # the rocker (link 4) runs B -> O4, link 6 D -> O6
        angles = dict((k, float(v)) for k, v, _deg in (kv.split() for kv in line[5:].split("<-")[0].split(", ")))
        miss = [max(off(angles["theta4"], w["B"], w["O4"]), off(angles["theta6"], w["D"], w["O6"]))
                for w in candidates]
        found.add(int(np.argmin(miss)))
        assert min(miss) < 1e-3
    assert found == {0, 1, 2, 3}


def test_stephenson_iii_at_an_angle_that_cannot_close_names_the_branch_dyad(tmp_path, capsys):
    from grubler.cli import main

    dims = {"crank": 0.1, "coupler": 0.35, "coupler_arm": 0.2, "coupler_web": 0.25, "rocker": 0.25, "link5": 0.2,
            "link6": 0.15, "rocker_pivot": [0.3, 0.0], "output_pivot": [0.3, 0.45]}
    scene = tmp_path / "tight.toml"
    scene.write_text('[mechanism]\ntype = "stephenson-iii"\ninput_angle = "30 deg"\n'
                     + "".join(f"{k} = {v}\n" for k, v in dims.items()))
    assert main(["info", str(scene)]) == 0
    assert main(["info", str(scene), "--at", "240 deg"]) == 2
    err = capsys.readouterr().err
    # the dyad on the branch: link 5 hangs from the floating ternary (link 3), link 6 from the ground pivot
    assert "link3-link5 (chain)" in err and "closure[1]" in err and "link5-link6" in err and "no triangle" in err
    assert joints("stephenson-iii", dims, math.radians(240), (1, 1)) is None  # the reference's dyad agrees
    assert joints("stephenson-iii", dims, math.radians(30), (1, 1)) is not None
