"""`identify_ambient`: operational modal analysis of measured time series through pyOMA2.

Per setup (one file of a `Recording`): the channels that look dead or clipped are dropped (a
far noisier one is kept: SSI-cov's covariances skip lag 0, where white sensor noise sits),
the mean is removed, the record decimated where the band lies far below the Nyquist frequency,
then one method of pyOMA2 (Pasca, Aloisio, Rosso, Sotiropoulos, pyOMA2, SoftwareX 2024):

- ``ssi-cov``: covariance-driven SSI over model orders 2..`order` (pyOMA2 ``SSI``), each pole's
  standard deviations propagated from the covariance of the Hankel matrix (``calc_unc``,
  Doehler & Mevel 2013, over `UNC_BLOCKS` blocks), poles chosen unattended by pyOMA2's
  clustering ``Neu`` (Neu et al. 2017: k-means split of stable and noise poles, hierarchical
  clustering on frequency, damping, eigenvalue and MAC distances, a 95 % Weibull cut, clusters
  smaller than MIN_CLUSTER_FRACTION of the largest and outliers (modified Thompson tau) removed),
  and a mode damped more than DAMPING_OUTLIER times the median rejected as noise. A mode's values
  are its cluster's means; its standard deviations are the propagated ones averaged over the
  cluster (SSI-cov's own uncertainty, not the scatter over orders). The shape's std is pyOMA2's
  propagation with its Jacobian of the unit-scaled shape corrected (`_scaled_shape_poles`: the
  scaled shape where pyOMA2 put the unscaled one, Doehler & Mevel 2013, eq. 45). Frequency,
  damping and shape std cover the truth at their nominal rate on simulated records
  (tests/test_oma.py).
- ``plscf``: poly-reference LSCF over orders 1..`order` (pyOMA2 ``pLSCF``), stable poles by its
  soft criteria, clustered and chosen by the rule of poles.py (`poles.select`); a mode's
  standard deviations are the scatter of its cluster over the orders (stated as such).
- ``fdd``: the peaks of the first singular value of the spectral density matrix
  (scipy.signal.find_peaks, `FDD_PROMINENCE_DB` prominence, a MAC below `FDD_MAX_MAC` to the
  neighbouring peak's vector), each estimated by pyOMA2's EFDD (frequency and damping from the
  enhanced bell's free decay); no standard deviation is stated.

Several setups: each is identified alone and the modes paired by pyOMA2's ``match_modes``
(frequency within 10 %, MAC on the reference channels >= 0.5); the shapes are merged by its
``merge_mode_shapes`` (each setup scaled onto the first through its reference channels, PoSER);
frequency and damping are the inverse-variance means over the setups.

Shapes are made real by the rotation that best aligns them with the real axis, scaled to a
largest entry of 1 (shape_std in those units); MPC and MPD (pyOMA2) state their complexity.
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from . import poles as P
from .timeseries_io import Recording, Setup, TimeSeriesError, channel_quality, label_text

METHODS = ("ssi-cov", "plscf", "fdd")
#: Default highest model order: SSI state dimension (2 per mode), pLSCF polynomial order
DEFAULT_ORDER = {"ssi-cov": 40, "plscf": 30, "fdd": 0}
MAX_ORDER_LIMIT = 160
#: The fewest cycles of the band's lowest frequency a record must hold (and samples in any case)
MIN_CYCLES = 100
MIN_SAMPLES = 500
#: Decimate when the band's top is below fs / DECIMATE_ABOVE, down to about that rate: the modes
#: between the band and the Nyquist frequency would take model orders (at 5, the benchmark's
#: building lost its first mode at order 40)
DECIMATE_ABOVE = 3.0
#: Blocks over which SSI-cov's Hankel covariance is estimated (pyOMA2's nb)
UNC_BLOCKS = 20
#: The most reference (projection) channels of SSI-cov (`projection_channels`)
MAX_PROJECTION_CHANNELS = 6
#: Block rows of the SSI Hankel matrix: at least this, and enough for the highest order (more, for
#: lags over a period of a low mode, lost that mode on the benchmark's building and tripled the
#: time: the uncertainty propagation grows with the square of the block rows)
MIN_BLOCK_ROWS = 15
#: Spectral density: segments of this many samples at most (Welch, 50 % overlap)
NXSEG = 1024
#: FDD peak picking: prominence of a peak of the first singular value (dB), largest MAC to a
#: neighbouring peak for two peaks to be two modes
FDD_PROMINENCE_DB = 6.0
FDD_MAX_MAC = 0.9
#: A chosen mode's MPC below this is named in a warning (a complex mode: noise or non-proportional damping)
MIN_MPC = 0.8
#: The feature transform of the clustering's pre-split (pyOMA2's 'Neu')
CLUSTER_TRANSFORM = "box-cox"
#: A cluster smaller than this fraction of the largest is dropped (pyOMA2's 'Neu': 0.5)
MIN_CLUSTER_FRACTION = 0.3
#: A mode whose damping exceeds this multiple of the median over the modes found is a noise mode
DAMPING_OUTLIER = 2.5
#: Largest physical damping ratio
MAX_DAMPING = 0.2


@dataclass(frozen=True, eq=False)
class AmbientIdentification:
    """What `identify_ambient` found: data (ModalData with per-mode std in meta and modes), charts
    (one poles.Chart per setup: every pole, stable, clustered, chosen), psd (below), modes (one dict per
    mode: frequency_hz, frequency_std_hz, damping_ratio, damping_std, shape_std, mpc, mpd,
    n_poles, setups), method, dropped (channel, kind) per setup, warnings. psd: one
    (frequency_hz (n,), singular values (n_sv, n)) of the spectral density matrix per setup."""

    data: object
    charts: tuple
    psd: tuple
    modes: tuple
    method: str
    uncertainty: str
    dropped: tuple
    warnings: tuple[str, ...]
    meta: dict = field(default_factory=dict)


def _pyoma():
    try:
        import pyoma2  # noqa: F401
    except ImportError:
        # a ValueError, as the other optional dependencies': the command line's one line, exit 2
        raise ValueError("femu identify --oma needs the 'oma' extra: pip install 'femu-bench[oma]'") from None
    from pyoma2.algorithms import EFDD, FDD, SSI, pLSCF
    from pyoma2.algorithms.data.run_params import Clustering
    from pyoma2.functions import gen
    from pyoma2.setup import SingleSetup

    for name in list(logging.root.manager.loggerDict):  # pyOMA2 logs every step at INFO
        if name.startswith("pyoma2"):
            logging.getLogger(name).setLevel(logging.WARNING)
    return SingleSetup, SSI, pLSCF, FDD, EFDD, Clustering, gen


@contextlib.contextmanager
def _quiet():
    """pyOMA2's progress bars (tqdm on stderr) and its libraries' warnings kept off the terminal."""
    with contextlib.redirect_stderr(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def real_shape(phi: np.ndarray, std: np.ndarray | None = None):
    """A complex shape rotated onto the real axis (the rotation of the principal axis of its
    points in the complex plane), scaled to a largest entry of +1; its std scaled alike."""
    phi = np.asarray(phi, complex)
    z = np.stack([phi.real, phi.imag])
    _, _, vt = np.linalg.svd(z @ z.T)
    theta = math.atan2(vt[0, 1], vt[0, 0])
    r = (phi * np.exp(-1j * theta)).real
    k = int(np.argmax(np.abs(r)))
    a = 1.0 / r[k]
    return r * a, (None if std is None else positive_std(np.abs(std) * abs(a)))


def positive_std(std: np.ndarray) -> np.ndarray:
    """A shape's std with the entries fixed by its scaling (std 0: the entry scaled to 1) given
    the smallest positive std of the others: the modal-data format wants every std > 0."""
    std = np.asarray(std, float)
    pos = std[std > 1e-9 * std.max(initial=0)]
    return np.where(std > 1e-9 * std.max(initial=0), std, pos.min() if pos.size else 1e-6)


def _prepare(setup: Setup, band, warn: list):
    """(acc, fs, kept channel indices, dropped (label, kind)) of one setup, checked against the band."""
    lo, hi = band
    if hi > setup.fs / 2:
        raise ValueError(f"--band {lo:g} {hi:g}: the top lies above the Nyquist frequency {setup.fs / 2:g} Hz of "
                         f"{setup.source} (sampled at {setup.fs:g} Hz)")
    need = max(MIN_SAMPLES, math.ceil(MIN_CYCLES * setup.fs / lo) if lo > 0 else 0)
    if setup.n_samples < need:
        why = f"{MIN_CYCLES} cycles of {lo:g} Hz" if lo > 0 and need > MIN_SAMPLES else f"at least {MIN_SAMPLES}"
        raise TimeSeriesError(f"{setup.source}: {setup.n_samples} samples ({setup.duration_s:.4g} s at "
                              f"{setup.fs:g} Hz): fewer samples than the band {lo:g}-{hi:g} Hz needs ({need}: {why}); "
                              "record longer or raise the band's low end")
    bad = channel_quality(setup)
    dropped, keep = [], np.ones(len(setup.channels), bool)
    for k, kind, msg in bad:
        if kind in ("dead", "clipped"):
            keep[k] = False
            dropped.append((label_text(setup.channels[k]), kind))
            warn.append(f"{msg}; dropped from the identification")
        else:
            warn.append(f"{msg}; kept (SSI-cov's output covariances skip lag 0, where white sensor noise sits)")
    if keep.sum() < 1:
        raise TimeSeriesError(f"{setup.source}: no usable channel (every one is dead or clipped)")
    acc = setup.acc[:, keep]
    acc = acc - acc.mean(0)
    fs = setup.fs
    q = int(fs / (DECIMATE_ABOVE * hi)) if hi > 0 else 1
    if q >= 2:
        from scipy.signal import decimate
        acc = decimate(acc, q, axis=0, ftype="fir", zero_phase=True)
        fs = fs / q
    return np.ascontiguousarray(acc), fs, np.flatnonzero(keep), dropped


def _chart_of(fn, xi, phi, stable, order_of_column) -> P.Chart:
    """A poles.Chart of pyOMA2's pole arrays (poles x orders [x channels]); NaN poles left out."""
    ok = ~np.isnan(fn)
    rows, cols = np.nonzero(ok)
    shapes = phi[rows, cols, :]
    return P.Chart(order_of_column[cols], fn[rows, cols], xi[rows, cols], P.mpc(shapes), shapes,
                   np.asarray(stable, bool)[rows, cols] if stable is not None else np.zeros(rows.size, bool),
                   np.full(rows.size, -1), (), int(order_of_column.max()) if order_of_column.size else 0)


def _mode_record(f, f_std, z, z_std, phi, phi_std, n_poles, gen):
    shape, shape_std = real_shape(phi, phi_std)
    return {"frequency_hz": float(f), "frequency_std_hz": None if f_std is None else float(f_std),
            "damping_ratio": float(z), "damping_std": None if z_std is None else float(z_std),
            "shape": shape, "shape_std": shape_std, "complex_shape": np.asarray(phi, complex),
            "mpc": float(gen.MPC(np.asarray(phi, complex))), "mpd_deg": float(np.degrees(gen.MPD(np.asarray(phi, complex)))),
            "n_poles": int(n_poles)}


def projection_channels(acc: np.ndarray) -> list[int]:
    """The channels SSI-cov projects on (its reference outputs, pyOMA2's ref_ind): every channel up
    to MAX_PROJECTION_CHANNELS, else the most independent ones by a pivoted QR (scipy) of the
    channels' correlation matrix. The Hankel covariance and its uncertainty propagation grow with
    the square of the channels x references: 30 references of 30 channels would need gigabytes."""
    n = acc.shape[1]
    if n <= MAX_PROJECTION_CHANNELS:
        return list(range(n))
    from scipy.linalg import qr

    x = acc / np.maximum(acc.std(0), 1e-300)
    _, _, piv = qr(x.T @ x / x.shape[0], pivoting=True, mode="economic")
    return sorted(int(i) for i in piv[:MAX_PROJECTION_CHANNELS])


def _clustering(lib, band):
    """pyOMA2's 'Neu' clustering (Neu et al. 2017), its damping limit ours, cut to the band. (Without
    its Box-Cox transform, half a second faster, it lost modes on the tests' shear building.)"""
    from pyoma2.algorithms.data.run_params import Step1, Step2, Step3

    Clustering = lib[5]
    step1 = Step1(hc=True, hc_dict={"xi_max": MAX_DAMPING, "mpc_lim": 0.0, "mpd_lim": 1.0, "CoV_max": np.inf},
                  sc=False, pre_cluster=True, pre_clus_typ="kmeans",
                  pre_clus_dist=["dfn", "dxi", "dlambda", "dMAC", "dMPD"], transform=CLUSTER_TRANSFORM)
    step2 = Step2(algo="hierarc", dc="95weib", linkage="average")
    step3 = Step3(post_proc=["min_size_pctg", "MTT"], min_pctg=MIN_CLUSTER_FRACTION, select="avg", freqlim=tuple(band))
    return Clustering(name="auto", steps=(step1, step2, step3))


#: pyOMA2's Jacobian of the unit-scaled shape (Doehler & Mevel 2013, Lemma 5, eq. 45: the scaled
#: shape's derivative is (I - phi_s e_k^T) dphi / phi_k, phi_s = phi / phi_k the scaled shape) puts
#: the unscaled phi where phi_s belongs: the shape std it states comes out about 10 times too large
#: (tests/test_oma.py). `_scaled_shape_poles` runs its SSI_poles with phi_s there instead.
_UNSCALED = "phi[:, jj].reshape(-1, 1)"
_SCALED = "(phi[:, jj] / vmaxs[jj]).reshape(-1, 1)"
_PATCHED: dict = {}


def _scaled_shape_poles():
    """pyOMA2's functions.ssi.SSI_poles with the shape Jacobian of Doehler & Mevel's eq. 45 as
    published (the two lines of its `Mat1_2`); ValueError if the installed pyOMA2 no longer reads
    as the one this was written for (1.4), rather than a silently different std."""
    if "f" not in _PATCHED:
        import inspect
        import textwrap

        from pyoma2.functions import ssi

        src = textwrap.dedent(inspect.getsource(ssi.SSI_poles))
        if src.count(_UNSCALED) != 2 or "Mat1_2" not in src:
            from importlib.metadata import version

            raise ValueError(f"femu identify --oma: the installed pyOMA2's SSI_poles ({version('pyoma-2')}) is not "
                             "the one femu corrects (its shape Jacobian changed); install pyoma-2 1.4 or update "
                             "fe_problem/identification/ambient.py")
        ns = dict(vars(ssi))
        exec(compile(src.replace(_UNSCALED, _SCALED), ssi.__file__, "exec"), ns)  # noqa: S102 (pyOMA2's own source)
        _PATCHED["f"] = ns["SSI_poles"]
    return _PATCHED["f"]


@contextlib.contextmanager
def _scaled_shape_std():
    """pyOMA2's SSI run with `_scaled_shape_poles` in place of its SSI_poles (restored after)."""
    from pyoma2.functions import ssi

    original = ssi.SSI_poles
    ssi.SSI_poles = _scaled_shape_poles()
    try:
        yield
    finally:
        ssi.SSI_poles = original


def _ssi(acc, fs, band, order, lib):
    SingleSetup, SSI, _, _, _, Clustering, gen = lib
    refs = projection_channels(acc)
    br = max(MIN_BLOCK_ROWS, math.ceil(order / len(refs)) + 1)
    setup = SingleSetup(acc, fs=fs)
    alg = SSI(name="ssi", method="cov", br=br, ordmax=order, calc_unc=True, nb=UNC_BLOCKS,
              ref_ind=None if len(refs) == acc.shape[1] else refs,
              hc={"xi_max": MAX_DAMPING, "mpc_lim": None, "mpd_lim": None, "CoV_max": None})
    setup.add_algorithms(alg)
    with _scaled_shape_std():
        setup.run_by_name("ssi")
    res = alg.result
    alg.add_clustering(_clustering(lib, band))
    alg.run_clustering("auto")
    c = res.clustering_results["auto"]
    n_cols = res.Fn_poles.shape[1]
    order_of_column = np.arange(n_cols)  # pyOMA2's column k holds the poles of order k (step 1)
    chart = _chart_of(res.Fn_poles, res.Xi_poles, res.Phi_poles, res.Lab == 1, order_of_column)
    in_band = (chart.frequency_hz >= band[0]) & (chart.frequency_hz <= band[1])
    chart = _subset(chart, in_band)
    labels = np.asarray(c.labels)
    fl, ol = np.asarray(c.Fn_fl).ravel(), np.asarray(c.order_fl).ravel()
    cluster = np.full(chart.order.size, -1)
    for lab in np.unique(labels[labels >= 0]):
        for f, o in zip(fl[labels == lab], ol[labels == lab]):
            hit = np.flatnonzero((chart.order == int(o)) & np.isclose(chart.frequency_hz, f, rtol=1e-12, atol=0))
            cluster[hit] = lab
    modes, chosen = [], []
    fn, xi = np.atleast_1d(c.Fn), np.atleast_1d(c.Xi)
    phis = np.atleast_2d(c.Phi.T) if np.ndim(c.Phi) == 1 else c.Phi.T
    fstd, xstd = np.atleast_1d(c.Fn_std), np.atleast_1d(c.Xi_std)
    pstd = np.atleast_2d(c.Phi_std.T) if np.ndim(c.Phi_std) == 1 else c.Phi_std.T
    names = np.unique(labels[labels >= 0])
    centres = np.array([fl[labels == lab].mean() for lab in names])
    for k in range(fn.size):
        lab = int(names[np.argmin(np.abs(centres - fn[k]))])  # the cluster whose mean is this mode's
        chosen.append(lab)
        rec = _mode_record(fn[k], fstd[k], xi[k], xstd[k], phis[k], pstd[k], (cluster == lab).sum(), gen)
        rec["cluster"] = lab
        # the clustering's averaged shape is real: the complexity is the members' (complex poles)
        members = chart.residues[cluster == lab]
        if members.size:
            rec["mpc"] = float(np.mean([gen.MPC(p) for p in members]))
            rec["mpd_deg"] = float(np.degrees(np.mean([gen.MPD(p) for p in members])))
        modes.append(rec)
    chart = replace(chart, cluster=cluster, chosen=tuple(chosen))
    return modes, chart


def _subset(chart: P.Chart, mask) -> P.Chart:
    return replace(chart, order=chart.order[mask], frequency_hz=chart.frequency_hz[mask], damping=chart.damping[mask],
                   mpc=chart.mpc[mask], residues=chart.residues[mask], stable=chart.stable[mask],
                   cluster=chart.cluster[mask])


def _plscf(acc, fs, band, order, lib):
    SingleSetup, _, pLSCF, _, _, _, gen = lib
    setup = SingleSetup(acc, fs=fs)
    nxseg = min(NXSEG, acc.shape[0] // 8)
    alg = pLSCF(name="plscf", ordmax=order, nxseg=nxseg, hc={"xi_max": MAX_DAMPING, "mpc_lim": None, "mpd_lim": None, "CoV_max": None})
    setup.add_algorithms(alg)
    setup.run_by_name("plscf")
    res = alg.result
    chart = _chart_of(res.Fn_poles, res.Xi_poles, res.Phi_poles, res.Lab == 1, np.arange(res.Fn_poles.shape[1]))
    chart = _subset(chart, (chart.frequency_hz >= band[0]) & (chart.frequency_hz <= band[1]))
    chart = P.select(chart, max_damping=MAX_DAMPING)
    modes = []
    for lab in chart.chosen:
        m = chart.cluster == lab
        f, z, shapes = chart.frequency_hz[m], chart.damping[m], chart.residues[m]
        ref = shapes[np.argmin(np.abs(f - np.median(f)))]
        real = np.array([real_shape(s)[0] for s in shapes])
        real *= np.sign(real @ real_shape(ref)[0])[:, None]
        rec = _mode_record(f.mean(), f.std(ddof=1), z.mean(), z.std(ddof=1), ref, None, m.sum(), gen)
        rec["cluster"] = lab
        rec["shape"] = real.mean(0) / np.abs(real.mean(0)).max()
        rec["shape_std"] = positive_std(real.std(0, ddof=1))
        modes.append(rec)
    return modes, chart


def _fdd_psd(acc, fs, lib):
    SingleSetup, _, _, FDD, _, _, _ = lib
    setup = SingleSetup(acc, fs=fs)
    alg = FDD(name="fdd", nxseg=min(NXSEG, acc.shape[0] // 8), method_SD="per")
    setup.add_algorithms(alg)
    setup.run_by_name("fdd")
    return setup, alg


def _fdd(acc, fs, band, lib):
    from scipy.signal import find_peaks

    SingleSetup, _, _, _, EFDD, _, gen = lib
    setup = SingleSetup(acc, fs=fs)
    alg = EFDD(name="efdd", nxseg=min(NXSEG, acc.shape[0] // 8), method_SD="per")
    setup.add_algorithms(alg)
    setup.run_by_name("efdd")
    r = alg.result
    freq, s1 = np.asarray(r.freq), np.asarray(r.S_val)[0, 0, :]
    db = 10 * np.log10(np.maximum(s1, 1e-300 * s1.max()))
    peaks, _ = find_peaks(db, prominence=FDD_PROMINENCE_DB)
    peaks = [p for p in peaks if band[0] <= freq[p] <= band[1]]
    vec = np.asarray(r.S_vec)[:, 0, :] if np.asarray(r.S_vec).ndim == 3 else None
    keep = []
    for p in peaks:  # two peaks with the same singular vector are one mode (a leakage side lobe)
        if keep and vec is not None and P.mac_complex(vec[:, p][None], vec[:, keep[-1]][None])[0, 0] > FDD_MAX_MAC:
            if s1[p] > s1[keep[-1]]:
                keep[-1] = p
            continue
        keep.append(p)
    chart = P.Chart(np.zeros(0, int), np.zeros(0), np.zeros(0), np.zeros(0), np.zeros((0, acc.shape[1]), complex),
                    np.zeros(0, bool), np.zeros(0, int), (), 0)
    if not keep:
        return [], chart
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alg.mpe(sel_freq=[float(freq[p]) for p in keep], DF1=0.1, DF2=1.0, cm=1, MAClim=0.95, sppk=3, npmax=20)
    rr = alg.result
    phis = np.asarray(rr.Phi).T
    modes = [_mode_record(rr.Fn[k], None, rr.Xi[k], None, phis[k], None, 1, gen) for k in range(len(keep))]
    return modes, chart


def _check_matrix_model(recording: Recording, model) -> None:
    """Every channel label is a DOF of a matrix model: a 1-based DOF number when the manifest
    gives a count of DOFs, a NODE:DIRECTION among its labels otherwise; TimeSeriesError naming
    the file and column."""
    where = f"model {model.name!r} ({model.source})" if model.source else f"model {model.name!r}"
    for s in recording.setups:
        for k, lab in enumerate(s.channels):
            if model.row_of(lab) is not None:
                continue
            if model.labelled:
                said = f"DOF number {lab}" if isinstance(lab, int) else f"{lab[0]}:{lab[1]}"
                raise TimeSeriesError(f"{s.channel_label(k)}: {said} is not one of the [node, direction] DOF labels "
                                      f"of {where}")
            if isinstance(lab, int):
                raise TimeSeriesError(f"{s.channel_label(k)}: DOF number {lab} is beyond {where}'s DOFs "
                                      f"1..{model.n_dof}")
            raise TimeSeriesError(f"{s.channel_label(k)}: a NODE:DIRECTION label, but {where} numbers its DOFs "
                                  f"1..{model.n_dof}: label the channels by DOF number")


def _check_model(recording: Recording, model) -> None:
    """Every channel label names a node and a DOF of `model`; TimeSeriesError naming the file and column."""
    from ..matrix_model import MatrixModel

    if isinstance(model, MatrixModel):
        return _check_matrix_model(recording, model)
    names = model.layout.names
    ids = set(model.node_ids)
    for s in recording.setups:
        for k, lab in enumerate(s.channels):
            if isinstance(lab, int):
                raise TimeSeriesError(f"{s.channel_label(k)}: a DOF number, but model {model.name!r} is a frame: "
                                      "label the channels NODE:DIRECTION")
            if lab[0] not in ids:
                raise TimeSeriesError(f"{s.channel_label(k)}: node {lab[0]} is not in model {model.name!r} "
                                      f"(its nodes: {min(ids)}..{max(ids)})")
            if lab[1] not in names:
                raise TimeSeriesError(f"{s.channel_label(k)}: direction {lab[1]!r} is not a DOF of model "
                                      f"{model.name!r} (its nodes have {', '.join(names)})")


def identify_ambient(recording: Recording, model=None, method: str = "ssi-cov", band_hz=None,
                     order: int | None = None) -> AmbientIdentification:
    """Identify the modes of an ambient test (a `Recording` from `read_timeseries`).

    model: a FrameModel, name or file whose nodes the channel labels name, or a matrix model
    (MatrixModel or manifest) whose DOF labels or numbers they are (optional: the data then
    names no model, model null: the channels keep their labels, mapped by a later --model); method: 'ssi-cov', 'plscf' or 'fdd'; band_hz (lo, hi) Hz (default 0 to
    the Nyquist frequency); order: the highest model order (SSI: state dimension; pLSCF:
    polynomial order). Returns an AmbientIdentification whose `data` is ModalData (real shapes
    scaled to a largest entry of 1; per mode frequency_std_hz, shape_std, damping in meta)."""
    from fe_problem import ModalData
    from fe_problem.any_model import load_any_model

    if method not in METHODS:
        raise ValueError(f"--method {method!r}: one of {', '.join(METHODS)}")
    order = DEFAULT_ORDER[method] if order is None else order
    if method != "fdd" and not (isinstance(order, int) and 2 <= order <= MAX_ORDER_LIMIT):
        raise ValueError(f"--order: a whole number from 2 to {MAX_ORDER_LIMIT}, got {order!r}")
    fs = recording.fs
    lo, hi = (0.0, fs / 2) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
        raise ValueError(f"--band {lo:g} {hi:g}: two finite frequencies (Hz), 0 <= LO < HI")
    model_ref = None
    if model is not None:
        model_ref = model if isinstance(model, str) else model.name
        model = load_any_model(model)
        _check_model(recording, model)
    lib = _pyoma()
    warn: list[str] = []
    results, charts, dropped, psd = [], [], [], []
    for s in recording.setups:
        acc, fs_used, kept, drop = _prepare(s, (lo, hi), warn)
        dropped.append(drop)
        band = (lo, min(hi, fs_used / 2))
        with _quiet():
            if method == "ssi-cov":
                modes, chart = _ssi(acc, fs_used, band, order, lib)
            elif method == "plscf":
                modes, chart = _plscf(acc, fs_used, band, order, lib)
            else:
                modes, chart = _fdd(acc, fs_used, band, lib)
            _, fdd = _fdd_psd(acc, fs_used, lib)
        f = np.asarray(fdd.result.freq)
        sv = np.asarray(fdd.result.S_val)
        sv = np.array([sv[i, i, :] for i in range(min(sv.shape[0], 4))]).real
        m = (f >= lo) & (f <= band[1])
        psd.append((f[m], sv[:, m]))
        modes = _damping_outliers(sorted(modes, key=lambda r: r["frequency_hz"]), warn)
        real = {m.get("cluster") for m in modes}  # the noise modes' clusters no longer marked chosen
        chart = replace(chart, chosen=tuple(lab for lab in chart.chosen if lab in real))
        results.append((s, kept, modes))
        charts.append(chart)
    labels, modes = _merge(results, recording, lib[-1], warn)
    if not modes:
        raise ValueError(f"{', '.join(recording.sources)}: no stable physical mode found in {lo:g}-{hi:g} Hz "
                         f"({method}, orders up to {order}): the records hold no resonance there, or the band is wrong")
    for k, m in enumerate(modes):
        if m["mpc"] < MIN_MPC:
            warn.append(f"mode {k + 1} ({m['frequency_hz']:.4g} Hz): MPC {m['mpc']:.2f} below {MIN_MPC}: a complex "
                        "shape (noise, non-proportional damping, or two close modes)")
    uncertainty = {"ssi-cov": "SSI-cov's propagated standard deviations (Doehler & Mevel 2013, pyOMA2), averaged "
                              "over the cluster's poles",
                   "plscf": "the scatter of the mode's cluster of stable poles over the model orders",
                   "fdd": "none: FDD/EFDD states no standard deviation"}[method]
    freqs = np.array([m["frequency_hz"] for m in modes])
    shapes = np.array([m["shape"] for m in modes]).T
    meta = {"source": f"femu identify --oma ({method}; pyOMA2) of " + ", ".join(recording.sources),
            "method": method, "files": list(recording.sources), "fs_hz": fs, "band_hz": [lo, hi],
            "order": order if method != "fdd" else None,
            "damping_ratio": [m["damping_ratio"] for m in modes],
            "damping_std": [m["damping_std"] for m in modes],
            "mpc": [m["mpc"] for m in modes], "mpd_deg": [m["mpd_deg"] for m in modes],
            "uncertainty": uncertainty,
            "references": [label_text(c) for c in recording.references],
            "dropped_channels": [{"file": s.source, "channel": c, "kind": kind}
                                 for s, d in zip(recording.setups, dropped) for c, kind in d],
            "warnings": warn}
    data = ModalData(model_ref, tuple(labels), freqs, shapes, meta, source=recording.sources[0])
    return AmbientIdentification(data, tuple(charts), tuple(psd), tuple(modes), method, uncertainty,
                                 tuple(dropped), tuple(warn))


def _damping_outliers(modes, warn):
    """The modes without those whose damping exceeds DAMPING_OUTLIER times the median of the
    modes found (each named in a warning): on the H-frame's simulated records with 15 channels,
    noise modes clustered at 2.8-5.4 % damping beside physical ones at 0.9-1.2 %."""
    if len(modes) < 3:
        return modes
    median = float(np.median([m["damping_ratio"] for m in modes]))
    keep = []
    for m in modes:
        if m["damping_ratio"] > DAMPING_OUTLIER * median:
            warn.append(f"a cluster at {m['frequency_hz']:.4g} Hz with damping {100 * m['damping_ratio']:.2g} % "
                        f"({m['damping_ratio'] / median:.1f} times the median {100 * median:.2g} %) was rejected "
                        "as a noise mode")
        else:
            keep.append(m)
    return keep


def _merge(results, recording: Recording, gen, warn):
    """The modes of every setup as one set over every channel kept: (labels, modes)."""
    if len(results) == 1:
        s, kept, modes = results[0]
        return [s.channels[k] for k in kept], modes
    refs = [c for c in recording.references
            if all(c in [s.channels[k] for k in kept] for s, kept, _ in results)]
    if not refs:
        raise TimeSeriesError(f"{', '.join(recording.sources)}: every reference channel was dropped; the setups "
                              "cannot be merged")
    reflists, shapes, fn_list, labels_of = [], [], [], []
    for s, kept, modes in results:
        labs = [s.channels[k] for k in kept]
        labels_of.append(labs)
        reflists.append([labs.index(c) for c in refs])
        shapes.append(np.array([m["complex_shape"] for m in modes]).T if modes else np.zeros((len(labs), 0)))
        fn_list.append(np.array([m["frequency_hz"] for m in modes]))
    mode_map = gen.match_modes(fn_list, shapes, reflists)
    n_modes = mode_map.shape[1]
    arrs = []
    for i, sh in enumerate(shapes):
        a = np.full((sh.shape[0], n_modes), np.nan, complex)
        hit = mode_map[i] >= 0
        a[:, hit] = sh[:, mode_map[i][hit]]
        arrs.append(a)
    # merge_mode_shapes puts the first setup's references first, then each setup's roving channels
    merged = gen.merge_mode_shapes(arrs, reflists)
    labels = list(refs) + [lab for labs, rl in zip(labels_of, reflists)
                           for j, lab in enumerate(labs) if j not in rl]
    out = []
    for k in range(n_modes):
        found = [(i, int(mode_map[i, k])) for i in range(len(results)) if mode_map[i, k] >= 0]
        if len(found) < len(results):
            warn.append(f"a mode near {results[found[0][0]][2][found[0][1]]['frequency_hz']:.4g} Hz was found in "
                        f"{len(found)} of {len(results)} setups: its shape is incomplete and left out")
            continue
        ms = [results[i][2][j] for i, j in found]
        fs_, sd = np.array([m["frequency_hz"] for m in ms]), [m["frequency_std_hz"] for m in ms]
        zs, zsd = np.array([m["damping_ratio"] for m in ms]), [m["damping_std"] for m in ms]
        if all(v for v in sd):
            w = 1 / np.array(sd) ** 2
            f, f_std = float((w * fs_).sum() / w.sum()), float(w.sum() ** -0.5)
        else:
            f, f_std = float(fs_.mean()), None
        if all(v for v in zsd):
            w = 1 / np.array(zsd) ** 2
            z, z_std = float((w * zs).sum() / w.sum()), float(w.sum() ** -0.5)
        else:
            z, z_std = float(zs.mean()), None
        rec = _mode_record(f, f_std, z, z_std, merged[:, k], None, sum(m["n_poles"] for m in ms), gen)
        if all(m["shape_std"] is not None for m in ms):
            # each entry's std from the setup that gave it, scaled as that setup's shape was scaled
            # onto the merged one (least squares over those entries)
            std, at = np.empty(len(labels)), 0
            for i, (m, rl) in enumerate(zip(ms, reflists)):
                idx = list(rl) + [j for j in range(len(m["shape"])) if j not in rl] if i == 0 else \
                    [j for j in range(len(m["shape"])) if j not in rl]
                r, target = m["shape"][idx], rec["shape"][at:at + len(idx)]
                std[at:at + len(idx)] = abs(r @ target / (r @ r)) * m["shape_std"][idx]
                at += len(idx)
            rec["shape_std"] = std
        out.append(rec)
    return labels, sorted(out, key=lambda r: r["frequency_hz"])
