"""Diagnosis: what the model gets wrong, which physical effect explains it, the extended model,
and the gain on held-out modes. See core.py for the method."""

from .candidates import CANDIDATE_KINDS, KINDS, Candidate, Setting, all_candidates
from .core import Diagnosis, diagnose

__all__ = ["CANDIDATE_KINDS", "KINDS", "Candidate", "Diagnosis", "Setting", "all_candidates", "diagnose"]
