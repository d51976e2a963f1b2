"""The package's version: one place, read by pyproject.toml and the FMUs' model descriptions."""

__version__ = "0.1.0"
