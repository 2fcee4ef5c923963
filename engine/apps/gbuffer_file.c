// A G-buffer read from an EXR's P, A and N layers.
#include "apps/gbuffer_file.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "io/exr.h"

pn_result pn_gbuffer_file_read(const char *path, pn_gbuffer_file *out)
{
    memset(out, 0, sizeof *out);
    pn_exr_image img;
    if (pn_exr_read(path, &img) != PN_OK)
        return PN_ERR_IO;
    const char *names[7] = {"P.X", "P.Y", "P.Z", "A", "N.X", "N.Y", "N.Z"};
    const float *ch[7];
    for (int c = 0; c < 7; c++)
        if (!(ch[c] = pn_exr_image_channel(&img, names[c]))) {
            pn_error("%s: no %s channel (write it with render --aovs)", path, names[c]);
            pn_exr_image_free(&img);
            return PN_ERR_FORMAT;
        }
    size_t px = (size_t)img.width * img.height;
    // The shadow rays start at P and leave along N: a non-finite one has no path through the tree.
    // A render's AOVs are finite everywhere (0 off geometry), so anything else is a damaged file.
    for (int c = 0; c < 7; c++)
        for (size_t i = 0; i < px; i++)
            if (!isfinite(ch[c][i])) {
                pn_error("%s: %s is not finite at pixel (%zu, %zu)", path, names[c], i % (size_t)img.width,
                         i / (size_t)img.width);
                pn_exr_image_free(&img);
                return PN_ERR_FORMAT;
            }
    out->p = calloc(px * 4, sizeof(float));
    out->n = calloc(px * 4, sizeof(float));
    if (!out->p || !out->n) {
        pn_error("%s: out of memory for a %dx%d G-buffer", path, img.width, img.height);
        pn_gbuffer_file_free(out);
        pn_exr_image_free(&img);
        return PN_ERR_MEMORY;
    }
    for (size_t i = 0; i < px; i++)
        for (int k = 0; k < 4; k++) {
            out->p[4 * i + k] = ch[k][i];
            out->n[4 * i + k] = k < 3 ? ch[4 + k][i] : 0.0f;
        }
    out->width = (uint32_t)img.width;
    out->height = (uint32_t)img.height;
    pn_exr_image_free(&img);
    return PN_OK;
}

void pn_gbuffer_file_free(pn_gbuffer_file *g)
{
    free(g->p);
    free(g->n);
    memset(g, 0, sizeof *g);
}
