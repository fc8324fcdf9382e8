"""Outputs never written through a link, and sizes refused before the work: `femu identify`,
`femu diagnose` and `femu report` with a symbolic link standing in the output directory, the
library's writers, and generated models too large for any solver (fe_problem/safe_files.py,
fe_problem/limits.py; docs/bad-input.md)."""

import tracemalloc

import pytest

import fe_problem as fp
from fe_problem.identification.frf_io import write_csv, write_npz, write_uff58
from fe_problem.safe_files import OutputPathError
from femu.cli import main


def _one_error(capsys, *says):
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert all(s in err for s in says), err


@pytest.fixture
def victim(tmp_path):
    v = tmp_path / "victim.txt"
    v.write_text("precious\n")
    return v


def _out_with_link(tmp_path, victim, name):
    out = tmp_path / "out"
    out.mkdir()
    (out / name).symlink_to(victim)
    return out


def test_femu_identify_refuses_a_link_in_its_output_directory(tmp_path, victim, capsys):
    frfs = fp.synthetic_frf("hframe", band_hz=(5, 240), resolution_hz=0.5, model_name="hframe")
    f = write_npz(frfs, tmp_path / "t.npz")
    for name in ("modal-data.json", "identification.json", "report.md", "stabilisation.png"):
        (tmp_path / name).mkdir()
        out = _out_with_link(tmp_path / name, victim, name)
        assert main(["identify", str(f), "--modes", "2", "--out", str(out)]) == 2
        _one_error(capsys, f"{out / name}: is a symbolic link", "does not write through links")
        assert victim.read_text() == "precious\n"


def test_femu_diagnose_refuses_a_link_in_its_output_directory(tmp_path, victim, capsys):
    out = _out_with_link(tmp_path, victim, "report.md")
    assert main(["diagnose", "paper", "--out", str(out)]) == 2
    _one_error(capsys, f"{out / 'report.md'}: is a symbolic link")
    assert victim.read_text() == "precious\n"


def test_femu_report_refuses_a_link_in_its_output_directory(tmp_path, victim, capsys):
    store = tmp_path / "store"
    assert main(["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10", "--store", str(store),
                 "--no-progress"]) == 0
    capsys.readouterr()
    out = _out_with_link(tmp_path, victim, "summary.json")
    assert main(["report", str(store), "--out", str(out)]) == 2
    _one_error(capsys, f"{out / 'summary.json'}: is a symbolic link")
    assert victim.read_text() == "precious\n"


@pytest.mark.parametrize("write", [
    lambda p: fp.save_model(fp.load_model("hframe"), p),
    lambda p: fp.save_modal_data(fp.load_modal_data("paper"), p),
    lambda p: write_uff58(fp.synthetic_frf("hframe", band_hz=(5, 60), resolution_hz=1.0), p),
    lambda p: write_csv(fp.synthetic_frf("hframe", band_hz=(5, 60), resolution_hz=1.0), p),
], ids=["model", "modal data", "uff58", "csv"])
def test_the_library_writers_refuse_a_link(tmp_path, victim, write):
    link = tmp_path / "file"
    link.symlink_to(victim)
    with pytest.raises(OutputPathError, match="is a symbolic link"):
        write(link)
    assert victim.read_text() == "precious\n"
    write(tmp_path / "plain")  # and an ordinary path is written
    assert (tmp_path / "plain").stat().st_size > 0


@pytest.mark.parametrize("build,says", [
    (lambda hframe: fp.regular_frame(10_000, 10_000), "a frame of 10000 bays and 10000 storeys: 100020001 nodes"),
    (lambda hframe: fp.split_elements(hframe, 100_000), "hframe with every element in 100000 parts"),
])
def test_a_generated_model_too_large_for_any_solver_is_refused_before_it_is_built(build, says):
    hframe = fp.load_model("hframe")
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match="free DOFs: more than the 250000 any solver path takes") as err:
            build(hframe)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert says in str(err.value)
    assert peak < 2**20, f"{peak} bytes allocated before the refusal: the model was (partly) built"


@pytest.mark.parametrize("argv", [["--frame", "10000x10000"], ["hframe", "--split", "100000"]])
def test_femu_model_refuses_a_too_large_model_in_one_line(argv, capsys):
    assert main(["model", *argv]) == 2
    _one_error(capsys, "any solver path takes")
