// The GPU's triangle pool (bvh.h): the triangles' vertices in scene order, which the exact mode's
// BVH leaves index, followed by the alpha masks.
#include <stdlib.h>
#include <string.h>

#include "accel/alpha.h"
#include "accel/bvh.h"

pn_result pn_triangle_pool(const pn_scene *s, float **out, uint64_t *bytes)
{
    uint32_t n = pn_scene_triangle_count(s);
    // The masks of alpha-masked triangles follow the triangles (accel/alpha.h); none: nothing.
    *bytes = ((uint64_t)(n ? n : 1) * 3 + pn_alpha_pool_vec4s(s)) * 4 * sizeof(float);
    *out = calloc(1, *bytes);
    if (!*out)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < n; i++)
        for (int j = 0; j < 3; j++)
            memcpy(*out + 12 * i + 4 * j, s->vertices[s->indices[3 * i + j]].pos, 3 * sizeof(float));
    pn_result r = pn_alpha_masked_triangles(s) ? pn_alpha_pool_fill(s, *out) : PN_OK;
    if (r != PN_OK) {
        free(*out);
        *out = NULL;
    }
    return r;
}
