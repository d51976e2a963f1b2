"""Controllers and transducers for a grubler mechanism (``grubler.controllers``)."""
