"""Another run's folder read as input: every file and field read back is checked strictly, in one place.

A folder given as input (``--workspace DIR``, a study resumed in its ``--out``) was written by another run and may
have been edited since. :class:`RunFolder` reads it:

- **Files** (:meth:`RunFolder.read_bytes`, :meth:`RunFolder.read_json`, :meth:`RunFolder.read_npz`): named by a
  relative path that stays inside the folder (no absolute path, no ``..``, no link leading out of it), a regular
  file (a FIFO never blocks, a link put there after the check is not followed) of bounded size; ``.npz`` arrays
  through :func:`npz_arrays` (the one reader of ``.npz`` bytes, the cache's too): each array's header is checked
  before its data is read (no object dtype, so no pickle; the data its shape declares within its member and the
  bound).
- **Fields** (:class:`RunDoc`'s ``read_*``): only what is read through them is trusted; a JSON ``true`` or
  ``false`` for a bool (never the string ``"false"``), an integer for an int (not 2.0, not true), a finite number
  for a float (never ``NaN`` or ``1e400``), a string of the allowed ones, a vector of its length of finite
  numbers, a path inside the folder.

Everything refused is a :class:`~pytdcr.validate.SettingsError` naming the setting that gave the folder (the
command line calls it by its option, ``--workspace``), the folder, the file and the field, e.g. ``--workspace
'run': workspace.json: inputs.loads.release = 'false': must be a JSON true or false``.
"""

from __future__ import annotations

import io
import json
import math
import os
import re
import stat
import zipfile
import zlib
from collections.abc import Iterable, Mapping
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np

from ..records import JsonObject
from ..validate import SettingsError, check_real, is_integer, show, show_path

__all__ = ["MAX_JSON_BYTES", "MAX_RUN_FILE_BYTES", "RunDoc", "RunFolder", "npz_arrays", "read_fd", "regular_file_bytes"]

#: the largest JSON file read back from a run's folder [bytes]
MAX_JSON_BYTES = 64 * 2**20
#: the largest other file (arrays, meshes) read back, and the most array data a ``.npz`` file may unpack [bytes]
MAX_RUN_FILE_BYTES = 4 * 2**30

_READ_FLAGS = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
_STEP = re.compile(r"\[(\d+)\]|\.?([^.\[\]]+)")
_MISSING = object()


def read_fd(fd: int, limit: int) -> bytes:
    """The bytes of the open file ``fd`` from where it stands, at most ``limit + 1`` of them (so that a caller
    sees a file that grew past ``limit`` since it was measured)."""
    chunks, left = [], limit + 1
    while left > 0:
        chunk = os.read(fd, min(left, 1 << 24))
        if not chunk:
            break
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def regular_file_bytes(path: str | Path, limit: int, *, follow: bool = True) -> bytes:
    """The bytes of the regular file at ``path``, at most ``limit`` of them: OSError when it cannot be read (or,
    unless ``follow``, is a link), ValueError when it is anything but a regular file (never opened: a device
    could do anything, a FIFO would block) or is larger than ``limit``."""
    flags = _READ_FLAGS | (0 if follow else getattr(os, "O_NOFOLLOW", 0))
    if not stat.S_ISREG((os.stat(path) if follow else os.lstat(path)).st_mode):
        raise ValueError("not a regular file")
    fd = os.open(path, flags)  # a FIFO put there since opens without waiting for a writer
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ValueError("not a regular file")
        if st.st_size > limit:
            raise ValueError(f"larger than {limit:,} bytes; not a file this run wrote")
        data = read_fd(fd, limit)
    finally:
        os.close(fd)
    if len(data) > limit:
        raise ValueError(f"larger than {limit:,} bytes; not a file this run wrote")
    return data


#: what reading a ``.npz`` file's bytes may raise besides ValueError: a broken zip, an encrypted or unknown
#: compression, a broken deflate stream, a header that nests too deep
_NPZ_ERRORS = (OSError, EOFError, KeyError, zipfile.BadZipFile, RuntimeError, NotImplementedError, zlib.error,
               RecursionError)


def _npy_header(member: io.BufferedIOBase) -> tuple[tuple[int, ...], np.dtype]:
    """The shape and dtype a ``.npy`` member's header declares (the member read up to its data)."""
    version = np.lib.format.read_magic(member)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(member)
    elif version == (2, 0):
        shape, _, dtype = np.lib.format.read_array_header_2_0(member)
    else:
        raise ValueError(f"npy format version {version[0]}.{version[1]}, not one numpy.savez writes")
    return shape, dtype


def npz_arrays(data: bytes, limit: int, keys: Iterable[str] | None = None) -> dict[str, np.ndarray]:
    """The arrays of the ``.npz`` file whose bytes are ``data`` (``keys`` only, when given; a key the file lacks
    is absent from the answer), each read only after its ``.npy`` header is checked.

    Nothing is unpacked before it is bounded: the members together unpack to at most ``limit`` bytes, and each
    array's header must declare a dtype of plain numbers (no object: no pickle is ever read), of a non-zero item
    size, and a shape whose data (``prod(shape) * itemsize``) fits in both its member's size and ``limit``; a
    header claiming a shape of 2**40 items is refused from its few bytes, never allocated.

    Parameters
    ----------
    data : bytes
        The ``.npz`` file's bytes.
    limit : int
        The most bytes the file may unpack to, and the largest array's data [bytes].
    keys : iterable of str, optional
        The arrays to read (each ``KEY.npy`` member); None: every member.

    Returns
    -------
    dict
        Each array read, by its key, exactly as :func:`numpy.load` reads it.

    Raises
    ------
    ValueError
        One line saying what is wrong: not a whole ``.npz`` file, unpacking to more than ``limit`` bytes, or an
        array whose header is refused (its key first, e.g. ``tensions: ...``).
    """
    wanted = None if keys is None else set(keys)
    out: dict[str, np.ndarray] = {}
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            infos = zf.infolist()
            if sum(i.file_size for i in infos) > limit:  # never inflated past the bound
                raise ValueError(f"unpacks to more than {limit:,} bytes; not a file this run wrote")
            for info in infos:
                key = info.filename.removesuffix(".npy")
                if wanted is not None and key not in wanted:
                    continue
                with zf.open(info) as member:
                    shape, dtype = _npy_header(member)
                if dtype.hasobject or dtype.itemsize == 0:
                    raise ValueError(f"{key}: not an array of numbers (dtype {show(str(dtype))})")
                if any(n < 0 for n in shape):
                    raise ValueError(f"{key}: its header declares the shape {show(shape)}")
                need = math.prod(shape) * dtype.itemsize
                if need > info.file_size or need > limit:
                    raise ValueError(f"{key}: its header declares {need:,} bytes of data (shape {show(shape, 80)}), "
                                     f"more than {'it holds' if need <= limit else f'{limit:,} bytes'}")
                with zf.open(info) as member:  # checked: now read, as numpy.load reads it
                    out[key] = np.lib.format.read_array(member, allow_pickle=False)
    except _NPZ_ERRORS as err:
        raise ValueError(f"not a whole .npz file ({type(err).__name__}: {show(str(err), 100)[1:-1]})") from None
    return out


class RunFolder:
    """A folder another run wrote, read as input; ``field`` is the setting that named it (its refusals name it).

    Parameters
    ----------
    folder : str or Path
        The run's folder.
    field : str
        The setting that gave it (``workspace``; the command line says ``--workspace``).
    """

    def __init__(self, folder: str | Path, field: str = "workspace") -> None:
        self.folder = Path(folder)
        self.field = field
        self.root = Path(os.path.realpath(self.folder))

    def refuse(self, text: str) -> SettingsError:
        """A refusal of this folder: ``text`` (``FILE: FIELD = VALUE: what is allowed``) after the folder."""
        return SettingsError(self.field, f" {show_path(self.folder)}: {text}")

    def path(self, name: str, what: str) -> Path:
        """The file ``name`` (a relative POSIX path) of the folder; refused (naming ``what``, e.g.
        ``workspace.json: mesh``) when it is absolute, climbs out with ``..`` or leads out by a link."""
        pure = PurePosixPath(name)
        if not name or "\x00" in name or "\\" in name or pure.is_absolute() or ".." in pure.parts:
            raise self.refuse(f"{what} = {show(name)}: must name a file inside the run's folder (a relative path, "
                              "no '..')")
        real = Path(os.path.realpath(self.root / pure))
        if real != self.root and self.root not in real.parents:
            raise self.refuse(f"{what} = {show(name)}: leads out of the run's folder (a link to "
                              f"{show_path(real)}); only files inside it are read")
        return real

    def read_bytes(self, name: str, limit: int, what: str | None = None) -> bytes:
        """The bytes of the regular file ``name`` (:meth:`path`), at most ``limit`` of them; refused when it is
        missing, anything but a regular file (a link put at the checked path since is not followed), or
        larger."""
        what = what or name
        path = self.path(name, what)
        try:  # the resolved path opened without following a link: none swapped in since it was checked
            return regular_file_bytes(path, limit, follow=False)
        except OSError as err:
            raise self.refuse(f"{what}: cannot read it ({err.strerror or err}); give the folder of one finished "
                              "run") from None
        except ValueError as err:
            raise self.refuse(f"{what}: {err}") from None

    def read_json(self, name: str, limit: int = MAX_JSON_BYTES) -> RunDoc:
        """The JSON object in ``name`` as a :class:`RunDoc` (a ``NaN``, ``Infinity`` or ``1e400`` is read as a
        non-finite float, for the field that holds it to refuse by name)."""
        data = self.read_bytes(name, limit)
        try:
            doc = json.loads(data.decode("utf-8"))
        except (ValueError, RecursionError) as err:
            raise self.refuse(f"{name}: not strict JSON ({show(str(err), 120)[1:-1]})") from None
        if not isinstance(doc, dict):
            raise self.refuse(f"{name}: must hold a JSON object, got {type(doc).__name__}")
        return RunDoc(self, name, doc)

    def read_npz(self, name: str, kinds: Mapping[str, str], limit: int = MAX_RUN_FILE_BYTES) -> dict[str, np.ndarray]:
        """The arrays ``kinds`` names of the ``.npz`` file ``name``, each of its kind (``"f"`` real numbers, read as
        float64; ``"b"`` booleans; ``"i"`` integers), without pickles; refused when one is missing or of another
        kind, or the file is not a whole ``.npz`` file, unpacks to more than ``limit`` bytes or has an array whose
        header declares more data than it holds (:func:`npz_arrays`)."""
        data = self.read_bytes(name, limit)
        try:
            arrays = npz_arrays(data, limit, kinds)
        except ValueError as err:
            raise self.refuse(f"{name}: {err}") from None
        words = {"f": "real numbers", "b": "booleans", "i": "integers"}
        out: dict[str, np.ndarray] = {}
        for key, kind in kinds.items():
            if key not in arrays:
                raise self.refuse(f"{name}: {key}: missing")
            arr = arrays[key]
            if arr.dtype.kind not in {"f": "fiu", "b": "b", "i": "iu"}[kind]:
                raise self.refuse(f"{name}: {key}: must be an array of {words[kind]}, got dtype "
                                  f"{show(str(arr.dtype))}")
            out[key] = arr.astype(np.float64) if kind == "f" else arr
        return out


def _steps(path: str) -> list[str | int]:
    """``"a.b[2].c"`` as keys and indices."""
    return [int(m.group(1)) if m.group(1) is not None else m.group(2) for m in _STEP.finditer(path)]


class RunDoc:
    """A JSON object read back from a run's folder: its fields read strictly by their path (``"inputs.loads.
    release"``, ``"inputs.loads.point_loads[0].disk"``), each refusal naming the folder, the file and the field."""

    def __init__(self, run: RunFolder, file: str, data: JsonObject) -> None:
        self.run, self.file, self.data = run, file, data

    def refuse(self, path: str, text: str, value: object = _MISSING) -> SettingsError:
        """A refusal of the field ``path``: ``FILE: PATH = VALUE: text`` (``FILE: PATH: text`` without a value)."""
        shown = "" if value is _MISSING else f" = {show(value)}"
        return self.run.refuse(f"{self.file}: {path}{shown}: {text}")

    def get(self, path: str, default: object = _MISSING) -> object:
        """The raw value at ``path``; ``default`` (when given) where it is missing, else refused as missing."""
        node: Any = self.data
        for step in _steps(path):
            ok = (isinstance(node, dict) and isinstance(step, str) and step in node) or (
                isinstance(node, list) and isinstance(step, int) and step < len(node))
            if not ok:
                if default is not _MISSING:
                    return default
                raise self.refuse(path, "missing; give the folder of one finished run")
            node = node[step]
        return node

    def has(self, path: str) -> bool:
        """``path`` is there and not null."""
        return self.get(path, None) is not None

    def read_bool(self, path: str) -> bool:
        """A JSON ``true`` or ``false``."""
        v = self.get(path)
        if not isinstance(v, bool):
            raise self.refuse(path, "must be a JSON true or false", v)
        return v

    def read_int(self, path: str, lo: int | None = None, hi: int | None = None) -> int:
        """A JSON integer (not 2.0, not true) in [lo, hi]."""
        v = self.get(path)
        if not is_integer(v) or (lo is not None and v < lo) or (hi is not None and v > hi):
            span = f"in [{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}]"
            raise self.refuse(path, f"must be an integer {span}", v)
        return int(v)

    def read_float(self, path: str, lo: float | None = None, hi: float | None = None) -> float:
        """A finite JSON number in [lo, hi] (:func:`~pytdcr.validate.check_real`: an integer of any size, too
        large for a float, is refused as out of range)."""
        v = self.get(path)
        try:
            return check_real(v, path, lo, hi, "")
        except (TypeError, ValueError):
            span = f"in [{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}]"
            raise self.refuse(path, f"must be a finite number {span}", v) from None

    def read_str(self, path: str, choices: Iterable[str] | None = None) -> str:
        """A JSON string, one of ``choices`` when given."""
        v = self.get(path)
        allowed = None if choices is None else sorted(choices)
        if not isinstance(v, str) or (allowed is not None and v not in allowed):
            what = "a string" if allowed is None else f"one of {', '.join(allowed)}"
            raise self.refuse(path, f"must be {what}", v)
        return v

    def read_vector(self, path: str, n: int | None = None, limit: float | None = None) -> np.ndarray:
        """A JSON list of ``n`` (any number when None) finite numbers, each within +/- ``limit``
        (:func:`~pytdcr.validate.check_real`: an integer too large for a float is refused, never an
        OverflowError)."""
        v = self.get(path)
        lo = None if limit is None else -limit
        try:
            if not isinstance(v, list) or (n is not None and len(v) != n):
                raise ValueError("not a list of its length")
            for k, x in enumerate(v):
                check_real(x, f"{path}[{k}]", lo, limit, "")
        except (TypeError, ValueError):
            size = "" if n is None else f"{n} "
            within = "" if limit is None else f" within +/-{limit:g}"
            raise self.refuse(path, f"must be a list of {size}finite numbers{within}", v) from None
        return np.array(v, dtype=float)

    def read_list(self, path: str, most: int | None = None) -> list[object]:
        """A JSON list (of at most ``most`` items)."""
        v = self.get(path)
        if not isinstance(v, list) or (most is not None and len(v) > most):
            raise self.refuse(path, f"must be a list{'' if most is None else f' of at most {most} items'}", v)
        return v

    def read_dict(self, path: str) -> JsonObject:
        """A JSON object."""
        v = self.get(path)
        if not isinstance(v, dict):
            raise self.refuse(path, "must be a JSON object", v)
        return v

    def read_path(self, path: str) -> str:
        """A relative path (a string) naming a file inside the run's folder (:meth:`RunFolder.path`)."""
        name = self.read_str(path)
        self.run.path(name, f"{self.file}: {path}")
        return name
