// PNG images written by the tests (alpha-masked textures for the glTF files they write): RGBA,
// 8 bits, one IDAT, no filtering. Apart from test_util.h so that only its users include zlib.
#pragma once
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static inline void pn_test_be32(unsigned char *p, uint32_t v)
{
    p[0] = v >> 24, p[1] = v >> 16 & 255, p[2] = v >> 8 & 255, p[3] = v & 255;
}

// Writes w x h texels of rgba (4 bytes each, rows top first) as an RGBA PNG at path.
static inline bool pn_test_write_png(const char *path, uint32_t w, uint32_t h, const unsigned char *rgba)
{
    size_t row = 1 + 4 * (size_t)w, n = row * h;
    unsigned char *raw = malloc(n);
    uLongf zn = compressBound((uLong)n);
    unsigned char *z = malloc(zn);
    bool ok = raw && z;
    for (uint32_t y = 0; ok && y < h; y++) {
        raw[y * row] = 0; // filter: none
        memcpy(raw + y * row + 1, rgba + 4 * (size_t)w * y, 4 * (size_t)w);
    }
    ok = ok && compress2(z, &zn, raw, (uLong)n, 9) == Z_OK;
    FILE *f = ok ? fopen(path, "wb") : NULL;
    if (f) {
        static const unsigned char sig[8] = {137, 80, 78, 71, 13, 10, 26, 10};
        fwrite(sig, 1, 8, f);
        unsigned char ihdr[13] = {0};
        pn_test_be32(ihdr, w), pn_test_be32(ihdr + 4, h);
        ihdr[8] = 8, ihdr[9] = 6; // 8 bits, RGBA
        struct {
            const char *type;
            const unsigned char *data;
            uint32_t n;
        } chunks[3] = {{"IHDR", ihdr, 13}, {"IDAT", z, (uint32_t)zn}, {"IEND", NULL, 0}};
        for (int c = 0; c < 3; c++) {
            unsigned char len[4], crc[4];
            pn_test_be32(len, chunks[c].n);
            fwrite(len, 1, 4, f);
            fwrite(chunks[c].type, 1, 4, f);
            if (chunks[c].n)
                fwrite(chunks[c].data, 1, chunks[c].n, f);
            uLong k = crc32(0, (const Bytef *)chunks[c].type, 4);
            if (chunks[c].n)
                k = crc32(k, chunks[c].data, chunks[c].n);
            pn_test_be32(crc, (uint32_t)k);
            fwrite(crc, 1, 4, f);
        }
        ok = fclose(f) == 0;
    } else {
        ok = false;
    }
    free(raw);
    free(z);
    return ok;
}
