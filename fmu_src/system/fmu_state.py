"""A serialised FMU state: a versioned plain byte layout, checked on the way in.

What fmi2SerializeFMUstate hands an importer, and what fmi2DeSerializeFMUstate
takes back from it, for every pythonfmu slave of the project.  Nothing in a blob
is ever unpickled or evaluated: the body is JSON whose values are tagged plain
data, decoded by a fixed set of rules, so a crafted blob can at worst be refused.

Layout (all integers little-endian)::

    magic    8 bytes   b"GRBSTATE"
    version  u32       FORMAT_VERSION
    length   u64       number of body bytes
    body     JSON, UTF-8: {"identity": {...}, "state": <tagged value>}
    digest   32 bytes  SHA-256 of everything before it

The identity names the FMU (model name, a digest of the code it runs, a
digest of its parameter values): a state from another FMU, another build or an
instance with other parameters is refused by :meth:`SlaveState.check`.

Values the state may hold (anything else is refused when the state is taken,
naming where it sits): None, bool, int, float (bit-exact: NaN payloads and -0.0
included), str, list, tuple, dict, collections.deque, numpy arrays of numbers
or booleans and numpy scalars (bit-exact, dtype and shape kept) and numpy
random Generators (their bit generator's state, so noise replays exactly).

Examples
--------
>>> import numpy as np
>>> ident = {"model": "Gain", "build": "b1", "parameters": "p1"}
>>> blob = to_bytes(SlaveState(ident, {"x": np.arange(3.0), "n": 2}))
>>> back = from_bytes(blob)
>>> back.check(ident), back.payload["x"].tolist(), back.payload["n"]
(None, [0.0, 1.0, 2.0], 2)
>>> bad = bytearray(blob); bad[30] ^= 1
>>> try:
...     from_bytes(bytes(bad))
... except StateError as exc:
...     print(exc)
state blob: corrupted (its SHA-256 digest does not match its content)

A blob starts with :data:`MAGIC` and :data:`FORMAT_VERSION`:

>>> blob[:8] == MAGIC, int.from_bytes(blob[8:12], "little") == FORMAT_VERSION
(True, True)
"""

from __future__ import annotations

import base64
import collections
import hashlib
import json
import math
import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

MAGIC = b"GRBSTATE"
FORMAT_VERSION = 1
_HEAD = struct.Struct("<8sIQ")
_DIGEST = 32
# a state blob is a few kilobytes; a length beyond this is a crafted header, not a state
MAX_BODY = 256 * 1024 * 1024
# nesting deeper than this is not a slave's state (and would exhaust the stack)
MAX_DEPTH = 64
# bit generators whose state numpy documents as plain data (ints, arrays, dicts)
_BIT_GENERATORS = ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")


class StateError(ValueError):
    """A state that cannot be serialised, or a blob that is refused.

    Examples
    --------
    >>> try:
    ...     from_bytes(b"GRBSTATE")
    ... except StateError as exc:                     # a ValueError: an FMU answers it with fmi2Error
    ...     print(exc)
    state blob: truncated (8 bytes, a state has at least 52)
    """


@dataclass(frozen=True)
class SlaveState:
    """An FMU state: who took it, and the slave's own payload.

    Examples
    --------
    >>> ident = {"model": "Gain", "build": "b1", "parameters": "p1"}
    >>> state = SlaveState(ident, {"k": 2.0})
    >>> state.check(ident) is None                    # taken from this FMU, this build, these parameters
    True
    >>> try:
    ...     state.check({**ident, "parameters": "p2"})
    ... except StateError as exc:
    ...     print(exc)
    state blob: taken from an instance with other parameter values (parameters 'p1', this instance has 'p2')
    """

    identity: dict
    payload: Any

    def check(self, identity: dict) -> None:
        """None, or StateError saying how this state's identity differs from ``identity``."""
        for key, what in (("model", "another FMU"), ("build", "another build of this FMU"),
                          ("parameters", "an instance with other parameter values")):
            if self.identity.get(key) != identity.get(key):
                raise StateError(f"state blob: taken from {what} ({key} {self.identity.get(key)!r}, "
                                 f"this instance has {identity.get(key)!r})")


# -- encoding ---------------------------------------------------------------------
def _f64(v: float) -> str:
    return struct.pack("<d", v).hex()


def _encode(value: Any, where: str, depth: int = 0) -> Any:
    if depth > MAX_DEPTH:
        raise StateError(f"state {where}: nested deeper than {MAX_DEPTH}")
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.generic):  # before int/float: np.float64 is a float
        if value.dtype.kind not in "biufc":
            raise StateError(f"state {where}: numpy scalar of dtype {value.dtype} cannot be serialised")
        return {"npscalar": value.dtype.str, "data": value.tobytes().hex()}
    if isinstance(value, int):
        return {"int": str(value)}
    if isinstance(value, float):
        return {"float": _f64(value)}
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biufc":
            raise StateError(f"state {where}: array of dtype {value.dtype} cannot be serialised "
                             "(numbers and booleans only)")
        data = np.ascontiguousarray(value).tobytes()
        return {"ndarray": value.dtype.str, "shape": list(value.shape),
                "data": base64.b64encode(data).decode("ascii")}
    if isinstance(value, np.random.Generator):
        bg = value.bit_generator
        name = type(bg).__name__
        if name not in _BIT_GENERATORS:
            raise StateError(f"state {where}: random generator {name} cannot be serialised")
        return {"generator": name, "state": _encode(bg.state, f"{where}.bit_generator", depth + 1)}
    if isinstance(value, collections.deque):
        return {"deque": [_encode(v, f"{where}[{k}]", depth + 1) for k, v in enumerate(value)],
                "maxlen": value.maxlen}
    if isinstance(value, (list, tuple)):
        items = [_encode(v, f"{where}[{k}]", depth + 1) for k, v in enumerate(value)]
        return {"list": items} if isinstance(value, list) else {"tuple": items}
    if isinstance(value, dict):
        return {"dict": [[_encode(k, f"{where} key", depth + 1), _encode(v, f"{where}[{k!r}]", depth + 1)]
                         for k, v in value.items()]}
    raise StateError(f"state {where}: a {type(value).__name__} cannot be serialised "
                     "(override get_state to return plain data)")


def to_bytes(state: SlaveState) -> bytes:
    """The blob of ``state`` (StateError naming any value that cannot be serialised).

    Examples
    --------
    >>> ident = {"model": "Gain", "build": "b1", "parameters": "p1"}
    >>> to_bytes(SlaveState(ident, {"k": 2.0}))[:8]
    b'GRBSTATE'
    >>> try:
    ...     to_bytes(SlaveState(ident, {"f": open}))
    ... except StateError as exc:
    ...     print(exc)
    state ['f']: a builtin_function_or_method cannot be serialised (override get_state to return plain data)
    """
    body = json.dumps({"identity": state.identity, "state": _encode(state.payload, "")},
                      separators=(",", ":"), allow_nan=False).encode("utf-8")
    head = _HEAD.pack(MAGIC, FORMAT_VERSION, len(body)) + body
    return head + hashlib.sha256(head).digest()


# -- decoding ---------------------------------------------------------------------
def _need(cond: bool, where: str, what: str) -> None:
    if not cond:
        raise StateError(f"state blob: {where or 'state'}: {what}")


def _decode(node: Any, where: str, depth: int = 0) -> Any:
    _need(depth <= MAX_DEPTH, where, f"nested deeper than {MAX_DEPTH}")
    if node is None or isinstance(node, (bool, str)):
        return node
    _need(isinstance(node, dict) and len(node) >= 1, where, f"unexpected {type(node).__name__}")
    tag = next(iter(node))
    try:
        if tag == "int" and len(node) == 1:
            _need(isinstance(node["int"], str) and len(node["int"]) <= 4300, where, "bad integer")
            return int(node["int"])
        if tag == "float" and len(node) == 1:
            return struct.unpack("<d", bytes.fromhex(node["float"]))[0]
        if tag == "npscalar" and set(node) == {"npscalar", "data"}:
            dtype = _dtype(node["npscalar"], where)
            data = bytes.fromhex(node["data"])
            _need(len(data) == dtype.itemsize, where, "scalar of the wrong size")
            return np.frombuffer(data, dtype=dtype)[0]
        if tag == "ndarray" and set(node) == {"ndarray", "shape", "data"}:
            dtype = _dtype(node["ndarray"], where)
            shape = node["shape"]
            _need(isinstance(shape, list) and len(shape) <= 32
                  and all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in shape),
                  where, "bad array shape")
            data = base64.b64decode(node["data"], validate=True)
            _need(len(data) == math.prod(shape) * dtype.itemsize, where,
                  f"array data of {len(data)} bytes for shape {shape} of {dtype}")
            return np.frombuffer(data, dtype=dtype).reshape(shape).copy()
        if tag == "generator" and set(node) == {"generator", "state"}:
            name = node["generator"]
            _need(name in _BIT_GENERATORS, where, f"unknown bit generator {name!r}")
            bg = getattr(np.random, name)()
            bg.state = _decode(node["state"], f"{where}.bit_generator", depth + 1)
            return np.random.Generator(bg)
        if tag == "deque" and set(node) == {"deque", "maxlen"}:
            maxlen = node["maxlen"]
            _need(maxlen is None or (isinstance(maxlen, int) and not isinstance(maxlen, bool) and maxlen >= 0),
                  where, "bad deque length")
            items = _items(node["deque"], where, depth)
            _need(maxlen is None or len(items) <= maxlen, where, "deque longer than its maxlen")
            return collections.deque(items, maxlen=maxlen)
        if tag in ("list", "tuple") and len(node) == 1:
            items = _items(node[tag], where, depth)
            return items if tag == "list" else tuple(items)
        if tag == "dict" and len(node) == 1:
            pairs = node["dict"]
            _need(isinstance(pairs, list) and all(isinstance(p, list) and len(p) == 2 for p in pairs),
                  where, "bad dict")
            out = {}
            for k, v in pairs:
                key = _decode(k, f"{where} key", depth + 1)
                _need(isinstance(key, (str, int, float, bool, tuple)) or key is None, where, "unhashable key")
                out[key] = _decode(v, f"{where}[{key!r}]", depth + 1)
            return out
    except StateError:
        raise
    except (TypeError, ValueError, KeyError, OverflowError, struct.error) as exc:
        raise StateError(f"state blob: {where or 'state'}: bad {tag}: {exc}") from None
    raise StateError(f"state blob: {where or 'state'}: unknown value tag {tag!r}")


def _items(seq: Any, where: str, depth: int) -> list:
    _need(isinstance(seq, list), where, "bad sequence")
    return [_decode(v, f"{where}[{k}]", depth + 1) for k, v in enumerate(seq)]


def _dtype(text: Any, where: str) -> np.dtype:
    _need(isinstance(text, str) and len(text) <= 8, where, "bad dtype")
    try:
        dtype = np.dtype(text)
    except TypeError:
        raise StateError(f"state blob: {where or 'state'}: unknown dtype {text!r}") from None
    _need(dtype.kind in "biufc" and not dtype.hasobject, where, f"dtype {text!r} is not a number type")
    return dtype


def from_bytes(blob: bytes) -> SlaveState:
    """The state in ``blob``, or StateError saying why it is refused (truncated, corrupted, foreign...).

    Examples
    --------
    >>> ident = {"model": "Gain", "build": "b1", "parameters": "p1"}
    >>> blob = to_bytes(SlaveState(ident, {"k": 2.0, "history": (1, -0.0)}))
    >>> from_bytes(blob).payload                      # bit-exact, tuples and -0.0 kept
    {'k': 2.0, 'history': (1, -0.0)}
    >>> try:
    ...     from_bytes(blob[:20])
    ... except StateError as exc:
    ...     print(exc)
    state blob: truncated (20 bytes, a state has at least 52)
    """
    blob = bytes(blob)
    if len(blob) < _HEAD.size + _DIGEST:
        raise StateError(f"state blob: truncated ({len(blob)} bytes, a state has at least "
                         f"{_HEAD.size + _DIGEST})")
    magic, version, length = _HEAD.unpack_from(blob)
    if magic != MAGIC:
        raise StateError(f"state blob: not a grubler FMU state (starts with {blob[:8]!r}, expected {MAGIC!r})")
    if version != FORMAT_VERSION:
        raise StateError(f"state blob: format version {version}, this FMU reads version {FORMAT_VERSION}")
    if length > MAX_BODY or _HEAD.size + length + _DIGEST != len(blob):
        raise StateError(f"state blob: truncated or padded (header says {length} body bytes, "
                         f"the blob holds {len(blob) - _HEAD.size - _DIGEST})")
    if hashlib.sha256(blob[:-_DIGEST]).digest() != blob[-_DIGEST:]:
        raise StateError("state blob: corrupted (its SHA-256 digest does not match its content)")
    try:
        doc = json.loads(blob[_HEAD.size:-_DIGEST].decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise StateError(f"state blob: body is not JSON ({type(exc).__name__})") from None
    _need(isinstance(doc, dict) and set(doc) == {"identity", "state"}, "", "bad body")
    identity = doc["identity"]
    _need(isinstance(identity, dict) and all(isinstance(v, str) for v in identity.values()), "identity", "bad")
    return SlaveState(identity, _decode(doc["state"], ""))


__all__ = ["FORMAT_VERSION", "MAGIC", "SlaveState", "StateError", "from_bytes", "to_bytes"]
