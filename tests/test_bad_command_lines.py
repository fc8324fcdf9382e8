"""Bad command lines: every one ends in exit code 2 and one error line on stderr that names the
flag, file or name at fault, never a traceback, and writes nothing it was not asked to.

Each case runs `femu.cli.main` in this process (argparse's own usage errors included, one line
naming the argument, without the usage lines argparse prints by default); a
sample also runs the installed `femu` program, to see what a user's terminal shows."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from femu.cli import main

def _study(optimizers: str, *more: str, store: str = "S", seeds: str = "0") -> list[str]:
    """A `femu study` command line with `optimizers`, `seeds`, `store` and the other arguments `more`."""
    return ["study", "--optimizers", optimizers, "--seeds", seeds, "--budget", "10", "--store", store, *more]



#: Plugin modules whose top-level code fails when imported (written into the test directory).
BAD_MODULES = {"raises_on_import.py": "raise RuntimeError('boom')\n",
               "exits_on_import.py": "import sys\nsys.exit(4)\n",
               "bad_syntax.py": "def (:\n"}


# (arguments, a fragment the error line must contain). In the arguments, FILE is a plain
# text file, DIR an empty directory, LATIN a file of latin-1 bytes, LIST a JSON list, EMPTY
# the JSON object {}, DEEP JSON nested 100,000 deep, BIGINT a model whose node x is a
# 400-digit integer, STORE a store with one run, S a fresh store path.
CASES = [
    # femu model
    (["model"], "give a MODEL (a shipped name or a model file) or --frame BAYSxSTOREYS, got neither"),
    (["model", "nosuch"], "no model file 'nosuch'"),
    (["model", "hframe", "--modes", "0"], "--modes: must be at least 1"),
    (["model", "hframe", "--modes", "-3"], "--modes: must be at least 1"),
    (["model", "hframe", "--modes", "abc"], "--modes: expected a whole number"),
    (["model", "FILE"], "FILE: not valid JSON"),
    (["model", "EMPTY"], "EMPTY: missing field 'format'"),
    (["model", "LIST"], "LIST: expected an object"),
    (["model", "DIR"], "DIR: is a directory"),
    (["model", "LATIN"], "LATIN: not UTF-8 text (byte 0xe9 at offset 0)"),
    (["model", "DEEP"], "DEEP: JSON nested too deeply"),
    (["model", "/"], "/: is a directory"),
    # femu study
    (["study", "--optimizers", "nosuch", "--seeds", "0", "--budget", "10", "--store", "S"], "unknown optimizer 'nosuch'"),
    (["study", "--optimizers", "../../etc:passwd", "--seeds", "0", "--budget", "10", "--store", "S"],
     "'../../etc:passwd': not a registry name or an import path"),
    (["study", "--optimizers", "::", "--seeds", "0", "--budget", "10", "--store", "S"], "'::': not a registry name"),
    (["study", "--optimizers", "os:system", "--seeds", "0", "--budget", "10", "--store", "S"],
     "'os:system' is not an optimizer class"),
    (["study", "--optimizers", "nosuchmodule:Cls", "--seeds", "0", "--budget", "10", "--store", "S"],
     "cannot import 'Cls' from module 'nosuchmodule'"),
    (["study", "--optimizers", "adapters.random_search:Nope", "--seeds", "0", "--budget", "10", "--store", "S"],
     "cannot import 'Nope'"),
    (["study", "--optimizers", "", "--seeds", "0", "--budget", "10", "--store", "S"], "--optimizers '': empty name"),
    (["study", "--optimizers", "random-search,random-search", "--seeds", "0", "--budget", "10", "--store", "S"],
     "--optimizers: 'random-search' is given twice"),
    (["study", "--optimizers", "random-search", "--seeds", "-1", "--budget", "10", "--store", "S"], "--seeds '-1'"),
    (["study", "--optimizers", "random-search", "--seeds", "", "--budget", "10", "--store", "S"], "--seeds '': empty"),
    (["study", "--optimizers", "random-search", "--seeds", "0,,1", "--budget", "10", "--store", "S"], "empty seed"),
    (["study", "--optimizers", "random-search", "--seeds", "0-3-4", "--budget", "10", "--store", "S"],
     "'0-3-4' is not a seed or a range"),
    (["study", "--optimizers", "random-search", "--seeds", "5-3", "--budget", "10", "--store", "S"], "runs backwards"),
    (["study", "--optimizers", "random-search", "--seeds", "1,1", "--budget", "10", "--store", "S"], "seed 1 is given twice"),
    (["study", "--optimizers", "random-search", "--seeds", "0-99999999999", "--budget", "10", "--store", "S"],
     "seed 99999999999 is above the largest seed"),
    (["study", "--optimizers", "random-search", "--seeds", "0-100000", "--budget", "10", "--store", "S"],
     "100001 seeds is more than the 100000"),
    (["study", "--optimizers", "random-search", "--seeds", "9" * 400, "--budget", "10", "--store", "S"],
     "is not a seed or a range"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "0", "--store", "S"],
     "--budget: must be an integer >= 1"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "-5", "--store", "S"],
     "--budget: must be an integer >= 1"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "1.5", "--store", "S"],
     "--budget: invalid int value"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "9" * 20, "--store", "S"],
     "--budget: must be at most 1000000000"),
    (["study", "--optimizers", "pymoo-ga", "--seeds", "0", "--budget", "5", "--store", "S"],
     "'pymoo-ga' needs a budget of at least"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", ""], "--store: an empty path"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "FILE"],
     "FILE: a store is a directory, this is a file"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--workers", "-1"],
     "--workers: must be an integer >= 0"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--workers", "x"],
     "--workers: invalid int value"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--time-limit", "-1"],
     "--time-limit: must be a positive number"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--time-limit", "nan"],
     "--time-limit: must be a positive number"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--time-limit", "inf"],
     "--time-limit: must be a positive number"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--variants", "nosuch"],
     "--variants: unknown problem variant 'nosuch'"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--variants",
      "paper,paper"], "--variants: 'paper' is given twice"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--scheduler",
      "notaurl"], "--scheduler 'notaurl': not a scheduler address"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--scheduler",
      "tcp://host"], "--scheduler 'tcp://host': not a scheduler address"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--scheduler",
      "ftp://h:1"], "unknown address scheme 'ftp'"),
    (["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", "S", "--workers", "1",
      "--scheduler", "tcp://h:1"], "--workers and --scheduler exclude each other"),
    (["study", "--seeds", "0", "--budget", "10", "--store", "S"], "required: --optimizers"),
    # femu results / report
    (["results"], "required: store"),
    (["results", "nosuch"], "nosuch: no such store"),
    (["results", "FILE"], "FILE: a store is a directory"),
    (["report", "nosuch", "--out", "R"], "nosuch: no such store"),
    (["report", "STORE"], "required: --out"),
    (["report", "STORE", "--out", "FILE"], "--out: FILE exists and is not a directory"),
    (["report", "DIR", "--out", "R"], "no finished runs to report on"),
    # femu reproduce
    (["reproduce", "--seeds", "0"], "a count of seeds must be >= 1"),
    (["reproduce", "--seeds", "abc"], "--seeds 'abc'"),
    (["reproduce", "--seeds", "99999999999999"], "more than the 100000 seeds"),
    (["reproduce", "--budget", "0"], "--budget: must be an integer >= 1"),
    (["reproduce", "--workers", "-2"], "--workers: must be an integer >= 0"),
    (["reproduce", "--out", "FILE"], "--out: FILE exists and is not a directory"),
    (["reproduce", "--out", ""], "--out: an empty path"),
    # femu diagnose
    (["diagnose", "nosuch.json"], "no data file 'nosuch.json'"),
    (["diagnose", "FILE"], "FILE: not valid JSON"),
    (["diagnose", "EMPTY"], "EMPTY: missing field 'format'"),
    (["diagnose", "DIR"], "DIR: is a directory"),
    (["diagnose", "LATIN"], "LATIN: not UTF-8 text"),
    (["diagnose", "paper", "--model", "nosuch"], "no model file 'nosuch'"),
    (["diagnose", "paper", "--shape-noise", "-1"], "--shape-noise must be a number > 0"),
    (["diagnose", "paper", "--freq-noise", "abc"], "--freq-noise: invalid float value"),
    (["diagnose", "paper", "--out", "FILE"], "exists and is not a directory"),
    # femu identify, femu suite, no command
    (["identify", "nosuch.uff"], "no FRF file 'nosuch.uff'"),
    (["identify", "FILE"], "FILE: no dataset 58"),
    (["identify", "FILE", "--modes", "0"], "--modes: must be at least 1"),
    (["identify", "FILE", "--out", "FILE"], "--out: FILE exists and is not a directory"),
    (["suite", "nosuch"], "suite selection 'nosuch' matches no problem"),
    (["suite", "paper/99"], "suite selection 'paper/99' matches no problem"),
    (["nosuchcommand"], "invalid choice: 'nosuchcommand'"),
    # plugins that cannot even be asked their minimum budget, or whose module cannot be imported
    (_study("sample_plugins:MinBudgetRaises"),
     "optimizer class MinBudgetRaises: asking its min_budget(n_var=12) raised RuntimeError: no budget for you"),
    (_study("sample_plugins:MinBudgetNotANumber"),
     "optimizer class MinBudgetNotANumber: min_budget must be a whole number of evaluations, got 'many'"),
    (_study("sample_plugins:NeedsArguments"), "optimizer class NeedsArguments: asking its min_budget(n_var=12) "
                                                      "raised TypeError"),
    (_study("adapters.protocol:Optimizer"), "asking its min_budget(n_var=12) raised TypeError: Protocols cannot be"),
    (_study("sample_plugins:AN_INSTANCE"), "'sample_plugins:AN_INSTANCE' is not an optimizer class"),
    (_study("adapters.harness:BudgetedObjective"), "'adapters.harness:BudgetedObjective' is not an optimizer class"),
    (_study("raises_on_import:Opt"), "importing module 'raises_on_import' ran its top-level code, which raised "
                                     "RuntimeError: boom"),
    (_study("exits_on_import:Opt"), "importing module 'exits_on_import' ran its top-level code, which raised "
                                    "SystemExit: 4"),
    (_study("bad_syntax:Opt"), "importing module 'bad_syntax' ran its top-level code, which raised SyntaxError"),
    # numbers out of range, malformed seeds
    (_study("random-search", "--workers", "9999"), "--workers: at most"),
    (_study("random-search", "--workers", "9" * 30), "--workers: at most"),
    (["reproduce", "--workers", "1000"], "--workers: at most"),
    (_study("random-search", "--time-limit", "0"), "--time-limit: must be a positive number of seconds, got 0.0"),
    (_study("random-search", "--budget", "1e3"), "--budget: invalid int value: '1e3'"),
    (_study("random-search", seeds="0-"),
     "--seeds '0-': '0-' is not a seed or a range"),
    (_study("random-search", seeds="1_000"),
     "--seeds '1_000': '1_000' is not a seed"),
    (_study("random-search", seeds="0x10"),
     "--seeds '0x10': '0x10' is not a seed"),
    (_study("random-search", seeds="+5"),
     "--seeds '+5': '+5' is not a seed"),
    (_study("random-search", seeds=" "), "empty seed"),
    (["reproduce", "--seeds", " "], "--seeds ' ': empty seed"),
    (_study("random-search,"), "--optimizers 'random-search,': empty name in the list"),
    (_study("random-search", "--variants", ","), "--variants ',': empty name in the list"),
    (["model", "hframe", "--modes", "1e3"], "--modes: expected a whole number, got '1e3'"),
    (["identify", "FILE", "--max-damping", "2"], "--max-damping must lie in (0, 1), got 2.0"),
    (["identify", "FILE", "--max-order", "0"], "--max-order: must be at least 1"),
    # places that cannot be written: a store or an output directory under /proc or a file
    (_study("random-search", store="/proc/femu-store"),
     "--store /proc/femu-store: cannot write in the store (No such file or directory"),
    (_study("random-search", store="FILE/sub"), "cannot write in the store (Not a directory"),
    (["report", "STORE", "--out", "/proc/femu-report"], "--out /proc/femu-report: cannot create the directory"),
    (["report", "STORE", "--out", "FILE/sub"], "cannot create the directory (Not a directory)"),
    (["reproduce", "--out", "/proc/femu-reproduce"], "--out /proc/femu-reproduce: cannot create the directory"),
    (["diagnose", "paper", "--out", ""], "--out: an empty path; name a directory"),
    (["diagnose", "paper", "--out", "/proc/femu-diagnose"], "--out /proc/femu-diagnose: cannot create the directory"),
    (["report", "", "--out", "R"], "--store: an empty path"),
    (["results", "STORE", "extra"], "unrecognized arguments: extra"),
    # argparse's own usage errors: one line naming the command and the argument, no usage lines
    (["model", "hframe", "--nosuch"], "femu model: error: unrecognized arguments: --nosuch"),
    (_study("random-search", "--x0", "maybe"), "femu study: error: argument --x0: invalid choice: 'maybe'"),
    (_study("random-search", "--x0", ""), "argument --x0: invalid choice: ''"),
    ([], "femu: error: the following arguments are required: COMMAND"),
    (["study"], "femu study: error: the following arguments are required: --optimizers, --seeds"),
    (["identify", "FILE", "--band", "1"], "argument --band: expected 2 arguments"),
    # the suite, noise levels, bands and orders out of range
    (_study("random-search", "--suite", "BAD"), "--suite: suite selection 'BAD' matches no problem"),
    (_study("random-search", "--suite", ""), "--suite: empty suite selection"),
    (["suite", ","], "empty suite selection"),
    (["suite", "paper/12/1/2/3"], "suite selection 'paper/12/1/2/3' matches no problem"),
    (["diagnose", "paper", "--freq-noise", "0"], "--freq-noise must be a number > 0"),
    (["diagnose", "paper", "--freq-noise", "nan"], "--freq-noise must be a number > 0"),
    (["diagnose", "paper", "--freq-noise", "1e400"], "--freq-noise must be a number > 0 (a relative standard "
                                                     "deviation, e.g. 0.002), got inf"),
    (["diagnose", "paper", "--freq-noise", "1e-400"], "got 0.0"),
    (["diagnose", "paper", "--shape-noise", "inf"], "--shape-noise must be a number > 0"),
    (["diagnose", "paper", "--freq-noise", "2"], "--freq-noise is a fraction, not a percentage: 2 would be 200 %; "
                                                  "for 2 % give 0.02"),
    (["diagnose", "paper", "--shape-noise", "1"], "--shape-noise is a fraction, not a percentage: 1 would be 100 %"),
    (["identify", "NPZ", "--band", "1", "1e400"], "--band 1.0 inf: two finite frequencies"),
    (["identify", "NPZ", "--band", "nan", "100"], "--band nan 100.0: two finite frequencies"),
    (["identify", "NPZ", "--band", "300", "100"], "the low end below the high end"),
    (["identify", "NPZ", "--max-order", "999999999"], "--max-order: must be a whole number from 1 to 200"),
    (["identify", "NPZ", "--max-damping", "nan"], "--max-damping must lie in (0, 1), got nan"),
    (["reproduce", "--seeds", "1e400"], "'1e400' is not a seed or a range"),
    (["reproduce", "--budget", "9" * 50], "--budget: must be at most 1000000000"),
    (["results", "/dev/null"], "/dev/null: a store is a directory, this is a file"),
    (["model", "/dev/zero"], "/dev/zero: not a regular file"),
    (["diagnose", "/dev/zero"], "/dev/zero: not a regular file"),
    (["identify", "/dev/zero"], "/dev/zero: not a regular file"),
    # a scheduler nobody answers at: refused within the connect timeout, nothing written
    (_study("random-search", "--scheduler", "tcp://127.0.0.1:1"),
     "--scheduler tcp://127.0.0.1:1: cannot connect to a Dask scheduler within 5 s"),
]


@pytest.fixture(scope="module")
def place(tmp_path_factory):
    """A directory with the files the cases name, and a store with one finished run."""
    d = tmp_path_factory.mktemp("bad")
    (d / "file.txt").write_text("not json\n")
    (d / "dir").mkdir()
    (d / "latin.json").write_bytes(b"\xe9t\xe9")
    (d / "list.json").write_text("[1, 2]")
    (d / "empty.json").write_text("{}")
    (d / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    from fe_problem import load_model, synthetic_frf
    from fe_problem.identification.frf_io import write_npz

    write_npz(synthetic_frf(load_model("hframe"), band_hz=(5, 100), resolution_hz=0.5), d / "frf.npz")
    for name, text in BAD_MODULES.items():
        (d / name).write_text(text)
    assert main(["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10",
                 "--store", str(d / "store"), "--no-progress", "--workers", "0"]) == 0
    return d


def _args(args: list[str], d: Path) -> list[str]:
    args = [a.replace("FILE/", str(d / "file.txt") + "/") for a in args]
    names = {"FILE": "file.txt", "DIR": "dir", "LATIN": "latin.json", "LIST": "list.json", "EMPTY": "empty.json",
             "DEEP": "deep.json", "STORE": "store", "S": "new-store", "R": "report", "NPZ": "frf.npz"}
    return [str(d / names[a]) if a in names else a for a in args]


def _expected(fragment: str, d: Path) -> str:
    for token, name in (("FILE", "file.txt"), ("DIR", "dir"), ("LATIN", "latin.json"), ("LIST", "list.json"),
                        ("EMPTY", "empty.json"), ("DEEP", "deep.json")):
        fragment = fragment.replace(token, str(d / name))
    return fragment


@pytest.mark.parametrize("args,says", CASES, ids=[" ".join(a)[:70] for a, _ in CASES])
def test_bad_command_line_is_one_error_line_and_exit_2(place, capsys, monkeypatch, args, says):
    monkeypatch.chdir(place)
    monkeypatch.syspath_prepend(str(place))  # the plugin modules that fail on import
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    before = sorted(p.name for p in place.iterdir())
    try:
        code = main(_args(args, place))
    except SystemExit as exc:  # argparse's own usage errors
        code = exc.code
    out, err = capsys.readouterr()
    assert code == 2, (out, err)
    assert "Traceback" not in err + out
    assert len(err.strip().splitlines()) == 1, err  # argparse's usage errors too: no usage lines before
    last = err.strip()
    assert last.startswith("femu") and "error:" in last and _expected(says, place) in last, last
    assert sorted(p.name for p in place.iterdir()) == before, "a refused command wrote something"


def test_there_are_at_least_60_cases():
    assert len(CASES) >= 60


@pytest.mark.parametrize("args", [["model", "/"], ["study", "--optimizers", "../../etc:passwd", "--seeds", "0",
                                                   "--budget", "10", "--store", "s"],
                                  ["study", "--optimizers", "random-search", "--seeds", "0-99999999999", "--budget",
                                   "10", "--store", "s"]])
def test_the_installed_program_shows_one_line(tmp_path, args):
    p = subprocess.run([sys.executable, "-m", "femu", *args], cwd=tmp_path, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 2 and "Traceback" not in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_model_with_a_400_digit_coordinate_is_refused_in_one_line(tmp_path, capsys):
    from fe_problem import load_model
    from fe_problem.model import model_to_dict

    d = model_to_dict(load_model("hframe"))
    d["nodes"][0]["x"] = int("9" * 400)
    f = tmp_path / "big.model.json"
    f.write_text(json.dumps(d))
    assert main(["model", str(f)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and str(f) in err and "x" in err and "Traceback" not in err


def _read_only(path: Path, on: bool) -> None:
    """Make `path` unwritable (or writable again), for root too: root ignores the mode bits,
    so as root the directory is made immutable (chattr +i)."""
    if os.geteuid() == 0:
        subprocess.run(["chattr", "+i" if on else "-i", str(path)], check=True)
    else:
        path.chmod(0o555 if on else 0o755)


@pytest.mark.parametrize("where", ["runs", "store"])
def test_a_read_only_store_is_one_error_line_naming_it(tmp_path, capsys, where):
    store = tmp_path / "ro"
    argv = ["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", str(store),
            "--workers", "0", "--no-progress"]
    assert main(argv) == 0
    capsys.readouterr()
    target = store / "runs" if where == "runs" else store
    _read_only(target, True)
    try:
        argv[4] = "0-1"  # one more run: its claim (runs) or the study's manifest (store) cannot be written
        assert main(argv) == 2
    finally:
        _read_only(target, False)
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith(f"femu study: error: --store {store}: cannot write in the store ("), err
    assert sorted(p.name for p in (store / "runs").iterdir()) == ["paper__random-search__b10__s0.json"]
