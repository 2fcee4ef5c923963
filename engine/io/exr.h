// OpenEXR files through OpenEXRCore (the C API). All channels are 32-bit float scanlines,
// row 0 at the top, ZIP-compressed.
#pragma once
#include <stdint.h>

#include "core/error.h"

typedef struct pn_exr_channel {
    const char *name;  // e.g. "R", "shadow.V", "P.X"
    const float *data; // width*height values, row-major, row 0 at the top
} pn_exr_channel;

typedef enum pn_exr_attr_type { PN_EXR_ATTR_STRING, PN_EXR_ATTR_FLOAT, PN_EXR_ATTR_INT, PN_EXR_ATTR_V3F } pn_exr_attr_type;

typedef struct pn_exr_attr {
    const char *name; // e.g. "penumbra/scene"
    pn_exr_attr_type type;
    const char *s; // PN_EXR_ATTR_STRING
    float f[3];    // PN_EXR_ATTR_FLOAT uses f[0]; PN_EXR_ATTR_V3F all three
    int32_t i;     // PN_EXR_ATTR_INT
} pn_exr_attr;

// Writes an EXR to a temporary name beside `path` and renames it into place. Channel order
// does not matter (the file stores them sorted by name). Logs and returns an error naming `path`.
pn_result pn_exr_write(const char *path, int width, int height, const pn_exr_channel *channels,
                       int channel_count, const pn_exr_attr *attrs, int attr_count);

typedef struct pn_exr_image {
    int width, height;
    int channel_count;
    char **names;  // channel_count names
    float **data;  // channel_count planes of width*height floats (half and uint converted)
} pn_exr_image;

// Reads every channel of a scanline or tiled EXR's first part, converted to float.
// Logs and returns an error naming `path` on failure, leaving *out zeroed.
pn_result pn_exr_read(const char *path, pn_exr_image *out);

// The plane of the channel called `name`, or NULL.
const float *pn_exr_image_channel(const pn_exr_image *img, const char *name);

void pn_exr_image_free(pn_exr_image *img);
