// PNG output through libpng: 8-bit RGB, deflate-compressed with libpng's default filters and
// level (the default render's 1280x720 preview: 108 KB, where stored blocks took 2.77 MB).
#include "io/png.h"

#include <errno.h>
#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "core/parallel.h"
#include "io/file.h"

// libpng's error callback: report with the output's path (its error pointer) and leave through
// the jump buffer set in write_png; it must not return.
static void on_png_error(png_structp png, png_const_charp msg)
{
    pn_error("%s: cannot write PNG: %s", (const char *)png_get_error_ptr(png), msg);
    png_longjmp(png, 1);
}

static void on_png_warning(png_structp png, png_const_charp msg)
{
    pn_warn("%s: PNG: %s", (const char *)png_get_error_ptr(png), msg);
}

// Writes the image to f; false after an error (reported).
static bool write_png(FILE *f, const char *path, int width, int height, const uint8_t *rgb)
{
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, (png_voidp)path, on_png_error, on_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!info) {
        pn_error("%s: out of memory writing PNG", path);
        png_destroy_write_struct(&png, NULL);
        return false;
    }
    // Nothing below changes a local that the error path reads after the jump.
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < height; y++)
        png_write_row(png, rgb + (size_t)y * (size_t)width * 3);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return true;
}

pn_result pn_png_write_rgb8(const char *path, int width, int height, const uint8_t *rgb)
{
    if (!path || !*path) {
        pn_error("PNG output: no path given");
        return PN_ERR_INVALID;
    }
    // PNG allows up to 2^31-1 per side (libpng's writer up to 10^6 by default: it reports more);
    // also keep the row and image sizes inside size_t.
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
    errno = 0;
    FILE *f = fopen(tmp, "wb");
    if (!f) {
        pn_error("%s: cannot create PNG: %s", path, strerror(errno));
        pn_file_discard(tmp);
        return PN_ERR_IO;
    }
    bool ok = write_png(f, path, width, height, rgb);
    errno = 0;
    if (ok && fflush(f) != 0) {
        pn_error("%s: cannot write PNG: %s", path, errno ? strerror(errno) : "short write");
        ok = false;
    }
    if (fclose(f) != 0 && ok) {
        pn_error("%s: cannot write PNG: %s", path, errno ? strerror(errno) : "short write");
        ok = false;
    }
    if (!ok) {
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

typedef struct tonemap_job {
    const float *rgba;
    float exposure;
    uint8_t *out;
} tonemap_job;

static void tonemap_pixels(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    (void)thread;
    const tonemap_job *j = ctx;
    for (uint64_t i = begin; i < end; i++)
        for (int c = 0; c < 3; c++)
            j->out[i * 3 + c] = tonemap_channel(j->rgba[i * 4 + c], j->exposure);
}

// On the worker threads: three double-precision pows a pixel were 44 ms of the demo's 1280x720
// frame on one core.
void pn_tonemap_srgb8(const float *rgba, int width, int height, float exposure, uint8_t *out)
{
    if (!rgba || !out || width <= 0 || height <= 0)
        return;
    tonemap_job job = {rgba, exposure, out};
    pn_parallel_for((uint64_t)width * (uint64_t)height, 16384, tonemap_pixels, &job);
}
