"""Diagnosis: what the model gets wrong, which physical effect explains it, the extended model,
and the gain on held-out modes. See core.py for the method, record.py for the answer's record."""

from .candidates import CANDIDATE_KINDS, DEFAULT_KINDS, Candidate, Setting, all_candidates
from .dispatch import diagnose
from .record import Answer, CandidateFit, Cause, Diagnosis, Gain, PinnedParameter, Residuals, Selection

__all__ = ["CANDIDATE_KINDS", "DEFAULT_KINDS", "Answer", "Candidate", "CandidateFit", "Cause", "Diagnosis", "Gain",
           "PinnedParameter", "Residuals", "Selection", "Setting", "all_candidates", "diagnose"]
