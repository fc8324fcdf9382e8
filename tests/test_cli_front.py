"""What a newcomer meets first (issue 23): `femu --version`, help texts that say what is required
and carry no developer text, and `import fe_problem` without the optional libraries."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from importlib.metadata import version
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_SCRIPT = Path(sys.executable).parent / "femu"  # the installed command
FEMU = [str(_SCRIPT)] if _SCRIPT.exists() else [sys.executable, "-m", "femu"]


def femu(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*FEMU, *args], capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, COLUMNS="100"))


def test_version_prints_the_installed_version_on_stdout():
    proc = femu("--version")
    assert proc.returncode == 0 and proc.stderr == ""
    assert proc.stdout == f"femu {version('femu-bench')} (femu-bench)\n"


def test_required_options_are_marked_in_the_help():
    out = femu("study", "--help").stdout
    for opt in ("--optimizers", "--seeds", "--budget", "--store"):
        block = out.split(f"  {opt} ", 1)[1].split("\n  --", 1)[0]
        assert "(required)" in block, f"{opt}: {block}"
    assert out.count("(required)") == 4  # the optional ones are not marked


def test_report_help_says_out_or_json_is_required_and_the_command_says_it_too(tmp_path):
    out = femu("report", "--help").stdout
    assert "one of them is required" in out
    assert "(required unless --json)" in out and "(required unless --out)" in " ".join(out.split())
    proc = femu("report", str(tmp_path))
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "--out DIR (the report), or --json" in proc.stderr


@pytest.mark.parametrize("command", ["model", "suite", "study", "results", "report", "reproduce", "diagnose",
                                     "identify", "import", "export"])
def test_help_texts_carry_no_developer_text(command):
    out = femu(command, "--help").stdout
    assert out.startswith(f"usage: femu {command}")
    for dev in ("ValueError", "FileNotFoundError", "femu.cli", "to_dict()", "`fe_problem.", "raises"):
        assert dev not in out, f"femu {command} --help: {dev!r}"


def test_the_help_names_the_space_frames_and_every_shipped_model():
    """`femu --help` covers space frames too, and `femu model --help` lists every shipped model
    (fe_problem.shipped_models: frame3d was missing)."""
    from fe_problem.model.io import shipped_models

    top = " ".join(femu("--help").stdout.split())
    assert "planar and space frames" in top and "planar frames:" not in top
    model = " ".join(femu("model", "--help").stdout.split())
    names = model.split("a shipped model name (", 1)[1].split(")", 1)[0].split(", ")
    assert sorted(names) == sorted(shipped_models()) and "frame3d" in names


def _python_without(blocked: tuple[str, ...], code: str) -> subprocess.CompletedProcess:
    """Run `code` in a fresh interpreter where importing any of `blocked` fails, as it would in a
    Python without those libraries (the system's, outside the project's environment)."""
    guard = textwrap.dedent(f"""\
        import sys
        class _Block:
            def find_spec(self, name, path=None, target=None):
                if name.split(".")[0] in {blocked!r}:
                    raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        sys.meta_path.insert(0, _Block())
    """)
    return subprocess.run([sys.executable, "-c", guard + code], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)


def test_fe_problem_imports_and_solves_without_the_optional_libraries():
    proc = _python_without(("pyuff", "joblib", "sdypy", "matplotlib", "rich", "dask"),
                           "import fe_problem as fp\nprint(round(float(fp.modal_analysis('hframe', 1)"
                           ".frequencies_hz[0]), 3))")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "56.287\n"


def test_fe_problem_without_numpy_says_how_to_install():
    proc = _python_without(("numpy",), "import fe_problem")
    assert proc.returncode == 1
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: fe_problem needs 'numpy'") and "pip install -e ." in last
