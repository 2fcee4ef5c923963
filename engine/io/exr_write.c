// Writing EXRs through OpenEXRCore (the C API of OpenEXR 3.x): checks, attributes, the encode
// pipeline's chunk loop, and the write to a temporary name renamed into place. The library keeps
// the channel list sorted by name whatever order channels were added in, so the encode pipeline
// is matched to our planes by channel name.
#include "io/exr.h"

#include <openexr.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "io/exr_core.h"
#include "io/file.h"

// Longest attribute or channel name the format allows (31 without the long-name flag).
#define PN_EXR_SHORT_NAME 31
#define PN_EXR_MAX_NAME 255

// Attributes the writer sets itself; a user attribute of the same name would clash.
static const char *const k_reserved_attrs[] = {
    "channels",         "compression",        "dataWindow",        "displayWindow",
    "lineOrder",        "pixelAspectRatio",   "screenWindowCenter", "screenWindowWidth",
    "tiles",            "type",               "name",              "version",
    "chunkCount",
};

static int is_reserved_attr(const char *name)
{
    for (size_t i = 0; i < sizeof k_reserved_attrs / sizeof k_reserved_attrs[0]; i++)
        if (strcmp(name, k_reserved_attrs[i]) == 0)
            return 1;
    return 0;
}

static pn_result validate_write(const char *path, int width, int height,
                                const pn_exr_channel *channels, int channel_count,
                                const pn_exr_attr *attrs, int attr_count, int *long_names)
{
    const char *p = path ? path : "(null)";
    if (!path || !*path) {
        pn_error("EXR output: no path given");
        return PN_ERR_INVALID;
    }
    if (width <= 0 || height <= 0 || (int64_t)width * 4 > INT32_MAX ||
        (uint64_t)width * (uint64_t)height > SIZE_MAX / 4) {
        pn_error("%s: invalid EXR size %dx%d", p, width, height);
        return PN_ERR_INVALID;
    }
    if (!channels) {
        pn_error("%s: no EXR channels given", p);
        return PN_ERR_INVALID;
    }
    if (channel_count <= 0 || channel_count > INT16_MAX) {
        pn_error("%s: an EXR needs 1 to %d channels (got %d)", p, INT16_MAX, channel_count);
        return PN_ERR_INVALID;
    }
    if (attr_count < 0 || (attr_count > 0 && !attrs)) {
        pn_error("%s: invalid EXR attribute list", p);
        return PN_ERR_INVALID;
    }
    *long_names = 0;
    for (int i = 0; i < channel_count; i++) {
        const char *n = channels[i].name;
        if (!n || !*n) {
            pn_error("%s: EXR channel %d has no name", p, i);
            return PN_ERR_INVALID;
        }
        if (strlen(n) > PN_EXR_MAX_NAME) {
            pn_error("%s: EXR channel name \"%.40s...\" is too long", p, n);
            return PN_ERR_INVALID;
        }
        if (strlen(n) > PN_EXR_SHORT_NAME)
            *long_names = 1;
        if (!channels[i].data) {
            pn_error("%s: EXR channel \"%s\" has no data", p, n);
            return PN_ERR_INVALID;
        }
        for (int j = 0; j < i; j++)
            if (strcmp(channels[j].name, n) == 0) {
                pn_error("%s: EXR channel \"%s\" given twice", p, n);
                return PN_ERR_INVALID;
            }
    }
    for (int i = 0; i < attr_count; i++) {
        const pn_exr_attr *a = &attrs[i];
        if (!a->name || !*a->name) {
            pn_error("%s: EXR attribute %d has no name", p, i);
            return PN_ERR_INVALID;
        }
        if (strlen(a->name) > PN_EXR_MAX_NAME) {
            pn_error("%s: EXR attribute name \"%.40s...\" is too long", p, a->name);
            return PN_ERR_INVALID;
        }
        if (strlen(a->name) > PN_EXR_SHORT_NAME)
            *long_names = 1;
        if (is_reserved_attr(a->name)) {
            pn_error("%s: EXR attribute name \"%s\" is reserved", p, a->name);
            return PN_ERR_INVALID;
        }
        switch (a->type) {
        case PN_EXR_ATTR_STRING:
            if (!a->s) {
                pn_error("%s: EXR string attribute \"%s\" has no value", p, a->name);
                return PN_ERR_INVALID;
            }
            if (strlen(a->s) > INT32_MAX / 2) {
                pn_error("%s: EXR string attribute \"%s\" is too long", p, a->name);
                return PN_ERR_INVALID;
            }
            break;
        case PN_EXR_ATTR_FLOAT:
        case PN_EXR_ATTR_INT:
        case PN_EXR_ATTR_V3F: break;
        default:
            pn_error("%s: EXR attribute \"%s\" has an unknown type %d", p, a->name, (int)a->type);
            return PN_ERR_INVALID;
        }
        for (int j = 0; j < i; j++)
            if (strcmp(attrs[j].name, a->name) == 0) {
                pn_error("%s: EXR attribute \"%s\" given twice", p, a->name);
                return PN_ERR_INVALID;
            }
    }
    return PN_OK;
}

static exr_result_t set_attr(exr_context_t ctx, int part, const pn_exr_attr *a)
{
    switch (a->type) {
    case PN_EXR_ATTR_STRING: return exr_attr_set_string(ctx, part, a->name, a->s);
    case PN_EXR_ATTR_FLOAT: return exr_attr_set_float(ctx, part, a->name, a->f[0]);
    case PN_EXR_ATTR_INT: return exr_attr_set_int(ctx, part, a->name, a->i);
    case PN_EXR_ATTR_V3F: {
        exr_attr_v3f_t v;
        v.x = a->f[0];
        v.y = a->f[1];
        v.z = a->f[2];
        return exr_attr_set_v3f(ctx, part, a->name, &v);
    }
    }
    return EXR_ERR_INVALID_ARGUMENT;
}

static const pn_exr_channel *find_channel(const pn_exr_channel *channels, int count,
                                          const char *name)
{
    for (int i = 0; name && i < count; i++)
        if (strcmp(channels[i].name, name) == 0)
            return &channels[i];
    return NULL;
}

// Writes the whole image into the open context; returns the first failure and what failed.
static exr_result_t write_image(exr_context_t ctx, int width, int height,
                                const pn_exr_channel *channels, int channel_count,
                                const pn_exr_attr *attrs, int attr_count, int long_names,
                                const char **what)
{
    exr_result_t rv;
    int part = 0;

    *what = "cannot set up EXR part";
    if (long_names && (rv = EXR_CALL(exr_set_longname_support(ctx, 1))))
        return rv;
    if ((rv = EXR_CALL(exr_add_part(ctx, NULL, EXR_STORAGE_SCANLINE, &part))))
        return rv;
    if ((rv = EXR_CALL(exr_initialize_required_attr_simple(ctx, part, width, height,
                                                           EXR_COMPRESSION_ZIP))))
        return rv;
    exr_attr_box2i_t dw;
    dw.min.x = 0;
    dw.min.y = 0;
    dw.max.x = width - 1;
    dw.max.y = height - 1;
    if ((rv = EXR_CALL(exr_set_data_window(ctx, part, &dw))))
        return rv;
    if ((rv = EXR_CALL(exr_set_compression(ctx, part, EXR_COMPRESSION_ZIP))))
        return rv;
    if ((rv = EXR_CALL(exr_set_lineorder(ctx, part, EXR_LINEORDER_INCREASING_Y))))
        return rv;

    *what = "cannot add EXR channel";
    for (int i = 0; i < channel_count; i++)
        if ((rv = EXR_CALL(exr_add_channel(ctx, part, channels[i].name, EXR_PIXEL_FLOAT,
                                           EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1))))
            return rv;

    *what = "cannot set EXR attribute";
    for (int i = 0; i < attr_count; i++)
        if ((rv = EXR_CALL(set_attr(ctx, part, &attrs[i]))))
            return rv;

    *what = "cannot write EXR header";
    if ((rv = EXR_CALL(exr_write_header(ctx))))
        return rv;

    int32_t lines = 0;
    if ((rv = EXR_CALL(exr_get_scanlines_per_chunk(ctx, part, &lines))))
        return rv;
    if (lines <= 0)
        return EXR_ERR_INVALID_ARGUMENT;

    *what = "cannot write EXR pixels";
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    for (int y = 0; y < height && rv == EXR_ERR_SUCCESS; y += lines) {
        exr_chunk_info_t cinfo;
        memset(&cinfo, 0, sizeof cinfo);
        if ((rv = EXR_CALL(exr_write_scanline_chunk_info(ctx, part, y, &cinfo))))
            break;
        if (cinfo.start_y < 0 || cinfo.height <= 0 || cinfo.start_y + cinfo.height > height ||
            cinfo.width != width) {
            pn_exr_msg_slot()[0] = '\0';
            rv = EXR_ERR_INCORRECT_CHUNK;
            break;
        }
        rv = EXR_CALL(initialized ? exr_encoding_update(ctx, part, &cinfo, &enc)
                                  : exr_encoding_initialize(ctx, part, &cinfo, &enc));
        if (rv)
            break;
        initialized = 1;
        for (int c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ch = &enc.channels[c];
            const pn_exr_channel *src = find_channel(channels, channel_count, ch->channel_name);
            if (!src) {
                snprintf(pn_exr_msg_slot(), PN_EXR_MSG_SIZE, "channel \"%s\" has no data",
                         ch->channel_name ? ch->channel_name : "?");
                rv = EXR_ERR_INVALID_ARGUMENT;
                break;
            }
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 4;
            ch->user_line_stride = 4 * width;
            ch->encode_from_ptr = (const uint8_t *)(src->data + (size_t)cinfo.start_y * width);
        }
        if (rv)
            break;
        if (y == 0 && (rv = EXR_CALL(exr_encoding_choose_default_routines(ctx, part, &enc))))
            break;
        rv = EXR_CALL(exr_encoding_run(ctx, part, &enc));
    }
    if (initialized)
        exr_encoding_destroy(ctx, &enc);
    return rv;
}

pn_result pn_exr_write(const char *path, int width, int height, const pn_exr_channel *channels,
                       int channel_count, const pn_exr_attr *attrs, int attr_count)
{
    int long_names = 0;
    pn_result r = validate_write(path, width, height, channels, channel_count, attrs, attr_count,
                                 &long_names);
    if (r != PN_OK)
        return r;

    char tmp[4096];
    if ((r = pn_file_tmp_path(path, tmp, sizeof tmp)) != PN_OK)
        return r;

    exr_context_initializer_t init = pn_exr_init();
    exr_context_t ctx = NULL;
    exr_result_t rv = EXR_CALL(exr_start_write(&ctx, tmp, EXR_WRITE_FILE_DIRECTLY, &init));
    if (rv != EXR_ERR_SUCCESS) {
        pn_error("%s: cannot create EXR: %s", path, pn_exr_msg(rv));
        if (ctx)
            exr_finish(&ctx);
        pn_file_discard(tmp);
        return PN_ERR_IO;
    }

    const char *what = "cannot write EXR";
    rv = write_image(ctx, width, height, channels, channel_count, attrs, attr_count, long_names,
                     &what);
    char msg[PN_EXR_MSG_SIZE];
    snprintf(msg, sizeof msg, "%s", pn_exr_msg(rv));

    // exr_finish writes the chunk offset table and closes the file: its failure fails the write.
    exr_result_t frv = EXR_CALL(exr_finish(&ctx));
    if (rv == EXR_ERR_SUCCESS && frv != EXR_ERR_SUCCESS) {
        rv = frv;
        what = "cannot finish EXR";
        snprintf(msg, sizeof msg, "%s", pn_exr_msg(frv));
    }
    if (rv != EXR_ERR_SUCCESS) {
        pn_error("%s: %s: %s", path, what, msg);
        pn_file_discard(tmp);
        return PN_ERR_IO;
    }
    return pn_file_commit(tmp, path);
}

