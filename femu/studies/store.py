"""The result store of a study: a directory with one JSON file per finished run.

    STORE/study.json             what the study was asked to run (written at start)
    STORE/runs/<key>.json        one RunResult (format femu.run/1), written atomically
    STORE/runs/<key>.claim       the process running that run now (pid, host), while it runs

A run's key is ``<variant>__<optimizer>__b<budget>__s<seed>``. Files are written to a
temporary name in the same directory and renamed into place, so a killed study leaves only
whole records (and at most a hidden ``.<key>.json.*.tmp`` file, which is ignored); a study
started again skips every key already present. A study claims each run before it starts it
(a claim file created exclusively), so two studies on one store never run the same run; a
claim left by a process that is gone (a kill -9, a crash) is stale and taken over.
"""

from __future__ import annotations

import json
import os
import socket
import tempfile
import time
from pathlib import Path

import psutil

from adapters.harness import RunResult
from fe_problem.jsonutil import dumps


#: Seconds after which a claim file that cannot be read counts as stale.
UNREADABLE_CLAIM_S = 10.0


class StoreError(ValueError):
    """An unreadable store or record; the message names the file."""


def run_key(variant: str, optimizer: str, budget: int, seed: int) -> str:
    """The key (file stem) of one run in a store: ``VARIANT__OPTIMIZER__bBUDGET__sSEED``."""
    return f"{variant}__{optimizer}__b{int(budget)}__s{int(seed)}"


def _umask() -> int:
    mask = os.umask(0o022)  # reading the umask means setting it: put it straight back
    os.umask(mask)
    return mask


def atomic_write_json(path: Path, obj) -> None:
    """Write JSON so that `path` holds either the old content or the whole new one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes the file private: give it the usual mode
        with os.fdopen(fd, "w") as fh:
            fh.write(dumps(obj))
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


class Store:
    """A study's result directory."""

    def __init__(self, path: str | Path):
        if not str(path).strip():
            raise StoreError("--store: an empty path; name a directory (use . for the current one)")
        self.path = Path(path)
        if self.path.exists() and not self.path.is_dir():
            raise StoreError(f"{self.path}: a store is a directory, this is a file")

    @property
    def runs_dir(self) -> Path:
        return self.path / "runs"

    def keys(self) -> set[str]:
        """Keys of the finished runs."""
        if not self.runs_dir.is_dir():
            return set()
        return {p.stem for p in self.runs_dir.glob("*.json")}

    def write(self, result: RunResult) -> Path:
        path = self.runs_dir / f"{run_key(result.variant, result.optimizer, result.budget, result.seed)}.json"
        atomic_write_json(path, result.to_dict())
        return path

    def claim(self, key: str) -> bool:
        """Claim run `key` for this process; False if a live process holds it already. A claim
        of a process that no longer runs on this host is stale: it is removed and retaken."""
        path = self.runs_dir / f"{key}.claim"
        path.parent.mkdir(parents=True, exist_ok=True)
        for _ in range(2):
            try:
                fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                if not self._stale(path):
                    return False
                path.unlink(missing_ok=True)
                continue
            with os.fdopen(fd, "w") as fh:
                fh.write(json.dumps({"pid": os.getpid(), "host": socket.gethostname()}))
            return True
        return False

    def release(self, key: str) -> None:
        """Remove this process's claim of run `key` (another process's claim is left alone)."""
        path = self.runs_dir / f"{key}.claim"
        if self._owner(path) == (os.getpid(), socket.gethostname()):
            path.unlink(missing_ok=True)

    def claimed(self) -> set[str]:
        """Keys of the runs that some process has claimed and not yet released."""
        return {p.stem for p in self.runs_dir.glob("*.claim")} if self.runs_dir.is_dir() else set()

    @staticmethod
    def _owner(path: Path) -> tuple[int, str] | None:
        try:
            d = json.loads(path.read_text())
            return int(d["pid"]), str(d["host"])
        except (OSError, ValueError, KeyError, TypeError):  # half-written or damaged: no owner
            return None

    def _stale(self, path: Path) -> bool:
        """Whether the claim at `path` belongs to a process that is gone (on this host), or
        cannot be read at all. A claim from another host is trusted."""
        owner = self._owner(path)
        if owner is None:  # being written this instant, or damaged: stale only once it is old
            try:
                return time.time() - path.stat().st_mtime > UNREADABLE_CLAIM_S
            except FileNotFoundError:
                return True
        pid, host = owner
        return host == socket.gethostname() and not psutil.pid_exists(pid)

    def read(self, key: str) -> RunResult:
        path = self.runs_dir / f"{key}.json"
        try:
            data = json.loads(path.read_text())
            if not isinstance(data, dict):
                raise TypeError(f"a JSON {type(data).__name__}, not an object")
            return RunResult.from_dict(data)
        except (OSError, ValueError, TypeError) as exc:  # ValueError: bad JSON or field values
            raise StoreError(f"{path}: not a readable run record ({exc})") from None

    def runs(self) -> list[RunResult]:
        """Every finished run, sorted by variant, optimizer, budget, seed."""
        if not self.path.is_dir():
            raise StoreError(f"{self.path}: no such store (run `femu study ... --store {self.path}` first)")
        out = [self.read(k) for k in self.keys()]
        return sorted(out, key=lambda r: (r.variant, r.optimizer, r.budget, r.seed))

    def write_manifest(self, manifest: dict) -> None:
        atomic_write_json(self.path / "study.json", manifest)

    def manifest(self) -> dict | None:
        p = self.path / "study.json"
        if not p.exists():
            return None
        try:
            data = json.loads(p.read_text())
        except (OSError, ValueError) as exc:
            raise StoreError(f"{p}: not valid JSON ({exc})") from None
        if not isinstance(data, dict):
            raise StoreError(f"{p}: not a study manifest (a JSON {type(data).__name__}, not an object)")
        return data
