"""Checks of the measured data before the diagnosis: faults of the test, not of the structure.

A fault of the data (a sensor mounted the wrong way round, two cables swapped, two identified
modes whose shapes were exchanged, a mode identified twice, a spurious pole) makes any model
misfit, and a diagnosis would otherwise name structural effects for it. Each check compares the
data with the nominal model's modes (global scale calibrated) and calls a fault only when a
discrete change of the data (one channel's sign, two channels' order) explains a misfit far
beyond the noise, consistently in every mode where it can be seen: a structural effect of the
sizes a model misses moves shapes a little everywhere, it does not flip the sign of a
well-excited entry in every mode while the other channels agree.

- ``channel_polarity`` (channel c): in every mode where the model's and the measured entry at c
  are both well excited (at least `EXCITED` of the mode's peak; at least two such modes), the
  measured sign disagrees with the model's, the mode's own sign being set by the other channels;
  reversing c lowers the shapes' chi^2 (noise-weighted, each measured mode paired with its best
  MAC partner) by at least `MIN_DROP` and at least half.
- ``channel_swap`` (channels c, d): exchanging the two rows of the measured shapes raises the
  MAC in every mode where the model's entries at c and d differ by at least `EXCITED` of the
  peak (at least two), and lowers the shapes' chi^2 as above.
  Channel faults are sought greedily: the largest drop first, the data corrected by it, then the
  next (at most `MAX_CHANNEL_FAULTS`).
- ``mode_order`` (modes i, j): paired by frequency (the calibrated model's nearest modes, one
  each), the shape of i matches j's partner and the shape of j matches i's (MAC >= `MATCH`), while
  each matches its own partner poorly (MAC < 0.5), and the two partners lie more than
  `APART` apart in frequency (closer modes may change order for real; the pairing by MAC
  follows that).
- ``duplicate_mode`` (modes i, j): two measured modes within `CLOSE` in frequency whose shapes
  agree (MAC >= `DUPLICATE_MAC`) and match the same model mode best.
- ``spurious_mode`` (mode i): a measured mode that pairs with no mode of the model nor of the
  model the diagnosis extended (found after the diagnosis, `spurious_modes`): a suspension mode
  a spring to ground explains is not one.

The diagnosis runs on the data as given; a record with a data check says that the fault may
explain the misfit.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..correlation import MAX_PAIR_FREQ, mac, pow2_scaled

#: An entry counts as well excited at this fraction of its mode's largest |entry| (7.5 times the
#: default shape noise).
EXCITED = 0.15
#: A channel fault must lower the shapes' chi^2 by this much (noise units) and by half.
MIN_DROP = 50.0
MAX_CHANNEL_FAULTS = 3
#: mode_order: a swapped pair's shapes match the other's partner at least this well; the two
#: partners lie further apart than this (relative frequency).
MATCH, APART = 0.8, 0.1
#: duplicate_mode: shapes this alike, frequencies this close (relative).
DUPLICATE_MAC, CLOSE = 0.9, 0.05


@dataclass(frozen=True)
class DataCheck:
    """A fault found in the data: kind (``channel_polarity``, ``channel_swap``, ``mode_order``,
    ``duplicate_mode`` or ``spurious_mode``), where (``{"channels": [[node, dir], ...]}`` or
    ``{"modes": [1-based, ...]}``) and the evidence (numbers) and a sentence for the user."""

    kind: str
    where: dict
    evidence: dict
    text: str

    def to_dict(self) -> dict:
        return {"kind": self.kind, "where": self.where, "evidence": self.evidence, "text": self.text}


def _channel(dofs, c: int) -> str:
    if not isinstance(dofs[c], (tuple, list)):  # a matrix model's DOF given by its row number
        return f"DOF {dofs[c]}"
    node, d = dofs[c]
    return f"{node}{d}"


def _key(ch):
    """A channel as a set key: (node, direction), or a matrix model's row number as it is."""
    return tuple(ch) if isinstance(ch, (tuple, list)) else ch


def _listed(ch):
    """A channel as JSON: [node, direction], or a matrix model's row number."""
    return list(ch) if isinstance(ch, (tuple, list)) else ch


def _shape_chi2(u_m: np.ndarray, sigma: np.ndarray, u_a: np.ndarray, hz_ratio_ok: np.ndarray):
    """For measured unit shapes u_m (..., n, m) with noise sigma (m,) and model unit shapes u_a
    (n, k): each mode's chi^2 against its best-MAC model mode among those allowed
    (hz_ratio_ok (m, k)), the partner's index and the MAC. Returns chi2 (..., m), partner (..., m),
    mac (..., m)."""
    macs = mac(u_m, u_a)                                     # (..., m, k)
    macs = np.where(hz_ratio_ok, macs, -1.0)
    partner = np.argmax(macs, axis=-1)                       # (..., m)
    ua = np.moveaxis(u_a[:, partner], 0, -2)                 # (..., n, m)
    sign = np.where(np.sum(ua * u_m, axis=-2, keepdims=True) < 0, -1.0, 1.0)
    r = (sign * ua - u_m) / sigma
    return np.sum(r * r, axis=-2), partner, np.take_along_axis(macs, partner[..., None], -1)[..., 0]


def check_data(frequencies_hz: np.ndarray, shapes: np.ndarray, has_shape: np.ndarray, model_hz: np.ndarray,
               model_shapes: np.ndarray, scale: float, dofs, shape_noise: float) -> tuple[DataCheck, ...]:
    """The data checks before a diagnosis (see the module docstring).

    frequencies_hz (m,), shapes (n, m) unit columns (NaN where not measured), has_shape (m,):
    the measured modes; model_hz (k,), model_shapes (n, k): the nominal model's modes at the
    measured coordinates; scale: the calibrated stiffness-to-mass scale; dofs: the measured
    coordinates (node, direction); shape_noise: as in the diagnosis."""
    out: list[DataCheck] = []
    hz = np.asarray(model_hz, dtype=float)
    hz = hz * np.sqrt(_scale_by_frequencies(np.asarray(frequencies_hz, dtype=float), hz, scale))
    sel = np.flatnonzero(has_shape)
    if len(sel) >= 2 and shapes.shape[0] >= 2:
        u_m = np.array(shapes[:, sel], dtype=float)
        u_a = model_shapes / np.linalg.norm(model_shapes, axis=0)
        ok = np.abs(hz[None, :] / frequencies_hz[sel, None] - 1.0) <= MAX_PAIR_FREQ
        ok[~ok.any(axis=1)] = True  # a mode with no model mode in reach: judged against all
        out += _channel_faults(u_m, u_a, ok, dofs, shape_noise)
        out += _mode_order(frequencies_hz, shapes, has_shape, hz, u_a)
        out += _duplicates(frequencies_hz, shapes, has_shape, u_a)
    return tuple(out)


def _scale_by_frequencies(f: np.ndarray, hz: np.ndarray, scale: float) -> float:
    """The stiffness-to-mass scale from the frequencies alone: the calibration pairs by MAC, which
    a fault of the shapes misleads (two exchanged shapes pair each frequency with a mode far off).
    Every ratio (f_i / hz_j)^2 is a trial scale (and `scale`); the one that brings most measured
    frequencies within 3 % of a model frequency (then the smallest mean log distance) wins, refined
    by the median ratio of those it matches."""
    trials = np.concatenate([[scale], ((f[:, None] / hz[None, :]) ** 2).ravel()])
    dist = np.abs(np.log(f[None, :, None] / (hz[None, None, :] * np.sqrt(trials)[:, None, None])))
    near = dist.min(axis=2)                                   # (T, m)
    hits = (near < 0.03).sum(axis=1)
    score = hits - np.minimum(near, 0.03).mean(axis=1)
    t = int(np.argmax(score))
    j = dist[t].argmin(axis=1)
    ok = near[t] < 0.03
    return float(np.median((f[ok] / hz[j[ok]]) ** 2)) if ok.any() else float(trials[t])


def _hypotheses(n: int):
    """Every single-channel reversal and two-channel exchange, as (kind, channels)."""
    for c in range(n):
        yield "channel_polarity", (c,)
    for c, d in itertools.combinations(range(n), 2):
        yield "channel_swap", (c, d)


def _undone(u_m: np.ndarray, kind: str, chans) -> np.ndarray:
    """The measured shapes (n, m) with the fault of one hypothesis undone."""
    out = np.array(u_m, dtype=float)
    if kind == "channel_polarity":
        out[chans[0]] *= -1.0
    else:
        out[[chans[0], chans[1]]] = out[[chans[1], chans[0]]]
    return out


#: Hypotheses scored at once by `_hypothesis_chi2` (its temporaries are (chunk, m, k) arrays).
HYPOTHESIS_CHUNK = 4096


def _hypothesis_chi2(u_m: np.ndarray, sigma: np.ndarray, u_a: np.ndarray, ok: np.ndarray, hyps) -> np.ndarray:
    """The shapes' chi^2 (summed over modes) of every hypothesis of `_hypotheses`, as `_shape_chi2`
    gives it for the shapes with the fault undone, without building those shapes: a reversal of
    channel c or an exchange of c and d changes the products of the measured shapes with the model's
    by a rank-one term (-2 u_c q_c, or (u_d - u_c)(q_c - q_d)) and leaves every norm and every
    mode's largest |entry| (so sigma) as they are. On 448 channels (100,576 hypotheses) the shapes
    themselves were a 2.9 GB array and 71 s of a 3,024-DOF diagnosis. Equal to `_shape_chi2` up to
    rounding (|r|^2 = |u_a|^2 + |u_m|^2 - 2 |u_a . u_m|): used to rank, not to report."""
    pm, qa = pow2_scaled(u_m), pow2_scaled(u_a)               # as `mac` scales them
    nm, na = np.sum(pm * pm, axis=0), np.sum(qa * qa, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = 1.0 / (nm[:, None] * na[None, :])               # (m, k)
    cross0, dot0 = pm.T @ qa, u_m.T @ u_a                     # (m, k) scaled, as given
    norms = np.sum(u_m * u_m, axis=0)[:, None] + np.sum(u_a * u_a, axis=0)[None, :]   # (m, k)
    c = np.array([h[1][0] for h in hyps])
    d = np.array([h[1][-1] for h in hyps])
    swap = np.array([h[0] == "channel_swap" for h in hyps])
    out = np.empty(len(hyps))
    for lo in range(0, len(hyps), HYPOTHESIS_CHUNK):
        cs, ds, sw = c[lo:lo + HYPOTHESIS_CHUNK], d[lo:lo + HYPOTHESIS_CHUNK], swap[lo:lo + HYPOTHESIS_CHUNK, None]
        # the rank-one terms: rows a (H, m) of the measured side, b (H, k) of the model's
        a_s = np.where(sw, pm[ds] - pm[cs], -2.0 * pm[cs])
        b_s = np.where(sw, qa[cs] - qa[ds], qa[cs])
        a_u = np.where(sw, u_m[ds] - u_m[cs], -2.0 * u_m[cs])
        b_u = np.where(sw, u_a[cs] - u_a[ds], u_a[cs])
        cross = cross0 + a_s[:, :, None] * b_s[:, None, :]   # (H, m, k)
        with np.errstate(invalid="ignore"):
            macs = np.nan_to_num(cross * cross * inv, nan=0.0)
        partner = np.argmax(np.where(ok, macs, -1.0), axis=-1)   # (H, m)
        rows_h = np.arange(len(cs))[:, None]
        cols_m = np.arange(u_m.shape[1])[None, :]
        dot = dot0[cols_m, partner] + a_u * b_u[rows_h, partner]
        chi = (norms[cols_m, partner] - 2.0 * np.abs(dot)) / (sigma * sigma)
        out[lo:lo + HYPOTHESIS_CHUNK] = chi.sum(axis=1)
    return out


def _channel_faults(u_m, u_a, ok, dofs, shape_noise) -> list[DataCheck]:
    n = u_m.shape[0]
    hyps = list(_hypotheses(n))
    found = []
    for _ in range(MAX_CHANNEL_FAULTS):
        sigma = shape_noise * np.max(np.abs(u_m), axis=0)
        chi0, part0, mac0 = _shape_chi2(u_m, sigma, u_a, ok)
        # every hypothesis ranked by its chi^2 from rank-one updates (`_hypothesis_chi2`); those
        # examined are scored again on their corrected shapes, as `_shape_chi2` scores the data
        drop = chi0.sum() - _hypothesis_chi2(u_m, sigma, u_a, ok, hyps)
        best = None
        for h in np.argsort(-drop):
            trial_h = _undone(u_m, *hyps[h])
            chi_h, part_h, macs_h = _shape_chi2(trial_h, sigma, u_a, ok)
            if chi0.sum() - chi_h.sum() < MIN_DROP or chi_h.sum() > 0.5 * chi0.sum():
                break
            kind, chans = hyps[h][0], hyps[h][1]
            ev = _consistent(kind, chans, u_m, u_a, part_h, macs_h, mac0)
            if ev is not None:
                best = h, ev
                break
        if best is None:
            break
        h, ev = best
        kind, chans = hyps[h][0], hyps[h][1]
        names = [_channel(dofs, c) for c in chans]
        ev.update({"chi2_shapes_as_given": float(chi0.sum()), "chi2_shapes_corrected": float(chi_h.sum())})
        if kind == "channel_polarity":
            text = (f"channel {names[0]} looks reversed in polarity: its sign disagrees with the model in every "
                    f"well-excited mode ({', '.join(map(str, ev['modes']))}) while the other channels agree; "
                    f"reversing it lowers the shapes' chi^2 from {chi0.sum():.4g} to {chi_h.sum():.4g}")
        else:
            text = (f"channels {names[0]} and {names[1]} look swapped: exchanging them raises the MAC in every mode "
                    f"where they differ ({', '.join(map(str, ev['modes']))}) and lowers the shapes' chi^2 from "
                    f"{chi0.sum():.4g} to {chi_h.sum():.4g}")
        found.append(DataCheck(kind, {"channels": [_listed(dofs[c]) for c in chans]}, ev, text))
        u_m = trial_h  # the next fault is sought in the data corrected by this one
    return found


def _consistent(kind, chans, u_m, u_a, partner, macs_fixed, macs_given) -> dict | None:
    """The evidence that the fault shows in every mode where it can be seen (None if it does not)."""
    ua = u_a[:, partner]                                       # (n, m) each mode's partner
    peak_a = np.max(np.abs(ua), axis=0)
    peak_m = np.max(np.abs(u_m), axis=0)
    if kind == "channel_polarity":
        c = chans[0]
        others = np.ones(u_m.shape[0], bool)
        others[c] = False
        mode_sign = np.sign(np.sum(ua[others] * u_m[others], axis=0))
        seen = (np.abs(ua[c]) >= EXCITED * peak_a) & (np.abs(u_m[c]) >= EXCITED * peak_m)
        disagree = ua[c] * u_m[c] * mode_sign < 0
        if seen.sum() < 2 or not disagree[seen].all():
            return None
        modes = np.flatnonzero(seen)
    else:
        c, d = chans
        seen = np.abs(ua[c] - ua[d]) >= EXCITED * peak_a
        if seen.sum() < 2 or not (macs_fixed[seen] > macs_given[seen]).all():
            return None
        modes = np.flatnonzero(seen)
    return {"modes": [int(i) + 1 for i in modes], "mac_as_given": [float(v) for v in macs_given[modes]],
            "mac_corrected": [float(v) for v in macs_fixed[modes]]}


def _mode_order(frequencies_hz, shapes, has_shape, hz, u_a) -> list[DataCheck]:
    """Two measured modes whose shapes belong to each other's frequency partners."""
    m = len(frequencies_hz)
    cost = np.abs(np.log(hz[None, :] / frequencies_hz[:, None]))
    rows, cols = linear_sum_assignment(cost)
    partner = np.full(m, -1)
    partner[rows] = cols
    macs = mac(np.nan_to_num(shapes), u_a)
    out = []
    for i, j in itertools.combinations(np.flatnonzero(has_shape & (partner >= 0)), 2):
        pi, pj = partner[i], partner[j]
        if (macs[i, pj] >= MATCH and macs[j, pi] >= MATCH and macs[i, pi] < 0.5 and macs[j, pj] < 0.5
                and abs(hz[pi] / hz[pj] - 1.0) > APART):
            out.append(DataCheck(
                "mode_order", {"modes": [int(i) + 1, int(j) + 1]},
                {"mac_own_partner": [float(macs[i, pi]), float(macs[j, pj])],
                 "mac_other_partner": [float(macs[i, pj]), float(macs[j, pi])],
                 "model_hz": [float(hz[pi]), float(hz[pj])]},
                f"modes {i + 1} and {j + 1} look exchanged: the shape measured at {frequencies_hz[i]:.4g} Hz is the "
                f"model's mode at {hz[pj]:.4g} Hz (MAC {macs[i, pj]:.2f}) and the one at {frequencies_hz[j]:.4g} Hz "
                f"is the model's mode at {hz[pi]:.4g} Hz (MAC {macs[j, pi]:.2f}), while each frequency is nearest "
                "the other's; two modes this far apart in frequency do not change order"))
    return out


def _duplicates(frequencies_hz, shapes, has_shape, u_a) -> list[DataCheck]:
    """Two measured modes, close in frequency, with one shape."""
    idx = np.flatnonzero(has_shape)
    own = mac(np.nan_to_num(shapes[:, idx]), np.nan_to_num(shapes[:, idx]))
    best = np.argmax(mac(np.nan_to_num(shapes[:, idx]), u_a), axis=1)
    out = []
    for a, b in itertools.combinations(range(len(idx)), 2):
        i, j = idx[a], idx[b]
        if own[a, b] >= DUPLICATE_MAC and abs(frequencies_hz[j] / frequencies_hz[i] - 1.0) < CLOSE \
                and best[a] == best[b]:
            out.append(DataCheck(
                "duplicate_mode", {"modes": [int(i) + 1, int(j) + 1]},
                {"mac_between": float(own[a, b]), "frequencies_hz": [float(frequencies_hz[i]), float(frequencies_hz[j])]},
                f"modes {i + 1} and {j + 1} look like one mode identified twice: their shapes agree (MAC "
                f"{own[a, b]:.3f}), their frequencies differ by {100 * abs(frequencies_hz[j] / frequencies_hz[i] - 1):.2g} %, "
                f"and both match the model's mode {best[a] + 1} best"))
    return out


def spurious_modes(unpaired_nominal, unpaired_final, frequencies_hz, skip=()) -> tuple[DataCheck, ...]:
    """Measured modes (0-based indices) that pair with no mode of the nominal model nor of the
    diagnosis's final model; `skip`: 1-based modes another check explains already."""
    out = []
    for i in sorted(set(int(k) for k in unpaired_nominal) & set(int(k) for k in unpaired_final)):
        if i + 1 in skip:
            continue
        out.append(DataCheck(
            "spurious_mode", {"modes": [i + 1]}, {"frequency_hz": float(frequencies_hz[i])},
            f"mode {i + 1} ({frequencies_hz[i]:.4g} Hz) pairs with no mode of the model, nor of the model the "
            "diagnosis extended: a spurious mode of the identification, or an effect outside the candidates"))
    return tuple(out)


#: The checks whose fault the diagnosis leaves out of its fit (`left_out`): the faults found before it.
FAULTS = ("channel_polarity", "channel_swap", "mode_order", "duplicate_mode")


def left_out(checks) -> dict:
    """What a diagnosis leaves out of its fit for the faults `checks` found (unless told to keep
    them): ``channels``, each faulty channel (node, direction) (a reversed one; both of a swapped
    pair: which is which is unknown); ``shapes``, the 1-based modes whose shapes are left out, their
    frequencies kept (two exchanged shapes: each belongs to the other's frequency); ``modes``, the
    1-based modes left out whole (of a mode identified twice, the second copy). Empty: no fault."""
    channels, shapes, modes = [], set(), set()
    for c in checks:
        if c.kind in ("channel_polarity", "channel_swap"):
            channels += [_key(ch) for ch in c.where["channels"] if _key(ch) not in channels]
        elif c.kind == "mode_order":
            shapes |= set(c.where["modes"])
        elif c.kind == "duplicate_mode":
            modes.add(max(c.where["modes"]))
    out = {}
    if channels:
        out["channels"] = [_listed(ch) for ch in channels]
    if shapes - modes:
        out["shapes"] = sorted(shapes - modes)
    if modes:
        out["modes"] = sorted(modes)
    return out


def without(data, leave: dict):
    """The modal data (`ModalData`) with what `left_out` names left out: its channels' rows, its
    shapes (NaN: frequency only), its modes. Mode numbers in `leave` are the file's (1-based)."""
    import dataclasses

    if not leave:
        return data
    shapes = np.array(data.shapes, dtype=float)
    shape_std = np.array(data.shape_std, dtype=float)  # a stated deviation goes where its entry goes
    for m in leave.get("shapes", []):
        shapes[:, m - 1] = np.nan
        shape_std[:, m - 1] = np.nan
    gone = {_key(ch) for ch in leave.get("channels", [])}
    rows = [i for i, d in enumerate(data.dofs) if _key(d) not in gone]
    keep = [k for k in range(data.n_modes) if k + 1 not in set(leave.get("modes", []))]
    return dataclasses.replace(data, dofs=tuple(data.dofs[i] for i in rows),
                               frequencies_hz=np.asarray(data.frequencies_hz)[keep], shapes=shapes[np.ix_(rows, keep)],
                               frequency_std_hz=np.asarray(data.frequency_std_hz)[keep],
                               shape_std=shape_std[np.ix_(rows, keep)])
