"""The paper's genetic-algorithm operators as small standalone, vectorised functions.

Marwala's GA (and the GA inside his MLP response-surface method) uses the operators of the
GAOT toolbox (Houck, Joines & Kay 1995): arithmetic crossover, Michalewicz's non-uniform
mutation and Joines & Houck's normalized geometric selection. Each function here acts on a
whole population at once, as numpy arrays, draws every random number from the numpy Generator
it is given, and works in whatever box it is told (the adapters use the unit cube, so that
1e10-scale moduli do not upset the arithmetic). `latin_hypercube` is the initial sampling of
the response-surface method.
"""

from __future__ import annotations

import numpy as np


def geometric_rank_probabilities(n: int, q: float = 0.08) -> np.ndarray:
    """Selection probability of ranks 1..n (best first) under normalized geometric selection.

    P(rank r) = q' (1 - q)^(r - 1) with q' = q / (1 - (1 - q)^n), so the n probabilities sum
    to one; q is the probability of selecting the best (0.08 in the paper).
    """
    if int(n) < 1:
        raise ValueError(f"n must be a positive population size, got {n}")
    if not 0.0 < q < 1.0:
        raise ValueError(f"q (probability of selecting the best) must be in (0, 1), got {q}")
    r = np.arange(int(n))
    return q / (1.0 - (1.0 - q) ** n) * (1.0 - q) ** r


def normalized_geometric_selection(fitness, k: int, rng: np.random.Generator, q: float = 0.08) -> np.ndarray:
    """Indices (k,) of individuals selected, with replacement, by normalized geometric ranking.

    fitness: (n,) values to minimise (the lowest is rank 1; ties keep their order). Each of
    the k draws picks rank r with the probability of `geometric_rank_probabilities`.
    """
    fitness = np.asarray(fitness, dtype=float)
    if fitness.ndim != 1 or len(fitness) == 0:
        raise ValueError(f"fitness must be a non-empty 1-D array, got shape {fitness.shape}")
    if np.isnan(fitness).any():
        raise ValueError("fitness contains NaN: ranks are undefined")
    order = np.argsort(fitness, kind="stable")
    cdf = np.cumsum(geometric_rank_probabilities(len(fitness), q))
    # inverse-CDF sampling; clip guards the last bin against cdf[-1] = 1 - 1e-16 round-off
    ranks = np.minimum(np.searchsorted(cdf, rng.random(int(k)), side="right"), len(fitness) - 1)
    return order[ranks]


def arithmetic_crossover(parents, rng: np.random.Generator, prob: float = 1.0) -> np.ndarray:
    """Children of consecutive pairs of rows: a*p1 + (1-a)*p2 and (1-a)*p1 + a*p2, a ~ U(0, 1).

    parents: (n, d); rows (0, 1), (2, 3), ... are mated, each pair with probability `prob`
    (otherwise copied); an odd last row is copied. One a per pair, as in GAOT's arithXover.
    Children lie on the segment between their parents, hence inside any box holding both.
    """
    P = np.asarray(parents, dtype=float)
    if P.ndim != 2:
        raise ValueError(f"parents must be a 2-D array (n, d), got shape {P.shape}")
    if not 0.0 <= prob <= 1.0:
        raise ValueError(f"crossover prob must be in [0, 1], got {prob}")
    m = len(P) // 2
    a = rng.random(m)
    cross = rng.random(m) < prob
    a = np.where(cross, a, 1.0)[:, None]  # a = 1 copies the parents unchanged
    p1, p2 = P[0:2 * m:2], P[1:2 * m:2]
    children = P.copy()
    children[0:2 * m:2] = a * p1 + (1.0 - a) * p2
    children[1:2 * m:2] = (1.0 - a) * p1 + a * p2
    return children


def non_uniform_mutation(X, generation: int, max_generations: int, rng: np.random.Generator, b: float = 3.0,
                         prob: float | None = None, lower=0.0, upper=1.0) -> np.ndarray:
    """Michalewicz's non-uniform mutation of a population X (n, d) inside [lower, upper].

    Each gene mutates with probability `prob` (default 1/d). A mutated gene moves towards
    the upper bound, x + (upper - x) * c, or the lower, x - (x - lower) * c, with equal
    chance, where c = 1 - r^((1 - t/T)^b), r ~ U(0, 1), t = generation, T = max_generations.
    The expected step shrinks to 0 as t -> T, faster for a larger shape parameter b (GAOT
    uses b = 3). The result stays inside the bounds.
    """
    X = np.asarray(X, dtype=float)
    if X.ndim != 2:
        raise ValueError(f"X must be a 2-D array (n, d), got shape {X.shape}")
    if int(max_generations) < 1 or not 0 <= generation <= max_generations:
        raise ValueError(f"need 0 <= generation <= max_generations and max_generations >= 1, "
                         f"got generation={generation}, max_generations={max_generations}")
    if b < 0:
        raise ValueError(f"shape parameter b must be >= 0, got {b}")
    prob = 1.0 / X.shape[1] if prob is None else float(prob)
    if not 0.0 <= prob <= 1.0:
        raise ValueError(f"mutation prob must be in [0, 1], got {prob}")
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    u = rng.random((3,) + X.shape)  # one draw of each kind per gene, whether it mutates or not
    c = 1.0 - u[2] ** ((1.0 - generation / max_generations) ** b)
    step = np.where(u[1] < 0.5, (upper - X) * c, (lower - X) * c)
    # the clip only removes round-off: the step never reaches beyond the bound it aims at
    return np.clip(np.where(u[0] < prob, X + step, X), lower, upper)


def latin_hypercube(n: int, d: int, rng: np.random.Generator) -> np.ndarray:
    """n points (n, d) in the unit cube, one in each of the n equal slices of every axis."""
    if int(n) < 1 or int(d) < 1:
        raise ValueError(f"latin_hypercube needs n >= 1 and d >= 1, got n={n}, d={d}")
    perm = rng.permuted(np.tile(np.arange(n), (d, 1)), axis=1).T
    return (perm + rng.random((n, d))) / n
