"""J does not depend on the BLAS thread count: the same suite problems built and evaluated in a
process with 1 and with 2 OpenBLAS threads give the same bits (fe_problem._threads pins one
thread inside building and evaluating; before, 25 of 126 suite ids differed by up to 2e-8)."""

import os
import subprocess
import sys

#: Ids that differed with 2 threads before the pin (a dense, a sparse-solver and a noisy one).
IDS = ("hframe-shape/48/1", "frame-shape/96/1", "hframe-shape-noisy/48/1")

SCRIPT = """
import sys
import numpy as np
from fe_problem.suite import suite_problem

if __name__ == "__main__":
    for pid in sys.argv[1:]:
        p = suite_problem(pid)
        X = np.random.default_rng(3).uniform(p.xl, p.xu, (4, p.n_var))
        print(pid, [v.hex() for v in p.evaluate(X)], p.least_squares(X[0]).f.hex(), float(p.f_opt).hex())
"""


def _values(threads: int, tmp_path) -> str:
    script = tmp_path / "evaluate.py"
    script.write_text(SCRIPT)
    env = dict(os.environ, OPENBLAS_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads))
    out = subprocess.run([sys.executable, str(script), *IDS], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_one_and_two_blas_threads_give_the_same_bits(tmp_path):
    one, two = _values(1, tmp_path), _values(2, tmp_path)
    assert len(one.splitlines()) == len(IDS)
    assert one == two
