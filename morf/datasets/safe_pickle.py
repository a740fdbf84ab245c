"""Reading the pickles that public datasets ship, without running their code.

People-Snapshot's ``camera.pkl`` / ``consensus.pkl`` and ZJU-MoCap's ``annots.npy`` /
``new_params/*.npy`` are pickles. A pickle is a program: an ordinary ``pickle.load`` (or
``np.load(allow_pickle=True)``) of a downloaded file can run any command. These files only
hold plain data -- dicts, lists, numbers, strings and numpy arrays -- so the unpickler here
resolves only the few callables that rebuild numpy arrays, dtypes and scalars and refuses
every other global (``os.system``, ``subprocess.Popen``, ``builtins.eval``, any class) with a
one-line :class:`~morf.errors.InputError` before anything is called.
"""

from __future__ import annotations

import io
import pickle
from pathlib import Path

import numpy as np

from morf.errors import InputError

try:  # numpy >= 2 keeps the reconstruction helpers in numpy._core
    from numpy._core import multiarray as _multiarray
    from numpy._core import numeric as _numeric
except ImportError:  # numpy 1.x
    from numpy.core import multiarray as _multiarray  # type: ignore[no-redef]
    from numpy.core import numeric as _numeric  # type: ignore[no-redef]

# (module, name) -> the object it resolves to. Both numpy spellings appear in the wild: files
# written by numpy 1.x name numpy.core, files written by numpy 2 name numpy._core.
_ALLOWED: dict[tuple[str, str], object] = {("numpy", "ndarray"): np.ndarray, ("numpy", "dtype"): np.dtype}
for _mod in ("numpy.core", "numpy._core"):
    _ALLOWED[(f"{_mod}.multiarray", "_reconstruct")] = _multiarray._reconstruct
    _ALLOWED[(f"{_mod}.multiarray", "scalar")] = _multiarray.scalar
    _ALLOWED[(f"{_mod}.numeric", "_frombuffer")] = _numeric._frombuffer
# Python 2 pickles store byte strings through _codecs.encode (protocol 2); the builtin
# containers below have no side effects when called.
_ALLOWED[("_codecs", "encode")] = __import__("codecs").encode
for _name, _obj in (("set", set), ("frozenset", frozenset), ("bytearray", bytearray), ("complex", complex)):
    _ALLOWED[("builtins", _name)] = _obj
    _ALLOWED[("__builtin__", _name)] = _obj  # Python 2 spelling


class RefusedPickle(pickle.UnpicklingError):
    """The pickle asked for a global outside the plain-data allow-list."""


class PlainDataUnpickler(pickle.Unpickler):
    """An unpickler that builds only plain data and numpy arrays (see the module docstring)."""

    def find_class(self, module: str, name: str):
        try:
            return _ALLOWED[(module, name)]
        except KeyError:
            raise RefusedPickle(f"{module}.{name}") from None

    def persistent_load(self, pid):
        raise RefusedPickle(f"persistent id {pid!r}")


def loads_plain(data: bytes, what: str = "pickle") -> object:
    """Unpickle ``data`` (bytes) allowing plain data only; ``what`` names it in errors."""
    return _load(io.BytesIO(data), what)


def load_plain_pickle(path: str | Path) -> object:
    """Read a ``.pkl`` file holding plain data (dicts, lists, numbers, strings, numpy arrays).

    Python 2 pickles (People-Snapshot) are read with ``encoding="latin1"``, which numpy
    needs to restore their array buffers. Raises InputError naming the file when it is
    missing, damaged, or asks for anything else.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"file not found: {path}")
    with open(path, "rb") as f:
        return _load(f, str(path))


def load_npy(path: str | Path) -> np.ndarray:
    """Read a ``.npy`` file; an object array (a pickled payload) is rebuilt plain-data-only.

    ``np.save`` of a dict (ZJU-MoCap's ``annots.npy``) writes a 0-d object array whose
    payload is a pickle; ``.item()`` of the result gives the dict back.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"file not found: {path}")
    fmt = np.lib.format
    try:
        with open(path, "rb") as f:
            version = fmt.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = fmt.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, fortran, dtype = fmt.read_array_header_2_0(f)
            else:
                shape, fortran, dtype = fmt._read_array_header(f, version)
            if not dtype.hasobject:
                return np.load(path, allow_pickle=False)
            arr = _load(f, str(path))
    except (ValueError, OSError, EOFError) as e:
        raise InputError(f"not a readable .npy file: {path} ({e})") from None
    if not isinstance(arr, np.ndarray) or arr.shape != tuple(shape):
        raise InputError(f"damaged .npy file: {path} (payload does not match its header)")
    return arr


def _load(f, what: str) -> object:
    try:
        return PlainDataUnpickler(f, encoding="latin1").load()
    except RefusedPickle as e:
        raise InputError(f"refused to load {what}: it asks for {e}, which is not plain data "
                         f"(only dicts, lists, numbers, strings and numpy arrays are accepted)") from None
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError, IndexError,
            KeyError, MemoryError, UnicodeDecodeError, OverflowError) as e:
        raise InputError(f"not a readable pickle: {what} ({type(e).__name__}: {e})") from None
