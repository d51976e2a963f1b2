"""What every pythonfmu slave of the project shares: declared output dependencies,
errors logged instead of raised, its whole state pickled for rollback, and a
balanced reference count on the slave script's namespace.

pythonfmu writes every output as depending on every input, which makes any
feedback loop through the FMU look algebraic to a master.  A slave that knows
better says so in :meth:`DeclaredDependencies.feedthrough` (output -> the inputs
it depends on at the same instant; an output it leaves out is a state), and its
model description's ModelStructure carries it.
"""

from __future__ import annotations

import pickle

from pythonfmu import Fmi2Slave
from pythonfmu.enums import Fmi2Status


class DeclaredDependencies(Fmi2Slave):
    """A pythonfmu slave whose model description declares its outputs' dependencies."""

    def feedthrough(self) -> dict[str, list[str]]:
        """Output -> inputs it depends on at the same instant (default: none)."""
        return {}

    def to_xml(self, model_options=None):
        root = super().to_xml(model_options if model_options is not None else {})
        variables = root.findall("ModelVariables/ScalarVariable")
        index = {v.get("name"): str(k + 1) for k, v in enumerate(variables)}
        feed = self.feedthrough()
        for unknown in root.findall("ModelStructure/Outputs/Unknown"):
            deps = [index[i] for i in feed.get(variables[int(unknown.get("index")) - 1].get("name"), [])]
            unknown.set("dependencies", " ".join(deps))
            if deps:
                unknown.set("dependenciesKind", " ".join(["dependent"] * len(deps)))
        return root


class ProjectSlave(DeclaredDependencies):
    """The base of the project's slaves.

    A failure is recorded in ``_error`` and logged as fmi2Error, never raised into
    the importer; the start time is kept in ``_start_time``; a slave's own
    ``_get_fmu_state`` returns everything a rollback needs (pythonfmu's default
    holds only the registered variables), and it is serialised with pickle
    (pythonfmu's default, JSON, takes no arrays or tuples).
    """

    _error: str | None = None
    _start_time: float = 0.0

    def _fail(self, msg: str) -> None:
        self._error = msg
        self.log(msg, Fmi2Status.error)

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._start_time = float(start_time or 0.0)

    @staticmethod
    def _fmu_state_to_bytes(state) -> bytes:
        return pickle.dumps(state)

    @staticmethod
    def _fmu_state_from_bytes(state: bytes):
        return pickle.loads(state)


def balance_loader_reference(namespace: dict) -> None:
    """Take the reference to a slave script's namespace that pythonfmu 0.7 gives back.

    pythonfmu 0.7's loader executes the slave script at every instantiation in
    the module's namespace and then releases a reference to that namespace it
    never took.  A script whose namespace few objects refer to (a thin slave) is
    freed under the loader by the second instance (a segfault in
    fmi2Instantiate); a larger one is merely left with a count that is too low.
    Every slave script calls this once per execution: one reference taken for
    the one released.
    """
    namespace.setdefault("_loader_references", []).append(namespace)


__all__ = ["DeclaredDependencies", "ProjectSlave", "balance_loader_reference"]
