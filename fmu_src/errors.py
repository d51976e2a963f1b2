"""Errors a user can act on: each names the field at fault and the reason."""

from __future__ import annotations

import contextlib


class GrublerError(Exception):
    """Base class of every error the library raises on purpose.

    Examples
    --------
    >>> import grubler
    >>> try:
    ...     grubler.load_scene("no-such-scene")
    ... except grubler.GrublerError as e:       # every refusal of the library is one
    ...     print(type(e).__name__, "|", e.field)
    SceneError | scene
    """


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
    """A mechanism or scene description that makes no sense (see :class:`InputError`).

    Examples
    --------
    >>> import grubler
    >>> try:
    ...     grubler.scene_from_dict({"link2": {"joint": "R", "a": -1.0, "m": 1.0}})
    ... except grubler.SceneError as e:
    ...     print(e.field, "|", e.reason)
    link2.a | length must be >= 0, got -1.0
    """


class SceneErrors(SceneError):
    """Several problems of one scene, each a :class:`SceneError`: all of them at once.

    ``field`` and ``reason`` are the first problem's; the message lists every
    problem, one ``field: reason`` line each, and ``problems`` holds them.

    Parameters
    ----------
    problems : sequence of SceneError
        Two or more (use :func:`raise_all`, which raises a single one as it is).

    Examples
    --------
    >>> exc = SceneErrors([SceneError("link2.a", "length must be >= 0, got -1.0"),
    ...                    SceneError("link3.m", "mass must be positive, got 0.0")])
    >>> print(exc)
    link2.a: length must be >= 0, got -1.0
    link3.m: mass must be positive, got 0.0
    >>> exc.field
    'link2.a'
    """

    def __init__(self, problems):
        self.problems = [p for p in problems]
        first = self.problems[0]
        super().__init__(first.field, first.reason)
        self.args = ("\n".join(str(p) for p in self.problems),)

    def __str__(self):
        return self.args[0]

    def __reduce__(self):  # sweep workers send errors back pickled
        return (type(self), (self.problems,))


def raise_all(problems) -> None:
    """Raise every problem found at once: nothing for none, one as it is, several as :class:`SceneErrors`."""
    problems = list(problems)
    if len(problems) == 1:
        raise problems[0]
    if problems:
        raise SceneErrors(problems)


class Problems:
    """Collects the refusals of independent checks, so that a scene tells every problem in one run.

    Examples
    --------
    >>> found = Problems()
    >>> with found.check():
    ...     raise SceneError("link2.a", "length must be >= 0, got -1.0")
    >>> with found.check():
    ...     raise SceneError("link4.joint", "must be 'R' or 'P', got 'X'")
    >>> [p.field for p in found]
    ['link2.a', 'link4.joint']
    """

    def __init__(self):
        self._found: list[SceneError] = []

    @contextlib.contextmanager
    def check(self):
        """A context in which a SceneError (or several) is recorded instead of raised."""
        try:
            yield
        except SceneErrors as exc:
            self._found += exc.problems
        except SceneError as exc:
            self._found.append(exc)

    def add(self, problem: SceneError) -> None:
        self._found.append(problem)

    def __iter__(self):
        return iter(self._found)

    def __len__(self):
        return len(self._found)

    def raise_all(self) -> None:
        """Raise what was recorded (see :func:`raise_all`); nothing if all went well."""
        raise_all(self._found)


class AssemblyError(SceneError):
    """The loop cannot be closed for the given dimensions or initial state.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> try:
    ...     grubler.assemble(m, [0.0, 0.0, 0.0])     # the crank held at 0: the loop cannot close
    ... except grubler.AssemblyError as e:
    ...     print(e.field, "|", e.reason[:45])
    initial | the loop cannot be closed with theta2 = 0 deg
    """


class Cancelled(GrublerError):
    """A run stopped on request (the app's cancel button) before its end: names the run and when."""

    def __init__(self, field: str, reason: str):
        self.field, self.reason = field, reason
        super().__init__(f"{field}: {reason}")

    def __reduce__(self):
        return (type(self), (self.field, self.reason))


class SystemDescriptionError(GrublerError):
    """A system description that cannot be run: names the element and the reason.

    Examples
    --------
    >>> from grubler import ssp
    >>> from grubler.errors import SystemDescriptionError
    >>> try:
    ...     ssp.from_xml("<not-an-ssd/>")
    ... except SystemDescriptionError as e:
    ...     print(e)
    SSD: the root element is not-an-ssd, not ssd:SystemStructureDescription
    """


class IntegrationError(GrublerError, RuntimeError):
    """The integrator could not continue (step-size underflow, non-finite state).

    Its message starts with the field ``integration:``, like every refusal the
    CLI prints: what failed is the run itself, at the time the reason gives.

    Examples
    --------
    >>> from grubler import IntegrationError, GrublerError
    >>> e = IntegrationError("step size underflow at t = 0.25 s")
    >>> str(e), isinstance(e, GrublerError), isinstance(e, RuntimeError)
    ('integration: step size underflow at t = 0.25 s', True, True)
    """

    field = "integration"

    def __init__(self, reason: str):
        self.reason = reason
        super().__init__(reason if reason.startswith("integration: ") else f"integration: {reason}")

    def __reduce__(self):  # sweep workers send errors back pickled
        return (type(self), (self.reason,))
