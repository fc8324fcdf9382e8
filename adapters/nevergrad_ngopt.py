"""nevergrad-ngopt: nevergrad's NGOpt, the library's own algorithm selector (it picks and
chains optimizers from the dimension, the budget and the number of workers), through nevergrad's
ask/tell interface, in the unit cube."""

from __future__ import annotations

import random
import threading
import time
import warnings
from contextlib import contextmanager

import numpy as np

from .harness import seeded_global_rngs, unit_scaled


class NevergradNGOpt:
    """nevergrad's NGOpt with budget = the run's FE evaluations, asked and told in batches.

    Works in the unit cube (u = (x - xl) / (xu - xl)): an ``ng.p.Array`` bounded to [0, 1].
    Settings, for any n_var (2 to 200) and budget:
        num_workers (1): points NGOpt is asked for before it is told their values; each such
            group is one batch of FE evaluations. NGOpt chooses its algorithm knowing it, the
            dimension and the budget (a sequential budget gets other methods than a parallel
            one); 1 is nevergrad's default. Nothing else is set: choosing is NGOpt's job.
    The starting point is x0 when the study gives it (x0=all); otherwise a point drawn uniformly
    from `rng` (nevergrad's default would be the centre of the box, which on the paper problem
    is the initial model: a solver told nothing must not get it). nevergrad draws from the
    parametrization's own RandomState, seeded from `rng`, and some of its optimizers from numpy's
    global generator, which is seeded for the run and restored after.
    """

    name = "nevergrad-ngopt"
    #: capabilities (adapters.capabilities)
    anytime = False
    uses_gradients = False
    batch = False
    supports_x0 = True
    #: the distribution it wraps (its version is listed by `femu optimizers`)
    library = 'nevergrad'

    def min_budget(self, n_var: int, num_workers: int = 1, **options) -> int:
        """One batch of asks: `num_workers` evaluations."""
        return int(num_workers)

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, num_workers: int = 1):
        """Ask `num_workers` points, evaluate them as one batch, tell their values; until the
        harness stops the run (or NGOpt has used its budget)."""
        with _global_rngs_kept():
            self._minimize(objective, bounds, budget, rng, x0, num_workers)

    def _minimize(self, objective, bounds, budget, rng, x0, num_workers) -> None:
        import nevergrad as ng

        f, _ = unit_scaled(objective, bounds)
        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        init = rng.uniform(0.0, 1.0, len(xl)) if x0 is None else np.clip(
            (np.asarray(x0, dtype=float) - xl) / (xu - xl), 0.0, 1.0)
        param = ng.p.Array(init=init, lower=0.0, upper=1.0)
        param.random_state = np.random.RandomState(int(rng.integers(2**32)))
        with seeded_global_rngs(rng), _metamodel_scalars(), _seeded_cma_fmin(), _recast_threads_stopped(), \
                warnings.catch_warnings():
            # for short budgets NGOpt picks scipy's COBYLA with settings scipy corrects and warns
            # about (RHOEND, MAXFUN): nevergrad's choice, nothing a user of this plugin can act on
            warnings.filterwarnings("ignore", message="COBYLA: Invalid", category=UserWarning)
            # pycma (inside NGOpt's CMA variants) on a point nevergrad injected into a population
            warnings.filterwarnings("ignore", message="orphanated injected solution")
            # scipy's Powell minimising MetaModel's quadratic surrogate when that has no minimum:
            # nevergrad then falls back to its base optimizer
            warnings.filterwarnings("ignore", message="(overflow|invalid value) encountered",
                                    category=RuntimeWarning, module=r"scipy\.optimize")
            started = set(threading.enumerate())
            opt = ng.optimizers.NGOpt(parametrization=param, budget=int(budget), num_workers=int(num_workers))
            while opt.num_ask < int(budget):
                asked = [opt.ask() for _ in range(min(int(num_workers), int(budget) - opt.num_ask))]
                values = f(np.array([c.value for c in asked]))
                for c, v in zip(asked, values):
                    opt.tell(c, float(v))
                    _recast_threads_settled(started)


@contextmanager
def _global_rngs_kept():
    """numpy's and Python's global generator states put back when the block ends: nevergrad
    draws from numpy's global generator also when its parametrization is built, before the run's
    generators are seeded."""
    np_state, py_state = np.random.get_state(), random.getstate()
    try:
        yield
    finally:
        np.random.set_state(np_state)
        random.setstate(py_state)


@contextmanager
def _seeded_cma_fmin():
    """nevergrad's CmaFmin2 (in NGOpt's choices, e.g. under MetaModel at 12 parameters) calls
    ``cma.fmin`` without a seed, and pycma then seeds numpy's global generator from the clock:
    for the run, a call without a seed gets one drawn from numpy's global generator, which the
    run has seeded."""
    import cma

    fmin = cma.fmin

    def seeded(*args, options=None, **kwargs):
        options = dict(options or {})
        options.setdefault("seed", int(np.random.randint(1, 2**31)))
        return fmin(*args, options=options, **kwargs)

    cma.fmin = seeded
    try:
        yield
    finally:
        cma.fmin = fmin


def _size_one_float(value) -> float:
    """float() as numpy < 2.4 gave it: the one element of a size-1 array."""
    return float(np.asarray(value).reshape(-1)[0]) if np.size(value) == 1 else float(value)


@contextmanager
def _metamodel_scalars():
    """nevergrad's MetaModel (which NGOpt picks for moderate dimensions and budgets, e.g. 12
    parameters and 1,000 evaluations) calls float() on scikit-learn's length-1 prediction; numpy
    2.4 made that a TypeError (nevergrad 1.0.12 is the latest release; the warning before it is
    facebookresearch/nevergrad#1612). For the run, that module's `float` converts size-1 arrays
    as before; its previous binding is put back after."""
    from nevergrad.optimization import metamodel

    missing = object()
    previous = metamodel.__dict__.get("float", missing)
    metamodel.float = _size_one_float
    try:
        yield
    finally:
        if previous is missing:
            del metamodel.float
        else:
            metamodel.float = previous


def _recast_threads_settled(before: set) -> None:
    """Waits until every recast thread nevergrad started (those not in `before`) has posted its
    next point or ended. Such a thread (e.g. the CMA of NGOpt's MetaModel, run by cma.fmin2)
    draws from numpy's global generator after each tell, as does the main thread when it asks
    next (MetaModel's inner optimizers seed themselves from it): without the wait, the two
    interleave as the scheduler pleases and a seed does not fix the run."""
    from nevergrad.optimization.recaster import _MessagingThread

    for thread in set(threading.enumerate()) - before:
        if isinstance(thread, _MessagingThread):
            while thread.is_alive() and thread.messages_ask.empty():
                time.sleep(1e-5)


@contextmanager
def _recast_threads_stopped():
    """Stops, when the block ends, the threads nevergrad started in it for its recast optimizers
    (scipy's COBYLA, Powell, ... run in a thread that waits for the next tell): the harness ends
    a run by raising in the middle of NGOpt's budget, and such a thread would otherwise wait for
    ever and keep the process from exiting."""
    from nevergrad.optimization.recaster import _MessagingThread

    before = set(threading.enumerate())
    try:
        yield
    finally:
        for thread in set(threading.enumerate()) - before:
            if isinstance(thread, _MessagingThread):
                thread.stop()
                thread.join(timeout=10)
