"""The paper's GA operators, each on its own: the statistics they must have, bounds, determinism."""

import numpy as np
import pytest
from scipy.stats import chi2, kstest

from adapters.ga_operators import (arithmetic_crossover, geometric_rank_probabilities, latin_hypercube,
                                   non_uniform_mutation, normalized_geometric_selection)

# a chi-square statistic above this has probability 1e-6 under the null hypothesis
P_FALSE_ALARM = 1e-6


def _chi_square(counts, probabilities):
    expected = probabilities * counts.sum()
    return float(np.sum((counts - expected) ** 2 / expected))


def test_rank_probabilities_follow_joines_houck_formula():
    q, n = 0.08, 30
    p = geometric_rank_probabilities(n, q)
    q_prime = q / (1 - (1 - q) ** n)
    assert p[0] == pytest.approx(q_prime, rel=1e-14)
    np.testing.assert_allclose(p[1:] / p[:-1], 1 - q, rtol=1e-12)
    assert p.sum() == pytest.approx(1.0, rel=1e-14)
    # for a large population q' -> q: the best is selected with probability q
    assert geometric_rank_probabilities(2000, q)[0] == pytest.approx(q, rel=1e-12)
    assert geometric_rank_probabilities(1, q) == pytest.approx([1.0], rel=1e-14)


def test_selection_frequencies_match_ranks():
    rng = np.random.default_rng(7)
    n, k = 20, 200_000
    fitness = rng.permutation(n).astype(float) * 3.1 - 10.0  # rank of individual i: order of fitness
    idx = normalized_geometric_selection(fitness, k, rng, q=0.08)
    assert idx.shape == (k,) and idx.min() >= 0 and idx.max() < n
    rank_of = np.argsort(np.argsort(fitness))  # 0 = lowest fitness = best
    counts = np.bincount(rank_of[idx], minlength=n)
    bound = chi2.ppf(1 - P_FALSE_ALARM, n - 1)
    assert _chi_square(counts, geometric_rank_probabilities(n, 0.08)) < bound
    # the same draws are far from a slightly different q or from reversed ranks: the check has power
    assert _chi_square(counts, geometric_rank_probabilities(n, 0.10)) > 10 * bound
    assert _chi_square(counts, geometric_rank_probabilities(n, 0.08)[::-1]) > 10 * bound


def test_selection_is_deterministic_and_rejects_bad_input():
    f = np.linspace(1, 2, 15)
    a = normalized_geometric_selection(f, 40, np.random.default_rng(3))
    b = normalized_geometric_selection(f, 40, np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="NaN"):
        normalized_geometric_selection([1.0, np.nan], 2, np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"q .* must be in \(0, 1\)"):
        normalized_geometric_selection(f, 2, np.random.default_rng(0), q=1.5)


def test_arithmetic_crossover_children_on_segment_and_complementary():
    rng = np.random.default_rng(11)
    lo, hi = np.full(12, -3.0), np.linspace(1.0, 4.0, 12)
    parents = lo + rng.random((2001, 12)) * (hi - lo)  # odd: the last row has no mate
    children = arithmetic_crossover(parents, np.random.default_rng(5))
    p1, p2, c1, c2 = parents[0:2000:2], parents[1:2000:2], children[0:2000:2], children[1:2000:2]
    # c1 = a p1 + (1 - a) p2 with one a per pair, the same in every coordinate
    a = np.sum((c1 - p2) * (p1 - p2), axis=1) / np.sum((p1 - p2) ** 2, axis=1)
    np.testing.assert_allclose(c1, a[:, None] * p1 + (1 - a[:, None]) * p2, atol=1e-12)
    np.testing.assert_allclose(c1 + c2, p1 + p2, atol=1e-12)  # the complement
    assert np.all((a >= 0) & (a <= 1))
    assert kstest(a, "uniform").pvalue > 1e-4  # a ~ U(0, 1)
    assert np.all((children >= lo) & (children <= hi))
    np.testing.assert_array_equal(children[-1], parents[-1])
    np.testing.assert_array_equal(children, arithmetic_crossover(parents, np.random.default_rng(5)))


def test_crossover_probability_is_per_pair():
    parents = np.random.default_rng(2).random((4000, 3))
    children = arithmetic_crossover(parents, np.random.default_rng(9), prob=0.3)
    crossed = np.any(children[0::2] != parents[0::2], axis=1)
    # binomial(2000, 0.3): mean 600, std 20.5; five standard deviations
    assert abs(crossed.sum() - 600) < 5 * np.sqrt(2000 * 0.3 * 0.7)
    np.testing.assert_array_equal(arithmetic_crossover(parents, np.random.default_rng(1), prob=0.0), parents)


def test_non_uniform_mutation_step_shrinks_as_predicted():
    # all genes at 0.5 in [0, 1], every gene mutates: |step| = 0.5 c with c = 1 - r^e,
    # e = (1 - t/T)^b, so E|step| = 0.5 e / (1 + e); check that law at five generations
    T, b = 100, 3.0
    X = np.full((20_000, 5), 0.5)
    means = []
    for t in (0, 25, 50, 75, 99):
        Y = non_uniform_mutation(X, t, T, np.random.default_rng(t), b=b, prob=1.0)
        step = np.abs(Y - X)
        e = (1 - t / T) ** b
        c = 2 * step  # c ~ 1 - U^e has variance < 1/4: a 6-sigma bound on the mean of 1e5 draws
        assert c.mean() == pytest.approx(e / (1 + e), abs=6 * 0.5 / np.sqrt(c.size))
        assert 0.4 < np.mean(Y > X) < 0.6  # both directions, with equal chance
        means.append(step.mean())
    assert all(a > b for a, b in zip(means, means[1:]))
    np.testing.assert_array_equal(non_uniform_mutation(X, T, T, np.random.default_rng(0), prob=1.0), X)


def test_non_uniform_mutation_stays_inside_bounds_and_mutates_at_rate():
    rng = np.random.default_rng(4)
    lo, hi = np.array([6e10, -1.0, 0.0]), np.array([8e10, 1.0, 1e-3])
    X = lo + rng.random((30_000, 3)) * (hi - lo)
    X[:5] = lo  # on the bounds already
    X[5:10] = hi
    Y = non_uniform_mutation(X, 0, 50, np.random.default_rng(8), b=2.0, prob=0.25, lower=lo, upper=hi)
    assert np.all((Y >= lo) & (Y <= hi))
    changed = (Y != X).mean()
    # binomial(90000, 0.25): std 0.0014 in the rate
    assert changed == pytest.approx(0.25, abs=0.01)
    # default rate 1/d
    Z = non_uniform_mutation(X, 0, 50, np.random.default_rng(8), lower=lo, upper=hi)
    assert (Z != X).mean() == pytest.approx(1 / 3, abs=0.01)
    np.testing.assert_array_equal(Z, non_uniform_mutation(X, 0, 50, np.random.default_rng(8), lower=lo, upper=hi))
    with pytest.raises(ValueError, match="generation"):
        non_uniform_mutation(X, 51, 50, rng)


def test_latin_hypercube_one_point_per_slice():
    U = latin_hypercube(150, 12, np.random.default_rng(0))
    assert U.shape == (150, 12) and np.all((U >= 0) & (U < 1))
    for j in range(12):
        np.testing.assert_array_equal(np.sort(np.floor(U[:, j] * 150)), np.arange(150))
    np.testing.assert_array_equal(U, latin_hypercube(150, 12, np.random.default_rng(0)))
    assert not np.array_equal(U, latin_hypercube(150, 12, np.random.default_rng(1)))
