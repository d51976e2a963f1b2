"""Errors a user can act on: each names the field at fault and the reason."""

from __future__ import annotations


class GrublerError(Exception):
    """Base class of every error the library raises on purpose."""


class SceneError(GrublerError, ValueError):
    """A mechanism or scene description that makes no sense.

    Parameters
    ----------
    field : str
        Where the bad value sits, spelled as in the scene file
        (e.g. ``links[2].m`` or ``closure.point``).
    reason : str
        What is wrong with it, in the engineer's terms.
    """

    def __init__(self, field: str, reason: str):
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")


class AssemblyError(SceneError):
    """The loop cannot be closed for the given dimensions or initial state."""


class IntegrationError(GrublerError, RuntimeError):
    """The integrator could not continue (step-size underflow, non-finite state)."""
