"""deap-ga: the paper's "GA with the full FE model", composed in a DEAP toolbox.

The toolbox holds the paper's operators from `adapters.ga_operators` (normalized geometric
selection with q = 0.08, arithmetic crossover, non-uniform mutation) and DEAP's logbook keeps
the statistics of each generation. The population is one numpy array, not a list of DEAP
`creator` individuals: every generation is then one batch for the objective, and the elite
is kept by one argsort (a DEAP hall of fame, deep-copying an individual per insertion, took
over a third of the time of the GA inside `mlp-surrogate`, which runs thousands of times). With no
creator classes there are none to re-create on every run. The search runs in the unit cube
and maps to the bounds only for the objective. `evolve` is also the GA of `mlp-surrogate`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from deap import base, tools

from . import ga_operators as ops
from .harness import seeded_global_rngs, unit_scaled


def make_toolbox(q: float = 0.08, b: float = 3.0, crossover_prob: float = 0.8,
                 mutation_prob: float | None = None) -> base.Toolbox:
    """A toolbox with the paper's operators: select(fitness, k, rng), mate(parents, rng),
    mutate(X, generation, max_generations, rng). q: probability of selecting the best; b:
    non-uniform mutation shape; crossover_prob per pair; mutation_prob per gene (None: 1/d)."""
    toolbox = base.Toolbox()
    toolbox.register("select", ops.normalized_geometric_selection, q=q)
    toolbox.register("mate", ops.arithmetic_crossover, prob=crossover_prob)
    toolbox.register("mutate", ops.non_uniform_mutation, b=b, prob=mutation_prob)
    return toolbox


@dataclass(frozen=True, eq=False)
class GAResult:
    """Outcome of `evolve`: best point x (unit cube, (d,)), its value f, the number of
    evaluations asked for, and DEAP's logbook (gen, nevals, best, mean per generation)."""

    x: np.ndarray
    f: float
    n_evals: int
    logbook: tools.Logbook


def evolve(evaluate, n_var: int, rng: np.random.Generator, population: int = 50, generations: int = 100,
           n_elite: int = 2, toolbox: base.Toolbox | None = None, initial=None) -> GAResult:
    """Minimise `evaluate` (batch (n, n_var) of unit-cube points -> (n,) values) with the GA.

    Generation 0 is `population` random points (the rows of `initial` first, if given); each
    later generation keeps the `n_elite` best points of the previous one (so the best never
    gets worse; they are not re-evaluated) and evaluates population - n_elite offspring made
    by select, mate and mutate, in one batch. Total evaluations:
    population + (generations - 1) * (population - n_elite).
    """
    population, generations, n_elite = int(population), int(generations), int(n_elite)
    if population < 2:
        raise ValueError(f"population must be >= 2, got {population}")
    if generations < 1:
        raise ValueError(f"generations must be >= 1, got {generations}")
    if not 1 <= n_elite < population:
        raise ValueError(f"n_elite must be in [1, population - 1] = [1, {population - 1}], got {n_elite}")
    toolbox = toolbox or make_toolbox()
    logbook = tools.Logbook()
    U = rng.random((population, n_var))
    if initial is not None:
        initial = np.clip(np.atleast_2d(np.asarray(initial, dtype=float))[:population], 0.0, 1.0)
        U[: len(initial)] = initial
    f = np.asarray(evaluate(U), dtype=float)
    n_evals = population
    logbook.record(gen=0, nevals=population, best=float(f.min()), mean=float(f.mean()))
    # the paper's operators draw from rng only; the global generators are seeded from it in
    # case a toolbox registers DEAP's stock operators, which draw from Python's `random`
    with seeded_global_rngs(rng):
        for gen in range(1, generations):
            elite = np.argsort(f, kind="stable")[:n_elite]  # the best so far: f never gets worse
            parents = U[toolbox.select(f, population - n_elite, rng=rng)]
            offspring = toolbox.mutate(toolbox.mate(parents, rng=rng), generation=gen,
                                       max_generations=generations, rng=rng)
            f_off = np.asarray(evaluate(offspring), dtype=float)
            n_evals += len(offspring)
            U, f = np.vstack([U[elite], offspring]), np.concatenate([f[elite], f_off])
            logbook.record(gen=gen, nevals=len(offspring), best=float(f.min()), mean=float(f.mean()))
    k = int(np.argmin(f))
    return GAResult(U[k].copy(), float(f[k]), n_evals, logbook)


class DeapGA:
    """The paper's GA on the FE model: normalized geometric selection (q = 0.08), arithmetic
    crossover, non-uniform mutation (b = 3), elitism.

    Options: population (default min(50, budget); the paper used 600), generations (default:
    as many as the budget allows, so the mutation step anneals over the whole run; the paper
    used 100), n_elite (2), q, b, crossover_prob (0.8 per pair), mutation_prob (per gene,
    default 1/n_var). When the generations end before the budget, an independent new GA
    starts, until the harness stops the run. x0 (study option x0=all) is the first point of
    the first GA's initial population.
    """

    name = "deap-ga"
    #: capabilities (adapters.capabilities)
    anytime = False
    uses_gradients = False
    batch = True
    supports_x0 = True
    #: the distribution it wraps (its version is listed by `femu optimizers`)
    library = 'deap'

    def min_budget(self, n_var: int, **options) -> int:
        """Four evaluations: the smallest population the operators work on."""
        return 4

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, population: int | None = None,
                 generations: int | None = None, n_elite: int = 2, q: float = 0.08, b: float = 3.0,
                 crossover_prob: float = 0.8, mutation_prob: float | None = None):
        """Run GAs on `objective` (a batch per generation) until the harness stops the run."""
        f, _ = unit_scaled(objective, bounds)
        pop = min(50, int(budget)) if population is None else int(population)
        if pop > budget:
            raise ValueError(f"population={pop} exceeds the budget of {budget} evaluations")
        if generations is None:
            generations = 1 + math.ceil(max(int(budget) - pop, 0) / max(pop - int(n_elite), 1))
        toolbox = make_toolbox(q, b, crossover_prob, mutation_prob)
        xl, xu = (np.asarray(v, dtype=float) for v in bounds)
        initial = None if x0 is None else (np.asarray(x0, dtype=float) - xl) / (xu - xl)
        while True:  # restart until the harness raises BudgetExhausted
            evolve(f, len(xl), rng, pop, generations, n_elite, toolbox, initial)
            initial = None  # x0 starts the first GA only
