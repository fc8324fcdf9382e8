"""`.ci/run` stops with one clear message when it cannot install the system libraries (issue 23).

The machine's `id`, `dpkg`, `sudo` and `apt-get` are replaced by stubs on PATH: a user who is not
root, has no password-less sudo, and lacks the libraries. `apt-get` records any call.
"""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _stub(bin_dir: Path, name: str, body: str) -> None:
    path = bin_dir / name
    path.write_text("#!/bin/sh\n" + body + "\n")
    path.chmod(path.stat().st_mode | stat.S_IEXEC)


def _run(tmp_path: Path, sudo_ok: bool, installed: bool = False) -> tuple[subprocess.CompletedProcess, Path]:
    repo = tmp_path / "repo"
    (repo / ".ci").mkdir(parents=True)
    shutil.copy2(ROOT / ".ci" / "run", repo / ".ci" / "run")
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    calls = tmp_path / "apt-calls"
    _stub(bin_dir, "id", 'echo 1000')
    _stub(bin_dir, "dpkg", 'exit 0' if installed else 'exit 1')  # are the libraries installed?
    _stub(bin_dir, "sudo", 'if [ "$1" = -n ]; then shift; fi; exec "$@"' if sudo_ok
          else 'echo "sudo: a password is required" >&2; exit 1')
    _stub(bin_dir, "apt-get", f'echo "$@" >> {calls}; exit 100')
    _stub(bin_dir, "python3", 'echo "python3 reached" >&2; exit 3')  # a run past the libraries would say so
    env = {"PATH": f"{bin_dir}:/usr/bin:/bin", "HOME": str(tmp_path)}
    proc = subprocess.run(["bash", str(repo / ".ci" / "run")], env=env, capture_output=True, text=True, timeout=60)
    return proc, calls


def test_a_user_who_cannot_install_gets_one_line_and_no_apt_errors(tmp_path):
    proc, calls = _run(tmp_path, sudo_ok=False)
    assert proc.returncode == 1 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith(".ci/run: error: the system libraries libblas3 liblapack3")
    assert "run .ci/run as root or with sudo" in proc.stderr
    assert not calls.exists()  # apt-get was never tried


def test_with_sudo_a_failing_apt_get_is_one_line_too(tmp_path):
    proc, calls = _run(tmp_path, sudo_ok=True)
    assert proc.returncode == 1 and proc.stdout == ""
    assert proc.stderr == (".ci/run: error: apt-get could not install libblas3 liblapack3 libsuitesparse-dev "
                           "(its output: /tmp/femu-ci-apt.log)\n")
    assert calls.read_text().splitlines()[0] == "update -qq"  # tried through sudo


def test_a_user_who_has_the_libraries_goes_on_without_apt(tmp_path):
    proc, calls = _run(tmp_path, sudo_ok=False, installed=True)
    assert proc.returncode == 3 and proc.stderr == "python3 reached\n"  # on to the environment and pytest
    assert not calls.exists()
