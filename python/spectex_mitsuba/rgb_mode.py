"""The plugin's RGB mode: a spectex file held at the cost of an RGB texture.

A bake of the basis or the lattice records how its spectra are rebuilt from RGB (rebuild.py). The
texture then streams the file's spectral channels a strip at a time, integrates each texel back to
the linear RGB its spectrum was made from (float32, 16 bytes a texel with alpha), and keeps the
record's table and: for the basis, that RGB and alpha; for the lattice, 8 bytes, the RGB located
in the lattice once, at load (its simplex and its three sorted local coordinates: a lookup then
reads no breakpoints, about a quarter faster), and alpha beside it when the file has one.
Mitsuba's own spectral ``bitmap`` keeps three float32 coefficients. float16 colours would add
2^-11 of the colour, which the lattice's slope in its darkest cells multiplies beyond the file's
own rounding; the local coordinates are kept to 2^-18 of the cell instead, whatever its size.
Peak memory while loading is one strip of the file's samples, never the whole file, and the RGB.

Before it is trusted, the record must match its CRC-32 and the file's channels, and the spectra
it rebuilds must be the file's on every 4th texel of one row in 64 (within four steps of each
bin's kept bits and 0.001; the largest difference measured on bakes is two steps): a table taken
from another file, a file whose pixels were scaled or colour-corrected by a tool that kept the
header, is refused.
"""
import math

import numpy as np

from . import rebuild as _rebuild
from .exr_strips import ExrDamaged, ExrStrips, ExrUnsupported

STRIP_ROWS = 64
# Two steps of the kept bits is the largest difference between the file's spectra and the rebuilt
# ones measured on bakes (the colour-aware rounding moves a bin to a farther neighbour at times);
# four steps and 0.001 leave room for that and for the RGB recovered from rounded spectra.
CHECK_STEPS, CHECK_ABS = 4.0, 1e-3


class RgbTexels:
    """What the RGB mode holds: RGB (and alpha) per texel, the record, the spectra's mean and max."""

    def __init__(self):
        self.width = self.height = 0
        self.lams = None
        self.record = None
        self.premultiplied = False
        self.stride = 4  # floats per texel: r, g, b and a (1 when not premultiplied): one packet
        self.data = None  # the owner of the texel array (a Dr.Jit Float, or a NumPy array)
        self.texels = None  # [H, W, stride] float32 view
        self.mean_spectrum = None
        self.max = 0.0
        self.reader = ""
        self.half = False  # the file's spectral samples are half
        self.attrs = {}
        self.locator = None  # the lattice's AxisLocator


def _kept_bits(attrs, bins, sample_bits):
    text = str(attrs.get("spectex:precisionBits", "")).split()
    if len(text) == bins:
        try:
            return np.array([int(b) for b in text], dtype=np.float64)
        except ValueError:
            pass
    return np.full(bins, float(sample_bits))


def _check_rows(filename, record, spectra, rgb, alpha, bits):
    """Raises RebuildError unless rebuild(rgb) (times alpha) is `spectra` within the tolerance."""
    again = _rebuild.rebuild(record, rgb)
    if alpha is not None:
        again = again * alpha[:, None]
    file = spectra.astype(np.float64)
    big = np.maximum(np.maximum(np.abs(again), np.abs(file)), 2.0 ** -14)
    step = 2.0 ** (np.floor(np.log2(big)) - bits)
    bad = np.abs(again - file) > CHECK_STEPS * step + CHECK_ABS
    if np.any(bad):
        worst = float(np.max(np.abs(again - file)))
        raise _rebuild.RebuildError(
            f"the spectra it rebuilds are not the file's (off by up to {worst:.3g}): the pixels or the "
            "table were changed after the bake")


def _bitmap_source(filename):
    """The fallback reader (tiled, MIP-mapped or otherwise compressed files): mi.Bitmap holds the
    whole file while the strips are made from it."""
    from . import _open_spectral_exr

    lams, pixels, index, a, premultiplied, metadata, bitmap = _open_spectral_exr(filename)
    names = [f.name for f in bitmap.struct_()]
    sample_bits = 10 if pixels.dtype == np.float16 else 23

    def strips(channels):
        pick = [names.index(c) for c in channels]
        for y0 in range(0, pixels.shape[0], STRIP_ROWS):
            yield y0, np.ascontiguousarray(np.moveaxis(pixels[y0:y0 + STRIP_ROWS][:, :, pick], 2, 0),
                                           dtype=np.float32)

    return names, metadata, pixels.shape[1], pixels.shape[0], sample_bits, strips


def open_strips(filename):
    """An ExrStrips reader of the file, or None where it does not take the file (Mitsuba's reader
    decides then: it reads more layouts, and names what is wrong); SpectexError when the file
    cannot be opened at all."""
    from . import SpectexError

    try:
        return ExrStrips(filename)
    except (ExrUnsupported, ExrDamaged):
        return None
    except OSError as e:
        raise SpectexError(f"spectex texture: {filename}: cannot read: {e.strerror or e}") from None


def straight_stats(filename, spectra, alpha):
    """A band's straight (un-premultiplied) spectra summed: (1 / alpha where alpha > 0, else 0, as
    float32, or None without alpha; each bin's sum over the band's texels [N]; the largest value),
    without making the straight spectra. spectra: [N, texels] float32, alpha: [texels] or None.
    SpectexError naming the file when any sample or alpha is NaN or infinite (a NaN or an infinity
    anywhere reaches its bin's sum)."""
    from . import SpectexError

    inv = None
    if alpha is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(alpha > 0, 1.0 / alpha, 0.0).astype(np.float32)
        sums = spectra @ inv
        top = float(np.max(spectra.max(axis=0) * inv)) if inv.size else 0.0
    else:
        sums = spectra @ np.ones(spectra.shape[1], dtype=np.float32)  # BLAS: 10x a float64 sum
        top = float(spectra.max()) if spectra.size else 0.0
    if not (np.all(np.isfinite(sums)) and math.isfinite(top)) or \
            (alpha is not None and not np.all(np.isfinite(alpha))):
        raise SpectexError(f"spectex texture: {filename}: the reflectance channels hold NaN or Inf")
    return inv, sums, top


def load(filename, alloc):
    """Loads `filename` in the RGB mode, or raises RebuildError (no usable record: the caller holds
    the bins instead, or refuses) or SpectexError (the file cannot be read at all).

    alloc(n) -> (owner, float32 NumPy view of n writable elements): where the texels go."""
    from . import SpectexError, _is_premultiplied, _spectral_channels

    t = RgbTexels()
    reader = open_strips(filename)
    try:
        if reader is not None:
            names = [c[0] for c in reader.channels]
            attrs = {k: v for k, v in reader.attributes.items() if isinstance(v, str)}
            width, height = reader.width, reader.height
            types = {c[0]: c[1] for c in reader.channels}
            t.reader = "strips"
        else:
            names, attrs, width, height, sample_bits, bitmap_strips = _bitmap_source(filename)
            t.reader = "mi.Bitmap"
        record = _rebuild.parse_record(attrs)
        if record is None:
            raise _rebuild.RebuildError("the file records no table to rebuild its spectra from (a Jakob-Hanika "
                                        "bake, an older spectex, another tool's file)")
        if record.rule == "lattice":  # before any pixel is read: breakpoints no table needs are refused
            t.locator = AxisLocator(record.axis)
        lams, index = _spectral_channels(filename, names)
        if len(lams) != record.bins or np.max(np.abs(lams - record.lams)) > 1e-6:
            raise _rebuild.RebuildError("the record's wavelengths are not the file's channels (channels were "
                                        "added or removed after the bake)")
        channels = [names[k] for k in index]
        premultiplied = _is_premultiplied(names, attrs)
        if premultiplied:
            channels.append("A")
        if reader is not None:
            sample_bits = 10 if all(types[c] == 1 for c in channels[:record.bins]) else 23
            strips = reader.strips(channels, rows=STRIP_ROWS, planar=True)
        else:
            strips = bitmap_strips(channels)
        bits = _kept_bits(attrs, record.bins, sample_bits)
        t.half = sample_bits == 10
        if t.half and record.rule == "lattice":
            # Held in half (within a half file's own rounding): the JIT variants pack it four halves
            # to a 64-bit word, and the scalar variants and the check use the same numbers.
            record.table = record.table.astype(np.float16).astype(np.float32)
        # The file's string attributes but the table's text (32 KB for the default lattice), which
        # the record holds decoded: a scene of thousands of small textures keeps no copy of it.
        t.attrs = {k: v for k, v in attrs.items() if k != _rebuild.TABLE_ATTR}
        t.width, t.height, t.lams, t.record, t.premultiplied = width, height, lams, record, premultiplied
        t.data, view = alloc(width * height * t.stride)
        t.texels = view.reshape(height, width, t.stride)
        total = np.zeros(record.bins)
        to_rgb = record.to_rgb.astype(np.float32)
        sample = []
        for y0, planes in strips:
            # planes: [channels, rows, width], each channel's samples contiguous.
            rows = planes.shape[1]
            spectra = planes[:record.bins].reshape(record.bins, -1)
            alpha = planes[record.bins].reshape(-1) if premultiplied else None
            out = t.texels[y0:y0 + rows].reshape(-1, t.stride)
            rgb = to_rgb @ spectra  # [3, texels]
            inv, sums, top = straight_stats(filename, spectra, alpha)
            if alpha is not None:
                rgb *= inv
                out[:, 3] = alpha
            else:
                out[:, 3] = 1.0
            out[:, :3] = rgb.T
            total += sums.astype(np.float64)
            t.max = max(t.max, top)
            # Every 4th texel of one row of each strip (a different row each time) is rebuilt and
            # compared: a table that is not this file's is wrong nearly everywhere.
            r = (y0 // STRIP_ROWS * 37) % rows
            sl = slice(r * width + (y0 // STRIP_ROWS) % 4, (r + 1) * width, 4)
            sample.append((spectra[:, sl].T.copy(), rgb[:, sl].T.astype(np.float64),
                           None if alpha is None else alpha[sl].copy()))
        if sample:  # checked at once: one call of the reference, not one a strip
            _check_rows(filename, record, np.concatenate([x[0] for x in sample]),
                        np.concatenate([x[1] for x in sample]),
                        np.concatenate([x[2] for x in sample]) if premultiplied else None, bits)
        t.mean_spectrum = total / max(1, width * height)
        return t
    except ExrDamaged as e:
        raise SpectexError(f"spectex texture: {e}") from None
    finally:
        if reader is not None:
            reader.close()


class AxisLocator:
    """The lattice's cell of a value without a search: a table over [0, 1] of M buckets (a power of
    two, so x * M is exact), each holding at most one breakpoint, gives the cell or the one before
    it, which one comparison settles. The same cells as rebuild.rebuild's search."""

    def __init__(self, axis):
        axis = np.asarray(axis, dtype=np.float64)
        n = len(axis)
        gap = float(np.min(np.diff(axis)))
        m = 1 << max(1, math.ceil(math.log2(2.0 / gap)))
        if m > 1 << 20:
            raise _rebuild.RebuildError("the lattice's breakpoints are closer than 2^-19")
        self.m = m
        self.lut = np.clip(np.searchsorted(axis, np.arange(m) / m, side="right") - 1, 0, n - 2).astype(np.uint32)
        self.lower = axis[:-1].astype(np.float32)
        self.upper = np.append(axis[1:-1], np.inf).astype(np.float32)  # the last cell takes x = 1
        self.inv_gap = (1.0 / np.diff(axis)).astype(np.float32)
