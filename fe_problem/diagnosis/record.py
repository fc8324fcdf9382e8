"""The diagnosis record: typed, frozen dataclasses; JSON only at the edge (`Diagnosis.to_dict()`).

`to_dict()` of each part gives the keys `femu diagnose --json` has always printed, in the same
order; numbers stay numpy until `fe_problem.jsonutil.jsonable` cleans them (NaN and inf become
None). Readers (the report, the terminal summary) use the attributes.

Units: frequencies in Hz, errors in % of the measured frequency, moduli in Pa, masses in kg;
chi^2 values are sums of squared noise-weighted residuals (dimensionless).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..correlation import Correlation
from ..jsonutil import jsonable
from ..model import FrameModel, model_to_dict


@dataclass(frozen=True)
class Cause:
    """The answer: which effect, where, how big.

    kind: a candidate kind, ``"none"`` (nothing significant) or ``"undetermined"`` (tied
    candidates of different kinds); location: ``{"element": id}``, ``{"node": id}``,
    ``{"node": id, "element": id}`` or None (no place, or tied candidates disagree on it);
    estimate: the effect's size in the candidate's own terms (empty unless identifiable);
    identifiable: False when several candidates explain the data equally well; p_adjusted: the
    Bonferroni-adjusted p-value of the best candidate; label: the best candidate's label (None
    when not identifiable; absent from the JSON when kind is none); indistinguishable: the tied
    candidates' labels; explanation: why the answer is none or not identifiable; plausible: False
    when the estimate lies beyond a physical bound (plausibility.py), `implausible_because` says which.
    """

    kind: str
    location: dict | None
    estimate: dict
    identifiable: bool
    p_adjusted: float
    label: str | None = None
    indistinguishable: tuple[str, ...] = ()
    explanation: str | None = None
    plausible: bool = True
    implausible_because: str | None = None

    @property
    def is_none(self) -> bool:
        """No candidate is significant."""
        return self.kind == "none"

    def to_dict(self) -> dict:
        out = {"kind": self.kind, "location": self.location, "estimate": self.estimate,
               "identifiable": self.identifiable, "p_adjusted": self.p_adjusted}
        if not self.is_none:
            out["label"] = self.label
        if not self.identifiable:
            out["indistinguishable"] = list(self.indistinguishable)
        if self.explanation is not None:
            out["explanation"] = self.explanation
        if self.estimate:  # judged only where there is an estimate
            out["plausible"] = self.plausible
            if not self.plausible:
                out["implausible_because"] = self.implausible_because
        return out


#: Families whose class, as the answer, stands in place of the local search's result.
NON_LOCAL = ("distributed", "sparse", "model_form")


@dataclass(frozen=True)
class Answer:
    """The answer: the best model class by evidence (evidence.py), and whether the data decide it.

    label, family (``none``, ``local``, ``several``, ``distributed``, ``sparse``, ``model_form``),
    kind and location (as in `Cause`; a sparse class's ``{"members": [...]}``, a group's
    ``{"group": name}``), estimate (None for several causes: see `Diagnosis.causes`),
    log_evidence against the calibrated model; decisive: False when a class that is a different
    answer (another family, or another place or kind) has a log evidence within ln 10 of it
    (`evidence.FACTOR_10`) or above it; runner_up: that class's ``{"label", "family", "estimate",
    "log_evidence"}`` (the best different answer, decisive or not; None when there is none);
    plausible, implausible_because: as in `Cause`. Within the local family (one cause or several)
    the local search's rounds choose; between families the evidence does (core.diagnose).
    not_decisive_because: why an answer is not decisive whatever its evidence (it rests on fewer
    residual degrees of freedom than `plausibility.MIN_DOF`; the data have a fault), else None."""

    label: str
    family: str
    kind: str
    location: dict | None
    estimate: dict | None
    log_evidence: float
    decisive: bool
    runner_up: dict | None = None
    plausible: bool = True
    implausible_because: str | None = None
    not_decisive_because: str | None = None

    @property
    def is_local(self) -> bool:
        """The answer is the local search's result (none, one cause or several), not another class."""
        return self.family not in NON_LOCAL

    def to_dict(self) -> dict:
        out = {k: getattr(self, k) for k in ("label", "family", "kind", "location", "estimate", "log_evidence",
                                              "decisive", "runner_up")}
        if self.estimate:
            out["plausible"] = self.plausible
            if not self.plausible:
                out["implausible_because"] = self.implausible_because
        if self.not_decisive_because:
            out["not_decisive_because"] = self.not_decisive_because
        return out


@dataclass(frozen=True)
class Found:
    """One cause of a diagnosis with several: kind, location (as in `Cause`), estimate, and its
    interval: for each numeric estimate a [low, high] pair at `level` (profile likelihood of the
    effect size, the other causes and the global scale at their best values; `None` where the
    bound was not reached inside the candidate's range). p_adjusted: the Bonferroni-adjusted
    p-value of its round; identifiable, indistinguishable, plausible, implausible_because: as in `Cause`."""

    kind: str
    location: dict | None
    estimate: dict
    interval: dict
    label: str | None
    p_adjusted: float
    identifiable: bool = True
    indistinguishable: tuple[str, ...] = ()
    plausible: bool = True
    implausible_because: str | None = None

    def to_dict(self) -> dict:
        out = {"kind": self.kind, "location": self.location, "estimate": self.estimate, "interval": self.interval,
               "label": self.label, "p_adjusted": self.p_adjusted, "identifiable": self.identifiable}
        if not self.identifiable:
            out["indistinguishable"] = list(self.indistinguishable)
        if self.estimate:
            out["plausible"] = self.plausible
            if not self.plausible:
                out["implausible_because"] = self.implausible_because
        return out


@dataclass(frozen=True)
class Verdict:
    """Goodness of fit of the final model (calibrated, with every cause found) against the
    stated noise: chi^2 over `dof` degrees of freedom (residuals less one per measured shape,
    less the fitted parameters), reduced_chi2 = chi2 / dof and the p-value P(chi^2_dof >= chi2).
    adequate: p_value >= alpha (the misfit is what the noise explains). implied_freq_noise,
    implied_shape_noise: the noise levels (same convention as the stated ones) at which the
    final model's frequency and shape residuals would be exactly typical, i.e. the noise the
    data imply if the final model is right (None without such residuals). explanation: a
    sentence for the user."""

    adequate: bool
    chi2: float
    dof: int
    reduced_chi2: float
    p_value: float
    alpha: float
    implied_freq_noise: float | None
    implied_shape_noise: float | None
    explanation: str

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class Noise:
    """The noise model the residuals were weighted with: relative frequency std, shape std as a
    fraction of the largest |entry| of each mode (`shape_convention`), and where they came from
    (`source`: "stated" by the caller or "default"). `data_deviations` (frequencies, shapes,
    modes): how many of the data's modes state their own deviations, which replace this noise
    model for them (`residuals.Observations`); left out of the record when none do."""

    freq_noise: float
    shape_noise: float
    source: str
    shape_convention: str = "fraction of the largest |entry| of each measured mode"
    data_deviations: tuple[int, int, int] = (0, 0, 0)

    def to_dict(self) -> dict:
        out = {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "data_deviations"}
        if any(self.data_deviations[:2]):
            out["data_deviations"] = dict(zip(("frequencies", "shapes", "modes"), self.data_deviations))
        return out


@dataclass(frozen=True)
class PinnedParameter:
    """An element modulus that a bounded update (+-1/7 of the calibrated value) drives to a bound."""

    parameter: str
    element: int
    bound: str          # "lower" or "upper"
    value_pa: float


@dataclass(frozen=True, eq=False)
class Residuals:
    """What the calibrated model (nominal model times the global stiffness scale) gets wrong.

    correlation: per-mode frequencies, errors, MAC, COMAC and the MAC matrix (every measured
    mode); global_scale: the stiffness-to-mass scale; chi2 over n_residuals residuals of the
    paired modes (reduced_chi2 = chi2 / dof, dof = n_residuals - one per measured shape - 1,
    as in the verdict); unpaired_modes: 1-based measured modes that pair with no model mode;
    measured_dofs: the measured coordinates (node, "x"/"y").
    """

    correlation: Correlation
    global_scale: float
    chi2: float
    n_residuals: int
    reduced_chi2: float
    unpaired_modes: tuple[int, ...]
    pinned_parameters: tuple[PinnedParameter, ...]
    measured_dofs: tuple[tuple[int, str], ...]

    def to_dict(self) -> dict:
        return {**self.correlation.to_dict(), "global_scale": self.global_scale, "chi2": self.chi2,
                "n_residuals": self.n_residuals, "reduced_chi2": self.reduced_chi2,
                "mac_matrix": self.correlation.mac_matrix, "unpaired_modes": list(self.unpaired_modes),
                "pinned_parameters": list(self.pinned_parameters),
                "measured_dofs": [list(d) for d in self.measured_dofs]}


@dataclass(frozen=True)
class Selection:
    """How the cause was chosen: the likelihood-ratio test and its settings.

    statistic: the chi^2 drop of the best candidate divided by the dispersion; p_value (single
    test), p_adjusted (times n_candidates, at most 1); threshold_chi2_drop: the drop the best
    candidate needs to be significant at alpha; dispersion: max(1, reduced chi^2 of the best);
    ambiguity_chi2: candidates closer than this to the best cannot be told apart; freq_noise,
    shape_noise: the noise model (relative standard deviations).
    """

    method: str
    alpha: float
    n_candidates: int
    threshold_chi2_drop: float
    n_fitted: int
    statistic: float
    p_value: float
    p_adjusted: float
    dispersion: float
    ambiguity_chi2: float
    freq_noise: float
    shape_noise: float

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class CandidateFit:
    """One candidate's scores: screened (first-order chi^2 drop) and, if fitted, its fit.

    chi2, chi2_drop (against the calibrated model), delta_to_best (chi^2 distance to the best,
    divided by the dispersion), estimate (the effect size in the candidate's terms) and
    global_scale are None unless fitted.
    """

    label: str
    kind: str
    location: dict | None
    screen_chi2_drop: float
    fitted: bool
    chi2: float | None = None
    chi2_drop: float | None = None
    delta_to_best: float | None = None
    estimate: dict | None = None
    global_scale: float | None = None

    def to_dict(self) -> dict:
        out = {"label": self.label, "kind": self.kind, "location": self.location,
               "screen_chi2_drop": self.screen_chi2_drop, "fitted": self.fitted}
        if self.fitted:
            out.update({"chi2": self.chi2, "chi2_drop": self.chi2_drop, "delta_to_best": self.delta_to_best,
                        "estimate": self.estimate, "global_scale": self.global_scale})
        return out

    def alternative_dict(self) -> dict:
        """The fitted candidate as an entry of the record's `alternatives`."""
        return {"kind": self.kind, "location": self.location, "label": self.label, "estimate": self.estimate,
                "chi2_drop": self.chi2_drop, "delta_to_best": self.delta_to_best}


@dataclass(frozen=True, eq=False)
class Gain:
    """The held-out test: the highest quarter of the paired modes predicted by models refitted
    on the rest. held_out_modes, fit_modes: 1-based; before: the calibrated model's prediction;
    after: the extended model's (None without a cause); estimate_from_fit_modes: the effect
    refitted on the fit modes alone; note: why nothing was held out (then the rest is empty);
    prediction_interval_hz: per held-out mode the [low, high] frequency (Hz) the extended model
    predicts over its effect's 95 % profile-likelihood interval."""

    held_out_modes: tuple[int, ...] = ()
    fit_modes: tuple[int, ...] = ()
    before: Correlation | None = None
    after: Correlation | None = None
    estimate_from_fit_modes: dict | None = None
    note: str | None = None
    prediction_interval_hz: tuple = ()

    @property
    def mean_abs_error_pct_reduction(self) -> float | None:
        """Mean |frequency error| before minus after, percentage points (None if either is missing)."""
        b, a = _mean(self.before, "mean_abs_error_pct"), _mean(self.after, "mean_abs_error_pct")
        return None if b is None or a is None else b - a

    @property
    def mean_mac_gain(self) -> float | None:
        """Mean MAC after minus before (None if either is missing)."""
        b, a = _mean(self.before, "mean_mac"), _mean(self.after, "mean_mac")
        return None if b is None or a is None else a - b

    def to_dict(self) -> dict:
        if not self.held_out_modes:
            return {"held_out_modes": [], "note": self.note}
        out = {"held_out_modes": list(self.held_out_modes), "fit_modes": list(self.fit_modes),
               "before": self.before}
        if self.after is not None:
            out["after"] = self.after
            out["estimate_from_fit_modes"] = self.estimate_from_fit_modes
            for key in ("mean_abs_error_pct_reduction", "mean_mac_gain"):
                if getattr(self, key) is not None:
                    out[key] = getattr(self, key)
            out["prediction_interval_hz"] = [list(p) for p in self.prediction_interval_hz]
        return out


def _mean(c: Correlation | None, key: str) -> float | None:
    return None if c is None else getattr(c, key)


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """The answer of a diagnosis; `to_dict()` is the JSON `femu diagnose --json` prints.

    candidates: every candidate in screening order (fitted ones first); alternatives: the
    fitted candidates shown beside the cause; extended_model: the calibrated model with every
    cause's effect (None when the cause is none); warnings: sentences for the user; causes:
    every cause the local search found, in order of evidence (the local class's causes; `cause` is
    the first when the answer is local); verdict: the final model's goodness of fit; noise: the
    noise model used; data_checks: faults found in the data before the diagnosis
    (`datachecks.DataCheck`), which ran on the data as given; evidence: every model class (none,
    local, distributed, sparse, model_form, several) ranked by its evidence (`evidence.Evidence`);
    answer: the best class by evidence (`Answer`). When the answer is not a local class (a
    distributed, sparse or model-form class) `cause`, `extended_model`, `gain` and `verdict` are
    that class's and `causes` stay the local search's. Records written before `answer` existed
    have none (None here). dropped: the candidates and classes whose solve failed numerically,
    each {"label", "reason"}, left out of the fits, the test and the evidence (dropped.py);
    left_out: the faulty channels, shapes and modes the diagnosis left out of its fit
    (`datachecks.left_out`; empty: none, or kept).
    """

    cause: Cause
    alternatives: tuple[CandidateFit, ...]
    residuals: Residuals
    gain: Gain
    candidates: tuple[CandidateFit, ...]
    selection: Selection
    extended_model: FrameModel | None
    warnings: tuple[str, ...] = field(default_factory=tuple)
    causes: tuple[Found, ...] = ()
    verdict: Verdict | None = None
    noise: Noise | None = None
    data_checks: tuple = ()
    evidence: object = None
    answer: Answer | None = None
    dropped: tuple = ()
    left_out: dict = field(default_factory=dict)

    @property
    def adequate(self) -> bool | None:
        """Whether the final model fits within the noise (None if not tested)."""
        return None if self.verdict is None else self.verdict.adequate

    @property
    def best(self) -> CandidateFit | None:
        """The fitted candidate with the lowest chi^2 (the one the test was applied to)."""
        fitted = [c for c in self.candidates if c.fitted and c.chi2 is not None and np.isfinite(c.chi2)]
        return min(fitted, key=lambda c: c.chi2) if fitted else None

    def to_dict(self) -> dict:
        """Plain JSON values only: numbers, strings, lists, dicts; NaN and inf as None."""
        return jsonable({"cause": self.cause, "alternatives": [a.alternative_dict() for a in self.alternatives],
                         "residuals": self.residuals, "gain": self.gain, "selection": self.selection,
                         "candidates": list(self.candidates), "warnings": list(self.warnings),
                         "extended_model": _model_dict(self.extended_model),
                         "causes": list(self.causes), "adequate": self.adequate,
                         "goodness_of_fit": self.verdict, "noise": self.noise,
                         "data_checks": [c.to_dict() for c in self.data_checks],
                         "evidence": None if self.evidence is None else self.evidence.to_dict(),
                         "answer": self.answer, "dropped": list(self.dropped),
                         "left_out": dict(self.left_out)})


def _model_dict(model) -> dict | None:
    """The extended model in the record: a frame model's file content; a matrix model's manifest
    fields without its matrices (name, DOF count, each term's name, family and multiplier; the
    files are written beside diagnosis.json by `femu diagnose --out`)."""
    if model is None:
        return None
    if isinstance(model, FrameModel):
        return model_to_dict(model)
    return {"format": "femu.matrix-model/1", "name": model.name, "dofs": model.n_dof,
            "description": model.description,
            **{family: [{"name": t.name, "initial": t.initial} for t in getattr(model, family)]
               for family in ("stiffness", "mass")}}
