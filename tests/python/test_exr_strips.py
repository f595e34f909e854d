"""python/spectex_mitsuba/exr_strips.py against OpenImageIO's reader.

Files baked by spectex (every lossless compression it offers, half and float, with and without
alpha) and written by OpenImageIO (mixed sample types, an offset data window, long channel
names, decreasing line order, incompressible chunks stored raw) must read bit for bit as
OpenImageIO reads them, in strips of any size and channels in any order. Files the reader does
not stream (PIZ, tiled, multi-part) raise ExrUnsupported; truncated or corrupted ones raise
ExrDamaged and nothing else.
"""
import importlib.util
import os
import random
import subprocess
import sys
import tempfile

import numpy as np
import pytest

import OpenImageIO as oiio

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.environ.get("SPECTEX_SOURCE_DIR", os.path.dirname(os.path.dirname(HERE)))
SPECTEX = os.environ.get("SPECTEX_BINARY", os.path.join(SOURCE, "build", "src", "spectex"))


def _load_reader():
    # From the source tree: the venv's installed spectex_mitsuba may predate the module.
    path = os.path.join(SOURCE, "python", "spectex_mitsuba", "exr_strips.py")
    spec = importlib.util.spec_from_file_location("spectex_exr_strips", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


ex = _load_reader()
ExrStrips, ExrDamaged, ExrUnsupported = ex.ExrStrips, ex.ExrDamaged, ex.ExrUnsupported


@pytest.fixture(scope="module")
def tmp():
    with tempfile.TemporaryDirectory() as d:
        yield d


def write_image(path, spec, pixels):
    out = oiio.ImageOutput.create(path)
    assert out.open(path, spec), out.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()
    return path


def write_png(path, width, height, channels, seed):
    pixels = np.random.default_rng(seed).integers(0, 256, (height, width, channels), np.uint8)
    return write_image(path, oiio.ImageSpec(width, height, channels, "uint8"), pixels)


def bake(src, dst, *args):
    if not os.access(SPECTEX, os.X_OK):
        pytest.skip(f"no spectex binary at {SPECTEX}")
    r = subprocess.run([SPECTEX, "bake", src, "-o", dst, "-q", *args], capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    return dst


def oiio_channels(path):
    """{name: [height, width] float32} as OpenImageIO reads the data window; UINT channels
    as their integer values converted to float32 (OpenImageIO's float would normalise them)."""
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    spec = inp.spec()
    pixels = inp.read_image("float")
    out = {}
    for c, name in enumerate(spec.channelnames):
        if spec.channelformat(c) == oiio.TypeDesc("uint"):
            out[name] = inp.read_image(0, 0, c, c + 1, "uint")[:, :, 0].astype(np.float32)
        else:
            out[name] = np.ascontiguousarray(pixels[:, :, c])
    inp.close()
    return out


def read_all(reader, names, rows, threads=None):
    """The strips of reader joined, checking they are consecutive, aligned and sized."""
    parts, expect_y = [], 0
    step = -(-rows // reader.rows_per_chunk) * reader.rows_per_chunk
    for y0, strip in reader.strips(names, rows=rows, threads=threads):
        assert y0 == expect_y
        assert strip.dtype == np.float32 and strip.flags.c_contiguous
        assert strip.shape == (min(step, reader.height - y0), reader.width, len(names))
        parts.append(strip)
        expect_y += strip.shape[0]
    assert expect_y == reader.height
    return np.concatenate(parts)


def assert_reads_as_oiio(path, rows_list=(1, 16, 64, 10000), threads=None):
    ref = oiio_channels(path)
    with ExrStrips(path) as r:
        names = [n for n, _ in r.channels]
        assert sorted(names) == sorted(ref)
        first = next(iter(ref.values()))
        assert (r.height, r.width) == first.shape
        orders = [names, names[::-1], random.Random(len(names)).sample(names, len(names)),
                  names[-1:] + names[:1]]
        for rows, order in zip(rows_list, orders * len(rows_list)):
            got = read_all(r, order, rows, threads)
            for k, name in enumerate(order):
                # Bitwise: half to float32 is exact, so nothing may differ by even 1 ulp.
                assert np.array_equal(got[:, :, k].view(np.uint32), ref[name].view(np.uint32)), \
                    (path, rows, name)
    return ref


@pytest.fixture(scope="module")
def pngs(tmp):
    # Odd sizes: a partial last ZIP chunk (45 = 2 x 16 + 13) and rows of 31 half channels whose
    # byte count is not a multiple of 8; 300 wide: ZIP chunks over 256 KB.
    return {"rgb": write_png(os.path.join(tmp, "rgb.png"), 67, 45, 3, 1),
            "rgba": write_png(os.path.join(tmp, "rgba.png"), 67, 45, 4, 2),
            "wide": write_png(os.path.join(tmp, "wide.png"), 300, 37, 3, 3)}


BAKES = [("rgb", "none"), ("rgb", "zip"), ("rgb", "zips"), ("rgb", "rle"), ("rgba", "zip"),
         ("rgba", "rle"), ("rgba", "none"), ("wide", "zip")]


@pytest.mark.parametrize("source,compression", BAKES)
def test_spectex_bakes_read_as_oiio(tmp, pngs, source, compression):
    out = bake(pngs[source], os.path.join(tmp, f"{source}_{compression}.exr"),
               "--compression", compression)
    assert_reads_as_oiio(out)
    with ExrStrips(out) as r:
        assert r.compression == {"none": 0, "rle": 1, "zips": 2, "zip": 3}[compression]
        assert r.rows_per_chunk == (16 if compression == "zip" else 1)
        assert r.data_window == (0, 0, r.width - 1, r.height - 1)
        assert all(t == 1 for _, t in r.channels)
        assert ("A" in [n for n, _ in r.channels]) == (source == "rgba")


@pytest.mark.parametrize("compression", ["zip", "zips", "none"])
def test_spectex_float_bakes_read_as_oiio(tmp, pngs, compression):
    out = bake(pngs["rgba"], os.path.join(tmp, f"float_{compression}.exr"), "--type", "float",
               "--compression", compression)
    assert_reads_as_oiio(out, rows_list=(1, 64))
    with ExrStrips(out) as r:
        assert all(t == 2 for n, t in r.channels if n.startswith("T."))


def test_string_attributes_match_oiio(tmp, pngs):
    out = bake(pngs["rgb"], os.path.join(tmp, "attributes.exr"))
    spec = oiio.ImageInput.open(out).spec()
    with ExrStrips(out) as r:
        a = r.attributes
        assert a["spectex:method"] == spec.getattribute("spectex:method")
        assert a["spectex:version"] == spec.getattribute("spectex:version")
        assert a["spectex:wavelengths"] == spec.getattribute("spectex:wavelengths")
        assert a["dataWindow"] == r.data_window
        assert a["compression"] == 3 and a["lineOrder"] == 0
        assert [c[:2] for c in a["channels"]] == r.channels
        assert a["pixelAspectRatio"] == 1.0 and a["screenWindowCenter"] == (0.0, 0.0)


def test_threads_and_early_close(tmp, pngs):
    out = bake(pngs["wide"], os.path.join(tmp, "threads.exr"))
    ref = oiio_channels(out)
    with ExrStrips(out) as r:
        names = [n for n, _ in r.channels]
        for threads in (1, 3):
            got = read_all(r, names[5:9], 16, threads)
            assert all(np.array_equal(got[:, :, k], ref[n]) for k, n in enumerate(names[5:9]))
        strips = r.strips(names, rows=16)
        next(strips)
        strips.close()  # abandons chunks in flight; the reader stays usable
        assert read_all(r, names[:1], 32).shape == (r.height, r.width, 1)
        with pytest.raises(KeyError):
            r.strips(["no such channel"])
        # The same channel twice is two copies.
        got = read_all(r, [names[3], names[3]], 64)
        assert np.array_equal(got[:, :, 0], got[:, :, 1])


# -- files written by OpenImageIO ------------------------------------------------------------

def oiio_spec(width, height, names, formats, compression, **attributes):
    spec = oiio.ImageSpec(width, height, len(names), oiio.TypeDesc("half"))
    spec.channelformats = tuple(oiio.TypeDesc(f) for f in formats)
    spec.channelnames = tuple(names)
    spec.attribute("compression", compression)
    for k, v in attributes.items():
        spec.attribute(k.replace("__", ":"), v)
    return spec


@pytest.mark.parametrize("compression", ["none", "rle", "zips", "zip"])
def test_mixed_types_offset_window_long_names(tmp, compression):
    names = ["B", "G", "R" + "x" * 40, "Z"]  # a 41-byte name: the long-names flag
    spec = oiio_spec(37, 23, names, ["half", "float", "uint", "half"], compression)
    spec.x, spec.y = 3, -5
    pixels = np.random.default_rng(4).random((23, 37, 4)).astype(np.float32)
    path = write_image(os.path.join(tmp, f"mixed_{compression}.exr"), spec, pixels)
    assert_reads_as_oiio(path)
    with ExrStrips(path) as r:
        assert r.data_window == (3, -5, 39, 17)
        assert dict(r.channels) == {"B": 1, "G": 2, "R" + "x" * 40: 0, "Z": 1}


def test_incompressible_chunks_are_stored_raw(tmp):
    # Random 32-bit integers do not deflate: OpenEXR stores such chunks as they are, which the
    # reader must recognise by their size.
    bits = np.random.default_rng(5).integers(0, 2**32, (40, 50, 2), dtype=np.uint32)
    spec = oiio_spec(50, 40, ["U", "V"], ["uint", "uint"], "zip")
    spec.set_format(oiio.TypeDesc("uint"))
    path = write_image(os.path.join(tmp, "raw_zip.exr"), spec, bits)
    with ExrStrips(path) as r:
        assert any(size == r._chunk_rows(i) * r._row_bytes for i, (_, size) in
                   enumerate(r._chunks))
    assert_reads_as_oiio(path, rows_list=(16, 64))


@pytest.mark.parametrize("compression", ["zip", "zips", "none"])
def test_decreasing_y_reads_as_increasing(tmp, compression):
    pixels = np.random.default_rng(6).random((45, 33, 3)).astype(np.float32)
    paths = []
    for order in ("increasingY", "decreasingY"):
        spec = oiio_spec(33, 45, ["B", "G", "R"], ["half"] * 3, compression,
                         openexr__lineOrder=order)
        paths.append(write_image(os.path.join(tmp, f"{order}_{compression}.exr"), spec, pixels))
    with ExrStrips(paths[1]) as r:
        assert r.line_order == 1
    a = assert_reads_as_oiio(paths[0], rows_list=(16,))
    b = assert_reads_as_oiio(paths[1], rows_list=(1, 64))
    assert all(np.array_equal(a[n], b[n]) for n in a)


def test_unsupported_files(tmp):
    pixels = np.random.default_rng(7).random((30, 40, 3)).astype(np.float32)
    piz = write_image(os.path.join(tmp, "piz.exr"),
                      oiio_spec(40, 30, "BGR", ["half"] * 3, "piz"), pixels)
    tiled_spec = oiio_spec(40, 30, "BGR", ["half"] * 3, "zip")
    tiled_spec.tile_width = tiled_spec.tile_height = 16
    tiled = write_image(os.path.join(tmp, "tiled.exr"), tiled_spec, pixels)
    multi = os.path.join(tmp, "multipart.exr")
    spec = oiio_spec(40, 30, "BGR", ["half"] * 3, "zip")
    out = oiio.ImageOutput.create(multi)
    assert out.open(multi, [spec, spec])
    out.write_image(pixels)
    out.open(multi, spec, "AppendSubimage")
    out.write_image(pixels)
    out.close()
    for path, why in ((piz, "PIZ"), (tiled, "tiled"), (multi, "multi-part")):
        with pytest.raises(ExrUnsupported, match=why):
            ExrStrips(path)


def test_a_path_that_is_not_a_regular_file_is_refused_without_waiting(not_regular_files):
    """The reader opens without blocking: a FIFO (which a blocking open holds until a writer comes)
    raises OSError at once naming what it is, as do a folder and a device. The check runs in a
    child with a deadline, so a hang fails the test instead of stalling the suite."""
    code = ("import importlib.util, sys\n"
            "spec = importlib.util.spec_from_file_location('m', sys.argv[1])\n"
            "m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m)\n"
            "try:\n    m.ExrStrips(sys.argv[2])\nexcept OSError as e:\n    print(e.strerror or e)\n")
    module = os.path.join(SOURCE, "python", "spectex_mitsuba", "exr_strips.py")
    for path, kind in not_regular_files:
        r = subprocess.run([sys.executable, "-c", code, module, path], capture_output=True, text=True, timeout=60)
        assert r.stdout.strip().endswith(f"must be a regular file, not {kind}"), (path, r.stdout, r.stderr)


# -- damaged files ---------------------------------------------------------------------------

def read_everything(path):
    with ExrStrips(path) as r:
        for _ in r.strips([n for n, _ in r.channels], rows=16):
            pass


def damaged_copy(src, dst, edit):
    data = bytearray(open(src, "rb").read())
    data = edit(data)
    with open(dst, "wb") as f:
        f.write(data)
    return dst


def header_end(path):
    """The byte after the offset table (where the first chunk begins)."""
    with ExrStrips(path) as r:
        return min(offset for offset, _ in r._chunks), r._chunks


@pytest.mark.parametrize("compression", ["zip", "rle", "none"])
def test_truncated_files_are_damaged(tmp, pngs, compression):
    src = bake(pngs["rgb"], os.path.join(tmp, f"trunc_src_{compression}.exr"),
               "--compression", compression)
    size = os.path.getsize(src)
    first_chunk, _ = header_end(src)
    cuts = {0, 3, 7, 8, 100, first_chunk - 9, first_chunk - 1, first_chunk, first_chunk + 5,
            first_chunk + 20, size // 2, size - 9, size - 1}
    for cut in sorted(cuts):
        path = damaged_copy(src, os.path.join(tmp, "cut.exr"), lambda d: d[:cut])
        with pytest.raises(ExrDamaged) as e:
            read_everything(path)
        assert path in str(e.value)


def test_corrupted_chunks_and_offsets_are_damaged(tmp, pngs):
    src = bake(pngs["wide"], os.path.join(tmp, "corrupt_src.exr"))
    first_chunk, chunks = header_end(src)
    table = first_chunk - 8 * len(chunks)
    size = os.path.getsize(src)

    def set_offset(i, value):
        def edit(d):
            d[table + 8 * i:table + 8 * i + 8] = value.to_bytes(8, "little")
            return d
        return edit

    def flip(at):
        def edit(d):
            d[at] ^= 0x5A
            return d
        return edit

    edits = [set_offset(1, size + 100), set_offset(1, size - 4), set_offset(0, 2**63 + 5),
             set_offset(1, chunks[0][0]),  # two entries for one chunk
             set_offset(0, 4)]  # into the header
    for offset, packed in chunks[:2]:
        edits += [flip(offset), flip(offset + 4),  # the chunk's y and size
                  flip(offset + 8), flip(offset + 8 + packed // 2), flip(offset + 7 + packed)]
    for k, edit in enumerate(edits):
        path = damaged_copy(src, os.path.join(tmp, "corrupt.exr"), edit)
        with pytest.raises(ExrDamaged):
            read_everything(path)


def test_hostile_data_window_is_damaged(tmp, pngs):
    """A header claiming a huge image in a small file is refused before any allocation."""
    src = bake(pngs["rgb"], os.path.join(tmp, "window_src.exr"))
    data = open(src, "rb").read()
    at = data.index(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
    for field, value in ((2, 2**30), (3, 2**30), (2, 2**31 - 1), (0, -2**31)):
        def edit(d):
            d[at + 4 * field:at + 4 * field + 4] = value.to_bytes(4, "little", signed=True)
            return d
        path = damaged_copy(src, os.path.join(tmp, "window.exr"), edit)
        with pytest.raises(ExrDamaged):
            read_everything(path)


@pytest.mark.parametrize("compression", ["zip", "rle", "zips"])
def test_random_damage_raises_only_exr_errors(tmp, pngs, compression):
    """Single-byte corruption and truncation anywhere: the file reads (RLE and deflate's
    literal bytes carry no checksum of their own) or raises ExrDamaged/ExrUnsupported, never
    anything else, and never hangs."""
    src = bake(pngs["rgba"], os.path.join(tmp, f"fuzz_src_{compression}.exr"),
               "--compression", compression)
    data = open(src, "rb").read()
    rng = random.Random(8)
    path = os.path.join(tmp, "fuzz.exr")
    for trial in range(300):
        d = bytearray(data)
        if trial % 5 == 4:
            d = d[:rng.randrange(len(d))]
        else:
            for _ in range(rng.choice((1, 1, 3))):
                d[rng.randrange(len(d))] = rng.randrange(256)
        with open(path, "wb") as f:
            f.write(d)
        try:
            read_everything(path)
        except (ExrDamaged, ExrUnsupported):
            pass


@pytest.mark.parametrize("compression", ["zip", "none"])
def test_planar_strips_are_the_same_samples_channel_first(tmp, pngs, compression):
    """planar=True (what the plugin's RGB mode reads): [channels, rows, width], the same values."""
    paths = [os.path.join(tmp, f"planar_{compression}.exr"),
             os.path.join(tmp, f"planar_mixed_{compression}.exr")]
    bake(pngs["rgba"], paths[0], "--compression", compression)
    spec = oiio_spec(37, 23, ["B", "G", "R"], ["half", "float", "uint"], compression)
    write_image(paths[1], spec, np.random.default_rng(9).random((23, 37, 3)).astype(np.float32))
    for path in paths:
        with ExrStrips(path) as r:
            names = [c for c, _ in r.channels][::-1]
            for rows in (1, 16, 64):
                want = read_all(r, names, rows)
                got = [strip for _, strip in r.strips(names, rows=rows, planar=True)]
                assert all(g.shape[0] == len(names) and g.flags.c_contiguous for g in got)
                assert np.array_equal(np.concatenate(got, axis=1), np.moveaxis(want, 2, 0))
