"""Studies over the mechanism and the drive (``grubler.studies``).

What lives here: linearisation into a python-control model
(:mod:`.linearize`), motor and gear-ratio sizing for a duty cycle
(:mod:`.sizing`), and parameter sweeps on local processes or Dask
(:mod:`.sweep`).

May import every layer below: the base modules, :mod:`grubler.mechanism`,
:mod:`grubler.motors`, :mod:`grubler.views`, :mod:`grubler.fmi`,
:mod:`grubler.system` and :mod:`grubler.controllers`. Only the CLI (and the
package's own ``__init__``) import the studies.
"""
