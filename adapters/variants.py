"""Problem variants a study can run: each name builds one UpdatingProblem, the same in every
process (no randomness outside a fixed seed).

- ``paper``: the paper's five measured frequencies, 12 element moduli, eq. 4 gamma weights.
- ``synthetic``: 8 modes with shapes at the 15 measured coordinates, measured on an H-frame
  whose elements 3 and 5 lost stiffness (E = 6.3e10 and 6.5e10 Pa, inside the bounds, so the
  optimum is known), 0.2 % frequency and 2 % shape noise (seed 0); unit weights plus the
  (1 - MAC) shape term.
- ``user:PATH``: a user's own model, data and parameters (PATH a problem source file that
  `femu study --model` writes: the files' paths and SHA-256), the balanced objective of
  `femu update` (fe_problem.user_problem).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from fe_problem import UpdatingProblem, load_model, synthetic_measurement

VARIANTS = ("paper", "synthetic")

#: The hidden moduli of the synthetic variant (Pa), element id -> E.
SYNTHETIC_TRUTH = {3: 6.3e10, 5: 6.5e10}


@lru_cache(maxsize=None)
def _synthetic_data():
    truth = load_model("hframe").with_element_moduli(SYNTHETIC_TRUTH)
    return synthetic_measurement(truth, n_modes=8, freq_noise=0.002, shape_noise=0.02, seed=0,
                                 model_name="hframe")


def make_problem(variant: str = "paper") -> UpdatingProblem:
    """A fresh problem (its own evaluation counter) for a variant name."""
    if variant == "paper":
        return UpdatingProblem("hframe", "paper", name="hframe:paper")
    if variant == "synthetic":
        return UpdatingProblem("hframe", _synthetic_data(), weights="unit", shape_weight=1.0,
                               name="hframe:synthetic")
    if variant.startswith(USER_PREFIX):
        return user_variant_problem(variant)
    raise ValueError(f"unknown problem variant {variant!r}; available: {', '.join(VARIANTS)}")


#: A variant ``user:PATH`` is a user's own problem: PATH a problem source file
#: (fe_problem.user_problem, format femu.user-problem/1) that `femu study --model` writes.
USER_PREFIX = "user:"


def user_variant_problem(variant: str) -> UpdatingProblem:
    """The problem of a ``user:PATH`` variant, rebuilt from its source file (ValueError when the
    file, or a file it names, is missing or has changed)."""
    from fe_problem.jsonutil import read_json_file
    from fe_problem.user_problem import problem_from_source, source_from_dict

    path = variant[len(USER_PREFIX):]
    if not Path(path).is_file():  # the variant holds its source's absolute path: a store moved loses it
        raise ValueError(f"{variant}: its problem source {path} is not there (written by `femu study --model` into "
                         "its store's problems/; moved with the store?): each run record's problem_source names "
                         "the model, data and parameter files with their SHA-256")
    return problem_from_source(source_from_dict(read_json_file(path), path))
