"""The force elements on the page as a designer edits them (issue 33 items 2 and 4): their links and joints
picked from menus of the scene's own, a load's arrow labelled with its magnitude, and their forces among the
analysis layer's joint-force arrows.  In headless Chromium (Playwright), on the drawing-tools module's page.

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
