"""The one JSON cleaning of the project: records become strict JSON here and nowhere else.

numpy arrays and scalars become lists and numbers, dataclasses their fields, tuples lists,
Paths strings, and a number that is not finite (NaN, inf) becomes None, so that every file the
project writes is strict JSON (``allow_nan=False``) that any reader accepts.
"""

from __future__ import annotations

import dataclasses
import json
import math
import stat
from pathlib import Path

import numpy as np


def jsonable(obj):
    """``obj`` as plain JSON values (dict, list, str, int, float, bool, None)."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        to_dict = getattr(obj, "to_dict", None)
        return jsonable(to_dict() if callable(to_dict) else dataclasses.asdict(obj))
    if isinstance(obj, Path):
        return str(obj)
    if obj is None or isinstance(obj, str):
        return obj
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def dumps(obj, indent: int | None = 1) -> str:
    """``obj`` as strict JSON text."""
    return json.dumps(jsonable(obj), indent=indent, allow_nan=False)


#: The largest JSON file the project reads (bytes): model, data and record files are far smaller
#: (a model at the dense path's size limit with 100 measured modes is about 20 MB), and parsing
#: one of this size takes under 1 GB of memory.
MAX_JSON_BYTES = 64 * 2**20


def _no_duplicate_keys(pairs):
    """An object hook that refuses a key given twice (JSON keeps the last one, silently)."""
    obj = dict(pairs)
    if len(obj) != len(pairs):
        seen = set()
        twice = next(k for k, _ in pairs if k in seen or seen.add(k))
        raise ValueError(f"key {twice!r} is given twice in one object")
    return obj


def _read_bounded(path: Path, error) -> bytes:
    """The bytes of the regular file at `path`, at most MAX_JSON_BYTES of them (a device such
    as /dev/zero or a named pipe would never end or never start)."""
    if path.is_dir():
        raise error(f"{path}: is a directory, not a file")
    if path.exists() and not stat.S_ISREG(path.stat().st_mode):
        raise error(f"{path}: not a regular file (a device, a pipe or a socket); name a JSON file")
    with open(path, "rb") as fh:
        raw = fh.read(MAX_JSON_BYTES + 1)
    if len(raw) > MAX_JSON_BYTES:
        raise error(f"{path}: larger than the {MAX_JSON_BYTES} bytes a JSON file may have")
    return raw


def read_json_file(path: Path, error: type[Exception] = ValueError):
    """The JSON value in the file at `path`, or `error` (a ValueError subclass) with a one-line
    message naming the file and what is wrong: unreadable (a directory, a device, no
    permission), too large, not UTF-8 (with the byte offset), not JSON (with line and column),
    a key given twice, nested too deep, a number too large to hold. A UTF-8 byte-order mark is
    accepted."""
    path = Path(path)
    try:
        raw = _read_bounded(path, error)
    except OSError as exc:
        raise error(f"{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); "
                    "save the file as UTF-8") from None
    try:
        return json.loads(text, object_pairs_hook=_no_duplicate_keys)
    except json.JSONDecodeError as exc:
        raise error(f"{path}: not valid JSON ({exc})") from None
    except RecursionError:
        raise error(f"{path}: JSON nested too deeply to read") from None
    except ValueError as exc:  # a key given twice, an integer of more than 4300 digits
        raise error(f"{path}: not valid JSON ({exc})") from None


def unknown_key(obj: dict, allowed, path: str = "") -> str | None:
    """What is wrong with the keys of `obj` (None if each is in `allowed`): the first unknown
    key, written as its path (`path` plus the key: ``history[0].seedz``), and the allowed key it
    was probably meant to be (the closest; among equally close ones a key the object lacks) or,
    when none is close, the allowed keys."""
    import difflib

    allowed = tuple(allowed)
    for key in obj:
        if key not in allowed:
            # a misspelt key stands for a key the object lacks: those first among equally close
            # ones ('best_fx' beside a 'best_x' is 'best_f'), but a closer key wins ('frequency'
            # beside a 'frequency_hz' is 'frequency_hz', not an optional 'frequency_std_hz')
            ratio = {k: difflib.SequenceMatcher(None, str(key), k).ratio() for k in allowed}
            ranked = sorted((k for k in allowed if ratio[k] >= 0.6), key=lambda k: (-ratio[k], k in obj))
            close = ranked[:1]
            hint = f"; did you mean {close[0]!r}?" if close else f"; the known keys are {', '.join(sorted(allowed))}"
            return f"unknown key {path + str(key)!r}{hint}"
    return None


def check_keys(obj: dict, allowed, where: str, error: type[Exception] = ValueError) -> None:
    """Refuse a key of `obj` that is not in `allowed`: `error` naming `where` (the file and the
    path to the object), the key and, when one is close, the allowed key it was probably meant
    to be. A misspelt key ('suports', 'releas_i') would otherwise be ignored without a word."""
    problem = unknown_key(obj, allowed)
    if problem:
        raise error(f"{where}: {problem}")
