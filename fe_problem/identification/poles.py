"""Poles over model orders (LSCF, sdypy-EMA), the stabilisation chart, automatic selection.

A pole of order n is *stable* when order n-1 has a pole within `tol_frequency` (relative) in
frequency, `tol_damping` (relative) in damping and whose residue vector (windowed fit, shapes.py)
has MAC >= `min_mac` with its own. Stable poles are grouped by average-linkage clustering on
the distance |f_a - f_b| / f_max + (1 - MAC_ab): one group per physical mode, closely spaced
modes stay apart because their shapes differ. A group is a mode when it holds a stable pole
in at least `min_fraction` of the orders, its median damping lies in (0, max_damping) and its
median modal phase collinearity (MPC) is at least `min_mpc`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from .shapes import windowed_residues

#: Defaults of the selection, documented in docs/identify.md
MAX_ORDER = 40            # highest LSCF order (pole pairs); polynomial orders 2, 4, ..., 2 x MAX_ORDER
MAX_ORDER_LIMIT = 200     # the highest max_order accepted: LSCF time and memory grow with it
TOL_FREQUENCY = 0.005     # relative frequency change between consecutive orders
TOL_DAMPING = 0.10        # relative damping change between consecutive orders
MIN_MAC = 0.98            # residue-vector MAC between consecutive orders
MAX_DAMPING = 0.10        # physical damping ratios lie in (0, MAX_DAMPING)
MIN_FRACTION = 0.25       # a mode is stable in at least this fraction of the orders
MIN_MPC = 0.80            # modal phase collinearity of a real (proportionally damped) mode
CLUSTER_DISTANCE = 0.05   # linkage distance: 5 % of the top frequency or MAC 0.95


@dataclass(frozen=True, eq=False)
class Chart:
    """Every in-band pole of every order (one entry per pole): order (pole pairs of the LSCF
    denominator), frequency_hz, damping (ratio), mpc, residues (n_poles, n_channels) complex,
    stable (bool: frequency, damping and shape stable against the order below), cluster
    (int, -1 if none), chosen_cluster (the clusters that are modes, ascending frequency)."""

    order: np.ndarray
    frequency_hz: np.ndarray
    damping: np.ndarray
    mpc: np.ndarray
    residues: np.ndarray
    stable: np.ndarray
    cluster: np.ndarray
    chosen: tuple[int, ...]
    n_orders: int


def complex_pole(frequency_hz, damping):
    """Upper-half-plane pole -zeta w + i w sqrt(1 - zeta^2) (rad/s) of a frequency (Hz) and damping ratio."""
    w = 2 * np.pi * np.asarray(frequency_hz, float)
    z = np.asarray(damping, float)
    return -z * w + 1j * w * np.sqrt(1 - z**2)


def mpc(vectors: np.ndarray) -> np.ndarray:
    """Modal phase collinearity (Pappa) of complex vectors (..., n): 1 for a real vector up to a phase."""
    re, im = vectors.real, vectors.imag
    sxx, syy, sxy = (re * re).sum(-1), (im * im).sum(-1), (re * im).sum(-1)
    return ((sxx - syy) ** 2 + 4 * sxy**2) / np.maximum((sxx + syy) ** 2, 1e-300)


def mac_complex(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC between the rows of complex arrays a (p, n) and b (q, n): (p, q)."""
    num = np.abs(a.conj() @ b.T) ** 2
    den = np.outer((np.abs(a) ** 2).sum(1), (np.abs(b) ** 2).sum(1))
    return num / np.maximum(den, 1e-300)


def lscf_poles(frequency_hz, frf, band_hz, form: str, max_order: int = MAX_ORDER):
    """Poles of every LSCF order 1..max_order (pole pairs) over the band: a list of complex arrays
    (rad/s), upper half plane, in band, damping in (0, 1). sdypy-EMA's LSCF (fast: no progress bar)."""
    from sdypy import EMA

    lo, hi = band_hz
    model = EMA.Model(frf=frf, freq=frequency_hz, lower=lo, upper=hi, pol_order_high=int(max_order),
                      frf_form=form)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.get_poles(method="lscf", show_progress=False)
    out = []
    for p in model.all_poles:
        p = np.asarray(p, complex)
        f, z = np.abs(p) / (2 * np.pi), -p.real / np.maximum(np.abs(p), 1e-300)
        out.append(p[(p.imag > 0) & (f >= lo) & (f <= hi) & (z > 0) & (z < 1)])
    return out


def lsfd(poles, frequency_hz, frf, form: str):
    """Residues (n_channels, n_poles) and the synthesised FRFs (n_channels, n_lines) of the given
    poles over all lines, with lower and upper residuals (sdypy-EMA's LSFD)."""
    from sdypy.EMA.EMA import LSFD

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a, h, _, _ = LSFD(np.asarray(poles, complex), frf, frequency_hz, True, True, 0, len(frequency_hz), form)
    return a, h


def stabilisation(frequency_hz, frf, form: str, poles_per_order, progress=None, tol_frequency=TOL_FREQUENCY,
                  tol_damping=TOL_DAMPING, min_mac=MIN_MAC, max_damping=MAX_DAMPING) -> Chart:
    """The stabilisation chart of `poles_per_order` (band-limited FRFs): residues by LSFD at every
    order, stability against the order below; clusters and chosen modes by `select`."""
    rows, prev = [], None
    n = len(poles_per_order)
    for k, poles in enumerate(poles_per_order):
        if progress is not None:
            progress(k + 1, n)
        if poles.size == 0:
            prev = None
            continue
        res = windowed_residues(poles, frequency_hz, frf, form).T      # (n_poles, n_channels)
        f, z = np.abs(poles) / (2 * np.pi), -poles.real / np.abs(poles)
        stable = np.zeros(poles.size, bool)
        if prev is not None:
            pf, pz, pres = prev
            near = np.abs(f[:, None] - pf[None, :]).argmin(1)
            macs = mac_complex(res, pres)[np.arange(poles.size), near]
            stable = ((np.abs(f - pf[near]) / f < tol_frequency) & (np.abs(z - pz[near]) / z < tol_damping)
                      & (macs >= min_mac))
        stable &= z < max_damping
        rows.append((np.full(poles.size, k + 1), f, z, mpc(res), res, stable))
        prev = (f, z, res)
    if not rows:
        empty = np.zeros(0)
        return Chart(empty.astype(int), empty, empty, empty, np.zeros((0, frf.shape[0]), complex),
                     empty.astype(bool), empty.astype(int), (), n)
    cols = [np.concatenate(c) for c in zip(*rows)]
    return Chart(cols[0], cols[1], cols[2], cols[3], cols[4], cols[5], np.full(cols[0].size, -1), (), n)


def select(chart: Chart, min_fraction=MIN_FRACTION, min_mpc=MIN_MPC, max_damping=MAX_DAMPING,
           distance=CLUSTER_DISTANCE) -> Chart:
    """Cluster the stable poles and choose the physical ones; returns the chart with `cluster`
    and `chosen` set (clusters in ascending median frequency, at most one pole per order each)."""
    from dataclasses import replace

    from scipy.cluster.hierarchy import fcluster, linkage

    idx = np.flatnonzero(chart.stable)
    cluster = np.full(chart.order.size, -1)
    if idx.size < 2:
        return replace(chart, cluster=cluster, chosen=())
    f = chart.frequency_hz[idx]
    d = np.abs(f[:, None] - f[None, :]) / f.max() + (1 - mac_complex(chart.residues[idx], chart.residues[idx]))
    d = np.clip((d + d.T) / 2, 0, None)
    labels = fcluster(linkage(d[np.triu_indices(idx.size, 1)], method="average"), distance, criterion="distance")
    chosen = []
    for lab in np.unique(labels):
        members = idx[labels == lab]
        fm = np.median(chart.frequency_hz[members])
        # one pole per order: the one nearest the group's median frequency
        order_of = chart.order[members]
        best = {}
        for m, o in zip(members, order_of):
            if o not in best or abs(chart.frequency_hz[m] - fm) < abs(chart.frequency_hz[best[o]] - fm):
                best[o] = m
        members = np.array(sorted(best.values()))
        cluster[members] = lab
        if (members.size >= max(3, min_fraction * chart.n_orders)
                and 0 < np.median(chart.damping[members]) < max_damping
                and np.median(chart.mpc[members]) >= min_mpc):
            chosen.append((fm, int(lab)))
    return replace(chart, cluster=cluster, chosen=tuple(lab for _, lab in sorted(chosen)))
