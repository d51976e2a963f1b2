"""The page as a designer edits it (issue 33 items 2 and 4): a force element's links and joint picked from menus
of the scene's own, a load's arrow labelled with its magnitude, the force elements' forces among the analysis
layer's joint-force arrows, the form's numbers to six digits with the scene's own kept, and compound units
following the unit choice.  In headless Chromium (Playwright), on the drawing-tools module's page.

Screenshots land in ``$GRUBLER_APP_SCREENSHOTS`` when set (else the test's temporary folder).
"""

import pytest

from test_app_browser import CHROMIUM, pick_preset
from test_app_drawing_tools import browser, page, scene, server, settled, shared, shots  # noqa: F401 (fixtures)

pytestmark = [pytest.mark.skipif(CHROMIUM is None, reason="no Chromium found (Debian: apt-get install chromium)"),
              pytest.mark.slow]


def options(page, key: str) -> list:
    return page.eval_on_selector(f'select[data-key="{key}"]', "(s) => [...s.options].map((o) => o.value)")


def test_a_force_element_s_links_and_joint_are_menus_of_the_scene_s_and_a_choice_moves_it(page, shots):
    pick_preset(page, "gas-spring-boom")
    # the spring's ends may be on the ground; the load is on a moving link; the torsion spring at a real joint
    assert options(page, "spring[0].from_link") == ["ground", "link2", "link3", "link4"]
    assert options(page, "spring[0].to_link") == ["ground", "link2", "link3", "link4"]
    assert options(page, "point_load[0].link") == ["link2", "link3", "link4"]
    assert options(page, "joint_spring[0].joint") == ["theta2", "theta3", "theta4"]
    # each shows what the scene says (the load's link written 3 reads link3; the scene keeps its 3)
    assert page.input_value('[data-key="spring[0].to_link"]') == "link2"
    assert page.input_value('[data-key="point_load[0].link"]') == "link3"
    assert page.input_value('[data-key="joint_spring[0].joint"]') == "theta3"
    assert scene(page)["point_load"][0]["link"] == 3
    spring = page.evaluate("() => state.analysis.frame.springs[0]")
    load = page.evaluate("() => state.analysis.frame.loads[0]")
    coil = page.evaluate("() => state.analysis.frame.coils[0]")
    # chosen: the element moves onto its new link, the value written as the menu names it
    page.select_option('[data-key="spring[0].to_link"]', "link3")
    settled(page, "state.scene.spring[0].to_link === 'link3' && state.analysis.scene === state.scene")
    moved = page.evaluate("() => state.analysis.frame.springs[0]")
    assert moved[0] == spring[0] and moved[-1] != pytest.approx(spring[-1], abs=1e-3)
    page.select_option('[data-key="point_load[0].link"]', "link2")
    settled(page, "state.scene.point_load[0].link === 'link2' && state.analysis.scene === state.scene")
    assert page.evaluate("() => state.analysis.frame.loads[0]")[:2] != pytest.approx(load[:2], abs=1e-3)
    page.select_option('[data-key="joint_spring[0].joint"]', "theta2")
    settled(page, "state.scene.joint_spring[0].joint === 'theta2' && state.analysis.scene === state.scene")
    assert page.evaluate("() => state.analysis.frame.coils[0]")[:2] != pytest.approx(coil[:2], abs=1e-3)
    page.screenshot(path=str(shots / "30-element-menus.png"))


def test_a_load_s_arrow_reads_its_magnitude_and_the_elements_forces_join_the_joint_force_arrows(page, shots):
    pick_preset(page, "gas-spring-boom")
    # the payload: 1962 N downwards (the scene's force [0, -1962]), written on its arrow
    assert page.text_content("#drawing g.load text.alabel") == "1962 N"
    page.fill('[data-key="point_load[0].force"]', "[300, -400]")
    page.press('[data-key="point_load[0].force"]', "Enter")
    settled(page, "state.scene.point_load[0].force[0] === 300 && state.analysis.scene === state.scene")
    assert page.text_content("#drawing g.load text.alabel") == "500 N"
    # the joint-force view: the four pins' reactions, the strut's force at both its ends, the payload's
    page.check('#analysis-layer input[data-kind="f"]')
    page.wait_for_selector(".analysis .arrow.force.element")
    assert page.locator(".analysis .arrow.force:not(.element)").count() == 4
    labels = page.eval_on_selector_all(".analysis .arrow.force.element text", "(ts) => ts.map((t) => t.textContent)")
    assert len(labels) == 3 and labels[0] == labels[1] and labels[0].startswith("strut ")
    assert labels[2] == "payload 500 N"
    a = page.evaluate("() => state.analysis.analysis")
    strut = [f for f in a["element_forces"] if f["label"] == "strut"]
    spring = page.evaluate("() => state.analysis.frame.springs[0]")
    # at the spring's two ends, equal and opposite, along its line
    assert strut[0]["at"] == pytest.approx(spring[-1], abs=1e-5)
    assert strut[1]["at"] == pytest.approx(spring[0], abs=1e-5)
    assert strut[0]["f"] == pytest.approx([-v for v in strut[1]["f"]])
    line = [spring[-1][0] - spring[0][0], spring[-1][1] - spring[0][1]]
    assert strut[0]["f"][0] * line[1] - strut[0]["f"][1] * line[0] == pytest.approx(0, abs=1e-6 * 1e4)
    # scaled with the joints' arrows: the longest of all is a fifth of the view
    lengths = page.eval_on_selector_all(".analysis .arrow.force polygon", """(ps) => ps.map((p) => {
        const g = p.parentNode.querySelector('line'); const [x, y] = p.getAttribute('points').split(' ')[0].split(',');
        return Math.hypot(x - g.getAttribute('x1'), y - g.getAttribute('y1')); })""")
    span = page.evaluate("() => state.box.span")
    assert max(lengths) == pytest.approx(0.2 * span, rel=1e-6)
    page.screenshot(path=str(shots / "31-load-label-and-element-forces.png"))
    page.uncheck('#analysis-layer input[data-kind="f"]')


def test_the_form_shows_six_digits_and_sends_the_scene_s_own_value_of_what_was_not_edited(page, shots):
    pick_preset(page, "gas-spring-boom")
    # 0.01 rad/s is 0.572957795131 deg/s: shown to six digits
    assert page.input_value('[data-key="joint_spring[0].friction_speed"]') == "0.572958"
    page.select_option("#unit-angle", "rad")
    assert page.input_value('[data-key="joint_spring[0].free"]') == "-1.00531"  # -57.6 deg
    # a list: one part edited, the other sent as the scene holds it, not as its six digits
    page.fill('[data-key="spring[0].from_point"]', "[0.123456789, -0.3]")
    page.press('[data-key="spring[0].from_point"]', "Enter")
    settled(page, "state.scene.spring[0].from_point[0] === 0.123456789")
    assert page.input_value('[data-key="spring[0].from_point"]') == "[0.123457, -0.3]"
    page.fill('[data-key="spring[0].from_point"]', "[0.123457, -0.25]")
    page.press('[data-key="spring[0].from_point"]', "Enter")
    settled(page, "state.scene.spring[0].from_point[1] === -0.25")
    assert scene(page)["spring"][0]["from_point"] == [0.123456789, -0.25]
    # a number edited: what was typed, to the digit
    page.fill('[data-key="joint_spring[0].free"]', "-1.0053")
    page.press('[data-key="joint_spring[0].free"]', "Enter")
    settled(page, "state.scene.joint_spring[0].free === -1.0053")
    page.fill('[data-key="joint_spring[0].free"]', "-1.00531")
    page.press('[data-key="joint_spring[0].free"]', "Enter")
    settled(page, "state.scene.joint_spring[0].free === -1.00531")
    # the form's other numbers untouched by these edits: the scene still says what it said
    assert scene(page)["joint_spring"][0]["friction_speed"] == 0.01


def test_the_mechanical_advantage_s_unit_follows_the_length_unit(page):
    pick_preset(page, "slider-crank")
    page.check('#analysis-layer input[data-kind="v"]')
    page.wait_for_selector(".analysis .arrow.vel")
    facts = page.inner_text("#analysis-facts")
    value = page.evaluate("() => state.analysis.analysis.advantage.value")
    assert page.evaluate("() => state.analysis.analysis.advantage.unit") == "1/m"
    assert f"{float(f'{value:.4g}'):g} 1/m" in facts
    page.select_option("#unit-length", "mm")
    facts = page.inner_text("#analysis-facts")
    assert f"{float(f'{value / 1000:.4g}'):g} 1/mm" in facts, facts
    page.uncheck('#analysis-layer input[data-kind="v"]')
