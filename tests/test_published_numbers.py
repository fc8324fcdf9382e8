"""Figures the docs publish, produced by the commands that make them (the quick ones): a number in
a page that drifts from what its command prints fails here."""

import re
from pathlib import Path

import pytest

from femu.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _number(pattern: str, text: str, where: str) -> str:
    m = re.search(pattern, " ".join(text.split()))
    assert m, f"{where}: no match for {pattern!r}"
    return m[1]


@pytest.fixture(scope="module")
def paper_diagnosis(tmp_path_factory):
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["diagnose", "paper"]) == 0
    return out.getvalue()


def test_diagnosis_page_on_the_papers_data(paper_diagnosis):
    page = (ROOT / "docs" / "diagnosis-real-data.md").read_text()
    said = " ".join(page[page.index("## On the paper's data"):].split())
    out = paper_diagnosis
    # "a linear trend of the modulus along the span has 15.17 more in log evidence than no effect"
    ev = _number(r"log evidence ([\d.]+) against 0\), but no candidate is significant", out, "femu diagnose paper")
    assert _number(r"along the span has ([\d.]+) more in log evidence", said, "docs/diagnosis-real-data.md") == ev
    assert "stiffness_trend@trend=linear_span+ has more evidence" in out
    # "drops chi^2 by 807 where 855 is needed after the correction for 166 candidates (p = 0.016)"
    drop = float(_number(r"chi\^2 drop ([\d.]+), \d+ needed", out, "femu diagnose paper"))
    need = _number(r"chi\^2 drop [\d.]+, (\d+) needed", out, "femu diagnose paper")
    assert _number(r"drops chi\^2 by (\d+) where", said, "docs/diagnosis-real-data.md") == f"{drop:.0f}"
    assert _number(r"where (\d+) is needed", said, "docs/diagnosis-real-data.md") == need
    n = _number(r"adjusted over (\d+) candidates", out, "femu diagnose paper")
    assert _number(r"correction for (\d+) candidates", said, "docs/diagnosis-real-data.md") == n
    p = float(_number(r"p = ([\d.]+) \(adjusted", out, "femu diagnose paper"))
    assert _number(r"candidates \(p = ([\d.]+)\)", said, "docs/diagnosis-real-data.md") == f"{p:.2g}"
    noise = float(_number(r"misfit implies: frequencies ([\d.]+) %", out, "femu diagnose paper"))
    assert _number(r"misfit implies ([\d.]+) % frequency noise", said, "docs/diagnosis-real-data.md") == f"{noise:.1f}"
    assert "CAUSE: none" in out and "VERDICT: NOT ADEQUATE" in out


def test_the_readme_reproduce_table_is_where_the_check_script_looks():
    # benchmarks/readme_reproduce.py (minutes of CPU: run before a release) compares README.md's
    # table with `femu reproduce --markdown`; here only that it finds that table and its form
    import importlib.util

    spec = importlib.util.spec_from_file_location("readme_reproduce", ROOT / "benchmarks" / "readme_reproduce.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    text = (ROOT / "README.md").read_text()
    first, end = mod.readme_table(text)
    table = text.splitlines()[first:end]
    assert table[0] == "|  | f1 | f2 | f3 | f4 | f5 | mean abs error % |"  # femu.reports.reproduce.render_markdown's
    assert table[2].startswith("| measured | 53.9 | 117.3 |") and table[-1].startswith("| paper PSO / SA / GA (Table 1) |")


@pytest.fixture(scope="module")
def hframe_modes():
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["model", "hframe", "--modes", "10"]) == 0
    return [float(m[1]) for m in re.finditer(r"^\s+\d+\s+([\d.]+)$", out.getvalue(), re.M)]


def test_hframe_page_nominal_frequencies_and_their_match_to_the_paper(hframe_modes):
    import math

    page = " ".join((ROOT / "docs" / "hframe.md").read_text().split())
    said = _number(r"Nominal elastic frequencies \(Hz\), modes 1-10: ([\d., ]+)\.", page, "docs/hframe.md")
    assert len(hframe_modes) == 10
    assert [f"{f:.3f}" for f in hframe_modes] == [s.strip() for s in said.split(",")]  # as `femu model` prints them
    # "reproduce the paper's initial-model frequencies to within X %": X is the worst mode's
    # difference to the paper's Table 1 (its "initial" column, read from the same page), rounded up
    text = (ROOT / "docs" / "hframe.md").read_text()
    table = re.findall(r"^\| (\d) \| [\d.]+ \| ([\d.]+) \|", text[text.index("## The published data"):], re.M)
    paper = [float(v) for _, v in table[:5]]
    worst = max(abs(f / p - 1) * 100 for f, p in zip(hframe_modes, paper))
    bound = f"{math.ceil(worst * 100) / 100:.2f}"
    for name in ("docs/hframe.md", "README.md"):
        text = " ".join((ROOT / name).read_text().split())
        assert _number(r"initial-model frequencies to within ([\d.]+) %", text, name) == bound


def test_the_space_frames_first_frequencies_on_the_elements_page():
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["model", "frame3d", "--modes", "5"]) == 0
    printed = re.findall(r"^\s+\d+\s+([\d.]+)$", out.getvalue(), re.M)
    page = " ".join((ROOT / "docs" / "model-elements.md").read_text().split())
    said = _number(r"its first frequencies are ([\d., ]+) Hz", page, "docs/model-elements.md")
    assert [s.strip() for s in said.split(",")] == printed  # as `femu model frame3d --modes 5` prints them


def test_the_long_run_check_finds_every_table_it_compares():
    # benchmarks/check_published.py (an hour of CPU: run before a stop) compares the diagnosis, reproduce
    # and suite tables with the pages; here only that each table it looks for is where it looks
    import importlib.util

    spec = importlib.util.spec_from_file_location("check_published", ROOT / "benchmarks" / "check_published.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    headers = {"diagnosis-standard": ("| truth \\ answer |", "| class | cases | right |"),
               "diagnosis-more": ("| class | cases | right |",), "diagnosis-real": ("| class | cases | right |",),
               "reproduce": ("|  | f1 | f2 |",), "adapter-references": ("| built-in | reference | problem |",)}
    for row in mod.TABLES:
        job, k, page, anchor = row[:4]
        lines = (ROOT / page).read_text().splitlines()
        first, end = mod.table_after(lines, anchor, row[4] if len(row) > 4 else 0)
        assert end - first >= 3 and lines[first].startswith(headers[job][min(k, len(headers[job]) - 1)]), (page, anchor)
    said = mod._suite_lines((ROOT / mod.SUITE_PAGE).read_text())
    assert said[0].startswith("# ") and not any(s.startswith("Made by") or s == "## Costs" for s in said)
    assert mod.tables("a\n| x |\n|---|\n| 1 |\nb\n| y |\n") == [["| x |", "|---|", "| 1 |"], ["| y |"]]


def test_the_long_run_check_reports_a_page_that_differs(tmp_path, capsys):
    import importlib.util

    spec = importlib.util.spec_from_file_location("check_published", ROOT / "benchmarks" / "check_published.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    lines = (ROOT / "docs" / "diagnosis-tables.md").read_text().splitlines()
    first, end = mod.table_after(lines, "## Classes of real structures (seed 5)")
    page_table = lines[first:end]
    (tmp_path / "diagnosis-real.md").write_text("\n".join(page_table) + "\n")  # what the page says: no difference
    assert mod.main(["--only", "diagnosis-real", "--reuse", "--dir", str(tmp_path)]) == 0
    changed = page_table[:2] + [page_table[2].replace("| 4 |", "| 5 |", 1)] + page_table[3:]
    (tmp_path / "diagnosis-real.md").write_text("\n".join(changed) + "\n")
    assert mod.main(["--only", "diagnosis-real", "--reuse", "--dir", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert f"-{page_table[2]}" in out and f"+{changed[2]}" in out


def _g(v: float, digits: int = 2, spec: str = "g") -> str:
    """v to `digits` significant digits as the pages write it (5e-9, 1.0e-9: no zeros in the exponent)."""
    return re.sub(r"e([-+])0*(\d)", r"e\1\2", f"{v:.{digits - (spec == 'e')}{spec}}").replace("e+", "e")


def test_suite_optima_192_certificates_are_the_stored_ones():
    # docs/suite-optima.md quotes the five 192-parameter certificates (benchmarks/suite_fopt.py's
    # output, fe_problem/suite_fopt.json; tests/test_certify.py evaluates J at each stored point and
    # checks it is f_opt within the precision and no point near or far is lower): each figure here
    # is read from the page and compared with the stored certificate to its printed precision
    import fe_problem.suite as fs

    certs = fs.certificates()
    c = {k: certs[f"hframe-shape-noisy/192/{k}"] for k in range(1, 6)}
    page = " ".join((ROOT / "docs" / "suite-optima.md").read_text().split())
    where = "docs/suite-optima.md"

    def said(pattern):
        m = re.search(pattern, page)
        assert m, f"{where}: no match for {pattern!r}"
        return m.groups()

    def ends(k):
        return sorted(e - c[k]["f_opt"] for e in c[k]["ends"])

    pct = {k: 100 * (1 - c[k]["f_opt"] / c[k]["j_truth"]) for k in c}
    # 192/1
    g = said(r"\*\*192/1 is certified\*\* \(x0, the truth, a random start; ([\d,]+) s wall, about \d+ CPU-minutes\): "
             r"f_opt ([\d.]+), precision ([\d.e-]+) \(the x0 and random ends ([\d.e-]+) apart; the truth's ended "
             r"([\d.e-]+) higher, outside the ([\d.e-]+) window\), noise ([\d.e-]+), projected gradient ([\d.e-]+)\.")
    e = ends(1)
    assert g == (f"{c[1]['seconds']:,.0f}", repr(c[1]["f_opt"]), _g(c[1]["precision"]), _g(e[1] - e[0]),
                 _g(e[2] - e[0], 1), "1e-8", _g(c[1]["noise"]), _g(c[1]["projected_gradient"]))
    assert e[2] - e[0] > 1e-8 * c[1]["f_opt"] > e[1] - e[0]  # the truth's end is outside the window, the others in
    # 192/2
    g = said(r"\*\*192/2 is certified\*\* the same way \(([\d,]+) s wall at nice 19 beside the test suite\): f_opt "
             r"([\d.]+) \(J\(truth\) ([\d.]+)\), precision ([\d.e-]+) \(twice the noise ([\d.e-]+) its solve measured; "
             r"the truth and random ends ([\d.e-]+) apart, the x0 end ([\d.e-]+) higher, outside the window\), "
             r"projected gradient ([\d.e-]+)\.")
    e = ends(2)
    assert g == (f"{int(c[2]['seconds']):,}", repr(c[2]["f_opt"]), f"{c[2]['j_truth']:.6g}", _g(c[2]["precision"]),
                 _g(c[2]["precision"] / 2), _g(e[1] - e[0]), _g(e[2] - e[0]), _g(c[2]["projected_gradient"], 2, "e"))
    # 192/3
    g = said(r"\*\*192/3 too\*\* \((\d+) s wall on a core of its own\): f_opt ([\d.]+) \(J\(truth\) ([\d.]+)\), "
             r"precision ([\d.e-]+) \(twice the noise ([\d.e-]+); the three ends, on the dense twin, ([\d.e-]+) apart\), "
             r"projected gradient ([\d.e-]+)\.")
    e = ends(3)
    assert g == (f"{c[3]['seconds']:.0f}", repr(c[3]["f_opt"]), f"{c[3]['j_truth']:.6g}", _g(c[3]["precision"]),
                 _g(c[3]["noise"]), _g(e[2] - e[0]), _g(c[3]["projected_gradient"]))
    assert c[3]["precision"] == pytest.approx(2 * c[3]["noise"], rel=1e-3) and c[3]["solved_on"] == "dense"
    # 192/4 and 192/5
    g = said(r"\*\*192/4 and 192/5 as well\*\* \((\d+) s and (\d+) s wall, each on a core of its own\): f_opt ([\d.]+) "
             r"and ([\d.]+) \(([\d.]+) % and ([\d.]+) % below J\(truth\)\), precisions ([\d.e-]+) and ([\d.e-]+) \(twice "
             r"J's noise: over the BLAS kernels for 192/4, at its solve for 192/5; the three ends of each ([\d.e-]+) "
             r"apart\), projected gradients ([\d.e-]+) and ([\d.e-]+)\.")
    assert g[:8] == (f"{c[4]['seconds']:.0f}", f"{c[5]['seconds']:.0f}", repr(c[4]["f_opt"]), repr(c[5]["f_opt"]),
                     f"{pct[4]:.1f}", f"{pct[5]:.1f}", _g(c[4]["precision"], 2, "e"), _g(c[5]["precision"], 2, "e"))
    assert max(ends(4)[2] - ends(4)[0], ends(5)[2] - ends(5)[0]) <= float(g[8]) and g[8] == "1e-13"
    assert g[9:] == (_g(c[4]["projected_gradient"]), _g(c[5]["projected_gradient"]))
    assert c[4]["precision"] == pytest.approx(2 * c[4]["noise"], rel=1e-3) and c[5]["precision"] > 2 * c[5]["noise"]


def test_suite_optima_why_the_192_minimum_is_not_0():
    # "the Jacobian at the truth of 192/1 has exactly 8 singular values at 1e-17 ... its singular values
    # fall from 0.33 to 1e-14 (95 above 1e-10 of the largest)": the analytic Jacobian (checked against
    # central differences by tests/test_certify.py) in the unit box, its singular values by LAPACK
    import numpy as np

    import fe_problem as fp
    from fe_problem.certify import ModalJacobian

    p = fp.suite_problem("hframe-shape-noisy/192/1")
    _, jac = ModalJacobian(p)(p.truth)
    s = np.linalg.svd(jac * (p.xu - p.xl), compute_uv=False)
    page = " ".join((ROOT / "docs" / "suite-optima.md").read_text().split())
    m = re.search(r"the 128 residuals span at most (\d+) directions \(the Jacobian at the truth of 192/1 has exactly "
                  r"(\d+) singular values at ([\d.e-]+)\), and its singular values fall from ([\d.]+) to ([\d.e-]+) "
                  r"\((\d+) above ([\d.e-]+) of the largest\)", page)
    assert m, "docs/suite-optima.md: the 192 Jacobian's singular values not found"
    assert len(s) == 128 and int(m[1]) == 120 and int(m[2]) == 128 - 120
    assert np.all(s[120:] < 10 * float(m[3])) and np.all(s[120:] > float(m[3]) / 10)  # at 1e-17: its order
    assert f"{s[0]:.2f}" == m[4] and _g(s[119], 1, "e") == m[5]
    assert int((s > float(m[7]) * s[0]).sum()) == int(m[6])
    # "The minimum found is 0.0130666 (J(truth) 0.0164585, 20.6 % lower)", the smaller sizes' certified
    # minima, the frequency-only instances' lowest J: the stored certificates (benchmarks/suite_fopt.py's)
    import fe_problem.suite as fs

    certs = fs.certificates()
    c1 = certs["hframe-shape-noisy/192/1"]
    where = "docs/suite-optima.md"
    g = (_number(r"The minimum found is ([\d.]+) \(J\(truth\)", page, where),
         _number(r"The minimum found is [\d.]+ \(J\(truth\) ([\d.]+),", page, where),
         _number(r"The minimum found is [\d.]+ \(J\(truth\) [\d.]+, ([\d.]+) % lower\)", page, where))
    assert g == (f"{c1['f_opt']:.6g}", f"{c1['j_truth']:.6g}", f"{100 * (1 - c1['f_opt'] / c1['j_truth']):.1f}")
    smaller = [v["f_opt"] for k, v in certs.items() if k.startswith("hframe-shape-noisy/") and "/192/" not in k]
    assert len(smaller) == 20 and _number(r"their certified minima \(([\d.]+-[\d.]+), many moduli", page, where) \
        == f"{min(smaller):.3f}-{max(smaller):.3f}"
    freq = min(min(v["ends"]) for k, v in certs.items() if k.startswith("hframe-freq-noisy/"))
    assert _number(r"as `hframe-freq-noisy` does \(8 residuals, J reaches ([\d.e-]+)\)", page, where) == _g(freq, 1, "e")


def _printed(said: str, value: float) -> bool:
    """`value` rounds to `said` at its printed precision (half a unit of its last digit: 7e-14 for
    7.1e-14, 2.1e-13 for 2.14e-13)."""
    m = re.fullmatch(r"(\d+)(?:\.(\d+))?(?:e([-+]?\d+))?", said.replace(",", ""))
    assert m, said
    unit = 10.0 ** (int(m[3] or 0) - len(m[2] or ""))
    return abs(float(said.replace(",", "")) - value) <= 0.5 * unit * (1 + 1e-9)


def test_suite_optima_certificate_ranges_are_the_stored_ones():
    # docs/suite-optima.md's ranges over the stored certificates (benchmarks/suite_fopt.py's output,
    # fe_problem/suite_fopt.json, which tests/test_certify.py checks against the problems): noise,
    # precision, spread of the starts, projected gradient, Jacobian check, time, per size
    import fe_problem.suite as fs

    certs = fs.certificates()
    page = " ".join((ROOT / "docs" / "suite-optima.md").read_text().split())

    def group(fam, *sizes):
        out = [c for k, c in certs.items() if k.split("/")[0] == fam and int(k.split("/")[1]) in sizes]
        assert len(out) == 5 * len(sizes)
        return out

    def spread(c):  # the ends within the 1e-8 window of the lowest
        low = min(c["ends"])
        return max(e for e in c["ends"] if e - low <= 1e-8 * low) - low

    def rng(pattern, values, text=page):
        m = re.search(pattern, text)
        assert m, f"docs/suite-optima.md: no match for {pattern!r}"
        lo, hi = m.groups()
        assert _printed(lo, min(values)) and _printed(hi, max(values)), (pattern, lo, hi, min(values), max(values))

    e = r"([\d.]+(?:e-\d+)?)"
    shape = {n: group("hframe-shape-noisy", n) for n in (12, 24, 48, 96, 192)}
    # J's evaluation noise (now the largest over the BLAS kernels) per size
    noise = page[page.index("That noise is the rounding"):page.index("a run may see J that much below")]
    for n in (12, 24, 48, 96):
        rng(rf"{e} to {e} at {n}\b", [c["noise"] for c in shape[n]], noise)
    # the precisions after suite_fopt.py --noise, their largest relative, the kernels
    now = page[page.index("Measured on an AVX-512 CPU"):page.index("`projected_gradient` is first-order")]
    for n in (12, 24, 48, 96, 192):
        rng(rf"{e} to {e} at {n}\b", [c["precision"] for c in shape[n]], now)
    every = [c for n in shape for c in shape[n]]
    m = re.search(rf"\(at most {e} relative\)", page)
    assert m and _printed(m[1], max(c["precision"] / c["f_opt"] for c in every))
    assert all(c["kernels"] == ["Haswell", "Sandybridge", "SkylakeX"] for c in every)
    assert "with Sandybridge, Haswell and SkylakeX" in page
    # "J reaches 1e-28" on the frequency-only instances, "all 0, precision 3e-28 to 1e-20"
    freq = group("hframe-freq-noisy", 12, 24, 48, 96, 192)
    assert all(c["f_opt"] == 0.0 for c in freq)
    m = re.search(rf"J reaches {e}\)", page)
    assert m and _printed(m[1], min(min(c["ends"]) for c in freq))
    rng(rf"all 0, precision {e} to {e};", [c["precision"] for c in freq])
    # 12, 24 and 48: 15 instances, 6 starts each, f_opt below J(truth), spread, gradient, Jacobian check, minutes
    small = shape[12] + shape[24] + shape[48]
    assert len(small) == 15 and all(c["starts"] == 6 for c in small) and "(15 instances, 6 starts each" in page
    rng(r"f_opt (\d+)-(\d+) % below J\(truth\)", [100 * (1 - c["f_opt"] / c["j_truth"]) for c in small])
    rng(rf"spread of the starts {e} to {e}, a relative", [spread(c) for c in small])
    rng(rf"a relative {e} to {e}, projected gradient", [spread(c) / c["f_opt"] for c in small])
    m = re.search(rf"projected gradient at most {e}, Jacobian check at most {e}; (\d+) to (\d+) minutes each", page)
    assert m and _printed(m[1], max(c["projected_gradient"] for c in small))
    assert _printed(m[2], max(c["jacobian_check"] for c in small))
    assert _printed(m[3], min(c["seconds"] for c in small) / 60) and _printed(m[4], max(c["seconds"] for c in small) / 60)
    # 96: 4 starts, minutes, the spread and its relative, the ends outside the window, the gradient
    big = shape[96]
    assert all(c["starts"] == 4 and c["starts_from"] == ["x0", "truth", "perturbed", "random"] for c in big)
    rng(r"\(4 starts each: x0, the truth, a perturbed truth, a random point; (\d+) to (\d+) minutes each\)",
        [c["seconds"] / 60 for c in big])
    rng(rf"the spread is {e} to {e} \(a", [spread(c) for c in big])
    rng(rf"\(a relative {e} to {e}; one start each", [spread(c) / c["f_opt"] for c in big])
    outside = {k: max(c["ends"]) - min(c["ends"]) for k, c in certs.items()
               if k.startswith("hframe-shape-noisy/96/") and max(c["ends"]) - min(c["ends"]) > 1e-8 * min(c["ends"])}
    assert sorted(outside) == [f"hframe-shape-noisy/96/{k}" for k in (2, 3, 4)]
    assert all(sum(e - min(certs[k]["ends"]) > 1e-8 * min(certs[k]["ends"]) for e in certs[k]["ends"]) == 1 for k in outside)
    rng(rf"one start each of 96/2, 96/3 and 96/4 ended {e} to {e} above", list(outside.values()))
    m = re.search(rf"not counted\); projected gradient up to {e}\.", page)
    assert m and _printed(m[1], max(c["projected_gradient"] for c in big))


def test_the_long_run_check_compares_the_studies_prose_with_reproduce_json():
    # benchmarks/check_published.py's `reproduce-json` job: docs/benchmark-studies.md's medians of J,
    # the best known J and the paper's errors against `femu reproduce --json` (here a result made of
    # the page's own numbers: no difference; one median moved by more than its last digit: reported)
    import importlib.util
    import json

    spec = importlib.util.spec_from_file_location("check_published", ROOT / "benchmarks" / "check_published.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    text = (ROOT / mod.STUDIES_PAGE).read_text()
    flat = " ".join(text.split())
    paper = json.loads((ROOT / "fe_problem" / "shipped" / "paper.modal.json").read_text())
    res = {"solvers": {name: {"best_f": float(re.search(rx, flat)[1])} for rx, name in mod.MEDIAN_J},
           "paper": {"mean_abs_error_pct_from_table": {"PSO": float(_number(r"Table 1 implies ([\d.]+) %", flat, "page"))},
                     "mean_error_pct_text": paper["meta"]["table1"]["mean_error_pct_text"]}}
    assert len(res["solvers"]) == 7 and mod.studies_prose(res, text) == []
    res["solvers"]["cma-es"]["best_f"] *= 1.01
    assert [b.split(":")[1] for b in mod.studies_prose(res, text)] == [" median J of cma-es"]
    assert mod.printed("5.414e-6", 5.41449e-6) and not mod.printed("5.414e-6", 5.4146e-6)


def test_the_suite_page_s_shape_noise_conventions_differ_by_what_it_says():
    # docs/suite.md: a fraction of the mode's RMS "is 2.2 to 2.9 times smaller on the H-frame" than
    # the same fraction of its largest entry: max|phi| / rms(phi) over the measured coordinates of the
    # suite's modes (fe_problem.suite.N_MODES), recomputed from the model
    import numpy as np

    import fe_problem as fp
    from fe_problem.suite import N_MODES

    m = fp.load_model("hframe")
    s = fp.modal_analysis(m, N_MODES).at(m.measured_dofs)
    ratio = np.abs(s).max(axis=0) / np.sqrt((s**2).mean(axis=0))
    page = " ".join((ROOT / "docs" / "suite.md").read_text().split())
    said = re.search(r"a fraction of the mode's RMS, which is ([\d.]+) to ([\d.]+) times smaller on the H-frame", page)
    assert said and said.groups() == (f"{ratio.min():.1f}", f"{ratio.max():.1f}"), ratio
