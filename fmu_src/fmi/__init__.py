"""Native FMI 2.0 and 3.0 co-simulation FMUs: the C kernel behind a thin C wrapper.

A native FMU runs no Python: its binary is the physics kernel
(``fmu_src/kernel``) plus a generic FMI wrapper (``c/fmi_common.c`` behind the
adapter of its FMI version, ``c/fmi2_wrapper.c`` or ``c/fmi3_wrapper.c``) and
one model file per model (``c/mechanism_model.c``).  This package holds what
writes such an FMU:

- :mod:`grubler.fmi.variables`: a model's variables and the layout of its
  values, the one definition the C header and the model description derive from;
- :mod:`grubler.fmi.mechanism`: the mechanism's variables, from a scene;
- :mod:`grubler.fmi.description`: ``modelDescription.xml``;
- :mod:`grubler.fmi.header`: ``sources/config.h``, the same layout for the C side;
- :mod:`grubler.fmi.build`: compile, package, and :func:`export` a scene.

May import: the base modules, :mod:`grubler.mechanism` and :mod:`grubler.motors`
(a scene's or a data set's quantities become the FMU's parameters). Not the
co-simulation, the studies or the CLI.
"""
