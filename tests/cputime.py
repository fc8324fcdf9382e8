"""Opt-in pytest plugin: the CPU seconds each test costs, to plan the suite's wall time.

`pytest --cpu-times FILE` records, for every test, its setup + call + teardown in CPU seconds of
the whole process tree (this process's time.process_time, its reaped children's
resource.getrusage RUSAGE_CHILDREN, and its live descendants' psutil cpu_times), and its wall
seconds. Under pytest-xdist each worker appends
to FILE.<worker>; the controller merges them into FILE, a table sorted by CPU, with totals per
test file, and FILE.groups.json, the CPU of each group xdist sends to one worker (`group_of`):
copied to tests/scope_costs.json, it orders the next runs' groups, heaviest first. CPU seconds do not depend on how busy the machine is, wall seconds do.
"""

from __future__ import annotations

import json
import os
import resource
import time
from collections import defaultdict
from pathlib import Path

import pytest


#: each group's measured seconds, the order in which .ci/run's workers take the groups (conftest.py)
COSTS_FILE = Path(__file__).with_name("scope_costs.json")


def group_of(nodeid: str) -> str:
    """The unit xdist sends to one worker (.ci/run; tests/conftest.py): a test module (its
    module-scoped fixtures are built once), except the docs pages, each its own unit (each runs
    in a fresh copy of the repository)."""
    module = nodeid.split("::", 1)[0]
    if module.endswith("tests/test_docs.py") and "[" in nodeid:
        return nodeid
    return module


def pytest_addoption(parser):
    parser.addoption("--cpu-times", metavar="FILE", default=None,
                     help="write each test's CPU seconds (own + children's) and wall seconds to FILE")


def _cpu() -> float:
    """CPU seconds of this process's tree so far: its own, its reaped children's (and theirs), and
    those of its descendants still alive (a pool's workers, a sandbox's spare worker), with what
    they reaped. A child that ends moves from the last term to the second, so the sum is steady."""
    import psutil

    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    total = time.process_time() + ch.ru_utime + ch.ru_stime
    try:
        children = psutil.Process().children(recursive=True)
    except psutil.Error:
        children = []
    for c in children:
        try:
            t = c.cpu_times()
            total += t.user + t.system + t.children_user + t.children_system
        except psutil.Error:  # ended meanwhile: counted once reaped
            pass
    return total


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    path = item.config.getoption("--cpu-times")
    if not path:
        yield
        return
    c0, w0 = _cpu(), time.perf_counter()
    yield
    cpu, wall = _cpu() - c0, time.perf_counter() - w0
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    with open(f"{path}.{worker}", "a") as f:
        f.write(json.dumps({"test": item.nodeid, "group": group_of(item.nodeid), "cpu": round(cpu, 3),
                            "wall": round(wall, 3), "worker": worker}) + "\n")


def _merge(path: str) -> None:
    rows = []
    for part in sorted(Path(path).parent.glob(Path(path).name + ".*")):
        rows += [json.loads(line) for line in part.read_text().splitlines() if line.strip()]
        part.unlink()
    if not rows:
        return
    rows.sort(key=lambda r: -r["cpu"])
    files = defaultdict(lambda: [0.0, 0.0, 0])
    workers = defaultdict(lambda: [0.0, 0.0])
    for r in rows:
        f = files[r["test"].split("::")[0]]
        f[0] += r["cpu"]; f[1] += r["wall"]; f[2] += 1
        workers[r["worker"]][0] += r["cpu"]; workers[r["worker"]][1] += r["wall"]
    out = [f"total: {len(rows)} tests, {sum(r['cpu'] for r in rows):.1f} s CPU, "
           f"{sum(r['wall'] for r in rows):.1f} s wall (summed over workers)"]
    out += [f"worker {w}: {c:.1f} s CPU, {wl:.1f} s wall" for w, (c, wl) in sorted(workers.items())]
    out += ["", "per file: CPU s, wall s, tests"]
    out += [f"{c:9.1f} {wl:9.1f} {n:5d}  {name}" for name, (c, wl, n) in sorted(files.items(), key=lambda kv: -kv[1][0])]
    out += ["", "per test: CPU s, wall s, worker"]
    out += [f"{r['cpu']:9.2f} {r['wall']:9.2f} {r['worker']:>5}  {r['test']}" for r in rows]
    Path(path).write_text("\n".join(out) + "\n")
    groups = defaultdict(float)
    for r in rows:
        groups[r.get("group") or r["test"].split("::")[0]] += r["cpu"]
    Path(path + ".groups.json").write_text(json.dumps(
        {g: round(c, 1) for g, c in sorted(groups.items(), key=lambda kv: -kv[1])}, indent=0) + "\n")


def pytest_sessionfinish(session, exitstatus):
    path = session.config.getoption("--cpu-times")
    if path and not os.environ.get("PYTEST_XDIST_WORKER"):
        _merge(path)
