// Reading EXRs through OpenEXRCore: every channel of a scanline or tiled file's first part,
// converted to float, with every size a damaged or hostile file claims checked before anything is
// allocated. The decode pipeline is matched to our planes by channel name.
#include "io/exr.h"

#include <openexr.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "io/exr_core.h"
#include "io/file.h"


const float *pn_exr_image_channel(const pn_exr_image *img, const char *name)
{
    if (!img || !name || !img->names || !img->data)
        return NULL;
    for (int i = 0; i < img->channel_count; i++)
        if (img->names[i] && strcmp(img->names[i], name) == 0)
            return img->data[i];
    return NULL;
}

void pn_exr_image_free(pn_exr_image *img)
{
    if (!img)
        return;
    for (int i = 0; i < img->channel_count; i++) {
        if (img->names)
            free(img->names[i]);
        if (img->data)
            free(img->data[i]);
    }
    free(img->names);
    free(img->data);
    memset(img, 0, sizeof *img);
}

static char *copy_str(const char *s, size_t n)
{
    char *d = malloc(n + 1);
    if (d) {
        memcpy(d, s, n);
        d[n] = '\0';
    }
    return d;
}

// Total floats the reader is prepared to hold (4 GiB, e.g. 16 channels of 8K x 8K): a damaged or
// hostile header claiming more is refused before anything is allocated.
#define PN_EXR_MAX_FLOATS ((uint64_t)1 << 30)

typedef struct exr_reader {
    const char *path;
    exr_context_t ctx;
    exr_compression_t comp;
    exr_attr_box2i_t dw;
    int width, height;
    pn_exr_image *img;
} exr_reader;

static int channel_index(const pn_exr_image *img, const char *name)
{
    for (int i = 0; name && i < img->channel_count; i++)
        if (strcmp(img->names[i], name) == 0)
            return i;
    return -1;
}

// Points every decoder channel at the place of the chunk in our planes, matched by name.
// (x0, y0) is the chunk's top-left corner relative to the data window.
static pn_result aim_decoder(exr_reader *rd, exr_decode_pipeline_t *dec, int64_t x0, int64_t y0,
                             const exr_chunk_info_t *cinfo)
{
    if (x0 < 0 || y0 < 0 || cinfo->width <= 0 || cinfo->height <= 0 ||
        x0 + cinfo->width > rd->width || y0 + cinfo->height > rd->height) {
        pn_error("%s: EXR chunk %d lies outside the data window", rd->path, cinfo->idx);
        return PN_ERR_FORMAT;
    }
    for (int c = 0; c < dec->channel_count; c++) {
        exr_coding_channel_info_t *ch = &dec->channels[c];
        int k = channel_index(rd->img, ch->channel_name);
        if (k < 0) {
            pn_error("%s: EXR chunk %d has an unknown channel", rd->path, cinfo->idx);
            return PN_ERR_FORMAT;
        }
        if (ch->width != cinfo->width || ch->height != cinfo->height) {
            char nb[64];
            pn_error("%s: EXR channel \"%s\" has an unexpected size", rd->path,
                     pn_exr_printable(rd->img->names[k], strlen(rd->img->names[k]), nb, sizeof nb));
            return PN_ERR_FORMAT;
        }
        ch->user_bytes_per_element = 4;
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_pixel_stride = 4;
        ch->user_line_stride = 4 * rd->width;
        size_t at = (size_t)y0 * (size_t)rd->width + (size_t)x0;
        ch->decode_to_ptr = (uint8_t *)(rd->img->data[k] + at);
    }
    return PN_OK;
}

// Decodes one chunk; the pipeline is set up on the first call and reused after that.
static pn_result decode_chunk(exr_reader *rd, exr_decode_pipeline_t *dec, int *initialized,
                              const exr_chunk_info_t *cinfo, int64_t x0, int64_t y0)
{
    exr_result_t rv;
    if (!*initialized) {
        rv = EXR_CALL(exr_decoding_initialize(rd->ctx, 0, cinfo, dec));
        if (rv) {
            pn_error("%s: cannot decode EXR: %s", rd->path, pn_exr_msg(rv));
            return PN_ERR_FORMAT;
        }
        *initialized = 1;
        pn_result r = aim_decoder(rd, dec, x0, y0, cinfo);
        if (r != PN_OK)
            return r;
        rv = EXR_CALL(exr_decoding_choose_default_routines(rd->ctx, 0, dec));
    } else {
        rv = EXR_CALL(exr_decoding_update(rd->ctx, 0, cinfo, dec));
        if (rv == EXR_ERR_SUCCESS) {
            pn_result r = aim_decoder(rd, dec, x0, y0, cinfo);
            if (r != PN_OK)
                return r;
        }
    }
    if (rv == EXR_ERR_SUCCESS)
        rv = EXR_CALL(exr_decoding_run(rd->ctx, 0, dec));
    if (rv != EXR_ERR_SUCCESS) {
        pn_error("%s: cannot decode EXR chunk %d: %s", rd->path, cinfo->idx, pn_exr_msg(rv));
        return rv == EXR_ERR_OUT_OF_MEMORY ? PN_ERR_MEMORY : PN_ERR_FORMAT;
    }
    return PN_OK;
}

// Bytes a chunk of packed_size bytes can decode to, at most. Every codec but DWA has a bounded
// ratio: none 1, RLE 64 (2 bytes make a run of 128), ZIP and ZIPS 1032 (deflate's limit), PXR24
// 1376 (deflate of 3 bytes a float), B44 11, PIZ about 450 (a run of 255 16-bit values in 9 bits
// of Huffman code). One generous bound covers them all, with room for the small chunks whose
// headers dominate. Without it a file of a few hundred bytes could claim a 4 GiB image in one
// chunk, which the reader would allocate before the decoder finds the data missing.
#define PN_EXR_MAX_RATIO 2048
#define PN_EXR_RATIO_SLACK 65536

static pn_result check_chunk_size(exr_reader *rd, const exr_chunk_info_t *cinfo)
{
    if (rd->comp == EXR_COMPRESSION_DWAA || rd->comp == EXR_COMPRESSION_DWAB)
        return PN_OK; // RLE and deflate in series: no useful bound
    if (cinfo->packed_size > UINT64_MAX / PN_EXR_MAX_RATIO - PN_EXR_RATIO_SLACK ||
        cinfo->unpacked_size <= cinfo->packed_size * PN_EXR_MAX_RATIO + PN_EXR_RATIO_SLACK)
        return PN_OK;
    pn_error("%s: damaged EXR: chunk %d claims %llu bytes of pixels from %llu bytes of data", rd->path,
             cinfo->idx, (unsigned long long)cinfo->unpacked_size, (unsigned long long)cinfo->packed_size);
    return PN_ERR_FORMAT;
}

static pn_result chunk_info_error(exr_reader *rd, exr_result_t rv)
{
    pn_error("%s: damaged EXR: %s", rd->path, pn_exr_msg(rv));
    return rv == EXR_ERR_OUT_OF_MEMORY ? PN_ERR_MEMORY : PN_ERR_FORMAT;
}

// Scanline parts: chunks of `lines` rows from the top of the data window.
static pn_result read_scanlines(exr_reader *rd, int pass)
{
    int32_t lines = 0;
    exr_result_t rv = EXR_CALL(exr_get_scanlines_per_chunk(rd->ctx, 0, &lines));
    if (rv || lines <= 0) {
        pn_error("%s: damaged EXR: bad scanlines per chunk", rd->path);
        return PN_ERR_FORMAT;
    }
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    pn_result r = PN_OK;
    for (int64_t y = rd->dw.min.y; y <= rd->dw.max.y && r == PN_OK; y += lines) {
        exr_chunk_info_t cinfo;
        memset(&cinfo, 0, sizeof cinfo);
        rv = EXR_CALL(exr_read_scanline_chunk_info(rd->ctx, 0, (int)y, &cinfo));
        if (rv) {
            r = chunk_info_error(rd, rv);
            break;
        }
        if (pass == 0) { // the first pass only checks that every chunk is in the file, and plausible
            r = check_chunk_size(rd, &cinfo);
            continue;
        }
        r = decode_chunk(rd, &dec, &initialized, &cinfo, (int64_t)cinfo.start_x - rd->dw.min.x,
                         (int64_t)cinfo.start_y - rd->dw.min.y);
    }
    if (initialized)
        exr_decoding_destroy(rd->ctx, &dec);
    return r;
}

// Tiled parts: the full-resolution level (0, 0) only.
static pn_result read_tiles(exr_reader *rd, int pass)
{
    int32_t tw = 0, th = 0, lw = 0, lh = 0;
    exr_result_t rv = EXR_CALL(exr_get_tile_sizes(rd->ctx, 0, 0, 0, &tw, &th));
    if (!rv)
        rv = EXR_CALL(exr_get_level_sizes(rd->ctx, 0, 0, 0, &lw, &lh));
    if (rv || tw <= 0 || th <= 0 || lw != rd->width || lh != rd->height) {
        pn_error("%s: damaged EXR: bad tile description", rd->path);
        return PN_ERR_FORMAT;
    }
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    pn_result r = PN_OK;
    int ty = 0;
    for (int64_t y0 = 0; y0 < lh && r == PN_OK; y0 += th, ty++) {
        int tx = 0;
        for (int64_t x0 = 0; x0 < lw && r == PN_OK; x0 += tw, tx++) {
            exr_chunk_info_t cinfo;
            memset(&cinfo, 0, sizeof cinfo);
            rv = EXR_CALL(exr_read_tile_chunk_info(rd->ctx, 0, tx, ty, 0, 0, &cinfo));
            if (rv) {
                r = chunk_info_error(rd, rv);
                break;
            }
            if (pass == 0) {
                r = check_chunk_size(rd, &cinfo);
                continue;
            }
            r = decode_chunk(rd, &dec, &initialized, &cinfo, x0, y0);
        }
    }
    if (initialized)
        exr_decoding_destroy(rd->ctx, &dec);
    return r;
}

// OpenEXRCore decodes DWAA/DWAB only from 3.1.10 on.
static int core_has_dwa(void)
{
    int maj = 0, min = 0, patch = 0;
    exr_get_library_version(&maj, &min, &patch, NULL);
    return maj > 3 || (maj == 3 && (min > 1 || (min == 1 && patch >= 10)));
}

static pn_result read_part(exr_reader *rd)
{
    exr_result_t rv;
    int parts = 0;
    if ((rv = EXR_CALL(exr_get_count(rd->ctx, &parts))) || parts < 1) {
        pn_error("%s: EXR has no image part", rd->path);
        return PN_ERR_FORMAT;
    }
    exr_storage_t storage;
    if ((rv = EXR_CALL(exr_get_storage(rd->ctx, 0, &storage)))) {
        pn_error("%s: damaged EXR: %s", rd->path, pn_exr_msg(rv));
        return PN_ERR_FORMAT;
    }
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
        pn_error("%s: deep EXR images are not supported", rd->path);
        return PN_ERR_UNSUPPORTED;
    }
    exr_compression_t comp = EXR_COMPRESSION_NONE;
    if ((rv = EXR_CALL(exr_get_compression(rd->ctx, 0, &comp)))) {
        pn_error("%s: damaged EXR: %s", rd->path, pn_exr_msg(rv));
        return PN_ERR_FORMAT;
    }
    rd->comp = comp;
    if ((comp == EXR_COMPRESSION_DWAA || comp == EXR_COMPRESSION_DWAB) && !core_has_dwa()) {
        int maj = 0, min = 0, patch = 0;
        exr_get_library_version(&maj, &min, &patch, NULL);
        pn_error("%s: EXR uses DWA compression, which OpenEXRCore %d.%d.%d cannot decode "
                 "(3.1.10 and later can)",
                 rd->path, maj, min, patch);
        return PN_ERR_UNSUPPORTED;
    }
    if ((rv = EXR_CALL(exr_get_data_window(rd->ctx, 0, &rd->dw)))) {
        pn_error("%s: damaged EXR: %s", rd->path, pn_exr_msg(rv));
        return PN_ERR_FORMAT;
    }
    int64_t w = (int64_t)rd->dw.max.x - rd->dw.min.x + 1;
    int64_t h = (int64_t)rd->dw.max.y - rd->dw.min.y + 1;
    if (w <= 0 || h <= 0 || w > INT32_MAX / 4 || h > INT32_MAX) {
        pn_error("%s: EXR data window (%d,%d)-(%d,%d) is invalid", rd->path, rd->dw.min.x,
                 rd->dw.min.y, rd->dw.max.x, rd->dw.max.y);
        return PN_ERR_FORMAT;
    }
    rd->width = (int)w;
    rd->height = (int)h;

    const exr_attr_chlist_t *chl = NULL;
    if ((rv = EXR_CALL(exr_get_channels(rd->ctx, 0, &chl))) || !chl) {
        pn_error("%s: damaged EXR: no channel list", rd->path);
        return PN_ERR_FORMAT;
    }
    if (chl->num_channels <= 0 || chl->num_channels > INT16_MAX || !chl->entries) {
        pn_error("%s: EXR has no channels", rd->path);
        return PN_ERR_FORMAT;
    }
    for (int i = 0; i < chl->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[i];
        char n[64];
        pn_exr_printable(e->name.str, e->name.length > 0 ? (size_t)e->name.length : 0, n, sizeof n);
        if (e->pixel_type != EXR_PIXEL_UINT && e->pixel_type != EXR_PIXEL_HALF &&
            e->pixel_type != EXR_PIXEL_FLOAT) {
            pn_error("%s: EXR channel \"%s\" has unknown pixel type %d", rd->path, n,
                     (int)e->pixel_type);
            return PN_ERR_FORMAT;
        }
        if (e->x_sampling != 1 || e->y_sampling != 1) {
            pn_error("%s: EXR channel \"%s\" is subsampled (%d x %d), which is not supported",
                     rd->path, n, e->x_sampling, e->y_sampling);
            return PN_ERR_UNSUPPORTED;
        }
        if (!e->name.str || e->name.length <= 0) {
            pn_error("%s: EXR channel %d has no name", rd->path, i);
            return PN_ERR_FORMAT;
        }
    }
    if ((uint64_t)w * (uint64_t)h * (uint64_t)chl->num_channels > PN_EXR_MAX_FLOATS) {
        pn_error("%s: EXR image %lldx%lld with %d channels is too large", rd->path, (long long)w,
                 (long long)h, chl->num_channels);
        return PN_ERR_MEMORY;
    }

    // Pass 0 checks the chunk table (a truncated or damaged file fails here, before the pixel
    // planes are allocated); pass 1 decodes.
    pn_result r = storage == EXR_STORAGE_SCANLINE ? read_scanlines(rd, 0) : read_tiles(rd, 0);
    if (r != PN_OK)
        return r;

    pn_exr_image *img = rd->img;
    int n = chl->num_channels;
    img->names = calloc((size_t)n, sizeof *img->names);
    img->data = calloc((size_t)n, sizeof *img->data);
    if (!img->names || !img->data) {
        pn_error("%s: out of memory reading EXR", rd->path);
        return PN_ERR_MEMORY;
    }
    img->channel_count = n;
    img->width = rd->width;
    img->height = rd->height;
    for (int i = 0; i < n; i++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[i];
        img->names[i] = copy_str(e->name.str, (size_t)e->name.length);
        img->data[i] = calloc((size_t)w * (size_t)h, sizeof(float));
        if (!img->names[i] || !img->data[i]) {
            pn_error("%s: out of memory reading EXR (%lldx%lld, %d channels)", rd->path,
                     (long long)w, (long long)h, n);
            return PN_ERR_MEMORY;
        }
        for (int j = 0; j < i; j++)
            if (strcmp(img->names[j], img->names[i]) == 0) {
                char nb[64];
                pn_error("%s: EXR channel \"%s\" appears twice", rd->path,
                         pn_exr_printable(img->names[i], strlen(img->names[i]), nb, sizeof nb));
                return PN_ERR_FORMAT;
            }
    }
    return storage == EXR_STORAGE_SCANLINE ? read_scanlines(rd, 1) : read_tiles(rd, 1);
}

pn_result pn_exr_read(const char *path, pn_exr_image *out)
{
    if (!out) {
        pn_error("%s: no image to read the EXR into", path ? path : "(null)");
        return PN_ERR_INVALID;
    }
    memset(out, 0, sizeof *out);
    if (!path || !*path) {
        pn_error("EXR input: no path given");
        return PN_ERR_INVALID;
    }

    exr_context_initializer_t init = pn_exr_init();
    exr_reader rd;
    memset(&rd, 0, sizeof rd);
    rd.path = path;
    rd.img = out;
    exr_result_t rv = EXR_CALL(exr_start_read(&rd.ctx, path, &init));
    if (rv != EXR_ERR_SUCCESS) {
        if (rd.ctx)
            exr_finish(&rd.ctx);
        if (rv == EXR_ERR_FILE_ACCESS) {
            pn_error("%s: cannot open EXR: %s", path, pn_exr_msg(rv));
            return PN_ERR_IO;
        }
        pn_error("%s: not a readable EXR: %s", path, pn_exr_msg(rv));
        return rv == EXR_ERR_OUT_OF_MEMORY ? PN_ERR_MEMORY : PN_ERR_FORMAT;
    }

    pn_result r = read_part(&rd);
    exr_finish(&rd.ctx);
    if (r != PN_OK)
        pn_exr_image_free(out);
    return r;
}
