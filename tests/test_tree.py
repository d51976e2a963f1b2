"""Chains that branch: each link's predecessor is any earlier link or the ground.

The Stephenson III six-bar needs it (tests/test_sixbar.py); here the tree is
checked in general, on an open chain that is no mechanism of any catalogue: a
"Y" of five bars whose joints hang from the ground twice, from one link twice
and from a branch's branch, against the body-and-pin reference
(tests/planar_bodies.py), which shares no code with the library.  Then what a
scene file may say about a link's predecessor, and the errors when it is wrong.
"""

import math

import numpy as np
import pytest

import grubler
from grubler import Link, Mechanism, Simulator
from grubler.mechanism.scene import scene_from_dict
from planar_bodies import Bodies, Body, Pin, rot

# link: (predecessor, a, p, q, m, I); link 4 sits 0.2 m across link 2's end, link 5
# on the ground 0.3 m above link 2's pivot, link 6 at the end of link 4
Y = {2: (1, 0.5, 0.25, 0.0, 1.0, 0.03), 3: (2, 0.4, 0.2, 0.05, 0.6, 0.01), 4: (2, 0.3, 0.15, 0.0, 0.5, 0.006),
     5: (1, 0.45, 0.2, -0.03, 0.7, 0.02), 6: (4, 0.35, 0.175, 0.0, 0.4, 0.004)}
B = {2: 0.0, 3: 0.0, 4: 0.2, 5: 0.3, 6: 0.0}  # each pair's slide across its predecessor's vector end
ANGLES = {2: -1.0, 3: -2.1, 4: -0.5, 5: -1.8, 6: 0.2}  # absolute, rad
RATES = {2: 1.0, 3: 0.0, 4: 0.0, 5: -0.5, 6: 0.0}  # relative to the predecessor, rad/s


def y_tree():
    links = tuple(Link("R", a=a, p=p, q=q, m=m, I=i, parent=pred) for pred, a, p, q, m, i in Y.values())
    q_ref = tuple(v for k in Y for v in (B[k], ANGLES[k]))
    return Mechanism(links=links, q_ref=q_ref, name="Y")


def y_reference():
    """Five bodies (frames at their mass centres, along their link vectors) and five pins, from the table."""
    bodies, pins = [], []
    for k, (pred, a, p, q, m, i) in Y.items():
        pts = {"joint": (-p, -q)}
        for c, row in Y.items():
            if row[0] == k:
                pts[f"pin{c}"] = (a - p, B[c] - q)
        bodies.append(Body(f"link{k}", m, i, pts))
        pins.append(Pin(k - 2, "joint", None, (0.0, B[k])) if pred == 1 else Pin(k - 2, "joint", pred - 2, f"pin{k}"))
    return Bodies(bodies, pins)


def y_start():
    """Mass-centre poses and velocities by hand: joints from the predecessors' ends."""
    joint, omega, vel = {}, {}, {}
    x, v = np.zeros(15), np.zeros(15)
    for k, (pred, a, p, q, m, i) in Y.items():
        if pred == 1:
            joint[k], vj, omega[k] = np.array([0.0, B[k]]), np.zeros(2), RATES[k]
        else:
            at = rot(ANGLES[pred]) @ np.array([Y[pred][1], B[k]])
            joint[k] = joint[pred] + at
            vj = vel[pred] + omega[pred] * np.array([-at[1], at[0]])
            omega[k] = omega[pred] + RATES[k]
        vel[k] = vj
        arm = rot(ANGLES[k]) @ np.array([p, q])
        x[3 * k - 6:3 * k - 3] = [*(joint[k] + arm), ANGLES[k]]
        v[3 * k - 6:3 * k - 3] = [*(vj + omega[k] * np.array([-arm[1], arm[0]])), omega[k]]
    return x, v


def test_a_y_shaped_tree_moves_like_bodies_and_pins_with_its_joint_forces():
    m = y_tree()
    assert m.parents == (1, 2, 2, 1, 4) and m.is_tree and m.mobility == 5
    ref = y_reference()
    x0, v0 = y_start()
    # consistent to rounding: a pin's row sums at most 6 rounded terms (two bodies'
    # x, y and rotated arm) of magnitudes totalling under 6 m (or m/s), so rounding
    # leaves at most 6 x 6 x 2^-53 = 4e-15, on any BLAS (the old 1e-15 was tighter)
    assert np.abs(ref.phi(x0)).max() < 1e-14 and np.abs(ref.jac(x0) @ v0).max() < 1e-14
    times = np.linspace(0.0, 3.0, 31)
    ref_x, ref_v = ref.simulate(x0, v0, times)
    sim = Simulator(m, zd0=np.array([RATES[k] for k in Y]), rtol=1e-12, atol=1e-12)
    worst_angle = worst_force = worst_moment = 0.0
    energies = []
    for t, x, v in zip(times, ref_x, ref_v):
        sim.advance_to(t)
        out = sim.outputs(["state", "dynamics", "energy", "reactions"])
        worst_angle = max(worst_angle, max(abs(out[f"theta{k}"] - x[3 * k - 4]) for k in Y))
        _, lam = ref.accelerations(x, v)
        for r, k in enumerate(Y):  # pin r holds link k to its predecessor: the force on link k
            f = np.array([out[f"R{k - 1}_Fx"], out[f"R{k - 1}_Fy"]])
            worst_force = max(worst_force, float(np.max(np.abs(f - lam[2 * r:2 * r + 2]))))
            worst_moment = max(worst_moment, abs(out[f"R{k - 1}_Mz"]))  # a free pin carries none
        energies.append(out["E"])
    assert np.ptp(ref_x[:, 2::3], axis=0).min() > 0.3  # every branch swings
    assert worst_angle < 1e-9, worst_angle
    assert worst_force < 1e-7, worst_force
    assert worst_moment < 1e-10, worst_moment
    assert np.ptp(energies) < 1e-9
    assert abs(energies[0] - ref.potential(x0) - ref.kinetic(v0)) < 1e-12


def test_the_same_y_from_a_scene_file_and_the_parent_spellings():
    base = {f"link{k}": {"joint": "R", "a": a, "p": p, "q": q, "m": m, "I": i}
            for k, (pred, a, p, q, m, i) in Y.items()}
    base["initial"] = {**{f"theta{k}": ANGLES[k] for k in Y}, **{f"B{k - 1}": B[k] for k in Y if B[k]}}
    spellings = {"link3": {"parent": "link2"}, "link4": {"parent": 2}, "link5": {"parent": "ground"},
                 "link6": {"parent": "link4"}}
    data = {k: dict(v, **spellings.get(k, {})) for k, v in base.items()}
    m = scene_from_dict(data).mechanism
    assert m.parents == y_tree().parents
    assert np.array_equal(m.arrays.links, y_tree().arrays.links)


@pytest.mark.parametrize("link, value, reason", [
    ("link4", "link4", "an earlier link"), ("link4", 5, "an earlier link"), ("link3", "link9", "link2"),
    ("link2", "link2", "must name the ground"), ("link4", True, "got True"), ("link4", 2.0, "got 2.0"),
    ("link4", "crank", "got 'crank'"), ("link4", 0, "got 0"),
])
def test_a_parent_that_is_not_the_ground_or_an_earlier_link_is_named(link, value, reason):
    data = {f"link{k}": {"joint": "R", "a": 0.3} for k in range(2, 6)}
    data[link]["parent"] = value
    with pytest.raises(grubler.SceneError, match=rf"{link}\.parent") as err:
        scene_from_dict(data)
    assert reason in str(err.value)


def test_the_command_line_refuses_a_bad_parent_with_exit_2(tmp_path, capsys):
    from grubler.cli import main

    scene = tmp_path / "bad.toml"
    scene.write_text('[link2]\njoint = "R"\na = 0.3\nm = 1\n[link3]\njoint = "R"\na = 0.3\nm = 1\nparent = "link3"\n')
    assert main(["info", str(scene)]) == 2
    assert "link3.parent" in capsys.readouterr().err
    good = tmp_path / "good.toml"
    good.write_text('[link2]\njoint = "R"\na = 0.3\nm = 1\n[link3]\njoint = "R"\na = 0.3\nm = 1\nparent = "ground"\n'
                    '[initial]\nB2 = 0.2\n')
    assert main(["info", str(good)]) == 0
    assert "link3 on the ground" in capsys.readouterr().out


def test_a_link_built_in_python_refuses_a_later_parent():
    with pytest.raises(grubler.SceneError, match=r"link3\.parent: must be the ground \(1\) or an earlier link 2\.\.2"):
        Mechanism(links=(Link("R", a=0.3), Link("R", a=0.3, parent=3)))


def test_a_loop_on_a_tree_counts_the_revolutes_on_its_tree_path():
    # links 3 and 4 hang from link 2; a closure from link 4 to link 3 closes the
    # loop 3-2-4: link 3's revolute pair, link 4's slide and the closure's slide
    # (a serial chain's count, link 4's pair alone, would say 0)
    links = (Link("R", a=0.5), Link("R", a=0.3), Link("P", a=0.3, parent=2))
    m = Mechanism(links=links, q_ref=(0, 0, 0.1, 0.5, 0.2, -0.5))
    assert m.loop_pairs(4, 3) == [3, 4] and m.loop_pairs(4, 1) == [2, 4]
    with pytest.raises(grubler.SceneError, match=r"the loop from link 3 to link 4 has 1 revolute"):
        m.replace(closures=(grubler.Closure("prismatic", link=4, point=(0.3, 0.0), to_link=3, angle=0.3),))


def test_a_tree_with_slides_on_its_branches_keeps_its_energy():
    # prismatic pairs off a turning parent carry the Coriolis and centripetal
    # terms of the parent's rotation (taken from the parent's row, not the
    # previous link's): were they wrong, an undamped, undriven run would not
    # keep its energy.  Link 3 slides across link 2's end, link 4 swings from
    # link 2 beside it, link 5 swings from the slider, link 6 slides on link 4.
    links = (Link("R", a=0.6, p=0.3, m=1.0, I=0.03), Link("P", a=0.0, m=0.4, I=0.002, parent=2),
             Link("R", a=0.4, p=0.2, q=0.02, m=0.5, I=0.007, parent=2), Link("R", a=0.3, p=0.15, m=0.3, I=0.002, parent=3),
             Link("P", a=0.1, p=0.05, m=0.2, I=0.001, parent=4))
    q_ref = (0.0, -0.3, 0.05, -0.3, -0.15, -1.2, 0.0, -2.0, 0.1, -0.4)
    m = Mechanism(links=links, q_ref=q_ref)
    assert m.parents == (1, 2, 2, 3, 4)
    sim = Simulator(m, zd0=np.array([1.5, 0.2, -1.0, 0.5, -0.3]), rtol=1e-11, atol=1e-11)
    energies, slides = [], []
    for t in np.linspace(0.0, 5.0, 101):
        sim.advance_to(t)
        out = sim.outputs(["state", "energy"])
        energies.append(out["E"])
        slides.append((out["B2"], out["B5"]))
    slides = np.array(slides)
    assert np.ptp(slides[:, 0]) > 0.05 and np.ptp(slides[:, 1]) > 0.05  # both slides move
    assert np.ptp(energies) < 1e-8 * max(abs(e) for e in energies), np.ptp(energies)
