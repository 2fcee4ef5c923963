// PNG output without a PNG or zlib library: 8-bit RGB, every scanline with filter type 0, in a
// zlib stream made of stored (uncompressed) deflate blocks. Bigger than a compressed PNG, but
// any viewer reads it and it takes no dependency.
#include "io/png.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "io/file.h"

// ---- CRC-32 (ISO 3309, as PNG uses it), table driven

static void crc_init(uint32_t table[256])
{
    for (uint32_t n = 0; n < 256; n++) {
        uint32_t c = n;
        for (int k = 0; k < 8; k++)
            c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        table[n] = c;
    }
}

// Running form: start with crc = 0xFFFFFFFF, finish by inverting.
static uint32_t crc_update(const uint32_t table[256], uint32_t crc, const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        crc = table[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
    return crc;
}

// ---- Adler-32 of the uncompressed zlib payload

typedef struct adler32 {
    uint32_t a, b;
} adler32;

static void adler_update(adler32 *s, const uint8_t *p, size_t n)
{
    const uint32_t mod = 65521;
    while (n > 0) {
        size_t k = n < 5552 ? n : 5552; // the most bytes before b can overflow 32 bits
        n -= k;
        while (k--) {
            s->a += *p++;
            s->b += s->a;
        }
        s->a %= mod;
        s->b %= mod;
    }
}

// ---- chunk output

// IDAT payload per chunk; any split is valid, the decoder concatenates them.
#define PN_PNG_IDAT_MAX (1u << 16)

typedef struct png_out {
    FILE *f;
    int err;       // first errno seen, or -1 for a short write without errno
    uint32_t crc_table[256];
    uint8_t idat[PN_PNG_IDAT_MAX];
    size_t idat_len;
} png_out;

static void put_be32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

static void out_bytes(png_out *o, const void *p, size_t n)
{
    if (o->err || n == 0)
        return;
    errno = 0;
    if (fwrite(p, 1, n, o->f) != n)
        o->err = errno ? errno : -1;
}

static void write_chunk(png_out *o, const char type[4], const uint8_t *data, uint32_t len)
{
    uint8_t head[8];
    put_be32(head, len);
    memcpy(head + 4, type, 4);
    uint32_t crc = crc_update(o->crc_table, 0xFFFFFFFFu, head + 4, 4);
    crc = crc_update(o->crc_table, crc, data, len) ^ 0xFFFFFFFFu;
    uint8_t tail[4];
    put_be32(tail, crc);
    out_bytes(o, head, sizeof head);
    out_bytes(o, data, len);
    out_bytes(o, tail, sizeof tail);
}

static void idat_flush(png_out *o)
{
    if (o->idat_len) {
        write_chunk(o, "IDAT", o->idat, (uint32_t)o->idat_len);
        o->idat_len = 0;
    }
}

// Appends to the zlib stream, emitting a full IDAT chunk whenever the buffer fills.
static void idat_put(png_out *o, const uint8_t *p, size_t n)
{
    while (n > 0 && !o->err) {
        size_t k = sizeof o->idat - o->idat_len;
        if (k > n)
            k = n;
        memcpy(o->idat + o->idat_len, p, k);
        o->idat_len += k;
        p += k;
        n -= k;
        if (o->idat_len == sizeof o->idat)
            idat_flush(o);
    }
}

// Streams the scanlines (filter byte 0 + RGB row) as stored deflate blocks of at most 65535
// bytes each, updating the Adler-32 of everything inside the blocks.
static void write_image_data(png_out *o, int width, int height, const uint8_t *rgb)
{
    static const uint8_t zlib_header[2] = {0x78, 0x01}; // deflate, 32K window, no dictionary
    idat_put(o, zlib_header, sizeof zlib_header);

    const size_t row_bytes = (size_t)width * 3;
    const size_t line = row_bytes + 1;
    const size_t total = line * (size_t)height;
    adler32 adler = {1, 0};
    size_t pos = 0; // offset in the filtered scanline stream
    while (pos < total && !o->err) {
        size_t block = total - pos;
        if (block > 65535)
            block = 65535;
        uint8_t head[5];
        head[0] = pos + block == total ? 1 : 0; // BFINAL, BTYPE = 00 (stored)
        head[1] = (uint8_t)block;
        head[2] = (uint8_t)(block >> 8);
        head[3] = (uint8_t)~block;
        head[4] = (uint8_t)(~block >> 8);
        idat_put(o, head, sizeof head);
        for (size_t left = block; left > 0 && !o->err;) {
            size_t y = pos / line, x = pos % line;
            const uint8_t *src;
            size_t n;
            static const uint8_t filter_none = 0;
            if (x == 0) {
                src = &filter_none;
                n = 1;
            } else {
                src = rgb + y * row_bytes + (x - 1);
                n = line - x;
                if (n > left)
                    n = left;
            }
            idat_put(o, src, n);
            adler_update(&adler, src, n);
            pos += n;
            left -= n;
        }
    }
    uint8_t tail[4];
    put_be32(tail, (adler.b << 16) | adler.a);
    idat_put(o, tail, sizeof tail);
    idat_flush(o);
}

pn_result pn_png_write_rgb8(const char *path, int width, int height, const uint8_t *rgb)
{
    if (!path || !*path) {
        pn_error("PNG output: no path given");
        return PN_ERR_INVALID;
    }
    // PNG allows up to 2^31-1 per side; also keep the row and image sizes inside size_t.
    if (width <= 0 || height <= 0 || (size_t)width > (SIZE_MAX - 1) / 3 / (size_t)height) {
        pn_error("%s: invalid PNG size %dx%d", path, width, height);
        return PN_ERR_INVALID;
    }
    if (!rgb) {
        pn_error("%s: no pixels to write", path);
        return PN_ERR_INVALID;
    }
    char tmp[4096];
    pn_result r = pn_file_tmp_path(path, tmp, sizeof tmp);
    if (r != PN_OK)
        return r;

    png_out *o = calloc(1, sizeof *o); // 64 KiB IDAT buffer: keep it off the stack
    if (!o) {
        pn_error("%s: out of memory writing PNG", path);
        return PN_ERR_MEMORY;
    }
    crc_init(o->crc_table);

    errno = 0;
    o->f = fopen(tmp, "wb");
    if (!o->f) {
        pn_error("%s: cannot create PNG: %s", path, strerror(errno));
        free(o);
        pn_file_discard(tmp);
        return PN_ERR_IO;
    }

    static const uint8_t signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    out_bytes(o, signature, sizeof signature);

    uint8_t ihdr[13];
    put_be32(ihdr, (uint32_t)width);
    put_be32(ihdr + 4, (uint32_t)height);
    ihdr[8] = 8;  // bit depth
    ihdr[9] = 2;  // colour type: RGB
    ihdr[10] = 0; // compression: deflate
    ihdr[11] = 0; // filter method 0
    ihdr[12] = 0; // no interlace
    write_chunk(o, "IHDR", ihdr, sizeof ihdr);

    write_image_data(o, width, height, rgb);
    write_chunk(o, "IEND", NULL, 0);

    if (!o->err && fflush(o->f) != 0)
        o->err = errno ? errno : -1;
    if (fclose(o->f) != 0 && !o->err)
        o->err = errno ? errno : -1;
    int err = o->err;
    free(o);
    if (err) {
        pn_error("%s: cannot write PNG: %s", path, err > 0 ? strerror(err) : "short write");
        pn_file_discard(tmp);
        return PN_ERR_IO;
    }
    return pn_file_commit(tmp, path);
}

// ---- tone mapping

static uint8_t tonemap_channel(float v, float exposure)
{
    double x = (double)v * (double)exposure;
    if (!(x > 0.0)) // zero, negative, NaN
        return 0;
    double t = isinf(x) ? 1.0 : x / (1.0 + x);
    double s = t <= 0.0031308 ? 12.92 * t : 1.055 * pow(t, 1.0 / 2.4) - 0.055;
    double q = floor(s * 255.0 + 0.5);
    if (q <= 0.0)
        return 0;
    if (q >= 255.0)
        return 255;
    return (uint8_t)q;
}

void pn_tonemap_srgb8(const float *rgba, int width, int height, float exposure, uint8_t *out)
{
    if (!rgba || !out || width <= 0 || height <= 0)
        return;
    size_t n = (size_t)width * (size_t)height;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            out[i * 3 + c] = tonemap_channel(rgba[i * 4 + c], exposure);
}
