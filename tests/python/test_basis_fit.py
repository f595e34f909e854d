"""`spectex basis` (Mallett & Yuksel 2019 spectral primary decomposition) checked against an
independent problem builder and independent solvers.

- the colour problem (W, M_RGB->XYZ, white = W.1) is rebuilt here in numpy from the shipped CSV
  tables, with its own linear interpolation, bin weights and matrix;
- feasibility is decided independently by an LP (scipy.optimize.linprog, HiGHS): minimise the
  L1 norm of the 9 colour residuals (slack variables) subject to 0 <= S <= 1 and the N
  sum-to-one rows; feasible iff the optimum is below 1e-9;
- the infeasible least-squares fallback is compared with an SLSQP solve of the same QP;
- the default basis is compared with colour-science's own Mallett 2019 implementation.

Run with `-s` to see the per-case summary lines (verdict, fit time, worst residual).
"""
import os
import re
import subprocess
import tempfile
import time
import warnings

import numpy as np
import pytest
from scipy.optimize import linprog, minimize

SPECTEX = os.environ["SPECTEX_BINARY"]
SOURCE = os.environ["SPECTEX_SOURCE_DIR"]
SPECTRAL = os.path.join(SOURCE, "config", "spectral")

PRIMARIES = {
    "srgb": [(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)],
    "rec709": [(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)],
    "p3": [(0.680, 0.320), (0.265, 0.690), (0.150, 0.060)],
    "rec2020": [(0.708, 0.292), (0.170, 0.797), (0.131, 0.046)],
}


# --------------------------------------------------------------------------------------------
# independent problem builder
# --------------------------------------------------------------------------------------------
def _read_table(path):
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            if line[0].isalpha():  # header
                continue
            rows.append([float(v) for v in line.split(",")])
    return np.array(rows)


_TABLES = {}


def table(name):
    if name not in _TABLES:
        _TABLES[name] = _read_table(os.path.join(SPECTRAL, name + ".csv"))
    return _TABLES[name]


def lerp(xs, ys, x):
    """Own piecewise-linear interpolation (no np.interp): bracket by searchsorted, then
    y0 + t (y1 - y0); exact at the knots."""
    x = np.asarray(x, dtype=float)
    assert np.all(x >= xs[0]) and np.all(x <= xs[-1]), "grid outside the table"
    i = np.clip(np.searchsorted(xs, x, side="right") - 1, 0, len(xs) - 2)
    x0, x1 = xs[i], xs[i + 1]
    t = (x - x0) / (x1 - x0)
    y0, y1 = ys[i], ys[i + 1]
    return y0 + t[..., None] * (y1 - y0) if ys.ndim == 2 else y0 + t * (y1 - y0)


def uniform_grid(spec):
    start, end, step = (float(v) for v in spec.split(":"))
    n = int(np.floor((end - start) / step + 1e-9)) + 1
    return start + step * np.arange(n)


def trapezoid_weights(lam):
    lam = np.asarray(lam, dtype=float)
    w = np.empty_like(lam)
    w[0] = (lam[1] - lam[0]) / 2
    w[-1] = (lam[-1] - lam[-2]) / 2
    w[1:-1] = (lam[2:] - lam[:-2]) / 2
    return w


def build_problem(lam, observer="cie1931-2", primaries="srgb", weights=None):
    """Returns A (3 x N) = M^-1 W, W (3 x N) and the white W.1."""
    lam = np.asarray(lam, dtype=float)
    obs = table("observer_" + observer)
    ill = table("illuminant_D65")
    cmf = lerp(obs[:, 0], obs[:, 1:4], lam)  # N x 3
    e = lerp(ill[:, 0], ill[:, 1], lam)  # N
    w = np.ones_like(lam) if weights is None else np.asarray(weights, dtype=float)
    W = (cmf * (e * w)[:, None]).T  # 3 x N
    W = W / W[1].sum()
    white = W.sum(axis=1)
    # RGB -> XYZ from xy chromaticities, scaled so that RGB (1,1,1) maps to the white W.1
    P = np.array([[x / y, 1.0, (1 - x - y) / y] for x, y in PRIMARIES[primaries]]).T
    scale = np.linalg.solve(P, white)
    M = P * scale[None, :]
    A = np.linalg.solve(M, W)
    return A, W, white


def colour_residuals(A, S):
    """S: N x 3 (columns r,g,b). Returns 3x3 matrix A S - I (column k = RGB(S_k) - e_k)."""
    return A @ S - np.eye(3)


def slack_lp_l1(A):
    """min sum |A S_k - e_k| over 0<=S<=1, sum_k S_k = 1 (per wavelength). HiGHS."""
    # scale the colour rows so their largest entry is 1: HiGHS' feasibility tolerances (1e-7)
    # are absolute, and on fine grids the entries of M^-1 W are ~1/N (0.5 nm: a 2.4e-8 L1
    # "optimum" unscaled, which is solver tolerance, not infeasibility)
    s = 1.0 / np.max(np.abs(A))
    A = A * s
    N = A.shape[1]
    nS = 3 * N
    nv = nS + 18  # S_r, S_g, S_b, then 9 (r+) and 9 (r-)
    Aeq = np.zeros((9 + N, nv))
    beq = np.zeros(9 + N)
    for k in range(3):
        for c in range(3):
            row = 3 * k + c
            Aeq[row, k * N:(k + 1) * N] = A[c]
            Aeq[row, nS + row] = 1.0
            Aeq[row, nS + 9 + row] = -1.0
            beq[row] = s if c == k else 0.0
    for i in range(N):
        Aeq[9 + i, [i, N + i, 2 * N + i]] = 1.0
        beq[9 + i] = 1.0
    cost = np.zeros(nv)
    cost[nS:] = 1.0
    bounds = [(0, 1)] * nS + [(0, None)] * 18
    res = linprog(cost, A_eq=Aeq, b_eq=beq, bounds=bounds, method="highs")
    assert res.status == 0, res.message  # the slack LP is always feasible and bounded
    return res.fun / s


def independent_feasible(A):
    # 1e-9: HiGHS' primal/dual tolerances are ~1e-7 on scaled data; a truly feasible problem gives
    # an L1 optimum at rounding level, an infeasible one at least ~1e-3 in all cases here
    l1 = slack_lp_l1(A)
    return l1 < 1e-9, l1


# --------------------------------------------------------------------------------------------
# CLI helpers
# --------------------------------------------------------------------------------------------
def run_basis(out, *args):
    t0 = time.perf_counter()
    r = subprocess.run([SPECTEX, "basis", "-o", out, *args], capture_output=True, text=True)
    return r, time.perf_counter() - t0


def read_basis(path):
    comments, rows, header = [], [], None
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            if line.startswith("#"):
                comments.append(line)
            elif header is None:
                header = line
            elif line:
                rows.append([float(v) for v in line.split(",")])
    assert header == "wavelength,r,g,b"
    assert not comments, "the CSV holds the table alone; its provenance is in FILE.provenance"
    # The provenance and certificate, one "key: value" line each.
    with open(path + ".provenance") as f:
        comments = [line.rstrip("\n") for line in f]
    data = np.array(rows)
    return data[:, 0], data[:, 1:4], comments


def data_lines(path):
    with open(path) as f:
        return [l for l in f.read().splitlines() if not l.startswith("#")]


def solver_time(stdout):
    m = re.search(r"solver:\s*(.*)", stdout)
    return m.group(1).strip() if m else "?"


def report(name, msg):
    print(f"\n[basis-case] {name}: {msg}")


@pytest.fixture(scope="module")
def tmp():
    with tempfile.TemporaryDirectory() as d:
        yield d


def check_feasible_basis(A, lam_expected, path, name, stdout, elapsed):
    lam, S, comments = read_basis(path)
    assert len(lam) == len(lam_expected)
    # 1e-9 nm: the file prints 17 significant digits; grids computed as start + k*step or by
    # accumulation differ by rounding only
    assert np.max(np.abs(lam - lam_expected)) <= 1e-9
    assert not np.isnan(S).any()
    R = colour_residuals(A, S)
    worst = np.max(np.abs(R))
    # 1e-12: an exact basis reproduces e_k up to double rounding (~1e-15 times the size of
    # the entries of M^-1 W summed over N bins); the two builders differ only by rounding
    assert worst <= 1e-12, f"{name}: max colour residual {worst:.3e}"
    # 1e-15: bounds are enforced exactly by clipping/projection; only ulp-level slack allowed
    assert S.min() >= -1e-15 and S.max() <= 1 + 1e-15, (S.min(), S.max())
    # 1e-14: sum of three doubles near 1 rounds at ~2.2e-16 each; a few ulps allowed
    sum_err = np.max(np.abs(S.sum(axis=1) - 1))
    assert sum_err <= 1e-14, sum_err
    assert any("feasible:                yes" in c for c in comments)
    report(name, f"feasible (CLI exit 0), solver: {solver_time(stdout)}, wall {elapsed:.3f} s, "
                 f"worst colour residual {worst:.2e}, sum err {sum_err:.1e}, "
                 f"bounds [{S.min():.1e}, {S.max():.17g}]")
    return S, worst


# --------------------------------------------------------------------------------------------
# 2. parametrised cases
# --------------------------------------------------------------------------------------------
CASES = [
    # (id, grid spec, observer, primaries)
    ("step1", "380:780:1", "cie1931-2", "srgb"),
    ("step2.5", "380:780:2.5", "cie1931-2", "srgb"),
    ("step5", "380:780:5", "cie1931-2", "srgb"),
    ("step10", "380:780:10", "cie1931-2", "srgb"),
    ("step20", "380:780:20", "cie1931-2", "srgb"),
    ("step40", "380:780:40", "cie1931-2", "srgb"),
    ("range360-830", "360:830:5", "cie1931-2", "srgb"),
    ("range400-700", "400:700:5", "cie1931-2", "srgb"),
    ("range420-680", "420:680:5", "cie1931-2", "srgb"),
    ("step3.7", "380:779.6:3.7", "cie1931-2", "srgb"),  # END on the grid: the CLI refuses 380:780:3.7
    ("cie1964-5", "380:780:5", "cie1964-10", "srgb"),
    ("cie1964-10nm", "380:780:10", "cie1964-10", "srgb"),
    ("rec2020", "380:780:5", "cie1931-2", "rec2020"),
    ("p3", "380:780:5", "cie1931-2", "p3"),
    ("narrow450-650", "450:650:5", "cie1931-2", "srgb"),
    ("narrow480-650", "480:650:5", "cie1931-2", "srgb"),
    ("narrow450-600", "450:600:5", "cie1931-2", "srgb"),
]


@pytest.mark.parametrize("name,spec,observer,primaries", CASES, ids=[c[0] for c in CASES])
def test_case_verdict_and_residuals(tmp, name, spec, observer, primaries):
    lam = uniform_grid(spec)
    A, _, _ = build_problem(lam, observer, primaries)
    feasible, l1 = independent_feasible(A)
    out = os.path.join(tmp, f"{name}.csv")
    r, elapsed = run_basis(out, "--wavelengths", spec, "--observer", observer,
                           "--primaries", primaries)
    assert "nan" not in (r.stdout + r.stderr).lower()
    if feasible:
        assert r.returncode == 0, f"independent LP says feasible (L1 {l1:.2e}); CLI: {r.stderr}"
        check_feasible_basis(A, lam, out, name, r.stdout, elapsed)
    else:
        assert r.returncode == 1, f"independent LP says infeasible (L1 {l1:.3e}); CLI rc {r.returncode}"
        assert "infeasible" in r.stderr + r.stdout
        report(name, f"infeasible (CLI exit 1; independent L1 optimum {l1:.3e}); "
                     f"CLI: {r.stderr.strip()}")


def test_fewer_than_three_bins(tmp):
    out = os.path.join(tmp, "two.csv")
    r, _ = run_basis(out, "--wavelengths", "500:505:5")
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert "at least 3" in r.stderr + r.stdout
    report("500:505:5", f"exit 1: {r.stderr.strip()}")


def _run_file_case(tmp, name, lam):
    path = os.path.join(tmp, f"{name}.txt")
    with open(path, "w") as f:
        f.write("\n".join(repr(float(v)) for v in lam) + "\n")
    A, _, _ = build_problem(lam, weights=trapezoid_weights(lam))
    feasible, l1 = independent_feasible(A)
    out = os.path.join(tmp, f"{name}.csv")
    r, elapsed = run_basis(out, "--wavelengths-file", path)
    assert "nan" not in (r.stdout + r.stderr).lower()
    assert feasible, f"independent LP: infeasible (L1 {l1:.3e})"
    assert r.returncode == 0, r.stderr
    return check_feasible_basis(A, lam, out, name, r.stdout, elapsed), r


def test_nonuniform_grid_file(tmp):
    # 380, 383, 390, 393, ..., 773, 780: steps alternate 3 and 7 nm
    lam = np.sort(np.concatenate([np.arange(380.0, 781.0, 10.0), np.arange(383.0, 780.0, 10.0)]))
    assert np.all(np.diff(lam) > 0) and len(set(np.round(np.diff(lam), 9))) == 2
    _run_file_case(tmp, "nonuniform-3-7", lam)


def test_near_duplicate_wavelengths(tmp):
    lam = np.unique(np.concatenate([np.arange(380.0, 781.0, 5.0), [500.000001]]))
    (S, worst), r = _run_file_case(tmp, "near-duplicate", lam)
    # the certificate's own residuals must be finite and small too
    m = re.search(r"colour residual r,g,b:\s*([^ ]+), ([^ ]+), ([^ ]+)", r.stdout)
    assert m, r.stdout
    cert = [float(v) for v in m.groups()]
    # 1e-12: same bound as the independent residual check
    assert all(np.isfinite(cert)) and max(cert) <= 1e-12, cert


def test_very_fine_grid(tmp):
    spec = "360:830:0.5"
    lam = uniform_grid(spec)
    A, _, _ = build_problem(lam)
    feasible, l1 = independent_feasible(A)
    assert feasible, l1
    out = os.path.join(tmp, "fine.csv")
    r, elapsed = run_basis(out, "--wavelengths", spec)
    assert r.returncode == 0, r.stderr
    # 10 s: the brief's budget for a 941-bin fit (the QP is small and sparse)
    assert elapsed < 10.0, elapsed
    check_feasible_basis(A, lam, out, "fine-0.5", r.stdout, elapsed)


# --------------------------------------------------------------------------------------------
# 3. --allow-infeasible
# --------------------------------------------------------------------------------------------
def slsqp_least_squares(A):
    N = A.shape[1]
    E = np.eye(3)

    def f(x):
        S = x.reshape(3, N).T
        R = A @ S - E
        return float(np.sum(R * R))

    def grad(x):
        S = x.reshape(3, N).T
        R = A @ S - E  # 3x3, column k
        return (2 * A.T @ R).T.reshape(-1)

    Csum = np.tile(np.eye(N), (1, 3))
    cons = [{"type": "eq", "fun": lambda x: Csum @ x - 1, "jac": lambda x: Csum}]
    x0 = np.full(3 * N, 1 / 3)
    res = minimize(f, x0, jac=grad, method="SLSQP", bounds=[(0, 1)] * (3 * N),
                   constraints=cons, options={"ftol": 1e-15, "maxiter": 2000})
    return np.sqrt(res.fun), res


def test_allow_infeasible_rec2020(tmp):
    spec = "380:780:10"
    lam = uniform_grid(spec)
    A, _, _ = build_problem(lam, primaries="rec2020")
    feasible, l1 = independent_feasible(A)
    assert not feasible
    out = os.path.join(tmp, "rec2020-ls.csv")
    r, elapsed = run_basis(out, "--wavelengths", spec, "--primaries", "rec2020",
                           "--allow-infeasible")
    assert r.returncode == 0, r.stderr
    lam_f, S, comments = read_basis(out)
    assert not np.isnan(S).any()
    # exact [0, 1] and sum-to-one: the fallback still satisfies the hard constraints
    assert S.min() >= 0 and S.max() <= 1
    assert np.max(np.abs(S.sum(axis=1) - 1)) <= 1e-14  # few ulps, as above
    assert any("feasible:" in c and "NO" in c for c in comments)
    cpp_norm = np.linalg.norm(colour_residuals(A, S))
    sl_norm, res = slsqp_least_squares(A)
    # SLSQP's own answer must be admissible for the comparison to mean anything
    Ssl = res.x.reshape(3, len(lam)).T
    assert np.max(np.abs(Ssl.sum(axis=1) - 1)) < 1e-8
    # (1 + 1e-3) + 1e-9: SLSQP stops at a loose tolerance, so its value is an upper bound on the
    # optimum only up to ~1e-3 relative; the C++ QP must be at least as good
    assert cpp_norm <= sl_norm * (1 + 1e-3) + 1e-9, (cpp_norm, sl_norm)
    # lower bound: ||r||_2 >= ||r||_1 / 3 for 9 entries, and the L1 optimum bounds ||r||_1 from
    # below (1e-9 absorbs HiGHS' tolerance)
    assert cpp_norm >= l1 / 3 - 1e-9
    report("rec2020 --allow-infeasible 380:780:10",
           f"exit 0, solver: {solver_time(r.stdout)}, C++ ||r||_2 = {cpp_norm:.9g}, "
           f"SLSQP {sl_norm:.9g} (rel diff {(cpp_norm - sl_norm) / sl_norm:.2e}), "
           f"L1 optimum {l1:.6g}")


# --------------------------------------------------------------------------------------------
# 4. determinism, 5. shipped file
# --------------------------------------------------------------------------------------------
def test_determinism(tmp):
    a, b = os.path.join(tmp, "det_a.csv"), os.path.join(tmp, "det_b.csv")
    for p in (a, b):
        r, _ = run_basis(p, "-q")
        assert r.returncode == 0, r.stderr
    assert data_lines(a) == data_lines(b)  # byte-identical: no tolerance


def test_shipped_basis_matches_fresh_fit(tmp):
    shipped = os.path.join(SPECTRAL, "basis_fit_smooth_380-780-5.csv")
    fresh = os.path.join(tmp, "fresh.csv")
    r, _ = run_basis(fresh, "-q")
    assert r.returncode == 0, r.stderr
    assert data_lines(shipped) == data_lines(fresh)

    def checksum(p):  # the provenance sidecar
        with open(p + ".provenance") as f:
            return [l for l in f.read().splitlines() if l.startswith("checksum:")]

    assert checksum(shipped) == checksum(fresh) and len(checksum(fresh)) == 1


def test_basis_csv_loads_in_generic_readers(tmp):
    # The header row first, nothing else: Python's csv module, numpy.genfromtxt(names=True) and
    # colour-science's read_sds_from_csv_file load it without options.
    import csv
    import colour

    out = os.path.join(tmp, "plain.csv")
    r, _ = run_basis(out, "-q")
    assert r.returncode == 0, r.stderr
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 81 and float(rows[0]["wavelength"]) == 380
    arr = np.genfromtxt(out, delimiter=",", names=True)
    assert arr.dtype.names == ("wavelength", "r", "g", "b") and len(arr) == 81
    sds = colour.read_sds_from_csv_file(out)
    assert sorted(sds) == ["b", "g", "r"]
    total = sds["r"].values + sds["g"].values + sds["b"].values
    assert np.allclose(total, 1, atol=1e-12)
    for name in ("r", "g", "b"):
        assert np.array_equal(sds[name].values, arr[name])


# --------------------------------------------------------------------------------------------
# 6. colour-science cross-check
# --------------------------------------------------------------------------------------------
def test_slow_colour_science_crosscheck(tmp):
    warnings.filterwarnings("ignore")
    import colour
    from colour.recovery import spectral_primary_decomposition_Mallett2019

    spec = "380:780:10"
    lam = uniform_grid(spec)
    A, _, white = build_problem(lam)
    out = os.path.join(tmp, "norm.csv")
    r, _ = run_basis(out, "--wavelengths", spec, "--objective", "norm")
    assert r.returncode == 0, r.stderr
    _, S, _ = read_basis(out)

    shape = colour.SpectralShape(380, 780, 10)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    ill = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    wxy = white[:2] / white.sum()
    cs = colour.RGB_Colourspace("sRGB primaries, W.1 white", np.array(PRIMARIES["srgb"]), wxy,
                                use_derived_matrix_RGB_to_XYZ=True,
                                use_derived_matrix_XYZ_to_RGB=True)
    msds = spectral_primary_decomposition_Mallett2019(cs, cmfs, ill)
    ref = msds.values
    assert np.allclose(msds.wavelengths, lam)
    diff = np.max(np.abs(S - ref))
    # colour's problem: rows must agree with the independent builder (same tables, same white)
    A_col = np.dot(cs.matrix_XYZ_to_RGB,
                   (ill.values[:, None] * cmfs.values / np.sum(cmfs.values[:, 1] * ill.values)).T)
    assert np.max(np.abs(A_col - A)) < 1e-12  # rounding only
    report("colour-science cross-check 380:780:10 norm",
           f"max |spectex - colour SLSQP| = {diff:.3e}; colour SLSQP colour residual "
           f"{np.max(np.abs(colour_residuals(A, ref))):.2e}")
    # 1e-3: colour runs SLSQP from x0 = 0 with ftol 1e-10 on the *unsquared* norm; its iterate is
    # accurate to ~1e-4..1e-3 in S, not to the QP's 1e-12
    assert diff <= 1e-3, diff
