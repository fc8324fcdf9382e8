"""deap-ga-stock: DEAP's stock real-coded GA, eaSimple's generational loop with DEAP's own
operators: tournament selection (selTournament), simulated binary crossover
(cxSimulatedBinaryBounded) and polynomial mutation (mutPolynomialBounded), varied by
`deap.algorithms.varAnd`. Beside `deap-ga` (the paper's operators), it is what a DEAP user
gets from the library's documented building blocks.
"""

from __future__ import annotations

import numpy as np
from deap import algorithms, base, creator, tools

from .budget import ga_population
from .harness import seeded_global_rngs, unit_scaled

# DEAP's creator registers classes globally: once per process, under names of our own
if not hasattr(creator, "FemuFitnessMin"):
    creator.create("FemuFitnessMin", base.Fitness, weights=(-1.0,))
if not hasattr(creator, "FemuIndividual"):
    creator.create("FemuIndividual", list, fitness=creator.FemuFitnessMin)


def stock_toolbox(n_var: int, eta_cx: float = 20.0, eta_mut: float = 20.0, indpb: float | None = None,
                  tournsize: int = 3) -> base.Toolbox:
    """A toolbox of DEAP's stock operators on the unit cube: mate (SBX, crowding eta_cx),
    mutate (polynomial, eta_mut, per-gene probability indpb, default 1/n_var), select
    (tournament of tournsize)."""
    toolbox = base.Toolbox()
    toolbox.register("mate", tools.cxSimulatedBinaryBounded, eta=eta_cx, low=0.0, up=1.0)
    toolbox.register("mutate", tools.mutPolynomialBounded, eta=eta_mut, low=0.0, up=1.0,
                     indpb=1.0 / n_var if indpb is None else indpb)
    toolbox.register("select", tools.selTournament, tournsize=tournsize)
    return toolbox


def _evaluate(f, individuals) -> int:
    """Evaluate the individuals without a valid fitness, as one batch (eaSimple's rule); how many."""
    todo = [ind for ind in individuals if not ind.fitness.valid]
    if todo:
        for ind, v in zip(todo, f(np.array(todo, dtype=float))):
            ind.fitness.values = (float(v),)
    return len(todo)


class DeapGAStock:
    """DEAP's eaSimple generational GA with SBX, polynomial mutation and tournament selection.

    Each generation: select `population` parents by tournament, vary them with varAnd (pairs
    crossed with probability cxpb, each child mutated with probability mutpb), evaluate the
    changed children in one batch, and replace the population (no elitism, as eaSimple; the
    harness keeps the best point). Works in the unit cube. Settings (DEAP's documented values
    for real-coded problems, e.g. its NSGA-II example):
        population (None): `adapters.budget.ga_population` (20 on 12 parameters, 48 on 96),
            whatever the budget (anytime);
        cxpb (0.9), mutpb (1.0): crossover and mutation probabilities of varAnd;
        eta_cx (20), eta_mut (20): SBX and polynomial-mutation crowding degrees;
        indpb (None = 1 / n_var): per-gene mutation probability; tournsize (3).
    The initial population is uniform in the bounds (x0 first when the study gives it). DEAP
    draws from Python's `random`: it is seeded from `rng` for the run and restored after.
    """

    name = "deap-ga-stock"
    #: capabilities (adapters.capabilities)
    anytime = True
    uses_gradients = False
    batch = True
    supports_x0 = True
    #: the distribution it wraps (its version is listed by `femu optimizers`)
    library = 'deap'

    def min_budget(self, n_var: int, population: int | None = None, **options) -> int:
        """One initial population (default: `ga_population(n_var)`)."""
        return int(population) if population is not None else ga_population(n_var)

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, population: int | None = None,
                 cxpb: float = 0.9, mutpb: float = 1.0, eta_cx: float = 20.0, eta_mut: float = 20.0,
                 indpb: float | None = None, tournsize: int = 3):
        """Generations until the harness stops the run."""
        f, _ = unit_scaled(objective, bounds)
        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        n_var = len(xl)
        pop_n = ga_population(n_var) if population is None else int(population)
        toolbox = stock_toolbox(n_var, eta_cx, eta_mut, indpb, tournsize)
        U = rng.random((pop_n, n_var))
        if x0 is not None:
            U[0] = np.clip((np.asarray(x0, dtype=float) - xl) / (xu - xl), 0.0, 1.0)
        pop = [creator.FemuIndividual(row) for row in U.tolist()]
        with seeded_global_rngs(rng):
            _evaluate(f, pop)
            idle = 0
            while idle < 100:  # eaSimple's loop, until the harness raises BudgetExhausted
                offspring = algorithms.varAnd(toolbox.select(pop, len(pop)), toolbox, cxpb, mutpb)
                idle = 0 if _evaluate(f, offspring) else idle + 1
                pop[:] = offspring
            # 100 generations without a changed child (cxpb = mutpb = 0): the search has stopped
