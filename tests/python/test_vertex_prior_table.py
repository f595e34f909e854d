"""The shipped `measured` vertex prior is what its script makes.

config/spectral/vertex_prior_measured.csv is data learned from measured reflectances; its comment
lines name the sets, the screen against the ColorCheckers, the fit and the cross-validated figures
that chose it. Running config/spectral/make_vertex_prior.py again (colour-science 0.4.7's data, the
same screen and leave-one-set-out choice) must write the same table: the same comment lines (the
choice and its figures, to their printed 3 decimals) and header, and the same numbers to 1e-7 (a
different BLAS may sum in another order: the table's 9 significant digits move by far less than
that on a z of at most a few units).
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

SOURCE = os.environ["SPECTEX_SOURCE_DIR"]
SCRIPT = os.path.join(SOURCE, "config", "spectral", "make_vertex_prior.py")
SHIPPED = os.path.join(SOURCE, "config", "spectral", "vertex_prior_measured.csv")


def split(path):
    with open(path) as f:
        lines = f.read().splitlines()
    text = [line for line in lines if line.startswith("#") or line.startswith("wavelength")]
    rows = np.array([[float(x) for x in line.split(",")] for line in lines if line not in text])
    return text, rows


def test_the_script_makes_the_shipped_table_again():
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "prior.csv")
        # One BLAS thread: the script's matrices are small, and the suite runs two tests at once on
        # two cores (with a thread a core it took 45 s of CPU for 28 s, against 28 s with one).
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        r = subprocess.run([sys.executable, SCRIPT, "-o", out], capture_output=True, text=True, env=env)
        assert r.returncode == 0, r.stderr
        made_text, made = split(out)
        assert sorted(os.listdir(d)) == ["prior.csv"]  # written atomically: no temporary left
    shipped_text, shipped = split(SHIPPED)
    assert made_text == shipped_text
    assert made.shape == shipped.shape
    assert np.abs(made - shipped).max() < 1e-7, np.abs(made - shipped).max()
