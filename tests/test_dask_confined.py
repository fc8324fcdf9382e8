"""Issue 39: a study on a Dask cluster (`--scheduler`) confines its plugins as a local study does.
The plugin is told where the store is (an option: a path is no secret) and tries to read and
write it; the store sits in a directory on the import path, which a worker may otherwise read.
A cluster whose workers cannot be confined needs --unconfined, naming the worker."""

from __future__ import annotations

import json
import os
import sys

import pytest

from femu.studies.store import Store

PLUGIN = '''
import json
import os


def _probe(action):
    try:
        action()
        return "ok"
    except Exception as exc:
        return type(exc).__name__


def _write(path):
    with open(path, "w") as fh:
        fh.write("{}")


def _read(path):
    with open(path) as fh:
        fh.read()


class ReadsTheStoreAt:
    """Reads and writes the store it is pointed to, then evaluates its budget honestly."""

    name = "reads-the-store-at"

    def min_budget(self, n_var, **options):
        return 1

    def minimize(self, objective, bounds, budget, rng, store=""):
        found = {"read": _probe(lambda: _read(os.path.join(store, "study.json"))),
                 "list": _probe(lambda: os.listdir(os.path.join(store, "runs"))),
                 "write": _probe(lambda: _write(os.path.join(store, "runs", "planted.json")))}
        print("STORE", json.dumps(found), flush=True)
        objective(rng.uniform(bounds[0], bounds[1], (budget, len(bounds[0]))))
'''

NAME = "dask_store_plugin:ReadsTheStoreAt"


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A one-process Dask cluster that imports the plugin from a directory on its import path."""
    from dask.distributed import LocalCluster

    here = tmp_path_factory.mktemp("dask-plugins")
    (here / "dask_store_plugin.py").write_text(PLUGIN)
    sys.path.insert(0, str(here))  # spawned workers inherit this process's import path
    cluster = LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None)
    yield here, cluster
    cluster.close()
    sys.path.remove(str(here))


def test_a_plugin_on_a_dask_worker_can_neither_read_nor_write_the_store(cluster):
    from femu.studies.study import run_study

    here, dask = cluster
    store = here / "store"  # inside a readable directory (the import path): hidden all the same
    result = run_study([NAME, "random-search"], "0", 30, store, scheduler=dask.scheduler_address, progress=False,
                       options={NAME: {"store": str(store)}})
    runs = {r.optimizer: r for r in result.runs}
    assert result.executor.startswith("Dask") and result.counts() == {"ok": 2}
    r = runs[NAME]
    assert r.verified and r.n_evals == 30 and r.sandbox["session"] and r.sandbox["limits"], r.sandbox
    found = json.loads(next(line for line in r.output.splitlines() if line.startswith("STORE "))[6:])
    assert r.sandbox["filesystem"] == (r.sandbox["landlock_abi"] > 0)
    if r.sandbox["filesystem"]:
        # as in a local study (tests/test_confinement.py); its runs/ lists (names only) there too
        assert (found["read"], found["write"]) == ("PermissionError", "PermissionError"), found
    assert not (store / "runs" / "planted.json").exists()
    assert {x.optimizer for x in Store(store).runs()} == {NAME, "random-search"}


def _landlock(value):
    """Set (or, with None, clear) FEMU_LANDLOCK in the Dask worker's process."""
    if value is None:
        os.environ.pop("FEMU_LANDLOCK", None)
    else:
        os.environ["FEMU_LANDLOCK"] = value


def test_a_dask_worker_that_cannot_confine_needs_unconfined_named(cluster, tmp_path):
    from dask.distributed import Client

    from femu.studies.study import run_study

    _, dask = cluster
    with Client(dask.scheduler_address, set_as_default=False) as client:
        client.run(_landlock, "off")  # stands for a worker's kernel without Landlock
        try:
            with pytest.raises(ValueError, match="--unconfined: 1 worker.*no Landlock"):
                run_study(["random-search"], "0", 20, tmp_path / "s", scheduler=dask.scheduler_address, progress=False)
            assert not (tmp_path / "s" / "runs").exists() or not list((tmp_path / "s" / "runs").iterdir())
            result = run_study(["random-search"], "0", 20, tmp_path / "u", scheduler=dask.scheduler_address,
                               progress=False, unconfined=True)
        finally:
            client.run(_landlock, None)
    (r,) = result.runs
    # its record says what held (here the worker's sandbox server, started before the switch, still
    # confined it: the switch stands for the machine's answer, not for its kernel)
    assert r.status == "ok" and r.verified and r.sandbox["filesystem"] == (r.sandbox["landlock_abi"] > 0)
