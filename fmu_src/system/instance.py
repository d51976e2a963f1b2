"""The FMUs of a co-simulation: unpacked once, described, instantiated and wired to the master's buffers.

:class:`UnpackedFMUs` keeps each FMU unpacked for as many runs as share it;
:func:`interfaces_of` reads what each component's FMU declares; an instance
holds one FMU with the preallocated buffers the C loop reads and writes, and
turns a refused call into a :class:`CosimError` with the FMU's own message.

Examples
--------
>>> from grubler.errors import GrublerError
>>> issubclass(CosimError, GrublerError)
True
"""

from __future__ import annotations

import ctypes
import os
import threading
from pathlib import Path


from grubler.errors import GrublerError, InputError
from grubler.limits import brief, clip, extract_zip, remove_temp_dir, temp_dir
from grubler.system.interface import FmuInterface
from grubler.system.plan import check
from grubler.system.ssp import System, SystemDescriptionError


class CosimError(GrublerError):
    """A co-simulation that failed while running: names the component and time.

    Examples
    --------
    >>> from grubler.errors import GrublerError
    >>> issubclass(CosimError, GrublerError)    # the CLI reports it in one line, as every grubler error
    True
    """


_STATUS = {2: "discard", 3: "error", 4: "fatal", 5: "pending"}


class _Instance:
    """One instantiated FMU with the master's preallocated buffers."""

    def __init__(self, name, itf: FmuInterface, unzipdir: str, start_time: float):
        from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

        md = itf.model_description
        self.name, self.itf, self.messages = name, itf, []
        cwd = os.getcwd()
        try:
            self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                                 modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        except Exception as exc:  # noqa: BLE001 - fmpy wraps the loader's OSError in a bare Exception
            os.chdir(cwd)  # fmpy loads from the binary's folder and stays there when that fails
            # the loader's own words (e.g. 'wrong ELF class: ELFCLASS32'), after the extraction's path
            why = str(exc.__context__ if isinstance(exc.__context__, OSError) else exc)
            why = why.rpartition(f"{Path(unzipdir).name}/binaries/")[2].partition(": ")[2] or why
            raise CosimError(f"{name}: the binary of {itf.path.name} cannot be loaded: {clip(why)}") from None

        def logger(component, instance_name, status, category, message):
            self.messages.append(f"{name}: {message.decode(errors='replace')}")

        # callbacks of its own, from instantiation on: an FMU keeps the pointer it is given
        # (fmpy's default struct is shared by every instance), and what it logs while it is
        # instantiated says why it could not be
        self._logger = fmi2CallbackLoggerTYPE(logger)  # keep a reference: C holds the pointer
        self._callbacks = fmi2CallbackFunctions(logger=self._logger, allocateMemory=defaultCallbacks.allocateMemory,
                                                freeMemory=defaultCallbacks.freeMemory)
        try:
            self.fmu.instantiate(loggingOn=True, callbacks=self._callbacks)
        except Exception:  # noqa: BLE001 - fmpy says only "Failed to instantiate model"
            raise CosimError(f"{name}: {itf.path.name} could not be instantiated" + _last_message(self)) from None
        try:
            self.fmu.setupExperiment(startTime=start_time)
        except Exception:  # noqa: BLE001 - fmpy raises FMICallException carrying the status
            # freed here: the caller never holds this instance, and the FMU keeps pointers to its callbacks,
            # which go with it (an FMU wrapped by pythonfmu's, controllers/status_wrapper.c, keeps the struct's)
            self.free()
            raise CosimError(f"{name}: setupExperiment at t = {start_time:g} s failed" + _last_message(self)) from None
        self.bind_calls()

    def set_parameters(self, params: dict):
        f, ports = self.fmu, self.itf.ports
        for p, v in params.items():
            port = ports[p]
            if port.type == "Real":
                f.setReal([port.vr], [float(v)])
            elif port.type in ("Integer", "Enumeration"):
                f.setInteger([port.vr], [int(v)])
            elif port.type == "Boolean":
                f.setBoolean([port.vr], [bool(v)])
            else:
                f.setString([port.vr], [str(v)])

    def wire(self, inputs: list[tuple[int, int]], outputs: list[tuple[int, int]], recorded: list[int]):
        """Inputs and connected outputs as (value reference, slot), the recorded value references."""
        n = len(inputs)
        self.in_vr = (ctypes.c_uint * n)(*[vr for vr, _ in inputs])
        self.in_slot = (ctypes.c_int * n)(*[s for _, s in inputs])
        self.in_buf = (ctypes.c_double * n)()
        self.n_in = n
        conn = [vr for vr, _ in outputs]
        self.out_slots = (ctypes.c_int * len(outputs))(*[s for _, s in outputs])
        reads = list(dict.fromkeys(conn + recorded))  # connected first, then the rest recorded
        self.read_vr = (ctypes.c_uint * len(reads))(*reads)
        self.read_buf = (ctypes.c_double * len(reads))()
        self.n_read = len(reads)
        self.n_conn = len(outputs)
        self.conn_vr = (ctypes.c_uint * len(outputs))(*conn)

    def bind_calls(self) -> None:
        """The FMU's C functions themselves: fmpy's wrappers cost more than a step here."""
        # the library's own function objects (ctypes keeps one per name), to which
        # fmpy gave their argument types: every fmpy since 0.3.20 does
        dll = self.fmu.dll
        self._c = self.fmu.component
        self._set, self._get, self._step = dll.fmi2SetReal, dll.fmi2GetReal, dll.fmi2DoStep

    def push(self, values: list[float]) -> None:
        if self.n_in:
            buf = self.in_buf
            for i, s in enumerate(self.in_slot):
                buf[i] = values[s]
            self._check(self._set(self._c, self.in_vr, self.n_in, buf), "fmi2SetReal")

    def pull(self, everything: bool) -> ctypes.Array:
        n = self.n_read if everything else self.n_conn
        if n:
            self._check(self._get(self._c, self.read_vr if everything else self.conn_vr, n, self.read_buf),
                        "fmi2GetReal")
        return self.read_buf

    def publish(self, values: list[float], everything: bool = False) -> None:
        """Read the outputs (and, with ``everything``, the recorded ones) into the connection slots."""
        buf = self.pull(everything)
        for i, s in enumerate(self.out_slots):
            values[s] = buf[i]

    def _check(self, status: int, what: str) -> None:
        if status > 1:
            raise self.refused(what, status)

    def refused(self, what: str, status: int) -> CosimError:
        """The error of a call this FMU refused, with the last message it logged."""
        return CosimError(f"{self.name}: {what} failed (status {_STATUS.get(status, status)})" + _last_message(self))

    def loop_view(self, seconds: int | None, in_mode=None, sampled: bool = False,
                  rollback: bool = False) -> "binding.MasterFmu":
        """This instance as the C stepping loop sees it (``seconds``: where it sums its call times, or None;
        ``in_mode``: the extrapolating master's mode of each input, a ctypes int array, or None; ``sampled``:
        the adaptive master steps it once per communication step; ``rollback``: its FMU state calls, which the
        adaptive master needs of every other FMU)."""
        from grubler import binding

        def at(fn) -> int:
            return ctypes.cast(fn, ctypes.c_void_p).value

        return binding.MasterFmu(self._c, at(self._set), at(self._get), at(self._step), self.n_in,
                                 ctypes.addressof(self.in_vr), ctypes.addressof(self.in_slot),
                                 ctypes.addressof(self.in_buf), self.n_conn, self.n_read,
                                 ctypes.addressof(self.read_vr), ctypes.addressof(self.read_buf),
                                 ctypes.addressof(self.out_slots), seconds,
                                 None if in_mode is None else ctypes.addressof(in_mode), int(sampled),
                                 *((at(self.fmu.dll.fmi2GetFMUstate), at(self.fmu.dll.fmi2SetFMUstate),
                                    at(self.fmu.dll.fmi2FreeFMUstate)) if rollback else (None, None, None)), None)

    def free(self):
        for call in (self.fmu.terminate, self.fmu.freeInstance):
            try:
                call()
            except Exception:  # noqa: BLE001 - freeing must go on for the others
                pass


class UnpackedFMUs:
    """FMUs unpacked once and kept for the runs that follow (an app that re-runs one system).

    A run given one reuses an FMU's folder while the file is unchanged (its
    size and modification time), and unpacks it again when it changed;
    :meth:`close` removes every folder. Threads may share one.

    Examples
    --------
    >>> with UnpackedFMUs() as unpacked:
    ...     pass        # cosim.run(system, unpacked=unpacked), as often as wanted
    """

    def __init__(self):
        self._folders: dict[Path, tuple[tuple[int, int], Path]] = {}
        self._old: list[Path] = []  # replaced folders: a run may still use one, so they go at close
        self._lock = threading.Lock()

    def folder(self, path: Path, field: str, where: str) -> Path:
        """The folder holding the FMU at ``path`` unpacked (refusals name ``field``)."""
        st = path.stat()
        stamp = (st.st_size, st.st_mtime_ns)
        with self._lock:
            hit = self._folders.get(path)
        if hit is not None and hit[0] == stamp:
            return hit[1]
        folder = temp_dir("grubler_fmu_")
        extract_zip(path, folder, field, where=where)
        with self._lock:
            old = self._folders.get(path)
            self._folders[path] = (stamp, folder)
            if old is not None:
                self._old.append(old[1])
        return folder

    def __getitem__(self, path: Path) -> Path:
        return self._folders[path][1]

    def close(self) -> None:
        """Remove every folder."""
        with self._lock:
            folders = [f for _, f in self._folders.values()] + self._old
            self._folders, self._old = {}, []
        for f in folders:
            remove_temp_dir(f)

    def __enter__(self) -> "UnpackedFMUs":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def interfaces_of(system: System, unzipped: "UnpackedFMUs") -> dict[str, FmuInterface]:
    """Every component's interface, its FMU unpacked in ``unzipped``, once the system is checked.

    Raises
    ------
    SystemDescriptionError
        Naming every problem :func:`check` finds, and every FMU that is missing or unreadable.

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.system.ssp import System
    >>> from grubler.controllers.native_fmu import pid_spec, trajectory_spec
    >>> from grubler.fmi.description import model_description
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> for spec in (pid_spec("PID"), trajectory_spec("Trajectory")):  # a model description is all a check reads
    ...     with zipfile.ZipFile(d / f"{spec.identifier}.fmu", "w") as z:
    ...         z.writestr("modelDescription.xml", model_description(spec, []))
    >>> s = System("follow", base=d)
    >>> _ = s.add("pid", "PID.fmu", K=2.0, Ts=0.01)
    >>> _ = s.add("move", "Trajectory.fmu", kind="trapezoid")
    >>> _ = s.connect("move.position", "pid.setpoint")
    >>> with UnpackedFMUs() as unpacked:
    ...     itf = interfaces_of(s, unpacked)
    >>> itf["pid"].ports["Ts"].unit, itf["move"].ports["position"].causality
    ('s', 'output')
    >>> _ = s.add("motor", "DCMotor.fmu")
    >>> with UnpackedFMUs() as unpacked:
    ...     interfaces_of(s, unpacked)                  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    grubler.errors.SystemDescriptionError: system 'follow': cannot run, 1 problem:
      component motor: FMU .../DCMotor.fmu not found (run python build_fmu.py?)
    >>> tmp.cleanup()
    """
    interfaces = {}
    problems = []
    for name, comp in system.components.items():
        path = system.source_path(comp)
        if not path.is_file():
            problems.append(f"component {name}: FMU {clip(str(path), 240)} not found (run python build_fmu.py?)")
            continue
        try:
            folder = unzipped.folder(path, f"component {name}", clip(comp.source))
            if not (folder / "modelDescription.xml").is_file():
                problems.append(f"component {name}: {clip(comp.source)} is not an FMU (no modelDescription.xml)")
                continue
            itf = FmuInterface.of(path, folder)
            if itf.model_description.fmiVersion != "2.0":
                problems.append(f"component {name}: {brief(path.name)} is an FMI {itf.model_description.fmiVersion} "
                                "FMU; this master runs FMI 2.0 co-simulation FMUs (build it as FMI 2.0)")
                continue
            interfaces[name] = itf
        except InputError as exc:
            problems.append(f"component {name}: cannot read {exc.reason}")
        except Exception as exc:  # noqa: BLE001 - a broken FMU is one of the problems listed
            problems.append(f"component {name}: cannot read {brief(path.name)}: {clip(str(exc), 200)}")
    problems += check(system, interfaces)
    if problems:
        raise SystemDescriptionError(f"system {brief(system.name)}: cannot run, {len(problems)} "
                                     f"problem{'s' if len(problems) > 1 else ''}:\n  " + "\n  ".join(problems))
    return interfaces


def _call(inst: _Instance, what: str, fn, t: float):
    try:
        return fn()
    except GrublerError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise CosimError(f"{inst.name}: {what} failed at t = {t:g} s ({exc})" + _last_message(inst)) from None


def _last_message(inst: _Instance) -> str:
    return f": {inst.messages[-1]}" if inst.messages else ""


__all__ = ["CosimError", "UnpackedFMUs", "interfaces_of"]
