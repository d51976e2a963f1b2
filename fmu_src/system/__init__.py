"""Co-simulation of FMUs as a system (``grubler.system``).

What lives here: what an FMU offers to a master (:mod:`.interface`), the SSP
system description read and written (:mod:`.ssp`), the master that plans,
sets up, steps and records a system (:mod:`.cosim`, its stepping loop in
``c/master.c``; the power at its mechanical connections and whether a run diverged,
:mod:`.coupling_energy`), a whole system exported as one FMU (:mod:`.container`), the
servo-drive builder (:mod:`.servo`), and the pythonfmu slave that turns a Python law into an FMU
(:mod:`.fmi_slave`, its versioned state :mod:`.fmu_state` and the loader that
finds the package inside the FMU, :mod:`.fmu_loader`).

The master knows FMUs and SSP, not mechanisms: only :mod:`.servo` builds a
system from a scene.

May import: the base modules, :mod:`grubler.mechanism`, :mod:`grubler.motors`,
:mod:`grubler.views` and :mod:`grubler.fmi`, plus fmpy. Not the controllers,
the studies or the CLI.
"""
