"""First-order screening of every candidate from one set of modes (large models).

`fit.screen` judges a candidate by one exact step: one eigen-solve of the candidate's own
system each. On a large model (thousands of candidates, each system thousands of DOFs) that
is the whole cost of a diagnosis. Here the step is taken on the first-order modes instead:

- eigenvalues: d lambda_i = phi_i^T D_i phi_i (D_i: the candidate's `Term`, local.py);
- shapes at the measured coordinates C: C d phi_i = -G_i^T (D_i phi_i) + c_i C phi_i (Nelson's
  derivative with the particular part M-orthogonal to phi_i), where G_i = Z_i C^T and
  Z_i = sum_{j != i} phi_j phi_j^T / (lambda_j - lambda_i) is applied through one sparse
  factorisation per mode of the bordered matrix [[K - lambda_i M, M phi_i], [phi_i^T M, 0]]
  with the measured coordinates as right-hand sides (Z_i is symmetric: an adjoint solve).

So the cost is one factorisation per mode plus a few flops per candidate and coordinate; the
memory is one (n_free x n_coord) block per paired mode and the changes of one chunk of
candidates at a time (`CHUNK_FLOATS`). The screened step then goes through the same
profiled residuals as `fit.screen` (`screen_linear`), so both screens rank on one scale.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..assembly import AffineModel, solver_path
from ..modal import frequencies_hz
from ..sparse import _cholmod
from .fit import Fit, profiled, profiled_paired, screen
from .local import Term
from .residuals import Observations


#: Bytes of the first-order changes held at once (a chunk of candidates): 64 MB.
CHUNK_FLOATS = 2**26 // 8
#: Candidates screened in one batch (`screen_linear_batch`; its temporaries are several times
#: their changes, so a batch is a part of a chunk).
SCREEN_BATCH = 64


def _to_free(system: AffineModel, dofs: np.ndarray) -> np.ndarray:
    """Model DOF indices to rows of the free-DOF vector; a supported DOF maps to row n_free
    (a zero row appended to every free-DOF array)."""
    pos = np.full(system.dofmap.n_total, system.n_free)
    pos[system.dofmap.free] = np.arange(system.n_free)
    return pos[dofs]


def _groups(terms: list[Term]) -> dict[int, np.ndarray]:
    """Candidate indices grouped by the number of DOFs their term touches (one einsum each)."""
    sizes = np.array([len(t.dofs) for t in terms])
    return {int(k): np.flatnonzero(sizes == k) for k in np.unique(sizes)}


@dataclass(frozen=True, eq=False)
class Baseline:
    """A system's modes at x0 and, for the modes `modes`, the adjoint blocks G_i = Z_i C^T
    (n_free + 1 rows, the last zero: the row of a supported DOF), one per mode."""

    system: AffineModel
    lam: np.ndarray        # (n_modes,) omega^2
    phi_z: np.ndarray      # (n_free + 1, n_modes), a zero row last
    phi_c: np.ndarray      # (n_coord, n_modes) at the measured coordinates
    modes: np.ndarray      # the modes whose changes are computed
    g: tuple               # (n_free + 1, n_coord) per mode in `modes`


def baseline(system: AffineModel, coords, n_modes: int, modes=None) -> Baseline:
    """The modes of `system` and one adjoint block per mode in `modes` (default all): one
    sparse factorisation and n_coord solves per mode. Memory: n_free x n_coord per mode."""
    lam, phi = system.eigen(system.x0[None, :], n_modes, vectors=True)
    lam, phi = lam[0], phi[0]
    k0, m0 = sp.csc_matrix(system.k0), sp.csc_matrix(system.m0)
    rows = system.nodal_rows(coords)
    ok = rows >= 0
    c_t = sp.csc_matrix((np.ones(ok.sum()), (rows[ok], np.flatnonzero(ok))), shape=(system.n_free, len(rows)))
    phi_c = np.where(ok[:, None], phi[np.clip(rows, 0, None)], 0.0)
    modes = np.arange(n_modes) if modes is None else np.asarray(modes, dtype=int)
    c_t = c_t.toarray()  # dense once: every mode's right-hand sides are built from it
    # the system's own factorisation: L D L^T where its sparse solver uses CHOLMOD; SuperLU on
    # the dense path and where SuperLU is forced (`SparseModalSolver(factorization="superlu")`)
    ldlt = getattr(system._solver, "factorization", None) == "cholmod"
    g = tuple(_adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt) for i in modes)
    return Baseline(system, lam, np.vstack([phi, np.zeros((1, n_modes))]), phi_c, modes, g)


def changes(base: Baseline, terms: list[Term]) -> tuple[np.ndarray, np.ndarray]:
    """First-order changes of the baseline's modes `modes` for each term: d lam (c, m) and
    d shapes at the measured coordinates (c, n_coord, m); callers pass terms in chunks.

    The shape change's G_i^T (D_i phi_i) is a sparse product (one row of the term's k entries
    per candidate) with G_i: no (c, k, n_coord) gather. The sparse product sums each row's
    entries in the term's DOF order from zero, as the einsum over k it replaced did, so the
    changes are the same to the bit (tests/test_screening_changes.py): mirror-image candidates
    still tie exactly, and their order stays the index order."""
    n_coord, m = base.phi_c.shape[0], len(base.modes)
    dlam = np.zeros((len(terms), m))
    groups = list(_groups(terms).values())
    whole = len(groups) == 1  # one group of all the terms in order (the usual case): no scatter
    dshape = np.empty((len(terms), n_coord, m)) if whole else np.zeros((len(terms), n_coord, m))
    phi_cols = {i: np.ascontiguousarray(base.phi_c[:, i]) for i in base.modes}
    for idx in groups:
        free = _to_free(base.system, np.array([terms[i].dofs for i in idx]))
        c, k = free.shape
        dk = np.array([terms[i].dk for i in idx])
        dm = np.array([terms[i].dm for i in idx])
        dm2 = (np.zeros_like(dk) if all(terms[i].dm2 is None for i in idx) else
               np.array([terms[i].dm2 if terms[i].dm2 is not None else np.zeros_like(terms[i].dk) for i in idx]))
        indptr = np.arange(0, c * k + 1, k)
        moved = np.empty((m, c, n_coord))  # mode-major while built: each mode's block contiguous
        for j, (i, g) in enumerate(zip(base.modes, base.g)):
            lam = base.lam[i]
            u = base.phi_z[free, i]                                       # (c, k)
            r = np.einsum("ckl,cl->ck", dk - lam * dm + lam ** 2 * dm2, u)
            dlam[idx, j] = np.einsum("ck,ck->c", u, r)
            c_i = 0.5 * np.einsum("ck,ckl,cl->c", u, -dm + 2.0 * lam * dm2, u)
            # rows of D_i phi_i at the term's free rows (a supported DOF: the zero row n_free)
            g_r = sp.csr_matrix((r.ravel(), free.ravel(), indptr), shape=(c, g.shape[0])) @ g   # (c, n_coord)
            np.multiply(c_i[:, None], phi_cols[i][None, :], out=moved[j])
            moved[j] -= g_r
        if whole:
            dshape[...] = moved.transpose(1, 2, 0)
        else:
            dshape[idx] = moved.transpose(1, 2, 0)
    return dlam, dshape


def chunks(base: Baseline, n: int):
    """Slices of range(n) whose `changes` fit in `CHUNK_FLOATS` floats."""
    step = max(1, CHUNK_FLOATS // (base.phi_c.shape[0] * max(len(base.modes), 1)))
    return [slice(c, min(c + step, n)) for c in range(0, n, step)]


def first_order_modes(system: AffineModel, coords, n_modes: int, terms: list[Term], modes=None):
    """Modes of `system` at x0 and the first-order change of modes `modes` (default: all
    n_modes) for each term: lam (n_modes,), shapes at `coords` (n_coord, n_modes), d lam
    (c, len(modes)) and d shapes (c, n_coord, len(modes))."""
    base = baseline(system, coords, n_modes, modes)
    return (base.lam, base.phi_c) + changes(base, terms)


#: The largest row-wise backward error |B x - r|_i / (|B_i|_1 |x|_inf + |r_i|) (row i of the
#: bordered matrix B, every column of the right-hand sides on its own) `_adjoint` accepts from
#: the unpivoted L D L^T of B before it solves again by SuperLU's pivoted LU. On the 3,024-DOF
#: scale frame's 8 paired modes (benchmarks/adjoint_solve.py's case) the L D L^T gives at most
#: 2.6e-15 in K - lam M's rows and 1.4e-13 in the border's (SuperLU: 6.5e-15 and 4.4e-13), so
#: the margin there is 7x; an unstable elimination (a tiny pivot and its growth) shows as
#: orders of magnitude more, and a spurious fallback costs time, not accuracy.
ADJOINT_BACKWARD_TOL = 1e-12


def _adjoint(k0, m0, lam: float, phi: np.ndarray, c_t: np.ndarray, ldlt: bool = False) -> np.ndarray:
    """G = Z C^T (n + 1 rows, the last zero) for one mode, through the bordered matrix
    B = [[K - lam M, M phi], [phi^T M, 0]] (c_t: C^T dense, n x n_coord: a 1 in each column at
    its coordinate's free DOF, or none).

    With `ldlt` (the system's own sparse solver factors by CHOLMOD: `baseline`) and
    scikit-sparse, B is factored as L D L^T in a fixed order (`_adjoint_ldlt`), which solves the
    n_coord right-hand sides at once where SuperLU solves them one column at a time
    (benchmarks/adjoint_solve.py). Its safety rests on the backward-error check of every column,
    not on the order: SuperLU's pivoted LU when that error exceeds `ADJOINT_BACKWARD_TOL`, and
    without `ldlt` or scikit-sparse."""
    n = k0.shape[0]
    b = m0 @ phi
    col = sp.csc_matrix(b[:, None])
    bordered = sp.bmat([[k0 - lam * m0, col], [col.T, None]], format="csc")
    if ldlt and _cholmod is not None and n >= 2:
        out = _adjoint_ldlt(bordered, b, phi, c_t)
        if out is not None:
            return out
    rhs = c_t - np.outer(b, phi @ c_t)   # P C^T: the part M-orthogonal to phi
    sol = splu(bordered).solve(np.vstack([rhs, np.zeros((1, rhs.shape[1]))]))
    out = sol.copy()
    out[n] = 0.0
    return out


def _bordered_order(bordered, phi: np.ndarray) -> np.ndarray:
    """The elimination order (new -> old, n + 1) of `_adjoint_ldlt`: CHOLMOD's fill-reducing
    order of the bordered matrix's pattern with the border (row n) moved next to last and the
    DOF q of phi's largest entry last."""
    n = len(phi)
    q = int(np.argmax(np.abs(phi)))
    order = _cholmod.analyze(bordered, mode="simplicial").P()
    return np.concatenate([order[(order != q) & (order != n)], [n, q]])


def _adjoint_ldlt(bordered, b: np.ndarray, phi: np.ndarray, c_t: np.ndarray):
    """The solve of `_adjoint` by CHOLMOD's simplicial L D L^T of the bordered matrix B
    (`bordered`, CSC, as `_adjoint` builds it; b: M phi), or None when its backward error in any row and column exceeds
    `ADJOINT_BACKWARD_TOL`.

    L D L^T does not pivot. The order (`_bordered_order`) keeps the last two pivots away from
    the zero of the singular K - lam M (phi is its null vector): the block without q is regular
    (phi_q != 0), the border's pivot is -b'^T (K - lam M)'^-1 b' and q's the 2 x 2 remainder's.
    It does not protect the earlier pivots of the indefinite K - lam M (a small one and its
    growth are possible: a review measured the smallest relative pivot at 5.7e-3 on a 300-DOF
    frame, and the smallest |D_ii| / |B_ii| is 1.1e-4 on the 3,024-DOF one), so the safety
    rests on the check: R = B x - r for all columns in one sparse product, and every entry
    |R_ij| <= TOL (|B_i|_1 |x_j|_inf + |r_ij|), else None. Row by row, so that the border's row, b^T x = 0 (b is O(1) where
    K - lam M's rows are O(1e9)), is judged on its own scale whatever the units: an error of x
    along phi, which only that row sees, shows there (tests/test_screening_adjoint.py).
    (Factoring with the border scaled to K's size instead, s = |K - lam M|_inf / |b|_inf, raised
    the L D L^T's backward error in K's norm on that frame to 3e-11, against 1e-13 for SuperLU
    on the same scaled matrix and 3e-16 unscaled: 6 of 8 modes fell back.)
    The right-hand sides P C^T = C^T - b (phi^T C^T) are built in that order, column-major as
    CHOLMOD takes them: -b (phi^T C^T) plus C^T's nonzeros, the same values as `_adjoint`'s."""
    n, n_coord = c_t.shape
    perm = _bordered_order(bordered, phi)
    where = np.empty(n + 1, dtype=np.int64)
    where[perm] = np.arange(n + 1)
    bp = bordered[perm][:, perm].tocsc()
    try:
        factor = _cholmod.analyze(bp, mode="simplicial", ordering_method="natural").cholesky(bp)
    except _cholmod.CholmodError:
        return None
    rows, cols = np.divmod(np.flatnonzero(c_t), n_coord)
    rp = np.outer(phi @ c_t, -np.append(b, 0.0)[perm]).T      # (n + 1, n_coord), column-major
    rp[where[rows], cols] += c_t[rows, cols]
    xp = factor.solve_A(rp)
    if not np.all(np.isfinite(xp)):
        return None
    row_norm = np.asarray(abs(bp).sum(axis=1)).ravel()
    bound = row_norm[:, None] * np.abs(xp).max(axis=0) + np.abs(rp)
    if np.any(np.abs(bp @ xp - rp) > ADJOINT_BACKWARD_TOL * bound):
        return None
    out = np.empty((n + 1, n_coord))
    out[perm] = xp
    out[n] = 0.0
    return out


def _moved(lam, phi_c, modes, dlam, dshape, step: float):
    """Frequencies (Hz) and shapes at a step along first-order changes of modes `modes`."""
    lam, phi_c = lam.copy(), phi_c.copy()
    lam[modes] += step * dlam
    phi_c[:, modes] += step * dshape
    return frequencies_hz(lam), phi_c


def screen_linear(obs: Observations, base: Fit, lam: np.ndarray, phi_c: np.ndarray, modes: np.ndarray,
                  dlam: np.ndarray, dshape: np.ndarray, step: float, upper: float) -> tuple[float, float]:
    """`fit.screen` on first-order modes: the chi^2 drop a linearised model promises and its a,
    from the profiled residuals at one small step with the baseline pairing held fixed (so
    only the paired `modes` need their changes)."""
    moved = profiled(obs, *_moved(lam, phi_c, modes, dlam, dshape, step), base.pairing)
    j = (moved.residuals - base.residuals) / step
    jj = float(j @ j)
    if jj <= 0.0:
        return 0.0, 0.0
    a = min(max(-float(base.residuals @ j) / jj, 0.0), upper)
    if a == 0.0:  # no change promises no drop (base.chi2 - |r|^2 may be an ulp, summed another way)
        return 0.0, 0.0
    drop = base.chi2 - float(np.sum((base.residuals + a * j) ** 2))
    return max(drop, 0.0), a


def screen_linear_batch(obs: Observations, base: Fit, lam: np.ndarray, phi_c: np.ndarray, modes: np.ndarray,
                        dlam: np.ndarray, dshape: np.ndarray, step: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """`screen_linear` of a chunk of candidates at once (dlam (c, m), dshape (c, n_coord, m), step
    and upper (c,)): (chi^2 drop, a) as rows (c, 2). Only the paired modes `modes` are moved
    (the pairing is held); the others stay in the batch as they are, because a paired shape
    is compared with its best combination with a close neighbour (`close_mode_shape`), paired
    or not: without them the residuals at a = 0 were not the baseline's (up to 15 sigma on
    frame3d with measured rotations, where the sway pairs are close), and the Jacobian was
    that offset over the step (a real stiffness loss screened at 0)."""
    j = (profiled_paired(obs, *_moved_batch(lam, phi_c, modes, dlam, dshape, step), base.pairing)
         - base.residuals) / step[:, None]
    jj = np.einsum("ci,ci->c", j, j)
    live = jj > 0.0
    a = np.zeros(len(j))
    # einsum, not a matrix-vector product: BLAS may sum a row differently in batches of other
    # sizes, and a candidate's screen must not depend on its batch (tests/test_diagnosis_scale.py)
    a[live] = np.minimum(np.maximum(-np.einsum("ci,i->c", j[live], base.residuals) / jj[live], 0.0), upper[live])
    drop = base.chi2 - np.sum((base.residuals + a[:, None] * j) ** 2, axis=1)
    return np.column_stack([np.where(live & (a > 0.0), np.maximum(drop, 0.0), 0.0), a])


def screen_all(obs: Observations, base: Fit, model, coords, n_modes: int, cands,
               setting=None) -> list[tuple[float, float]]:
    """(chi^2 drop, a) of every candidate with a first-order term, from one set of modes of
    `model`; candidates without one (global effects) get (nan, nan): the caller screens them
    by a step or fits them outright. setting: the candidates' `Setting` of `model` (its
    system and its baselines kept, `Setting.baselines`), else the system is built here."""
    with_term = [i for i, c in enumerate(cands) if c.term is not None]
    modes = np.unique(base.pairing[base.pairing >= 0])
    if setting is None:
        first = baseline(AffineModel(model), coords, n_modes, modes)
    else:
        key = (tuple(coords), n_modes, tuple(modes.tolist()))
        if key not in setting.baselines:
            setting.baselines[key] = baseline(setting.system, coords, n_modes, modes)
        first = setting.baselines[key]
    out = [(float("nan"), float("nan"))] * len(cands)
    for sl in chunks(first, len(with_term)):  # the changes of a chunk of candidates at a time
        part = with_term[sl]
        dlam, dshape = changes(first, [cands[i].term() for i in part])
        step = np.array([cands[i].step for i in part], dtype=float)
        upper = np.array([cands[i].upper for i in part], dtype=float)
        for b in range(0, len(part), SCREEN_BATCH):  # its temporaries a few times the chunk's / 8
            # every batch of the same size (the last padded by repeating its first row): numpy
            # reduces a stack of one or a few rows in another order than a stack of many, and a
            # candidate's screen must not depend on how the candidates were chunked
            sub = np.arange(b, min(b + SCREEN_BATCH, len(part)))
            pad = np.concatenate([sub, np.full(SCREEN_BATCH - len(sub), sub[0])])
            rows = screen_linear_batch(obs, base, first.lam, first.phi_c, modes, dlam[pad], dshape[pad], step[pad],
                                       upper[pad])
            for i, (drop, a) in zip([part[k] for k in sub], rows[:len(sub)].tolist()):
                out[i] = (drop, a)
    return out


def screen_steps(obs: Observations, base: Fit, setting, cands) -> list[tuple[float, float]]:
    """(chi^2 drop, a) of each candidate as `fit.screen` judges it (one exact step), except on a
    model of the sparse path, where a candidate with a first-order term is screened from one set
    of modes (`screen_all`): there a step builds and solves a model per candidate (a 3,000-DOF
    frame's 6,000 model-form candidates took most of its diagnosis)."""
    if not cands or solver_path(len(setting.local.dofmap.free)) == "dense":
        return [screen(obs, c, base) for c in cands]
    first = screen_all(obs, base, setting.model, setting.coords, setting.n_modes, cands, setting)
    return [screen(obs, c, base) if c.term is None else f for c, f in zip(cands, first)]


def linear_bounded_moduli(obs: Observations, base: Fit, local, coords, n_modes: int, rel_lo: float,
                          rel_hi: float) -> np.ndarray:
    """The bounded update of every element modulus in [rel_lo, rel_hi] x its calibrated value
    (scaled into z in [0, 1]), linearised at the calibrated model: the residuals' first-order
    model (Jacobian from first-order modes) fitted by `bounded_linear_fit`, the MAP with each
    box as a prior of its width. Returns z (n_el,). For models where a finite-difference
    Jacobian (one solve per element) would cost too much; unlike the dense path's nonlinear fit
    (60 evaluations from z = 1/2, no prior) a modulus the data do not determine stays at 1/2."""
    s, model = base.s, local.model
    span = (rel_hi - rel_lo) * s * local.modulus            # Pa per unit z
    terms = [local.stiffness(e.id, span[k]) for k, e in enumerate(model.elements)]
    mid = 0.5 * (rel_lo + rel_hi) * s * local.modulus       # z = 1/2
    start = model.with_element_moduli({e.id: float(mid[k]) for k, e in enumerate(model.elements)})
    modes = np.unique(base.pairing[base.pairing >= 0])
    first = baseline(AffineModel(start), coords, n_modes, modes)
    lam, phi_c = first.lam, first.phi_c
    r0 = obs.residuals(frequencies_hz(lam), phi_c, base.pairing)[0]
    h = 1e-4
    columns = []
    for sl in chunks(first, len(terms)):
        dlam, dshape = changes(first, terms[sl])
        for b in range(0, len(dlam), SCREEN_BATCH):  # the models at a step, a batch at a time
            part = slice(b, min(b + SCREEN_BATCH, len(dlam)))
            columns.append((obs.residuals_paired(*_moved_batch(lam, phi_c, modes, dlam[part], dshape[part], h),
                                                 base.pairing) - r0).T / h)
    return bounded_linear_fit(r0, np.hstack(columns))


def _moved_batch(lam, phi_c, modes, dlam, dshape, step):
    """`_moved` of a batch of changes (dlam (c, m), dshape (c, n_coord, m)) at steps `step` (c,)
    or one step: frequencies (c, n_modes) Hz and shapes (c, n_coord, n_modes). Each model's the
    same to the bit as `_moved`'s, and so are its residuals through
    `Observations.residuals_paired` (tests/test_pinned_fit.py: the Jacobian of
    `linear_bounded_moduli` against one model at a time)."""
    step = np.broadcast_to(np.asarray(step, dtype=float), (len(dlam),))
    lam_m = np.repeat(lam[None, :], len(dlam), axis=0)
    lam_m[:, modes] += step[:, None] * dlam
    phi_m = np.repeat(phi_c[None], len(dlam), axis=0)
    if len(modes) and np.array_equal(modes, np.arange(modes[0], modes[-1] + 1)):  # in place: no gather, scatter
        phi_m[:, :, modes[0]:modes[-1] + 1] += step[:, None, None] * dshape
    else:
        phi_m[:, :, modes] += step[:, None, None] * dshape
    return frequencies_hz(lam_m), phi_m


def bounded_linear_fit(r0: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """z in [0, 1]^n, the most probable moduli of the linearised problem (MAP): minimises
    ||r0 + jac (z - 1/2)||^2 + ||2 (z - 1/2)||^2 over the box. r0 (m,) are the noise-weighted
    residuals at z = 1/2 (chi^2 = ||r0||^2) and jac (m, n) their derivatives by z; each
    modulus' box is taken as a Gaussian prior of the same width (centred at the calibrated
    value, z = 1/2, sd half the box, 1/2 in z: the rows 2 (z - 1/2)), and the bounds are kept.
    The objective is strictly convex (its Hessian, 2 (jac^T jac + 4 I), is at least 8 I), so
    the answer is unique and continuous in r0 and jac: a direction the data leave undetermined
    stays at the prior's centre instead of where rounding leaves an iterative fit (the fit this
    replaced moved z by 0.2-0.5 and changed most of its pinned list under a 1e-15 change of
    its Jacobian at 1,080 and 3,024 DOFs; benchmarks/pinned_rounding.py).

    The data rows and the prior's rows are compressed together to n + 1 (`compressed`: the same
    norm at every z, one QR), a triangle R and c: the unbounded minimiser is then one back
    substitution, the answer wherever it lies in the box (none at a bound: 3,528 x 1,188, 0.65 s
    against 0.9 s CPU for the compression of the data rows alone and `lsq_linear`'s own
    unbounded least squares on the stacked rows, which it returned as it is; the same to 1.4e-14
    in z). Otherwise solved exactly (to rounding) by `lsq_linear`'s bvls, an active-set method; the moduli its active set holds at a bound are set exactly on
    it (bvls's last step leaves them within 1e-16), and a run that ends on its iteration limit
    is an error, never a silent answer. trf, an
    interior method, leaves a pinned modulus 1e-8 to 1e-4 inside its bound and was slower
    wherever bounds are active (a 3,024-DOF frame's 1,176 moduli, its misfit tripled so that 16
    are at a bound: bvls 0.96 s, trf 4.1 s CPU; as measured, none at a bound: 0.53 s and 0.13 s)."""
    from scipy.linalg import solve_triangular
    from scipy.optimize import lsq_linear

    n = jac.shape[1]
    # ||c + r (z - 1/2)|| = ||[r0 + jac (z - 1/2); 2 (z - 1/2)]||: data and prior rows at once
    c, r = compressed(np.concatenate([r0, np.zeros(n)]), np.vstack([jac, 2.0 * np.eye(n)]))
    if jac.shape[0] > 1:  # compressed by QR: r[:n] upper triangular, its diagonal nonzero (the 2 I)
        z = 0.5 - solve_triangular(r[:n], c[:n])
        if np.all((z >= 0.0) & (z <= 1.0)):  # as `lsq_linear` returns its unbounded answer
            return z
    res = lsq_linear(r, 0.5 * r.sum(axis=1) - c, bounds=(0.0, 1.0), method="bvls", max_iter=10 * n + 100)
    if res.status <= 0:
        raise RuntimeError(f"the bounded fit of {n} moduli did not converge (bvls: {res.message})")
    z = res.x.copy()
    z[res.active_mask < 0], z[res.active_mask > 0] = 0.0, 1.0
    return z


def compressed(r0: np.ndarray, jac: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(r0', jac') with ||r0' + jac' x|| = ||r0 + jac x|| for every x and jac'^T jac' = jac^T jac,
    n + 1 rows for a jac of n columns (QR once); unchanged when jac has no more rows than that.

    The triangle R of [jac, r0] = Q R is the compressed system itself: its first n columns are
    jac's R (with a zero row last) and its last column is Q^T r0, whose last entry is +- the part
    of r0 no x reaches. So Q is never formed (numpy's mode "r"): half the time of the reduced QR
    and Q^T r0 it replaced (3,528 x 1,188: 0.31 s against 0.63 s CPU), the same to rounding
    (tests/test_pinned_fit.py)."""
    n = jac.shape[1]
    if jac.shape[0] <= n + 1:
        return r0, jac
    r = np.linalg.qr(np.column_stack([jac, r0]), mode="r")  # (n + 1, n + 1), upper triangular
    return r[:, n].copy(), r[:, :n]
