"""Mitsuba 3 texture plugin for spectex's spectral reflectance OpenEXR files.

    import mitsuba as mi
    mi.set_variant("llvm_ad_spectral")     # or "scalar_spectral"
    import spectex_mitsuba
    spectex_mitsuba.register()             # registers the texture plugin "spectex" in this variant
    {"type": "spectex", "filename": "albedo.exr", "filter_type": "bilinear", "wrap_mode": "repeat"}

The file is any reflective spectral EXR in the layout of Fichet, Pacanowski & Wilkie (JCGT 2021):
channels ``T.<λ>nm`` (comma or point as the decimal separator), half or float, scanline, tiled or
MIP-mapped (only level 0 is read: Mitsuba filters it like its own ``bitmap`` texture, without
MIP-mapping).

``mode`` says what the texture holds:

- ``"rgb"``: for a bake that records how its spectra are rebuilt from RGB (the basis and the
  lattice: ``spectex:rebuild*``, rebuild.py), the record's table and, a texel, the basis 16 bytes
  (its linear RGB and alpha) and the lattice 8 (its place in the lattice, found once at load) and
  4 more for alpha when the file has it; the method is evaluated at the sampled wavelengths at
  lookup (rgb_mode.py).
  The file is read a strip at a time (exr_strips.py; tiled and other compressions through
  ``mi.Bitmap``). A file without a record, or whose record fails its checks, is refused.
- ``"spectra"``: every bin as the file holds it (half or float32), any file; read a strip at a time
  as in mode "rgb" (other layouts through ``mi.Bitmap``).
- ``"auto"`` (default): ``"rgb"`` when the file has a record, ``"spectra"`` otherwise; a record that
  fails its checks is set aside with a warning, never used.

``eval`` returns the reflectance at ``si.wavelengths`` (in mode "rgb", of the rebuilt bins, which
are the file's to within its own rounding). Between the file's bins (any grid, uniform or not;
the end bins' values held outside it), ``wavelength_filter`` ``"stochastic"`` (the default) reads
one of the two bins around a wavelength, the upper with probability its linear weight, by a hash of
uv, the wavelength's bits and the texture's ``seed`` (an integer; by default the CRC-32 of
``filename``, so two files pick independently): the linear filter on average over a pixel's
samples, at half its table reads (docs/mitsuba.md); ``"linear"`` interpolates. In uv: bilinear or nearest
with Mitsuba's ``bitmap`` conventions (``uv = (0, 0)`` is the first pixel of the first row,
texel centres at ``(x + 0.5) / width``; ``repeat``, ``mirror``, ``clamp``), or ``"stochastic"``:
one of the bilinear 4 texels picked by a hash of uv and ``seed`` with probability its weight (times its alpha
when premultiplied), the bilinear filter on average over a pixel's samples at the cost of one
texel (docs/mitsuba.md). A coordinate that is NaN or infinite, or whose texel position overflows
float32, is read as 0, and a wavelength that is NaN as 0 nm (the first bin), so a lookup always
returns a reflectance.

Alpha: an ``A`` channel means premultiplied (associated) spectra, OpenEXR's convention and what
``spectex bake`` writes by default, unless the header's ``spectex:alpha`` says ``unassociated``.
Premultiplied files are filtered premultiplied and divided by the filtered alpha (the reflectance
is 0 where alpha is 0), so ``eval`` always returns the straight reflectance. Alpha itself is not
applied: give it to Mitsuba's ``mask`` BSDF as the opacity.

Only the spectral variants (``scalar_spectral``, ``llvm_ad_spectral``, ``cuda_ad_spectral`` and
their ``_polarized`` forms) are supported; an RGB or mono variant is refused. The texture holds no
differentiable parameters.
"""
import ctypes
import hashlib
import math
import os
import re
import stat
import threading
import warnings
import weakref
import zlib

import numpy as np

from .rebuild import RebuildError
from . import rebuild as _rebuild
from . import rgb_mode as _rgb_mode
from .exr_strips import ExrDamaged, file_kind

__all__ = ["register", "SpectexTexture", "read_spectral_exr", "SpectexError", "RebuildError"]
__version__ = "0.1.0"

_T_CHANNEL = re.compile(r"^T\.([0-9]+(?:[.,][0-9]*)?(?:[eE][+-]?[0-9]+)?)nm$")
_WRAP_MODES = ("repeat", "mirror", "clamp")
_MODES = ("auto", "rgb", "spectra")
_FILTERS = ("bilinear", "nearest", "stochastic")
_WAVELENGTH_FILTERS = ("stochastic", "linear")
# The 6 Kuhn simplices of a lattice cell, as (the axis of the first step, of the second): a located
# texel records its simplex as its place in this list, a * 2 + b - (b > a).
_SIMPLICES = tuple((a, b) for a in range(3) for b in range(3) if a != b)


class SpectexError(ValueError):
    """A file or setting the plugin cannot use; the message names the file."""


def _mi():
    import mitsuba as mi
    return mi


def _check_variant():
    mi = _mi()
    variant = mi.variant()
    if variant is None:
        raise SpectexError("spectex texture: no Mitsuba variant is set; call mitsuba.set_variant('scalar_spectral') "
                           "or 'llvm_ad_spectral' first")
    if not mi.is_spectral:
        raise SpectexError(f"spectex texture: Mitsuba variant '{variant}' is not spectral; spectral textures need "
                           "a spectral variant such as 'scalar_spectral' or 'llvm_ad_spectral'")
    return mi, variant


def _spectral_channels(filename, names):
    """The reflectance channels among `names`: (wavelengths [N] float64 ascending, the index in
    `names` of each), refusing channels that name no wavelength and files without any."""
    bins = []
    for k, name in enumerate(names):
        if not (name.startswith("T.") and name.endswith("nm")):
            continue  # R, G, B, A and other layers
        # A reflectance channel whose wavelength is not a positive, finite number of nanometres
        # (T.-5nm, T.1e400nm, T.nm) is a damaged file: refused, never dropped or read as infinity.
        m = _T_CHANNEL.match(name)
        lam = float(m.group(1).replace(",", ".")) if m else float("nan")
        if not (math.isfinite(lam) and lam > 0):
            raise SpectexError(f"spectex texture: {filename}: channel '{name}' does not name a wavelength "
                               "(T.<positive nanometres>nm)")
        bins.append((lam, k, name))
    if not bins:
        shown = ", ".join(names[:8]) + (", ..." if len(names) > 8 else "")
        raise SpectexError(f"spectex texture: {filename}: no reflectance channels 'T.<wavelength>nm' (the file has "
                           f"{shown}); it is not a reflective spectral EXR (Fichet 2021 layout) such as "
                           "'spectex bake' writes")
    bins.sort()
    lams = np.array([b[0] for b in bins])
    if np.any(np.diff(lams) <= 0):
        dup = lams[1:][np.diff(lams) <= 0][0]
        raise SpectexError(f"spectex texture: {filename}: two channels name the wavelength {dup:g} nm")
    return lams, [b[1] for b in bins]


def _is_premultiplied(names, metadata):
    return "A" in names and metadata.get("spectex:alpha", "associated").strip() != "unassociated"


def _open_spectral_exr(filename):
    """Read a reflective spectral EXR with mi.Bitmap, without copying its pixels.

    Returns (wavelengths [N] float64 ascending, pixels [H, W, C] the bitmap's own samples (half or
    float), the channel index of each wavelength, the channel index of A or None, premultiplied
    bool, metadata dict of str, the bitmap that owns the pixels)."""
    mi = _mi()
    try:
        bitmap = mi.Bitmap(str(filename))
    except Exception as e:  # Mitsuba's message names the cause; ours names the file as given
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        if isinstance(e, MemoryError) or "bad_alloc" in first:  # sized from the header, before reading
            first = f"not enough memory for the pixels its header claims ({first})"
        raise SpectexError(f"spectex texture: {filename}: cannot read: {first}") from None
    names = [field.name for field in bitmap.struct_()]
    if len(names) != bitmap.channel_count():
        raise SpectexError(f"spectex texture: {filename}: unexpected channel list {names}")
    lams, index = _spectral_channels(filename, names)
    pixels = np.array(bitmap, copy=False)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    metadata = {}
    md = bitmap.metadata()
    for key in md.keys():
        try:
            metadata[key] = str(md[key])
        except Exception:
            pass
    alpha_index = names.index("A") if "A" in names else None
    return lams, pixels, index, alpha_index, _is_premultiplied(names, metadata), metadata, bitmap


# Rows converted at a time: a band of the file's samples in float32 is all the reading adds to the
# bitmap and the texture's own array (2048 texels x 81 bins x 64 rows: 42 MB).
_BAND_ROWS = 64


def _fill_spectra(filename, pixels, index, out):
    """Copies the reflectance channels of `pixels` ([H, W, C]) into `out` ([H, W, N] float32), a
    band of rows at a time; refuses NaN and Inf."""
    for y0 in range(0, pixels.shape[0], _BAND_ROWS):
        band = out[y0:y0 + _BAND_ROWS]
        band[...] = pixels[y0:y0 + _BAND_ROWS][:, :, index]
        if not np.all(np.isfinite(band)):
            raise SpectexError(f"spectex texture: {filename}: the reflectance channels hold NaN or Inf")


def read_spectral_exr(filename):
    """Read a reflective spectral EXR with mi.Bitmap.

    Returns (wavelengths [N] float64 ascending, T [H, W, N] float32, alpha [H, W] float32 or None,
    premultiplied bool, metadata dict of str)."""
    _check_regular_file(str(filename))  # the texture checks its file once, when it is made
    lams, pixels, index, a, premultiplied, metadata, bitmap = _open_spectral_exr(filename)
    cube = np.empty(pixels.shape[:2] + (len(index),), dtype=np.float32)
    _fill_spectra(filename, pixels, index, cube)
    alpha = np.ascontiguousarray(pixels[:, :, a], dtype=np.float32) if a is not None else None
    return lams, cube, alpha, premultiplied, metadata


_malloc_trim = None


def _give_back_freed_memory():
    """Returns to the system the heap memory a texture's load freed (strips, temporaries), which
    glibc keeps in the reader threads' arenas otherwise: 36 MB after a 1536^2 file of 31 bins in
    the spectra mode, 9 MB in the RGB mode. glibc's malloc_trim; nothing where there is none. About
    2 ms with a large heap: called after large loads only."""
    global _malloc_trim
    if _malloc_trim is None:
        try:
            _malloc_trim = ctypes.CDLL(None).malloc_trim
        except (OSError, AttributeError):
            _malloc_trim = False
    if _malloc_trim:
        _malloc_trim(0)


def _spectra_bands(filename):
    """The spectra mode's source: (wavelengths [N] float64 ascending, width, height, whether every
    reflectance channel is half, premultiplied, metadata dict of str, bands), bands yielding
    (first row, spectra [N, rows, W] float32 (each bin's samples contiguous), alpha [rows, W]
    float32 or None when not premultiplied). Read a strip at a time by exr_strips where it takes
    the file (scanline NONE, RLE, ZIPS, ZIP: what spectex writes), so that loading never holds the
    whole file; by mi.Bitmap otherwise (which decodes it whole first)."""
    reader = _rgb_mode.open_strips(filename)
    if reader is None:
        lams, pixels, index, a, premultiplied, metadata, bitmap = _open_spectral_exr(filename)
        premultiplied = a is not None and premultiplied

        def from_bitmap():
            for y0 in range(0, pixels.shape[0], _BAND_ROWS):
                band = pixels[y0:y0 + _BAND_ROWS]
                yield (y0, np.ascontiguousarray(np.moveaxis(band[:, :, index], 2, 0), dtype=np.float32),
                       np.asarray(band[:, :, a], dtype=np.float32) if premultiplied else None)

        return (lams, pixels.shape[1], pixels.shape[0], pixels.dtype == np.float16, premultiplied, metadata,
                from_bitmap())
    try:
        names = [c[0] for c in reader.channels]
        types = {c[0]: c[1] for c in reader.channels}
        metadata = {k: v for k, v in reader.attributes.items() if isinstance(v, str)}
        lams, index = _spectral_channels(filename, names)
        channels = [names[k] for k in index]
        premultiplied = _is_premultiplied(names, metadata)
        if premultiplied:
            channels.append("A")
        half = all(types[c] == 1 for c in channels[:len(lams)])
    except BaseException:
        reader.close()
        raise

    def from_strips():
        try:
            for y0, planes in reader.strips(channels, rows=_BAND_ROWS, planar=True):
                yield y0, planes[:len(lams)], planes[len(lams)] if premultiplied else None
        except ExrDamaged as e:
            raise SpectexError(f"spectex texture: {e}") from None
        finally:
            reader.close()

    return lams, reader.width, reader.height, half, premultiplied, metadata, from_strips()


def _jit_float_view(mi, n, kind=None):
    """A Dr.Jit array of n elements (kind: mi.Float, the default, or mi.UInt32 for words of two
    halves), not cleared, and a writeable NumPy view of its memory, or (None, None) where the
    backend gives copies (a GPU): the texture's spectra are then written into its own array once,
    without a NumPy array of them besides."""
    import drjit as dr

    data = dr.empty(kind or mi.Float, n)  # every element is written by the caller: not cleared first
    dr.eval(data)
    view = data.numpy()
    if view.flags["OWNDATA"] or not view.flags["WRITEABLE"] or n == 0:
        return None, None
    view[0] = 1.0  # a write through the view must be seen by Dr.Jit
    if float(data[0]) != 1.0:
        return None, None
    view[0] = 0.0
    return data, view


def _half_to_float(mi, dr, h):
    """IEEE half bit patterns (UInt32, below 2^16; no infinity or NaN: the texture refuses them) as
    float32, exactly: a normal half moves its exponent from bias 15 to 127 and its mantissa 13 bits
    up; a subnormal one (and zero) is its mantissa times 2^-24."""
    sign = (h & 0x8000) << 16
    magnitude = h & 0x7FFF
    normal = dr.reinterpret_array(mi.Float, ((magnitude << 13) + 0x38000000) | sign)
    small = mi.Float(magnitude) * 2.0 ** -24
    return dr.select(magnitude >= 0x400, normal, dr.select(sign != 0, -small, small))


def _wrap_index(i, n, mode, dr=None, Int=None):
    """Texel index i wrapped into [0, n) as Mitsuba's bitmap does (repeat, mirror, clamp)."""
    if dr is None:  # Python ints
        if mode == "clamp":
            return min(max(i, 0), n - 1)
        if mode == "repeat":
            return i % n
        m = i % (2 * n)
        return m if m < n else 2 * n - 1 - m
    if mode == "clamp":
        return dr.clip(i, 0, n - 1)
    # Python-style modulo for signed Dr.Jit integers: ((i % n) + n) % n
    if mode == "repeat":
        m = i % n
        return dr.select(m < 0, m + n, m)
    p = 2 * n
    m = i % p
    m = dr.select(m < 0, m + p, m)
    return dr.select(m < n, m, p - 1 - m)


def _resolve(mi, filename):
    """The file as Mitsuba's file resolver finds it, as its `bitmap` texture does: a scene file's
    relative path is relative to the scene's folder (mi.load_file adds it) and to the search paths,
    not to the working folder; a path it does not find is kept as given (and refused, naming it)."""
    resolver = getattr(mi, "file_resolver", None)
    try:
        resolver = resolver() if resolver is not None else mi.Thread.thread().file_resolver()
        return str(resolver.resolve(filename))
    except Exception:  # an older Mitsuba without a resolver in Python: the path as given
        return filename


def _check_regular_file(filename):
    """Raises SpectexError unless filename is a regular file (after links), before any reader opens
    it: a FIFO would hold the scene's load until something writes to it, and a device such as
    /dev/zero never ends. (The strips reader also opens without blocking and checks again.)"""
    try:
        mode = os.stat(filename).st_mode
    except OSError as e:
        raise SpectexError(f"spectex texture: {filename}: cannot read: {e.strerror or e}") from None
    if not stat.S_ISREG(mode):
        raise SpectexError(f"spectex texture: {filename}: a texture must be a regular file, not "
                           f"{file_kind(mode)}")


def _on_texture(x, n):
    """A texture coordinate as a lookup reads it: one that is not finite, or whose texel position
    x * n is not (in float32, as the JIT variants compute it), has no texel and is read as 0. A
    lookup then stays a reflectance, in every variant and filter, where Mitsuba's bilinear
    `bitmap` returns NaN (which a pixel filter spreads) and Python's floor() raises."""
    return x if math.isfinite(x) and abs(x) * n <= _FLOAT32_MAX else 0.0


_FLOAT32_MAX = 3.4028234663852886e38


def _mix32(h):
    """murmur3's 32-bit finaliser, every input bit moving every output bit (Python ints or Dr.Jit
    UInt32, which wraps by itself)."""
    h = ((h ^ (h >> 16)) * 0x85EBCA6B) & 0xFFFFFFFF
    h = ((h ^ (h >> 13)) * 0xC2B2AE35) & 0xFFFFFFFF
    return h ^ (h >> 16)


def _lookup_seed(ubits, vbits, salt):
    """A lookup's 32 hashed bits of its u and v (their float32 bits) and the texture's salt: the
    same for the BSDF's two evaluations at one point (its sample and its eval_pdf), so that both
    pick the same texel and bins; independent between textures of different salts, so that a BSDF
    multiplying two of them at one point gets the product of their filtered values on average."""
    return _mix32(_mix32(((ubits * 0x9E3779B1) & 0xFFFFFFFF) ^ vbits) ^ salt)


def _texture_salt(props, filename):
    """The texture's salt: its integer property 'seed' (any int, taken modulo 2^32), else the CRC-32
    of its filename as the scene gives it (the same file gets the same picks in both modes and in
    every render; two files pick independently)."""
    if "seed" in props:
        seed = props["seed"]
        if isinstance(seed, bool) or not isinstance(seed, int):
            raise SpectexError(f"spectex texture: {filename}: seed '{seed}' is not an integer")
        return seed & 0xFFFFFFFF
    return zlib.crc32(filename.encode("utf-8", "surrogateescape"))


def _pick_bits(ubits, vbits, salt):
    """filter_type "stochastic"'s 24 random bits for a lookup (times 2^-24: a number in [0, 1),
    exact in float32)."""
    return _lookup_seed(ubits, vbits, salt) >> 8


def _bin_bits(seed, lbits):
    """wavelength_filter "stochastic"'s 24 random bits for one of a lookup's wavelengths (lbits: its
    float32 bits): hashed again with the lookup's seed, so that they are independent of the texel's
    pick and of the other wavelengths'."""
    return _mix32(seed ^ lbits) >> 8


def _f32_bits(x):
    """The bits of x as float32 (rounded as Dr.Jit rounds it; past float32's range, infinity)."""
    with np.errstate(over="ignore"):
        return int(np.float32(x).view(np.uint32))


class SpectexTexture:
    """Placeholder replaced by the variant's class in register(); see _make_class."""


_classes = {}


class _SharedTables:
    """A lattice's or basis' tables as the lookups read them, shared by the textures of one table."""


# (variant, rule, size, bins, half, wavelength filter, digest of the table and breakpoints) -> the
# tables, while some texture holds them.
_SHARED_TABLES = weakref.WeakValueDictionary()
_SHARED_LOCK = threading.Lock()


def _make_class(mi):
    import drjit as dr

    scalar = mi.variant().startswith("scalar")

    class SpectexTexture(mi.Texture):
        """The "spectex" texture: spectral reflectance from a Fichet 2021 EXR (see the module doc)."""

        def __init__(self, props):
            mi.Texture.__init__(self, props)
            _check_variant()
            if "filename" not in props:
                raise SpectexError("spectex texture: the property 'filename' is required")
            self.filename = _resolve(mi, str(props["filename"]))
            _check_regular_file(self.filename)
            self._salt = _texture_salt(props, str(props["filename"]))
            self.filter_type = str(props["filter_type"]) if "filter_type" in props else "bilinear"
            self.wrap_mode = str(props["wrap_mode"]) if "wrap_mode" in props else "repeat"
            if self.filter_type not in _FILTERS:
                raise SpectexError(f"spectex texture: {self.filename}: filter_type '{self.filter_type}' is not one "
                                   f"of {', '.join(_FILTERS)}")
            self.wavelength_filter = str(props["wavelength_filter"]) if "wavelength_filter" in props \
                else "stochastic"
            if self.wavelength_filter not in _WAVELENGTH_FILTERS:
                raise SpectexError(f"spectex texture: {self.filename}: wavelength_filter '{self.wavelength_filter}' "
                                   f"is not one of {', '.join(_WAVELENGTH_FILTERS)}")
            if self.wrap_mode not in _WRAP_MODES:
                raise SpectexError(f"spectex texture: {self.filename}: wrap_mode '{self.wrap_mode}' is not one of "
                                   f"{', '.join(_WRAP_MODES)}")
            self.mode = str(props["mode"]) if "mode" in props else "auto"
            if self.mode not in _MODES:
                raise SpectexError(f"spectex texture: {self.filename}: mode '{self.mode}' is not one of "
                                   f"{', '.join(_MODES)}")
            self._rgb = None
            try:
                self._load()
            except BaseException:
                _give_back_freed_memory()
                raise
            if self.width * self.height * self.bins >= 1 << 21:  # not after each of many small ones
                _give_back_freed_memory()

        def _load(self):
            if self.mode != "spectra":
                try:
                    self._load_rgb()
                    return
                except RebuildError as e:
                    self._rgb = None  # whatever was set up is not used
                    if self.mode == "rgb":
                        raise SpectexError(f"spectex texture: {self.filename}: cannot hold it as RGB: {e}") from None
                    if "records no table" not in str(e):  # a record that is there but wrong is worth a word
                        warnings.warn(f"spectex texture: {self.filename}: {e}; holding every bin instead",
                                      stacklevel=2)
            self._load_spectra()

        def _load_spectra(self):
            self.holds = "spectra"
            lams, width, height, half, premultiplied, metadata, bands = _spectra_bands(self.filename)
            self.wavelengths_nm = lams
            self.metadata = metadata
            self.height, self.width = height, width
            self.bins = len(lams)
            self.premultiplied = premultiplied
            # The spectra once in memory: in the JIT variants straight into the Dr.Jit array the
            # texture evaluates (a view of its memory), a band of rows at a time as the file is
            # read. A half file's bins are held in half by the JIT variants, two to a 32-bit word
            # (the lookup widens them to float32 exactly, so every value is the same): half the
            # memory of float32. (Dr.Jit's own Float16 gathers made the render 1.4x slower.)
            self._half_bins = not scalar and half
            count = self.height * self.width * self.bins
            data = view = None
            if not scalar:
                if self._half_bins:
                    data, words = _jit_float_view(mi, (count + 1) // 2, mi.UInt32)
                    view = None
                    if words is not None:
                        words[-1:] = 0  # the last word's second half, when count is odd, is never read
                        view = words.view(np.float16)[:count]
                else:
                    data, view = _jit_float_view(mi, count)
            cube = view.reshape(self.height, self.width, self.bins) if view is not None else \
                np.empty((self.height, self.width, self.bins), dtype=np.float16 if self._half_bins else np.float32)
            alpha = np.empty((self.height, self.width), dtype=np.float32) if premultiplied else None
            # mean(): the mean over texels of the mean over Mitsuba's wavelength range (ends held),
            # and max(), both of the straight spectra, a band at a time.
            total = np.zeros(self.bins)
            self._max = 0.0
            for y0, planes, a_band in bands:
                rows = planes.shape[1]
                cube[y0:y0 + rows] = np.moveaxis(planes, 0, 2)
                if a_band is not None:
                    alpha[y0:y0 + rows] = a_band
                _, sums, top = _rgb_mode.straight_stats(self.filename, planes.reshape(self.bins, -1),
                                                        None if a_band is None else a_band.reshape(-1))
                total += sums.astype(np.float64)
                self._max = max(self._max, top)
            del bands  # the bitmap, when Mitsuba's reader read the file
            lo, hi = float(mi.MI_CIE_MIN), float(mi.MI_CIE_MAX)
            fine = np.linspace(lo, hi, int(round(hi - lo)) + 1)
            avg_spec = total / max(1, self.height * self.width)
            self._mean = float(np.interp(fine, lams, avg_spec).mean())
            self._alpha_np = alpha
            self._uniform = self.bins > 1 and np.allclose(np.diff(lams), lams[1] - lams[0], rtol=1e-6, atol=1e-9)
            if scalar:
                self._cube_np = cube
            else:
                self._cube_np = None  # the JIT variants evaluate self._data only
                if data is None and self._half_bins:
                    data = mi.UInt32(np.append(cube.reshape(-1), np.float16(0) if count % 2 else []).view(np.uint32))
                self._data = data if data is not None else mi.Float(cube.reshape(-1))
                del cube, view
                self._grid = mi.Float(lams.astype(np.float32))
                self._alpha = mi.Float(alpha.reshape(-1)) if alpha is not None else None

        def _load_rgb(self):
            def alloc(n):
                data = view = None
                if not scalar:
                    data, view = _jit_float_view(mi, n)
                if view is None:
                    view = np.empty(n, dtype=np.float32)
                return data, view

            t = _rgb_mode.load(self.filename, alloc)
            self.holds = "rgb"
            self._rgb = t
            self.wavelengths_nm = t.lams
            self.metadata = t.attrs
            self.height, self.width, self.bins = t.height, t.width, len(t.lams)
            self.premultiplied = t.premultiplied
            self._max = t.max
            lo, hi = float(mi.MI_CIE_MIN), float(mi.MI_CIE_MAX)
            fine = np.linspace(lo, hi, int(round(hi - lo)) + 1)
            self._mean = float(np.interp(fine, t.lams, t.mean_spectrum).mean())
            lams = t.lams
            self._uniform = self.bins > 1 and np.allclose(np.diff(lams), lams[1] - lams[0], rtol=1e-6, atol=1e-9)
            rec = t.record
            if scalar:
                return
            self._texels = t.data if t.data is not None else mi.Float(t.texels.reshape(-1))
            t.texels = t.data = None  # the Dr.Jit array is what is evaluated, and held once
            self._grid = mi.Float(lams.astype(np.float32))
            rows = rec.table.reshape(-1, self.bins).astype(np.float32)
            self._half_tables = rec.rule == "lattice" and t.half
            # The method's tables as the lookups read them are shared by every texture of the same
            # table, layout and variant: a scene of thousands of small textures baked alike holds
            # them once (0.76 MB for the default lattice, against 64 KB of texels at 64^2).
            key = (mi.variant(), rec.rule, rec.size if rec.rule == "lattice" else 0, self.bins,
                   self._half_tables, self.wavelength_filter,
                   hashlib.blake2b(rows.tobytes() + np.asarray(rec.axis if rec.rule == "lattice" else [],
                                                               dtype=np.float64).tobytes()).digest())
            with _SHARED_LOCK:
                shared = _SHARED_TABLES.get(key)
                if shared is None:
                    shared = _SHARED_TABLES[key] = self._method_tables(rec, rows, t.locator)
            self._shared = shared  # alive while a texture holds it (the cache holds it weakly)
            for name, value in vars(shared).items():
                setattr(self, name, value)
            rec.table = None  # the lookups read the shared tables only
            if rec.rule == "lattice":
                self._locate_texels()

        def _method_tables(self, rec, rows, loc):
            """The arrays a lookup reads besides the texels (_SharedTables: attributes of the same
            names as the texture's)."""
            out = _SharedTables()
            if self.wavelength_filter == "linear":
                # The table as pairs of neighbouring bins (k, k + 1), so that one gather reads both
                # values a wavelength between them needs.
                nxt = rows[:, np.minimum(np.arange(self.bins) + 1, self.bins - 1)]
                cols = max(1, self.bins - 1)
                out._pair_cols = cols
                pairs = np.stack([rows[:, :cols], nxt[:, :cols]], axis=-1)
                if rec.rule == "lattice":
                    out._ends, out._mids = self._simplex_tables(rec.size, pairs)
                else:
                    out._pairs = mi.Float(pairs.reshape(-1))
            elif rec.rule == "lattice":
                out._quads = self._quad_tables(rec.size, rows)
            else:
                out._rows = mi.Float(rows.reshape(-1))
            if rec.rule == "lattice":
                out._loc_m = loc.m
                out._loc_lut = mi.UInt32(loc.lut)
                out._loc_lower = mi.Float(loc.lower)
                out._loc_upper = mi.Float(loc.upper)
                out._loc_inv_gap = mi.Float(loc.inv_gap)
            dr.eval(*[v for v in vars(out).values() if not isinstance(v, int)])
            return out

        def _cells(self, n):
            """Each cell's low corner (its vertex index) and the index steps along r, g and b."""
            c = n - 1
            cells = np.arange(c ** 3)
            return ((cells // (c * c)) * n + (cells // c) % c) * n + cells % c, (n * n, n, 1)

        def _words(self, x):
            """The table's values [..., 4] as they are held: for a half file, 64-bit words of 4
            halves (a 64-bit gather costs about 1.25 32-bit ones where measured, docs/mitsuba.md);
            rounding the vertex spectra to half moves them by at most 2^-11 of their value (2^-25
            below 2^-14), within the file's own rounding (at most 10 bits kept). A float file's stay
            float32."""
            if not self._half_tables:
                return mi.Float(x.reshape(-1))
            h = x.astype(np.float16).view(np.uint16).astype(np.uint64)
            return mi.UInt64((h[..., 0] | h[..., 1] << np.uint64(16) | h[..., 2] << np.uint64(32)
                              | h[..., 3] << np.uint64(48)).reshape(-1))

        def _simplex_tables(self, n, pairs):
            """wavelength_filter "linear": the lattice's table arranged so that a texel reads its 4
            vertices at a bin pair in two gathers: `_ends` holds each cell's low and high corner (v0
            and v3, which every simplex of the cell has), `_mids` each of its 6 simplices' other two
            (v1, v2), both [.., bin pair, 4 values] (_words): a lookup reads its table in 32
            gathers, not 64. 0.86 MB for the default 9^3 lattice at 31 bins in half; at most 6 MB
            (12 MB in float) for any lattice a record holds (2^17 values)."""
            v0, step = self._cells(n)
            ends = np.concatenate([pairs[v0], pairs[v0 + n * n + n + 1]], axis=-1)  # [cell, bin, 4]
            mids = np.stack([np.concatenate([pairs[v0 + step[a]], pairs[v0 + step[a] + step[b]]], axis=-1)
                             for a, b in _SIMPLICES], axis=1)  # [cell, simplex, bin, 4]
            return self._words(ends), self._words(mids)

        def _quad_tables(self, n, rows):
            """wavelength_filter "stochastic": each simplex's 4 vertices (v0 to v3) at each bin in one
            entry (_words), [cell, simplex, bin, 4]: a texel reads one word a wavelength, 16 gathers a
            lookup. 0.76 MB for the default 9^3 lattice at 31 bins in half; under 6.3 MB (12.6 MB in
            float) for any lattice a record holds (2^17 values)."""
            v0, step = self._cells(n)
            quads = np.stack([np.stack([rows[v0], rows[v0 + step[a]], rows[v0 + step[a] + step[b]],
                                        rows[v0 + n * n + n + 1]], axis=-1)
                              for a, b in _SIMPLICES], axis=1)
            return self._words(quads)

        # -- sampling positions ------------------------------------------------------------------
        def _corners_scalar(self, u, v):
            w, h, mode = self.width, self.height, self.wrap_mode
            u, v = _on_texture(u, w), _on_texture(v, h)
            if self.filter_type == "nearest":
                x, y = math.floor(u * w), math.floor(v * h)
                return [(_wrap_index(x, w, mode), _wrap_index(y, h, mode), 1.0)]
            x, y = u * w - 0.5, v * h - 0.5
            x0, y0 = math.floor(x), math.floor(y)
            fx, fy = x - x0, y - y0
            out = []
            for dy, wy in ((0, 1 - fy), (1, fy)):
                for dx, wx in ((0, 1 - fx), (1, fx)):
                    out.append((_wrap_index(x0 + dx, w, mode), _wrap_index(y0 + dy, h, mode), wx * wy))
            if self.filter_type == "stochastic":
                bits = [_f32_bits(c) for c in (u, v)]
                p = [wgt * (self._alpha_scalar(x, y) if self.premultiplied else 1.0) for x, y, wgt in out]
                r = _pick_bits(*bits, self._salt) * 2.0 ** -24 * sum(p)
                total = 0.0
                for (x, y, _), pk in zip(out[:3], p[:3]):
                    total += pk
                    if r < total:
                        return [(x, y, 1.0)]
                return [out[3][:2] + (1.0,)]
            return out

        def _alpha_scalar(self, x, y):
            if self._rgb is not None:
                return float(self._rgb.texels[y, x][3])
            return float(self._alpha_np[y, x])

        def _alpha_jit(self, texel, active):
            """A premultiplied file's alpha at a texel (the basis holds it in its texel)."""
            if self._rgb is not None and self._rgb.record.rule == "basis":
                return dr.gather(mi.Float, self._texels, texel * 4 + 3, active)
            return dr.gather(mi.Float, self._alpha, texel, active)

        def _corners(self, uv, active):
            """The texels a lookup blends, with their weights: Mitsuba's bilinear or nearest, or
            ("stochastic") one of the bilinear 4 with weight 1, picked with probability its
            bilinear weight (times its alpha in a premultiplied file) by a hash of uv. Its
            expectation over a pixel's samples is then the bilinear filter's value, blended as
            spectra (premultiplied, then divided by the blended alpha) whatever the method, at
            the cost of one texel."""
            corners = self._corners_jit(uv)
            if self.filter_type != "stochastic":
                return corners
            p = [wgt * self._alpha_jit(texel, active) if self.premultiplied else wgt for texel, wgt in corners]
            r = mi.Float(self._seed_jit(uv) >> 8) * 2.0 ** -24 * (p[0] + p[1] + p[2] + p[3])
            # The last texel whose cumulative sum is still above r, going down: a texel of weight 0
            # is never picked (the sums are the same floats in the same order as the total).
            texel = corners[3][0]
            cum = [p[0], p[0] + p[1], p[0] + p[1] + p[2]]
            for k in (2, 1, 0):
                texel = dr.select(r < cum[k], corners[k][0], texel)
            return [(texel, mi.Float(1.0))]

        def _texture_uv(self, uv):
            """_on_texture: a coordinate with no texel position is read as 0."""
            return mi.Point2f(*(dr.select(dr.isfinite(x * n), x, 0.0) for x, n in zip(uv, (self.width, self.height))))

        def _seed_jit(self, uv):
            return _lookup_seed(dr.reinterpret_array(mi.UInt32, uv.x), dr.reinterpret_array(mi.UInt32, uv.y),
                                self._salt)

        def _corners_jit(self, uv):
            Int = mi.Int32
            w, h, mode = self.width, self.height, self.wrap_mode
            if self.filter_type == "nearest":
                x = Int(dr.floor(uv.x * w))
                y = Int(dr.floor(uv.y * h))
                xi = _wrap_index(x, w, mode, dr, Int)
                yi = _wrap_index(y, h, mode, dr, Int)
                return [(mi.UInt32(yi * w + xi), mi.Float(1.0))]
            x = uv.x * w - 0.5
            y = uv.y * h - 0.5
            x0f, y0f = dr.floor(x), dr.floor(y)
            fx, fy = x - x0f, y - y0f
            x0, y0 = Int(x0f), Int(y0f)
            xs = [_wrap_index(x0, w, mode, dr, Int), _wrap_index(x0 + 1, w, mode, dr, Int)]
            ys = [_wrap_index(y0, h, mode, dr, Int), _wrap_index(y0 + 1, h, mode, dr, Int)]
            out = []
            for dy, wy in ((0, 1 - fy), (1, fy)):
                for dx, wx in ((0, 1 - fx), (1, fx)):
                    out.append((mi.UInt32(ys[dy] * w + xs[dx]), wx * wy))
            return out

        # -- wavelength lookup -------------------------------------------------------------------
        def _bin_jit(self, lam):
            """Lower bin index i (so that i + 1 is valid) and the weight t of bin i + 1. A wavelength
            that is NaN is read as 0 nm, below the grid (the first bin), so that a lookup stays a
            reflectance in every filter; an infinite one is past an end, as any other."""
            n = self.bins
            if n == 1:
                return mi.UInt32(0), mi.Float(0.0)
            lam = dr.select(dr.isnan(lam), 0.0, lam)
            lams = self.wavelengths_nm
            if self._uniform:
                step = float(lams[1] - lams[0])
                pos = (lam - float(lams[0])) / step
                i = mi.UInt32(dr.clip(dr.floor(pos), 0, n - 2))
                t = dr.clip(pos - mi.Float(i), 0.0, 1.0)
                return i, t
            # Non-uniform grid: i = the last bin whose wavelength is <= lam, found by bisection.
            i = dr.binary_search(0, n - 1, lambda k: dr.gather(mi.Float, self._grid, k) <= lam)
            i = dr.clip(mi.UInt32(i), 1, n - 1) - 1
            l0 = dr.gather(mi.Float, self._grid, i)
            l1 = dr.gather(mi.Float, self._grid, i + 1)
            t = dr.clip((lam - l0) / (l1 - l0), 0.0, 1.0)
            return i, t

        def _bin_pick_jit(self, lam, seed):
            """wavelength_filter "stochastic": the bin read at a wavelength, i + 1 with probability t
            and i otherwise (_bin_jit's i and t), by a hash of the lookup's uv and the wavelength's
            bits. Its expectation is the linear filter's value at every wavelength."""
            i, t = self._bin_jit(lam)
            if self.bins == 1:
                return i
            r = mi.Float(_bin_bits(seed, dr.reinterpret_array(mi.UInt32, lam))) * 2.0 ** -24
            return dr.select(r < t, i + 1, i)

        def _wavelengths_jit(self, si, uv):
            """Each sampled wavelength as the lookup reads it: (i, t) for the linear filter, the bin
            picked for the stochastic one."""
            lams = [si.wavelengths[j] for j in range(len(si.wavelengths))]
            if self.wavelength_filter == "linear":
                return [self._bin_jit(lam) for lam in lams]
            seed = self._seed_jit(uv)
            return [self._bin_pick_jit(lam, seed) for lam in lams]

        def _bin_value(self, index, active):
            """Mode "spectra": a bin of a texel (index: texel * bins + bin) as float32."""
            if not self._half_bins:
                return dr.gather(mi.Float, self._data, index, active)
            word = dr.gather(mi.UInt32, self._data, index >> 1, active)
            return _half_to_float(mi, dr, (word >> ((index & 1) << 4)) & 0xFFFF)

        # -- Texture interface -------------------------------------------------------------------
        def eval(self, si, active=True):
            if self._rgb is not None:
                return self._eval_rgb_scalar(si) if scalar else self._eval_rgb_jit(si, active)
            if scalar:
                return self._eval_scalar(si)
            uv = self._texture_uv(si.uv)
            corners = self._corners(uv, active)
            n, step = self.bins, min(1, self.bins - 1)
            values = []
            for at in self._wavelengths_jit(si, uv):
                acc = mi.Float(0.0)
                for texel, wgt in corners:
                    if self.wavelength_filter == "linear":
                        i, t = at
                        a = self._bin_value(texel * n + i, active)
                        b = self._bin_value(texel * n + i + step, active)
                        acc += wgt * dr.lerp(a, b, t)
                    else:
                        acc += wgt * self._bin_value(texel * n + at, active)
                values.append(acc)
            spec = mi.UnpolarizedSpectrum(*values)
            if self._alpha is not None:
                alpha = mi.Float(0.0)
                for texel, wgt in corners:
                    alpha += wgt * self._alpha_jit(texel, active)
                spec = dr.select(alpha > 0, spec / dr.select(alpha > 0, alpha, 1.0), 0.0)
            return spec

        # -- the RGB mode: the method evaluated at the sampled wavelengths -------------------------
        def _locate_jit(self, rgb):
            """Each colour's Kuhn simplex in the lattice (rebuild.py): its cell (index over the
            cells, (r * c + g) * c + b with c = size - 1), the axes of its first two steps (a, b: 0
            red, 1 green, 2 blue) and the local coordinates sorted, ta >= tb >= tc."""
            cell, frac = [], []
            for x in rgb:
                x = dr.clip(x, 0.0, 1.0)  # RGB integrated from finite spectra: never NaN
                i = dr.gather(mi.UInt32, self._loc_lut, mi.UInt32(dr.minimum(x * self._loc_m, self._loc_m - 1)))
                i = dr.select(x >= dr.gather(mi.Float, self._loc_upper, i), i + 1, i)
                t = (x - dr.gather(mi.Float, self._loc_lower, i)) * dr.gather(mi.Float, self._loc_inv_gap, i)
                cell.append(i)
                frac.append(dr.clip(t, 0.0, 1.0))
            ta, tb, tc = frac
            a, b, c = mi.UInt32(0), mi.UInt32(1), mi.UInt32(2)

            def order(hi, lo, ahi, alo):  # (larger, smaller) with their axes; ties keep r, g, b
                swap = hi < lo
                return (dr.select(swap, lo, hi), dr.select(swap, hi, lo),
                        dr.select(swap, alo, ahi), dr.select(swap, ahi, alo))

            ta, tb, a, b = order(ta, tb, a, b)
            tb, tc, b, c = order(tb, tc, b, c)
            ta, tb, a, b = order(ta, tb, a, b)
            n = self._rgb.record.size - 1
            return (cell[0] * n + cell[1]) * n + cell[2], a, b, ta, tb, tc

        def _texel_bits(self):
            """A located texel's 64 bits: its simplex (cell * 6 + its place in _SIMPLICES) in the
            top `row` bits, and below it its three sorted coordinates in `q` bits each: 17 for the
            9^3 lattice, 14 for the largest a record can hold. The rebuilt spectrum is S(v0) plus
            each coordinate times the step between two of its vertices (values in [0, 1]), so a
            coordinate rounded to 2^-(q+1) moves it by at most 3 * 2^-(q+1): 1.1e-5 at 17 bits."""
            c = self._rgb.record.size - 1
            row = max(1, (6 * c ** 3 - 1).bit_length())
            return row, (64 - row) // 3

        def _locate_texels(self):
            """Replaces each texel's RGB by its place in the lattice, once, a million texels at a
            time: 8 bytes (_texel_bits); alpha moves to an array of its own. A lookup then reads one
            64-bit word and no breakpoints. Written into a new array: the RGB one was filled
            through a NumPy view, and Dr.Jit copies such an array whole before a scatter into it
            (a second copy that stayed)."""
            count = self.width * self.height
            rgb = self._texels
            if self.premultiplied:
                self._alpha = dr.gather(mi.Float, rgb, dr.arange(mi.UInt32, count) * 4 + 3)
                dr.eval(self._alpha)
            located = dr.empty(mi.UInt64, count)
            _, q = self._texel_bits()
            top = float((1 << q) - 1)

            def chunk(start, stop):  # its temporaries go with it
                idx = dr.arange(mi.UInt32, start, stop)
                tv = dr.gather(mi.Vector4f, rgb, idx)
                cell, a, b, ta, tb, tc = self._locate_jit([tv.x, tv.y, tv.z])
                row = cell * 6 + a * 2 + b - dr.select(b > a, mi.UInt32(1), mi.UInt32(0))
                # Rounding keeps ta >= tb >= tc, so the weights stay >= 0 and sum to 1.
                bits = mi.UInt64(row) << (3 * q)
                for k, t in enumerate((ta, tb, tc)):
                    bits |= mi.UInt64(mi.UInt32(dr.round(t * top))) << (k * q)
                dr.scatter(located, bits, idx)
                dr.eval(located)

            for start in range(0, count, 1 << 20):
                chunk(start, min(count, start + (1 << 20)))
            self._texels = located
            del rgb
            dr.flush_malloc_cache()  # the RGB array and the chunks' temporaries

        def _simplex_of(self, bits):
            """The simplex (cell * 6 + place) and barycentric weights of a located texel's bits."""
            _, q = self._texel_bits()
            mask = (1 << q) - 1
            ta, tb, tc = (mi.Float(mi.UInt32((bits >> (k * q)) & mask)) * (1.0 / mask) for k in range(3))
            return mi.UInt32(bits >> (3 * q)), (1.0 - ta, ta - tb, tb - tc, tc)

        def _eval_rgb_jit(self, si, active):
            rec = self._rgb.record
            uv = self._texture_uv(si.uv)
            corners = self._corners(uv, active)
            at = self._wavelengths_jit(si, uv)
            linear = self.wavelength_filter == "linear"
            weights, texels = [], []
            alpha = mi.Float(0.0)
            for texel, wgt in corners:
                texels.append(dr.gather(mi.Vector4f if rec.rule == "basis" else mi.UInt64, self._texels, texel,
                                        active))
                if self.premultiplied:  # the basis' texel holds alpha; the lattice's has it apart
                    wgt = wgt * (texels[-1].w if rec.rule == "basis" else self._alpha_jit(texel, active))
                    alpha += wgt
                weights.append(wgt)
            if rec.rule == "basis":
                r = sum(w * tv.x for w, tv in zip(weights, texels))
                g = sum(w * tv.y for w, tv in zip(weights, texels))
                b = sum(w * tv.z for w, tv in zip(weights, texels))

                def table(k, a):  # row k of the table at the wavelength as read
                    if linear:
                        pair = dr.gather(mi.Point2f, self._pairs, k * self._pair_cols + a[0], active)
                        return dr.lerp(pair.x, pair.y, a[1])
                    return dr.gather(mi.Float, self._rows, k * self.bins + a, active)
                values = [r * table(0, a) + g * table(1, a) + b * table(2, a) for a in at]
            else:
                values = self._lattice_jit(weights, texels, at, active)
            spec = mi.UnpolarizedSpectrum(*values)
            if self.premultiplied:
                spec = dr.select(alpha > 0, spec / dr.select(alpha > 0, alpha, 1.0), 0.0)
            return spec

        def _lattice_jit(self, weights, texels, at, active):
            """The lattice's spectra of the located texels, blended with their weights, at each
            wavelength as read (_wavelengths_jit)."""
            linear = self.wavelength_filter == "linear"
            cols = self._pair_cols if linear else self.bins
            if self._half_tables:
                # A half's bits moved to a float's place are its value times 2^-112 (no sign: the
                # lattice's spectra are in [0, 1]); the weight carries the 2^112 instead (one product
                # per texel and vertex, not per wavelength), so each product is of the value's own
                # size and never flushed to zero as one below 2^-126 would be.
                unit = 5.192296858534828e33

                def halves(u):
                    return (dr.reinterpret_array(mi.Float, (u & 0x7FFF) << 13),
                            dr.reinterpret_array(mi.Float, (u >> 3) & (0x7FFF << 13)))

                def split(word):  # a word's 4 halves, lowest first
                    return halves(mi.UInt32(word & 0xFFFFFFFF)) + halves(mi.UInt32(word >> 32))
            else:
                unit = 1.0
            if linear:
                # Lerp last: sum_v w_v lerp(lo_v, hi_v, t) = lerp(sum_v w_v lo_v, sum_v w_v hi_v, t),
                # two FMAs a vertex (5-6 % faster a render than a lerp per vertex, alternating runs
                # of tests/bench/mitsuba_speed.py).
                if self._half_tables:
                    def vertices(simplex, i):  # the 4 vertices' (lo, hi) at bin pair i, v0 to v3
                        e = split(dr.gather(mi.UInt64, self._ends, (simplex // 6) * cols + i, active))
                        m = split(dr.gather(mi.UInt64, self._mids, simplex * cols + i, active))
                        return [(e[0], e[1]), (m[0], m[1]), (m[2], m[3]), (e[2], e[3])]
                else:
                    def vertices(simplex, i):
                        e = dr.gather(mi.Vector4f, self._ends, (simplex // 6) * cols + i, active)
                        m = dr.gather(mi.Vector4f, self._mids, simplex * cols + i, active)
                        return [(e.x, e.y), (m.x, m.y), (m.z, m.w), (e.z, e.w)]
                lo_sum = [mi.Float(0.0) for _ in at]
                hi_sum = [mi.Float(0.0) for _ in at]
                for wgt, bits in zip(weights, texels):
                    simplex, ws = self._simplex_of(bits)
                    ws = [wgt * unit * w for w in ws]
                    for j, (i, t) in enumerate(at):
                        for w, (lo, hi) in zip(ws, vertices(simplex, i)):
                            lo_sum[j] = dr.fma(w, lo, lo_sum[j])
                            hi_sum[j] = dr.fma(w, hi, hi_sum[j])
                return [dr.lerp(lo, hi, t) for lo, hi, (i, t) in zip(lo_sum, hi_sum, at)]
            # One bin a wavelength: the simplex's 4 vertices there in one word (or 4 floats).
            if self._half_tables:
                def vertices(simplex, k):
                    return split(dr.gather(mi.UInt64, self._quads, simplex * cols + k, active))
            else:
                def vertices(simplex, k):
                    q = dr.gather(mi.Vector4f, self._quads, simplex * cols + k, active)
                    return q.x, q.y, q.z, q.w
            sums = [mi.Float(0.0) for _ in at]
            for wgt, bits in zip(weights, texels):
                simplex, ws = self._simplex_of(bits)
                ws = [wgt * unit * w for w in ws]
                for j, k in enumerate(at):
                    for w, value in zip(ws, vertices(simplex, k)):
                        sums[j] = dr.fma(w, value, sums[j])
            return sums

        def _eval_rgb_scalar(self, si):
            t = self._rgb
            spec = np.zeros(self.bins)
            alpha = 0.0
            for x, y, wgt in self._corners_scalar(float(si.uv[0]), float(si.uv[1])):
                texel = t.texels[y, x]
                if self.premultiplied:
                    wgt *= float(texel[3])
                    alpha += wgt
                spec += wgt * _rebuild.rebuild(t.record, texel[:3])
            out = self._at_wavelengths_scalar(spec, si)
            if self.premultiplied:
                out = out / alpha if alpha > 0 else np.zeros_like(out)
            return mi.UnpolarizedSpectrum(*[float(o) for o in out])

        def _at_wavelengths_scalar(self, spec, si):
            """A blended spectrum [bins] at the sampled wavelengths, as _wavelengths_jit reads it
            (its bins and weights in float32, so that the stochastic filter picks the bin the JIT
            variants pick)."""
            lams = [float(si.wavelengths[j]) for j in range(len(si.wavelengths))]
            if self.bins == 1:
                return np.full(len(lams), spec[0])
            if self.wavelength_filter == "linear":  # NaN: 0 nm, as _bin_jit reads it
                return np.interp([0.0 if math.isnan(lam) else lam for lam in lams], self.wavelengths_nm, spec)
            f32, n = np.float32, self.bins
            grid = self.wavelengths_nm.astype(np.float32)
            seed = _lookup_seed(*(_f32_bits(_on_texture(float(c), size))
                                  for c, size in zip(si.uv, (self.width, self.height))), self._salt)
            out = []
            for lam in lams:
                bits = _f32_bits(lam)
                with np.errstate(over="ignore", invalid="ignore"):
                    lam32 = f32(0.0 if math.isnan(lam) else lam)
                    if self._uniform:
                        lams_nm = self.wavelengths_nm
                        pos = (lam32 - f32(lams_nm[0])) / f32(lams_nm[1] - lams_nm[0])
                        i = int(min(max(math.floor(min(max(pos, -1.0), float(n))), 0), n - 2))
                        t = pos - f32(i)
                    else:
                        # dr.binary_search over [0, n - 1]: the first bin above lam, n - 1 at most.
                        i = min(max(int(np.searchsorted(grid[:n - 1], lam32, side="right")), 1), n - 1) - 1
                        t = (lam32 - grid[i]) / (grid[i + 1] - grid[i])
                t = min(max(float(t), 0.0), 1.0)
                r = _bin_bits(seed, bits) * 2.0 ** -24
                out.append(spec[i + 1] if r < t else spec[i])
            return np.array(out)

        def _eval_scalar(self, si):
            spec = np.zeros(self.bins)
            alpha = 0.0
            for x, y, wgt in self._corners_scalar(float(si.uv[0]), float(si.uv[1])):
                spec += wgt * self._cube_np[y, x]
                if self._alpha_np is not None:
                    alpha += wgt * self._alpha_scalar(x, y)
            out = self._at_wavelengths_scalar(spec, si)
            if self._alpha_np is not None:
                out = out / alpha if alpha > 0 else np.zeros_like(out)
            return mi.UnpolarizedSpectrum(*[float(o) for o in out])

        def eval_1(self, si, active=True):
            # A scalar view of the reflectance: its mean over the sampled wavelengths.
            return dr.mean(self.eval(si, active)) if not scalar else float(np.mean(np.array(self.eval(si, active))))

        def mean(self):
            return self._mean

        def max(self):
            return self._max

        def is_spatially_varying(self):
            return True

        def resolution(self):
            return mi.ScalarVector2i(self.width, self.height)

        def spectral_resolution(self):
            return float(np.min(np.diff(self.wavelengths_nm))) if self.bins > 1 else 0.0

        def to_string(self):
            return (f"SpectexTexture[filename='{self.filename}', holds {self.holds}, {self.width}x{self.height}, "
                    f"{self.bins} bins "
                    f"{self.wavelengths_nm[0]:g}-{self.wavelengths_nm[-1]:g} nm, filter_type={self.filter_type}, "
                    f"wavelength_filter={self.wavelength_filter}, wrap_mode={self.wrap_mode}, seed={self._salt}, "
                    f"alpha={'premultiplied' if self.premultiplied else 'none/straight'}]")

        def __repr__(self):
            return self.to_string()

    return SpectexTexture


def register(name="spectex"):
    """Register the texture plugin `name` ("spectex") in the current Mitsuba variant.

    Raises SpectexError with one line in a variant that is not spectral."""
    global SpectexTexture
    mi, variant = _check_variant()
    cls = _classes.get(variant)
    if cls is None:
        cls = _classes[variant] = _make_class(mi)
    SpectexTexture = cls
    mi.register_texture(name, lambda props: cls(props))
    return cls
