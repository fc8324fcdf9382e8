"""`diagnose(model, data)`: show what the model gets wrong, name the cause, extend the model,
measure the gain on held-out modes.

Steps
1. Calibrate the global stiffness-to-mass scale (what every model is allowed) and show the
   residuals: frequency errors, MAC matrix, COMAC, pairing, and the element moduli that a
   bounded update (+-1/7 around the calibrated value, the paper's 6-8e10 Pa range) pins to
   a bound.
2. Screen every candidate by its first-order chi^2 drop, fit the promising ones (a batched
   grid over the effect size, then a bounded scalar refinement), and select.
3. Selection: a likelihood-ratio test of the best candidate against the calibrated model.
   Each candidate adds one parameter, bounded at zero, so under "no effect" the statistic is
   a 50:50 mixture of chi^2_0 and chi^2_1; the p-value is multiplied by the number of
   candidates tried (Bonferroni), since the best of many is being tested. The statistic is
   divided by the best model's reduced chi^2 when that exceeds 1 (quasi-likelihood), so a
   remaining misfit makes the test more cautious, never less. Significant at alpha = 0.01,
   otherwise the cause is ``none``. Candidates whose chi^2 lies within 2 ln 20 = 6 of the
   best (likelihood ratio < 20, "strong evidence" on the Kass-Raftery scale) cannot be told
   apart from it: then the cause says so (``identifiable: false``) and lists them, with the
   kind (and place) given only where all of them agree.
4. The extended model (calibrated, with the effect) as a model file.
5. Gain: the highest quarter of the modes (at least one) is held out; the calibrated model
   and the extended model are refitted without them and both predict them. (The choice of
   candidate saw every mode; the parameters that make the prediction did not.)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2 as chi2_dist

from ..correlation import comac, mac
from ..modal_data import DataFileError, ModalData, load_modal_data
from ..model import FrameModel, load_model, model_to_dict
from ..assembly import AffineModel
from ..parameters import element_moduli
from .candidates import Candidate, Setting, all_candidates, scale_stiffness, solve
from .fit import Fit, fit, profiled, screen
from .residuals import Observations

ALPHA = 0.01
AMBIGUITY_CHI2 = 2.0 * np.log(20.0)
MIN_MODES = 3


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """The answer of a diagnosis; `to_dict()` is the JSON the CLI prints."""

    cause: dict
    alternatives: list
    residuals: dict
    gain: dict
    candidates: list
    selection: dict
    extended_model: FrameModel | None
    warnings: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """Plain JSON values only: numbers, strings, lists, dicts; NaN and inf as None."""
        return _num({"cause": self.cause, "alternatives": self.alternatives, "residuals": self.residuals,
                     "gain": self.gain, "selection": self.selection, "candidates": self.candidates,
                     "warnings": self.warnings,
                     "extended_model": None if self.extended_model is None else model_to_dict(self.extended_model)})


def _num(x):
    """JSON-friendly floats (NaN and inf become None)."""
    if isinstance(x, dict):
        return {k: _num(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [_num(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if np.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def _modes_of(system_or_cand, a: float, st: Setting):
    if isinstance(system_or_cand, Candidate):
        hz, sh = system_or_cand.forward(np.array([a]))
    else:
        hz, sh = solve(system_or_cand, np.zeros((1, 0)), st.coords, st.n_modes)
    return hz[0], sh[0]


def _correlate(obs: Observations, hz: np.ndarray, shapes: np.ndarray, s: float, pairing: np.ndarray) -> dict:
    """Per-mode errors, MAC and COMAC of a calibrated model against observations."""
    f = hz * np.sqrt(s)
    ok = pairing >= 0
    model_hz = np.where(ok, f[np.clip(pairing, 0, None)], np.nan)
    err = 100.0 * (model_hz - obs.frequencies_hz) / obs.frequencies_hz
    macs = np.full(obs.n_modes, np.nan)
    cm = None
    sel = obs.has_shape & ok
    if sel.any():
        paired = shapes[:, pairing[sel]]
        macs[sel] = np.diag(mac(obs.shapes[:, sel], paired))
        cm = comac(obs.shapes[:, sel], paired)
    return {"measured_hz": obs.frequencies_hz, "model_hz": model_hz, "error_pct": err,
            "mean_abs_error_pct": float(np.nanmean(np.abs(err))) if ok.any() else None,
            "mac": macs, "mean_mac": float(np.nanmean(macs)) if sel.any() else None,
            "comac": cm, "mean_comac": float(np.mean(cm)) if cm is not None else None,
            "paired_model_mode": np.where(ok, pairing + 1, -1)}


def _pinned_moduli(st: Setting, obs: Observations, s: float, pairing: np.ndarray) -> list:
    """Element moduli a bounded update (+-1/7 of the calibrated value) drives to a bound."""
    params = element_moduli(st.model)
    system = AffineModel(st.model, params)
    e0 = system.x0 * s
    lo, hi = e0 * 6.0 / 7.0, e0 * 8.0 / 7.0

    def residuals(z):  # z in [0, 1]^12: the moduli scaled into their bounds
        hz, sh = solve(system, (lo + z * (hi - lo))[None], st.coords, st.n_modes)
        return obs.residuals(hz[0], sh[0], pairing)[0]

    res = least_squares(residuals, np.full(len(params), 0.5), bounds=(0.0, 1.0), diff_step=1e-4, max_nfev=60)
    out = []
    for p, z in zip(params, res.x):
        if z <= 0.005 or z >= 0.995:
            out.append({"parameter": p.label, "element": p.targets[0], "bound": "lower" if z <= 0.005 else "upper",
                        "value_pa": float(lo[params.index(p)] + z * (hi - lo)[params.index(p)])})
    return out


def _check(model: FrameModel, data: ModalData) -> None:
    data_model = data.model
    if data_model != model.name and not data_model.endswith((f"{model.name}.json", f"{model.name}.model.json")):
        raise DataFileError(f"{data.source}: the data are for model {data_model!r}, not {model.name!r} "
                            "(pass the data's own model, or data measured on this one)")
    data.check_model(model)
    if data.n_modes < MIN_MODES:
        raise DataFileError(f"{data.source}: {data.n_modes} mode(s) are too few to say anything: "
                            f"a diagnosis needs at least {MIN_MODES}")


def diagnose(model: FrameModel | str | None, data: ModalData | str, freq_noise: float = 0.002,
             shape_noise: float = 0.02, kinds=None, n_fit: int = 8, alpha: float = ALPHA) -> Diagnosis:
    """Diagnose what `model` misses in `data` (see the module docstring for the method).

    freq_noise: std of a measured frequency, relative (0.002 = 0.2 %); shape_noise: std of a
    measured shape entry relative to the mode's RMS (0.02 = 2 %). kinds: candidate kinds to
    try (default all); n_fit: how many screened candidates are fitted properly.
    """
    data = load_modal_data(data)
    model = data.load_model() if model is None else load_model(model)
    _check(model, data)
    warnings: list[str] = []
    st = Setting(model, data.dofs, min(data.n_modes + 6, AffineModel(model).n_elastic))
    baseline_system = AffineModel(model)
    obs_all = Observations.of(data, freq_noise=freq_noise, shape_noise=shape_noise)
    hz0, sh0 = _modes_of(baseline_system, 0.0, st)
    base_all = profiled(obs_all, hz0, sh0)

    # measured modes that pair with no model mode are shown, never fitted
    unpaired = np.flatnonzero(base_all.pairing < 0)
    used = np.flatnonzero(base_all.pairing >= 0)
    if len(unpaired):
        warnings.append(f"measured mode(s) {[int(i) + 1 for i in unpaired]} pair with no model mode "
                        "(MAC < 0.5 with every model mode, or no model frequency within 30 %): left out of the fit")
    if len(used) < MIN_MODES:
        raise DataFileError(f"{data.source}: only {len(used)} measured mode(s) pair with a mode of model "
                            f"{model.name!r}; a diagnosis needs at least {MIN_MODES}")
    if not obs_all.has_shape[used].any():
        warnings.append("no measured shapes: frequencies alone can rarely tell a place apart")
    obs = Observations.of(data, modes=used, freq_noise=freq_noise, shape_noise=shape_noise)
    base = profiled(obs, hz0, sh0)

    residual_view = _correlate(obs_all, hz0, sh0, base.s, base_all.pairing)
    residual_view.update({
        "global_scale": base.s, "chi2": base.chi2, "n_residuals": obs.n_residuals,
        "reduced_chi2": base.chi2 / max(obs.n_residuals - 1, 1),
        "mac_matrix": mac(np.nan_to_num(obs_all.shapes), sh0) if obs_all.has_shape.any() else None,
        "unpaired_modes": [int(i) + 1 for i in unpaired],
        "pinned_parameters": _pinned_moduli(st, obs, base.s, base.pairing),
        "measured_dofs": [list(d) for d in data.dofs],
    })

    # screen every candidate, fit the promising ones
    cands = all_candidates(st, kinds)
    screened = [(screen(obs, c, base), c) for c in cands]
    order = sorted(range(len(cands)), key=lambda i: -screened[i][0][0])
    fitted: dict[int, Fit] = {i: fit(obs, cands[i], screened[i][0][1]) for i in order[:n_fit]}

    n_params_best = 2
    best_i = min(fitted, key=lambda i: fitted[i].chi2)
    best = fitted[best_i]
    dof = max(obs.n_residuals - n_params_best, 1)
    dispersion = max(1.0, best.chi2 / dof)
    lr = max(base.chi2 - best.chi2, 0.0) / dispersion
    p_single = 0.5 * chi2_dist.sf(lr, 1) if lr > 0 else 1.0
    p_adj = min(1.0, p_single * len(cands))
    significant = p_adj < alpha

    table = []
    for i in order:
        c = cands[i]
        row = {"label": c.label, "kind": c.kind, "location": c.location,
               "screen_chi2_drop": screened[i][0][0], "fitted": i in fitted}
        if i in fitted:
            f = fitted[i]
            row.update({"chi2": f.chi2, "chi2_drop": base.chi2 - f.chi2,
                        "delta_to_best": (f.chi2 - best.chi2) / dispersion,
                        "estimate": c.estimate(f.a, f.s), "global_scale": f.s})
        table.append(_num(row))

    # the chi^2 drop the best candidate must exceed to be significant (the test, inverted)
    threshold = dispersion * chi2_dist.isf(min(1.0, 2.0 * alpha / len(cands)), 1)
    selection = _num({"method": "likelihood ratio vs the calibrated model, Bonferroni over candidates, "
                                "quasi-likelihood dispersion", "alpha": alpha, "n_candidates": len(cands),
                      "threshold_chi2_drop": threshold,
                      "n_fitted": len(fitted), "statistic": lr, "p_value": p_single, "p_adjusted": p_adj,
                      "dispersion": dispersion, "ambiguity_chi2": AMBIGUITY_CHI2,
                      "freq_noise": freq_noise, "shape_noise": shape_noise})

    if not significant:
        cause = {"kind": "none", "location": None, "estimate": {}, "identifiable": True,
                 "p_adjusted": p_adj, "explanation": "no candidate explains the residuals significantly "
                 "better than the calibrated model"}
        close = [i for i in order[:3] if i in fitted]
        alternatives = [_alt(cands[i], fitted[i], base, best, dispersion) for i in close]
        gain = _gain(st, data, used, freq_noise, shape_noise, None)
        return Diagnosis(_num(cause), _num(alternatives), _num(residual_view), _num(gain), table, selection,
                         None, warnings)

    tied = [i for i in fitted if (fitted[i].chi2 - best.chi2) / dispersion < AMBIGUITY_CHI2]
    tied.sort(key=lambda i: fitted[i].chi2)
    c_best = cands[best_i]
    # candidates that differ only in how a loss is spread along one element are one answer
    answers = {(cands[i].kind, str(cands[i].location)) for i in tied}
    identifiable = len(answers) == 1
    kinds_tied = {cands[i].kind for i in tied}
    places_tied = {str(cands[i].location) for i in tied}
    cause = {"kind": c_best.kind if len(kinds_tied) == 1 else "undetermined",
             "location": c_best.location if len(places_tied) == 1 else None,
             "estimate": c_best.estimate(best.a, best.s) if identifiable else {},
             "identifiable": identifiable, "p_adjusted": p_adj, "label": c_best.label if identifiable else None}
    if not identifiable:
        cause["indistinguishable"] = [cands[i].label for i in tied]
        cause["explanation"] = (f"{len(answers)} candidates explain the data equally well (chi^2 within "
                                f"{AMBIGUITY_CHI2:.1f} of the best): the data cannot tell them apart")
        warnings.append(cause["explanation"])
    alternatives = [_alt(cands[i], fitted[i], base, best, dispersion)
                    for i in sorted(fitted, key=lambda i: fitted[i].chi2)
                    if (cands[i].kind, cands[i].location) != (c_best.kind, c_best.location)]
    extended = scale_stiffness(c_best.extend(best.a), best.s).replace(
        name=f"{model.name}+{c_best.label}", description=f"{model.name} extended by diagnosis: {c_best.label} "
        f"({_describe(c_best.estimate(best.a, best.s))}), stiffness scaled by {best.s:.5f}", source="<diagnosis>")
    gain = _gain(st, data, used, freq_noise, shape_noise, c_best)
    return Diagnosis(_num(cause), _num(alternatives), _num(residual_view), _num(gain), table, selection,
                     extended, warnings)


def _describe(estimate: dict) -> str:
    return ", ".join(f"{k} {v:.4g}" for k, v in estimate.items() if isinstance(v, (int, float)))


def _alt(c: Candidate, f: Fit, base: Fit, best: Fit, dispersion: float) -> dict:
    return {"kind": c.kind, "location": c.location, "label": c.label, "estimate": c.estimate(f.a, f.s),
            "chi2_drop": base.chi2 - f.chi2, "delta_to_best": (f.chi2 - best.chi2) / dispersion}


def _gain(st: Setting, data: ModalData, used: np.ndarray, freq_noise: float, shape_noise: float,
          cand: Candidate | None) -> dict:
    """Refit without the highest quarter of the modes and predict them, before and after."""
    n_hold = max(1, int(round(len(used) / 4)))
    if len(used) - n_hold < 2:
        return {"held_out_modes": [], "note": "too few modes to hold any out"}
    fit_modes, hold = used[:-n_hold], used[-n_hold:]
    obs_fit = Observations.of(data, modes=fit_modes, freq_noise=freq_noise, shape_noise=shape_noise)
    obs_hold = Observations.of(data, modes=hold, freq_noise=freq_noise, shape_noise=shape_noise)
    hz0, sh0 = _modes_of(AffineModel(st.model), 0.0, st)
    b = profiled(obs_fit, hz0, sh0)
    before = _correlate(obs_hold, hz0, sh0, b.s, obs_hold.pair(hz0 * np.sqrt(b.s), sh0))
    out = {"held_out_modes": [int(i) + 1 for i in hold], "fit_modes": [int(i) + 1 for i in fit_modes],
           "before": before}
    if cand is not None:
        f = fit(obs_fit, cand)
        hz, sh = _modes_of(cand, f.a, st)
        after = _correlate(obs_hold, hz, sh, f.s, obs_hold.pair(hz * np.sqrt(f.s), sh))
        out["after"] = after
        out["estimate_from_fit_modes"] = cand.estimate(f.a, f.s)
        if before["mean_abs_error_pct"] is not None and after["mean_abs_error_pct"] is not None:
            out["mean_abs_error_pct_reduction"] = before["mean_abs_error_pct"] - after["mean_abs_error_pct"]
        if before["mean_mac"] is not None and after["mean_mac"] is not None:
            out["mean_mac_gain"] = after["mean_mac"] - before["mean_mac"]
    return out
