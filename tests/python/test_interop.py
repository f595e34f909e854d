"""Interoperability: spectex's output read by independent readers.

- colour-science's reader for the Fichet 2021 layout (colour.io.read_spectral_image_Fichet2021),
  integrated back to sRGB with colour-science's own CIE tables and matrices;
- OpenImageIO's Python bindings (PyPI wheel) and the iinfo tool (Debian's OpenImageIO).
"""
import os
import subprocess
import tempfile
import warnings

import numpy as np
import pytest

warnings.filterwarnings("ignore")
import colour  # noqa: E402
import OpenImageIO as oiio  # noqa: E402

SPECTEX = os.environ["SPECTEX_BINARY"]
SOURCE = os.environ["SPECTEX_SOURCE_DIR"]
IINFO = os.environ.get("SPECTEX_IINFO", "iinfo")
CHART = os.path.join(SOURCE, "examples", "textures", "colour_chart.png")
LEAF = os.path.join(SOURCE, "examples", "textures", "leaf_rgba.png")


def bake(src, dst, *args):
    r = subprocess.run([SPECTEX, "bake", src, "-o", dst, *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return dst


@pytest.fixture(scope="module")
def tmp():
    with tempfile.TemporaryDirectory() as d:
        yield d


def to_linear_srgb(wavelengths, cube):
    """Integrate spectra (H, W, N) under D65 with CIE 1931 2° on the file's bins (colour-science's
    tables), with the sRGB matrix built from the white of D65 on those same bins."""
    shape = colour.SpectralShape(wavelengths[0], wavelengths[-1], wavelengths[1] - wavelengths[0])
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    w = cmfs.values * d65.values[:, None]
    w /= w[:, 1].sum()
    white = w.sum(axis=0)
    xyz = cube @ w
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    m = colour.RGB_Colourspace(
        "sRGB (white from D65 on the bins)", srgb.primaries, colour.XYZ_to_xy(white)
    ).matrix_XYZ_to_RGB
    return xyz @ m.T


def test_colour_science_reads_the_layout_and_integrates_back(tmp):
    out = bake(CHART, os.path.join(tmp, "chart.exr"))
    components, spec = colour.io.read_spectral_image_Fichet2021(out, additional_data=True)
    assert set(components) == {"T"}
    assert not spec.is_emissive
    wavelengths, cube = components["T"]
    np.testing.assert_allclose(wavelengths, np.arange(400, 701, 10))  # the default's grid
    assert cube.shape == (256, 512, 31)

    src = oiio.ImageBuf(CHART).get_pixels(oiio.FLOAT)[..., :3]
    # The IEC 61966-2-1 decoding, by colour-science.
    expected = colour.models.eotf_sRGB(src)
    rgb = to_linear_srgb(wavelengths, cube.astype(np.float64))
    # Half output: each bin rounded to 2^-11 relative; the published basis is exact to 3.5e-8 under
    # a white-consistent matrix. The C++ round-trip test bounds this per pixel; 1e-3 is its worst case.
    assert np.abs(rgb - expected).max() < 1e-3


def test_alpha_and_preview_through_oiio(tmp):
    out = bake(LEAF, os.path.join(tmp, "leaf.exr"), "--preview")
    buf = oiio.ImageBuf(out)
    spec = buf.spec()
    names = list(spec.channelnames)
    assert "A" in names and {"R", "G", "B"} <= set(names)
    assert sum(n.startswith("T.") and n.endswith("nm") for n in names) == 31  # 400:700:10
    assert spec.get_string_attribute("spectralLayoutVersion") == "1.0"
    # The default: the LHTSS lattice with its precision budget, as OIIO reads the header.
    assert spec.get_string_attribute("spectex:method") == "lattice"
    assert spec.get_string_attribute("spectex:vertexPrior") == "lhtss"
    assert spec.get_string_attribute("spectex:precision") == "auto"
    alpha = buf.get_pixels(oiio.FLOAT)[..., names.index("A")]
    src_alpha = oiio.ImageBuf(LEAF).get_pixels(oiio.UINT8)[..., 3]
    # A is the source alpha, exact to its 8-bit code.
    assert np.array_equal(np.rint(alpha * 255).astype(np.uint8), src_alpha)


def test_iinfo_reads_it(tmp):
    out = bake(CHART, os.path.join(tmp, "chart2.exr"))
    r = subprocess.run([IINFO, "-v", out], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "31 channel" in r.stdout  # the default's 400:700:10
    assert "T.550nm" in r.stdout
    assert 'spectralLayoutVersion: "1.0"' in r.stdout


@pytest.mark.parametrize("bit_depth", ["float16", "float32"])
def test_verify_reads_colour_science_files(tmp, bit_depth):
    """spectex verify on files written by another tool: colour-science's writer for the layout,
    spectra made with NumPy from the published basis (mallett2019, colour-science's own table) and
    colour-science's sRGB decoding; verify must integrate them back to the source codes."""
    src = oiio.ImageBuf(CHART).get_pixels(oiio.FLOAT)[..., :3]
    lin = colour.models.eotf_sRGB(src)
    basis = colour.recovery.MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019
    wl = basis.wavelengths
    cube = np.einsum("hwc,nc->hwn", lin, basis.values)
    out = os.path.join(tmp, f"colour_{bit_depth}.exr")
    assert colour.io.write_spectral_image_Fichet2021({"T": (wl, cube)}, out, bit_depth)
    r = subprocess.run([SPECTEX, "verify", out, "--source", CHART, "--json", "-"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    import json

    v = json.loads(r.stdout)
    assert v["bins"] == len(wl) == 81
    assert v["sample_type"] == ("half" if bit_depth == "float16" else "float")
    assert v["nonfinite"]["count"] == 0
    s = v["source"]
    assert s["compared_pixels"] == src.shape[0] * src.shape[1]
    # The published basis is exact under D65 to its 8 printed digits (3.5e-8 in colour-science's
    # cross-check), float32 storage adds ~1e-7: the error is far below an 8-bit step near black
    # (1.5e-4 linear), and every pixel re-encodes to its code. Half storage rounds each of 81 bins
    # to 2^-11 relative with plain rounding (colour-science's writer): up to ~4e-4 in the integral,
    # still below a visible difference (ΔE00 0.05) though not always the same code.
    if bit_depth == "float32":
        assert s["rgb_error"]["max"] < 2e-6
        assert s["code_match"]["share"] == 1.0
    else:
        assert s["rgb_error"]["max"] < 5e-4
        assert s["code_match"]["share"] > 0.99
    assert s["ciede2000"]["max"] < 0.05
    # And the gate: a threshold far below the half error fails with exit 1.
    g = subprocess.run([SPECTEX, "verify", out, "--source", CHART, "--max-rgb-error", "1e-9"],
                       capture_output=True, text=True)
    assert g.returncode == 1
