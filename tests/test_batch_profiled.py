"""The diagnosis's batched pairing and profiled fits (fe_problem/diagnosis/fit.py `profiled_batch`,
residuals.py `Observations.pair_batch`, correlation.py `pair_index`, `mac_scaled`): a batch of
models gives, to the bit, what the models give one at a time through the per-model rule written
out here (the code the batch replaced); the assignment is checked against a brute-force search
over every pairing, and the MAC against its formula."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.correlation import mac, mac_scaled, pair_index, pair_modes, pow2_scaled
from fe_problem.diagnosis.fit import profiled, profiled_batch
from fe_problem.diagnosis.residuals import Observations


def _one_at_a_time(obs, hz, shapes, pairing=None):
    """The per-model profiled fit as it was before the batch: pair (correlation.pair_modes), the
    scale in closed form, pair again at the scale (twice at most), residuals of a batch of one."""
    def pair(f):
        return pair_modes(obs.frequencies_hz, f, obs.shapes, shapes, obs.has_shape).model_index

    idx = pair(hz) if pairing is None else pairing
    for _ in range(2):
        ok = (idx >= 0) & np.isfinite(hz[np.clip(idx, 0, None)])
        if not ok.any():
            s = 1.0
        else:
            q = hz[idx[ok]] / obs.frequencies_hz[ok]
            s = float((q.sum() / (q * q).sum()) ** 2)
        if pairing is not None:
            break
        new = pair(hz * np.sqrt(s))
        if np.array_equal(new, idx):
            break
        idx = new
    r = obs.residuals_paired((hz * np.sqrt(s))[None], shapes[None], idx)[0]
    return s, float(r @ r), idx, r


@pytest.fixture(scope="module")
def batch():
    """Observations of an H-frame with a hidden crack (8 modes; modes 3 and 6 without a shape) and
    12 models: cracked H-frames with their modes scaled (some far enough that frequency-only
    modes pair again at the fitted scale), two with model modes swapped (other pairings), one
    with a failed solve's mode (NaN frequency and shape) and one with a shape that does not move
    the coordinates."""
    h = fp.load_model("hframe")
    truth = fp.crack_element(h, 10, 0.3, 3e4)
    data = fp.synthetic_measurement(truth, 8, freq_noise=0.002, shape_noise=0.02, seed=11, model_name="hframe")
    obs = Observations.of(data)
    no_shape = np.array([3, 6])
    has = obs.has_shape.copy()
    has[no_shape] = False
    shapes, std = obs.shapes.copy(), obs.shape_std.copy()
    shapes[:, no_shape] = std[:, no_shape] = np.nan
    obs = dataclasses.replace(obs, shapes=shapes, has_shape=has, shape_std=std)
    hz, sh = [], []
    for i, (element, k) in enumerate(itertools.product((2, 5, 7, 10), (1e4, 3e4, 1e5))):
        r = fp.modal_analysis(fp.crack_element(h, element, 0.4, k), 10)
        hz.append(r.frequencies_hz * (0.75, 1.0, 1.3)[i % 3])
        sh.append(r.at(data.dofs))
    hz, sh = np.array(hz), np.array(sh)
    hz[4, [1, 2]], sh[4][:, [1, 2]] = hz[4, [2, 1]], sh[4][:, [2, 1]]
    hz[7, [5, 6]], sh[7][:, [5, 6]] = hz[7, [6, 5]], sh[7][:, [6, 5]]
    hz[9, 4], sh[9][:, 4] = np.nan, np.nan
    sh[10][:, 0] = 0.0
    return obs, hz, sh


def _same(fit, ref):
    s, chi2, idx, r = ref
    return fit.s == s and fit.chi2 == chi2 and np.array_equal(fit.pairing, idx) and \
        np.array_equal(fit.residuals, r, equal_nan=True)


def test_a_batch_of_models_fits_as_each_model_alone(batch):
    obs, hz, sh = batch
    fits = profiled_batch(obs, hz, sh)
    refs = [_one_at_a_time(obs, hz[i], sh[i]) for i in range(len(hz))]
    assert [_same(f, r) for f, r in zip(fits, refs)] == [True] * len(hz)
    assert all(_same(profiled(obs, hz[i], sh[i]), refs[i]) for i in (0, 4, 9))
    # the batch exercises what it claims: several pairings, and models paired again at the scale
    assert len({tuple(f.pairing) for f in fits}) >= 3
    first = [pair_modes(obs.frequencies_hz, hz[i], obs.shapes, sh[i], obs.has_shape).model_index
             for i in range(len(hz))]
    assert sum(not np.array_equal(f.pairing, p) for f, p in zip(fits, first)) >= 2
    assert np.isfinite([f.chi2 for f in fits]).all()
    assert profiled_batch(obs, hz[:0], sh[:0]) == []


def test_a_batch_with_the_pairing_held_fits_as_each_model_alone(batch):
    obs, hz, sh = batch
    held = _one_at_a_time(obs, hz[1], sh[1])[2]
    fits = profiled_batch(obs, hz, sh, held)
    assert all(_same(f, _one_at_a_time(obs, hz[i], sh[i], held)) for i, f in enumerate(fits))


def test_the_measured_side_prepared_once_gives_the_same_macs(batch):
    obs, hz, sh = batch
    a = np.nan_to_num(obs.shapes[:, obs.has_shape])
    scaled = pow2_scaled(a)
    together = mac_scaled(scaled, np.sum(scaled * scaled, axis=-2), sh)
    assert all(np.array_equal(together[i], mac(a, sh[i])) for i in range(len(sh)))
    # and the MAC is its formula, |a.b|^2 / (a.a b.b); a zero shape has MAC 0 with everything
    formula = (a.T @ sh[0]) ** 2 / np.outer((a * a).sum(0), (sh[0] * sh[0]).sum(0))
    np.testing.assert_allclose(together[0], formula, rtol=1e-12)
    assert (together[10][:, 0] == 0).all()
    assert np.array_equal(obs.pair_batch(hz, obs.mac_batch(sh))[4],
                          pair_modes(obs.frequencies_hz, hz[4], obs.shapes, sh[4], obs.has_shape).model_index)


def test_the_assignment_is_the_best_over_every_pairing():
    """pair_index against a brute-force search: every injective map of 4 measured modes onto 6
    model modes, the cheapest total cost (refused pairs at 1e6), refused pairs then dropped."""
    rng = np.random.default_rng(5)
    for _ in range(30):
        measured = np.sort(rng.uniform(1, 10, 4))
        model = np.sort(rng.uniform(1, 10, 6))
        has = rng.random(4) < 0.5
        mm = rng.random((4, 6))
        dist = np.abs(model[None, :] - measured[:, None]) / measured[:, None]
        cost = np.where(has[:, None], 1 - mm + 0.01 * dist, dist)
        allowed = np.where(has[:, None], mm >= 0.5, dist <= 0.3)
        best = min(itertools.permutations(range(6), 4),
                   key=lambda p: sum(cost[i, j] if allowed[i, j] else 1e6 for i, j in enumerate(p)))
        expected = [j if allowed[i, j] else -1 for i, j in enumerate(best)]
        assert pair_index(measured, model[None], mm[None], has)[0].tolist() == expected
