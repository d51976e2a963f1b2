"""What the tests' child processes share when they drive an FMU through fmpy.

A child process runs the FMU, writes what it measured and leaves with os._exit,
so that pythonfmu's crash at interpreter exit (upstream issue 228) cannot hide
or fake a result.
"""

from __future__ import annotations


def status(call) -> str:
    """'ok', or fmpy's message carrying the FMI status of a failed call."""
    try:
        call()
        return "ok"
    except Exception as exc:  # fmpy raises FMICallException carrying the status
        return str(exc)


def recording_callbacks(log):
    """fmpy callbacks whose logger is ``log(env, instance, status, category, message)``, for ``instantiate``.

    A native FMU copies its logger when it is instantiated (as the Reference
    FMUs do: a host may free its callback struct after fmi2Instantiate), so a
    logger is given then, not put into fmpy's struct afterwards.
    """
    from fmpy.fmi2 import defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

    return fmi2CallbackFunctions(logger=fmi2CallbackLoggerTYPE(log), allocateMemory=defaultCallbacks.allocateMemory,
                                 freeMemory=defaultCallbacks.freeMemory)


def instance(md, unzipped: str, name: str, messages: list[str], params: dict | None = None, start: float = 0.0):
    """An FMU2Slave instantiated, its parameters set by their declared type, initialised.

    The FMU's log messages are appended to ``messages`` as 'status:text'; the
    status of exitInitializationMode (as :func:`status` gives it) is kept in the
    instance's ``init_status``: a failed initialisation leaves an instance that
    refuses its steps, which the scenarios test.
    """
    from fmpy.fmi2 import FMU2Slave

    def logger(component, instance_name, level, category, message):
        messages.append(f"{level}:{message.decode()}")

    vr = {v.name: v.valueReference for v in md.modelVariables}
    types = {v.name: v.type for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=name)
    # fmpy's default logger prints; record the messages instead
    s.instantiate(loggingOn=True, callbacks=recording_callbacks(logger))
    s.setupExperiment(startTime=start)
    s.enterInitializationMode()
    for k, v in (params or {}).items():
        kind = types[k]
        if kind == "String":  # (an Enumeration is set as an Integer)
            s.setString([vr[k]], [str(v)])
        elif kind in ("Integer", "Enumeration"):
            s.setInteger([vr[k]], [int(v)])
        elif kind == "Boolean":
            s.setBoolean([vr[k]], [bool(v)])
        else:
            s.setReal([vr[k]], [float(v)])
    s.init_status = status(s.exitInitializationMode)
    return s


def report(out_path: str, result) -> None:
    """Write the child's result for the parent test, durably, and leave at once.

    ``os._exit``: the parent judges the child by this file alone, and pythonfmu's
    heap corruption at interpreter exit (upstream issue 228) must not decide the
    outcome.
    """
    import json
    import os

    with open(out_path, "w") as fh:
        json.dump({"done": True, "result": result}, fh)
        fh.flush()
        os.fsync(fh.fileno())
    os._exit(0)


def central_difference(s, ref: list[int], input_vr: int, at: float, h: float = 1e-3):
    """d(outputs ref)/d(input) by central differences of the FMU's own outputs, the input set back to ``at``.

    The outputs are affine in the efforts at a fixed state: the differences carry only rounding.
    """
    import numpy as np

    s.setReal([input_vr], [at + h])
    up = np.array(s.getReal(ref))
    s.setReal([input_vr], [at - h])
    down = np.array(s.getReal(ref))
    s.setReal([input_vr], [at])
    return (up - down) / (2 * h)
