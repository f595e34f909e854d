"""A real spectral renderer renders spectex's files: Mitsuba 3 through python/spectex_mitsuba.

The plugin (installed into the venv with `pip install --no-deps ./python` by .ci/bootstrap test) is
checked against independent code: the files are read back with OpenImageIO's Python bindings,
spectra are integrated with numpy on the shipped CIE tables (config/spectral/), the spatial
filtering is compared with Mitsuba's own `bitmap` texture, and whole renders (llvm_ad_spectral:
plane, uniform `constant` light, orthographic camera, `direct` integrator, XYZ film) are compared
patch by patch with the integral they estimate.
"""
import itertools
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np
import pytest

warnings.filterwarnings("ignore")
import colour  # noqa: E402
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
import OpenImageIO as oiio  # noqa: E402

import spectex_mitsuba  # noqa: E402

SPECTEX = os.environ["SPECTEX_BINARY"]
SOURCE = os.environ["SPECTEX_SOURCE_DIR"]
SPECTRAL = os.path.join(SOURCE, "config", "spectral")
CHART = os.path.join(SOURCE, "examples", "textures", "colour_chart.png")
LEAF = os.path.join(SOURCE, "examples", "textures", "leaf_rgba.png")
JIT = "llvm_ad_spectral"

# The chart's bottom half: 4 rows x 6 flat patches (examples/textures/make_examples.py).
PATCH_X = np.linspace(0, 512, 7).round().astype(int)
PATCH_Y = np.linspace(128, 256, 5).round().astype(int)


def use(variant):
    mi.set_variant(variant)
    spectex_mitsuba.register()


def bake(src, dst, *args):
    r = subprocess.run([SPECTEX, "bake", src, "-o", dst, "-q", *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return dst


def read_csv(path):
    rows = [line.strip() for line in open(path) if line.strip() and not line.startswith("#")]
    names = rows[0].split(",")
    data = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
    return {n: data[:, k] for k, n in enumerate(names)}


def read_exr(path):
    """Independent reader: OpenImageIO. Returns (wavelengths, T [H, W, N], A or None)."""
    buf = oiio.ImageBuf(path)
    names = list(buf.spec().channelnames)
    px = buf.get_pixels(oiio.FLOAT)
    ts = sorted((float(n[2:-2].replace(",", ".")), k) for k, n in enumerate(names)
                if n.startswith("T.") and n.endswith("nm"))
    alpha = px[:, :, names.index("A")] if "A" in names else None
    return np.array([t[0] for t in ts]), px[:, :, [t[1] for t in ts]], alpha


@pytest.fixture(scope="module")
def tmp():
    with tempfile.TemporaryDirectory() as d:
        yield d


@pytest.fixture(scope="module")
def chart(tmp):
    return bake(CHART, os.path.join(tmp, "chart.exr"))


def surface(uv, lams):
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.uv = mi.Point2f(uv[:, 0], uv[:, 1])
    si.wavelengths = mi.Spectrum(*[mi.Float(lams[:, j]) for j in range(lams.shape[1])])
    return si


def eval_texture(tex, uv, lams):
    """The texture at n (u, v) and n x 4 wavelengths, in the current variant -> [n, 4]."""
    if mi.variant().startswith("scalar"):
        out = []
        si = dr.zeros(mi.SurfaceInteraction3f)
        for k in range(len(uv)):
            si.uv = mi.Point2f(*uv[k])
            si.wavelengths = mi.Spectrum(*lams[k])
            out.append(np.array(tex.eval(si)))
        return np.array(out)
    return np.array(tex.eval(surface(uv, lams))).reshape(4, -1).T


def textures(filename, **choices):
    """The spectex texture of `filename` with every combination of the given property values:
    (properties, texture) pairs, in the current variant."""
    for values in itertools.product(*choices.values()):
        props = dict(zip(choices, values))
        yield props, mi.load_dict({"type": "spectex", "filename": filename, **props})


# --- the texture itself -------------------------------------------------------------------------

def file_record(exr):
    """The file's spectex:rebuild* record (python/spectex_mitsuba/rebuild.py), read with OIIO."""
    spec = oiio.ImageInput.open(exr).spec()
    return spectex_mitsuba.rebuild.parse_record(
        {a.name: a.value for a in spec.extra_attribs if isinstance(a.value, str)})


def rebuilt_cube(exr, cube, alpha=None):
    """What the RGB mode holds a texel as, rebuilt by the NumPy reference: the method's spectrum
    of the linear RGB the file's spectrum integrates to (straight, when alpha is premultiplied).
    The plugin holds a half file's lattice in half (within the file's own rounding): so does this."""
    record = file_record(exr)
    if record.rule == "lattice" and oiio.ImageInput.open(exr).spec().format == oiio.HALF:
        record.table = record.table.astype(np.float16).astype(np.float32)
    rgb = spectex_mitsuba.rebuild.file_rgb(record, cube)
    if alpha is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            rgb = np.where(alpha[..., None] > 0, rgb / alpha[..., None], 0.0)
    return spectex_mitsuba.rebuild.rebuild(record, rgb)


@pytest.mark.parametrize("wfilter", ["linear", "stochastic"])
@pytest.mark.parametrize("mode", ["spectra", "rgb"])
@pytest.mark.parametrize("variant", ["scalar_spectral", JIT])
@pytest.mark.parametrize("kind", ["half", "float_10nm", "tiled", "mipmap", "nonuniform"])
def test_eval_is_the_files_spectra_linear_in_wavelength(tmp, variant, kind, mode, wfilter):
    """mode spectra: the file's bins; mode rgb: the bins the file's record rebuilds from the RGB
    of each texel (the tiled and MIP-mapped files are read by mi.Bitmap, the others in strips).
    wavelength_filter "linear": linear between the two bins around each wavelength; "stochastic"
    (the default): one of those two bins, exactly (how often each is read:
    test_the_stochastic_wavelength_filter_is_the_linear_filter_on_average)."""
    args = {"half": [], "float_10nm": ["--type", "float", "--wavelengths", "380:780:10"],
            "tiled": ["--tile", "64"], "mipmap": ["--mipmap"]}.get(kind)
    if kind == "nonuniform":
        grid = os.path.join(tmp, "grid.txt")
        with open(grid, "w") as f:  # uneven steps, a non-whole wavelength (written T.383,7nm)
            f.write("\n".join(f"{w:g}" for w in [380, 383.7, 400, 430, 450, 470, 500, 520, 545, 580, 600,
                                                 610, 640, 680, 700, 730, 780]) + "\n")
        args = ["--wavelengths-file", grid]
    exr = os.path.join(tmp, f"eval_{kind}.exr")
    if not os.path.exists(exr):
        bake(CHART, exr, *args)
    lams_file, cube, _ = read_exr(exr)
    if mode == "rgb":
        cube = rebuilt_cube(exr, cube)
    use(variant)
    tex = mi.load_dict({"type": "spectex", "filename": exr, "filter_type": "nearest", "mode": mode,
                        "wavelength_filter": wfilter})
    rng = np.random.default_rng(7)
    n = 300 if variant == JIT else 60
    xy = np.stack([rng.integers(0, 512, n), rng.integers(0, 256, n)], axis=1)
    uv = (xy + 0.5) / [512, 256]
    lams = rng.uniform(360, 830, (n, 4))
    lams[:4] = [[360, 380, 780, 830], [383.7, 400, 401, 779.9], [500, 505, 507.5, 600], [379, 781, 555, 556]]
    got = eval_texture(tex, uv, lams)
    want = np.array([np.interp(lams[k], lams_file, cube[xy[k, 1], xy[k, 0]]) for k in range(n)])
    # float32 arithmetic in the plugin against float64 here: the result's own rounding (2e-6), and
    # the wavelength's (a float32 of about 800 nm is off by up to 3e-5 nm, 6e-6 of a 5 nm bin),
    # which moves the value by that share of the step between the two bins around it. The
    # precision budget's coarse bins have steps up to about 0.5, so the bound is per sample. The
    # RGB mode recovers the texel's RGB in float32 (a relative 1e-6 of 31 products summed), which
    # moves the rebuilt spectrum by up to that share of the lattice's slope: 2e-5 more.
    step = np.array([np.abs(np.diff(cube[xy[k, 1], xy[k, 0]])).max() for k in range(n)])
    tol = 2e-6 + 1e-5 * step[:, None] + (2e-5 if mode == "rgb" else 0.0)
    if wfilter == "linear":
        assert (np.abs(got - want) < tol).all(), np.abs(got - want).max()
        return
    # The two bins around each wavelength (the end bins' values held outside the grid).
    i = np.clip(np.searchsorted(lams_file, lams, side="right") - 1, 0, len(lams_file) - 2)
    spectra = cube[xy[:, 1], xy[:, 0]]
    lo, hi = (np.take_along_axis(spectra, i + d, axis=1) for d in (0, 1))
    d = np.minimum(np.abs(got - lo), np.abs(got - hi))
    assert (d < tol).all(), d.max()
    assert ((np.abs(got - lo) < tol) & (np.abs(lo - hi) > 0.01)).any()  # both are read
    assert ((np.abs(got - hi) < tol) & (np.abs(lo - hi) > 0.01)).any()


def test_spatial_filtering_is_mitsubas_bitmap(tmp, chart):
    """Each bin, filtered over uv, equals Mitsuba's own `bitmap` texture of that bin alone (raw,
    one channel): bilinear and nearest, repeat, mirror and clamp, uv well outside [0, 1]."""
    lams_file, cube, _ = read_exr(chart)
    use(JIT)
    rng = np.random.default_rng(3)
    uv = rng.uniform(-1.7, 2.3, (2000, 2))
    for k in (0, len(lams_file) // 2, len(lams_file) - 1):  # first, middle and last bins
        mono = os.path.join(tmp, f"bin{k}.exr")
        mi.Bitmap(np.ascontiguousarray(cube[:, :, k:k + 1])).write(mono)
        lams = np.full((len(uv), 4), lams_file[k])
        for filt in ("bilinear", "nearest"):
            for wrap in ("repeat", "mirror", "clamp"):
                ours = mi.load_dict({"type": "spectex", "filename": chart, "filter_type": filt, "wrap_mode": wrap,
                                     "mode": "spectra"})
                theirs = mi.load_dict({"type": "bitmap", "filename": mono, "raw": True, "filter_type": filt,
                                       "wrap_mode": wrap})
                got = eval_texture(ours, uv, lams)[:, 0]
                want = np.array(theirs.eval_1(surface(uv, lams)))
                assert np.abs(got - want).max() < 1e-5, (k, filt, wrap)


@pytest.mark.parametrize("mode", ["spectra", "rgb"])
def test_premultiplied_alpha_is_divided_out(tmp, mode):
    exr = os.path.join(tmp, "leaf.exr")
    if not os.path.exists(exr):
        bake(LEAF, exr)
    lams_file, cube, alpha = read_exr(exr)
    if mode == "rgb":  # the straight spectra rebuilt, times alpha: what the file holds
        cube = rebuilt_cube(exr, cube, alpha) * alpha[..., None]
    use(JIT)
    tex = mi.load_dict({"type": "spectex", "filename": exr, "filter_type": "nearest", "mode": mode})
    ys, xs = np.nonzero((alpha > 0.05) & (alpha < 0.95))
    assert len(xs) > 50
    xy = np.stack([xs, ys], axis=1)[:200]
    uv = (xy + 0.5) / 256.0
    lams = np.tile([450.0, 550.0, 600.0, 650.0], (len(xy), 1))
    got = eval_texture(tex, uv, lams)
    straight = cube[xy[:, 1], xy[:, 0]] / alpha[xy[:, 1], xy[:, 0], None]
    want = np.array([np.interp(lams[k], lams_file, straight[k]) for k in range(len(xy))])
    # float32 against float64; the RGB mode also divides the recovered RGB by alpha (half) in float32.
    assert np.abs(got - want).max() < (1e-5 if mode == "spectra" else 5e-5)
    # Fully transparent texels: 0, not NaN.
    ys0, xs0 = np.nonzero(alpha == 0)
    got0 = eval_texture(tex, (np.stack([xs0[:20], ys0[:20]], axis=1) + 0.5) / 256.0, lams[:20])
    assert np.all(got0 == 0)


def test_wrong_files_are_refused_naming_the_file(tmp):
    use(JIT)
    rgb = os.path.join(tmp, "rgb.exr")
    mi.Bitmap(np.full((4, 4, 3), 0.5, dtype=np.float32), mi.Bitmap.PixelFormat.RGB).write(rgb)
    emissive = os.path.join(tmp, "emissive.exr")
    out = oiio.ImageOutput.create(emissive)
    spec = oiio.ImageSpec(4, 4, 2, oiio.HALF)
    spec.channelnames = ("S0.500nm", "S0.600nm")
    spec.attribute("spectralLayoutVersion", "1.0")
    assert out.open(emissive, spec)
    out.write_image(np.full((4, 4, 2), 0.5, dtype=np.float32))
    out.close()
    for path in (rgb, emissive, os.path.join(tmp, "missing.exr")):
        with pytest.raises(Exception) as e:
            mi.load_dict({"type": "spectex", "filename": path})
        message = str(e.value)
        assert path in message, message
    with pytest.raises(Exception, match="no reflectance channels 'T.<wavelength>nm'") as e:
        mi.load_dict({"type": "spectex", "filename": rgb})
    # As docs/mitsuba.md says it arrives: Mitsuba's wrapper, spectex's line last.
    assert str(e.value).strip().splitlines()[-1].startswith(f"SpectexError: spectex texture: {rgb}: "), e.value


@pytest.mark.parametrize("bad", ["T.-5nm", "T.1e400nm", "T.nm", "T.0nm", "T.5x5nm"])
def test_a_channel_that_names_no_wavelength_is_refused_naming_it(tmp, bad):
    """Beside valid channels, a T.<...>nm channel without a positive finite wavelength is refused
    (it was read as infinity, or silently dropped)."""
    use(JIT)
    path = os.path.join(tmp, "bad.exr")
    out = oiio.ImageOutput.create(path)
    spec = oiio.ImageSpec(4, 4, 3, oiio.HALF)
    spec.channelnames = ("T.500nm", "T.600nm", bad)
    spec.attribute("spectralLayoutVersion", "1.0")
    assert out.open(path, spec)
    out.write_image(np.full((4, 4, 3), 0.5, dtype=np.float32))
    out.close()
    with pytest.raises(Exception) as e:
        mi.load_dict({"type": "spectex", "filename": path})
    message = str(e.value)
    assert path in message and f"channel '{bad}'" in message, message


def test_rgb_variant_is_refused_in_one_line():
    mi.set_variant("scalar_rgb")
    with pytest.raises(spectex_mitsuba.SpectexError) as e:
        spectex_mitsuba.register()
    assert "not spectral" in str(e.value) and "\n" not in str(e.value)


# --- renders ------------------------------------------------------------------------------------

OBSERVER = read_csv(os.path.join(SPECTRAL, "observer_cie1931-2.csv"))
FINE = np.arange(360.0, 831.0)  # Mitsuba's wavelength range, 1 nm
CMF = np.stack([np.interp(FINE, OBSERVER["wavelength"], OBSERVER[c]) for c in "xyz"], axis=1)


def illuminant(name):
    s = read_csv(os.path.join(SPECTRAL, f"illuminant_{name}.csv"))
    return s["wavelength"], s["value"]


def reference_xyz(lams_file, spectra, light):
    """XYZ that Mitsuba's XYZ film estimates for a diffuse reflector under a uniform light:
    L = rho E (the cosine-weighted hemisphere integral of rho / pi), and the film's XYZ is
    integral(L xbar) / integral(ybar) over 360-830 nm. Reflectance linear between bins, ends held;
    the light linear between its samples and 0 outside them, as Mitsuba's `irregular` spectrum."""
    wl, val = light
    e = np.interp(FINE, wl, val, left=0.0, right=0.0)
    rho = np.array([np.interp(FINE, lams_file, s) for s in np.atleast_2d(spectra)])
    return (rho * e) @ CMF / CMF[:, 1].sum()


def render(exr, light, width=256, spp=64, texture=None, emitter=None):
    """`texture`: another reflectance texture (a dict) instead of the spectex one of `exr`;
    `emitter`: the scene's light as a dict (an emitter, or a shape carrying one) instead of a
    uniform `constant` light of the spectrum `light`."""
    use(JIT)
    if emitter is None:
        wl, val = light
        emitter = {"type": "constant", "radiance": {"type": "irregular",
                                                    "wavelengths": ",".join(f"{w:g}" for w in wl),
                                                    "values": ",".join(f"{v:.9g}" for v in val)}}
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct"},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 1], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": width, "height": width // 2, "pixel_format": "xyz",
                     "component_format": "float32", "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "light": emitter,
        "plane": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([1, 0.5, 1]),
                  "bsdf": {"type": "diffuse",
                           "reflectance": texture or {"type": "spectex", "filename": exr}}},
    })
    img = np.array(mi.render(scene, seed=1), dtype=np.float64)
    return img[::-1]  # Mitsuba's rectangle has v upwards; row 0 is now the texture's first row


def patches(img, margin=3):
    """Interior pixels of the 24 patches -> list of ((row, col), [n, 3])."""
    h, w = img.shape[:2]
    out = []
    for r in range(4):
        for c in range(6):
            y0, y1 = int(np.ceil(PATCH_Y[r] * h / 256)) + margin, int(PATCH_Y[r + 1] * h / 256) - margin
            x0, x1 = int(np.ceil(PATCH_X[c] * w / 512)) + margin, int(PATCH_X[c + 1] * w / 512) - margin
            out.append(((r, c), img[y0:y1, x0:x1].reshape(-1, 3)))
    return out


def patch_spectra(exr):
    lams_file, cube, _ = read_exr(exr)
    centres = [((PATCH_Y[r] + PATCH_Y[r + 1]) // 2, (PATCH_X[c] + PATCH_X[c + 1]) // 2)
               for r in range(4) for c in range(6)]
    return lams_file, np.array([cube[y, x] for y, x in centres])


@pytest.fixture(scope="module")
def renders(chart):
    out = {}
    for mode in ("rgb", "spectra"):
        for name in ("D65", "A", "FL11"):
            t = time.time()
            out[name if mode == "rgb" else (name, mode)] = render(
                chart, illuminant(name), texture={"type": "spectex", "filename": chart, "mode": mode})
            print(f"{name}, mode {mode}: rendered 256x128 at 64 spp in {time.time() - t:.2f} s")
    return out


@pytest.mark.parametrize("mode", ["rgb", "spectra"])
@pytest.mark.parametrize("light", ["D65", "A", "FL11"])
def test_rendered_patches_are_the_files_spectra_integrated(chart, renders, light, mode):
    """Both modes: the spectra held (spectra), and those rebuilt from RGB (rgb, the default)."""
    # 256x128 pixels at 64 spp: a patch interior is about 36 x 10 pixels. Bound: 5 standard
    # errors of the patch mean, from the per-pixel variance measured in that patch (pixels are
    # independent: independent sampler, 1-pixel box filter), plus 2e-4 of the white's Y for the
    # quadrature and CIE tables (Mitsuba's own, against config/spectral's 1 nm sum here).
    lams_file, spectra = patch_spectra(chart)
    want = reference_xyz(lams_file, spectra, illuminant(light))
    white_y = reference_xyz(lams_file, np.ones(len(lams_file)), illuminant(light))[0, 1]
    worst = 0.0
    for k, ((r, c), px) in enumerate(patches(renders[light if mode == "rgb" else (light, mode)])):
        mean = px.mean(axis=0)
        sem = px.std(axis=0, ddof=1) / np.sqrt(len(px))
        bound = 5 * sem + 2e-4 * white_y
        err = np.abs(mean - want[k])
        worst = max(worst, float(np.max(err / bound)))
        assert np.all(err <= bound), (light, r, c, mean, want[k], sem)
    print(f"{light}: worst |rendered - integrated| / bound = {worst:.2f}")


def srgb_encode(linear):
    linear = np.clip(linear, 0.0, 1.0)
    return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)


def srgb_decode(code):
    v = np.asarray(code, dtype=np.float64) / 255.0
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))


def test_d65_render_reencodes_to_the_png_codes(chart, renders):
    """XYZ -> linear sRGB with the sRGB primaries and the white of D65 as the render integrates it
    (the perfect reflector, same integral: a perfect white is exactly (1, 1, 1)), then the sRGB
    curve and 8 bits, against the PNG's codes: +-1 code, for the Monte-Carlo noise (a patch mean
    at 64 spp has 0.1-0.5 % noise: up to about half a code at the top, near a code in the sRGB toe).

    One exception, measured and explained rather than widened: the bake is exact for the sum over
    its 5 nm bins, while Mitsuba integrates the linearly interpolated spectrum continuously. That
    moves linear values by up to about 1e-3, invisible except where sRGB's toe magnifies it (12.92 x
    255 codes per unit): the zero channels of the saturated patches (the reference integral itself
    gives up to 3 codes there). Such a channel passes when the render is as far from the source's
    value as the noise-free integral of the file is, within 5 standard errors of the mean."""
    lams_file, spectra = patch_spectra(chart)
    light = illuminant("D65")
    white = reference_xyz(lams_file, np.ones(len(lams_file)), light)[0]
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    m = colour.RGB_Colourspace("sRGB, white of D65 as rendered", srgb.primaries,
                               colour.XYZ_to_xy(white)).matrix_XYZ_to_RGB
    exact = reference_xyz(lams_file, spectra, light) / white[1] @ m.T
    png = oiio.ImageBuf(CHART).get_pixels(oiio.UINT8)
    worst, by_quadrature = 0, []
    for k, ((r, c), px) in enumerate(patches(renders["D65"])):
        lin = px / white[1] @ m.T
        mean, sem = lin.mean(axis=0), lin.std(axis=0, ddof=1) / np.sqrt(len(lin))
        code = np.round(srgb_encode(mean) * 255).astype(int)
        src = png[(PATCH_Y[r] + PATCH_Y[r + 1]) // 2, (PATCH_X[c] + PATCH_X[c + 1]) // 2].astype(int)
        for ch in range(3):
            if abs(code[ch] - src[ch]) <= 1:
                worst = max(worst, abs(code[ch] - src[ch]))
                continue
            gap = abs(exact[k, ch] - srgb_decode(src[ch]))
            assert src[ch] < 16 and abs(mean[ch] - srgb_decode(src[ch])) <= gap + 5 * sem[ch], \
                (r, c, ch, code, src, mean, exact[k], sem)
            by_quadrature.append(f"patch {r},{c} channel {'RGB'[ch]}: {code[ch]} for {src[ch]}")
    print(f"D65: worst code difference {worst} on {72 - len(by_quadrature)} channels; "
          f"toe channels within the quadrature difference: {by_quadrature}")


def test_scalar_variant_renders_the_same(chart, renders):
    """scalar_spectral (one Python call per lookup, so a small film: 24x12 at 16 spp; 64 took 18 s)
    estimates the same XYZ. Bound: 5 standard errors, from the per-pixel standard deviation
    measured on the JIT render of the same patch (64 spp, the same scene), doubled for a scalar
    pixel's 16 spp (the deviation goes as one over the root of the samples), over the scalar
    pixels averaged, plus the same 2e-4 of the white's Y."""
    use("scalar_spectral")
    wl, val = illuminant("D65")
    spp, jit_spp = 16, 64
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "direct"},
        "sensor": {"type": "orthographic",
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 1], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 24, "height": 12, "pixel_format": "xyz",
                            "component_format": "float32", "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "light": {"type": "constant", "radiance": {"type": "irregular", "wavelengths": ",".join(f"{w:g}" for w in wl),
                                                   "values": ",".join(f"{v:.9g}" for v in val)}},
        "plane": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([1, 0.5, 1]),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "spectex", "filename": chart}}},
    })
    t = time.time()
    img = np.array(mi.render(scene, seed=2), dtype=np.float64)[::-1]
    print(f"scalar_spectral: 24x12 at {spp} spp in {time.time() - t:.2f} s")
    lams_file, spectra = patch_spectra(chart)
    want = reference_xyz(lams_file, spectra, illuminant("D65"))
    white_y = reference_xyz(lams_file, np.ones(len(lams_file)), illuminant("D65"))[0, 1]
    jit = dict(patches(renders["D65"]))
    # Film row 6 holds texture rows 128-149 (patch row 0), row 9 rows 192-213 (patch row 2); film
    # columns 4c .. 4c+3 lie inside patch column c; the two middle ones keep off the bilinear edge.
    for r, row in ((0, 6), (2, 9)):
        for c in range(6):
            px = img[row, 4 * c + 1:4 * c + 3]
            sigma = jit[(r, c)].std(axis=0, ddof=1) * np.sqrt(jit_spp / spp)
            bound = 5 * sigma / np.sqrt(len(px)) + 2e-4 * white_y
            assert np.all(np.abs(px.mean(axis=0) - want[6 * r + c]) <= bound), (r, c, px.mean(axis=0), want[6 * r + c])


@pytest.mark.parametrize("bit_depth", ["float16", "float32"])
def test_foreign_fichet_file_from_colour_science(tmp, bit_depth):
    """A Fichet 2021 file another tool wrote (colour-science's writer: its own channel order and
    header, no spectex attributes) is read the same way: linear in wavelength between its bins."""
    wl = np.arange(400.0, 701.0, 20.0)
    rng = np.random.default_rng(3)
    cube = rng.uniform(0.05, 0.95, (6, 8, len(wl)))
    path = os.path.join(tmp, f"foreign_{bit_depth}.exr")
    assert colour.io.write_spectral_image_Fichet2021({"T": (wl, cube)}, path, bit_depth)
    lams_file, stored, _ = read_exr(path)
    assert np.allclose(lams_file, wl)
    use(JIT)
    tex = mi.load_dict({"type": "spectex", "filename": path, "filter_type": "nearest", "wavelength_filter": "linear"})
    xy = np.stack([rng.integers(0, 8, 50), rng.integers(0, 6, 50)], axis=1)
    uv = (xy + 0.5) / [8, 6]
    lams = rng.uniform(380, 720, (50, 4))
    got = eval_texture(tex, uv, lams)
    want = np.array([np.interp(lams[k], lams_file, stored[xy[k, 1], xy[k, 0]]) for k in range(50)])
    # float32 arithmetic in the plugin against float64 here, as above.
    assert np.abs(got - want).max() < 2e-6


# --- the documented CIE lights (docs/mitsuba.md, "Tungsten and fluorescent light") ---------------

def python_blocks(page, heading=None):
    """The ```python blocks of a page, or of `heading`'s section (a KeyError if it is gone)."""
    text = open(os.path.join(SOURCE, page), encoding="utf-8").read()
    if heading:
        start = text.find("\n" + heading + "\n")
        if start < 0:
            raise KeyError(f"{page}: no section '{heading}'")
        end = text.find("\n## ", start + 1)
        text = text[start:end if end > 0 else None]
    return re.findall(r"```python\n(.*?)```", text, re.S)


def run_blocks(page, blocks, folder):
    """Run a page's blocks one after the other in `folder`, as a user's script -> its names."""
    ns = {"__name__": "documented"}
    here = os.getcwd()
    os.chdir(folder)
    try:
        t = time.time()
        for block in blocks:
            exec(compile(block, page, "exec"), ns)
        print(f"{page}: {len(blocks)} block(s) ran in {time.time() - t:.2f} s")
    finally:
        os.chdir(here)
    return ns


def spectrum_of(d):
    """An `irregular` spectrum dict -> (wavelengths, values)."""
    assert d["type"] == "irregular", d
    return (np.array([float(w) for w in d["wavelengths"].split(",")]),
            np.array([float(v) for v in d["values"].split(",")]))


@pytest.fixture(scope="module")
def documented_lights(tmp):
    """The page's block run as a user runs it, unchanged: in a folder holding albedo.exr (a flat
    orange 8x4 PNG baked with bake's defaults) and the spectex tree's config/ (a link)."""
    work = os.path.join(tmp, "documented_lights")
    os.makedirs(work)
    os.symlink(os.path.join(SOURCE, "config"), os.path.join(work, "config"))
    png = os.path.join(work, "albedo.png")
    out = oiio.ImageOutput.create(png)
    assert out.open(png, oiio.ImageSpec(8, 4, 3, oiio.UINT8))
    out.write_image(np.tile(np.array([230, 120, 40], dtype=np.uint8), (4, 8, 1)))
    out.close()
    exr = bake(png, os.path.join(work, "albedo.exr"))
    blocks = python_blocks("docs/mitsuba.md", "## Tungsten and fluorescent light")
    assert len(blocks) == 1, blocks
    return work, exr, run_blocks("docs/mitsuba.md", blocks, work)


def test_python_readme_lights_are_the_guides(documented_lights):
    """python/README.md's blocks, run in order as one script, build the same lights as the guide's
    (its copy of cie_light cannot drift from the tested one)."""
    work, _, ns = documented_lights
    readme = run_blocks("python/README.md", python_blocks("python/README.md"), work)
    assert readme["bsdf"]["reflectance"]["type"] == "spectex"
    assert readme["light"] == ns["scene_dict"]["light"]
    for key in ("type", "emitter"):
        assert readme["lamp"][key] == ns["lamp"][key], key
    assert np.array_equal(np.array(readme["lamp"]["to_world"].matrix), np.array(ns["lamp"]["to_world"].matrix))


def test_documented_lights_are_the_cie_tables(documented_lights):
    """The block's lights are the tables of config/spectral/ (read here with this file's own CSV
    reader) at every wavelength, scaled so that a white surface under them from every direction has
    Y = scale; and its two renders were written."""
    work, _, ns = documented_lights
    lamp_radiance = ns["lamp"]["emitter"]["radiance"]
    for spectrum, name, scale in ((ns["tungsten"], "A", 1.0), (lamp_radiance, "FL11", 4 * np.pi)):
        wl, val = spectrum_of(spectrum)
        table_wl, table_val = illuminant(name)
        assert np.array_equal(wl, table_wl), name
        ratio = val / table_val
        # one factor for every wavelength: the values are written with 9 significant digits, each
        # off by up to 5e-9 of itself, so two ratios differ by up to 1e-8
        assert np.ptp(ratio) <= 1e-8 * ratio.mean(), name
        # the white's Y with this file's reference integral (1 nm, the shipped CIE 1931 table)
        white_y = reference_xyz(table_wl, np.ones(len(table_wl)), (wl, val))[0, 1]
        assert abs(white_y - scale) <= 1e-6 * scale, (name, white_y)
    for name in ("albedo_A.exr", "albedo_FL11.exr"):
        img = np.array(mi.Bitmap(os.path.join(work, name)), dtype=np.float64)
        assert img.shape == (128, 256, 3) and np.isfinite(img).all() and img.mean() > 0, name
    # tungsten is orange: the A render's sky (its top rows, the light seen directly) has R > G > B
    sky = np.array(mi.Bitmap(os.path.join(work, "albedo_A.exr")), dtype=np.float64)[:8].reshape(-1, 3).mean(0)
    assert sky[0] > sky[1] > sky[2], sky


def test_documented_tungsten_renders_the_files_spectra(documented_lights):
    """The block's tungsten light on the test scene (orthographic, `direct`, XYZ film): the flat
    texture renders as its spectrum integrated under the table, and a white surface at Y = 1
    (Mitsuba's own CIE tables: the block's scaling holds in the renderer, not only here). Bounds as
    in test_rendered_patches_are_the_files_spectra_integrated: 5 standard errors of the mean over
    the interior pixels, plus 2e-4 of the white's Y for the quadrature and the CIE tables."""
    _, exr, ns = documented_lights
    light = spectrum_of(ns["tungsten"])
    lams_file, cube, _ = read_exr(exr)
    assert np.ptp(cube, axis=(0, 1)).max() == 0  # a flat texture: one spectrum
    want = reference_xyz(lams_file, cube[0, 0], light)[0]
    for texture, expected in ((None, want), ({"type": "uniform", "value": 1.0}, np.array([np.nan, 1.0, np.nan]))):
        img = render(exr, None, width=128, texture=texture, emitter=ns["scene_dict"]["light"])
        px = img[3:-3, 3:-3].reshape(-1, 3)
        mean, sem = px.mean(axis=0), px.std(axis=0, ddof=1) / np.sqrt(len(px))
        ok = ~np.isnan(expected)
        bound = 5 * sem + 2e-4
        print(f"tungsten, {'white' if texture else 'the file'}: |rendered - integrated| / bound = "
              f"{np.max((np.abs(mean - expected) / bound)[ok]):.2f}")
        assert np.all(np.abs(mean - expected)[ok] <= bound[ok]), (texture, mean, expected, sem)


def test_documented_lamp_lights_white_below_it_as_the_comment_says(documented_lights):
    """The block's fluorescent panel (1 x 1, 2 units up, radiance L) on the test scene: a diffuse
    surface right below it reflects rho L F, F the form factor of the square seen from its centre
    (4 quarters of side 0.25 h: 4/(2 pi) * 2 * x/sqrt(1+x^2) * atan(x/sqrt(1+x^2)), x = 0.25), so
    a white one renders at Y = 4 pi F = 0.92 with the block's scale, as its comment says. Checked
    on the pixels within 0.047 of the centre, where the irradiance falls by under 0.2 % (0.19 % at
    the window's corners, 0.06 % on average: 2e-3 of the value is added to the bound, beside 5
    standard errors and 2e-4 of the white's Y for the tables)."""
    _, exr, ns = documented_lights
    x = 0.25
    form_factor = 4 / (2 * np.pi) * 2 * x / np.sqrt(1 + x * x) * np.arctan(x / np.sqrt(1 + x * x))
    assert round(4 * np.pi * form_factor, 2) == 0.92  # the figure in the block's comment
    lams_file, cube, _ = read_exr(exr)
    light = spectrum_of(ns["lamp"]["emitter"]["radiance"])
    want = form_factor * reference_xyz(lams_file, cube[0, 0], light)[0]
    white_y = form_factor * reference_xyz(lams_file, np.ones(len(lams_file)), light)[0, 1]
    img = render(exr, None, width=256, emitter=ns["lamp"])  # 128 pixels a unit
    px = img[64 - 6:64 + 6, 128 - 6:128 + 6].reshape(-1, 3)  # within 6/128 of the centre
    mean, sem = px.mean(axis=0), px.std(axis=0, ddof=1) / np.sqrt(len(px))
    bound = 5 * sem + 2e-3 * want + 2e-4 * white_y
    print(f"lamp: |rendered - integrated| / bound = {np.max(np.abs(mean - want) / bound):.2f}")
    assert np.all(np.abs(mean - want) <= bound), (mean, want, sem)


@pytest.mark.parametrize("variant", ["scalar_spectral", JIT])
def test_a_wavelength_off_the_grid_reads_an_end_bin_and_nan_the_first(chart, variant):
    """A wavelength that is infinite or far outside the grid reads the end bin on its side (the end
    bins are held outside the grid), and NaN is read as 0 nm, below the grid: the first bin. In
    both modes, both wavelength filters and every filter in uv, a lookup stays a reflectance
    (before, the scalar variant's stochastic pick raised from floor(), and the linear filter
    returned NaN). Bound 1e-6: the same bin's value, read two ways."""
    use(variant)
    lams_file = read_exr(chart)[0]
    first, last = float(lams_file[0]), float(lams_file[-1])
    # Patch centres of the chart's bottom half: their spectra slope, so the two ends differ.
    uv = np.array([[(PATCH_X[c] + PATCH_X[c + 1]) / 1024, (PATCH_Y[r] + PATCH_Y[r + 1]) / 512]
                   for r in range(4) for c in range(6)])
    bad = [np.nan, np.inf, -np.inf, 1e30, -1e30, 3e38, 0.0]
    ends = [first, last, first, last, first, last, first]
    lams = np.array([[b, 550.0, b, 600.0] for b in bad for _ in uv])
    want_lams = np.array([[e, 550.0, e, 600.0] for e in ends for _ in uv])
    at = np.tile(uv, (len(bad), 1))
    for props, tex in textures(chart, mode=("rgb", "spectra"), wavelength_filter=("stochastic", "linear"),
                               filter_type=("bilinear", "nearest", "stochastic")):
        got = eval_texture(tex, at, lams)
        want = eval_texture(tex, at, want_lams)
        assert np.all(np.isfinite(got)), (props, got)
        assert np.abs(got - want).max() < 1e-6, (props, np.abs(got - want).max())
        assert np.abs(want[:, 0] - eval_texture(tex, at, np.full_like(lams, last))[:, 0]).max() > 0.05


@pytest.mark.parametrize("variant", ["scalar_spectral", JIT])
def test_a_coordinate_with_no_texel_is_read_as_0_in_every_filter(chart, variant):
    """NaN, an infinity, or a coordinate whose texel position overflows float32 (3e38 x 512) has no
    texel: it is read as 0, in both modes and every filter and wrap mode, so a lookup stays the
    reflectance at that coordinate (before, the scalar variants raised from floor() and aborted
    the render, and the bilinear JIT lookup returned NaN)."""
    use(variant)
    bad = [np.nan, np.inf, -np.inf, 3e38, -3e38]
    good = [0.3, 0.61]
    # Each bad value as u with a good v, and as v with a good u, then both bad.
    uv = np.array([(b, good[1]) for b in bad] + [(good[0], b) for b in bad] + [(b, b) for b in bad])
    want_uv = np.where(np.isfinite(uv) & (np.abs(uv) < 1e30), uv, 0.0)
    lams = np.tile([450.0, 520.0, 610.0, 680.0], (len(uv), 1))
    for props, tex in textures(chart, mode=("rgb", "spectra"), filter_type=("bilinear", "nearest", "stochastic"),
                               wrap_mode=("repeat", "mirror", "clamp")):
        got = eval_texture(tex, uv, lams)
        want = eval_texture(tex, want_uv, lams)
        assert np.all(np.isfinite(got)), (props, got)
        # The same texels and weights: equal to float32 rounding.
        assert np.abs(got - want).max() < 1e-6, props


def test_a_path_that_is_not_a_regular_file_is_refused_without_waiting(not_regular_files):
    """A FIFO held the scene's load until something wrote to it (a hang); a folder and a device
    are refused the same way, in one line naming the path and what it is, and so is
    read_spectral_exr. Each load runs in a child process with a deadline, so a hang fails the
    test instead of stalling the suite."""
    code = ("import sys, mitsuba as mi; mi.set_variant(sys.argv[1]); import spectex_mitsuba; "
            "spectex_mitsuba.register()\n"
            "try:\n    mi.load_dict({'type': 'spectex', 'filename': sys.argv[2], 'mode': sys.argv[3]})\n"
            "except Exception as e:\n    print(str(e).strip().splitlines()[-1])\n"
            "try:\n    spectex_mitsuba.read_spectral_exr(sys.argv[2])\n"
            "except Exception as e:\n    print(str(e).strip().splitlines()[-1])\n")
    for path, kind in not_regular_files:
        for variant, mode in (("scalar_spectral", "auto"), (JIT, "rgb"), (JIT, "spectra")):
            r = subprocess.run([sys.executable, "-c", code, variant, path, mode], capture_output=True, text=True,
                               timeout=60)
            lines = r.stdout.strip().splitlines()
            assert len(lines) == 2, (path, variant, r.stdout, r.stderr)
            for line in lines:
                assert f"{path}: a texture must be a regular file, not {kind}" in line, line


def test_a_scene_files_relative_path_is_found_from_the_scenes_folder(tmp, chart, monkeypatch):
    """As Mitsuba's `bitmap`: a texture's relative filename in a scene file is looked up from the
    scene's folder (the file resolver), not the working folder (it was refused as missing when the
    render ran from anywhere else)."""
    scene_dir = os.path.join(tmp, "scene")
    os.makedirs(os.path.join(scene_dir, "textures"), exist_ok=True)
    shutil.copy(chart, os.path.join(scene_dir, "textures", "chart.exr"))
    scene = os.path.join(scene_dir, "scene.xml")
    with open(scene, "w") as f:
        f.write('<scene version="3.0.0"><shape type="rectangle"><bsdf type="diffuse">'
                '<texture type="spectex" name="reflectance"><string name="filename" value="textures/chart.exr"/>'
                '</texture></bsdf></shape></scene>')
    elsewhere = os.path.join(tmp, "elsewhere")
    os.makedirs(elsewhere, exist_ok=True)
    monkeypatch.chdir(elsewhere)
    for variant in ("scalar_spectral", JIT):
        use(variant)
        text = str(mi.load_file(scene).shapes()[0].bsdf())  # the BSDF prints its texture's file
        assert os.path.join(scene_dir, "textures", "chart.exr") in text, text


@pytest.mark.parametrize("compression", ["zip", "rle"])
def test_a_damaged_file_loads_or_is_refused_naming_it_in_every_mode(tmp, compression):
    """Single bytes changed or the file cut anywhere (the plugin reads spectex's own files a strip
    at a time in both modes, other layouts through mi.Bitmap): each of 60 damaged copies of a
    small premultiplied bake either loads (deflate's and RLE's literal bytes carry no checksum)
    and every lookup is finite, or is refused with an error that names the file, in the "rgb",
    "spectra" and "auto" modes. A crash or hang would take the test process down."""
    use(JIT)
    src = bake(os.path.join(SOURCE, "examples", "textures", "leaf_rgba.png"),
               os.path.join(tmp, f"damage_src_{compression}.exr"), "--compression", compression)
    data = open(src, "rb").read()
    rng = np.random.default_rng(13)
    path = os.path.join(tmp, f"damaged_{compression}.exr")
    uv, wl = rng.random((256, 2)), rng.uniform(380, 780, (256, 4))
    loaded = refused = 0
    for trial in range(60):
        d = bytearray(data)
        if trial % 5 == 4:
            d = d[:int(rng.integers(len(d)))]
        else:
            for _ in range(int(rng.choice([1, 1, 3]))):
                d[int(rng.integers(len(d)))] = int(rng.integers(256))
        with open(path, "wb") as f:
            f.write(d)
        for mode in ("rgb", "spectra", "auto"):
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # a record set aside is worth a warning, not a failure
                    tex = mi.load_dict({"type": "spectex", "filename": path, "mode": mode})
            except Exception as e:  # SpectexError, or Mitsuba's RuntimeError holding its message
                assert path in str(e), (trial, mode, str(e)[-300:])
                refused += 1
                continue
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.uv = mi.Point2f(uv[:, 0], uv[:, 1])
            si.wavelengths = mi.Spectrum(*[mi.Float(wl[:, j]) for j in range(4)])
            assert np.all(np.isfinite(np.array(tex.eval(si)))), (trial, mode)
            loaded += 1
    assert refused > 0 and loaded > 0, (refused, loaded)
