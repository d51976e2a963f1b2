"""Pictures and records of a run (``grubler.views``).

What lives here: panel plots (:mod:`.plotting`), the animated mechanism
(:mod:`.animation`), the one-page run report (:mod:`.report`) and the reader of
the CSV records a simulation or co-simulation writes (:mod:`.runs`).

May import: the base modules (:mod:`grubler.errors`, :mod:`grubler.limits`,
:mod:`grubler.binding`) and :mod:`grubler.mechanism`, plus matplotlib and Pillow.
The layers above (FMUs, co-simulation, studies) draw their own results through
these modules; a view never imports them.
"""
