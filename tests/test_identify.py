"""The identification library: the synthetic test rig against modal theory, the FRF file
layouts (UFF 58, .npz, CSV) and their errors, and `fp.identify` on exact and noisy FRFs."""

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.identification import FRFFileError, write_csv, write_npz, write_uff58

ZETA = np.linspace(0.01, 0.02, 40)  # one damping ratio per mode, known exactly


@pytest.fixture(scope="module")
def exact():
    """Noise-free accelerances of the nominal H-frame and their identification."""
    frfs = fp.synthetic_frf("hframe", band_hz=(5, 1400), damping=ZETA, noise=0.0)
    return frfs, fp.identify(frfs)


def test_rig_follows_modal_theory(exact):
    """At each well-separated resonance the driving-point accelerance is about -phi_ref^2 / (2 i zeta)
    (the mode alone), its real part crosses zero and its imaginary part peaks."""
    frfs, _ = exact
    modes = fp.modal_analysis("hframe", 8)
    k_ref = frfs.coordinates.index(frfs.reference)
    phi_ref = modes.at([frfs.reference])[0]
    for r in (0, 1, 4):  # modes well apart from their neighbours
        line = np.argmin(np.abs(frfs.frequency_hz - modes.frequencies_hz[r]))
        single = phi_ref[r] ** 2 / (2 * ZETA[r])
        assert abs(frfs.frf[k_ref, line].imag) == pytest.approx(single, rel=0.05)
    assert frfs.frequency_hz[0] == 5 and frfs.frequency_hz[-1] == 1400
    np.testing.assert_allclose(np.diff(frfs.frequency_hz), 0.25)


def test_rig_noise_is_seeded_and_of_the_stated_size():
    clean = fp.synthetic_frf("hframe", band_hz=(5, 700), noise=0.0)
    a = fp.synthetic_frf("hframe", band_hz=(5, 700), noise=0.02, seed=5)
    b = fp.synthetic_frf("hframe", band_hz=(5, 700), noise=0.02, seed=5)
    c = fp.synthetic_frf("hframe", band_hz=(5, 700), noise=0.02, seed=6)
    assert np.array_equal(a.frf, b.frf) and not np.array_equal(a.frf, c.frf)
    rms = np.sqrt(np.mean(np.abs(clean.frf) ** 2, axis=1))
    ratio = np.sqrt(np.mean(np.abs(a.frf - clean.frf) ** 2, axis=1)) / rms
    np.testing.assert_allclose(ratio, 0.02, rtol=0.1)


def test_exact_frfs_give_exact_modes(exact):
    frfs, ident = exact
    data = ident.data
    truth = fp.modal_analysis("hframe", 8)
    assert data.n_modes == 8 and data.model == "hframe"
    np.testing.assert_allclose(data.frequencies_hz, truth.frequencies_hz, rtol=1e-5)
    np.testing.assert_allclose(data.meta["damping_ratio"], ZETA[:8], rtol=1e-3)
    assert np.all(np.diag(fp.mac(data.shapes, truth.at(data.dofs))) > 0.99999)
    # mass-normalised through the driving point: the scale is the model's, up to sign
    assert data.meta["scaling"].startswith("mass-normalised")
    np.testing.assert_allclose(np.abs(data.shapes), np.abs(truth.at(data.dofs)), atol=2e-3 * np.abs(data.shapes).max())
    assert np.all(np.array(data.meta["mpc"]) > 0.999)
    assert ident.fit.shape == ident.frf.shape


def test_modes_option_keeps_the_lowest(exact):
    frfs, ident = exact
    three = fp.identify(frfs, n_modes=3)
    np.testing.assert_array_equal(three.data.frequencies_hz, ident.data.frequencies_hz[:3])
    assert fp.identify(frfs, band_hz=(5, 300), n_modes=6).warnings  # only 4 modes below 300 Hz: said so


@pytest.mark.parametrize("writer, suffix", [(write_uff58, ".uff"), (write_npz, ".npz"), (write_csv, ".csv")])
def test_layouts_round_trip(tmp_path, writer, suffix):
    frfs = fp.synthetic_frf("hframe", band_hz=(5, 300), resolution_hz=1.0, noise=0.01, seed=2)
    path = writer(frfs, tmp_path / f"frf{suffix}")
    back = fp.read_frf(path)
    assert back.coordinates == frfs.coordinates and back.reference == frfs.reference
    assert (back.form, back.units, back.model) == ("accelerance", "m/s^2/N", "hframe")
    np.testing.assert_allclose(back.frequency_hz, frfs.frequency_hz, rtol=1e-9)
    np.testing.assert_allclose(back.frf, frfs.frf, rtol=1e-8, atol=1e-8 * np.abs(frfs.frf).max())


def test_uff_shaker_and_hammer_layouts_agree(tmp_path):
    frfs = fp.synthetic_frf("hframe", band_hz=(5, 300), resolution_hz=1.0)
    a = fp.read_frf(write_uff58(frfs, tmp_path / "h.uff", test="roving-hammer"))
    b = fp.read_frf(write_uff58(frfs, tmp_path / "s.uff", test="shaker"))
    assert a.coordinates == b.coordinates and np.array_equal(a.frf, b.frf)


def test_layout_errors(tmp_path):
    frfs = fp.synthetic_frf("hframe", band_hz=(5, 300), resolution_hz=1.0)
    np.savez(tmp_path / "bad.npz", frequency_hz=frfs.frequency_hz, frf=frfs.frf)
    with pytest.raises(FRFFileError, match=r"bad.npz: missing array\(s\) \['response_node'"):
        fp.read_frf(tmp_path / "bad.npz")
    text = write_csv(frfs, tmp_path / "x.csv").read_text().replace("# reference: 5 x\n", "")
    (tmp_path / "noref.csv").write_text(text)
    with pytest.raises(FRFFileError, match="noref.csv: missing reference"):
        fp.read_frf(tmp_path / "noref.csv")
    other = fp.synthetic_frf("hframe", band_hz=(5, 300), resolution_hz=1.0, reference=(1, "x"))
    write_npz(other, tmp_path / "other.npz")
    with pytest.raises(FRFFileError, match=r"other.npz: channel 1 \(1 x\): reference \(1, 'x'\) differs"):
        fp.read_frf(tmp_path / "x.csv", tmp_path / "other.npz")
    with pytest.raises(FRFFileError, match="channel 1 .*measured twice"):
        fp.read_frf(tmp_path / "x.csv", tmp_path / "x.csv")
    uneven = fp.FRFSet(frfs.frequency_hz ** 1.01, frfs.frf, frfs.coordinates, frfs.reference, model="hframe")
    with pytest.raises(FRFFileError, match="evenly spaced"):
        fp.read_frf(write_npz(uneven, tmp_path / "uneven.npz"))
    with pytest.raises(FileNotFoundError, match="no FRF file"):
        fp.read_frf(tmp_path / "missing.uff")
