"""A fingerprint of planar results, to check a refactoring leaves them bit-identical.

    python benchmarks/planar_fingerprint.py save /tmp/planar_before.npz    # on the old code
    python benchmarks/planar_fingerprint.py check /tmp/planar_before.npz   # on the new code

`check` compares every array with np.array_equal (bit-identical, NaN equal to NaN) and every
text exactly, and exits 1 naming what differs. The fingerprint covers: the H-frame's modes
(dense), `UpdatingProblem.evaluate` on a fixed population for suite problems of every family,
a split frame on the sparse path, a `regular_frame` (fixed and pinned), the model file text
after a round trip (the H-frame with a release, a crack, a weak zone, a spring and a mass),
the drawn mode shapes (`deformed_frame`), synthetic FRFs of the H-frame and one diagnosis.
Bit-identity holds on one machine and BLAS; the file is not meant to travel.
"""

from __future__ import annotations

import json
import sys

import numpy as np

import fe_problem as fp
from fe_problem.elements import deformed_frame
from fe_problem.model import Spring, model_to_dict
from fe_problem.suite import storey_frame


def fingerprint() -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    h = fp.load_model("hframe")
    r = fp.modal_analysis(h, 10, solver="dense")
    out["hframe/hz"], out["hframe/shapes"] = r.frequencies_hz, r.shapes
    out["hframe/drawn"] = deformed_frame(h, r.shapes[:, 0], 0.1)

    rng = np.random.default_rng(7)
    for pid in ("paper/12/1", "hframe-freq/24/2", "hframe-shape/12/1", "hframe-shape-noisy/24/1",
                "frame-shape/12/3"):
        p = fp.suite_problem(pid)
        lo, hi = p.bounds
        X = lo + (hi - lo) * rng.random((6, len(lo)))
        out[f"suite/{pid}/X"], out[f"suite/{pid}/f"] = X, p.evaluate(X)

    # a split frame on the sparse path, with a release, a mass and a spring
    m = fp.split_elements(storey_frame(8), 3)
    m = fp.release_element_end(m, 5, m.element(5).node_j, 2e6)
    m = fp.add_mass(m, 7, 120.0, 0.5)
    pars = fp.element_moduli(m, lower=1.8e11, upper=2.4e11)
    sys_ = fp.AffineModel(m, pars, solver="sparse")
    theta = 1.8e11 + 6e10 * rng.random((3, len(pars)))
    lam, phi = sys_.eigen(theta, 8, vectors=True)
    out["sparse/lam"], out["sparse/phi"], out["sparse/rigid"] = lam, phi, np.array([sys_.n_rigid, sys_.n_elastic])
    dense = fp.AffineModel(m, pars, solver="dense")
    out["dense_split/lam"] = dense.eigen(theta, 8)[0]

    for base in ("fixed", "pinned"):
        g = fp.regular_frame(3, 4, base=base, floor_mass_kg=500.0)
        rg = fp.modal_analysis(g, 8)
        out[f"regular/{base}/hz"], out[f"regular/{base}/shapes"] = rg.frequencies_hz, rg.shapes
        out[f"regular/{base}/text"] = np.array(json.dumps(model_to_dict(g), sort_keys=True))

    e = fp.release_element_end(h, 5, 3, 1e5)
    e = fp.crack_element(e, 2, 0.4, 3e4)
    e = fp.add_mass(e, 5, 0.15, 6e-5)
    e = e.replace(springs=(Spring(1, (10, "y"), None, 2e4),))
    e = fp.split_element(e, 4, 0.37, 1e5)
    t = fp.modal_analysis(fp.with_formulation(e, "timoshenko"), 8)
    out["timoshenko/hz"], out["timoshenko/shapes"] = t.frequencies_hz, t.shapes
    text = json.dumps(model_to_dict(e), sort_keys=True)
    out["file/text"] = np.array(text)
    back = fp.model.model_from_dict(json.loads(text), "<fingerprint>")
    out["file/again"] = np.array(json.dumps(model_to_dict(back), sort_keys=True))
    re = fp.modal_analysis(e, 8)
    out["edited/hz"], out["edited/shapes"] = re.frequencies_hz, re.shapes
    out["edited/drawn"] = deformed_frame(e, re.shapes[:, 2], 0.1)

    frf = fp.synthetic_frf(h, noise=0.01, seed=3)
    out["frf/h"], out["frf/hz"] = frf.frf, frf.frequency_hz

    truth = fp.add_mass(h, 6, 0.2)
    data = fp.synthetic_measurement(truth, 8, freq_noise=0.002, shape_noise=0.02, seed=11, model_name=h.name)
    d = fp.diagnose(h, data)
    out["diagnosis/json"] = np.array(json.dumps(d.to_dict(), sort_keys=True, default=repr))
    return out


def main(argv: list[str]) -> int:
    if len(argv) != 3 or argv[1] not in ("save", "check"):
        print(__doc__)
        return 2
    fresh = fingerprint()
    if argv[1] == "save":
        np.savez(argv[2], **fresh)
        print(f"saved {len(fresh)} entries to {argv[2]}")
        return 0
    old = np.load(argv[2])
    bad = [k for k in old.files
           if k not in fresh or not np.array_equal(old[k], fresh[k], equal_nan=old[k].dtype.kind == "f")]
    bad += [k for k in fresh if k not in old.files]
    for k in bad:
        print(f"DIFFERS: {k}")
    print(f"{len(old.files) - len(bad)} of {len(old.files)} entries bit-identical")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
