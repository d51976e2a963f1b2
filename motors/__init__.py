"""Motor models that drive a grubler mechanism (``grubler.motors``)."""
