"""The time-series reader (fe_problem/identification/timeseries_io.py, shared/formats/time-series.md):
CSV and npz read as written, setups and their references, every bad record refused by
`femu identify --oma` with one line naming the file, the line or column and the problem (exit 2),
and dead, clipped or far noisier channels named."""

import subprocess
import sys

import numpy as np
import pytest

from fe_problem.identification.timeseries_io import (Recording, Setup, TimeSeriesError, channel_quality,
                                                     read_timeseries)
from femu.cli import main
from oma_sim import ambient_response, write_csv

FS = 100.0
LABELS = ("2:x", "3:x", "4:x")


@pytest.fixture(scope="module")
def record():
    acc, f, V = ambient_response(seed=5, duration_s=30.0, fs=FS, noise=0.05)
    return acc


def test_csv_and_npz_read_as_written(tmp_path, record):
    csv = write_csv(tmp_path / "a.csv", record, FS, LABELS)
    rec = read_timeseries(csv)
    (s,) = rec.setups
    assert s.fs == pytest.approx(FS, rel=1e-9) and s.channels == ((2, "x"), (3, "x"), (4, "x"))
    assert s.comments == ("simulated shear building",)
    np.testing.assert_allclose(s.acc, record, rtol=1e-8, atol=1e-12)
    npz = tmp_path / "a.npz"
    np.savez(npz, acc=record, fs=FS, dofs=np.array(LABELS))
    np.testing.assert_array_equal(read_timeseries(npz).setups[0].acc, record)
    g = read_timeseries(npz, units="g").setups[0].acc
    np.testing.assert_allclose(g, record * 9.80665)
    # no time column: the sampling frequency from --fs
    bare = write_csv(tmp_path / "b.csv", record, FS, ["12", "13", "14"], time_column=False)
    s = read_timeseries(bare, fs=FS).setups[0]
    assert s.channels == (12, 13, 14) and s.fs == FS


def test_setups_share_references(tmp_path, record):
    a = write_csv(tmp_path / "a.csv", record, FS, ("2:x", "3:x", "4:x"))
    b = write_csv(tmp_path / "b.csv", record, FS, ("4:x", "3:x", "5:x"))
    rec = read_timeseries(a, b)
    assert rec.references == ((3, "x"), (4, "x"))
    assert rec.channels == ((2, "x"), (3, "x"), (4, "x"), (5, "x"))
    c = write_csv(tmp_path / "c.csv", record, FS, ("6:x", "7:x", "8:x"))
    with pytest.raises(TimeSeriesError, match="no channel label is in every file"):
        read_timeseries(a, c)


def _bad_files(tmp_path, record):
    """(file, extra arguments, words the one-line message must hold) for each rule of the format."""
    good = write_csv(tmp_path / "good.csv", record, FS, LABELS).read_text().splitlines()
    cases = []

    def variant(name, lines, args=(), *words):
        p = tmp_path / name
        p.write_text("\n".join(lines) + "\n")
        cases.append((p, list(args), words))

    nan = list(good)
    nan[10] = nan[10].rsplit(",", 1)[0] + ",nan"
    variant("nan.csv", nan, (), "line 11", "column 4 (4:x)", "NaN")
    short = list(good)
    short[20] = short[20].rsplit(",", 1)[0]
    variant("short.csv", short, (), "line 21", "3 fields", "4 columns", "unequal lengths")
    jump = [good[0], good[1]] + [ln for k, ln in enumerate(good[2:]) if k != 100]  # one sample missing
    variant("jump.csv", jump, (), "line 103", "time_s", "not uniform", "after 0.99 s")
    text = list(good)
    text[5] = text[5].replace(",", ",abc,", 1).rsplit(",", 1)[0]
    variant("text.csv", text, (), "line 6", "'abc'", "not a number")
    variant("label.csv", [good[0], "time_s,2:x,3:q,4:x"] + good[2:], (), "column 2", "'3:q'", "direction")
    variant("nofs.csv", [good[0], ",".join(LABELS)] + [ln.split(",", 1)[1] for ln in good[2:]], (), "no time_s",
            "--fs")
    variant("tiny.csv", good[:300], ("--band", "1", "30"), "298 samples", "fewer samples than the band",
            "100 cycles of 1 Hz")
    npz = tmp_path / "bad.npz"
    np.savez(npz, acc=record, fs=FS, dofs=np.array(LABELS[:2]))
    cases.append((npz, [], ("'acc' has 3 channels", "'dofs' has 2 labels")))
    return cases


def test_bad_records_one_line_exit_2(tmp_path, record, capsys):
    for path, args, words in _bad_files(tmp_path, record):
        code = main(["identify", str(path), "--oma", "--model", "hframe", "--out", str(tmp_path / "o"), *args])
        out, err = capsys.readouterr()
        assert code == 2, (path, out, err)
        lines = err.strip().splitlines()
        assert len(lines) == 1 and str(path) in lines[0], (path, err)
        for w in words:
            assert w in lines[0], (path, w, lines[0])
        assert not (tmp_path / "o" / "modal-data.json").exists()


def test_model_band_and_fs_checked(tmp_path, record, capsys):
    csv = write_csv(tmp_path / "a.csv", record, FS, ("2:x", "99:x", "4:x"))
    good = write_csv(tmp_path / "b.csv", record, FS, LABELS)
    cases = [([csv, "--model", "hframe"], f"{csv}: column 3 (99:x): node 99 is not in model 'hframe'"),
             ([good, "--model", "hframe", "--band", "1", "60"], "above the Nyquist frequency 50 Hz"),
             ([good, "--model", "hframe", "--fs", "200"], f"{good}: column 1 (time_s) gives 100 Hz but --fs is 200 Hz"),
             ([good, "--band", "1", "60"], "above the Nyquist frequency 50 Hz"),  # checked without a model too
             ([tmp_path / "none.csv", "--model", "hframe"], "none.csv")]
    for argv, words in cases:
        code = main(["identify", *map(str, argv), "--oma", "--out", str(tmp_path / "o")])
        out, err = capsys.readouterr()
        assert code == 2 and len(err.strip().splitlines()) == 1 and words in err, (argv, err)


def test_missing_pyoma2_is_one_line(tmp_path, record, capsys, monkeypatch):
    good = write_csv(tmp_path / "b.csv", record, FS, LABELS)
    monkeypatch.setitem(sys.modules, "pyoma2", None)  # import pyoma2 raises ImportError
    code = main(["identify", str(good), "--oma", "--model", "hframe", "--out", str(tmp_path / "o")])
    out, err = capsys.readouterr()
    assert code == 2 and err.strip() == ("femu identify: error: femu identify --oma needs the 'oma' extra: "
                                         "pip install 'femu-bench[oma]'")


def test_bad_record_through_python_m_femu(tmp_path, record):
    """The real command line: `python -m femu identify --oma` on a NaN: one line, exit 2, no traceback."""
    lines = write_csv(tmp_path / "good.csv", record, FS, LABELS).read_text().splitlines()
    lines[7] = lines[7].rsplit(",", 1)[0] + ",NaN"
    bad = tmp_path / "nan.csv"
    bad.write_text("\n".join(lines) + "\n")
    proc = subprocess.run([sys.executable, "-m", "femu", "identify", str(bad), "--oma", "--model", "hframe",
                           "--out", str(tmp_path / "o")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert f"{bad}: line 8: column 4 (4:x)" in proc.stderr and "NaN" in proc.stderr


def test_dead_clipped_and_noisy_channels_named(record):
    rng = np.random.default_rng(0)
    acc = np.column_stack([record, record[:, 1], record[:, 2], record[:, 0]])  # 6 channels
    acc[:, 3] = 0.25  # dead
    acc[:, 4] = np.clip(acc[:, 4], -0.6 * np.abs(acc[:, 4]).max(), 0.6 * np.abs(acc[:, 4]).max())  # clipped
    acc[:, 5] = acc[:, 5] + 1.5 * acc[:, 5].std() * rng.standard_normal(acc.shape[0])  # far noisier
    labels = ((2, "x"), (3, "x"), (4, "x"), (5, "x"), (6, "x"), (7, "x"))
    s = Setup(acc, FS, labels, "test.csv", (), tuple(range(2, 8)))
    found = {(k, kind) for k, kind, _ in channel_quality(s)}
    assert found == {(3, "dead"), (4, "clipped"), (5, "noisy")}
    msgs = [m for _, _, m in channel_quality(s)]
    assert any("test.csv: column 5 (5:x) looks dead" in m for m in msgs)
    assert any("column 6 (6:x) looks clipped" in m for m in msgs)
    assert any("column 7 (7:x) looks far noisier" in m for m in msgs)
    # clean channels raise nothing
    assert channel_quality(Setup(record, FS, labels[:3], "clean.csv")) == []
