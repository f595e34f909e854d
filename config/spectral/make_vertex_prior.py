#!/usr/bin/env python3
"""Learn the lattice's `measured` vertex prior from measured reflectances; write its table.

    build/venv/bin/python config/spectral/make_vertex_prior.py [-o config/spectral/vertex_prior_measured.csv]

(the venv of `.ci/lib.sh` has colour-science 0.4.7 and NumPy/SciPy; any venv with them works.)

The model. A reflectance s in (0, 1) is written s = (tanh z + 1) / 2, as in LHTSS, and z is a
Gaussian: mean mu (beta times the mean z of the training reflectances: the estimate shrunk
towards LHTSS's centre z = 0, s = 1/2) and covariance G + F Fᵀ, where G is
the inverse of the first-difference roughness Σ_k (z[k+1] - z[k])² · 5 nm / Δλ_k (Brownian
motion along the wavelength axis: the grid-independent smoothness of LHTSS) and F (N × m) holds
the training set's first m principal directions of z - mu, scaled by the square root of their
variance over sigma2 (the roughness prior's own variance: the covariance is sigma2 (G + F Fᵀ)
up to a scale that no answer depends on). A vertex's spectrum is the most probable one with the
vertex's exact colour: min (z - mu)ᵀ (G + F Fᵀ)⁻¹ (z - mu) subject to C s(z) = v. With m = 0
and mu = 0 this is LHTSS. With face = "lhtss", the vertices on the RGB cube's faces (a channel 0 or
1) keep mu = 0 (LHTSS's smoothness, the table's face_mean column): every colour clipped to the
gamut lands there, its code is not its measured colour, and the measured mean pulls it further
from it (cross-validated, the clipped colours' worst rose with beta under every light).

Training data (licences allow shipping what is derived; all as colour-science 0.4.7 ships them,
380-780 nm at 5 nm): CIE 2017 colour evaluation samples (99), CIE 2024 TCS01-15, NIST CQS 9.0
VS1-15, and the 190 patches of the RAW to ACES v1 training set. Screen: a training spectrum
within RMS 0.02 (reflectance units, over 380-780 nm at 5 nm) of any patch of any ColorChecker
colour-science ships (N Ohta, BabelColor Average, ISO 17321-1) is dropped: those are the
held-out test, and the RAW to ACES set holds two copies of ColorChecker patches (RMS 0.002);
the next closest spectra are at RMS 0.008-0.02 (dropped too, as possible re-measurements).

Choice of m, sigma2, beta and face: cross-validation leaving one training set out at a time (a
texture's reflectances come from a source the prior has not seen: random folds, which mix the
sets, overstated the gain: chosen that way, m = 3 and beta = 1 won 7 % on random folds and lost
26 % to LHTSS on the ColorChecker). Each held-out sample's 8-bit sRGB code is turned into a
spectrum by a 9³ lattice of this prior's vertex spectra (learned from the other sets), and
scored by ΔE00 against the measured reflectance under A, FL2, FL11, D50 and LED-B3
(tests/bench/method_accuracy.py's colorimetry). Score of a set: the average over the five
lights of the mean ΔE00, divided by LHTSS's on that set. The rule: among the models whose worst
sample under each light is no worse than LHTSS's (all of them if none is), the lowest worst-set
ratio; among models within 0.005 of it, the fewest components, then the largest sigma2 (the
smoothest), then LHTSS on the faces, then the smallest beta (the closest to LHTSS). No
ColorChecker figure is computed here.
"""
import argparse
import sys
import warnings
from pathlib import Path

warnings.filterwarnings("ignore")
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent.parent
sys.path.insert(0, str(ROOT / "tests" / "bench"))
import method_accuracy as M  # noqa: E402

import colour  # noqa: E402

GRID, N, C = M.GRID, M.N, M.C
CLIP = 1e-3  # reflectances are clipped to [CLIP, 1 - CLIP] before atanh (|z| <= 3.8)
SCREEN_RMS = 0.02
FOLDS = 5
MS = [0, 3, 8]
SIGMA2S = [0.1, 1.0]
BETAS = [0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 1.0]
FACES = ["lhtss", "same"]  # the faces' mean: 0 (LHTSS's smoothness) or the vertices' own
CHECKERS = ["ColorChecker N Ohta", "BabelColor Average", "ISO 17321-1"]


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def training_sets():
    from colour.characterisation import read_training_data_rawtoaces_v1

    tuning, _ = M.load_sets()  # CES, TCS, VS (never the charts)
    d = read_training_data_rawtoaces_v1()
    tuning["RAW to ACES v1 (190)"] = np.stack(
        [M.on_grid(d.wavelengths, d.values[:, i]) for i in range(d.values.shape[1])])
    return tuning


def screen(sets):
    """The screened pool, each sample's set index, and a line per set."""
    charts = np.concatenate([M.sds_to_array(colour.SDS_COLOURCHECKERS[k].values()) for k in CHECKERS])
    kept, group, report = [], [], []
    for i, (name, R) in enumerate(sets.items()):
        rms = np.sqrt(((R[:, None, :] - charts[None]) ** 2).mean(2)).min(1)
        keep = rms > SCREEN_RMS
        kept.append(R[keep])
        group.append(np.full(int(keep.sum()), i))
        report.append(f"{name}: {int(keep.sum())} kept, {int((~keep).sum())} dropped")
    return np.concatenate(kept), np.concatenate(group), report


def roughness(lam, weight=None):
    """Σ_k (z[k+1] - z[k])² · 5 nm / Δλ_k as a dense matrix (the C++ keeps it tridiagonal), each
    step times weight[k] if given."""
    n = len(lam)
    K = np.zeros((n, n))
    for k in range(n - 1):
        w = 5.0 / (lam[k + 1] - lam[k]) * (1.0 if weight is None else weight[k])
        K[k, k] += w
        K[k + 1, k + 1] += w
        K[k, k + 1] -= w
        K[k + 1, k] -= w
    return K


def fit(R, m, sigma2, beta):
    """mu and F (N × m) of the model, from reflectances R (K × N)."""
    Z = np.arctanh(2 * np.clip(R, CLIP, 1 - CLIP) - 1)
    mu = Z.mean(0)
    if m == 0:
        return beta * mu, np.zeros((N, 0))
    _, S, Vt = np.linalg.svd(Z - mu, full_matrices=False)
    var = S[:m] ** 2 / (len(R) - 1)
    return beta * mu, Vt[:m].T * np.sqrt(var / sigma2)


def precision(F):
    """(G + F Fᵀ)⁻¹ = K - K F (I + Fᵀ K F)⁻¹ Fᵀ K, K the roughness (+1e-9 I, as the C++)."""
    K = roughness(GRID) + 1e-9 * np.eye(N)
    if F.shape[1] == 0:
        return K
    A = np.eye(F.shape[1]) + F.T @ K @ F
    P = K - K @ F @ np.linalg.solve(A, F.T @ K)
    return 0.5 * (P + P.T)


def vertex_spectrum(v, P, mu, tol=1e-12, zmax=18.5):
    """min (z - mu)ᵀ P (z - mu) s.t. C s(z) = v: Newton on the Lagrange system, backtracking on
    the residual (the C++ does the same with the roughness kept tridiagonal); unconverged (the
    sRGB cube's saturated corners) -> the Euclidean projection onto the exact bounded set, as the
    lattice does."""
    z, lam = mu.copy(), np.zeros(3)

    def ev(z, lam):
        t = np.tanh(z)
        s, sp, g = 0.5 * (t + 1), 0.5 * (1 - t * t), C.T @ lam
        return t, s, sp, g, P @ (z - mu) - sp * g, C @ s - v

    t, s, sp, g, r1, r2 = e = ev(z, lam)
    merit = r1 @ r1 + r2 @ r2
    for _ in range(100):
        if np.abs(r2).max() <= tol and np.abs(r1).max() <= 1e-9 * max(1.0, np.abs(P).max()):
            break
        J = np.block([[P + np.diag(2 * t * sp * g), -(sp[:, None] * C.T)],
                      [C * sp[None, :], np.zeros((3, 3))]])
        try:
            d = np.linalg.solve(J, -np.concatenate([r1, r2]))
        except np.linalg.LinAlgError:
            break
        step, moved = 1.0, False
        for _ in range(40):
            zn, ln = np.clip(z + step * d[:N], -zmax, zmax), lam + step * d[N:]
            e = ev(zn, ln)
            m = e[4] @ e[4] + e[5] @ e[5]
            if m < merit * (1 - 1e-4 * step) or m == 0:
                z, lam, merit, moved = zn, ln, m, True
                t, s, sp, g, r1, r2 = e
                break
            step *= 0.5
        if not moved:
            break
    if np.abs(r2).max() > 1e-9:
        return M.solve_qp(np.eye(N), s, v), False
    return s, True


class Lattice9:
    def __init__(self, P, mu, n=9, mu_face=None):
        self.P, self.mu, self.n = P, mu, n
        self.mu_face = mu if mu_face is None else mu_face
        self.xb = M.srgb_decode(np.linspace(0, 1, n))
        self.cache = {}
        self.unconverged = 0

    def vertex(self, t):
        if t not in self.cache:
            if all(i == 0 for i in t):
                s = np.zeros(N)
            elif all(i == self.n - 1 for i in t):
                s = np.ones(N)
            else:
                face = min(t) == 0 or max(t) == self.n - 1
                v = self.xb[np.array(t)]
                s, ok = vertex_spectrum(v, self.P, self.mean_at(v, face))
                self.unconverged += not ok
            self.cache[t] = s
        return self.cache[t]

    def mean_at(self, v, face):
        """The prior's mean at a vertex of colour v (linear RGB), on a face of the cube or not."""
        return self.mu_face if face else self.mu

    def spectra(self, V):
        out = np.zeros((len(V), N))
        for k, v in enumerate(V):
            w, corners = M.kuhn_simplex(self.xb, v)
            out[k] = w @ np.stack([self.vertex(c) for c in corners])
        return out


def scores(de, group, clipped):
    """ΔE00 per light (de) summed up: per set, the average over the lights of the mean; pooled
    mean and maximum per light, and the maximum apart for the colours inside sRGB and those
    clipped to it."""
    return dict(avg=float(np.mean([de[L].mean() for L in M.LIGHTS])),
                per_set=[float(np.mean([de[L][group == f].mean() for L in M.LIGHTS])) for f in np.unique(group)],
                mean={L: float(de[L].mean()) for L in M.LIGHTS},
                max={L: float(de[L].max()) for L in M.LIGHTS},
                max_in={L: float(de[L][~clipped].max()) for L in M.LIGHTS},
                max_clipped={L: float(de[L][clipped].max()) for L in M.LIGHTS})


def cross_validate(R, V, group, clipped, ev, m, sigma2, beta, face="same", lhtss=False):
    """Leave-one-set-out scores (scores()) of the prior (m, sigma2, beta, face), or of LHTSS."""
    S = np.zeros_like(R)
    for f in np.unique(group):
        tr, te = group != f, group == f
        if lhtss:
            P, mu = roughness(GRID) + 1e-9 * np.eye(N), np.zeros(N)
        else:
            mu, F = fit(R[tr], m, sigma2, beta)
            P = precision(F)
        S[te] = Lattice9(P, mu, mu_face=np.zeros(N) if face == "lhtss" else mu).spectra(V[te])
    return scores({L: ev.delta_e(L, R, S) for L in M.LIGHTS}, group, clipped)


class _LocalMean(Lattice9):
    """The mean at a vertex: beta times the training z's average weighted by a Gaussian of the
    CIELAB distance (under D65) between the vertex's colour and each training colour; 0 on the
    faces."""
    def __init__(self, P, Z, lab, beta, h):
        super().__init__(P, np.zeros(N))
        self.Z, self.lab, self.beta, self.h = Z, lab, beta, h

    def mean_at(self, v, face):
        if face:
            return np.zeros(N)
        w = np.exp(-0.5 * ((_lab(v[None])[0] - self.lab) ** 2).sum(1) / self.h ** 2)
        return self.beta * (w @ self.Z) / w.sum()


class _JakobHanikaFaces(Lattice9):
    """The shipped model inside; on the faces, the mean gamma times the z of Jakob-Hanika's spectrum
    of the vertex's colour (gamma = 1: that spectrum itself where it is exact, the nearest exact
    one in z where not)."""
    def __init__(self, P, mu, gamma):
        super().__init__(P, mu)
        self.gamma = gamma

    def mean_at(self, v, face):
        if not face:
            return self.mu
        c, _ = M.jh_fit(v[None])
        return self.gamma * np.arctanh(2 * np.clip(M.jh_spectrum(c)[0], CLIP, 1 - CLIP) - 1)


def _increment_weighted(Z, alpha):
    """roughness() with step k weighted by (var(z[k+1] - z[k]) / their mean)^-alpha over Z's rows."""
    v = np.var(np.diff(Z, axis=1), axis=0)
    return roughness(GRID, (v / v.mean()) ** -alpha) + 1e-9 * np.eye(N)


def _lab(rgb):
    return colour.XYZ_to_Lab(np.clip(rgb, 1e-6, None) @ M.NPM.T,
                             colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])


def also_tried(R, V, group, clipped, ev, beta):
    """Models tried beside the Gaussian of fit() and not kept, cross-validated the same way (leave
    one set out): (label, scores()) pairs. A mean that depends on the vertex's colour; Jakob-Hanika's
    spectra centring the faces (where the clipped colours land); a curvature term added to the
    roughness (w times the sum of squared second differences of z, on the 5 nm grid); the roughness
    weighted per wavelength by the training z's increments (each step's weight the variance of
    z[k+1] - z[k] to the power -alpha, relative to their mean: Brownian motion whose speed is
    learned)."""
    K = roughness(GRID) + 1e-9 * np.eye(N)
    D2 = np.diff(np.eye(N), 2, axis=0)
    Z = np.arctanh(2 * np.clip(R, CLIP, 1 - CLIP) - 1)
    lab = _lab(R @ C.T)
    makers = [(f"mean local in CIELAB, h = {h}, beta = {b:g}", lambda tr, h=h, b=b: _LocalMean(K, Z[tr], lab[tr], b, h))
              for h, b in ((10, 0.7), (25, 0.7), (60, 0.7), (60, 1.0))]
    makers += [(f"faces Jakob-Hanika, gamma = {g:g}, beta = {beta:g}",
                lambda tr, g=g: _JakobHanikaFaces(K, fit(R[tr], 0, 1.0, beta)[0], g)) for g in (0.25, 1.0)]
    makers += [(f"curvature w = {w:g}, faces 0, beta = {beta:g}",
                lambda tr, w=w: Lattice9(K + w * D2.T @ D2, fit(R[tr], 0, 1.0, beta)[0], mu_face=np.zeros(N)))
               for w in (10, 100)]
    makers += [(f"roughness by the increments' variance, alpha = {al:g}, faces 0, beta = {beta:g}",
                lambda tr, al=al: Lattice9(_increment_weighted(Z[tr], al), fit(R[tr], 0, 1.0, beta)[0],
                                           mu_face=np.zeros(N)))
               for al in (0.25, 0.5, 1.0)]
    out = []
    for label, make in makers:
        S = np.zeros_like(R)
        for f in np.unique(group):
            S[group == f] = make(group != f).spectra(V[group == f])
        out.append((label, scores({L: ev.delta_e(L, R, S) for L in M.LIGHTS}, group, clipped)))
        log(label)
    return out


def regression_floor(R, V, group, ev):
    """Per set, the average over the lights of the mean ΔE00 of a least-squares regression from
    the 8-bit colour (linear RGB, quadratic features) straight to the colour under each light,
    fitted on the other sets: a predictor no spectrum constrains, for scale."""
    def feats(X):
        r, g, b = X.T
        t = X.sum(1) + 1e-9
        return np.stack([r, g, b, r * g / t, g * b / t, b * r / t, r * r / t, g * g / t, b * b / t], 1)
    de = {}
    for L in M.LIGHTS:
        T = R @ ev.W[L].T @ ev.cat[L].T
        pred = np.zeros_like(T)
        for f in np.unique(group):
            tr, te = group != f, group == f
            B, *_ = np.linalg.lstsq(feats(V[tr]), T[tr], rcond=None)
            pred[te] = feats(V[te]) @ B
        de[L] = colour.delta_E(colour.XYZ_to_Lab(T, ev.white_xy), colour.XYZ_to_Lab(pred, ev.white_xy),
                               method="CIE 2000")
    return [float(np.mean([de[L][group == f].mean() for L in M.LIGHTS])) for f in np.unique(group)]


def tradeoff_svg(path, jh, lhtss, curve, chosen):
    """One panel per light: the mean ΔE00 over all samples (x) against the worst inside sRGB (y),
    for LHTSS (beta = 0) and each beta, the chosen one ringed, Jakob-Hanika as a cross. Plain SVG,
    no plotting library."""
    W, H, pad = 190, 190, 34
    panels = []
    for p, L in enumerate(M.LIGHTS):
        pts = [(lhtss["mean"][L], lhtss["max_in"][L], 0.0)] + [(r["mean"][L], r["max_in"][L], b) for b, r in curve]
        xs = [x for x, _, _ in pts] + [jh["mean"][L]]
        ys = [y for _, y, _ in pts] + [jh["max_in"][L]]
        x0, x1 = min(xs) * 0.97, max(xs) * 1.03
        y0, y1 = min(ys) * 0.97, max(ys) * 1.03
        ox = p * (W + 10)

        def X(v):
            return ox + pad + (v - x0) / (x1 - x0) * (W - pad - 6)

        def Y(v):
            return H - pad + 6 - (v - y0) / (y1 - y0) * (H - pad - 6)
        g = [f'<rect x="{ox + pad}" y="6" width="{W - pad - 6}" height="{H - pad}" fill="none" stroke="#999"/>',
             f'<text x="{ox + pad + 4}" y="20" font-size="12" font-weight="bold">{L}</text>',
             f'<text x="{ox + pad}" y="{H - pad + 20}" font-size="10">{x0:.2f}</text>',
             f'<text x="{ox + W - 6}" y="{H - pad + 20}" font-size="10" text-anchor="end">{x1:.2f}</text>',
             f'<text x="{ox + pad - 3}" y="{H - pad + 6}" font-size="10" text-anchor="end">{y0:.1f}</text>',
             f'<text x="{ox + pad - 3}" y="16" font-size="10" text-anchor="end">{y1:.1f}</text>',
             '<polyline fill="none" stroke="#1f77b4" stroke-width="1.5" points="'
             + " ".join(f"{X(x):.1f},{Y(y):.1f}" for x, y, _ in pts) + '"/>']
        for x, y, b in pts:
            g.append(f'<circle cx="{X(x):.1f}" cy="{Y(y):.1f}" r="{4.5 if b == chosen else 2.5}" '
                     f'fill="{"#d62728" if b == chosen else "#1f77b4"}"/>')
            if b in (0.0, chosen, 1.0):
                g.append(f'<text x="{X(x) + 5:.1f}" y="{Y(y) - 4:.1f}" font-size="9">'
                         f'{"lhtss" if b == 0 else "β " + format(b, "g")}</text>')
        jx, jy = X(jh["mean"][L]), Y(jh["max_in"][L])
        g.append(f'<path d="M{jx - 4:.1f},{jy - 4:.1f}L{jx + 4:.1f},{jy + 4:.1f}M{jx - 4:.1f},{jy + 4:.1f}'
                 f'L{jx + 4:.1f},{jy - 4:.1f}" stroke="#333" stroke-width="1.5"/>')
        g.append(f'<text x="{jx + 5:.1f}" y="{jy + 10:.1f}" font-size="9">JH</text>')
        panels.append("\n".join(g))
    width = len(M.LIGHTS) * (W + 10)
    text = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{H + 38}" '
            f'font-family="sans-serif">\n<rect width="100%" height="100%" fill="white"/>\n'
            + "\n".join(panels)
            + f'\n<text x="6" y="{H + 16}" font-size="11">x: mean ΔE00 over the 301 training colours; '
              f'y: the worst of the 260 inside sRGB; each set scored by a prior learned without it.</text>'
              f'\n<text x="6" y="{H + 30}" font-size="11">The line runs from lhtss (β 0) to β 1 in steps '
              f'of the table in docs/methods.md; the shipped β is ringed; JH: Jakob-Hanika.</text>\n</svg>\n')
    tmp = Path(str(path) + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def row(label, r, base=None):
    ratio = f"{max(np.array(r['per_set']) / np.array(base['per_set'])):.3f}" if base and "per_set" in r else "-"
    return (f"| {label} | {ratio} | {r['avg']:.3f} | "
            + " | ".join(f"{r['mean'][L]:.2f} / {r['max'][L]:.2f}" for L in M.LIGHTS) + " |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--output", default=str(Path(__file__).resolve().parent / "vertex_prior_measured.csv"))
    ap.add_argument("--svg", help="also draw the trade-off along beta here (docs/images/measured_prior_tradeoff.svg)")
    ap.add_argument("--also-tried", action="store_true",
                    help="also score the models tried and not kept (docs/methods.md), about 15 s more")
    a = ap.parse_args()
    sets = training_sets()
    R, group, report = screen(sets)
    for line in report:
        log(line)
    codes, V, clipped = M.to_codes(R)
    ev = M.Evaluator()
    table = ["| model | worst set vs lhtss | avg of means | "
             + " | ".join(f"{L} mean / max" for L in M.LIGHTS) + " |",
             "|---|---|---|" + "---|" * len(M.LIGHTS)]
    c, _ = M.jh_fit(V)
    jh = scores({L: ev.delta_e(L, R, M.jh_spectrum(c)) for L in M.LIGHTS}, group, clipped)
    base = cross_validate(R, V, group, clipped, ev, 0, 1.0, 0.0, lhtss=True)
    table.append(row("Jakob-Hanika (no lattice)", jh))
    table.append(row("lhtss (m = 0, mu = 0)", base, base))
    results = {}
    for m in MS:
        for s2 in (SIGMA2S if m else [1.0]):
            for face in FACES:
                for beta in BETAS:
                    r = results[(m, s2, face, beta)] = cross_validate(R, V, group, clipped, ev, m, s2, beta, face)
                    r["ratio"] = float(max(np.array(r["per_set"]) / np.array(base["per_set"])))
                    table.append(row(f"m = {m}, sigma2 = {s2:g}, faces {face}, beta = {beta:g}", r, base))
                    log(table[-1])
    eligible = {k: r for k, r in results.items() if all(r["max"][L] <= base["max"][L] + 1e-9 for L in M.LIGHTS)}
    eligible = eligible or results
    best = min(r["ratio"] for r in eligible.values())
    near = [k for k, r in eligible.items() if r["ratio"] <= best + 0.005]
    m, s2, face, beta = min(near, key=lambda k: (k[0], -k[1], FACES.index(k[2]), k[3]))
    chosen = results[(m, s2, face, beta)]
    print("\n".join(table))
    print(f"\nchosen: m = {m}, sigma2 = {s2:g}, faces {face}, beta = {beta:g} (worst set {chosen['ratio']:.3f} of "
          f"lhtss's; best {best:.3f} among the {len(eligible)} models no worse than lhtss on any light's worst)")
    # The trade-off along beta (the chosen m and sigma2): per-set scores, worst inside sRGB and of
    # the colours clipped to it, per light. docs/methods.md shows this table.
    def worst(r, key):
        return " / ".join(f"{r[key][L]:.2f}" for L in M.LIGHTS)
    trade = [("Jakob-Hanika (no lattice)", jh), ("lhtss", base)]
    trade += [(f"measured, faces {fc}, beta = {b:g}", results[(m, s2, fc, b)]) for fc in FACES for b in BETAS]
    print(f"\nTrade-off along beta (m = {m}, sigma2 = {s2:g}); sets {', '.join(sets)}; "
          f"{int((~clipped).sum())} colours inside sRGB, {int(clipped.sum())} clipped:\n")
    print("| prior | " + " | ".join(sets) + " | in-sRGB worst " + " / ".join(M.LIGHTS)
          + " | clipped worst " + " / ".join(M.LIGHTS) + " |")
    print("|---|" + "---|" * len(sets) + "---|---|")
    if a.also_tried:
        trade += also_tried(R, V, group, clipped, ev, beta)
    for label, r in trade:
        print(f"| {label} | " + " | ".join(f"{x:.3f}" for x in r["per_set"])
              + f" | {worst(r, 'max_in')} | {worst(r, 'max_clipped')} |")
    if a.svg:
        tradeoff_svg(a.svg, jh, base, [(b, results[(m, s2, face, b)]) for b in BETAS], beta)
        log(f"wrote {a.svg}")
    # What clipping alone costs: the 8-bit code's distance from the measured colour under D65,
    # which every exact method reproduces (the code, not the colour).
    white = colour.XYZ_to_xy(M.WHITE65)
    clip_de = colour.delta_E(colour.XYZ_to_Lab(R @ M.W65.T, white), colour.XYZ_to_Lab(V @ M.NPM.T, white),
                             method="CIE 2000")
    worst_all = {L: int(np.argmax(ev.delta_e(L, R, Lattice9(roughness(GRID) + 1e-9 * np.eye(N), np.zeros(N))
                                              .spectra(V)))) for L in M.LIGHTS}
    print("\nThe clipped colours' codes under D65, ΔE00 from the measured colour: max "
          f"{clip_de[clipped].max():.2f}, median {np.median(clip_de[clipped]):.2f}; LHTSS's worst sample under "
          + ", ".join(f"{L} is #{i} (clipped: {bool(clipped[i])}, {clip_de[i]:.2f} under D65)"
                      for L, i in worst_all.items()))
    floor = regression_floor(R, V, group, ev)
    print("\nRegression from the 8-bit colour to each light's colour (quadratic, same split), per set: "
          + ", ".join(f"{x:.3f}" for x in floor))
    mu, F = fit(R, m, s2, beta)
    mu_face = np.zeros(N) if face == "lhtss" else mu
    out = Path(a.output)
    names = list(sets)
    lines = [
        "# spectex measured vertex prior: s = (tanh z + 1) / 2, z Gaussian with mean 'mean' (on the RGB cube's",
        "# faces, where a channel is 0 or 1: 'face_mean') and",
        "# covariance G + F F' (G: inverse of the roughness sum_k (z[k+1] - z[k])^2 * 5 nm / dlambda_k;",
        "# F: the columns f1.., if any). Made by config/spectral/make_vertex_prior.py from colour-science 0.4.7.",
        "# training: " + "; ".join(report),
        f"# screen: dropped within RMS {SCREEN_RMS} of any patch of {', '.join(CHECKERS)}",
        f"# fit: reflectance clipped to [{CLIP:g}, {1 - CLIP:g}], z = atanh(2 s - 1); mean = {beta:g} x the mean z;"
        f" face_mean = {'0 (lhtss)' if face == 'lhtss' else 'mean'}; m = {m} principal directions, sigma2 = {s2:g}"
        " (leave-one-set-out cross-validation, rule in the script)",
        "# cross-validated avg over A, FL2, FL11, D50, LED-B3 of the mean dE00 per held-out set ("
        + ", ".join(names) + "): "
        + ", ".join(f"{x:.3f}" for x in chosen["per_set"]) + "; lhtss "
        + ", ".join(f"{x:.3f}" for x in base["per_set"]),
        "wavelength,mean,face_mean" + "".join(f",f{j + 1}" for j in range(m)),
    ]
    for k in range(N):
        lines.append(f"{GRID[k]:g}," + ",".join(f"{x:.9g}" for x in [mu[k], mu_face[k], *F[k]]))
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(out)
    log(f"wrote {out}")


if __name__ == "__main__":
    main()
