"""Ambient responses of a shear building, simulated for the OMA tests by a route independent of
the project's modal code: the building's mass and stiffness matrices assembled here, modal
damping, the state space discretised exactly for a force held over each sample (scipy.signal,
zero-order hold) and run by `dlsim` under white random forces at every storey, plus white
sensor noise of a fraction of each channel's standard deviation. The truth (frequencies and
mass-normalised shapes) comes from scipy.linalg.eigh of the same matrices.
"""

import numpy as np
import scipy.linalg as sl
import scipy.signal as sg

#: storey stiffness N/m and mass kg of the default building: 3 storeys at 4.48, 12.55, 18.14 Hz
STOREY_STIFFNESS = 4.0e3
STOREY_MASS = 1.0


def shear_building(n_storeys: int = 3, k: float = STOREY_STIFFNESS, m: float = STOREY_MASS):
    """(M, K) of a fixed-base shear building of n storeys (storey 1 at the base)."""
    K = np.zeros((n_storeys, n_storeys))
    for i in range(n_storeys):
        K[i, i] += k
        if i + 1 < n_storeys:
            K[i, i] += k
            K[i, i + 1] = K[i + 1, i] = -k
    return m * np.eye(n_storeys), K


def truth(M, K):
    """(frequencies Hz, shapes (n, n) by column) of the undamped building."""
    w2, V = sl.eigh(K, M)
    return np.sqrt(w2) / (2 * np.pi), V


def ambient_response(seed: int, duration_s: float = 120.0, fs: float = 100.0, noise: float = 0.1,
                     damping: float = 0.01, n_storeys: int = 3, storey_stiffness: float = STOREY_STIFFNESS):
    """(acc (n_samples, n_storeys) m/s^2, frequencies Hz, shapes) of one ambient record."""
    M, K = shear_building(n_storeys, storey_stiffness)
    f, V = truth(M, K)
    w = 2 * np.pi * f
    C = M @ V @ np.diag(2 * damping * w) @ V.T @ M  # modal damping: V^T C V = diag(2 zeta w)
    n = n_storeys
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    B = np.vstack([np.zeros((n, n)), Minv])
    system = sg.StateSpace(A, B, A[n:], Minv).to_discrete(1 / fs, method="zoh")  # acceleration output
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((int(duration_s * fs), n))
    _, y, _ = sg.dlsim(system, u)
    y = y + noise * y.std(0) * rng.standard_normal(y.shape)
    return y, f, V


def write_csv(path, acc, fs, labels, time_column=True, comment="simulated shear building"):
    """The time-series CSV layout (shared/formats/time-series.md)."""
    t = np.arange(acc.shape[0]) / fs
    head = ",".join((["time_s"] if time_column else []) + list(labels))
    table = np.column_stack([t, acc]) if time_column else acc
    with open(path, "w") as fh:
        fh.write(f"# {comment}\n{head}\n")
        np.savetxt(fh, table, delimiter=",", fmt="%.9g")
    return path
