"""Bounded NPZ reading: every NPZ archive sgt reads (motion files, the matching engine's
database, corpus shards) goes through :func:`load_npz`, which checks what the archive claims
before it inflates anything:

- **The file** is opened by :func:`core.reading.open_input` (a regular file within its kind's
  size limit; a FIFO or a device is refused unread).
- **Each member** must be a ``.npy`` array, stored or deflated (what ``numpy.savez`` and
  ``savez_compressed`` write), no object arrays (no pickles). A stored member's declared size
  must be its size in the file.
- **Inflated sizes**, as the zip directory declares them, are added up before a byte is
  inflated: more than :data:`INFLATED` allows for the kind (a floor, then a ratio to the
  file's size) is refused as a zip bomb, with what it would have taken.
- **Each array's header** (shape and dtype, read from the first bytes of the member) must
  account for exactly the member's declared size; the array is then allocated at that size and
  filled a piece at a time, so a member whose stream inflates to more or less than it
  declares (or whose CRC is wrong) is refused without holding more than it declared.

A damaged deflate stream, a truncated archive or a wrong header raises :class:`NpzError` with
one line ("poses_0.npy: damaged compressed data (invalid stored block lengths)"), never
``zlib.error`` or ``BadZipFile``.

numpy and the standard library only.
"""

from __future__ import annotations

import io
import math
import os
import struct
import zipfile
import zlib

import numpy as np

from core.reading import MiB, open_input

#: Per kind of archive: (floor, ratio). Its arrays may hold, inflated, at most the larger of
#: ``floor`` bytes and ``ratio`` times the file's size. Measured: the shipped matching database
#: inflates to 1.07 times its size, motion files to 2 (the network's takes) to 6.3 times (the
#: keyframe engine's), corpus shards are stored (1.0).
INFLATED = {
    "motion file": (64 * MiB, 64),
    "matching database": (64 * MiB, 16),
    "corpus shard": (64 * MiB, 16),
}

#: The .npy header readers by format version (numpy writes 1.0, and 2.0 for headers over 64 KiB).
_HEADERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}

#: Bytes inflated at a time while an array is filled.
_PIECE = 1 << 20


class NpzError(ValueError):
    """An NPZ archive that is not read (damaged, foreign, or a zip bomb); ``str`` is one line,
    without the file's name (the caller puts it in front)."""


def load_npz(source, what: str, keys=None) -> dict[str, np.ndarray]:
    """The arrays of the NPZ archive ``source`` (a path, opened by :func:`core.reading.open_input`
    with the limit of ``what``, or the archive's bytes), by name without ``.npy``; only those in
    ``keys`` when given (the others are not inflated). Raises :class:`NpzError` for an archive
    that breaks the rules above; a path raises what ``open_input`` raises (``InputFileError``,
    ``FileNotFoundError``...)."""
    if isinstance(source, (bytes, bytearray, memoryview)):
        return _load(io.BytesIO(source), len(source), what, keys)
    with open_input(source, what) as f:
        return _load(f, os.fstat(f.fileno()).st_size, what, keys)


def _load(f, size: int, what: str, keys) -> dict[str, np.ndarray]:
    try:
        with zipfile.ZipFile(f) as z:
            members = [m for m in z.infolist() if keys is None or m.filename.removesuffix(".npy") in keys]
            _check_members(members, size, what)
            return {m.filename.removesuffix(".npy"): _array(z, m) for m in members}
    except NpzError:
        raise
    except (zipfile.BadZipFile, ValueError, struct.error) as exc:
        # zipfile on a damaged directory: BadZipFile, also ValueError ("negative seek value"),
        # UnicodeDecodeError (a name flagged UTF-8 that is not), struct.error (measured by mutating archives)
        raise NpzError(f"not a readable NPZ archive ({exc})") from None
    except zlib.error as exc:
        raise NpzError(f"damaged compressed data ({exc})") from None
    except EOFError:
        raise NpzError("the archive ends early (it is truncated)") from None
    except (NotImplementedError, RuntimeError) as exc:  # another compression, an encrypted member
        raise NpzError(f"an archive numpy does not write ({exc})") from None


def _check_members(members: list[zipfile.ZipInfo], size: int, what: str) -> None:
    """Refuse, before inflating anything, a member that is not an array numpy writes or
    inflated sizes beyond :data:`INFLATED`."""
    for m in members:
        if not m.filename.endswith(".npy"):
            raise NpzError(f"{m.filename!r} is not an array (.npy)")
        if m.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            raise NpzError(f"{m.filename}: compression method {m.compress_type}; numpy writes stored or deflated arrays")
        if m.compress_type == zipfile.ZIP_STORED and m.file_size != m.compress_size:
            raise NpzError(f"{m.filename}: stored, yet it declares {m.file_size} bytes in {m.compress_size}")
        if m.compress_size > size:
            raise NpzError(f"{m.filename}: declares {m.compress_size} bytes in a file of {size}")
    floor, ratio = INFLATED[what]
    total = sum(m.file_size for m in members)
    most = max(floor, ratio * size)
    if total > most:
        raise NpzError(f"its arrays would inflate to {_size(total)}, {total / max(size, 1):.0f} times the file's "
                       f"{_size(size)}; a {what} may hold at most {_size(most)}: refused as a zip bomb")


def _array(z: zipfile.ZipFile, m: zipfile.ZipInfo) -> np.ndarray:
    """The array of member ``m``, its header checked against its declared size first."""
    with z.open(m) as f:
        try:
            version = np.lib.format.read_magic(f)
            read_header = _HEADERS.get(version)
            if read_header is None:
                raise ValueError(f"npy format version {version}; numpy writes 1.0 and 2.0")
            shape, fortran, dtype = read_header(f)
        except (zlib.error, EOFError, zipfile.BadZipFile):
            raise
        except Exception as exc:  # noqa: BLE001 - numpy parses the header (at most 10,000 bytes) with tokenize and
            # ast.literal_eval: ValueError, SyntaxError, TokenError, TypeError on damaged headers (measured by mutating
            # archives); only the header's read is inside, and the archive's own errors go on above
            first = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
            raise NpzError(f"{m.filename}: not a numpy array ({first})") from None
        if dtype.hasobject:
            raise NpzError(f"{m.filename}: an array of Python objects (a pickle); not read")
        if any(n < 0 for n in shape):
            raise NpzError(f"{m.filename}: its header gives the shape {shape}")
        count = math.prod(shape)
        if f.tell() + count * dtype.itemsize != m.file_size:
            raise NpzError(f"{m.filename}: its header says {shape} {dtype}, {count * dtype.itemsize} bytes, "
                           f"the archive {m.file_size - f.tell()}")
        flat = np.empty(count, dtype)
        buf = flat.view(np.uint8) if flat.nbytes else np.zeros(0, np.uint8)
        done = 0
        while done < len(buf):
            piece = f.read(min(_PIECE, len(buf) - done))
            if not piece:
                raise NpzError(f"{m.filename}: its data ends after {done} of {len(buf)} bytes")
            buf[done : done + len(piece)] = np.frombuffer(piece, np.uint8)
            done += len(piece)
        if f.read(1):  # (zipfile stops at the declared size; this read also checks the CRC)
            raise NpzError(f"{m.filename}: more data than it declares")
    return flat.reshape(shape[::-1]).T if fortran else flat.reshape(shape)


def _size(n: int) -> str:
    return f"{n / MiB:.1f} MiB" if n >= MiB else f"{n} bytes"
