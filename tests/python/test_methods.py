"""Methods under other light, measured with the real binary on measured reflectances.

tests/bench/method_accuracy.py --spectex bakes each set's 8-bit sRGB codes with spectex and
compares the spectra with the measured reflectances under A, FL2, FL11, D50 and LED-B3
(colour-science's tables, Bradford to D65's white, CIEDE2000). TUNING sets (CES, TCS, VS) are where
priors and sizes were chosen; the ColorCheckers (Ohta, shipped in config/spectral/, and BabelColor)
are held out: nothing was tuned on them.

The default bake (no --method: the LHTSS lattice with its precision budget, spectra as its file
stores them) was chosen against Jakob-Hanika and the basis: on the held-out charts its mean ΔE00
over the five lights is at most 0.8x Jakob-Hanika's, and its worst patch under each light within
1.0 of Jakob-Hanika's (docs/methods.md, "The default"). This test measures both on every run.
"""
import json
import os
import subprocess
import sys
import tempfile

import pytest

SPECTEX = os.environ["SPECTEX_BINARY"]
SOURCE = os.environ["SPECTEX_SOURCE_DIR"]
SCRIPT = os.path.join(SOURCE, "tests", "bench", "method_accuracy.py")
LIGHTS = ["A", "FL2", "FL11", "D50", "LED-B3"]
OHTA = "ColorChecker (Ohta, 24)"
BABEL = "ColorChecker (BabelColor Average, 24)"
TOL = 0.03  # the tolerance the JH-prior lattice is held to against Jakob-Hanika, ΔE00


@pytest.fixture(scope="module")
def results():
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "acc.json")
        r = subprocess.run([sys.executable, SCRIPT, "--spectex", SPECTEX, "--json", out, "--methods",
                            "--objective smooth", "jakob-hanika", "lattice:9", "default"],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        print(r.stdout)
        with open(out) as f:
            return json.load(f)["per_set"]


def test_every_method_baked(results):
    assert set(results) == {"--objective smooth", "jakob-hanika", "lattice:9", "default"}


def test_exact_methods_are_exact_and_jakob_hanika_is_not(results):
    # D65 residual against the decoded 8-bit codes: float output, float32 arithmetic and OCIO's
    # sRGB curve (7.6e-7 from the IEC formula) make ~2e-7; 1e-6 allows for both.
    for name in ("--objective smooth", "lattice:9"):
        for group, row in results[name].items():
            assert row["d65_resid_max"] < 1e-6, (name, group)
            assert 0.0 <= row["range"][0] and row["range"][1] <= 1.0
    assert max(row["d65_resid_max"] for row in results["jakob-hanika"].values()) > 1e-4


def test_lattice_is_as_natural_as_jakob_hanika_on_average(results):
    # Means on both held-out charts: within 0.03 under every light and better on
    # average over the five (measured: Ohta 1.084 against 1.104, BabelColor 1.160 against 1.171).
    for chart in (OHTA, BABEL):
        lat, jh = results["lattice:9"][chart], results["jakob-hanika"][chart]
        for light in LIGHTS:
            assert lat[light]["mean"] <= jh[light]["mean"] + TOL, (chart, light)
        assert lat["avg_mean"] < jh["avg_mean"], chart
        # And far better than the three-spectrum basis, whose ceiling the lattice passes.
        assert lat["avg_mean"] < results["--objective smooth"][chart]["avg_mean"] - 0.2, chart


def default_method():
    with tempfile.TemporaryDirectory() as d:
        png = os.path.join(SOURCE, "examples", "textures", "colour_chart.png")
        exr = os.path.join(d, "o.exr")
        subprocess.run([SPECTEX, "bake", png, "-o", exr, "-q"], check=True)
        info = subprocess.run([SPECTEX, "info", exr], capture_output=True, text=True, check=True).stdout
        return {line.split()[0]: line.split()[-1] for line in info.splitlines()
                if line.strip().startswith("spectex:")}


def test_the_default_is_natural_on_the_held_out_charts(results):
    # The thresholds are the ones the default was chosen by; the figures the run of
    # docs/methods.md measured were 0.77x and 0.71x, and at most 0.4 above Jakob-Hanika's worst.
    header = default_method()
    assert (header["spectex:method"], header["spectex:vertexPrior"], header["spectex:precision"]) == \
        ("lattice", "lhtss", "auto")
    for chart in (OHTA, BABEL):
        d, jh, basis = results["default"][chart], results["jakob-hanika"][chart], results["--objective smooth"][chart]
        assert d["avg_mean"] <= 0.8 * jh["avg_mean"], (chart, d["avg_mean"], jh["avg_mean"])
        for light in LIGHTS:
            assert d[light]["max"] <= jh[light]["max"] + 1.0, (chart, light)
        # And far better than the basis on average (1.41 against 0.85 on Ohta).
        assert d["avg_mean"] < basis["avg_mean"] - 0.4, chart
