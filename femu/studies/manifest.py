"""study.json: what each invocation of a study asked for, with the executor, the start time
(UTC), the host and the library versions; the latest request at the top, earlier ones (resumed
or extended studies) in ``history``."""

from __future__ import annotations

import platform
from datetime import datetime, timezone

from adapters.provenance import library_versions

from fe_problem.jsonutil import unknown_key

from .store import Store, StoreError, _is_int, _is_num

STUDY_FORMAT = "femu.study/1"

#: Distributions study.json records beside the run libraries (the executors' own).
EXECUTOR_LIBRARIES = ("dask", "distributed", "rich")


#: What to do about a damaged study.json (it records requests only: no result is in it).
MANIFEST_HINT = ("it only records what each invocation asked for, the runs are kept in runs/: "
                 "delete or repair study.json and run the study again")


def _str_list(v) -> bool:
    return isinstance(v, list) and all(isinstance(x, str) and x for x in v)


def _is_time(v) -> bool:
    if not isinstance(v, str):
        return False
    try:
        datetime.fromisoformat(v)
    except ValueError:
        return False
    return True


#: The fields of one request in study.json: (name, required, test, what it must be).
REQUEST_FIELDS = (
    ("optimizers", True, _str_list, "a list of optimizer names"),
    ("seeds", True, lambda v: isinstance(v, list) and all(_is_int(x) and x >= 0 for x in v),
     "a list of integers >= 0"),
    ("budget", True, lambda v: _is_int(v) and v >= 1, "an integer >= 1"),
    ("variants", True, _str_list, "a list of problem names"),
    ("suite", False, lambda v: v is None or (isinstance(v, str) and v) or _str_list(v),
     "null, a suite id or a list of them"),
    ("time_limit_s", False, lambda v: v is None or (_is_num(v) and v > 0), "null or seconds > 0"),
    ("options", False, lambda v: isinstance(v, dict), "an object"),
    ("retry_failed", False, lambda v: isinstance(v, bool), "true or false"),
    ("x0", False, lambda v: v in ("none", "all"), "none or all"),
    ("in_process", False, lambda v: isinstance(v, bool), "true or false"),
    ("blind", False, lambda v: isinstance(v, bool), "true or false"),
    ("executor", True, lambda v: isinstance(v, str) and v, "a non-empty string"),
    ("started", True, _is_time, "an ISO 8601 time"),
    ("host", False, lambda v: isinstance(v, str), "a string"),
    ("versions", False, lambda v: isinstance(v, dict) and all(x is None or isinstance(x, str) for x in v.values()),
     "an object of version strings (null: not installed)"),
)


#: The keys of one request (REQUEST_FIELDS' names), and of the whole study.json: a key not
#: listed (a misspelt ``seedz``, a hand-added field) is refused, never ignored.
REQUEST_KEYS = tuple(name for name, *_ in REQUEST_FIELDS)
STUDY_KEYS = ("format", *REQUEST_KEYS, "history")


def check_manifest(d) -> str | None:
    """What is wrong with the study manifest `d` (None if nothing): an unknown key (with its
    path and the known key it was probably meant to be), its format, every request field with
    its type and range, and each earlier request in ``history``."""
    if not isinstance(d, dict):
        return f"a JSON {type(d).__name__}, not an object"
    problem = unknown_key(d, STUDY_KEYS)
    if problem:
        return problem
    if d.get("format") != STUDY_FORMAT:
        return f"field 'format': {d.get('format')!r} is not {STUDY_FORMAT!r}"
    history = d.get("history", [])
    if not isinstance(history, list):
        return f"field 'history': must be a list of earlier requests, got a {type(history).__name__}"
    for where, req in [("", d)] + [(f"history[{i}].", h) for i, h in enumerate(history)]:
        if not isinstance(req, dict):
            return f"field '{where.rstrip('.')}': must be an object"
        if where and (problem := unknown_key(req, REQUEST_KEYS, where)):
            return problem
        for name, required, ok, what in REQUEST_FIELDS:
            if name not in req:
                if required:
                    return f"field '{where}{name}': missing"
            elif not ok(req[name]):
                return f"field '{where}{name}': must be {what}, got {req[name]!r:.60}"
    return None


def read_manifest(store: Store) -> dict | None:
    """STORE/study.json checked field by field (None if the store has none); StoreError naming
    the file, the field, the problem and what to do."""
    data = store.manifest()
    problem = None if data is None else check_manifest(data)
    if problem:
        raise StoreError(f"{store.path / 'study.json'}: not a study manifest ({problem}); {MANIFEST_HINT}")
    return data


def write_manifest(store: Store, request: dict, executor: str) -> None:
    """Write STORE/study.json for `request` (the study's arguments) run by `executor` (its name),
    keeping the manifests of earlier invocations in its history."""
    old = read_manifest(store)
    history = []
    if old is not None:
        history = list(old.get("history", [])) + [{k: v for k, v in old.items() if k not in ("history", "format")}]
    store.write_manifest({"format": STUDY_FORMAT, **request, "executor": executor,
                          "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                          "host": platform.node(), "versions": library_versions(EXECUTOR_LIBRARIES),
                          "history": history})
