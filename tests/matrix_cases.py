"""Independent truths for the diagnosis of models given as matrices (tests/test_diagnosis_matrix.py).

A planar frame (`storeys` storeys, `bays` bays) assembled here from the textbook 6 x 6
Euler-Bernoulli frame element (none of the project's element or assembly code), one stiffness
matrix per storey (its columns and the beams above it), masses lumped on the translations of the
floor nodes and every rotation without mass. The "measured" modes come from the truth's own
matrices by another route: the massless rotations condensed out statically and the reduced
pencil solved by scipy.linalg.eigh (not femu's sparse solver), and each effect made as a
physical change, not as the candidate's form:

- a storey softer: one column's bending stiffness inside that storey's assembly (EI x ratio);
- an added mass: a small subsystem, a mass on a stiff spring attached at the DOF (one extra DOF);
- a spring to ground: an extra spring element from the DOF to a ground node.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from fe_problem.modal_data import ModalData

E, I_COL, I_BEAM, A = 2.1e11, 8.0e-5, 1.6e-4, 6.0e-3
HEIGHT, WIDTH = 3.0, 5.0
FLOOR_MASS = 8.0e3  # kg per floor node, on x and y


def frame_element(x1, y1, x2, y2, ei, ea):
    """The 6 x 6 global stiffness of a planar Euler-Bernoulli frame element (textbook)."""
    L = np.hypot(x2 - x1, y2 - y1)
    c, s = (x2 - x1) / L, (y2 - y1) / L
    k = np.zeros((6, 6))
    a, b12, b6, b4, b2 = ea / L, 12 * ei / L**3, 6 * ei / L**2, 4 * ei / L, 2 * ei / L
    k[np.ix_([0, 3], [0, 3])] = [[a, -a], [-a, a]]
    k[np.ix_([1, 2, 4, 5], [1, 2, 4, 5])] = [[b12, b6, -b12, b6], [b6, b4, -b6, b2],
                                             [-b12, -b6, b12, -b6], [b6, b2, -b6, b4]]
    t = np.zeros((6, 6))
    r = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    t[:3, :3] = t[3:, 3:] = r
    return t.T @ k @ t


class Frame:
    """The frame's nodes, DOF labels [node, direction] and per-storey stiffness matrices."""

    def __init__(self, storeys=3, bays=1, column_ei=None):
        self.storeys, self.bays = storeys, bays
        self.nodes = {}
        nid = 0
        for s in range(storeys + 1):
            for b in range(bays + 1):
                nid += 1
                self.nodes[nid] = (b * WIDTH, s * HEIGHT, s)
        self.free = [n for n, (_, _, s) in self.nodes.items() if s > 0]
        self.labels = [(n, d) for n in self.free for d in ("x", "y", "rz")]
        self.row = {lab: i for i, lab in enumerate(self.labels)}
        self.n = len(self.labels)
        # elements: (storey, i, j, EI); columns of storey s join floor s-1 to s
        self.elements = []
        grid = {(b, s): b + 1 + s * (bays + 1) for s in range(storeys + 1) for b in range(bays + 1)}
        for s in range(1, storeys + 1):
            for b in range(bays + 1):
                self.elements.append((s, grid[b, s - 1], grid[b, s], I_COL * E))
            for b in range(bays):
                self.elements.append((s, grid[b, s], grid[b + 1, s], I_BEAM * E))

    def storey_matrix(self, s, ei_ratio=None):
        """Storey s's stiffness (n x n); ei_ratio: {element index in the storey: ratio} (a column softer)."""
        k = np.zeros((self.n, self.n))
        members = [e for e in self.elements if e[0] == s]
        for idx, (_, i, j, ei) in enumerate(members):
            ratio = (ei_ratio or {}).get(idx, 1.0)
            (x1, y1, _), (x2, y2, _) = self.nodes[i], self.nodes[j]
            ke = frame_element(x1, y1, x2, y2, ei * ratio, E * A)
            dofs = [self.row.get((n, d), -1) for n in (i, j) for d in ("x", "y", "rz")]
            for a, ra in enumerate(dofs):
                for b, rb in enumerate(dofs):
                    if ra >= 0 and rb >= 0:
                        k[ra, rb] += ke[a, b]
        return k

    def mass_matrix(self):
        return np.diag([FLOOR_MASS if d != "rz" else 0.0 for _, d in self.labels])

    def write(self, folder: Path, name="frame", bounds=True) -> Path:
        """The manifest and its .npz matrices: one stiffness term per storey (with bounds), one mass."""
        folder.mkdir(parents=True, exist_ok=True)
        stiffness = []
        for s in range(1, self.storeys + 1):
            sp.save_npz(folder / f"storey{s}.npz", sp.csr_matrix(self.storey_matrix(s)))
            entry = {"name": f"storey{s}", "file": f"storey{s}.npz"}
            if bounds:
                entry.update(lower=0.3, upper=3.0)
            stiffness.append(entry)
        sp.save_npz(folder / "mass.npz", sp.csr_matrix(self.mass_matrix()))
        path = folder / f"{name}.json"
        path.write_text(json.dumps({"format": "femu.matrix-model/1", "name": name, "dofs": [list(x) for x in self.labels],
                                    "stiffness": stiffness, "mass": [{"name": "floors", "file": "mass.npz"}]}))
        return path


def condensed_modes(k, m, n_modes):
    """Frequencies (Hz) and full mode shapes of (K, M) with the massless DOFs condensed out
    statically (exact for them), solved by scipy.linalg.eigh."""
    mass = np.diag(m) > 0
    kmm, kmo = k[np.ix_(mass, mass)], k[np.ix_(mass, ~mass)]
    koo = k[np.ix_(~mass, ~mass)]
    t = -np.linalg.solve(koo, kmo.T)
    kr = kmm + kmo @ t
    lam, vec = scipy.linalg.eigh(kr, m[np.ix_(mass, mass)])
    lam, vec = lam[:n_modes], vec[:, :n_modes]
    full = np.zeros((k.shape[0], n_modes))
    full[mass] = vec
    full[~mass] = t @ vec
    return np.sqrt(lam) / (2 * np.pi), full


def truth(frame: Frame, soft=None, mass_at=None, spring_at=None):
    """The truth's (K, M) with its effect made physically (see the module docstring):
    soft = (storey, column index, EI ratio); mass_at = (label, kg); spring_at = (label, N/m)."""
    k = sum(frame.storey_matrix(s, {soft[1]: soft[2]} if soft and soft[0] == s else None)
            for s in range(1, frame.storeys + 1))
    m = frame.mass_matrix()
    if spring_at is not None:  # a spring element from the DOF to a ground node (fixed: its row removed)
        r = frame.row[spring_at[0]]
        ke = spring_at[1] * np.array([[1.0, -1.0], [-1.0, 1.0]])
        k[r, r] += ke[0, 0]
    if mass_at is not None:  # a mass on a stiff spring (100 x the first mode's scale) at the DOF: one DOF more
        r = frame.row[mass_at[0]]
        kk = 1e3 * k[r, r]
        k = np.pad(k, ((0, 1), (0, 1)))
        m = np.pad(m, ((0, 1), (0, 1)))
        k[np.ix_([r, -1], [r, -1])] += kk * np.array([[1.0, -1.0], [-1.0, 1.0]])
        m[-1, -1] = mass_at[1]
    return k, m


def measured(frame: Frame, manifest: Path, k, m, dofs, n_modes=5, freq_noise=0.002, shape_noise=0.02, seed=0,
             with_shapes=True) -> ModalData:
    """Noisy "measured" modes of the truth (K, M) at `dofs` (labels): frequencies with relative
    Gaussian noise, shape entries with noise of shape_noise x the mode's peak, random scale and sign."""
    rng = np.random.default_rng(seed)
    hz, phi = condensed_modes(k, m, n_modes)
    rows = [frame.row[tuple(d)] for d in dofs]
    shapes = phi[rows].copy()
    shapes += shape_noise * np.abs(shapes).max(axis=0) * rng.standard_normal(shapes.shape)
    shapes *= rng.choice([-1.0, 1.0], n_modes) * rng.uniform(0.5, 2.0, n_modes)
    f = hz * (1 + freq_noise * rng.standard_normal(n_modes))
    if not with_shapes:
        shapes[:] = np.nan
    return ModalData(str(manifest), tuple(tuple(d) for d in dofs), f, shapes, {"source": "test truth"})
