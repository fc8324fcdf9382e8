"""`femu --help` and `femu COMMAND --help` start at once (issue 25): building the parser loads
neither numpy nor scipy nor the physics, which load when a command runs; the public names of
the packages are still there, loaded on first use."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("numpy", "scipy", "matplotlib", "fe_problem.assembly", "fe_problem.diagnosis", "adapters.harness")


def loaded_after(code: str) -> list[str]:
    """The heavy modules a fresh interpreter holds after running `code`."""
    out = subprocess.run([sys.executable, "-c", code + "\nimport sys, json\nprint(json.dumps(sorted(sys.modules)))"],
                         capture_output=True, text=True, check=True)
    mods = json.loads(out.stdout.splitlines()[-1])
    return [m for m in mods if any(m == h or m.startswith(h + ".") for h in HEAVY)]


def test_building_every_commands_parser_loads_no_numpy_and_no_physics():
    assert loaded_after("from femu.cli import build_parser\nbuild_parser()") == []


@pytest.mark.parametrize("command", ["model", "suite", "study", "results", "report", "reproduce", "diagnose",
                                     "identify", "import", "export"])
def test_each_commands_help_answers_without_the_physics(command):
    code = f"import contextlib, io\nfrom femu.cli import main\ntry:\n    with contextlib.redirect_stdout(io.StringIO()):\n" \
           f"        main([{command!r}, '--help'])\nexcept SystemExit as e:\n    assert e.code == 0"
    assert loaded_after(code) == []


def test_the_public_names_load_on_first_use():
    import adapters
    import fe_problem as fp

    for name in fp.__all__:
        assert getattr(fp, name) is not None
    for name in adapters.__all__:
        assert getattr(adapters, name) is not None
    assert fp.sparse.ARPACK_TOL == 1e-10  # a submodule by attribute, as before
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        fp.nonexistent  # noqa: B018
    assert "diagnose" in dir(fp)
