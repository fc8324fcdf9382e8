"""Confinement of an optimizer's worker by the kernel's own means (issue 39).

`confine` is called in a worker (adapters.sandbox_worker) once it has settled its run's output
file and directory, before any of its optimizer's code is imported, and returns what held:

- ``limits``: resource limits (address space, processes of its uid, open files, file size, no
  core dump; CPU seconds once its run's time limit is known, `limit_cpu`);
- ``landlock_abi`` and ``filesystem``: a Landlock ruleset (where the kernel offers it) that lets
  it read only the import path, Python's installation and the system's directories (never the
  paths it is told to hide: a study's store, the FE package and its data), and write only its
  own temporary directory (and the directories named in `WRITABLE_ENV`, which the caller sets);
- ``signal_scope``: from Landlock ABI 6, no signal to a process outside its own domain;
- ``network``: from Landlock ABI 4, no TCP connection made or port bound (`_NET_TCP`); UDP
  and other socket families are not covered by Landlock;
- ``own_uid``: when the server runs as root, a uid of its own from `UID_BASE` (no capability
  left but CAP_DAC_OVERRIDE: Landlock, where it holds, alone decides file access): it cannot signal, ptrace or read the memory of another run's worker, its server or
  its evaluating process, and the server refuses its connections (SO_PEERCRED).

Where a mechanism is missing (another kernel, not root), the worker runs without it and the run's
record says so (`RunResult.sandbox`). The syscalls are made through ctypes: Python has no
binding of Landlock's three calls or of capset, and no well-kept package covers ABI 6's scopes.
"""

from __future__ import annotations

import ctypes
import os
import resource

#: The first uid of the range from which a root server gives each worker its own (uid = base +
#: the worker's pid, unique among live workers): far above any account a system creates.
UID_BASE = 1_900_000_000

#: Environment variable: directories (os.pathsep-separated) a worker may also read and write,
#: set by the user of the evaluating side (tests: their plugins leave pids and marks there).
WRITABLE_ENV = "FEMU_SANDBOX_RW"
#: Environment variable: paths a worker may not read though they are under a readable directory
#: (a study sets its store here; the evaluating side adds the FE package's directory).
HIDDEN_ENV = "FEMU_SANDBOX_HIDE"
#: Environment variable: ``off`` runs workers without Landlock (to debug a plugin's file access);
#: a study then needs --unconfined.
LANDLOCK_ENV = "FEMU_LANDLOCK"

#: Resource limits of a worker: bytes of address space (at least), processes and threads of its
#: own uid, open files, bytes of any file it writes.
ADDRESS_SPACE_BYTES = 16 << 30
PROCESSES = 512
OPEN_FILES = 1024
FILE_BYTES = 4 << 30

#: System directories a worker may read (and execute from), where they exist.
SYSTEM_DIRS = ("/usr", "/lib", "/lib64", "/lib32", "/bin", "/sbin", "/etc", "/opt", "/proc", "/sys", "/dev")

_SYS_LANDLOCK_CREATE_RULESET, _SYS_LANDLOCK_ADD_RULE, _SYS_LANDLOCK_RESTRICT_SELF = 444, 445, 446
_LANDLOCK_CREATE_RULESET_VERSION = 1
_LANDLOCK_RULE_PATH_BENEATH = 1
_LANDLOCK_SCOPE_SIGNAL = 2
#: Landlock's network rights (ABI 4): bind and connect on TCP ports; handled with no rule, both
#: are refused for every port.
_NET_TCP = 1 | 2
_PR_SET_NO_NEW_PRIVS, _PR_SET_KEEPCAPS, _PR_SET_DUMPABLE, _PR_GET_DUMPABLE = 38, 8, 4, 3
_CAP_DAC_OVERRIDE = 1
_PR_CAP_AMBIENT, _PR_CAP_AMBIENT_RAISE = 47, 2

# Landlock's filesystem rights (uapi/linux/landlock.h) and the ABI that added each
_EXECUTE, _WRITE_FILE, _READ_FILE, _READ_DIR = 1, 2, 4, 8
_WRITE_DIR = sum(1 << i for i in range(4, 13))  # remove, make char/dir/reg/sock/fifo/block/sym
_REFER, _TRUNCATE, _IOCTL_DEV = 1 << 13, 1 << 14, 1 << 15
_FILE_RIGHTS = _EXECUTE | _WRITE_FILE | _READ_FILE | _TRUNCATE | _IOCTL_DEV

_libc = None


def _c():
    global _libc
    if _libc is None:
        _libc = ctypes.CDLL(None, use_errno=True)
    return _libc


def landlock_abi() -> int:
    """The Landlock ABI version the kernel offers (0: none, or not Linux, or `LANDLOCK_ENV` off)."""
    if os.environ.get(LANDLOCK_ENV, "").lower() == "off":
        return 0
    try:
        v = _c().syscall(_SYS_LANDLOCK_CREATE_RULESET, None, ctypes.c_size_t(0),
                         ctypes.c_uint32(_LANDLOCK_CREATE_RULESET_VERSION))
    except (OSError, AttributeError):
        return 0
    return max(int(v), 0)


def _handled(abi: int) -> int:
    rights = _EXECUTE | _WRITE_FILE | _READ_FILE | _READ_DIR | _WRITE_DIR
    if abi >= 2:
        rights |= _REFER
    if abi >= 3:
        rights |= _TRUNCATE
    if abi >= 5:
        rights |= _IOCTL_DEV
    return rights


class _PathBeneath(ctypes.Structure):
    _pack_ = 1
    _fields_ = [("allowed_access", ctypes.c_uint64), ("parent_fd", ctypes.c_int32)]


def _add_rule(ruleset: int, path: str, rights: int) -> None:
    """Allow `rights` beneath `path` (a file: its file rights only); a missing path: nothing."""
    try:
        fd = os.open(path, os.O_PATH | os.O_CLOEXEC)
    except OSError:
        return
    try:
        if not os.path.isdir(path):
            rights &= _FILE_RIGHTS
        attr = _PathBeneath(rights, fd)
        if _c().syscall(_SYS_LANDLOCK_ADD_RULE, ctypes.c_int(ruleset), ctypes.c_int(_LANDLOCK_RULE_PATH_BENEATH),
                        ctypes.byref(attr), ctypes.c_uint32(0)) != 0:
            raise OSError(ctypes.get_errno(), f"landlock_add_rule {path}")
    finally:
        os.close(fd)


def _within(path: str, top: str) -> bool:
    return path == top or path.startswith(top.rstrip("/") + "/")


def _grant(ruleset: int, path: str, rights: int, hidden: list[str], depth: int = 0) -> None:
    """Allow `rights` beneath `path` but for the `hidden` paths under it: a directory that holds
    one is listed only (its entries' names readable), and each of its entries granted apart.
    Paths are taken as the real paths they lead to: a rule holds for an inode, and a symbolic
    link beside a hidden directory may lead into it."""
    path = os.path.realpath(path)
    inside = [h for h in hidden if _within(h, path)]
    if not inside:
        _add_rule(ruleset, path, rights)
        return
    if path in inside or depth > 16 or not os.path.isdir(path):
        return
    _add_rule(ruleset, path, _READ_DIR)
    try:
        entries = [e.path for e in os.scandir(path)]
    except OSError:
        return
    for entry in entries:
        _grant(ruleset, entry, rights, inside, depth + 1)


def _landlock(abi: int, readable: list[str], writable: list[str], hidden: list[str]) -> bool:
    """Restrict this process (and what it starts) to reading `readable`, reading and writing
    `writable`, never `hidden`; True once it holds."""
    handled = _handled(abi)
    size = 8 if abi < 4 else 16 if abi < 6 else 24  # struct landlock_ruleset_attr grew with the ABI
    attr = (ctypes.c_uint64 * 3)(handled, _NET_TCP if abi >= 4 else 0, _LANDLOCK_SCOPE_SIGNAL if abi >= 6 else 0)
    ruleset = _c().syscall(_SYS_LANDLOCK_CREATE_RULESET, ctypes.byref(attr), ctypes.c_size_t(size),
                           ctypes.c_uint32(0))
    if ruleset < 0:
        return False
    try:
        read = _EXECUTE | _READ_FILE | _READ_DIR
        for path in readable:
            _grant(ruleset, path, read, hidden)
        for path in writable:
            _grant(ruleset, path, handled, hidden)
        _c().prctl(_PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0)
        return _c().syscall(_SYS_LANDLOCK_RESTRICT_SELF, ctypes.c_int(ruleset), ctypes.c_uint32(0)) == 0
    finally:
        os.close(ruleset)


def _limits() -> None:
    """This process's resource limits (lowered, never raised)."""
    try:
        import psutil

        memory = max(ADDRESS_SPACE_BYTES, psutil.virtual_memory().total)
    except Exception:
        memory = ADDRESS_SPACE_BYTES
    for which, value in ((resource.RLIMIT_AS, memory), (resource.RLIMIT_NOFILE, OPEN_FILES),
                         (resource.RLIMIT_FSIZE, FILE_BYTES), (resource.RLIMIT_CORE, 0)):
        _lower(which, value)


def _lower(which: int, value: int) -> None:
    soft, hard = resource.getrlimit(which)
    hard = value if hard == resource.RLIM_INFINITY else min(hard, value)
    resource.setrlimit(which, (min(value, hard), hard))


def limit_cpu(seconds: int) -> None:
    """Limit this process's CPU to `seconds` (then SIGXCPU, SIGKILL a second later)."""
    _lower(resource.RLIMIT_CPU, int(seconds))


class _CapHeader(ctypes.Structure):
    _fields_ = [("version", ctypes.c_uint32), ("pid", ctypes.c_int)]


class _CapData(ctypes.Structure):
    _fields_ = [("effective", ctypes.c_uint32), ("permitted", ctypes.c_uint32), ("inheritable", ctypes.c_uint32)]


def _own_uid(keep_dac_override: bool) -> int | None:
    """Become uid `UID_BASE` + this pid (gid the same, no supplementary groups), keeping
    CAP_DAC_OVERRIDE alone when asked (under Landlock) and no other capability; the uid, or
    None when this process is not root (then nothing changes)."""
    if os.geteuid() != 0:
        return None
    uid = UID_BASE + os.getpid()
    os.setgroups([])
    os.setgid(uid)
    _c().prctl(_PR_SET_KEEPCAPS, int(keep_dac_override), 0, 0, 0)
    os.setresuid(uid, uid, uid)
    keep = (1 << _CAP_DAC_OVERRIDE) if keep_dac_override else 0
    data = (_CapData * 2)(_CapData(keep, keep, keep), _CapData(0, 0, 0))
    if _c().capset(ctypes.byref(_CapHeader(0x20080522, 0)), data) != 0:
        raise OSError(ctypes.get_errno(), "capset")
    _c().prctl(_PR_SET_KEEPCAPS, 0, 0, 0, 0)
    # ambient: kept by the programs it runs (a plugin's `python -c ...`), else they lose it at
    # execve and cannot reach what Landlock grants in a directory of another user
    if keep and _c().prctl(_PR_CAP_AMBIENT, _PR_CAP_AMBIENT_RAISE, _CAP_DAC_OVERRIDE, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_CAP_AMBIENT_RAISE)")
    return uid


def confine(readable: list[str], writable: list[str], hidden: list[str], tmp_dir: str | None) -> dict:
    """Confine this process (a worker, before its optimizer is imported); what held (module doc).
    `tmp_dir`: its own temporary directory (made the temporary directory of this process and
    what it starts, owned by its own uid)."""
    _limits()
    abi = landlock_abi()
    uid = UID_BASE + os.getpid() if os.geteuid() == 0 else None
    if tmp_dir is not None:
        if uid is not None:
            os.chown(tmp_dir, uid, uid)
        for name in ("TMPDIR", "TEMP", "TMP", "MPLCONFIGDIR", "XDG_CACHE_HOME", "XDG_CONFIG_HOME"):
            os.environ[name] = tmp_dir
        import tempfile

        tempfile.tempdir = tmp_dir
        writable = [tmp_dir, *writable]
    filesystem = bool(abi) and _landlock(abi, readable, [*writable, os.devnull], hidden)
    # CAP_DAC_OVERRIDE kept: Python and the plugins may sit in directories of root's alone (a
    # pyenv under /root, pytest's directories), and file access is Landlock's to decide (without
    # Landlock, the record says the filesystem is not confined)
    own = _own_uid(keep_dac_override=True)
    if own is not None:
        resource.setrlimit(resource.RLIMIT_NPROC, (PROCESSES, PROCESSES))  # its own uid's processes only
    return {"landlock_abi": abi, "filesystem": filesystem, "signal_scope": filesystem and abi >= 6,
            "network": filesystem and abi >= 4,
            "own_uid": own is not None, "limits": True}


def make_undumpable() -> bool:
    """Make this process (the evaluating side) not dumpable: no process without CAP_SYS_PTRACE
    may ptrace it or open its /proc/PID/mem; True once it holds."""
    try:
        _c().prctl(_PR_SET_DUMPABLE, 0, 0, 0, 0)
        return _c().prctl(_PR_GET_DUMPABLE, 0, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False
