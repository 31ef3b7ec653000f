"""A digest of what a callable computes, for keys of stored results (the score cache).

A metric is keyed by its definition, not its name: the bytecode and constants of its
function (and of every function nested in it), its default arguments, the values its closure
holds, the values of the globals it reads (module constants, other functions, recursively),
and for a ``functools.partial`` or a callable object the arguments or attributes it carries.
Changing any of them (``2.0`` to ``1.0`` in a miss rate, a threshold passed to
``partial``, a helper it calls) changes the digest; moving a function within its file or
editing a comment does not. What cannot be read (a C function) is keyed by its qualified
name.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import re
import types
from collections.abc import Callable, Collection, Mapping

import numpy as np

_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")
_MAX_DEPTH = 12
"""How deep globals and attributes are followed (a cycle is cut where it closes)."""


def definition_digest(value: object) -> str:
    """SHA256 (hex) of what ``value`` (a function, partial, callable object or plain value)
    computes, as described in the module docstring."""
    digest = hashlib.sha256()
    _feed(digest, value, {}, 0)  # one memo: a value met again is named, not fed again
    return digest.hexdigest()


def _feed(digest: hashlib._Hash, value: object, seen: dict[int, object], depth: int) -> None:
    """Add ``value`` to ``digest``: its kind, then what defines it."""
    if _feed_plain(digest, value):
        return
    if id(value) in seen or depth > _MAX_DEPTH:
        digest.update(f"ref:{_qualified(value)};".encode())
        return
    seen[id(value)] = value  # kept alive, so that its id is not reused by another value
    if isinstance(value, types.ModuleType):
        digest.update(f"module:{value.__name__};".encode())
    elif isinstance(value, list | tuple | set | frozenset | Mapping):
        _feed_collection(digest, value, seen, depth)
    elif isinstance(value, functools.partial):
        digest.update(b"partial:")
        _feed(digest, (value.func, value.args, value.keywords), seen, depth + 1)
    elif isinstance(value, types.MethodType):
        digest.update(b"method:")
        _feed(digest, (value.__func__, value.__self__), seen, depth + 1)
    elif isinstance(value, types.FunctionType):
        _feed_function(digest, value, seen, depth)
    elif isinstance(value, types.CodeType):
        _feed_code(digest, value, seen, depth)
    elif isinstance(value, type):
        digest.update(f"class:{_qualified(value)};".encode())
        call = value.__dict__.get("__call__")
        if isinstance(call, types.FunctionType):
            _feed_function(digest, call, seen, depth + 1)
    elif isinstance(value, types.BuiltinFunctionType | np.ufunc) or not _has_state(value):
        digest.update(f"opaque:{_qualified(value)}:{_ADDRESS.sub('', repr(value))};".encode())
    else:  # an object: its class (and ``__call__``) and its attributes
        _feed(digest, type(value), seen, depth + 1)
        _feed(digest, _state(value), seen, depth + 1)


def _feed_plain(digest: hashlib._Hash, value: object) -> bool:
    """Add a scalar, string or array by value; False for anything else."""
    if value is None or isinstance(value, bool | int | float | complex | str | bytes):
        digest.update(f"{type(value).__name__}:{value!r};".encode())
        return True
    if isinstance(value, np.ndarray | np.generic):
        array = np.asarray(value)
        digest.update(f"ndarray:{array.dtype.str}:{array.shape};".encode())
        plain = array.dtype != object
        digest.update(np.ascontiguousarray(array).tobytes() if plain else repr(array).encode())
        return True
    return False


def _feed_collection(
    digest: hashlib._Hash,
    value: Collection[object] | Mapping[object, object],
    seen: dict[int, object],
    depth: int,
) -> None:
    """A sequence in order; a set or mapping sorted by its keys' text."""
    if isinstance(value, Mapping):
        digest.update(f"mapping[{len(value)}]:".encode())
        for key in sorted(value, key=repr):
            _feed(digest, key, seen, depth + 1)
            _feed(digest, value[key], seen, depth + 1)
        return
    items = sorted(value, key=repr) if isinstance(value, set | frozenset) else list(value)
    digest.update(f"{type(value).__name__}[{len(items)}]:".encode())
    for item in items:
        _feed(digest, item, seen, depth + 1)


def _feed_function(
    digest: hashlib._Hash, function: types.FunctionType, seen: dict[int, object], depth: int
) -> None:
    """A Python function: its code, defaults, closure values and the globals it reads."""
    digest.update(f"function:{function.__qualname__};".encode())
    _feed_code(digest, function.__code__, seen, depth)
    _feed(digest, (function.__defaults__, function.__kwdefaults__), seen, depth + 1)
    cells = [_cell_value(cell) for cell in function.__closure__ or ()]
    _feed(digest, cells, seen, depth + 1)
    read = {
        name: function.__globals__[name]
        for name in sorted(_global_names(function.__code__))
        if name in function.__globals__
    }
    _feed(digest, read, seen, depth + 1)


def _feed_code(
    digest: hashlib._Hash, code: types.CodeType, seen: dict[int, object], depth: int
) -> None:
    """Bytecode, constants (nested functions' code too) and names; not line numbers."""
    digest.update(b"code:" + code.co_code)
    digest.update(repr((code.co_names, code.co_argcount, code.co_kwonlyargcount)).encode())
    _feed(digest, code.co_consts, seen, depth + 1)


def _global_names(code: types.CodeType) -> set[str]:
    """The names a code object (and the code nested in it) may read as globals."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _global_names(const)
    return names


def _cell_value(cell: types.CellType) -> object:
    try:
        return cell.cell_contents
    except ValueError:  # an empty cell (a name assigned later)
        return "<empty cell>"


def _has_state(value: object) -> bool:
    """Whether an object carries attributes that may define what it computes."""
    return dataclasses.is_dataclass(value) or hasattr(value, "__dict__") or _slots(value) != ()


def _slots(value: object) -> tuple[str, ...]:
    return tuple(
        name for cls in type(value).__mro__ for name in getattr(cls, "__slots__", ()) or ()
    )


def _state(value: object) -> dict[str, object]:
    """An object's attributes by name (``__dict__`` and ``__slots__``)."""
    found = dict(getattr(value, "__dict__", {}))
    for name in _slots(value):
        if hasattr(value, name):
            found[name] = getattr(value, name)
    return found


def _qualified(value: object) -> str:
    """``module.qualname`` of a function or class, else of the value's type."""
    named: Callable[..., object] | type = value if callable(value) else type(value)
    module = getattr(named, "__module__", None) or ""
    name = getattr(named, "__qualname__", None) or getattr(named, "__name__", None) or ""
    return f"{module}.{name}"
