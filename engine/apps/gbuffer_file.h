// A G-buffer from an EXR (render --aovs's P.X/Y/Z, A and N.X/Y/Z layers, or any file with them):
// the points of bench --shader shadow --gbuffer and render --gbuffer, in place of the raster pass.
#pragma once
#include <stdint.h>

#include "core/error.h"

typedef struct pn_gbuffer_file {
    float *p, *n; // RGBA planes as the renderer's images hold them: P.w = A, N.w = 0
    uint32_t width, height;
} pn_gbuffer_file;

// Reads `path`; logs the file and the problem (unreadable, a missing layer, a non-finite value
// with its pixel) and returns an error, leaving *out zeroed.
pn_result pn_gbuffer_file_read(const char *path, pn_gbuffer_file *out);
void pn_gbuffer_file_free(pn_gbuffer_file *g);
