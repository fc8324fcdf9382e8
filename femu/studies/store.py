"""The result store of a study: a directory with one JSON file per finished run.

    STORE/study.json             what the study was asked to run (written at start)
    STORE/runs/<key>.json        one RunResult (format femu.run/1), written atomically
    STORE/runs/<key>.claim       the process running that run now (pid, host, its start time)

A run's key is ``<variant>__<optimizer>__b<budget>__s<seed>`` (a suite id's ``/`` as ``+``). Files are written to a
temporary name in the same directory and renamed into place, so a killed study leaves only
whole records (and at most a hidden ``.<key>.json.*.tmp`` file, which is ignored); a study
started again skips every key already present. A study claims each run before it starts it
(a claim file created exclusively), so two studies on one store never run the same run; a
claim left by a process that is gone (a kill -9, a crash; also a pid since reused by another
process, told apart by its start time) is stale and taken over, with a warning.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import math
import os
import socket
import tempfile
import time
import warnings
from contextlib import contextmanager
from pathlib import Path
from urllib.parse import quote

import secrets

import psutil

from adapters.capabilities import CAPABILITIES
from adapters.harness import RECORD_FORMAT, RunResult
from fe_problem.jsonutil import dumps, read_json_file, unknown_key
from fe_problem.model.validate import is_number, shown


#: Seconds after which a claim file that cannot be read counts as stale.
UNREADABLE_CLAIM_S = 10.0


class StoreError(ValueError):
    """An unreadable store or record; the message names the file."""


#: The statuses a run record can have (adapters.harness.RunResult).
STATUSES = ("ok", "stopped", "failed", "timeout")
#: What to do about a damaged record.
REDO_HINT = "delete the file and run the same `femu study` command again to redo that run"


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v) -> bool:
    return is_number(v)  # a finite int or float, not a bool; an int too large for a float is not


#: How far below 0 a stored best J may be: the rounding of 1 - MAC in records made before J was
#: clamped at 0 (down to -3e-15 was seen); anything further below is not a J.
J_ROUNDING = 1e-12


#: The keys of a run record (format femu.run/1): RunResult's fields, defined there once. Records
#: written before a field existed lack it (it reads as its default); a key not listed here
#: (a misspelt ``best_fx``, a hand-added field) is refused, never ignored.
RECORD_KEYS = (*RunResult.__dataclass_fields__, "mac")
#: The store's secret key for its records' MACs (`Store.sign`): made with the store, mode 0600,
#: read by the evaluating side only (a worker may not read the store: adapters.confine).
KEY_FILE = ".key"
#: The store's blind secret (`Store.blind_secret`, femu.studies.blind): mode 0600, never sent to a worker.
BLIND_FILE = ".blind"
#: The keys of a record's ``capabilities`` object (adapters.capabilities).
CAPABILITY_KEYS = CAPABILITIES


def check_record(d, key: str) -> str | None:
    """What is wrong with the run record `d` stored under `key` (None if nothing): an unknown
    key (with its path and the known key it was probably meant to be), every field of format
    femu.run/1 with its type and range, and the key it must be stored under."""
    if not isinstance(d, dict):
        return f"a JSON {type(d).__name__}, not an object"
    problem = unknown_key(d, RECORD_KEYS)
    if problem is None and isinstance(d.get("capabilities"), dict):
        problem = unknown_key(d["capabilities"], CAPABILITY_KEYS, "capabilities.")
    if problem:
        return problem
    if d.get("format", RECORD_FORMAT) != RECORD_FORMAT:
        return f"field 'format': {d.get('format')!r} is not {RECORD_FORMAT!r}"
    for name in ("optimizer", "problem", "variant"):
        if not isinstance(d.get(name), str) or not d.get(name):
            return f"field {name!r}: must be a non-empty string, got {shown(d.get(name))}"
    checks = (("seed", _is_int(d.get("seed")) and d.get("seed", -1) >= 0, "an integer >= 0"),
              ("budget", _is_int(d.get("budget")) and d.get("budget", 0) >= 1, "an integer >= 1"),
              ("n_evals", _is_int(d.get("n_evals")) and 0 <= d.get("n_evals", -1) <= max(d["budget"], 0)
               if _is_int(d.get("budget")) else False, "an integer from 0 to the budget"),
              ("best_f", d.get("best_f") is None or (_is_num(d["best_f"]) and d["best_f"] >= -J_ROUNDING),
               f"a finite number >= 0 (J is a sum of squares; -{J_ROUNDING:g} allowed for rounding) or null"),
              ("status", d.get("status") in STATUSES, f"one of {', '.join(STATUSES)}"),
              ("options", isinstance(d.get("options", {}), dict), "an object"),
              ("best_x", isinstance(d.get("best_x", []), list) and all(_is_num(v) for v in d.get("best_x", [])),
               "a list of finite numbers"),
              ("trace", _trace_ok(d.get("trace", [])), "a list of [n_evals, f] pairs, n_evals increasing"))
    for name, ok, need in checks:
        if not ok:
            return f"field {name!r}: must be {need}, got {shown(d.get(name))}"
    if not (d.get("f_opt") is None or _is_num(d["f_opt"])):
        return f"field 'f_opt': must be a finite number or null, got {shown(d.get('f_opt'))}"
    for name in ("wall_s", "cpu_s", "fe_s", "fe_cpu_s", "opt_cpu_s"):
        if not (_is_num(d.get(name, 0.0)) and d.get(name, 0.0) >= 0):
            return f"field {name!r}: must be a number of seconds >= 0, got {shown(d.get(name))}"
    if not (_is_int(d.get("n_jacobians", 0)) and d.get("n_jacobians", 0) >= 0):
        return f"field 'n_jacobians': must be an integer >= 0, got {shown(d.get('n_jacobians'))}"
    if d.get("x0", "none") not in ("none", "all"):
        return f"field 'x0': must be none or all, got {shown(d.get('x0'))}"
    for name, ok, need in (("error", d.get("error") is None or isinstance(d["error"], str), "a string or null"),
                           ("host", isinstance(d.get("host", ""), str), "a string"),
                           ("verified", isinstance(d.get("verified", False), bool), "true or false"),
                           ("output", isinstance(d.get("output", ""), str), "a string"),
                           ("distribution", d.get("distribution") is None or isinstance(d["distribution"], str),
                            "a string or null"),
                           ("distribution_version", d.get("distribution_version") is None
                            or isinstance(d["distribution_version"], str), "a string or null"),
                           ("effective_options", isinstance(d.get("effective_options", {}), dict), "an object"),
                           ("suite_version", d.get("suite_version") is None or isinstance(d["suite_version"], str),
                            "a string or null"),
                           ("capabilities", isinstance(d.get("capabilities", {}), dict)
                            and all(isinstance(v, bool) for v in d.get("capabilities", {}).values()),
                            "an object of capability -> true or false"),
                           ("versions", isinstance(d.get("versions", {}), dict), "an object of library -> version"),
                           ("problem_source", d.get("problem_source") is None or isinstance(d["problem_source"], dict),
                            "an object (a user problem's files and their SHA-256) or null"),
                           ("sandbox", isinstance(d.get("sandbox", {}), dict), "an object (what confined its worker)"),
                           ("blind", isinstance(d.get("blind", False), bool), "true or false"),
                           ("f_opt_kind", d.get("f_opt_kind") is None or isinstance(d["f_opt_kind"], str),
                            "a string or null"),
                           ("f_opt_precision", d.get("f_opt_precision") is None or _is_num(d["f_opt_precision"]),
                            "a finite number or null"),
                           ("f_start", d.get("f_start") is None or _is_num(d["f_start"]), "a finite number or null"),
                           ("mac", isinstance(d.get("mac", ""), str), "a string (the record's HMAC)")):
        if not ok:
            return f"field {name!r}: must be {need}, got {shown(d.get(name))}"
    expected = run_key(d["variant"], d["optimizer"], d["budget"], d["seed"])
    if expected != key:
        return f"its fields (variant, optimizer, budget, seed) make the key {expected!r}, not the file's name {key!r}"
    return None


def _trace_ok(trace) -> bool:
    if not isinstance(trace, list):
        return False
    last = 0
    for entry in trace:
        if not (isinstance(entry, list) and len(entry) == 2 and _is_int(entry[0]) and entry[0] >= last
                and _is_num(entry[1])):
            return False
        last = entry[0]
    return True


def _started(pid: int) -> float | None:
    """The start time (s since the epoch) of process `pid`, None if it is gone."""
    try:
        return psutil.Process(pid).create_time()
    except psutil.Error:
        return None


def _claim_started(path: Path) -> float | None:
    """The owner's start time a claim file records (None: not recorded, older claims)."""
    try:
        started = json.loads(path.read_text()).get("started")
    except (OSError, ValueError, AttributeError):
        return None
    return float(started) if isinstance(started, (int, float)) and not isinstance(started, bool) else None


#: Characters a name keeps in a run's file name; every other one is percent-encoded.
_SAFE_NAME = "-_."
#: The longest key kept as it is (a file name has at most 255 bytes, with room for suffixes).
MAX_KEY_CHARS = 200


def safe_name(text: str, keep: str = "") -> str:
    """`text` as a piece of a file name: letters, digits and ``-_.`` (and `keep`) as they are,
    every other character percent-encoded (``/`` as ``%2F``, a plugin's ``module:Class`` colon as
    ``%3A``: no file system or archive refuses the name), so that a name from user input (an
    optimizer's entry point named ``../../escaped``) can neither leave the directory nor collide
    with another name; a leading dot is encoded too (no hidden files)."""
    out = quote(str(text), safe=_SAFE_NAME + keep)
    return "%2E" + out[1:] if out.startswith(".") else out


def run_key(variant: str, optimizer: str, budget: int, seed: int) -> str:
    """The key (file stem) of one run in a store: ``VARIANT__OPTIMIZER__bBUDGET__sSEED``; the
    slashes of a suite id (``hframe-freq/12/1``) become ``+`` (``hframe-freq+12+1``), and the
    names are made safe file-name pieces (`safe_name`); a key longer than MAX_KEY_CHARS keeps
    its start and a SHA-256 of the whole."""
    key = f"{safe_name(variant.replace('/', '+'), '+')}__{safe_name(optimizer)}__b{int(budget)}__s{int(seed)}"
    if len(key) > MAX_KEY_CHARS:
        key = f"{key[:MAX_KEY_CHARS - 18]}~{hashlib.sha256(key.encode()).hexdigest()[:16]}"
    return key


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
        self.skipped: list[str] = []  # the damaged records the last runs(skip_invalid=True) left out
        if self.path.exists() and not self.path.is_dir():
            raise StoreError(f"{self.path}: a store is a directory, this is a file")

    @property
    def runs_dir(self) -> Path:
        return self.path / "runs"

    def keys(self) -> set[str]:
        """Keys of the finished runs (a record a store of an earlier version wrote under a name
        with ':' counts under its key: `record_path`)."""
        if not self.runs_dir.is_dir():
            return set()
        return {p.stem.replace(":", "%3A") for p in self.runs_dir.glob("*.json")}

    def record_path(self, key: str) -> Path:
        """The file of run `key`'s record: ``runs/<key>.json``, or the name with ':' an earlier
        version gave a plugin's run (``module:Class`` kept its colon) if that file is the one there."""
        path = self.runs_dir / f"{key}.json"
        if "%3A" in key and not path.exists():
            legacy = self.runs_dir / f"{key.replace('%3A', ':')}.json"
            if legacy.exists():
                return legacy
        return path

    def write(self, result: RunResult) -> Path:
        """Store one run's record (atomically), with its MAC (`sign`); StoreError if the store
        cannot be written."""
        key = run_key(result.variant, result.optimizer, result.budget, result.seed)
        path, old = self.runs_dir / f"{key}.json", self.record_path(key)
        with self._writing():
            record = json.loads(dumps(result.to_dict()))  # signed as it will be read back
            atomic_write_json(path, dict(record, mac=self.sign(record, make=True)))
            if old != path:  # an earlier version's name of this run (with ':'): one record per run
                old.unlink(missing_ok=True)
        return path

    def _key(self, make: bool = False) -> bytes | None:
        """The store's secret key (STORE/.key, 32 random bytes, mode 0600), made when `make` and
        missing; None when there is none."""
        return self._secret(KEY_FILE, make, "key", "a changed key makes every record unverifiable")

    def blind_secret(self, make: bool = False) -> bytes | None:
        """The store's blind secret (STORE/.blind, 32 random bytes, mode 0600, made once when
        `make`): the seed of its blind instances' truths (femu.studies.blind); None when there is none."""
        return self._secret(BLIND_FILE, make, "blind secret",
                            "a changed secret makes other blind instances than its records were run on")

    def _secret(self, name: str, make: bool, what: str, why: str) -> bytes | None:
        """32 random bytes kept in STORE/`name` (mode 0600, created exclusively when `make`)."""
        path = self.path / name
        try:
            key = path.read_bytes()
        except FileNotFoundError:
            if not make:
                return None
            path.parent.mkdir(parents=True, exist_ok=True)
            try:
                fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
            except FileExistsError:  # another study on this store made it first
                return self._secret(name, False, what, why)
            with os.fdopen(fd, "wb") as fh:
                fh.write(secrets.token_bytes(32))
                fh.flush()
                os.fsync(fh.fileno())
            return self._secret(name, False, what, why)
        if len(key) != 32:
            raise StoreError(f"{path}: not this store's {what} (32 bytes); {why}")
        return key

    def sign(self, record: dict, make: bool = False) -> str | None:
        """HMAC-SHA256 of `record` (its canonical JSON, without its ``mac``) by the store's key;
        None when the store has no key (and `make` is False)."""
        key = self._key(make)
        if key is None:
            return None
        body = json.dumps({k: v for k, v in record.items() if k != "mac"}, sort_keys=True, separators=(",", ":"))
        return hmac.new(key, body.encode(), hashlib.sha256).hexdigest()

    def unsigned(self) -> list[str]:
        """Keys of records without a MAC in a store that has a key (written before the store
        signed its records, or stripped of it): reports flag them."""
        if self._key() is None:
            return []
        out = []
        for k in sorted(self.keys()):
            try:
                if "mac" not in read_json_file(self.runs_dir / f"{k}.json", StoreError):
                    out.append(k)
            except StoreError:
                pass
        return out

    @contextmanager
    def _writing(self):
        """OSError while writing into the store (read-only, full, a file in the way) as a
        StoreError naming --store and the reason."""
        try:
            yield
        except OSError as exc:
            raise self._write_error(exc) from None

    def _write_error(self, exc: OSError) -> StoreError:
        where = f": {exc.filename}" if exc.filename else ""
        return StoreError(f"--store {self.path}: cannot write in the store ({exc.strerror or exc}{where})")

    def claim(self, key: str) -> bool:
        """Claim run `key` for this process; False if a live process holds it already. A claim
        of a process that no longer runs on this host is stale: it is removed and retaken."""
        path = self.runs_dir / f"{key}.claim"
        for _ in range(2):
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                if not self._stale(path):
                    return False
                owner = self._owner(path)
                warnings.warn(f"{path}: run {key} was claimed by process {owner[0] if owner else '?'}, which ended "
                              f"without recording it (a study killed); running it again")
                path.unlink(missing_ok=True)
                continue
            except OSError as exc:  # a read-only place, a file in the way, a full disk
                raise self._write_error(exc) from None
            with os.fdopen(fd, "w") as fh:
                pid = os.getpid()
                fh.write(json.dumps({"pid": pid, "host": socket.gethostname(), "started": _started(pid)}))
            return True
        return False

    def release(self, key: str) -> None:
        """Remove this process's claim of run `key` (another process's claim is left alone)."""
        path = self.runs_dir / f"{key}.claim"
        if self._owner(path) == (os.getpid(), socket.gethostname()):
            path.unlink(missing_ok=True)

    def remove_stale_claims(self) -> list[str]:
        """Remove every claim of a process that is gone (a study killed before it could release
        them); the keys removed. A claim whose run was recorded is only left over (one warning
        for all); one whose run was not says so by name (the study that asks for it runs it).
        Live claims stay."""
        if not self.runs_dir.is_dir():
            return []
        gone = sorted(p for p in self.runs_dir.glob("*.claim") if self._stale(p))
        left_over = []
        for p in gone:
            if p.with_suffix(".json").exists():
                left_over.append(p.stem)
            else:
                owner = self._owner(p)
                warnings.warn(f"{p}: run {p.stem} was claimed by process {owner[0] if owner else '?'}, which ended "
                              f"without recording it (a study killed); the claim is removed and the run is done by "
                              f"the study that asks for it")
            p.unlink(missing_ok=True)
        if left_over:
            warnings.warn(f"{self.runs_dir}: removed {len(left_over)} stale claim{'s' if len(left_over) != 1 else ''} "
                          f"of recorded runs left by a study that was killed ({', '.join(left_over[:3])}"
                          f"{', ...' if len(left_over) > 3 else ''})")
        return [p.stem for p in gone]

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
        if host != socket.gethostname():
            return False
        started = _claim_started(path)
        # a pid is reused once its process is gone: the same pid with another start time is not the owner
        return not psutil.pid_exists(pid) or (started is not None and _started(pid) != started)

    def read(self, key: str) -> RunResult:
        """The run record stored under `key`; StoreError naming the file, the field and what
        to do if it is damaged or was edited into something that is not a record."""
        path = self.record_path(key)
        try:
            data = read_json_file(path, StoreError)
        except StoreError as exc:
            problem = str(exc).removeprefix(f"{path}: ")
        else:
            problem = check_record(data, key)
            if problem is None and isinstance(data.get("mac"), str) and \
                    not hmac.compare_digest(data["mac"], self.sign(data) or ""):
                problem = ("changed since it was written: its MAC does not match its content under this store's key "
                           "(or the key was changed)")
        if problem:
            hint = f"correct or remove that key, or {REDO_HINT}" if problem.startswith("unknown key") else REDO_HINT
            raise StoreError(f"{path}: not a readable run record ({problem}); {hint}")
        return RunResult.from_dict(data)

    def runs(self, skip_invalid: bool = False) -> list[RunResult]:
        """Every finished run, sorted by variant, optimizer, budget, seed. A damaged record
        raises StoreError (naming every damaged file), or with `skip_invalid` is left out and
        its message kept in `self.skipped`."""
        if not self.path.is_dir():
            raise StoreError(f"{self.path}: no such store (run `femu study ... --store {self.path}` first)")
        out, self.skipped = [], []
        for k in sorted(self.keys()):
            try:
                out.append(self.read(k))
            except StoreError as exc:
                self.skipped.append(str(exc))
        if self.skipped and not skip_invalid:
            more = f" (and {len(self.skipped) - 1} more damaged records)" if len(self.skipped) > 1 else ""
            raise StoreError(f"{self.skipped[0]}{more}; --skip-invalid goes on with the valid records")
        return sorted(out, key=lambda r: (r.variant, r.optimizer, r.budget, r.seed))

    def write_manifest(self, manifest: dict) -> None:
        """Write STORE/study.json (atomically); StoreError if the store cannot be written."""
        with self._writing():
            atomic_write_json(self.path / "study.json", manifest)

    def manifest(self):
        """STORE/study.json as parsed JSON (None if there is none); StoreError if it is no JSON.
        femu.studies.manifest.read_manifest checks its fields."""
        p = self.path / "study.json"
        if not p.exists():
            return None
        return read_json_file(p, StoreError)
