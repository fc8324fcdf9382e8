"""Test session settings: one BLAS thread (fe_problem._threads, the one place that sets it),
imported before anything loads numpy."""

import fe_problem._threads  # noqa: F401
import pytest

#: `--cpu-times FILE`: each test's CPU seconds (tests/cputime.py)
pytest_plugins = ["cputime"]


@pytest.fixture(scope="module")
def random_search_store(tmp_path_factory):
    """A store of two short random-search runs made by `femu study`, for the tests that damage
    its records (a copy each: the fixture is shared within a module)."""
    from femu.cli import main

    s = tmp_path_factory.mktemp("rec") / "store"
    assert main(["study", "--optimizers", "random-search", "--seeds", "0-1", "--budget", "10", "--store", str(s),
                 "--workers", "0", "--no-progress"]) == 0
    return s


@pytest.fixture(scope="session", autouse=True)
def _plugins_may_write_in_tmp_path(tmp_path_factory):
    """The tests' plugins leave pids and marks in their test's tmp_path: a confined worker writes
    only its own temporary directory and the directories named in FEMU_SANDBOX_RW (adapters.confine),
    which the user of the evaluating side sets, as here. A study's store stays hidden even there
    (FEMU_SANDBOX_HIDE, set by the study: tests/test_confinement.py)."""
    import os

    from adapters.confine import WRITABLE_ENV

    os.environ[WRITABLE_ENV] = str(tmp_path_factory.getbasetemp())


# -- the order and grouping of the tests under pytest-xdist (.ci/run: --dist loadscope) --------------
def pytest_xdist_make_scheduler(config, log):
    """--dist loadscope with our units (cputime.group_of: a test module, its module-scoped fixtures
    built once, or one docs page), sent out in the order the workers collected them (below)."""
    if config.getvalue("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    from cputime import group_of

    class Grouped(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return group_of(nodeid)

    return Grouped(config, log)


def pytest_collection_modifyitems(config, items):
    """In an xdist worker, the units run heaviest first by tests/scope_costs.json (longest
    processing time first: the workers end together, no long unit is left for last); .ci/run
    passes --no-loadscope-reorder so that xdist keeps this order."""
    if not hasattr(config, "workerinput"):
        return
    import json

    from cputime import COSTS_FILE, group_of

    costs = json.loads(COSTS_FILE.read_text()) if COSTS_FILE.exists() else {}
    items.sort(key=lambda item: -costs.get(group_of(item.nodeid), 0.0))  # stable: a unit's tests keep their order


@pytest.fixture
def ctrl_c_is_pythons():
    """The precondition of the tests that press Ctrl-C in this process, whatever ran before in it
    (an xdist worker runs many modules; a library may have put its own SIGINT handler in at C
    level, where `signal.getsignal` does not see it, or blocked SIGINT in this thread, which a
    child process inherits across exec): SIGINT has Python's default handler, installed again, and
    is not blocked. Both are restored after."""
    import signal

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    blocked = signal.pthread_sigmask(signal.SIG_UNBLOCK, [signal.SIGINT])
    yield
    signal.signal(signal.SIGINT, previous)
    if signal.SIGINT in blocked:
        signal.pthread_sigmask(signal.SIG_BLOCK, [signal.SIGINT])
