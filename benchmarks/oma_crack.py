"""A crack found from ambient records, end to end: the H-frame with the crack of the FRF path's
test (element 7 at 0.3, 3e4 N m/rad) simulated under ambient excitation, identified by
`femu identify --oma`, diagnosed by `femu diagnose`.

The records: modal superposition of the cracked model's first 20 modes (the project's modal
analysis: the route of this script is not independent of it, unlike tests/test_oma.py's
accuracy checks), 1 % modal damping, independent white modal forces scaled by 1/sqrt(omega) so
that each mode adds about the same acceleration variance (a well-excited test; with equal
forces the first mode sits barely above the noise and is not found), each mode's SDOF filter
discretised exactly for a force held over a sample (scipy), accelerations at the model's 15
measured coordinates, 5 % sensor noise, 20 s at 5 kHz.

    OPENBLAS_NUM_THREADS=1 python benchmarks/oma_crack.py [DIR]

Prints the identified modes against the truth and the diagnosis' cause. Its CI-sized version,
built independently of the project's modal code (OpenSeesPy, a split element), is
tests/test_oma_crack.py. `femu diagnose` reads
the identified file as written, its `frequency_std_hz` and `shape_std` the noise of each mode.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.signal as sg

import fe_problem as fp

CRACK = dict(element_id=7, position=0.3, stiffness=3e4)
FS, DURATION_S, DAMPING, NOISE, N_MODES = 5000.0, 20.0, 0.01, 0.05, 20


def simulate(seed: int = 0):
    truth = fp.crack_element(fp.load_model("hframe"), **CRACK)
    dofs = fp.load_model("hframe").measured_dofs
    modes = fp.modal_analysis(truth, N_MODES)
    phi = modes.at(dofs)  # (15, N_MODES)
    rng = np.random.default_rng(seed)
    n = int(FS * DURATION_S)
    acc = np.zeros((n, len(dofs)))
    for j, f in enumerate(modes.frequencies_hz):
        w = 2 * np.pi * f
        # q'' + 2 zeta w q' + w^2 q = p(t); output q'' = p - 2 zeta w q' - w^2 q
        A = np.array([[0.0, 1.0], [-w * w, -2 * DAMPING * w]])
        system = sg.StateSpace(A, np.array([[0.0], [1.0]]), A[1:], np.array([[1.0]])).to_discrete(1 / FS)
        _, qdd, _ = sg.dlsim(system, rng.standard_normal(n) / np.sqrt(w))
        acc += np.outer(qdd.ravel(), phi[:, j])
    acc += NOISE * acc.std(0) * rng.standard_normal(acc.shape)
    return acc, dofs, fp.modal_analysis(truth, 8).frequencies_hz


def main(out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    acc, dofs, f_true = simulate()
    npz = out / "ambient.npz"
    np.savez(npz, acc=acc, fs=FS, dofs=np.array([f"{n}:{d}" for n, d in dofs]))
    femu = [sys.executable, "-m", "femu"]
    ident = subprocess.run(femu + ["identify", str(npz), "--oma", "--model", "hframe", "--band", "20", "1400",
                                   "--order", "60", "--out", str(out / "oma")], capture_output=True, text=True)
    print(ident.stdout, ident.stderr)
    if ident.returncode:
        return ident.returncode
    doc = json.loads((out / "oma" / "modal-data.json").read_text())
    found = np.array([m["frequency_hz"] for m in doc["modes"]])
    print("true Hz    ", np.round(f_true, 2))
    print("found Hz   ", np.round(found, 2))
    diag = subprocess.run(femu + ["diagnose", str(out / "oma" / "modal-data.json"), "--json"], capture_output=True,
                          text=True)
    if diag.returncode:
        print(diag.stderr)
        return diag.returncode
    cause = json.loads(diag.stdout)["cause"]
    print("cause", cause)
    return 0 if cause.get("location") == {"element": CRACK["element_id"]} else 1


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="oma-crack-"))))
