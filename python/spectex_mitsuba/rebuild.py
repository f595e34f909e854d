"""Rebuilding a spectex file's spectra from RGB: the reference evaluation, in plain NumPy.

A spectex bake of the basis or the lattice records in its header what its spectra are a function
of (docs/file-format.md, "Rebuilding spectra from RGB"): the rule, the lattice's breakpoints, the
weights that integrate a spectrum to the linear RGB it was made from, and the table of spectra
(in the file's sample type, differenced along each spectrum, in byte planes, deflated, base64),
with a CRC-32 over them. A renderer can then hold three numbers a texel instead of every bin::

    record = parse_record(header)              # the header's string attributes; None: no record
    rgb = file_rgb(record, spectra)            # [..., bins] -> [..., 3] linear RGB
    again = rebuild(record, rgb)               # [..., 3] -> [..., bins], the method's spectra

`again` is the file's spectra to within the file's own rounding (its half bits) and the table's
(a half file's table is in half: 2^-11 of each vertex value, 2^-25 below 2^-14): the file holds the method's spectrum
of each texel's colour, rounded. Needs NumPy and zlib only (no Mitsuba), so that another
renderer's pipeline can test its own implementation against it.
"""
import base64
import zlib

import numpy as np

RULES = ("basis", "lattice")
# A table larger than the writer ever records (2^17 values, src/io/rebuild_record.h) is refused
# before it is decoded: a header is not a place for hostile megabytes.
TABLE_LIMIT = 1 << 17
# spectex:rebuildTableEncoding: bytes a value, the bit patterns' type, the values' type. A record
# without one is an earlier spectex's: base64 of little-endian float32, as they are.
ENCODINGS = {"half-delta-zlib": (2, np.uint16, np.float16), "float-delta-zlib": (4, np.uint32, np.float32)}


class RebuildError(ValueError):
    """The header's record is damaged, tampered with or of a rule this reader does not know."""


class RebuildRecord:
    def __init__(self, rule, lams, to_rgb, table, axis):
        self.rule, self.lams, self.to_rgb, self.table, self.axis = rule, lams, to_rgb, table, axis
        self.bins = len(lams)

    @property
    def size(self):
        """Breakpoints per axis of the lattice (0 for the basis)."""
        return len(self.axis)


def _numbers(text, what):
    try:
        v = np.array(text.split(), dtype=np.float64)
    except ValueError:
        raise RebuildError(f"{what} holds something that is not a number") from None
    if not np.all(np.isfinite(v)):
        raise RebuildError(f"{what} holds NaN or infinity")
    return v


TABLE_ATTR = "spectex:rebuildTable"  # the table's text: the largest attribute of a record


def parse_record(attrs):
    """The record of a header (a mapping of attribute name to string), or None when the file has
    none (Jakob-Hanika, a bake by an older spectex, another tool's file). Raises RebuildError when
    the record is there but cannot be trusted: a checksum that does not match, a rule this reader
    does not know, sizes that disagree."""
    rule = attrs.get("spectex:rebuild")
    if rule is None:
        return None
    texts = [str(rule)] + [str(attrs.get(k, "")) for k in (
        "spectex:rebuildAxis", "spectex:rebuildToRgb", "spectex:rebuildTable", "spectex:wavelengthList")]
    encoding = attrs.get("spectex:rebuildTableEncoding")
    if encoding is not None:
        texts.append(str(encoding))
    # Deflate never grows data by more than 5 bytes a 16 KiB block and 6 a stream.
    if len(texts[3]) > (TABLE_LIMIT * 4 * 1.001 + 64) // 3 * 4 + 4:
        raise RebuildError("spectex:rebuildTable is larger than any spectex writes")
    crc = zlib.crc32("".join(t + "\n" for t in texts).encode("utf-8"))
    if str(attrs.get("spectex:rebuildChecksum", "")) != f"crc32:{crc:08x}":
        raise RebuildError("spectex:rebuildChecksum does not match the record (damaged or edited)")
    if rule not in RULES:
        raise RebuildError(f"spectex:rebuild names the rule '{rule}', which this reader does not know")
    if encoding is not None and encoding not in ENCODINGS:
        raise RebuildError(f"spectex:rebuildTableEncoding names '{encoding}', which this reader does not know")
    lams = _numbers(texts[4], "spectex:wavelengthList")
    to_rgb = _numbers(texts[2], "spectex:rebuildToRgb")
    axis = _numbers(texts[1], "spectex:rebuildAxis")
    bins = len(lams)
    if bins == 0 or to_rgb.size != 3 * bins:
        raise RebuildError("spectex:rebuildToRgb does not fit the file's bins")
    if rule == "basis":
        if axis.size:
            raise RebuildError("the basis has no breakpoints")
        count = 3 * bins
    else:
        n = axis.size
        if n < 2 or axis[0] != 0 or axis[-1] != 1 or np.any(np.diff(axis) <= 0):
            raise RebuildError("the lattice's breakpoints do not fit (0 = first < ... < last = 1)")
        count = n ** 3 * bins
    if count > TABLE_LIMIT:
        raise RebuildError("spectex:rebuildTable is larger than any spectex writes")
    table = _table(texts[3], encoding, count, bins)
    if not np.all(np.isfinite(table)):
        raise RebuildError("spectex:rebuildTable holds NaN or infinity")
    return RebuildRecord(rule, lams, to_rgb.reshape(3, bins), table, axis)


def _table(text, encoding, count, row):
    """The table's count values (float32) from the attribute's text; row: values a spectrum."""
    try:
        data = base64.b64decode(text, validate=True)
    except ValueError:
        raise RebuildError("spectex:rebuildTable is not base64") from None
    if encoding is None:
        if len(data) != 4 * count:
            raise RebuildError("spectex:rebuildTable does not hold the float32 values its record needs")
        return np.frombuffer(data, dtype="<f4").astype(np.float32)
    size, bits, values = ENCODINGS[encoding]
    z = zlib.decompressobj()
    try:
        raw = z.decompress(data, size * count + 1)  # never more than a whole table: no inflate bomb
    except zlib.error:
        raise RebuildError("spectex:rebuildTable is not a zlib stream") from None
    if len(raw) != size * count or not z.eof or z.unused_data:
        raise RebuildError("spectex:rebuildTable does not hold the values its record needs")
    planes = np.frombuffer(raw, dtype=np.uint8).reshape(size, count).astype(np.uint64)
    diffs = sum(planes[b] << np.uint64(8 * b) for b in range(size)).reshape(-1, row)
    mask = np.uint64((1 << (8 * size)) - 1)
    return (np.cumsum(diffs, axis=1) & mask).astype(bits).view(values).astype(np.float32).reshape(-1)


def file_rgb(record, spectra):
    """Linear RGB of spectra [..., bins] under the conditions the method is exact for."""
    return np.asarray(spectra, dtype=np.float64) @ record.to_rgb.T


def rebuild(record, rgb):
    """The method's spectra [..., bins] of linear RGB [..., 3], in float64."""
    rgb = np.asarray(rgb, dtype=np.float64)
    bins = record.bins
    if record.rule == "basis":  # linear: RGB as it is, out of [0, 1] too
        return rgb @ record.table.reshape(3, bins).astype(np.float64)
    axis, n = record.axis, record.size
    x = np.clip(np.nan_to_num(rgb, nan=0.0), 0.0, 1.0)
    i = np.clip(np.searchsorted(axis, x, side="right") - 1, 0, n - 2)  # axis[i] <= x < axis[i + 1]
    t = np.clip((x - axis[i]) / (axis[i + 1] - axis[i]), 0.0, 1.0)
    # Kuhn simplex: from the cell's low corner, one step along each axis in order of decreasing t
    # (ties keep the order r, g, b); weights 1 - t_a, t_a - t_b, t_b - t_c, t_c.
    order = np.argsort(-t, axis=-1, kind="stable")
    ts = np.take_along_axis(t, order, axis=-1)
    step = np.array([n * n, n, 1])[order]
    v0 = (i[..., 0] * n + i[..., 1]) * n + i[..., 2]
    v1 = v0 + step[..., 0]
    v2 = v1 + step[..., 1]
    v3 = v2 + step[..., 2]
    w = (1.0 - ts[..., 0], ts[..., 0] - ts[..., 1], ts[..., 1] - ts[..., 2], ts[..., 2])
    T = record.table.reshape(n ** 3, bins).astype(np.float64)
    return sum(wk[..., None] * T[vk] for wk, vk in zip(w, (v0, v1, v2, v3)))
