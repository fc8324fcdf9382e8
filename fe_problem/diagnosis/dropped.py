"""Candidates whose solve fails: dropped with a sentence naming them, never an exception.

A candidate at the edge of its range can make a system the solvers cannot handle on some data:
a support released until the structure hangs on a spring a thousandth of its members' stiffness,
an eigen-solve that does not converge, a factorisation of a matrix that is no longer positive
definite, modes that come out non-finite. A diagnosis must still answer on any data that load
(issue 38: an 18-storey frame's "SVD did not converge" from a support candidate's look along its
grid ended the run). Such a candidate is dropped:

- its failing solve gives non-finite modes (`failed_modes`), which the residuals count as losing
  every mode (`residuals.Observations.residuals_paired`: a non-finite model mode pairs with
  nothing), so no fit can prefer those sizes;
- it is recorded here (`note`) under its label with the error, and the diagnosis leaves every
  recorded candidate out of its fits, its test and its evidence table (core.py), and lists it in
  the record (`Diagnosis.dropped`) and its warnings.

The record is kept in a context variable that `recording()` opens for one diagnosis; outside one,
`note` records nothing (a candidate solved on its own still gives its non-finite modes).
"""

from __future__ import annotations

import contextlib
import contextvars

import numpy as np

_DROPPED: contextvars.ContextVar[dict | None] = contextvars.ContextVar("femu_diagnosis_dropped", default=None)
#: The shape of the last modes solved in this diagnosis ((k,), (n_coord, k)): a failing first solve
#: of a candidate gives non-finite modes of that shape.
_SHAPES: contextvars.ContextVar[tuple | None] = contextvars.ContextVar("femu_diagnosis_shapes", default=None)


def is_numerical(exc: BaseException) -> bool:
    """Whether `exc` is a numerical failure of a solve (LAPACK, ARPACK, a sparse factorisation, a
    floating-point trap), not a bug or a user error."""
    from scipy.sparse.linalg import ArpackError

    if isinstance(exc, (np.linalg.LinAlgError, ArpackError, FloatingPointError)):
        return True
    name = type(exc).__name__
    if name.startswith("Cholmod"):  # scikit-sparse's errors (not positive definite, ...)
        return True
    text = str(exc).lower()
    if isinstance(exc, RuntimeError) and "singular" in text:  # SuperLU: "Factor is exactly singular"
        return True
    return isinstance(exc, ValueError) and ("infs or nans" in text or "non-finite" in text)


@contextlib.contextmanager
def recording():
    """Open the record of dropped candidates for one diagnosis: yields the dict label -> reason."""
    out: dict[str, str] = {}
    token, token_s = _DROPPED.set(out), _SHAPES.set(None)
    try:
        yield out
    finally:
        _DROPPED.reset(token)
        _SHAPES.reset(token_s)


def note(label: str, reason: str) -> None:
    """Record candidate `label` as dropped for `reason` (the first reason kept)."""
    out = _DROPPED.get()
    if out is not None and label not in out:
        out[label] = reason


def dropped() -> dict[str, str]:
    """The candidates recorded so far in this diagnosis (label -> reason); empty outside one."""
    return dict(_DROPPED.get() or {})


def is_dropped(label: str) -> bool:
    return label in (_DROPPED.get() or {})


def reason_of(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}".strip().rstrip(":")


def solved(hz: np.ndarray, shapes: np.ndarray) -> None:
    """Remember the shape of one candidate's modes (one size): a later failure gives that shape."""
    _SHAPES.set((hz.shape[-1:], shapes.shape[-2:]))


def failed_modes(n: int, like: tuple | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """Non-finite modes for `n` sizes, shaped as the modes solved last (`like`: ((k,), (n_coord, k))
    of the candidate's own kept modes, else the last of this diagnosis); None when no shape is known."""
    like = like or _SHAPES.get()
    if like is None:
        return None
    return np.full((n, *like[0]), np.nan), np.full((n, *like[1]), np.nan)


def guarded(label: str, compute, default):
    """`compute()`, or `default` with `label` recorded as dropped when it fails numerically (a class
    fitted by its own solves: "every member" sparse, the free group classes)."""
    try:
        return compute()
    except Exception as exc:  # noqa: BLE001 - only numerical failures are caught (is_numerical)
        if not is_numerical(exc):
            raise
        note(label, f"its fit failed ({reason_of(exc)})")
        return default
