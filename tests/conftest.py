"""Test session settings: one BLAS thread (fe_problem._threads, the one place that sets it),
imported before anything loads numpy."""

import fe_problem._threads  # noqa: F401
import pytest


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
