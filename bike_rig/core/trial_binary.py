"""Checks of a binary trial file before its arrays are read, so that a damaged file costs bounded memory.

``.npy``: the header's announced array (shape × item size) must fit in the bytes after it.
``.mat`` (MATLAB v5): each compressed element is inflated in bounded chunks, counting bytes, so
a small file that inflates to gigabytes is refused; scipy's reader is not hardened against
damaged input (it can crash the process), so :func:`load_mat_isolated` runs it in a forked
child within a time limit. Each check raises :class:`~bike_rig.core.errors.InputFileError`.
"""

from __future__ import annotations

import faulthandler
import math
import multiprocessing
import struct
import warnings
import zlib
from multiprocessing.connection import Connection
from pathlib import Path
from tokenize import TokenError
from typing import Any

import numpy as np

from .errors import InputFileError, one_line

__all__ = ["MAT_TIME_LIMIT_S", "MAX_TRIAL_BYTES", "check_mat_sizes", "check_npy_header", "load_mat_isolated"]

#: The longest a .mat file may take to read [s] (a trial's takes milliseconds).
MAT_TIME_LIMIT_S = 30.0

#: The most bytes a binary trial's arrays may take [bytes]: 64 M samples, hours at 1 kHz (a
#: pendulum trial is some tens of seconds).
MAX_TRIAL_BYTES = 512 << 20

#: MATLAB v5: the header's length [bytes], and the data type of a compressed element.
_MAT_HEADER = 128
_MI_COMPRESSED = 15
#: Bytes inflated at a time while counting a compressed element.
_CHUNK = 1 << 20


def check_npy_header(name: str, path: Path) -> None:
    """Refuse a ``.npy`` file whose header is damaged or announces more data than the file holds.

    Args:
        name: The file as given, for messages.
        path: The file.

    Raises:
        InputFileError: unreadable header, an object array, or an array larger than the bytes
            after the header (or than :data:`MAX_TRIAL_BYTES`).
    """
    fmt = np.lib.format
    try:
        with path.open("rb") as f, warnings.catch_warnings():
            warnings.simplefilter("ignore", SyntaxWarning)  # Python's, on a damaged header's literal
            version = fmt.read_magic(f)
            if version == (1, 0):
                shape, _fortran, dtype = fmt.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, _fortran, dtype = fmt.read_array_header_2_0(f)
            else:
                raise ValueError(f"unsupported .npy format version {version[0]}.{version[1]}")
            data_bytes = path.stat().st_size - f.tell()
    except (ValueError, TypeError, EOFError, OSError, SyntaxError, TokenError) as exc:  # TokenError: a cut header
        raise InputFileError(name, f"not a readable NumPy .npy file ({one_line(str(exc))})") from None
    if dtype.hasobject:
        raise InputFileError(name, "not a readable NumPy .npy file: it holds Python objects, not numbers")
    needed = math.prod(shape) * dtype.itemsize
    if needed > data_bytes:
        raise InputFileError(
            name,
            f"truncated or damaged: its header announces a {shape} array of {dtype} ({needed} bytes), "
            f"but only {data_bytes} bytes follow it",
        )
    if needed > MAX_TRIAL_BYTES:
        reason = f"a {shape} array ({needed} bytes) is larger than any trial ({MAX_TRIAL_BYTES} bytes)"
        raise InputFileError(name, reason)


def _inflated_size(data: bytes, limit: int) -> int:
    """The size of zlib-compressed ``data`` inflated, counted in chunks; stops above ``limit``.

    Damaged compressed data count as what inflated before the damage (scipy then reports it).
    """
    inflater = zlib.decompressobj()
    total = 0
    pending = data
    try:
        while pending and total <= limit:
            total += len(inflater.decompress(pending, _CHUNK))
            pending = inflater.unconsumed_tail
    except zlib.error:
        pass
    return total


def check_mat_sizes(name: str, path: Path) -> None:
    """Refuse a MATLAB v5 ``.mat`` file whose elements, inflated, exceed :data:`MAX_TRIAL_BYTES`.

    Files of other versions, and structure that the walk does not follow, are left to scipy.

    Raises:
        InputFileError: the inflated elements are larger than any trial.
    """
    data = path.read_bytes()
    if len(data) < _MAT_HEADER or data[126:128] not in (b"IM", b"MI"):
        return
    order = "<" if data[126:128] == b"IM" else ">"
    pos, total = _MAT_HEADER, 0
    while pos + 8 <= len(data) and total <= MAX_TRIAL_BYTES:
        kind, size = struct.unpack(order + "II", data[pos : pos + 8])
        if kind >> 16:  # a small element: type and size in 4 bytes, data in the other 4
            pos += 8
            continue
        body = data[pos + 8 : pos + 8 + size]
        total += _inflated_size(body, MAX_TRIAL_BYTES - total) if kind == _MI_COMPRESSED else len(body)
        pos += 8 + size + (-size % 8 if kind != _MI_COMPRESSED else 0)
    if total > MAX_TRIAL_BYTES:
        raise InputFileError(name, f"its arrays take more than {MAX_TRIAL_BYTES} bytes, more than any trial")


def _load_mat_child(path: str, out: Connection) -> None:
    """In the child: read the file with scipy and send ``("ok", fields, warnings)`` or ``("error", reason)``."""
    from scipy.io import loadmat

    faulthandler.disable()  # a crash here is expected and told in one line by the parent: no stack dump

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mat = loadmat(path, squeeze_me=True, chars_as_strings=True)
        out.send(("ok", mat, [one_line(str(w.message)) for w in caught]))
    except NotImplementedError:
        out.send(("error", "MATLAB v7.3 (HDF5) files are not supported: save with -v7"))
    except Exception as exc:
        out.send(("error", f"not a readable MATLAB .mat file ({one_line(str(exc)) or type(exc).__name__})"))
    finally:
        out.close()


def load_mat_isolated(name: str, path: Path) -> tuple[dict[str, Any], list[str]]:
    """Scipy's ``loadmat(path, squeeze_me=True, chars_as_strings=True)``, run in a forked child.

    Returns:
        The file's fields, and scipy's warnings (one line each).

    Raises:
        InputFileError: scipy refused the file, its reader died (a signal) or ran past
            :data:`MAT_TIME_LIMIT_S`.
    """
    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)
    child = context.Process(target=_load_mat_child, args=(str(path), send), daemon=True)
    child.start()
    send.close()
    try:
        if not receive.poll(MAT_TIME_LIMIT_S):
            raise InputFileError(name, f"reading the .mat file took longer than {MAT_TIME_LIMIT_S:g} s")
        reply = receive.recv()
    except EOFError:
        child.join(5.0)
        reason = f"not a readable MATLAB .mat file (scipy's reader died: exit {child.exitcode})"
        raise InputFileError(name, reason) from None
    finally:
        receive.close()
        if child.is_alive():
            child.kill()
        child.join(5.0)
    if reply[0] != "ok":
        raise InputFileError(name, reply[1])
    return reply[1], reply[2]
