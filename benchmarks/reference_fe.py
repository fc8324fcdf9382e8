"""The naive per-sample baseline: the H-frame objective computed one sample at a time.

This is what model updating codes commonly do, and what `UpdatingProblem.evaluate` is timed
against: for every parameter vector, assemble the global stiffness K and consistent mass M
element by element in a Python loop, solve the generalised eigenproblem K phi = lambda M phi
with `scipy.linalg.eigh`, drop the three rigid-body modes of the free-free frame, and form the
paper's eq. 4 objective.

It is written from the textbook on purpose, independently of fe_problem's element and
assembly code (fe_problem/elements/ and assembly.py are not used): the model and the
measured data are read straight from the shipped JSON files, the 6x6 matrices are written
out by hand. tests/test_reference_fe.py checks that both give the same objective, so the
fast path is verified against a from-scratch implementation.

Scope: the shipped ``hframe`` model (2-node Euler-Bernoulli frame elements, no lumped
masses, springs, supports or end releases) and data without measured shapes (the paper's).
Units: SI (m, Pa, kg/m^3); frequencies in Hz.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

import numpy as np
import scipy.linalg

#: A free-free planar frame moves rigidly in x, y and rotation about z.
N_RIGID = 3


def _shipped(name: str) -> Path:
    return Path(str(files("fe_problem") / "shipped" / name))


@dataclass(frozen=True)
class Frame:
    """The geometry and section data of a planar frame, one entry per element.

    xy: (n_nodes, 2) node coordinates (m), in model order; ends: (n_el, 2) node positions
    (0-based rows of xy) of each element's ends i, j; area_m2, inertia_m4, density_kg_m3:
    (n_el,); modulus_pa: (n_el,) the nominal moduli.
    """

    xy: np.ndarray
    ends: np.ndarray
    area_m2: np.ndarray
    inertia_m4: np.ndarray
    density_kg_m3: np.ndarray
    modulus_pa: np.ndarray

    @property
    def n_dof(self) -> int:
        return 3 * self.xy.shape[0]

    @property
    def n_elements(self) -> int:
        return self.ends.shape[0]


def load_frame(path: str | Path | None = None) -> Frame:
    """Read a ``femu.model/1`` file (default: the shipped hframe) with the json module alone.

    Raises ValueError naming the file for anything this baseline does not model.
    """
    path = _shipped("hframe.model.json") if path is None else Path(path)
    doc = json.loads(path.read_text())
    for key in ("masses", "springs", "supports"):
        if doc.get(key):
            raise ValueError(f"{path}: the reference baseline models no {key}, the file has {len(doc[key])}")
    ids = [n["id"] for n in doc["nodes"]]
    row = {nid: k for k, nid in enumerate(ids)}
    xy = np.array([[n["x"], n["y"]] for n in doc["nodes"]], dtype=float)
    ends, area, inertia, density, modulus = [], [], [], [], []
    for e in doc["elements"]:
        if e.get("formulation", "euler-bernoulli") != "euler-bernoulli":
            raise ValueError(f"{path}: element {e['id']} is {e['formulation']!r}; the baseline is Euler-Bernoulli only")
        if e.get("release_i") is not None or e.get("release_j") is not None:
            raise ValueError(f"{path}: element {e['id']} has an end release; the baseline models none")
        sec, mat = doc["sections"][e["section"]], doc["materials"][e["material"]]
        ends.append([row[e["nodes"][0]], row[e["nodes"][1]]])
        area.append(sec["area_m2"])
        inertia.append(sec["inertia_m4"])
        density.append(mat["density_kg_m3"])
        modulus.append(e.get("youngs_modulus_pa") or mat["youngs_modulus_pa"])
    return Frame(xy, np.array(ends, dtype=int), np.array(area), np.array(inertia), np.array(density),
                 np.array(modulus))


def local_stiffness(e_pa: float, a_m2: float, i_m4: float, l_m: float) -> np.ndarray:
    """Euler-Bernoulli frame element stiffness in local axes (u1, v1, th1, u2, v2, th2), N/m."""
    ea, ei = e_pa * a_m2 / l_m, e_pa * i_m4
    b12, b6, b4, b2 = 12 * ei / l_m**3, 6 * ei / l_m**2, 4 * ei / l_m, 2 * ei / l_m
    return np.array([
        [ea,   0.0,  0.0, -ea,  0.0,  0.0],
        [0.0,  b12,  b6,  0.0, -b12,  b6],
        [0.0,  b6,   b4,  0.0, -b6,   b2],
        [-ea,  0.0,  0.0, ea,   0.0,  0.0],
        [0.0, -b12, -b6,  0.0,  b12, -b6],
        [0.0,  b6,   b2,  0.0, -b6,   b4],
    ])


def local_mass(rho: float, a_m2: float, l_m: float) -> np.ndarray:
    """Consistent mass of the same element (linear axial, Hermite cubic transverse), kg.

    No rotary inertia: the Euler-Bernoulli beam's textbook consistent mass."""
    c, L = rho * a_m2 * l_m / 420.0, l_m
    return c * np.array([
        [140.0, 0.0,     0.0,       70.0, 0.0,     0.0],
        [0.0,   156.0,   22 * L,    0.0,  54.0,   -13 * L],
        [0.0,   22 * L,  4 * L**2,  0.0,  13 * L, -3 * L**2],
        [70.0,  0.0,     0.0,       140.0, 0.0,    0.0],
        [0.0,   54.0,    13 * L,    0.0,  156.0,  -22 * L],
        [0.0,  -13 * L, -3 * L**2,  0.0, -22 * L,  4 * L**2],
    ])


def transformation(c: float, s: float) -> np.ndarray:
    """T with local = T global, for an element whose axis has direction cosines (c, s)."""
    r = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    t = np.zeros((6, 6))
    t[:3, :3] = t[3:, 3:] = r
    return t


def assemble(frame: Frame, moduli_pa) -> tuple[np.ndarray, np.ndarray]:
    """Global K (N/m) and M (kg), (n_dof, n_dof), for one vector of element moduli (Pa)."""
    moduli_pa = np.asarray(moduli_pa, dtype=float)
    if moduli_pa.shape != (frame.n_elements,):
        raise ValueError(f"moduli_pa must have shape ({frame.n_elements},), got {moduli_pa.shape}")
    n = frame.n_dof
    k_glob, m_glob = np.zeros((n, n)), np.zeros((n, n))
    for e in range(frame.n_elements):
        i, j = frame.ends[e]
        dx, dy = frame.xy[j] - frame.xy[i]
        length = math.hypot(dx, dy)
        t = transformation(dx / length, dy / length)
        k = t.T @ local_stiffness(moduli_pa[e], frame.area_m2[e], frame.inertia_m4[e], length) @ t
        m = t.T @ local_mass(frame.density_kg_m3[e], frame.area_m2[e], length) @ t
        dofs = np.r_[3 * i: 3 * i + 3, 3 * j: 3 * j + 3]
        k_glob[np.ix_(dofs, dofs)] += k
        m_glob[np.ix_(dofs, dofs)] += m
    return k_glob, m_glob


def elastic_frequencies_hz(frame: Frame, moduli_pa, n_modes: int) -> np.ndarray:
    """The lowest `n_modes` elastic natural frequencies (Hz) for one vector of moduli."""
    k, m = assemble(frame, moduli_pa)
    lam = scipy.linalg.eigh(k, m, eigvals_only=True)
    elastic = lam[N_RIGID: N_RIGID + n_modes]
    return np.sqrt(np.clip(elastic, 0.0, None)) / (2.0 * math.pi)


class ReferenceObjective:
    """The paper's eq. 4 objective, one FE solve per sample in a Python loop.

    J(theta) = sum_i gamma_i ((f_i_meas - f_i(theta)) / f_i_meas)^2, with
    gamma_i = ((f_i_meas - f_i_initial) / f_i_meas)^2 and f_i_initial the model at the nominal
    moduli. Measured modes are paired once, at the nominal moduli, each with the nearest
    still unpaired model frequency among the lowest (measured + 4) modes.

    Parameters: model_path, data_path: ``femu.model/1`` and ``femu.modal-data/1`` files
    (default: the shipped hframe and the paper's five frequencies).
    """

    def __init__(self, model_path: str | Path | None = None, data_path: str | Path | None = None):
        self.frame = load_frame(model_path)
        data_path = _shipped("paper.modal.json") if data_path is None else Path(data_path)
        modes = json.loads(data_path.read_text())["modes"]
        if any(m.get("shape") is not None for m in modes):
            raise ValueError(f"{data_path}: the reference baseline handles frequency-only data")
        self.measured_hz = np.array([m["frequency_hz"] for m in modes], dtype=float)
        self.n_model_modes = len(modes) + 4
        self.x0 = self.frame.modulus_pa.copy()
        f0 = elastic_frequencies_hz(self.frame, self.x0, self.n_model_modes)
        index, used = [], set()
        for fm in self.measured_hz:
            rel = [abs(f - fm) / fm if j not in used else math.inf for j, f in enumerate(f0)]
            j = int(np.argmin(rel))
            index.append(j)
            used.add(j)
        self.model_index = np.array(index)
        self.initial_hz = f0[self.model_index]
        self.weights = ((self.measured_hz - self.initial_hz) / self.measured_hz) ** 2

    @property
    def n_var(self) -> int:
        return self.frame.n_elements

    def evaluate_one(self, x) -> float:
        """J at one vector of element moduli (Pa)."""
        f = elastic_frequencies_hz(self.frame, x, self.n_model_modes)[self.model_index]
        return float(np.sum(self.weights * ((self.measured_hz - f) / self.measured_hz) ** 2))

    def evaluate(self, X) -> np.ndarray:
        """J (n,) for X (n, n_var) or (n_var,): one assembly and one eigen-solve per row."""
        X = np.asarray(X, dtype=float)
        if X.ndim == 1:
            X = X[None, :]
        if X.ndim != 2 or X.shape[1] != self.n_var:
            raise ValueError(f"X must have shape ({self.n_var},) or (n, {self.n_var}), got {np.shape(X)}")
        return np.array([self.evaluate_one(x) for x in X])
