"""What every file loader checks before it parses: sizes, nesting depth and paths, in one module.

The loaders (``trajectory``, ``scenefile``, ``mjcf``, ``meshfile``) each keep their own limits as
documented constants and raise their own error type; this module gives them the checks, each
raising ``FileLimitError`` (a ValueError) with the problem, which the loader turns into its error
naming the file:

- ``check_size``: a file's size from ``stat`` against a maximum, before it is read;
- ``toml_depth`` / ``json_depth``: the deepest nesting of a TOML or JSON text (brackets, braces,
  and for TOML dotted keys), from one linear scan that builds nothing, so a 50,000-deep key is
  refused before a parser recurses or builds 50,000 tables;
- ``read_npz``: the arrays of an ``.npz`` (a zip of ``.npy``) with every member's ``.npy`` header
  read from its zip entry first, and shape x itemsize checked against the entry's stated size,
  against what deflate can hold in the compressed bytes (``DEFLATE_MAX_RATIO``), against the
  caller's maximum and, when the caller gives one, against a bound on the arrays' bytes per byte
  of the file (above a floor), before any array is allocated; the data is then read in bounded
  chunks, so no more than the stated size is ever decompressed and the memory a file can make the
  loader take stays within that bound times its size;
- ``inside``: the rule for paths a file names (meshes of a scene or MJCF file): they resolve
  (symlinks followed) inside the file's own folder or a folder the caller allowed; the error does
  not say whether the outside path exists.
"""
from __future__ import annotations

import math
import re
import zipfile
import zlib
from pathlib import Path
from typing import Iterable

import numpy as np

__all__ = ["FileLimitError", "RatioLimitError", "OutsideError", "check_size", "toml_depth", "json_depth", "read_npz",
           "inside", "DEFLATE_MAX_RATIO"]

#: deflate's largest possible expansion (a run of one byte: 258 bytes per 2-bit code, ~1032:1), so
#: an entry claiming more than this times its compressed bytes cannot be honest
DEFLATE_MAX_RATIO = 1032
# chunk of a member read at a time (bounded decompression, bounded temporary memory)
_CHUNK = 1 << 20


class FileLimitError(ValueError):
    """A file over one of its loader's limits, or not what it claims; the message says which."""


class RatioLimitError(FileLimitError):
    """An .npz whose arrays hold more bytes per byte of the file than its loader allows."""


class OutsideError(FileLimitError):
    """A path a file names that resolves outside the folders it may be read from (``inside``)."""


def check_size(path: Path, max_bytes: int) -> int:
    """The size (bytes) of a file, or FileLimitError when it is over max_bytes."""
    size = Path(path).stat().st_size
    if size > max_bytes:
        raise FileLimitError(f"the file is {size:,} bytes, over the limit of {max_bytes:,}")
    return size


def read_limited(path: Path, max_bytes: int, what: str, error: type) -> bytes:
    """The bytes of a file of at most max_bytes: FileNotFoundError when it does not exist, else
    ``error`` (the reader's own exception class) for one over the limit or unreadable, each message
    starting "{what} '{path}'" (what: "URDF file", "MJCF file", ...)."""
    try:
        check_size(path, max_bytes)
        return Path(path).read_bytes()
    except FileNotFoundError:
        raise FileNotFoundError(f"{what} {str(path)!r} does not exist") from None
    except FileLimitError as e:
        raise error(f"{what} {str(path)!r}: {e}") from None
    except OSError as e:
        raise error(f"{what} {str(path)!r}: unreadable: {e}") from None


# strings and comments skipped, then the characters that open, close or separate. An unterminated
# string runs to the end of its line (or of the text), so each quote starts one token ending where
# a scan would: no match restarts inside a string (which made '"\"\"\"...' quadratic)
_TOML_TOKENS = re.compile(r'"""(?:[^\\]|\\[\s\S])*?(?:"""|\Z)|\'\'\'[\s\S]*?(?:\'\'\'|\Z)|"(?:[^"\\\n]|\\.)*"?'
                          r"|'[^'\n]*'?|#[^\n]*|[\[\]{}=,.\n]")
_JSON_TOKENS = re.compile(r'"(?:[^"\\]|\\[\s\S])*"?|[\[\]{}]')


def toml_depth(text: str, limit: int) -> int:
    """The deepest nesting of a TOML text: open arrays and tables plus the parts of a dotted key
    (``a.b.c`` is 3 deep). FileLimitError naming the line once it passes limit (the scan stops
    there). Linear in the text; a float's dot counts as one part, which only overstates by one."""
    depth, dots, line, deepest = 0, 0, 1, 0
    for m in _TOML_TOKENS.finditer(text):
        t = m.group()
        if t in "[{":
            depth += 1
            dots = 0
        elif t in "]}":
            depth = max(depth - 1, 0)
            dots = 0
        elif t == ".":
            dots += 1
        elif t in "=,\n":
            dots = 0
            line += t == "\n"
        elif t[0] in "\"'":
            line += t.count("\n")
            continue
        else:
            continue
        here = depth + dots + 1
        if here > deepest:
            deepest = here
            if deepest > limit:
                raise FileLimitError(f"line {line}: nested deeper than {limit} levels (arrays, tables and dotted "
                                     "keys together)")
    return deepest


def json_depth(text: str, limit: int) -> int:
    """The deepest nesting of arrays and objects in a JSON text; FileLimitError once it passes
    limit. Linear in the text, nothing built."""
    depth, deepest = 0, 0
    for m in _JSON_TOKENS.finditer(text):
        t = m.group()
        if t in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > limit:
                    raise FileLimitError(f"JSON nested deeper than {limit} levels")
        elif t in "]}":
            depth = max(depth - 1, 0)
    return deepest


def _member_header(z: zipfile.ZipFile, info: zipfile.ZipInfo, max_array_bytes: int):
    """(shape, fortran order, dtype, data bytes) of one .npy member, from its header only."""
    name = info.filename
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise FileLimitError(f"{name}: compression method {info.compress_type} (only stored or deflated)")
    stored = info.compress_type == zipfile.ZIP_STORED
    if info.file_size > (info.compress_size if stored else DEFLATE_MAX_RATIO * info.compress_size + 1024):
        raise FileLimitError(f"{name}: claims {info.file_size:,} bytes from {info.compress_size:,} compressed, "
                             "more than the format can hold")
    with z.open(info) as f:
        try:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
            elif version in ((2, 0), (3, 0)):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
            else:
                raise ValueError(f"unknown .npy version {version}")
        except Exception as e:  # numpy's header parser (ast, tokenize) raises many types
            raise FileLimitError(f"{name}: not an .npy array: {type(e).__name__}: {e}") from None
        header = f.tell()
    if dtype.hasobject or dtype.itemsize == 0:
        raise FileLimitError(f"{name}: dtype {dtype} refused (Python objects, or no bytes per item)")
    if any(not isinstance(s, int) or s < 0 for s in shape):
        raise FileLimitError(f"{name}: bad shape {shape}")
    nbytes = math.prod(shape) * dtype.itemsize
    if nbytes > max_array_bytes:
        raise FileLimitError(f"{name}: shape {shape} of {dtype} is {nbytes:,} bytes, over the limit of "
                             f"{max_array_bytes:,}")
    if header + nbytes != info.file_size:
        raise FileLimitError(f"{name}: shape {shape} of {dtype} needs {nbytes:,} bytes of data, the entry holds "
                             f"{info.file_size - header:,}")
    return shape, fortran, dtype, nbytes, header


def read_npz(path: Path, max_total_bytes: int, names: Iterable[str] | None = None, *,
             max_ratio: float | None = None, ratio_floor: int = 0) -> dict[str, np.ndarray]:
    """The arrays of an .npz, {name without .npy: array}, reading only the members in ``names``
    (all when None). Every member's header is checked first (see the module doc): the total of
    the members read must be at most max_total_bytes and, with max_ratio, at most max_ratio times
    the file's size once it is over ratio_floor bytes (a small file may always hold ratio_floor);
    then each is read in chunks into an array of its stated size (nothing more is decompressed).
    FileLimitError for anything else, including a zip that is not one, a CRC mismatch, duplicated
    or non-.npy members."""
    try:
        size = Path(path).stat().st_size
        with zipfile.ZipFile(path) as z:
            infos = z.infolist()
            wanted = None if names is None else set(names)
            seen: dict[str, tuple] = {}
            total = 0
            for info in infos:
                if not info.filename.endswith(".npy"):
                    raise FileLimitError(f"{info.filename}: not an .npy member")
                key = info.filename[:-4]
                if key in seen:
                    raise FileLimitError(f"{info.filename}: appears twice")
                if wanted is not None and key not in wanted:
                    seen[key] = ()
                    continue
                seen[key] = (info, *_member_header(z, info, max_total_bytes))
                total += seen[key][4]
                if total > max_total_bytes:
                    raise FileLimitError(f"its arrays hold more than {max_total_bytes:,} bytes (limit)")
            if max_ratio is not None and total > max(ratio_floor, max_ratio * size):
                largest = max((e for e in seen.values() if e), key=lambda e: e[4])
                raise RatioLimitError(
                    f"{largest[0].filename} and the other arrays hold {total:,} bytes once decompressed (this one "
                    f"{largest[4]:,}) from a file of {size:,} bytes: {total / max(size, 1):,.0f}:1, over the limit "
                    f"of {max_ratio:g}:1 for arrays of more than {ratio_floor:,} bytes")
            out = {}
            for key, entry in seen.items():
                if not entry:
                    continue
                info, shape, fortran, dtype, nbytes, header = entry
                buf = np.empty(nbytes, dtype=np.uint8)
                with z.open(info) as f:
                    f.read(header)
                    at = 0
                    while at < nbytes:
                        chunk = f.read(min(_CHUNK, nbytes - at))
                        if not chunk:
                            raise FileLimitError(f"{info.filename}: truncated ({at:,} of {nbytes:,} bytes)")
                        buf[at:at + len(chunk)] = np.frombuffer(chunk, dtype=np.uint8)
                        at += len(chunk)
                    if f.read(1):
                        raise FileLimitError(f"{info.filename}: more data than its header says")
                array = buf.view(dtype)
                out[key] = array.reshape(shape[::-1]).T if fortran else array.reshape(shape)
            return out
    except FileLimitError:
        raise
    except (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, EOFError, OSError, NotImplementedError,
            ValueError) as e:
        raise FileLimitError(f"unreadable as .npz: {type(e).__name__}: {e}") from None


def inside(name: str, base: Path, allowed: Iterable[Path], what: str) -> Path:
    """The path ``name`` (as a file wrote it) resolved against the folder ``base``, when it lands
    (symlinks followed) inside one of the ``allowed`` folders (the file's own folder first); else
    OutsideError saying so, with the same words whether or not the outside path exists (nothing
    about it is revealed)."""
    folders = [Path(a).resolve() for a in allowed]
    try:
        target = (Path(base) / name).resolve()
    except (OSError, RuntimeError, ValueError):
        target = None
    if target is None or not any(target.is_relative_to(folder) for folder in folders):
        raise OutsideError(f"{what} {name!r} is outside the folders it may be read from (the file's own folder"
                             f"{' and the ones allowed' if len(folders) > 1 else ''}); refused")
    return target
