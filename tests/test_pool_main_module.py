"""A parallel batch never runs the user's main module again (issue 23).

The sparse path splits a batch over worker processes (fe_problem/_pool.py). Those workers must
not import `__main__`: a user's script without `if __name__ == "__main__":` would run again in
each of them, a script fed on standard input has no file to import, and a notebook's cells are
no module at all. Each way of running the same code is started in a fresh interpreter here; the
code prints a line at its top level, evaluates a batch on a 2-worker pool and prints the result.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import fe_problem as fp

#: The user's code, with no main guard. It asks for 2 processes and checks the pool ran.
SCRIPT = textwrap.dedent("""\
    import json
    import numpy as np
    import fe_problem as fp
    import fe_problem._pool
    print("TOP-LEVEL-RAN")
    system = fp.AffineModel(fp.regular_frame(3, 20), fp.element_moduli(fp.regular_frame(3, 20), lower=1.8e11, upper=2.4e11), workers=2)
    X = np.random.default_rng(0).uniform(0.9, 1.1, (6, len(system.parameters))) * system.x0
    lam, _ = system.eigen(X, 5)
    print("RESULT " + json.dumps({"lam": lam.tolist(), "workers": len(fe_problem._pool.worker_pids()),
                                  "path": system.path}))
""")


def _env() -> dict:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    env.pop("FEMU_SOLVER_WORKERS", None)
    return env


def _check(proc: subprocess.CompletedProcess) -> np.ndarray:
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout.splitlines()
    assert out.count("TOP-LEVEL-RAN") == 1, proc.stdout  # the workers did not run it again
    assert "Traceback" not in proc.stderr and "leaked" not in proc.stderr, proc.stderr
    assert proc.stderr.strip() == "", proc.stderr
    (line,) = [s for s in out if s.startswith("RESULT ")]
    got = json.loads(line[len("RESULT "):])
    assert got["path"] == "sparse" and got["workers"] == 1  # the batch did go to a worker
    return np.array(got["lam"])


def _in_process_reference() -> np.ndarray:
    m = fp.regular_frame(3, 20)
    system = fp.AffineModel(m, fp.element_moduli(m, lower=1.8e11, upper=2.4e11), workers=1)
    X = np.random.default_rng(0).uniform(0.9, 1.1, (6, len(system.parameters))) * system.x0
    return system.eigen(X, 5)[0]


@pytest.fixture(scope="module")
def reference() -> np.ndarray:
    return _in_process_reference()


def test_an_unguarded_script_runs_once_and_gives_the_in_process_values(tmp_path, reference):
    script = tmp_path / "user_script.py"
    script.write_text(SCRIPT)
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=_env(), capture_output=True,
                          text=True, timeout=300)
    assert np.array_equal(_check(proc), reference)  # bit-identical to one process


def test_a_script_on_standard_input(tmp_path, reference):
    proc = subprocess.run([sys.executable, "-"], input=SCRIPT, cwd=tmp_path, env=_env(), capture_output=True,
                          text=True, timeout=300)
    assert np.array_equal(_check(proc), reference)


def test_code_run_cell_by_cell_as_a_notebook_runs_it(tmp_path, reference):
    """A Jupyter kernel compiles each cell and executes it in the namespace of `__main__`, which
    has no file; the cells are split where a notebook user would split them."""
    lines = SCRIPT.splitlines(keepends=True)
    cells = ["".join(lines[:5]), "".join(lines[5:8]), "".join(lines[8:])]
    runner = textwrap.dedent("""\
        import json, sys, __main__
        cells = json.loads(sys.stdin.read())
        assert not hasattr(__main__, "__file__")
        for i, cell in enumerate(cells):
            exec(compile(cell, f"<cell {i}>", "exec"), __main__.__dict__)
    """)
    proc = subprocess.run([sys.executable, "-c", runner], input=json.dumps(cells), cwd=tmp_path, env=_env(),
                          capture_output=True, text=True, timeout=300)
    assert np.array_equal(_check(proc), reference)
