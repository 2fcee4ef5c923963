# The one reader of the single-channel FITS images the tests convert EXR layers into (oiiotool):
# a primary header of 80-character cards, padded to 2880 bytes, then big-endian 32-bit floats.
import struct


def read(path):
    """(width, height, values): values as FITS stores them, the bottom row first."""
    b = open(path, "rb").read()
    hdr, off = {}, 0
    while True:
        card = b[off:off + 80].decode("ascii"); off += 80
        if card.startswith("END"):
            break
        if "=" in card[:10]:
            hdr[card[:8].strip()] = card[10:].split("/")[0].strip()
    off = (off + 2879) // 2880 * 2880
    w, h = int(hdr["NAXIS1"]), int(hdr["NAXIS2"])
    assert int(hdr["BITPIX"]) == -32, hdr
    return w, h, list(struct.unpack(">%df" % (w * h), b[off:off + 4 * w * h]))
