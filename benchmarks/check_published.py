"""Run the long commands whose output the pages publish, and compare the pages with what they print.

    OPENBLAS_NUM_THREADS=1 nice python benchmarks/check_published.py [--only JOB ...] [--dir DIR] [--reuse] [--write]

The jobs (benchmarks/published.toml lists every figure, with `kind = "script"` for these):

- `diagnosis-standard`, `diagnosis-more`, `diagnosis-real`: `python tests/diagnosis_cases.py SEED
  --only GROUP --markdown` (seed 2026 for the standard and further classes, 5 for the classes of
  real structures): the tables of docs/diagnosis-tests.md (the full seed-2026 tables) and
  docs/diagnosis-tables.md (the current run's section). Each 10-20 minutes of CPU.
- `reproduce`: `femu reproduce --markdown` (5 seeds x 1000 evaluations, 12 optimizers; a few
  minutes): the table of README.md and docs/benchmark-studies.md, and the best mean error both
  pages quote ("gets below about X %").
- `reproduce-json`: `femu reproduce --json` on the same store (no new run after `reproduce`): the
  median best J per optimizer, the best known J and the paper's errors docs/benchmark-studies.md
  quotes below its table.
- `adapter-references`: `python benchmarks/adapter_references.py --budget 1000 --seeds 5` (each
  built-in against its library's own driver; tens of minutes, mlp-surrogate and nevergrad most of
  it): the table of docs/suite-adapters.md.
- `suite`: the study docs/benchmark-tables.md names, `femu report --json`, and
  `benchmarks/readme_suite_tables.py`: every line of that page except its provenance line
  ("Made by ...") and its Costs section (times: `machine` figures, not compared).

Each job's output is kept in DIR (default `published-check/`) as JOB.md; `--reuse` takes a job's
output from there when it exists instead of running it again (and the study's store is resumable
anyway). Prints a unified diff per page where the page differs from the fresh output and exits 1;
exit 0 when every page says what the commands print. `--write` puts the fresh output in the pages
(then review the diff with git, and update the prose that quotes the tables). Run it before a stop,
with the library versions the README names; the tests do not run it (tests/test_published_numbers.py
recomputes the quick figures).
"""

from __future__ import annotations

import argparse
import difflib
import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable

SUITE_STUDY = ["--suite", "hframe-freq/12,hframe-shape/12", "--optimizers", "cma-es,random-search,sensitivity",
               "--seeds", "0-14", "--budget", "300", "--workers", "1"]

#: job -> the command (run from the repository root)
JOBS = {
    "diagnosis-standard": [PY, "tests/diagnosis_cases.py", "2026", "--only", "standard", "--markdown"],
    "diagnosis-more": [PY, "tests/diagnosis_cases.py", "2026", "--only", "more", "--markdown"],
    "diagnosis-real": [PY, "tests/diagnosis_cases.py", "5", "--only", "real", "--markdown"],
    "reproduce": [PY, "-m", "femu", "reproduce", "--markdown", "--out", "{dir}/reproduce"],
    # the same runs (the store resumes: after `reproduce`, no new run) as JSON: the medians of J
    "reproduce-json": [PY, "-m", "femu", "reproduce", "--json", "--out", "{dir}/reproduce"],
    "suite": None,  # three commands: see _suite
    "adapter-references": [PY, "benchmarks/adapter_references.py", "--budget", "1000", "--seeds", "5"],
}

#: (job, index of the table in the job's output, page, the line after which the page shows it)
TABLES = (
    ("diagnosis-standard", 0, "docs/diagnosis-tests.md", "a claim that is not the truth."),
    ("diagnosis-standard", 1, "docs/diagnosis-tests.md", "a claim that is not the truth.", 1),
    ("diagnosis-more", 0, "docs/diagnosis-tests.md", "a claim that is not the truth.", 2),
    ("diagnosis-standard", 0, "docs/diagnosis-tables.md", "## Standard classes (seed 2026)"),
    ("diagnosis-standard", 1, "docs/diagnosis-tables.md", "## Standard classes (seed 2026)", 1),
    ("diagnosis-real", 0, "docs/diagnosis-tables.md", "## Classes of real structures (seed 5)"),
    ("reproduce", 0, "README.md", "## What `femu reproduce` found"),
    ("reproduce", 0, "docs/benchmark-studies.md", "femu reproduce --markdown"),
    ("adapter-references", 0, "docs/suite-adapters.md", "<!-- adapter-references: begin -->"),
)
#: pages that quote the reproduce table's best mean error
BEST_ERROR = (("README.md", r"gets below about ([\d.]+) %"), ("docs/benchmark-studies.md", r"gets below about ([\d.]+) %"))
SUITE_PAGE = "docs/benchmark-tables.md"
#: docs/benchmark-studies.md's prose on `femu reproduce --json`: (the words before a median best J,
#: the optimizer whose median it is); the paper's Table 1 and text errors; the best known J
STUDIES_PAGE = "docs/benchmark-studies.md"
MEDIAN_J = ((r"in the terminal\): scipy-sa ([\d.e-]+),", "scipy-sa"),
            (r"the paper's settings before, until commit \w+ of [\d-]+\) ([\d.e-]+) and", "mlp-surrogate"),
            (r"the sensitivity method ([\d.e-]+) reach it", "sensitivity"),
            (r"NGOpt \(([\d.e-]+)\)", "nevergrad-ngopt"),
            (r"pyswarms-pso \(([\d.e-]+)\)", "pyswarms-pso"),
            (r"CMA-ES ends at ([\d.e-]+);", "cma-es"),
            (r"\(DEAP, its operators, ([\d.e-]+)\)", "deap-ga"))


def printed(said: str, value: float) -> bool:
    """`value` rounds to `said` at said's printed precision (half a unit of its last digit)."""
    m = re.fullmatch(r"(\d+)(?:\.(\d+))?(?:e([-+]?\d+))?", said)
    if not m:
        return False
    return abs(float(said) - value) <= 0.5 * 10.0 ** (int(m[3] or 0) - len(m[2] or "")) * (1 + 1e-9)


def studies_prose(res: dict, text: str) -> list[str]:
    """Where docs/benchmark-studies.md's prose differs from `femu reproduce --json`'s result `res`."""
    from fe_problem.suite import PAPER_F_OPT

    text, bad = " ".join(text.split()), []
    for rx, name in MEDIAN_J:
        said = re.search(rx, text)
        got = res["solvers"].get(name, {}).get("best_f")
        if not said or got is None or not printed(said[1], got):
            bad.append(f"{STUDIES_PAGE}: median J of {name}: the page says {said[1] if said else 'nothing'}, "
                       f"the run {got}")
    said = re.search(r"against the best known J = ([\d.e-]+),", text)
    if not said or not printed(said[1], PAPER_F_OPT):
        bad.append(f"{STUDIES_PAGE}: best known J {said[1] if said else 'missing'}, PAPER_F_OPT {PAPER_F_OPT}")
    table = res["paper"]["mean_abs_error_pct_from_table"]
    said = re.search(r"The paper's Table 1 implies ([\d.]+) % for its PSO", text)
    if not said or said[1] != f"{table['PSO']:.2f}":
        bad.append(f"{STUDIES_PAGE}: the paper's Table 1 PSO error {said[1] if said else 'missing'}, recomputed {table['PSO']:.2f}")
    for k, v in res["paper"]["mean_error_pct_text"].items():
        if f"{v} % ({k})" not in text:
            bad.append(f"{STUDIES_PAGE}: the paper's text error {v} % ({k}) is not quoted")
    return bad


def tables(text: str) -> list[list[str]]:
    """The Markdown tables of a text, each as its lines."""
    out, cur = [], []
    for line in text.splitlines():
        if line.startswith("|"):
            cur.append(line)
        elif cur:
            out.append(cur)
            cur = []
    if cur:
        out.append(cur)
    return out


def table_after(lines: list[str], anchor: str, skip: int = 0) -> tuple[int, int]:
    """(first, end) line indices of the table after the first line that contains `anchor`, past
    `skip` tables; ValueError when there is none."""
    start = next((i for i, ln in enumerate(lines) if anchor in ln), None)
    if start is None:
        raise ValueError(f"no line {anchor!r}")
    i = first = start + 1
    for _ in range(skip + 1):
        while i < len(lines) and not lines[i].startswith("|"):
            i += 1
        first = i
        while i < len(lines) and lines[i].startswith("|"):
            i += 1
    if first >= len(lines):
        raise ValueError(f"no table after {anchor!r}")
    return first, i


def run(cmd: list[str], out: Path) -> str:
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed (exit {done.returncode}):\n{done.stderr[-3000:]}")
    out.write_text(done.stdout)
    return done.stdout


def _suite(d: Path) -> str:
    store = d / "suite-store"
    for cmd in ([PY, "-m", "femu", "study", *SUITE_STUDY, "--store", str(store)],
                [PY, "-m", "femu", "report", str(store), "--json"]):
        done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed (exit {done.returncode}):\n{done.stderr[-3000:]}")
    (d / "suite-stats.json").write_text(done.stdout)
    study = "femu study " + " ".join(SUITE_STUDY)
    made = subprocess.run([PY, "benchmarks/readme_suite_tables.py", str(d / "suite-stats.json"), "--study", study],
                          cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return made


def output(job: str, d: Path, reuse: bool) -> str:
    kept = d / f"{job}.md"
    if reuse and kept.is_file():
        return kept.read_text()
    if job == "suite":
        text = _suite(d)
        kept.write_text(text)
        return text
    return run([c.format(dir=d) for c in JOBS[job]], kept)


def _suite_lines(text: str) -> list[str]:
    """The suite page's lines that a fresh run must reproduce: not the provenance line, not the costs."""
    out, costs = [], False
    for line in text.splitlines():
        if line.startswith("## "):
            costs = line.strip() == "## Costs"
        if costs or line.startswith("Made by "):
            continue
        out.append(line)
    return out


def diff(page: str, said: list[str], made: list[str]) -> str:
    return "\n".join(difflib.unified_diff(said, made, f"{page} (the page)", f"{page} (the command)", lineterm=""))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", choices=list(JOBS), default=list(JOBS), help="the jobs to run")
    ap.add_argument("--dir", default="published-check", help="where the jobs' outputs are kept")
    ap.add_argument("--reuse", action="store_true", help="take a job's output from --dir when it is there")
    ap.add_argument("--write", action="store_true", help="put the fresh output in the pages")
    a = ap.parse_args(argv)
    d = Path(a.dir).resolve()
    d.mkdir(parents=True, exist_ok=True)
    made = {job: output(job, d, a.reuse) for job in a.only}
    problems = 0
    pages: dict[str, list[str]] = {}
    for row in TABLES:
        job, k, page, anchor = row[:4]
        skip = row[4] if len(row) > 4 else 0
        if job not in made:
            continue
        lines = pages.setdefault(page, (ROOT / page).read_text().splitlines())
        fresh = tables(made[job])[k]
        try:
            first, end = table_after(lines, anchor, skip)
        except ValueError as exc:
            print(f"{page}: {exc}")
            problems += 1
            continue
        if lines[first:end] == fresh:
            print(f"{page}: the table after {anchor!r} is what `{job}` prints")
        elif a.write:
            lines[first:end] = fresh
            print(f"{page}: the table after {anchor!r} rewritten from `{job}`")
        else:
            print(diff(page, lines[first:end], fresh))
            problems += 1
    if "reproduce" in made:
        best = min(float(r.split("|")[-2]) for r in tables(made["reproduce"])[0][4:-1])
        for page, rx in BEST_ERROR:
            text = " ".join((ROOT / page).read_text().split())
            said = re.search(rx, text)
            if not said or said[1] != f"{best:.2f}":
                print(f"{page}: says {said[1] if said else 'nothing'} for the best mean error; the table's is {best:.2f}")
                problems += 1
            else:
                print(f"{page}: the best mean error {said[1]} % is the table's")
    if "reproduce-json" in made:
        bad = studies_prose(json.loads(made["reproduce-json"]), (ROOT / STUDIES_PAGE).read_text())
        print("\n".join(bad) or f"{STUDIES_PAGE}: the medians of J and the paper's errors are the run's")
        problems += len(bad)
    if "suite" in made:
        said = _suite_lines((ROOT / SUITE_PAGE).read_text())
        fresh = _suite_lines(made["suite"])
        if said == fresh:
            print(f"{SUITE_PAGE}: what benchmarks/readme_suite_tables.py prints (provenance and costs not compared)")
        elif a.write:
            (ROOT / SUITE_PAGE).write_text(made["suite"])
            print(f"{SUITE_PAGE}: rewritten")
        else:
            print(diff(SUITE_PAGE, said, fresh))
            problems += 1
    if a.write:
        for page, lines in pages.items():
            (ROOT / page).write_text("\n".join(lines) + "\n")
    print(json.dumps({"jobs": list(made), "pages_differing": problems}))
    return 1 if problems and not a.write else 0


if __name__ == "__main__":
    sys.exit(main())
