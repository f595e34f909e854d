"""The record a bake carries to rebuild its spectra from RGB, and the plugin's RGB mode.

A bake of the basis or the lattice records its table (spectex:rebuild*); the NumPy reference
(python/spectex_mitsuba/rebuild.py) rebuilds the file's spectra from it, and the plugin holds RGB
and evaluates the table at lookup. A record that cannot be trusted (damaged, edited, moved to other
pixels) is refused in mode "rgb" and set aside, with a warning, in mode "auto": never silently
wrong.
"""
import base64
import os
import subprocess
import tempfile
import warnings
import zlib

import numpy as np
import pytest

warnings.filterwarnings("ignore", category=DeprecationWarning)
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
import OpenImageIO as oiio  # noqa: E402

import spectex_mitsuba  # noqa: E402
from spectex_mitsuba import rebuild  # noqa: E402

SPECTEX = os.environ["SPECTEX_BINARY"]
SOURCE = os.environ["SPECTEX_SOURCE_DIR"]
CHART = os.path.join(SOURCE, "examples", "textures", "colour_chart.png")
LEAF = os.path.join(SOURCE, "examples", "textures", "leaf_rgba.png")
JIT = "llvm_ad_spectral"


@pytest.fixture(scope="module")
def tmp():
    with tempfile.TemporaryDirectory() as d:
        yield d


def bake(src, dst, *args):
    r = subprocess.run([SPECTEX, "bake", src, "-o", dst, "-q", *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return dst


def header(path):
    spec = oiio.ImageInput.open(path).spec()
    return {a.name: a.value for a in spec.extra_attribs if isinstance(a.value, str)}


def read(path):
    """(wavelengths, spectra [H, W, N] float64, alpha or None) by OpenImageIO."""
    buf = oiio.ImageBuf(path)
    names = list(buf.spec().channelnames)
    px = buf.get_pixels(oiio.FLOAT).astype(np.float64)
    ts = sorted((float(n[2:-2].replace(",", ".")), k) for k, n in enumerate(names) if n.startswith("T."))
    alpha = px[:, :, names.index("A")] if "A" in names else None
    return np.array([t[0] for t in ts]), px[:, :, [t[1] for t in ts]], alpha


def source_linear(png):
    """The source's linear sRGB (8-bit codes through the sRGB decode), and its alpha."""
    px = oiio.ImageBuf(png).get_pixels(oiio.FLOAT).astype(np.float64)
    c = px[:, :, :3]
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return lin, (px[:, :, 3] if px.shape[2] == 4 else None)


def kept_step(values, attrs, bins):
    """One step of each bin's kept mantissa bits at each value (half: 10 bits unless the
    precision budget kept fewer)."""
    text = attrs.get("spectex:precisionBits", "").split()
    bits = np.array([int(b) for b in text], dtype=np.float64) if len(text) == bins else np.full(bins, 10.0)
    return 2.0 ** (np.floor(np.log2(np.maximum(np.abs(values), 2.0 ** -14))) - bits)


# --- the record -----------------------------------------------------------------------------------

@pytest.mark.parametrize("args", [[], ["--method", "basis"], ["--type", "float"], ["--wavelengths", "380:780:5"]])
def test_the_record_rebuilds_the_method_at_the_source_colours(tmp, args):
    """The file holds the method's spectrum of each source colour, rounded to its kept bits; the
    record evaluated at that colour gives it to within that rounding and the table's own. Bound:
    one step of the bin's kept bits (rounding to nearest is half a step; the colour-aware rounding
    moves a bin to its other neighbour, one step), plus the table's rounding, in a half file to
    half (2^-11 of each value, so at most 2^-11 of the weighted sum of the values' magnitudes;
    values below 2^-14 are half's subnormals, 2^-25 at most, inside the slack), plus float32
    against float64: 2e-6 absolute, and for a float file 2e-5 (the source
    linearised in float32, 1e-7 of the colour, times the lattice's slope in its darkest cells, up
    to about 100 per unit of RGB)."""
    exr = bake(CHART, os.path.join(tmp, f"chart{len(args)}{''.join(args)}.exr".replace(":", "_")), *args)
    attrs = header(exr)
    record = rebuild.parse_record(attrs)
    assert record is not None and record.rule == ("basis" if "basis" in args else "lattice")
    half = "--type" not in args
    assert attrs["spectex:rebuildTableEncoding"] == ("half-delta-zlib" if half else "float-delta-zlib")
    lams, spectra, _ = read(exr)
    assert np.array_equal(record.lams, lams)
    lin, _ = source_linear(CHART)
    want = rebuild.rebuild(record, lin)
    step = kept_step(np.maximum(np.abs(want), np.abs(spectra)), attrs, len(lams))
    slack = 2e-6
    if not half:
        step, slack = np.abs(want) * 2.0 ** -23, 2e-5
    magnitude = rebuild.RebuildRecord(record.rule, record.lams, record.to_rgb, np.abs(record.table), record.axis)
    table_rounding = (2.0 ** -11 if half else 2.0 ** -24) * rebuild.rebuild(magnitude, np.abs(lin))
    err = np.abs(spectra - want)
    bound = 2 * step + table_rounding + slack
    assert np.all(err <= bound), float(np.max(err / bound))
    # And the file's spectra integrate back to the source colour: what lets a renderer recover it.
    rgb = rebuild.file_rgb(record, spectra)
    assert np.max(np.abs(rgb - lin)) < 2.0 ** -10 * 1.001 + 6.2e-5


def signed(attrs):
    """The record with a checksum that matches it, over five texts when it names no encoding (an
    earlier spectex's) and six when it does: what an attacker who read docs/file-format.md writes."""
    a = dict(attrs)
    texts = [a["spectex:rebuild"], a.get("spectex:rebuildAxis", ""), a["spectex:rebuildToRgb"],
             a["spectex:rebuildTable"], a["spectex:wavelengthList"]]
    texts += [a["spectex:rebuildTableEncoding"]] if "spectex:rebuildTableEncoding" in a else []
    a["spectex:rebuildChecksum"] = f"crc32:{zlib.crc32(''.join(t + chr(10) for t in texts).encode()):08x}"
    return a


def legacy(attrs, table_bytes):
    """The record as an earlier spectex wrote it: the table as base64 of float32, no encoding."""
    a = {k: v for k, v in attrs.items() if k != "spectex:rebuildTableEncoding"}
    a["spectex:rebuildTable"] = base64.b64encode(table_bytes).decode()
    return signed(a)


def test_the_table_is_compact_an_earlier_record_still_reads_and_a_hostile_one_is_refused(tmp):
    """The default's table in the header: under a third of its float32 base64 (on a 512 x 256
    texture that is 0.59x the basis' bytes rather than 0.65x). A record an earlier spectex wrote
    (float32, no encoding) reads to the same numbers. Well-signed records whose table is not what
    the rest of the record says (short, long, not zlib, an inflate bomb, an unknown encoding) raise
    RebuildError and nothing else."""
    exr = bake(CHART, os.path.join(tmp, "compact.exr"))
    attrs = header(exr)
    record = rebuild.parse_record(attrs)
    values = record.table.size
    assert len(attrs["spectex:rebuildTable"]) < (values * 4 + 2) // 3 * 4 / 3
    floats = record.table.astype("<f4").tobytes()
    earlier = legacy(attrs, floats)
    again = rebuild.parse_record(earlier)
    assert again.rule == record.rule and np.array_equal(again.table, record.table)
    assert np.array_equal(again.axis, record.axis) and np.array_equal(again.to_rgb, record.to_rgb)

    def to_earlier(spec, px):
        spec.erase_attribute("spectex:rebuildTableEncoding")
        for k in ("spectex:rebuildTable", "spectex:rebuildChecksum"):
            spec.attribute(k, earlier[k])
        return spec, px
    # And the plugin holds such a file as RGB, as it did when that spectex wrote it.
    earlier_exr = rewrite(exr, os.path.join(tmp, "earlier.exr"), to_earlier)
    assert "spectex:rebuildTableEncoding" not in header(earlier_exr)
    assert load(earlier_exr, "rgb").holds == "rgb"
    raw = zlib.decompress(base64.b64decode(attrs["spectex:rebuildTable"]))
    assert len(raw) == 2 * values

    def table(text):
        return signed(dict(attrs, **{"spectex:rebuildTable": text}))

    def b64z(data):
        return base64.b64encode(zlib.compress(data)).decode()
    # Every value infinite: each row starts at 0x7c00 (half's infinity) and never changes.
    diffs = np.zeros((values // record.bins, record.bins), dtype="<u2")
    diffs[:, 0] = 0x7C00
    hostile = {
        "short": table(b64z(raw[:-2])),
        "long": table(b64z(raw + b"\0\0")),
        "bomb": table(b64z(bytes(1 << 26))),
        "not zlib": table(base64.b64encode(raw).decode()),
        "not base64": table("@@@@"),
        "trailing bytes": table(base64.b64encode(zlib.compress(raw) + b"x").decode()),
        "infinite": table(b64z(diffs.reshape(-1).view(np.uint8).reshape(-1, 2).T.tobytes())),
        "encoding": signed(dict(attrs, **{"spectex:rebuildTableEncoding": "bfloat16-zstd"})),
        "earlier, short": legacy(attrs, floats[:-4]),
    }
    for what, a in hostile.items():
        try:
            rebuild.parse_record(a)
        except rebuild.RebuildError:
            continue
        pytest.fail(f"{what}: accepted")


def test_methods_that_cannot_be_rebuilt_record_nothing(tmp):
    jh = bake(CHART, os.path.join(tmp, "jh.exr"), "--method", "jakob-hanika")
    assert not any(k.startswith("spectex:rebuild") for k in header(jh))
    # 17^3 vertices x 31 bins = 152,303 values: over the 2^17 a header carries.
    big = bake(CHART, os.path.join(tmp, "big.exr"), "--lattice-size", "17")
    assert not any(k.startswith("spectex:rebuild") for k in header(big))
    assert rebuild.parse_record(header(big)) is None


# --- the plugin's RGB mode ------------------------------------------------------------------------

def load(exr, mode="auto", **props):
    mi.set_variant(JIT)
    spectex_mitsuba.register()
    return mi.load_dict({"type": "spectex", "filename": exr, "mode": mode, **props})


def eval_at(tex, uv, lams):
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.uv = mi.Point2f(uv[:, 0], uv[:, 1])
    si.wavelengths = mi.Spectrum(*[mi.Float(lams[:, j]) for j in range(4)])
    return np.array(tex.eval(si)).reshape(4, -1).T


def points_where_texels_differ(key, threshold, n, rng, lo, hi):
    """n uv points, each between the centres of 4 texels whose `key` (an [H, W] image) differs by
    over `threshold` among them, at an offset in [lo, hi] of a texel from the first one's centre."""
    height, width = key.shape
    block = np.stack([key[:-1, :-1], key[:-1, 1:], key[1:, :-1], key[1:, 1:]])
    ys, xs = np.nonzero(block.max(axis=0) - block.min(axis=0) > threshold)
    at = rng.integers(0, len(xs), n)
    return np.stack([(xs[at] + 0.5 + rng.uniform(lo, hi, n)) / width,
                     (ys[at] + 0.5 + rng.uniform(lo, hi, n)) / height], axis=1)


def write_spectra(path, lams, cube, alpha=None, sample_type=oiio.FLOAT):
    """A float (or half) Fichet-layout file of exactly these spectra (no record): the RGB mode's
    spectra held by the spectra mode."""
    names = [f"T.{lam:g}nm" for lam in lams] + (["A"] if alpha is not None else [])
    data = cube if alpha is None else np.concatenate([cube, alpha[..., None]], axis=2)
    spec = oiio.ImageSpec(cube.shape[1], cube.shape[0], len(names), sample_type)
    spec.channelnames = tuple(names)
    spec.attribute("spectralLayoutVersion", "1.0")
    out = oiio.ImageOutput.create(path)
    out.open(path, spec)
    out.write_image(np.ascontiguousarray(data, dtype=np.float32))
    out.close()


@pytest.mark.parametrize("png,args", [(CHART, []), (LEAF, []), (LEAF, ["--type", "float"]),
                                      (CHART, ["--lattice-size", "13", "--wavelengths", "400:700:10"]),
                                      (LEAF, ["--lattice-size", "2"])])
def test_the_rgb_mode_blends_the_rebuilt_spectra_as_the_spectra_mode_blends_bins(tmp, png, args):
    """Bilinear and nearest, every wrap mode, both wavelength filters, uv outside [0, 1]: the RGB
    mode equals the spectra mode of a file holding exactly the spectra the record rebuilds (alpha
    premultiplied on the leaf), for the half and the float table, and for the default lattice, a
    13^3 one (14 bits of simplex, 16 of each coordinate in a texel's 64) and the smallest. The
    stochastic wavelength filter's pick is a hash of uv, wavelength and the texture's seed: given
    the same seed, the two files read the same bin. Bound 5e-5: float32
    evaluation, RGB recovered in float32 and divided by alpha, and each texel's coordinates rounded
    to 2^-17 at worst (16 bits), which moves a value by at most 3 * 2^-17 = 2.3e-5."""
    exr = bake(png, os.path.join(tmp, os.path.basename(png) + ".exr"), *args)
    record = rebuild.parse_record(header(exr))
    if "--type" not in args:
        # The plugin holds a half file's lattice in half (2^-11 of each value, within the file's
        # own rounding): the twin is made from the same numbers.
        record.table = record.table.astype(np.float16).astype(np.float32)
    lams, spectra, alpha = read(exr)
    rgb = rebuild.file_rgb(record, spectra)
    if alpha is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            rgb = np.where(alpha[..., None] > 0, rgb / alpha[..., None], 0.0)
    again = rebuild.rebuild(record, rgb)
    if alpha is not None:
        again *= alpha[..., None]
    twin = os.path.join(tmp, "twin_" + os.path.basename(exr))
    write_spectra(twin, lams, again, alpha)
    rng = np.random.default_rng(11)
    uv = rng.uniform(-1.3, 2.2, (4000, 2))
    wl = rng.uniform(360, 830, (4000, 4))
    for filt in ("bilinear", "nearest"):
        for wrap in ("repeat", "mirror", "clamp"):
            for wfilt in ("stochastic", "linear"):  # the stochastic one picks the same bins in both modes
                ours = load(exr, "rgb", filter_type=filt, wrap_mode=wrap, wavelength_filter=wfilt, seed=7)
                assert ours.holds == "rgb"
                theirs = load(twin, "spectra", filter_type=filt, wrap_mode=wrap, wavelength_filter=wfilt, seed=7)
                d = np.abs(eval_at(ours, uv, wl) - eval_at(theirs, uv, wl))
                assert d.max() < 5e-5, (filt, wrap, wfilt, d.max())


@pytest.mark.parametrize("png,args", [(CHART, []), (LEAF, []), (LEAF, ["--method", "basis"])])
def test_the_stochastic_filter_picks_one_bilinear_texel_and_is_the_bilinear_filter_on_average(tmp, png, args):
    """filter_type "stochastic" (both modes; the lattice, and the basis whose texel holds alpha; the
    leaf's alpha premultiplied):
    - each lookup is exactly one of its 4 bilinear texels' spectra (the nearest filter at that
      texel's centre; 1e-6: float32 evaluation of the same numbers);
    - the same uv gives the same texel, and scalar_spectral picks the texel the JIT variant picks
      (but where the pick's random number is within float32's rounding of a boundary, which its
      float64 weights can move: at least 99 % of lookups);
    - over 64 uv jittered by up to 0.05 texel around each of 4000 points, the mean is the bilinear
      filter's mean at the same uv: the mean of the differences over the points within 5 of its
      standard errors at each wavelength. The points are where the texels differ (the leaf's alpha
      edges, the chart's patch borders): a pick that ignored alpha (probability the bilinear
      weight alone) is off by over 20 standard errors on the leaf."""
    exr = os.path.join(tmp, "stochastic_" + "_".join([os.path.basename(png)] + args) + ".exr")
    if not os.path.exists(exr):
        bake(png, exr, *args)
    _, spectra, alpha = read(exr)
    height, width = spectra.shape[:2]
    rng = np.random.default_rng(5)
    n, k = 4000, 64
    uv = points_where_texels_differ(alpha if alpha is not None else spectra.sum(axis=2), 0.05, n, rng, 0.1, 0.9)
    jit = (uv[:, None, :] + rng.uniform(-0.05, 0.05, (n, k, 2)) / [width, height]).reshape(-1, 2)
    lams = np.tile([450.0, 520.0, 600.0, 650.0], (n * k, 1))
    picked = {}
    for mode in ("rgb", "spectra"):
        st = load(exr, mode, filter_type="stochastic")
        got = eval_at(st, jit, lams)
        assert np.array_equal(got, eval_at(st, jit, lams))
        # The 4 texels' centres, each looked up with the nearest filter.
        x0 = np.floor(jit[:, 0] * width - 0.5)
        y0 = np.floor(jit[:, 1] * height - 0.5)
        near = load(exr, mode, filter_type="nearest")
        corners = [eval_at(near, np.stack([(x0 + dx + 0.5) / width, (y0 + dy + 0.5) / height], axis=1), lams)
                   for dy in (0, 1) for dx in (0, 1)]
        dist = np.array([np.abs(got - c).max(axis=1) for c in corners])
        assert dist.min(axis=0).max() < 1e-6, (mode, dist.min(axis=0).max())
        picked[mode] = (corners, dist.argmin(axis=0))
        bilinear = eval_at(load(exr, mode), jit, lams)
        d = (got - bilinear).reshape(n, k, 4).mean(axis=1)
        z = np.abs(d.mean(axis=0)) / (d.std(axis=0) / np.sqrt(n))
        assert np.all(z < 5), (mode, z)
    mi.set_variant("scalar_spectral")
    spectex_mitsuba.register()
    scalar = mi.load_dict({"type": "spectex", "filename": exr, "mode": "rgb", "filter_type": "stochastic"})
    si = mi.SurfaceInteraction3f()
    corners, which = picked["rgb"]
    same = 0
    for j in range(400):
        si.uv = mi.Point2f(float(jit[j, 0]), float(jit[j, 1]))
        si.wavelengths = mi.Spectrum(450.0, 520.0, 600.0, 650.0)
        value = np.array(scalar.eval(si)).reshape(-1)
        # The texel whose JIT spectrum is nearest (the scalar variant rebuilds in float64 from the
        # float64 table: within the half table's 2^-11 of it); texels of equal spectra are one.
        mine = int(np.argmin([np.abs(value - c[j]).max() for c in corners]))
        same += np.abs(corners[mine][j] - corners[which[j]][j]).max() < 1e-6
    assert same >= 396, same


@pytest.mark.parametrize("png,args", [(CHART, []), (LEAF, []), (CHART, ["--method", "basis"]),
                                      (CHART, ["--type", "float"]), (CHART, ["--wavelengths-file", "uneven"])])
def test_the_stochastic_wavelength_filter_is_the_linear_filter_on_average(tmp, png, args):
    """wavelength_filter "stochastic" (the default) against "linear", both modes (the lattice in half
    and in float, the basis, premultiplied alpha, an uneven grid), bilinear in uv. At each of 2000
    random (uv, wavelengths), 64 lookups with uv moved by under 1e-3 texel (so that the pick's hash
    changes and the spectra hardly do):
    - each lookup is the value the linear filter gives at one of the two bins around the wavelength
      (the same uv; 1e-5: float32 evaluation of the same numbers);
    - where the two bins differ by over 1e-3 and the weight t of the upper one is in [0.05, 0.95],
      the upper one is read with probability t: over the 64 lookups its share s gives
      z = (s - t) / sqrt(t (1 - t) / 64), whose mean over the points is within 5 of its standard
      errors (1 / sqrt(points)) of 0 and its mean square (1 for a fair pick) in [0.8, 1.2]: a pick
      that ignored its wavelength or its uv would be 0 or 1 at every point (mean square about 64);
    - the 4 wavelengths of a lookup pick independently: the correlation of their picks' residuals
      s - t under 5 / sqrt(lookups) in absolute value (a pick shared by the 4 would be near 1);
    - the same inputs give the same values, and scalar_spectral picks the bin the JIT variant
      picks in at least 99 % of 400 lookups (its t in float64 can fall on the other side of the
      random number within float32's rounding)."""
    exr = os.path.join(tmp, "wfilter_" + "_".join([os.path.basename(png)] + args) + ".exr")
    if "uneven" in args:
        args = [os.path.join(tmp, "uneven.txt") if a == "uneven" else a for a in args]
        with open(args[-1], "w") as f:  # uneven steps, one not a whole number
            f.write("\n".join(f"{w:g}" for w in [380, 383.7, 400, 430, 450, 470, 500, 520, 545, 580, 600, 610, 640,
                                                 680, 700, 730, 780]) + "\n")
    if not os.path.exists(exr):
        bake(png, exr, *args)
    lams_file, spectra, alpha = read(exr)
    height, width = spectra.shape[:2]
    rng = np.random.default_rng(17)
    n, k = 2000, 64
    if alpha is not None:  # where the leaf is
        ys, xs = np.nonzero(alpha[:-1, :-1] > 0.5)
        at = rng.integers(0, len(xs), n)
        base = np.stack([(xs[at] + 0.5 + rng.uniform(0, 1, n)) / width,
                         (ys[at] + 0.5 + rng.uniform(0, 1, n)) / height], axis=1)
    else:
        base = rng.uniform(0, 1, (n, 2))
    uv = (base[:, None, :] + rng.uniform(-1e-3, 1e-3, (n, k, 2)) / [width, height]).reshape(-1, 2)
    lams = np.repeat(rng.uniform(360, 830, (n, 4)), k, axis=0)
    lams[:k] = [lams_file[0], lams_file[-1], 300.0, 900.0]  # on and outside the grid's ends
    i = np.clip(np.searchsorted(lams_file, lams, side="right") - 1, 0, len(lams_file) - 2)
    t = np.clip((lams - lams_file[i]) / (lams_file[i + 1] - lams_file[i]), 0.0, 1.0)
    picks = {}
    for mode in ("rgb", "spectra"):
        st = load(exr, mode)
        assert st.holds == mode
        got = eval_at(st, uv, lams)
        assert np.array_equal(got, eval_at(st, uv, lams))
        linear = load(exr, mode, wavelength_filter="linear")
        lo, hi = (eval_at(linear, uv, lams_file[i + d]) for d in (0, 1))
        assert np.minimum(np.abs(got - lo), np.abs(got - hi)).max() < 1e-5, mode
        upper = (np.abs(got - hi) < np.abs(got - lo)).astype(float)
        picks[mode] = lo, hi, upper
        clear = (np.abs(hi - lo) > 1e-3).reshape(n, k, 4).all(axis=1)
        share = upper.reshape(n, k, 4).mean(axis=1)
        tp = t.reshape(n, k, 4)[:, 0]
        fair = clear & (tp >= 0.05) & (tp <= 0.95)
        z = (share - tp)[fair] / np.sqrt(tp * (1 - tp) / k)[fair]
        assert fair.sum() > 1000, fair.sum()
        assert abs(z.mean()) * np.sqrt(len(z)) < 5, (mode, z.mean())
        assert 0.8 < (z ** 2).mean() < 1.2, (mode, (z ** 2).mean())
        res = np.where(clear.repeat(k, axis=0), upper - t, np.nan)
        for a in range(4):
            for b in range(a + 1, 4):
                ok = ~np.isnan(res[:, a]) & ~np.isnan(res[:, b])
                c = np.corrcoef(res[ok, a], res[ok, b])[0, 1]
                assert abs(c) < 5 / np.sqrt(ok.sum()), (mode, a, b, c)
    mi.set_variant("scalar_spectral")
    spectex_mitsuba.register()
    scalar = mi.load_dict({"type": "spectex", "filename": exr, "mode": "rgb"})
    si = mi.SurfaceInteraction3f()
    same = 0
    lo, hi, upper = picks["rgb"]
    for j in range(0, 400 * k, k):
        si.uv = mi.Point2f(float(uv[j, 0]), float(uv[j, 1]))
        si.wavelengths = mi.Spectrum(*[float(x) for x in lams[j]])
        value = np.array(scalar.eval(si)).reshape(-1)
        mine = np.abs(value - hi[j]) < np.abs(value - lo[j])
        same += np.all((mine == upper[j].astype(bool)) | (np.abs(hi[j] - lo[j]) < 1e-3))
    assert same >= 396, same


@pytest.mark.parametrize("filters", [{}, {"filter_type": "stochastic", "wavelength_filter": "linear"}])
def test_two_textures_pick_independently_so_their_product_is_the_product_of_their_filtered_values(tmp, filters):
    """A BSDF may multiply two spectex textures at one point. Their stochastic picks (the bin of
    each wavelength by default; the texel with filter_type "stochastic") are hashed with each
    texture's salt (its seed, else the CRC-32 of its filename), so two files, here the same bake
    under two names, pick independently: over 64 lookups at each of 10000 points where the texels
    or bins differ, the mean of the product of the two lookups minus the product of their exact
    filters' values is within 5 of its standard errors of 0 at each wavelength. Given the same
    seed, the two pick alike: their lookups are equal, and the same statistic is over 5 standard
    errors (the product's mean is then the filtered product of the squares: the test has the
    power to see the difference). The same file loaded twice picks alike; a seed that is not an
    integer is refused in one line naming the file."""
    exr = bake(CHART, os.path.join(tmp, "salt_a.exr"))
    other = os.path.join(tmp, "salt_b.exr")
    with open(exr, "rb") as f, open(other, "wb") as g:
        g.write(f.read())
    _, spectra, _ = read(exr)
    height, width = spectra.shape[:2]
    # Points where the 4 bilinear texels differ (the patches' borders) and the spectra change
    # between bins: the picks matter there.
    rng = np.random.default_rng(23)
    n, k = 10000, 64
    base = points_where_texels_differ(spectra.sum(axis=2), 0.5, n, rng, 0.2, 0.8)
    uv = (base[:, None, :] + rng.uniform(-1e-3, 1e-3, (n, k, 2)) / [width, height]).reshape(-1, 2)
    lams = np.repeat(rng.uniform(400, 700, (n, 4)), k, axis=0)
    exact = {"filter_type": "bilinear", "wavelength_filter": "linear"}
    ref = eval_at(load(exr, **exact), uv, lams)
    target = (ref * ref).reshape(n, k, 4).mean(axis=1)

    def z_of_product(a, b):
        d = (eval_at(a, uv, lams) * eval_at(b, uv, lams)).reshape(n, k, 4).mean(axis=1) - target
        return np.abs(d.mean(axis=0)) / (d.std(axis=0) / np.sqrt(n))

    a, b = load(exr, **filters), load(other, **filters)
    z = z_of_product(a, b)
    assert np.all(z < 5), z
    assert not np.array_equal(eval_at(a, uv[:4096], lams[:4096]), eval_at(b, uv[:4096], lams[:4096]))
    assert np.array_equal(eval_at(a, uv[:4096], lams[:4096]), eval_at(load(exr, **filters), uv[:4096], lams[:4096]))
    same_a, same_b = load(exr, seed=99, **filters), load(other, seed=99 + 2 ** 32, **filters)  # modulo 2^32
    assert np.array_equal(eval_at(same_a, uv, lams), eval_at(same_b, uv, lams))
    z = z_of_product(same_a, same_b)
    assert np.all(z > 5), z
    for bad in ("seven", 1.5):
        with pytest.raises((RuntimeError, spectex_mitsuba.SpectexError),
                           match=rf"salt_a\.exr: seed '{bad}' is not an integer"):
            load(exr, seed=bad, **filters)


def test_textures_of_different_tables_held_together_each_read_their_own(tmp):
    """The method's tables are shared by the textures of one table (same values, lattice, bins,
    precision and wavelength filter): bakes of one PNG whose tables differ (the LHTSS and the
    measured vertex prior on the same 31 bins in half, whose tables differ in their values alone; a
    13^3 lattice; a float file), loaded together with a second texture of the first file, each
    evaluate exactly as when loaded alone, in both wavelength filters, and the different tables
    give different values."""
    import gc

    files = [bake(CHART, os.path.join(tmp, f"tables_{k}.exr"), *args) for k, args in enumerate(
        [["--wavelengths", "400:700:10"], ["--wavelengths", "400:700:10", "--vertex-prior", "measured"],
         ["--wavelengths", "400:700:10", "--lattice-size", "13"], ["--type", "float"]])]
    rng = np.random.default_rng(31)
    uv, wl = rng.random((3000, 2)), rng.uniform(380, 780, (3000, 4))
    for wfilt in ("stochastic", "linear"):
        alone = []
        for f in files:
            tex = load(f, "rgb", wavelength_filter=wfilt, seed=3)
            alone.append(eval_at(tex, uv, wl))
            del tex
            gc.collect()
        held = [load(f, "rgb", wavelength_filter=wfilt, seed=3) for f in files + files[:1]]
        together = [eval_at(tex, uv, wl) for tex in held]
        for k, f in enumerate(files + files[:1]):
            assert np.array_equal(together[k], alone[k % len(files)]), (wfilt, f)
        for k in range(1, len(files)):
            assert not np.array_equal(alone[0], alone[k]), (wfilt, files[k])


def test_a_half_files_bins_are_read_exactly_in_the_spectra_mode(tmp):
    """The JIT variants hold a half file's bins in half, two to a 32-bit word, and widen them at
    lookup with integer operations: every kind of finite half (zero and negative zero, the smallest
    and largest subnormal, the smallest normal, 1/3, 1, the largest half, negatives) reads as that
    half in float32 exactly, at each texel's centre and bin (nearest, linear in wavelength), in an
    image whose sample count is odd (the last word half used); and the same values in a float file
    give the same lookups everywhere (bilinear, both wavelength filters, random uv and
    wavelengths), in the JIT and the scalar variant."""
    values = np.array([0.0, -0.0, 2.0 ** -24, 1023 * 2.0 ** -24, 2.0 ** -14, 1 / 3, 1.0, 65504.0, -2.5,
                       -(2.0 ** -24), 0.75, 1e-3, 0.5, 2.0, 0.1], dtype=np.float16)
    rng = np.random.default_rng(41)
    cube = rng.choice(values, size=(3, 5, 3)).astype(np.float16)  # 45 samples: odd
    cube.reshape(-1, 3)[:5] = values.reshape(5, 3)  # every value at least once
    lams = np.array([450.0, 550.0, 650.0])
    half, full = os.path.join(tmp, "kinds_half.exr"), os.path.join(tmp, "kinds_float.exr")
    write_spectra(half, lams, cube.astype(np.float32), sample_type=oiio.HALF)
    write_spectra(full, lams, cube.astype(np.float32))
    ys, xs = np.mgrid[0:3, 0:5]
    centres = np.stack([(xs.reshape(-1) + 0.5) / 5, (ys.reshape(-1) + 0.5) / 3], axis=1)
    at_bins = np.tile(lams.tolist() + [lams[0]], (15, 1))
    expect = np.concatenate([cube.reshape(-1, 3), cube.reshape(-1, 3)[:, :1]], axis=1).astype(np.float32)
    uv, wl = rng.uniform(-0.2, 1.2, (4000, 2)), rng.uniform(400, 700, (4000, 4))
    for variant in (JIT, "scalar_spectral"):
        mi.set_variant(variant)
        spectex_mitsuba.register()

        def tex(path, **props):
            return mi.load_dict({"type": "spectex", "filename": path, "mode": "spectra", **props})

        def at(t, points, lams_):
            if variant == JIT:
                return eval_at(t, points, lams_)
            si, out = mi.SurfaceInteraction3f(), []
            for p, w in zip(points, lams_):
                si.uv = mi.Point2f(float(p[0]), float(p[1]))
                si.wavelengths = mi.Spectrum(*[float(x) for x in w])
                out.append(np.array(t.eval(si)).reshape(-1))
            return np.array(out, dtype=np.float32)

        got = at(tex(half, filter_type="nearest", wavelength_filter="linear"), centres, at_bins)
        assert np.array_equal(got, expect), (variant, got, expect)
        n = 4000 if variant == JIT else 300
        for wfilt in ("stochastic", "linear"):
            a = at(tex(half, wavelength_filter=wfilt, seed=5), uv[:n], wl[:n])
            b = at(tex(full, wavelength_filter=wfilt, seed=5), uv[:n], wl[:n])
            assert np.array_equal(a, b), (variant, wfilt, np.abs(a - b).max())


def test_auto_holds_rgb_for_a_bake_and_the_bins_for_other_files(tmp):
    exr = bake(CHART, os.path.join(tmp, "auto.exr"))
    assert load(exr).holds == "rgb"
    jh = bake(CHART, os.path.join(tmp, "auto_jh.exr"), "--method", "jakob-hanika")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no record is no news: nothing to warn about
        assert load(jh).holds == "spectra"
    # Mitsuba reports a plugin's exception inside its own (RuntimeError), with the message.
    with pytest.raises((RuntimeError, spectex_mitsuba.SpectexError), match=r"auto_jh\.exr.*records no table"):
        load(jh, "rgb")
    with pytest.raises((RuntimeError, spectex_mitsuba.SpectexError), match="mode 'fast' is not one of"):
        load(exr, "fast")
    with pytest.raises((RuntimeError, spectex_mitsuba.SpectexError),
                       match=r"auto\.exr: wavelength_filter 'cubic' is not one of stochastic, linear"):
        load(exr, wavelength_filter="cubic")


@pytest.mark.parametrize("compression", ["piz"])
def test_files_the_strip_reader_does_not_take_are_read_by_mitsuba(tmp, compression):
    """PIZ goes to mi.Bitmap (the whole file), ZIP to the strip reader: the same samples (both keep
    the budget's bits), so the same texels."""
    exr = bake(CHART, os.path.join(tmp, f"c_{compression}.exr"), "--compression", compression)
    ref = bake(CHART, os.path.join(tmp, "c_zip.exr"))
    rng = np.random.default_rng(2)
    uv, wl = rng.random((2000, 2)), rng.uniform(380, 780, (2000, 4))
    a, b = load(exr, "rgb", seed=1), load(ref, "rgb", seed=1)  # two files: the same picks given one seed
    assert np.array_equal(eval_at(a, uv, wl), eval_at(b, uv, wl))


def rewrite(src, dst, change):
    """A copy of src through OpenImageIO with change(spec, pixels) applied (the samples unchanged
    otherwise: half read as float and written as half is exact)."""
    buf = oiio.ImageBuf(src)
    spec = buf.spec()
    px = buf.get_pixels(oiio.FLOAT)
    spec, px = change(spec, px)
    out = oiio.ImageOutput.create(dst)
    out.open(dst, spec)
    out.write_image(np.ascontiguousarray(px))
    out.close()
    return dst


@pytest.mark.parametrize("compression", ["zip", "piz"])
def test_a_sample_that_is_not_finite_is_refused_naming_the_file_in_every_mode(tmp, compression):
    """A NaN or an infinity in one bin of one texel, or in one alpha, of a premultiplied bake (half)
    is refused in each mode, with the file's name, whether the strip reader (ZIP) or Mitsuba's
    (PIZ) reads it: a lookup would return it, and a render would carry it to every pixel it
    reaches. The same rewrite with the sample left finite loads (the edit alone is no error)."""
    exr = bake(LEAF, os.path.join(tmp, "nf.exr"))

    def edited(name, channel, value):
        def change(spec, px):
            spec.attribute("compression", compression)
            px = px.copy()
            px[5, 7, list(spec.channelnames).index(channel)] = value
            return spec, px
        return rewrite(exr, os.path.join(tmp, f"{name}_{compression}.exr"), change)

    kept = edited("nf_finite", "T.550nm", 0.25)
    at, wl = np.array([[7.5 / 256, 5.5 / 256]]), np.full((1, 4), 550.0)
    for mode in ("rgb", "spectra", "auto"):
        assert np.all(np.isfinite(eval_at(load(kept, mode), at, wl)))
    for name, channel, value in (("nf_nan", "T.550nm", np.nan), ("nf_inf", "T.700nm", np.inf),
                                 ("nf_minus_inf", "T.400nm", -np.inf), ("nf_alpha", "A", np.nan)):
        path = edited(name, channel, value)
        for mode in ("rgb", "spectra", "auto"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                with pytest.raises((RuntimeError, spectex_mitsuba.SpectexError),
                                   match=rf"{name}_{compression}\.exr.*NaN or Inf"):
                    load(path, mode)


def test_a_damaged_or_moved_record_is_refused_or_set_aside(tmp):
    exr = bake(CHART, os.path.join(tmp, "t.exr"))
    other = bake(CHART, os.path.join(tmp, "t_jh_prior.exr"), "--vertex-prior", "jakob-hanika")
    attrs, attrs_other = header(exr), header(other)

    def edited(name, change_attrs=None, change_pixels=None):
        def change(spec, px):
            if change_attrs:
                for k, v in change_attrs(dict(attrs)).items():
                    spec.attribute(k, v)
            return spec, (change_pixels(spec, px) if change_pixels else px)
        return rewrite(exr, os.path.join(tmp, name), change)

    table = attrs["spectex:rebuildTable"]
    flipped = table[:100] + ("B" if table[100] != "B" else "C") + table[101:]
    cases = {
        # A changed character of the table: the checksum.
        "checksum": edited("t_flip.exr", lambda a: {"spectex:rebuildTable": flipped}),
        # Another prior's table with its own checksum (a whole record moved): the pixels.
        "other table": edited("t_moved.exr", lambda a: {k: attrs_other[k] for k in attrs_other
                                                         if k.startswith("spectex:rebuild")}),
        # Pixels scaled by a tool that kept the header: the lattice is not linear, the pixels say so.
        "scaled": edited("t_scaled.exr", None, lambda spec, px: px * 0.5),
    }

    def drop_channel(spec, px):
        names = list(spec.channelnames)
        keep = [k for k, n in enumerate(names) if n != "T.550nm"]
        spec.nchannels = len(keep)
        spec.channelnames = tuple(names[k] for k in keep)
        spec.channelformats = ()
        return px[:, :, keep]

    cases["channel removed"] = edited("t_fewer.exr", None, drop_channel)

    # A record whose own checksum holds but whose breakpoints crowd together (1e-7 apart: no
    # lookup table of the texture can tell them apart) is refused before any pixel is read.
    def crowded(a):
        n = len(a["spectex:rebuildAxis"].split())
        axis = " ".join(["0"] + [f"{k * 1e-7:.9g}" for k in range(1, n - 1)] + ["1"])
        r = signed(dict(a, **{"spectex:rebuildAxis": axis}))
        return {k: r[k] for k in ("spectex:rebuildAxis", "spectex:rebuildChecksum")}

    cases["crowded breakpoints"] = edited("t_crowded.exr", crowded)
    for what, path in cases.items():
        name = os.path.basename(path).replace(".", r"\.")
        with pytest.raises((RuntimeError, spectex_mitsuba.SpectexError), match=name + ".*cannot hold it as RGB"):
            load(path, "rgb")
        with pytest.warns(UserWarning, match="holding every bin instead"):
            tex = load(path)
        assert tex.holds == "spectra", what
    # The same edits of a basis file: a scaled basis file is still the basis' spectra (it is
    # linear), so its record is still right and is used.
    basis = bake(CHART, os.path.join(tmp, "tb.exr"), "--method", "basis")
    scaled = rewrite(basis, os.path.join(tmp, "tb_scaled.exr"), lambda spec, px: (spec, px * 0.5))
    assert load(scaled, "rgb").holds == "rgb"
