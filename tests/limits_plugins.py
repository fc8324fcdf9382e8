"""Plugins that run into their worker's resource limits (adapters.confine), for
tests/test_limits.py. Each fails its own run; none is a danger where the limit holds, and each
bounds itself where it does not (a machine without the limit: the record says so)."""

from __future__ import annotations

import json
import os
import resource

import numpy as np


class _Plugin:
    anytime = batch = True

    def min_budget(self, n_var, **options):
        return 1


class AllocatesPastItsMemory(_Plugin):
    """Asks for 1 GiB more address space than its limit allows (never touched: np.empty)."""

    name = "allocates-past-its-memory"

    def minimize(self, objective, bounds, budget, rng):
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft == resource.RLIM_INFINITY:
            raise RuntimeError("no address-space limit")
        objective(rng.uniform(bounds[0], bounds[1], (1, len(bounds[0]))))
        np.empty(soft + (1 << 30), dtype=np.uint8)  # MemoryError where the limit holds


class ForksUntilRefused(_Plugin):
    """Reports its process limit (``NPROC soft hard``), lowers its soft limit to `LOWERED` (a
    process may lower its own: so that the test forks tens of processes, not hundreds, on a
    loaded machine), then forks children that wait until the kernel refuses (RLIMIT_NPROC
    counts the processes of its uid, its own under root) or it has forked 2,000 (no such limit
    here); prints ``FORKED [pids]`` and lets the refusal end its run."""

    name = "forks-until-refused"
    LOWERED = 40

    def minimize(self, objective, bounds, budget, rng):
        import signal

        objective(rng.uniform(bounds[0], bounds[1], (1, len(bounds[0]))))
        soft, hard = resource.getrlimit(resource.RLIMIT_NPROC)
        print("NPROC", soft, hard, flush=True)
        resource.setrlimit(resource.RLIMIT_NPROC, (min(self.LOWERED, hard), hard))
        pids = []
        try:
            while len(pids) < 2000:
                pid = os.fork()
                if pid == 0:
                    try:
                        while True:
                            signal.pause()
                    finally:
                        os._exit(0)
                pids.append(pid)
            raise RuntimeError("forked 2000 processes: no process limit")
        finally:
            print("FORKED", json.dumps(pids), flush=True)


class OpensUntilRefused(_Plugin):
    """Opens /dev/null until the kernel refuses (RLIMIT_NOFILE) or 100,000 are open."""

    name = "opens-until-refused"

    def minimize(self, objective, bounds, budget, rng):
        objective(rng.uniform(bounds[0], bounds[1], (1, len(bounds[0]))))
        files = []
        while len(files) < 100_000:
            files.append(os.open(os.devnull, os.O_RDONLY))
        raise RuntimeError("opened 100000 files: no open-file limit")


class ConnectsOut(_Plugin):
    """Connects to the TCP port `port` on this machine and binds one of its own; prints
    ``NET {"connect": ..., "bind": ...}`` (ok or the error's name), then evaluates honestly."""

    name = "connects-out"

    def minimize(self, objective, bounds, budget, rng, port=0):
        import socket

        def probe(action):
            try:
                action()
                return "ok"
            except OSError as exc:
                return type(exc).__name__

        def connect():
            with socket.create_connection(("127.0.0.1", port), timeout=5):
                pass

        def bind():
            with socket.socket() as s:
                s.bind(("127.0.0.1", 0))
                s.listen(1)

        print("NET", json.dumps({"connect": probe(connect), "bind": probe(bind)}), flush=True)
        objective(rng.uniform(bounds[0], bounds[1], (budget, len(bounds[0]))))
