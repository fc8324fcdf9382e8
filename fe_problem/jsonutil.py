"""The one JSON cleaning of the project: records become strict JSON here and nowhere else.

numpy arrays and scalars become lists and numbers, dataclasses their fields, tuples lists,
Paths strings, and a number that is not finite (NaN, inf) becomes None, so that every file the
project writes is strict JSON (``allow_nan=False``) that any reader accepts.
"""

from __future__ import annotations

import dataclasses
import json
import math
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


#: The largest JSON file the project reads (bytes): model, data and record files are far smaller.
MAX_JSON_BYTES = 256 * 2**20


def read_json_file(path: Path, error: type[Exception] = ValueError):
    """The JSON value in the file at `path`, or `error` (a ValueError subclass) with a one-line
    message naming the file and what is wrong: unreadable (a directory, no permission), too
    large, not UTF-8 (with the byte offset), not JSON (with line and column), nested too deep,
    a number too large to hold."""
    path = Path(path)
    try:
        if path.is_dir():
            raise error(f"{path}: is a directory, not a file")
        size = path.stat().st_size
        if size > MAX_JSON_BYTES:
            raise error(f"{path}: {size} bytes is larger than the {MAX_JSON_BYTES} a JSON file may have")
        raw = path.read_bytes()
    except OSError as exc:
        raise error(f"{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); "
                    "save the file as UTF-8") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"{path}: not valid JSON ({exc})") from None
    except RecursionError:
        raise error(f"{path}: JSON nested too deeply to read") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise error(f"{path}: not valid JSON ({exc})") from None
