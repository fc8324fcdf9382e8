"""FRF files read as they are meant: units converted to SI or refused, one rule for CSV lines,
npz arrays type-checked and bounded, and identification that does not depend on the FRFs'
scale (fe_problem/identification/frf_io.py, units.py, core.py; docs/identify.md)."""

import json
import math
import zipfile

import numpy as np
import pytest
import pyuff

import fe_problem as fp
from fe_problem.identification.frf_io import FRFFileError, read_frf, write_csv, write_npz, write_uff58
from femu.cli import main

G = 9.80665


@pytest.fixture(scope="module")
def frfs():
    """Noise-free FRFs of the H-frame's first modes: 5-240 Hz holds its lowest three."""
    return fp.synthetic_frf(fp.load_model("hframe"), band_hz=(5, 240), resolution_hz=0.25, damping=0.01,
                            model_name="hframe")


def _relabel(src, dst, x_factor=1.0, data_factor=1.0, **labels):
    """A copy of the UFF 58 file `src` with its abscissa multiplied by x_factor, its data by
    data_factor and the given label fields replaced (pyuff reads and writes it)."""
    sets = pyuff.UFF(str(src)).read_sets()
    sets = sets if isinstance(sets, list) else [sets]
    for ds in sets:
        ds["x"] = np.asarray(ds["x"]) * x_factor
        ds["data"] = np.asarray(ds["data"]) * data_factor
        ds.update(labels)
    pyuff.UFF(str(dst)).write_sets(sets, mode="overwrite")
    return dst


def test_a_uff_abscissa_in_rad_per_s_or_cpm_is_converted_to_hz(frfs, tmp_path):
    hz = write_uff58(frfs, tmp_path / "hz.uff")
    rad = _relabel(hz, tmp_path / "rad.uff", x_factor=2 * math.pi, abscissa_axis_units_lab="rad/s")
    cpm = _relabel(hz, tmp_path / "cpm.uff", x_factor=60.0, abscissa_axis_units_lab="CPM")
    rpm = _relabel(hz, tmp_path / "rpm.uff", x_factor=60.0, abscissa_spec_data_type=19,
                   abscissa_axis_units_lab="NONE")
    ref = read_frf(hz)
    for f in (rad, cpm, rpm):
        got = read_frf(f)
        # UFF 58 stores an even abscissa as start and increment in E13.5: 6 significant digits
        np.testing.assert_allclose(got.frequency_hz, ref.frequency_hz, rtol=5e-6)
        np.testing.assert_array_equal(got.frf, ref.frf)


def test_a_uff_ordinate_in_g_or_mm_over_kn_is_converted_to_si(frfs, tmp_path):
    si = write_uff58(frfs, tmp_path / "si.uff")
    in_g = _relabel(si, tmp_path / "g.uff", data_factor=1 / G, ordinate_axis_units_lab="g/N")
    mm_kn = _relabel(si, tmp_path / "mm.uff", data_factor=1e3 * 1e3, ordinate_axis_units_lab="(mm/s^2)/kN")
    ref = read_frf(si)
    for f in (in_g, mm_kn):
        got = read_frf(f)
        assert got.units == "m/s^2/N"
        np.testing.assert_allclose(got.frf, ref.frf, rtol=1e-10, atol=0)  # UFF 58 writes 12 digits


@pytest.mark.parametrize("labels,says", [
    ({"abscissa_axis_units_lab": "kHz"}, "unknown frequency unit 'kHz'; use one of Hz, rad/s, CPM"),
    ({"abscissa_spec_data_type": 17}, "the abscissa's data type 17 is not a frequency axis"),
    ({"ordinate_axis_units_lab": "furlong/N"}, "unknown FRF unit 'furlong/N' for accelerance"),
    ({"ordinate_axis_units_lab": "m/s/N"}, "a mobility unit on an accelerance FRF"),
])
def test_an_unknown_or_mismatched_unit_is_refused_naming_file_and_channel(frfs, tmp_path, labels, says):
    bad = _relabel(write_uff58(frfs, tmp_path / "a.uff"), tmp_path / "bad.uff", **labels)
    with pytest.raises(FRFFileError) as err:
        read_frf(bad)
    assert str(err.value).startswith(f"{bad}: channel 1 (dataset 58 #1)") and says in str(err.value)


def test_csv_comments_and_blank_lines_anywhere_drop_no_row(frfs, tmp_path):
    plain = write_csv(frfs, tmp_path / "plain.csv")
    lines = plain.read_text().splitlines()
    # a comment and a blank line after the header and between rows, an indented comment, a free note
    noisy = lines[:5] + ["# measured on the rig, take 2", ""] + lines[5:9] + ["   # a note: free text", ""] + lines[9:]
    (tmp_path / "noisy.csv").write_text("\n".join(noisy) + "\n")
    a, b = read_frf(plain), read_frf(tmp_path / "noisy.csv")
    assert b.frequency_hz.size == a.frequency_hz.size == len(lines) - 5
    np.testing.assert_array_equal(b.frf, a.frf)


@pytest.mark.parametrize("edit,says", [
    (lambda L: L[:7] + [L[7] + ",0.5"] + L[8:], "line 8: 32 fields, but the header has 31"),
    (lambda L: ["# refrence: 5 x"] + L, "line 1: unknown key '# refrence:'; did you mean '# reference:'?"),
    (lambda L: L[:2] + ["# units: m/s/N"] + L[2:], "'# units:' is given twice"),
    (lambda L: L[:2] + ["# units: g/N"] + [x for x in L[2:] if not x.startswith("# units")],
     None),  # a valid unit: read, converted (checked below)
])
def test_csv_rows_and_metadata_are_checked(frfs, tmp_path, edit, says):
    lines = write_csv(frfs, tmp_path / "a.csv").read_text().splitlines()
    f = tmp_path / "b.csv"
    f.write_text("\n".join(edit(lines)) + "\n")
    if says is None:
        np.testing.assert_allclose(read_frf(f).frf, G * read_frf(tmp_path / "a.csv").frf, rtol=1e-12)
        return
    with pytest.raises(FRFFileError, match="^" + str(f).replace(".", r"\.")) as err:
        read_frf(f)
    assert says in str(err.value)


def _npz_with(frfs, tmp_path, **changes):
    write_npz(frfs, tmp_path / "a.npz")
    d = dict(np.load(tmp_path / "a.npz"))
    d.update(changes)
    for k in [k for k, v in changes.items() if v is None]:
        del d[k]
    np.savez(tmp_path / "b.npz", **d)
    return tmp_path / "b.npz"


@pytest.mark.parametrize("changes,says", [
    ({"reference_node": np.array(True)}, "array 'reference_node' must be a single value of a whole number"),
    ({"reference_node": np.array(5.0)}, "array 'reference_node' must be a single value of a whole number"),
    ({"response_node": np.arange(1, 16) * 1.0}, "array 'response_node' must be a 1-D array of whole numbers"),
    ({"frequency": np.arange(3.0)}, "unknown key 'frequency'; did you mean 'frequency_hz'?"),
    ({"reference_dir": np.array("q")}, "array 'reference_dir': direction 'q' is not one of"),
    ({"units": np.array("g/N")}, None),
])
def test_npz_arrays_are_type_checked(frfs, tmp_path, changes, says):
    f = _npz_with(frfs, tmp_path, **changes)
    if says is None:
        np.testing.assert_allclose(read_frf(f).frf, G * frfs.frf, rtol=1e-12)
        return
    with pytest.raises(FRFFileError) as err:
        read_frf(f)
    assert str(err.value).startswith(str(f)) and says in str(err.value)


def test_an_npz_that_would_expand_beyond_the_limit_is_refused_before_loading(tmp_path):
    """A forged array header declaring 80 GB: refused from the header, in well under a second."""
    header = {"descr": "<c16", "fortran_order": False, "shape": (100_000, 50_000)}
    f = tmp_path / "bomb.npz"
    with zipfile.ZipFile(f, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        with zf.open("frf.npy", "w") as fh:
            np.lib.format.write_array_header_1_0(fh, header)
            fh.write(b"\0" * 4096)
    with pytest.raises(FRFFileError, match="would take more than .* bytes when decompressed .*'frf.npy'"):
        read_frf(f)


def test_negative_lines_and_an_all_zero_channel_are_refused(frfs, tmp_path):
    neg = _npz_with(frfs, tmp_path, frequency_hz=frfs.frequency_hz - 100.0)
    with pytest.raises(FRFFileError, match="below 0 Hz"):
        read_frf(neg)
    zero = frfs.frf.copy()
    zero[3] = 0
    f = _npz_with(frfs, tmp_path, frf=zero)
    with pytest.raises(FRFFileError, match=r"channel 4 \(4 x\): every value is zero"):
        read_frf(f)


@pytest.mark.parametrize("factor", [2.0 ** -700, 1e-200, 1e200])
def test_identification_does_not_depend_on_the_frfs_scale(frfs, factor):
    from dataclasses import replace

    ref = fp.identify(frfs, n_modes=3)
    got = fp.identify(replace(frfs, frf=frfs.frf * factor), n_modes=3)
    # not bit-identical: a relative change of 1e-12 in the FRFs alone moves the third frequency by
    # 6e-8 (a median over the stable orders of the LSCF), so 1e-6 is the scale of rounding here
    np.testing.assert_allclose(got.data.frequencies_hz, ref.data.frequencies_hz, rtol=1e-6)
    # mass-normalised shapes (the reference is measured) scale with the square root of the FRFs
    # (the same 1e-12 change moves the third mode's shape by 5e-6)
    np.testing.assert_allclose(got.data.shapes / math.sqrt(factor), ref.data.shapes, rtol=1e-4, atol=1e-9)


def test_femu_identify_reads_rad_per_s_as_hz(frfs, tmp_path, capsys):
    hz = write_uff58(frfs, tmp_path / "hz.uff")
    rad = _relabel(hz, tmp_path / "rad.uff", x_factor=2 * math.pi, abscissa_axis_units_lab="rad/s")
    out = []
    for f in (hz, rad):
        assert main(["identify", str(f), "--modes", "3", "--out", str(tmp_path / f.stem), "--json"]) == 0
        out.append(json.loads(capsys.readouterr().out))
    got = [m["frequency_hz"] for m in out[1]["modes"]]
    np.testing.assert_allclose(got, [m["frequency_hz"] for m in out[0]["modes"]], rtol=5e-6)  # E13.5 increment
    np.testing.assert_allclose(got, fp.modal_analysis("hframe", n_modes=3).frequencies_hz, rtol=2e-3)
