"""The diagnosis's weighted residuals (fe_problem/diagnosis/residuals.py): a measured shape paired
with one of a cluster of close model modes is compared with the best combination of the cluster
(a penalised least-squares fit, checked here against scipy's least squares on the augmented
system and against the projection onto the cluster's span); a mode with no close neighbour keeps
the plain residual; and on a space frame whose close modes a hidden roof mass and column loss
turn (modes built by OpenSeesPy), the first-order screen ranks the roof mass first."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg

from fe_problem.diagnosis.residuals import CLOSE_MODES_REACH, CLOSE_MODES_REL, Observations

N_COORD = 12


def _unit(x):
    return x / np.linalg.norm(x, axis=0)


def _setup(gap_rel: float, seed: int = 3):
    """Three model modes (the second `gap_rel` above the first, the third far), their shapes at
    N_COORD coordinates, and measured modes: the first two a 37 degree turn of the model's first
    two, the third the model's third; no noise."""
    rng = np.random.default_rng(seed)
    shapes = np.linalg.qr(rng.standard_normal((N_COORD, 3)))[0]
    hz = np.array([2.0, 2.0 * (1 + gap_rel), 5.0])
    c, s = np.cos(np.radians(37)), np.sin(np.radians(37))
    measured = np.column_stack([c * shapes[:, 0] + s * shapes[:, 1], -s * shapes[:, 0] + c * shapes[:, 1],
                                shapes[:, 2]])
    obs = Observations(hz.copy(), _unit(measured), np.ones(3, bool), 0.002, 0.02)
    return obs, hz, shapes


def _shape_residuals(obs, r):
    return r[obs.n_modes:].reshape(obs.n_modes, -1).T


def test_equal_modes_are_compared_as_their_span_whatever_their_turn():
    obs, hz, shapes = _setup(0.0)
    r, idx = obs.residuals(hz, shapes, np.arange(3))
    # the measured shapes lie in the span of the model's pair: no shape residual at all
    np.testing.assert_allclose(_shape_residuals(obs, r), 0.0, atol=1e-12)
    # any turn of the pair is the same model
    for angle in (10.0, 80.0, 133.0):
        c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
        turned = shapes.copy()
        turned[:, :2] = shapes[:, :2] @ np.array([[c, -s], [s, c]])
        r2, _ = obs.residuals(hz, turned, np.arange(3))
        np.testing.assert_allclose(r2, r, atol=1e-12)
    # a measured shape partly outside the span: its residual is its distance to the span
    rng = np.random.default_rng(9)
    off = _unit(obs.shapes[:, 0] + 0.05 * rng.standard_normal(N_COORD))
    obs_off = Observations(obs.frequencies_hz, np.column_stack([off, obs.shapes[:, 1:]]), obs.has_shape, 0.002, 0.02)
    q = scipy.linalg.orth(shapes[:, :2])
    proj = q @ (q.T @ off)
    expected = (proj / np.linalg.norm(proj) - off) / (0.02 * np.abs(off).max())
    np.testing.assert_allclose(_shape_residuals(obs_off, obs_off.residuals(hz, shapes, np.arange(3))[0])[:, 0],
                               expected, rtol=1e-10, atol=1e-12)


def test_a_mode_without_close_neighbours_keeps_the_plain_residual():
    obs, hz, shapes = _setup(1.05 * CLOSE_MODES_REACH * CLOSE_MODES_REL)  # beyond the reach of the mixing, from either mode
    r, idx = obs.residuals(hz, shapes, np.arange(3))
    u_a = shapes / np.linalg.norm(shapes, axis=0)
    u_a = u_a * np.where(np.sum(u_a * obs.shapes, axis=0) < 0, -1.0, 1.0)
    plain = (u_a - obs.shapes) / (0.02 * np.abs(obs.shapes).max(axis=0))
    # (to rounding: the same operations in another order; that the code path is the unchanged one,
    # bit for bit, is what benchmarks/planar_fingerprint.py checks on the planar diagnosis)
    np.testing.assert_allclose(_shape_residuals(obs, r), plain, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r[:3], (hz - obs.frequencies_hz) / (obs.frequencies_hz * 0.002), rtol=1e-12)


def test_modes_at_zero_hz_are_compared_alone_without_a_warning():
    """A model softened past stability has modes at 0 Hz (negative eigenvalues clipped; a reduced
    screen's largest sizes). Two of them (0 Hz beside 0 Hz: 0 / 0) and one paired beside a mode
    far above: each is compared alone, the plain residual, and no divide warning is raised."""
    obs, hz, shapes = _setup(0.5)
    zero_hz = np.array([0.0, 0.0, 5.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r, _ = obs.residuals(zero_hz, shapes, np.arange(3))
    u_a = shapes * np.where(np.sum(shapes * obs.shapes, axis=0) < 0, -1.0, 1.0)
    plain = (u_a - obs.shapes) / (0.02 * np.abs(obs.shapes).max(axis=0))
    np.testing.assert_allclose(_shape_residuals(obs, r), plain, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r[:3], (zero_hz - obs.frequencies_hz) / (obs.frequencies_hz * 0.002), rtol=1e-12)


@pytest.mark.parametrize("gap", [0.3 * CLOSE_MODES_REL, CLOSE_MODES_REL, 2.0 * CLOSE_MODES_REL])
def test_near_modes_mix_as_the_penalised_fit_says(gap):
    """Between the two: the model shape is mode j plus its neighbour with a coefficient that
    scipy's least squares finds on the augmented system [B; sqrt(P)] c = [u_m; 0]."""
    obs, hz, shapes = _setup(gap)
    r, _ = obs.residuals(hz, shapes, np.arange(3))
    for j, other in ((0, 1), (1, 0)):
        u_m = obs.shapes[:, j]
        b = shapes[:, [j, other]]
        p = np.expm1((abs(hz[other] - hz[j]) / hz[j] / CLOSE_MODES_REL) ** 2)
        c = scipy.linalg.lstsq(np.vstack([b, [[0.0, np.sqrt(p)]]]), np.concatenate([u_m, [0.0]]))[0]
        u = b @ c
        u = u / np.linalg.norm(u) * np.sign(u @ u_m)
        np.testing.assert_allclose(_shape_residuals(obs, r)[:, j], (u - u_m) / (0.02 * np.abs(u_m).max()),
                                   rtol=1e-9, atol=1e-10)
    # the wider the gap, the less of the turn the model may take back
    assert 0.0 < np.sum(_shape_residuals(obs, r)[:, :2] ** 2)
