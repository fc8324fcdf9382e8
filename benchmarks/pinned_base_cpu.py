"""CPU seconds of one diagnosis of a portal whose base is really pinned, as a user runs it
(default `max_causes`): the case of tests/test_diagnosis_supports.py (node 1, the column's end
released with no spring by the reference FE, seed 1).

    PYTHONPATH=<tree> python benchmarks/pinned_base_cpu.py [--other-base]

Run it on two trees (main and a branch) to compare: it prints one JSON line with the CPU and
wall seconds, the answer, the local search's causes and the verdict. --other-base: the base at
node 13 (seed 4) instead. Measured for the early stop of the rounds (fe_problem/diagnosis/core.py,
`_form_explains`): main 32.0 s of CPU and four local causes, adequate; the branch 2.7 s, one
cause, the support class the answer (one run each, beside other work).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import diagnosis_cases as dc  # noqa: E402
import fe_problem as fp  # noqa: E402
from fe_problem.jsonutil import dumps  # noqa: E402


def main(argv: list[str]) -> int:
    node, column, seed = (13, 12, 4) if "--other-base" in argv else (1, 1, 1)
    truth = fp.release_element_end(dc.PORTAL, column, node, 0.0)
    data = fp.synthetic_measurement(truth, 8, dofs=dc.PORTAL.measured_dofs, freq_noise=dc.FREQ_NOISE,
                                    shape_noise=dc.SHAPE_NOISE, seed=seed, model_name=dc.PORTAL.name)
    cpu, wall = time.process_time(), time.perf_counter()
    record = json.loads(dumps(fp.diagnose(dc.PORTAL, data)))
    answer = record.get("answer") or {}
    print(json.dumps({"cpu_s": round(time.process_time() - cpu, 1), "wall_s": round(time.perf_counter() - wall, 1),
                      "cause": [record["cause"]["kind"], record["cause"]["location"]],
                      "answer": {k: answer.get(k) for k in ("label", "family", "decisive")},
                      "causes": [[c["kind"], c["location"]] for c in record["causes"]],
                      "adequate": record["adequate"]}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
