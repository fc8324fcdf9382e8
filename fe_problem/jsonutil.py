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
