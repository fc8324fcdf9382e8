"""tests/cputime.py, the opt-in --cpu-times table: a test's CPU counts its children's, reaped or
still running, and the workers' tables merge into one (the numbers .ci/run's order is planned on)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent

BURN = r"""
import subprocess, sys, time

LOOP = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.4: pass\n"

def test_a_reaped_child():
    subprocess.run([sys.executable, "-c", LOOP], check=True)

def test_a_child_still_running_at_the_end(tmp_path):
    done = tmp_path / "burnt"
    p = subprocess.Popen([sys.executable, "-c", LOOP + f"open({str(done)!r}, 'w').close()\ntime.sleep(60)"])
    end = time.monotonic() + 120
    while not done.exists() and time.monotonic() < end:  # until the child has burnt its CPU (then it sleeps)
        time.sleep(0.05)
    assert done.exists()
    test_a_child_still_running_at_the_end.child = p

def test_nothing():
    pass

def test_zz_end_the_child():
    test_a_child_still_running_at_the_end.child.kill()
"""


@pytest.mark.parametrize("workers", [[], ["-n", "2", "--dist", "loadscope"]], ids=["one process", "xdist"])
def test_cpu_times_count_children_and_merge_the_workers(tmp_path, workers):
    (tmp_path / "test_burn.py").write_text(BURN)
    out = tmp_path / "cpu.txt"
    # a pytest of its own: not this run's xdist worker (PYTEST_XDIST_WORKER would make it write a worker's part only)
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    env["PYTHONPATH"] = os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")])
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "cputime", "-p", "no:cacheprovider",
                           "--rootdir", str(tmp_path), *workers, "--cpu-times", str(out), str(tmp_path / "test_burn.py")],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    table = out.read_text()
    cpu = {line.split()[-1].split("::")[-1]: float(line.split()[0]) for line in table.splitlines()
           if "::" in line and line.split()[0][0].isdigit()}
    assert cpu["test_a_reaped_child"] >= 0.35 and cpu["test_a_child_still_running_at_the_end"] >= 0.3, table
    assert cpu["test_nothing"] < 0.1, table
    assert table.startswith("total: 4 tests") and not list(tmp_path.glob("cpu.txt.gw*")) and \
        not list(tmp_path.glob("cpu.txt.main"))
    groups = json.loads((tmp_path / "cpu.txt.groups.json").read_text())
    assert list(groups) == ["test_burn.py"] and groups["test_burn.py"] >= 0.7
