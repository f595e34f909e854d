"""Strip-at-a-time reader of single-part scanline OpenEXR files, in pure Python and NumPy.

It reads what spectex writes by default, so that the Mitsuba plugin can stream a large
multichannel texture (2048x2048 x 81 half channels is 680 MB as float32) a band of rows at a
time instead of holding the whole image:

- single-part scanline files (version 2, with or without long names);
- channels of type UINT, HALF and FLOAT with x/y sampling 1, all returned as float32 (UINT by
  value, as OpenEXR's own conversion does, not normalised as OpenImageIO does);
- compression NONE, RLE, ZIPS and ZIP; any line order (chunks are found by their y).

It refuses, with ExrUnsupported, what a caller should hand to a full reader instead: tiled,
multi-part and deep files, sub-sampled channels and the other compressions (PIZ, PXR24, B44,
B44A, DWAA, DWAB, HTJ2K...). A file that is not a readable EXR (bad magic, truncated, a header
or offset table that does not add up, a chunk that does not inflate to its exact size) raises
ExrDamaged naming the file; no other exception type escapes for a bad file (OSError aside, for
a file that cannot be opened or read).

Memory: the header and offset table, plus the strips in flight (the one being yielded and the
one being decoded) and the few chunks being decompressed. Nothing larger than the
header-declared image is ever allocated, and the header's sizes are checked against what the
file's bytes can possibly hold before anything is allocated.
"""
import array
import collections
import concurrent.futures
import errno
import os
import stat
import struct
import threading
import zlib

import numpy as np

__all__ = ["ExrStrips", "ExrUnsupported", "ExrDamaged"]


class ExrUnsupported(Exception):
    """The file is a valid-looking EXR this reader does not stream (tiled, multi-part, deep, a
    compression other than NONE/RLE/ZIPS/ZIP, ...); the caller falls back to another reader.
    Message says why."""


class ExrDamaged(ValueError):
    """The file is not a readable EXR (truncated, bad magic, bad header, chunk out of bounds,
    decompression failure). Message names the file and the cause."""


MAGIC = 20000630
FLAG_TILED, FLAG_LONG_NAMES, FLAG_NON_IMAGE, FLAG_MULTIPART = 0x200, 0x400, 0x800, 0x1000
KNOWN_FLAGS = FLAG_TILED | FLAG_LONG_NAMES | FLAG_NON_IMAGE | FLAG_MULTIPART

NONE, RLE, ZIPS, ZIP = 0, 1, 2, 3
COMPRESSION_NAMES = {0: "NONE", 1: "RLE", 2: "ZIPS", 3: "ZIP", 4: "PIZ", 5: "PXR24", 6: "B44",
                     7: "B44A", 8: "DWAA", 9: "DWAB", 10: "HTJ2K256", 11: "HTJ2K32"}
ROWS_PER_CHUNK = {NONE: 1, RLE: 1, ZIPS: 1, ZIP: 16}

UINT, HALF, FLOAT = 0, 1, 2
SAMPLE_BYTES = {UINT: 4, HALF: 2, FLOAT: 4}
SAMPLE_DTYPE = {UINT: np.dtype("<u4"), HALF: np.dtype("<f2"), FLOAT: np.dtype("<f4")}

# Attribute names are at most 255 bytes with the long-names flag, 31 without; files written
# without the flag but with longer names exist, so 255 is accepted either way.
MAX_NAME = 255
# No chunk of a real file inflates more than deflate's limit (about 1032:1) or RLE's (128 bytes
# from 2, 64:1); a header claiming more than its chunks can hold is refused before allocating.
MAX_ZIP_RATIO, MAX_RLE_RATIO = 1040, 64
# A strip is refused beyond this many samples (8 GB of float32): a caller's mistake or a
# hostile header, never a texture.
MAX_STRIP_SAMPLES = 1 << 31
# Work per thread-pool task: chunks are grouped up to about this many uncompressed bytes so
# that one-row chunks (NONE, RLE, ZIPS) do not cost a task each.
TASK_BYTES = 1 << 20

_I32, _U64, _CHUNK_HEAD = struct.Struct("<i"), struct.Struct("<Q"), struct.Struct("<ii")


class _Header:
    """Reads the header through a growing buffer, so that a file is never read whole and a
    truncated one is reported as such rather than as an IndexError."""

    def __init__(self, fd, path, file_size):
        self.fd, self.path, self.file_size = fd, path, file_size
        self.buf, self.pos = bytearray(), 0

    def _need(self, n):
        end = self.pos + n
        if end > self.file_size:
            raise ExrDamaged(f"{self.path}: truncated header (needs byte {end}, "
                             f"file has {self.file_size})")
        while len(self.buf) < end:
            want = max(end - len(self.buf), 1 << 16)
            got = _pread(self.fd, min(want, self.file_size - len(self.buf)), len(self.buf))
            if not got:
                raise ExrDamaged(f"{self.path}: file shrank while reading its header")
            self.buf += got

    def take(self, n):
        self._need(n)
        out = bytes(self.buf[self.pos:self.pos + n])
        self.pos += n
        return out

    def name(self, what):
        """A null-terminated name of 0 to MAX_NAME bytes."""
        avail = min(MAX_NAME + 1, self.file_size - self.pos)
        self._need(max(avail, 1))
        end = self.buf.find(b"\0", self.pos, self.pos + avail)
        if end < 0:
            if avail < MAX_NAME + 1:
                raise ExrDamaged(f"{self.path}: truncated header (in a {what})")
            raise ExrDamaged(f"{self.path}: {what} longer than {MAX_NAME} bytes or not "
                             "terminated")
        raw = bytes(self.buf[self.pos:end])
        self.pos = end + 1
        return raw.decode("utf-8", "replace")


def _decode_chlist(value, path):
    """[(name, pixel_type, p_linear, x_sampling, y_sampling)] in file order."""
    out, pos = [], 0
    while True:
        end = value.find(b"\0", pos)
        if end < 0:
            raise ExrDamaged(f"{path}: channel list not terminated")
        if end == pos:  # the empty name ends the list
            if end != len(value) - 1:
                raise ExrDamaged(f"{path}: bytes after the end of the channel list")
            return out
        if end - pos > MAX_NAME:
            raise ExrDamaged(f"{path}: channel name longer than {MAX_NAME} bytes")
        name = value[pos:end].decode("utf-8", "replace")
        if end + 17 > len(value):
            raise ExrDamaged(f"{path}: channel list truncated in channel {name!r}")
        pixel_type, p_linear, x_s, y_s = struct.unpack_from("<iB3xii", value, end + 1)
        out.append((name, pixel_type, p_linear, x_s, y_s))
        pos = end + 17


def _decode_attribute(type_name, value, path, name):
    """The value of a known attribute type as a Python value, else (type_name, bytes)."""
    fixed = {"box2i": "<4i", "compression": "<B", "lineOrder": "<B", "int": "<i",
             "float": "<f", "double": "<d", "v2f": "<2f", "v2i": "<2i"}
    if type_name == "string":
        return value.decode("utf-8", "replace")
    if type_name == "chlist":
        return _decode_chlist(value, path)
    if type_name in fixed:
        fmt = fixed[type_name]
        if len(value) != struct.calcsize(fmt):
            raise ExrDamaged(f"{path}: attribute {name!r} of type {type_name} has "
                             f"{len(value)} bytes")
        v = struct.unpack(fmt, value)
        return v if len(v) > 1 else v[0]
    return (type_name, value)


if hasattr(os, "pread"):
    _pread = os.pread
else:  # Windows: no positional read, so a seek and a read under a lock
    _seek_lock = threading.Lock()

    def _pread(fd, n, offset):
        with _seek_lock:
            os.lseek(fd, offset, os.SEEK_SET)
            return os.read(fd, n)


def _pread_exact(fd, n, offset, path, what):
    data = _pread(fd, n, offset)
    if len(data) != n:
        raise ExrDamaged(f"{path}: truncated file ({what} at byte {offset} needs {n} bytes, "
                         f"got {len(data)})")
    return data


_scratch = threading.local()


def _scratch_array(name, n, dtype):
    """A per-thread buffer of at least n items, reused from chunk to chunk: fresh multi-MB
    arrays for every chunk cost page faults comparable to the decoding itself."""
    a = getattr(_scratch, name, None)
    if a is None or a.size < n or a.dtype != dtype:
        a = np.empty(n, dtype)
        setattr(_scratch, name, a)
    return a[:n]


_M, _K = np.uint64(0x00FF00FF00FF00FF), np.uint64(0x0001000100010001)
_BIAS = np.uint64(0x0080008000800080)
_SWAR_WORDS = 1 << 15  # words per block: the five temporaries stay in the L2 cache


def _undo_predictor(src, t):
    """t[i] = t[i-1] + d[i] - 128 (mod 256), t[0] = d[0], for the bytes d of src, into the
    uint8 array t. That is t[i] = (d[0] + ... + d[i]) + 128 i, a prefix sum, which np.cumsum
    does at one element per step; so it is done 8 bytes at a time (SWAR on uint64 words):
    even and odd bytes spread into 16-bit lanes cannot carry into each other, multiplying by
    0x0001000100010001 sums each lane with the lanes below it, and only the words' totals
    need a sequential cumsum, 8 times shorter."""
    n = len(t)
    words = n // 8
    d = np.frombuffer(src, "<u8", count=words)
    x = t[:words * 8].view("<u8")
    carry = np.uint64(0)
    e, o, b, tot, c = (_scratch_array(k, min(words, _SWAR_WORDS), np.uint64)
                       for k in ("swar_e", "swar_o", "swar_b", "swar_tot", "swar_c"))
    for w0 in range(0, words, _SWAR_WORDS):
        blk = d[w0:w0 + _SWAR_WORDS]
        m = len(blk)
        e_, o_, b_, tot_, c_ = e[:m], o[:m], b[:m], tot[:m], c[:m]
        np.bitwise_and(blk, _M, out=e_)  # bytes 0, 2, 4, 6 in lanes 0..3
        np.right_shift(blk, np.uint64(8), out=o_)
        o_ &= _M  # bytes 1, 3, 5, 7
        e_ *= _K  # lane l: sum of even bytes 0..2l
        o_ *= _K  # lane l: sum of odd bytes 1..2l+1
        np.add(e_, o_, out=b_)  # lane l: sum of bytes 0..2l+1
        np.right_shift(b_, np.uint64(48), out=tot_)  # the word's sum
        np.cumsum(tot_, out=c_)
        c_ -= tot_  # sum of the words before, in this block
        c_ += carry
        carry = c_[-1] + tot_[-1]
        c_ &= np.uint64(0xFF)
        c_ *= _K  # added to every lane
        b_ += c_
        b_ += _BIAS  # odd bytes: + 128 i is + 128 (mod 256); even: 0
        o_ <<= np.uint64(16)  # lane l: sum of odd bytes 1..2l-1
        o_ += e_
        o_ += c_  # lane l: sum of bytes 0..2l
        o_ &= _M
        b_ &= _M
        b_ <<= np.uint64(8)
        np.bitwise_or(b_, o_, out=x[w0:w0 + m])
    # The last n % 8 bytes, one at a time.
    tail = np.frombuffer(src, np.uint8)
    prev = int(t[words * 8 - 1]) if words else None
    for i in range(words * 8, n):
        prev = int(tail[i]) if prev is None else (prev + int(tail[i]) - 128) & 0xFF
        t[i] = prev


def _undo_predictor_and_interleave(src, dst):
    """The inverse of OpenEXR's ZIP/RLE pre-pass into dst (a uint8 array of len(src), which is
    even): src holds the deltas (see _undo_predictor) of a buffer whose first half is the even
    bytes of dst and whose second half the odd ones."""
    n = len(dst)
    t = _scratch_array("predicted", n, np.uint8)
    _undo_predictor(src, t)
    half = n // 2
    # Pairs of bytes as little-endian 16-bit words: one pass instead of two strided copies.
    words = dst.view("<u2")
    np.left_shift(t[half:], 8, out=words, dtype=np.uint16)
    np.bitwise_or(words, t[:half], out=words)


def _libdeflate():
    """The system's libdeflate (the library spectex itself compresses with), through ctypes, or
    None: it inflates about twice as fast as zlib, and a call releases the GIL like zlib's."""
    import ctypes
    import ctypes.util

    for name in ("libdeflate.so.0", ctypes.util.find_library("deflate")):
        if not name:
            continue
        try:
            lib = ctypes.CDLL(name)
            lib.libdeflate_alloc_decompressor.restype = ctypes.c_void_p
            lib.libdeflate_alloc_decompressor.argtypes = []
            lib.libdeflate_zlib_decompress_ex.restype = ctypes.c_int
            lib.libdeflate_zlib_decompress_ex.argtypes = [
                ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t, ctypes.c_void_p, ctypes.c_size_t,
                ctypes.POINTER(ctypes.c_size_t), ctypes.POINTER(ctypes.c_size_t)]
            return lib
        except (OSError, AttributeError):
            continue
    return None


_LIBDEFLATE = None if os.environ.get("SPECTEX_NO_LIBDEFLATE") else _libdeflate()
_inflaters = threading.local()


def _inflate_libdeflate(data, expected, path, y):
    import ctypes

    d = getattr(_inflaters, "d", None)
    if d is None:
        d = _inflaters.d = _LIBDEFLATE.libdeflate_alloc_decompressor()
        if not d:
            raise MemoryError("libdeflate_alloc_decompressor")
    out = _scratch_array("inflated", expected, np.uint8)
    got_in, got_out = ctypes.c_size_t(0), ctypes.c_size_t(0)
    status = _LIBDEFLATE.libdeflate_zlib_decompress_ex(d, data, len(data), out.ctypes.data, expected,
                                                       ctypes.byref(got_in), ctypes.byref(got_out))
    if status == 3:  # LIBDEFLATE_INSUFFICIENT_SPACE
        raise ExrDamaged(f"{path}: chunk at y={y} inflates to longer than {expected} bytes")
    if status != 0:
        raise ExrDamaged(f"{path}: chunk at y={y} does not inflate (damaged deflate stream or checksum)")
    if got_out.value != expected:
        raise ExrDamaged(f"{path}: chunk at y={y} inflates to {got_out.value} bytes, not {expected} bytes")
    if got_in.value != len(data):
        raise ExrDamaged(f"{path}: chunk at y={y} has {len(data) - got_in.value} bytes after its "
                         "compressed data")
    return out


def _inflate(data, expected, path, y):
    if _LIBDEFLATE is not None:
        return _inflate_libdeflate(data, expected, path, y)
    return _inflate_zlib(data, expected, path, y)


def _inflate_zlib(data, expected, path, y):
    """zlib-inflate a chunk that must give exactly `expected` bytes; the output is capped
    there, so a hostile stream cannot inflate beyond the chunk's size."""
    z = zlib.decompressobj()
    try:
        out = z.decompress(data, expected)
        # At the cap the stream's end (its checksum) may still be unread: finish it, allowing
        # one more byte only to detect a stream longer than the chunk.
        extra = b"" if z.eof else z.decompress(z.unconsumed_tail, 1)
    except zlib.error as e:
        raise ExrDamaged(f"{path}: chunk at y={y} does not inflate ({e})") from None
    if len(out) != expected or extra or not z.eof:
        why = ("longer than" if extra else "incomplete at" if not z.eof and len(out) == expected
               else f"{len(out)} bytes, not")
        raise ExrDamaged(f"{path}: chunk at y={y} inflates to {why} {expected} bytes")
    if z.unused_data:  # the stream ends before the chunk: its size is wrong
        raise ExrDamaged(f"{path}: chunk at y={y} has {len(z.unused_data)} bytes after its "
                         "compressed data")
    return out


# Bytes from one RLE count byte to the next: a negative count -n is followed by n literal
# bytes, a count n >= 0 by the one byte it repeats n + 1 times.
_RLE_STEP = tuple(2 if c < 128 else 1 + 256 - c for c in range(256))


def _rle_decode(src, expected, path, y):
    """OpenEXR's RLE. Only finding where each run starts needs a loop (over runs, not bytes);
    the output is then one np.repeat of the input, each byte repeated as often as it appears
    in the output: count bytes 0 times, literal bytes once, a repeated byte its count."""
    n, step, starts = len(src), _RLE_STEP, array.array("q")
    append, i = starts.append, 0
    while i < n:
        append(i)
        i += step[src[i]]
    if i != n:
        raise ExrDamaged(f"{path}: RLE chunk at y={y} ends inside a run")
    data = np.frombuffer(src, np.uint8)
    runs = np.frombuffer(starts, np.int64)  # no copy, unlike np.asarray of a list
    counts = data[runs].view(np.int8)
    repeated = counts >= 0
    repeats = runs[repeated] + 1
    repeat_counts = counts[repeated].view(np.uint8) + np.uint8(1)  # 1 to 128
    total = n - len(runs) - len(repeats) + int(repeat_counts.sum(dtype=np.int64))
    if total != expected:
        raise ExrDamaged(f"{path}: RLE chunk at y={y} decodes to {total} bytes, "
                         f"not {expected}")
    times = np.ones(n, np.uint8)  # uint8 counts: np.repeat is twice as fast as with intp
    times[runs] = 0
    times[repeats] = repeat_counts
    return np.repeat(data, times)


def _convert(buf, rows, width, channels, plan, dst, planar=False):
    """The uncompressed lines in buf (per line, channel after channel, `width` samples each)
    into dst[rows, width, len(plan)] float32, channel k of dst being channels[plan[k]]; or, when
    planar, into dst[len(plan), rows, width] (the file's own order within a line, no transpose)."""
    if not plan:
        return
    types = {t for _, t in channels}
    if planar or len(types) > 1:
        # One channel at a time, a [rows, width] strided view of each (planar: the file's own
        # layout, so each copy is contiguous rows).
        offsets, offset = [], 0
        for _, pixel_type in channels:
            offsets.append(offset)
            offset += width * SAMPLE_BYTES[pixel_type]
        lines = buf.reshape(rows, offset)
        for k, c in enumerate(plan):
            pixel_type = channels[c][1]
            part = lines[:, offsets[c]:offsets[c] + width * SAMPLE_BYTES[pixel_type]]
            np.copyto(dst[k] if planar else dst[:, :, k], part.view(SAMPLE_DTYPE[pixel_type]),
                      casting="unsafe")
        return
    # One sample type: the lines are a [rows, channels, width] array, and the conversion is one
    # transposing copy, whatever the number of channels.
    (pixel_type,) = types
    lines = buf.view(SAMPLE_DTYPE[pixel_type]).reshape(rows, len(channels), width)
    if plan != list(range(len(channels))):
        lines = lines[:, plan, :]
    if pixel_type == HALF:
        # Transposing 16-bit words and then widening contiguous ones is faster than a casting
        # strided copy.
        t = _scratch_array("transposed", dst.size, np.uint16).reshape(dst.shape)
        np.copyto(t, lines.view(np.uint16).transpose(0, 2, 1))
        np.copyto(dst, t.view("<f2"))
    else:
        np.copyto(dst, lines.transpose(0, 2, 1), casting="unsafe")


def file_kind(mode):
    """What a path that is not a regular file is, in words (st_mode from os.stat)."""
    for test, kind in ((stat.S_ISDIR, "a directory"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return kind
    return "anything but a regular file"


class ExrStrips:
    """A single-part scanline OpenEXR file read a strip of rows at a time (see the module)."""

    def __init__(self, path):
        self.path = os.fspath(path)
        # O_NONBLOCK: opening a FIFO would wait for a writer; it is refused below instead (a
        # regular file's reads ignore the flag).
        self._fd = os.open(self.path, os.O_RDONLY | getattr(os, "O_BINARY", 0) | getattr(os, "O_NONBLOCK", 0))
        try:
            st = os.fstat(self._fd)
            if not stat.S_ISREG(st.st_mode):
                raise OSError(errno.EINVAL, f"an OpenEXR file must be a regular file, not {file_kind(st.st_mode)}")
            self._file_size = st.st_size
            self._parse()
        except (ExrDamaged, ExrUnsupported, OSError):
            self.close()
            raise
        except (struct.error, IndexError, KeyError, TypeError, ValueError, OverflowError) as e:
            # Every check above should have caught a bad header first; this is the guarantee
            # that a bad file raises ExrDamaged whatever slipped through.
            self.close()
            raise ExrDamaged(f"{self.path}: malformed header ({type(e).__name__}: {e})") \
                from None
        except BaseException:
            self.close()
            raise

    # -- header ----------------------------------------------------------------------------

    def _parse(self):
        h = _Header(self._fd, self.path, self._file_size)
        if self._file_size < 8:
            raise ExrDamaged(f"{self.path}: not an OpenEXR file ({self._file_size} bytes)")
        magic, version = struct.unpack("<iI", h.take(8))
        if magic != MAGIC:
            raise ExrDamaged(f"{self.path}: not an OpenEXR file (bad magic number)")
        flags = version & ~0xFF
        if version & 0xFF != 2:
            raise ExrUnsupported(f"{self.path}: OpenEXR file format version {version & 0xFF}")
        for flag, what in ((FLAG_MULTIPART, "multi-part"), (FLAG_NON_IMAGE, "deep"),
                           (FLAG_TILED, "tiled")):
            if flags & flag:
                raise ExrUnsupported(f"{self.path}: {what} file")
        if flags & ~KNOWN_FLAGS:
            raise ExrUnsupported(f"{self.path}: unknown version flags 0x{flags:x}")

        self.attributes, self._attribute_types = {}, {}
        while True:
            name = h.name("attribute name")
            if not name:
                break
            type_name = h.name(f"type of attribute {name!r}")
            (size,) = _I32.unpack(h.take(4))
            if size < 0:
                raise ExrDamaged(f"{self.path}: attribute {name!r} has size {size}")
            self.attributes[name] = _decode_attribute(type_name, h.take(size), self.path, name)
            self._attribute_types[name] = type_name
        self._check_required()
        self._read_offsets(h)

    def _check_required(self):
        a, p = self.attributes, self.path
        types = self._attribute_types
        for name, type_name in (("channels", "chlist"), ("compression", "compression"),
                                ("dataWindow", "box2i"), ("lineOrder", "lineOrder"),
                                ("chunkCount", "int"), ("type", "string")):
            if name in types and types[name] != type_name:
                raise ExrDamaged(f"{p}: attribute {name!r} has type {types[name]!r}, "
                                 f"not {type_name!r}")
            if name not in types and name in ("channels", "compression", "dataWindow"):
                raise ExrDamaged(f"{p}: header lacks the {name!r} attribute")
        if a.get("type", "scanlineimage") != "scanlineimage":
            raise ExrUnsupported(f"{p}: part type {a['type']!r}")
        if "tiles" in a:
            raise ExrUnsupported(f"{p}: tiled file")
        self.compression = a["compression"]
        if self.compression not in ROWS_PER_CHUNK:
            name = COMPRESSION_NAMES.get(self.compression, f"code {self.compression}")
            raise ExrUnsupported(f"{p}: {name} compression")
        self.rows_per_chunk = ROWS_PER_CHUNK[self.compression]
        self.line_order = a.get("lineOrder", 0)
        if self.line_order > 2:
            raise ExrDamaged(f"{p}: bad lineOrder {self.line_order!r}")
        self.data_window = xmin, ymin, xmax, ymax = a["dataWindow"]
        if xmax < xmin or ymax < ymin:
            raise ExrDamaged(f"{p}: empty or inverted data window {self.data_window}")
        self.width, self.height = xmax - xmin + 1, ymax - ymin + 1

        self.channels, seen = [], set()
        for name, pixel_type, _, x_s, y_s in a["channels"]:
            if pixel_type not in SAMPLE_BYTES:
                raise ExrDamaged(f"{p}: channel {name!r} has pixel type {pixel_type}")
            if name in seen:
                raise ExrDamaged(f"{p}: channel {name!r} listed twice")
            if (x_s, y_s) != (1, 1):
                raise ExrUnsupported(f"{p}: channel {name!r} is sub-sampled ({x_s}x{y_s})")
            seen.add(name)
            self.channels.append((name, pixel_type))
        self._row_bytes = self.width * sum(SAMPLE_BYTES[t] for _, t in self.channels)

    def _chunk_rows(self, i):
        return min(self.rows_per_chunk, self.height - i * self.rows_per_chunk)

    def _read_offsets(self, h):
        p, rpc = self.path, self.rows_per_chunk
        count = -(-self.height // rpc)
        declared = self.attributes.get("chunkCount")
        if declared is not None and declared != count:
            raise ExrDamaged(f"{p}: chunkCount {declared!r} but the data window needs {count}")
        table_end = h.pos + 8 * count
        if table_end > self._file_size:
            raise ExrDamaged(f"{p}: truncated offset table ({count} chunks need byte "
                             f"{table_end}, file has {self._file_size})")
        table = np.frombuffer(_pread_exact(self._fd, 8 * count, h.pos, p, "offset table"),
                              "<u8")
        bad = np.flatnonzero((table < table_end) | (table > self._file_size - 8))
        if bad.size:
            raise ExrDamaged(f"{p}: offset of chunk {bad[0]} ({table[bad[0]]}) lies outside "
                             f"the chunk area [{table_end}, {self._file_size})")
        # Each chunk's own y and size; the table is in y order, but a chunk is trusted only by
        # the y it carries, so a table in another order is mapped back by y.
        heads = [_CHUNK_HEAD.unpack(_pread_exact(self._fd, 8, int(o), p, "chunk header"))
                 for o in table]
        ymin = self.data_window[1]
        by_y = {}
        for offset, (y, size) in zip(table.tolist(), heads):
            i, rem = divmod(y - ymin, rpc)
            if rem or not 0 <= i < count or i in by_y:
                raise ExrDamaged(f"{p}: chunk at byte {offset} has y={y}, not the first row "
                                 "of a distinct chunk of the data window")
            by_y[i] = (offset, size)
        self._chunks = [by_y[i] for i in range(count)]
        for i, (offset, size) in enumerate(self._chunks):
            self._check_chunk_size(i, offset, size)
        # Only now, when the chunks are known to be able to hold them: what the format's
        # 32-bit sizes cannot describe.
        if self._row_bytes * self.rows_per_chunk >= 1 << 31:
            raise ExrUnsupported(f"{p}: a chunk of {self.rows_per_chunk} rows of "
                                 f"{self._row_bytes} bytes exceeds OpenEXR's 2 GB")

    def _check_chunk_size(self, i, offset, size):
        p, y = self.path, self.data_window[1] + i * self.rows_per_chunk
        raw = self._chunk_rows(i) * self._row_bytes
        if size < 0 or offset + 8 + size > self._file_size:
            raise ExrDamaged(f"{p}: chunk at y={y} ({size} bytes at byte {offset}) runs past "
                             f"the end of the file ({self._file_size} bytes)")
        if size == raw:
            return
        ratio = MAX_RLE_RATIO if self.compression == RLE else MAX_ZIP_RATIO
        if self.compression == NONE or size > raw or raw > ratio * size + 64:
            raise ExrDamaged(f"{p}: chunk at y={y} has {size} bytes for {raw} uncompressed "
                             f"({COMPRESSION_NAMES[self.compression]})")

    # -- pixels ----------------------------------------------------------------------------

    def _read_chunk(self, fd, i, dst):
        """Chunk i's uncompressed bytes into dst (uint8, exactly the chunk's size)."""
        offset, size = self._chunks[i]
        y = self.data_window[1] + i * self.rows_per_chunk
        data = _pread_exact(fd, size, offset + 8, self.path, f"chunk y={y}")
        raw = len(dst)
        if size == raw:  # stored as is whatever the compression (it did not shrink)
            dst[:] = np.frombuffer(data, np.uint8)
            return
        if self.compression == RLE:
            src = _rle_decode(data, raw, self.path, y)
        else:
            src = _inflate(data, raw, self.path, y)
        _undo_predictor_and_interleave(src, dst)

    def _decode_task(self, fd, first, last, out, out_row, plan, planar=False):
        """Chunks first..last-1 decoded, and the channels of plan (indices into
        self.channels, one per channel of out) converted into out[out_row:...] (planar:
        out[:, out_row:...])."""
        try:
            rows = sum(self._chunk_rows(i) for i in range(first, last))
            buf = _scratch_array("chunks", rows * self._row_bytes, np.uint8)
            pos = 0
            for i in range(first, last):
                n = self._chunk_rows(i) * self._row_bytes
                self._read_chunk(fd, i, buf[pos:pos + n])
                pos += n
            dst = out[:, out_row:out_row + rows] if planar else out[out_row:out_row + rows]
            _convert(buf, rows, self.width, self.channels, plan, dst, planar)
        except (ExrDamaged, OSError, MemoryError):
            raise
        except (IndexError, ValueError, TypeError, OverflowError, zlib.error) as e:
            # The header and chunk checks should make this unreachable; if not, a bad file
            # still says so as ExrDamaged.
            y = self.data_window[1] + first * self.rows_per_chunk
            raise ExrDamaged(f"{self.path}: cannot decode the chunks from y={y} "
                             f"({type(e).__name__}: {e})") from None

    def _tasks(self, rows):
        """(strip y0, strip rows, [(first chunk, end chunk, row of the first in the strip)])."""
        rpc = self.rows_per_chunk
        per_task = max(1, TASK_BYTES // max(1, self._row_bytes * rpc))
        for y0 in range(0, self.height, rows):
            n = min(rows, self.height - y0)
            first, end = y0 // rpc, -(-(y0 + n) // rpc)
            yield y0, n, [(c, min(c + per_task, end), c * rpc - y0)
                          for c in range(first, end, per_task)]

    def strips(self, names, rows=64, threads=None, planar=False):
        """Yield (y0, array) for consecutive strips covering the data window top to bottom:
        array is float32 of shape [n_rows, width, len(names)] with the named channels in the
        order given (half and uint converted to float32). y0 is the row index from 0 (relative
        to the data window). `rows` is rounded up to a multiple of rows_per_chunk. Chunks are
        decompressed on a thread pool (zlib releases the GIL), with a bounded number of chunks
        in flight, so memory stays O(strip). planar=True gives [len(names), n_rows, width]
        instead (each channel's rows contiguous, as the file holds them: no transpose).

        Raises KeyError for a name the file lacks, ValueError for rows < 1 or a strip of more
        than 2^31 samples, ExrDamaged for a chunk that cannot be decoded."""
        if self._fd is None:
            raise ValueError(f"{self.path}: the reader is closed")
        if isinstance(names, str):
            raise TypeError("names must be a list of channel names, not a string")
        names = list(names)
        missing = [n for n in names if n not in {c for c, _ in self.channels}]
        if missing:
            raise KeyError(f"{self.path}: no channel {missing[0]!r} (channels: "
                           f"{', '.join(n for n, _ in self.channels)})")
        rows = int(rows)
        if rows < 1:
            raise ValueError(f"rows must be at least 1, not {rows}")
        rows = -(-rows // self.rows_per_chunk) * self.rows_per_chunk
        rows = min(rows, -(-self.height // self.rows_per_chunk) * self.rows_per_chunk)
        if min(rows, self.height) * self.width * len(names) > MAX_STRIP_SAMPLES:
            raise ValueError(f"{self.path}: a strip of {rows} rows x {self.width} x "
                             f"{len(names)} channels is more than 2^31 samples")
        if not threads:  # the cores this process may run on, not the machine's
            affinity = getattr(os, "sched_getaffinity", None)
            threads = len(affinity(0)) if affinity else os.cpu_count() or 1
        threads = max(1, int(threads))
        return self._strips(names, rows, threads, planar)

    def _strips(self, names, rows, threads, planar=False):
        index = {name: k for k, (name, _) in enumerate(self.channels)}
        plan = [index[n] for n in names]
        shape = (self.width, len(names))
        max_in_flight = 2 * threads
        strips = list(self._tasks(rows))
        pending = ((s, y0, n, task) for s, (y0, n, tasks) in enumerate(strips)
                   for task in tasks)
        in_flight = collections.deque()  # (strip index, future), in submission order
        arrays = {}
        # A descriptor of its own: close() of the reader during the iteration cannot make
        # the workers read another file that reused the number.
        if self._fd is None:
            raise ValueError(f"{self.path}: the reader is closed")
        fd = os.dup(self._fd)
        if threads == 1 or sum(len(tasks) for _, _, tasks in strips) <= 1:
            # One task (a small texture) or one thread: decoded here. Starting a pool's thread
            # cost more than decoding a 64^2 file (a scene may hold thousands of them).
            try:
                for y0, n, tasks in strips:
                    array = np.empty((len(names), n, self.width) if planar else (n,) + shape, np.float32)
                    for first, last, row in tasks:
                        self._decode_task(fd, first, last, array, row, plan, planar)
                    yield y0, array
            finally:
                os.close(fd)
            return
        pool = concurrent.futures.ThreadPoolExecutor(threads, thread_name_prefix="exr_strips")

        def submit():
            while len(in_flight) < max_in_flight:
                item = next(pending, None)
                if item is None:
                    return
                s, y0, n, (first, last, row) = item
                if s not in arrays:
                    arrays[s] = np.empty((len(names), n, self.width) if planar else (n,) + shape, np.float32)
                in_flight.append((s, pool.submit(self._decode_task, fd, first, last, arrays[s], row,
                                                    plan, planar)))

        try:
            for s, (y0, n, _) in enumerate(strips):
                submit()
                while in_flight and in_flight[0][0] == s:
                    in_flight.popleft()[1].result()
                    submit()
                yield y0, arrays.pop(s)
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
            os.close(fd)

    # -- lifetime --------------------------------------------------------------------------

    def close(self):
        fd, self._fd = getattr(self, "_fd", None), None
        if fd is not None:
            os.close(fd)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()

    def __repr__(self):
        return (f"ExrStrips({self.path!r}: {self.width}x{self.height}, "
                f"{len(self.channels)} channels, "
                f"{COMPRESSION_NAMES.get(self.compression, self.compression)})")
