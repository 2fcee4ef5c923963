#!/usr/bin/env python3
"""Writes the seed corpus of fuzz_exr (tests/fuzz/corpus_exr/seed_*): small EXRs as penumbra's users
give them to diff and bench --gbuffer, made by penumbra itself at 8x6 pixels:
  - seed_render.exr   render's channels (R G B A shadow.V): a diff input
  - seed_aovs.exr     render --aovs: the G-buffer bench --gbuffer reads (P, N, A, ...)
  - seed_error.exr    diff -o: the error image (one channel, diff's own attributes)
then the same image in the other layouts the reader decodes, written by oiiotool (installed by
ci/deps.sh): half and tiled with an offset data window, uint, and every compression but ZIP
(DWAA, which OpenEXRCore 3.1.5 refuses, included); and hand-broken copies (seed_broken_*):
truncated, a damaged chunk offset table, a data window far larger than the file, a channel named
twice, a bad magic number.

Not byte-for-byte deterministic (render stores its timings as attributes); run it again only to
change the seeds. Needs a built penumbra and a Vulkan device (lavapipe will do):
    python3 tests/fuzz/make_corpus_exr.py [build/penumbra]
Crash reproducers (regress_*) are not touched.
"""
import os
import shutil
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "corpus_exr")
SIZE = "8x6"


def run(*cmd):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def attr_value(data, name, typ):
    """Offset of the value of the header attribute `name` of type `typ`, and its size."""
    key = name.encode() + b"\0" + typ.encode() + b"\0"
    at = data.index(key) + len(key)
    (size,) = struct.unpack_from("<i", data, at)
    return at + 4, size


def header_end(data):
    """Offset just past the header (magic, version, attributes, a NUL): the chunk offset table."""
    at = 8
    while data[at] != 0:
        at = data.index(b"\0", data.index(b"\0", at) + 1) + 1  # name, type
        (size,) = struct.unpack_from("<i", data, at)
        at += 4 + size
    return at + 1


def broken(render):
    """(name, bytes) of damaged copies of a render's EXR."""
    table = header_end(render)
    yield "seed_broken_truncated.exr", render[: table + (len(render) - table) // 2]
    yield "seed_broken_header_only.exr", render[:table]
    yield "seed_broken_magic.exr", b"\x76\x2f\x31\x00" + render[4:]
    # The first chunk's offset past the end of the file.
    b = bytearray(render)
    struct.pack_into("<Q", b, table, len(render) + 1000)
    yield "seed_broken_offsets.exr", bytes(b)
    # A data window of 100000 x 6 pixels in a file of a few KiB.
    b = bytearray(render)
    at, _ = attr_value(render, "dataWindow", "box2i")
    struct.pack_into("<i", b, at + 8, 99999)
    yield "seed_broken_huge_window.exr", bytes(b)
    # The channel list names G twice (the list must be sorted and unique).
    b = bytearray(render)
    at, size = attr_value(render, "channels", "chlist")
    g = b.index(b"G\0", at, at + size)
    b[g:g + 1] = b"B"
    yield "seed_broken_channel_twice.exr", bytes(b)


def main():
    penumbra = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "..", "..", "build", "penumbra")
    if not shutil.which("oiiotool"):
        sys.exit("make_corpus_exr.py: oiiotool not found (ci/deps.sh installs openimageio-tools)")
    os.makedirs(OUT, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="pn_corpus_exr.")
    try:
        render, aovs, err = (os.path.join(tmp, n) for n in ("render.exr", "aovs.exr", "error.exr"))
        common = ["--size", SIZE, "--spp", "2", "builtin:default"]
        run(penumbra, "render", *common, "-o", render)
        run(penumbra, "render", *common, "--aovs", "-o", aovs)
        run(penumbra, "render", *common, "--mode", "exact", "-o", os.path.join(tmp, "exact.exr"))
        run(penumbra, "diff", render, os.path.join(tmp, "exact.exr"), "-o", err)
        seeds = {"seed_render.exr": render, "seed_aovs.exr": aovs, "seed_error.exr": err}
        # Other writers' layouts of the same render (tests/test_io.c checks their values).
        variants = {
            "seed_half_tiled_piz.exr": ["--origin", "+5-7", "-d", "half", "--tile", "4", "4", "--compression", "piz"],
            "seed_uint_a.exr": ["--ch", "A,shadow.V", "-d", "uint32", "--compression", "none"],
            "seed_rle.exr": ["--compression", "rle"],
            "seed_zips.exr": ["-d", "half", "--compression", "zips"],
            "seed_pxr24.exr": ["--compression", "pxr24"],
            "seed_b44.exr": ["-d", "half", "--compression", "b44"],
            "seed_dwaa.exr": ["--compression", "dwaa"],
            "seed_aovs_tiled.exr": ["--tile", "8", "3", "--compression", "zip"],
        }
        for name, args in variants.items():
            src = aovs if "aovs" in name else render
            dst = os.path.join(tmp, name)
            run("oiiotool", src, *args, "-o", dst)
            seeds[name] = dst
        for name, path in seeds.items():
            with open(path, "rb") as f:
                data = f.read()
            with open(os.path.join(OUT, name), "wb") as f:
                f.write(data)
            print(f"{name}: {len(data)} bytes")
        with open(render, "rb") as f:
            data = f.read()
        for name, b in broken(data):
            with open(os.path.join(OUT, name), "wb") as f:
                f.write(b)
            print(f"{name}: {len(b)} bytes")
    finally:
        shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
