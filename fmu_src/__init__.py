"""grubler: planar four-link Grübler mechanisms by the imaginary-joints method.

The model (:class:`Mechanism`) is immutable data; a :class:`Simulator` holds one
run's state over it; :func:`simulate` runs a scene and returns a :class:`Result`.

Examples
--------
>>> import grubler
>>> res = grubler.simulate("thesis-fourbar", t_end=0.2, dt_out=0.1)
>>> res.columns[:7]
['t', 'B1', 'theta2', 'B2', 'theta3', 'B3', 'theta4']
>>> bool(res["closure_error"].max() < 1e-12)
True
>>> sys = grubler.linearize("thesis-fourbar-damped")      # a python-control StateSpace
>>> sys.state_labels
['theta2', 'theta2_d']
"""

import sys

from grubler._version import __version__
from grubler.mechanism.analysis import Grashof, classify, grashof, kutzbach_mobility
from grubler.mechanism.assembly import assemble
from grubler.mechanism.dynamics import Inputs, forward_dynamics, inverse_dynamics, joint_reactions
from grubler.errors import AssemblyError, GrublerError, IntegrationError, SceneError, SceneErrors
from grubler.studies.linearize import OperatingPoint, linearize, operating_point
from grubler.mechanism.model import Closure, JointSpring, Link, Mechanism, PointLoad, Spring
from grubler.mechanism.scene import Scene, load_scene, preset_names, scene_from_dict
from grubler.mechanism.simulate import Result, Simulator, evaluate, output_columns, simulate
from grubler.system import cosim, ssp

# grubler.motors after `import grubler` (the data sets and the drives); by its full name, which a
# doctest run that imports this folder as `fmu_src` also finds
from grubler import motors

# the co-simulation modules keep their public names (``import grubler.cosim``,
# ``from grubler.ssp import System``) now that they live in grubler.system
sys.modules[__name__ + ".cosim"], sys.modules[__name__ + ".ssp"] = cosim, ssp


__all__ = [
    "AssemblyError", "Closure", "Grashof", "GrublerError", "Inputs", "IntegrationError", "JointSpring", "Link",
    "Mechanism", "OperatingPoint", "Result", "Scene", "SceneError", "SceneErrors", "Simulator", "assemble", "classify", "evaluate",
    "forward_dynamics", "grashof", "inverse_dynamics", "joint_reactions", "kutzbach_mobility", "linearize",
    "load_scene", "operating_point", "output_columns", "PointLoad", "preset_names", "scene_from_dict", "simulate", "Spring",
]
