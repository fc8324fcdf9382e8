"""Issue 39: a plugin that runs into its worker's resource limits (adapters.confine: address
space, processes of its own uid, open files) fails its own run only, named, and the study goes
on; the processes it started do not outlive its run. And a spare worker dropped while a Ctrl-C
lands is ended all the same (`sandbox.drop_spare`)."""

from __future__ import annotations

import json
import os
import signal

import psutil
import pytest

import limits_plugins as lp
from adapters.confine import PROCESSES

BUDGET = 20
PLUGINS = [f"limits_plugins:{c.__name__}" for c in (lp.AllocatesPastItsMemory, lp.ForksUntilRefused,
                                                     lp.OpensUntilRefused)]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    from femu.studies.study import run_study

    result = run_study([*PLUGINS, "random-search"], "0", BUDGET, tmp_path_factory.mktemp("limits") / "s", workers=0,
                       progress=False)
    return {r.optimizer: r for r in result.runs}


def test_the_study_goes_on_past_the_plugins_that_hit_their_limits(runs):
    honest = runs["random-search"]
    assert honest.status == "ok" and honest.n_evals == BUDGET and honest.verified
    for name in PLUGINS:  # each one's own run failed, under its own name, after the one evaluation it made
        assert runs[name].status == "failed" and runs[name].n_evals == 1 and runs[name].sandbox["limits"], name


def test_a_plugin_past_its_memory_limit_fails_with_a_memory_error(runs):
    r = runs[PLUGINS[0]]
    assert "MemoryError" in r.error and "no address-space limit" not in r.error, r.error


def test_a_fork_bomb_is_bounded_by_its_process_limit_and_outlives_nothing(runs):
    r = runs[PLUGINS[1]]
    pids = json.loads(next(line for line in r.output.splitlines() if line.startswith("FORKED "))[7:])
    soft, hard = (int(v) for v in next(line for line in r.output.splitlines() if line.startswith("NPROC ")).split()[1:])
    if r.sandbox["own_uid"]:  # RLIMIT_NPROC (the sandbox's hard limit) counts the processes of its own uid
        assert soft == hard == PROCESSES
        assert "BlockingIOError" in r.error and 0 < len(pids) < lp.ForksUntilRefused.LOWERED, (r.error[:300], pids)
    else:  # not root: no uid of its own, no process limit; the record says so and it bounded itself
        assert "no process limit" in r.error
    alive = []
    for pid in pids:
        try:
            if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                alive.append(pid)
        except psutil.NoSuchProcess:
            pass
    assert alive == [], f"{len(alive)} of the {len(pids)} processes it forked outlived its run"


def test_a_plugin_past_its_open_file_limit_fails_named(runs):
    r = runs[PLUGINS[2]]
    assert "Too many open files" in r.error and "no open-file limit" not in r.error, r.error


def test_a_spare_dropped_while_a_ctrl_c_lands_is_ended_and_the_interrupt_raised_after(monkeypatch, ctrl_c_is_pythons):
    from adapters import sandbox

    sandbox.drop_spare()
    sandbox.fork_spare()
    spare = sandbox._spare
    assert spare is not None and os.path.exists(spare.output_path)
    pid, output = spare.pid, spare.output_path
    freeze = sandbox._Worker.freeze

    def pressed(self):  # a Ctrl-C lands as the spare is stopped
        os.kill(os.getpid(), signal.SIGINT)
        freeze(self)

    monkeypatch.setattr(sandbox._Worker, "freeze", pressed)
    with pytest.raises(KeyboardInterrupt):
        sandbox.drop_spare()
    assert sandbox._spare is None and spare.conn.closed and not os.path.exists(output)
    try:
        assert psutil.Process(pid).status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        pass


def test_a_worker_makes_no_tcp_connection_where_landlock_scopes_the_network():
    """Landlock ABI 4 refuses TCP connect and bind to the worker; the record says whether it held
    (an older kernel: not, and the plugin connects: the record and docs/plugins.md say so)."""
    import socket

    import adapters
    from adapters.variants import make_problem

    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(4)
        r = adapters.run("limits_plugins:ConnectsOut", make_problem("paper"), BUDGET, 0,
                         port=listener.getsockname()[1])
    found = json.loads(next(line for line in r.output.splitlines() if line.startswith("NET "))[4:])
    assert r.status == "ok" and r.sandbox["network"] == (r.sandbox["filesystem"] and r.sandbox["landlock_abi"] >= 4)
    if r.sandbox["network"]:
        assert found == {"connect": "PermissionError", "bind": "PermissionError"}, found
    else:
        assert found["connect"] == "ok", found
