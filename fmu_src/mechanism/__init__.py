"""The mechanism: the Python face of the C kernel (``grubler.mechanism``).

What lives here: the model (:mod:`.model`: links, closures, the immutable
:class:`~grubler.mechanism.model.Mechanism`), scenes and their builders
(:mod:`.scene`, :mod:`.builders`; the preset TOML files are ``grubler/presets``),
assembly and analysis (:mod:`.assembly`, :mod:`.analysis`: mobility, Grashof,
branches), the kinematic and dynamic evaluations (:mod:`.kinematics`,
:mod:`.dynamics`, :mod:`.inverse`), the analysis at one instant (:mod:`.instant`:
velocities, accelerations, instant centres, transmission angles, joint forces),
and the run (:mod:`.integrators`,
:mod:`.simulate`).

Data flows one way: scene -> model tables -> kernel state and workspace ->
integrator -> result.

May import: :mod:`grubler.errors`, :mod:`grubler.limits` and
:mod:`grubler.binding` (the one module that calls the C kernel), and numpy and
scipy. Nothing above: not the FMUs, the co-simulation, the studies or the views.
"""
