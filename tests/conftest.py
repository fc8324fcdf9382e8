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
