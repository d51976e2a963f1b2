"""Linearise the triple-rocker at its toggle and print the verdict (run by test_linearize.py).

    python toggle_scenario.py

The test runs it once per OpenBLAS kernel (OPENBLAS_CORETYPE is read when numpy
loads, so each kernel needs its own process).  Prints the one-line refusal, or
``accepted``.
"""

import math

import grubler
from grubler import SceneError
from grubler.studies.linearize import linearize


def toggle_angle(scene) -> float:
    """The crank angle at which a triple-rocker's coupler and rocker lie in line.

    The crank turns only while its pin stays within coupler + rocker of the rocker
    pivot; at that limit theta3 and theta4 no longer follow from theta2.
    """
    ground, crank, coupler, rocker = grubler.classify(scene.mechanism).fourbar_lengths
    d = coupler + rocker
    return math.acos((crank ** 2 + ground ** 2 - d ** 2) / (2 * crank * ground))


def verdict() -> str:
    scene = grubler.load_scene("fourbar-triple-rocker")
    try:
        linearize(scene, at={"theta2": toggle_angle(scene)})
    except SceneError as exc:
        return str(exc)
    return "accepted"


if __name__ == "__main__":
    print(verdict())
