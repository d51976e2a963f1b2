"""Errors a user can act on: each names the field at fault and the reason."""

from __future__ import annotations


class GrublerError(Exception):
    """Base class of every error the library raises on purpose."""


class InputError(GrublerError, ValueError):
    """A value from outside (an option, a file, a field of a scene or system) that is refused.

    Parameters
    ----------
    field : str
        Where the bad value sits, spelled as the user wrote it (an option such
        as ``--dt-out``, a scene field such as ``links[2].m``).
    reason : str
        What is wrong with it, in the engineer's terms.
    """

    MAX_CHARS = 1000  # a value echoed into a message is cut, whatever its size

    def __init__(self, field: str, reason: str):
        field, reason = _cut(str(field), 200), _cut(str(reason), self.MAX_CHARS)
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")

    def __reduce__(self):  # sweep workers send errors back pickled
        return (type(self), (self.field, self.reason))


def _cut(text: str, limit: int) -> str:
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


class LimitError(InputError):
    """An input that would take more memory, disk or time than the program allows itself."""


class SceneError(InputError):
    """A mechanism or scene description that makes no sense (see :class:`InputError`)."""


class AssemblyError(SceneError):
    """The loop cannot be closed for the given dimensions or initial state."""


class Cancelled(GrublerError):
    """A run stopped on request (the app's cancel button) before its end: names the run and when."""

    def __init__(self, field: str, reason: str):
        self.field, self.reason = field, reason
        super().__init__(f"{field}: {reason}")

    def __reduce__(self):
        return (type(self), (self.field, self.reason))


class SystemDescriptionError(GrublerError):
    """A system description that cannot be run: names the element and the reason."""


class IntegrationError(GrublerError, RuntimeError):
    """The integrator could not continue (step-size underflow, non-finite state).

    Its message starts with the field ``integration:``, like every refusal the
    CLI prints: what failed is the run itself, at the time the reason gives.
    """

    field = "integration"

    def __init__(self, reason: str):
        self.reason = reason
        super().__init__(reason if reason.startswith("integration: ") else f"integration: {reason}")

    def __reduce__(self):  # sweep workers send errors back pickled
        return (type(self), (self.reason,))
