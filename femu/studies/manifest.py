"""study.json: what each invocation of a study asked for, with the executor, the start time
(UTC), the host and the library versions; the latest request at the top, earlier ones (resumed
or extended studies) in ``history``."""

from __future__ import annotations

import platform
from datetime import datetime, timezone

from adapters.provenance import library_versions

from .store import Store

STUDY_FORMAT = "femu.study/1"

#: Distributions study.json records beside the run libraries (the executors' own).
EXECUTOR_LIBRARIES = ("dask", "distributed", "rich")


def write_manifest(store: Store, request: dict, executor: str) -> None:
    """Write STORE/study.json for `request` (the study's arguments) run by `executor` (its name),
    keeping the manifests of earlier invocations in its history."""
    old = store.manifest()
    history = []
    if old is not None:
        history = list(old.get("history", [])) + [{k: v for k, v in old.items() if k not in ("history", "format")}]
    store.write_manifest({"format": STUDY_FORMAT, **request, "executor": executor,
                          "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                          "host": platform.node(), "versions": library_versions(EXECUTOR_LIBRARIES),
                          "history": history})
