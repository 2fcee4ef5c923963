// Alpha-masked casters in the triangle pool (alpha.h).
#include "accel/alpha.h"

#include <stdlib.h>
#include <string.h>

static void put_u32(float *f, uint32_t v) { memcpy(f, &v, sizeof v); }

static bool masked(const pn_scene *s, uint32_t material)
{
    return material < s->material_count && s->materials[material].alpha_cutoff > 0;
}

uint64_t pn_alpha_masked_triangles(const pn_scene *s)
{
    uint64_t n = 0;
    for (uint32_t d = 0; d < s->draw_count; d++)
        n += masked(s, s->draws[d].material) ? s->draws[d].index_count / 3 : 0;
    return n;
}

pn_result pn_alpha_triangle_flags(const pn_scene *s, uint8_t **out)
{
    *out = NULL;
    if (pn_alpha_masked_triangles(s) == 0)
        return PN_OK;
    uint8_t *f = malloc(pn_scene_triangle_count(s) ? pn_scene_triangle_count(s) : 1);
    if (!f)
        return PN_ERR_MEMORY;
    pn_alpha_mark(s, f);
    *out = f;
    return PN_OK;
}

void pn_alpha_mark(const pn_scene *s, uint8_t *out)
{
    memset(out, 0, pn_scene_triangle_count(s));
    for (uint32_t d = 0; d < s->draw_count; d++) {
        const pn_draw *dr = &s->draws[d];
        if (masked(s, dr->material)) // the triangles pn_alpha_pool_fill gives a record
            for (uint32_t k = dr->first_index; k + 2 < dr->first_index + dr->index_count; k += 3)
                out[k / 3] = 1;
    }
}

// The texture a masked material's alpha comes from, or NULL.
static const pn_texture *alpha_texture(const pn_scene *s, uint32_t material)
{
    int32_t t = s->materials[material].texture;
    return t >= 0 && (uint32_t)t < s->texture_count ? &s->textures[t] : NULL;
}

uint64_t pn_alpha_pool_vec4s(const pn_scene *s)
{
    uint64_t n = 0;
    for (uint32_t m = 0; m < s->material_count; m++) {
        if (!masked(s, m))
            continue;
        const pn_texture *t = alpha_texture(s, m);
        n += 2 + (t ? ((uint64_t)t->width * t->height + 15) / 16 : 0);
    }
    return n + 2 * pn_alpha_masked_triangles(s);
}

pn_result pn_alpha_pool_fill(const pn_scene *s, float *pool)
{
    uint64_t at = 3ull * pn_scene_triangle_count(s); // the next free vec4
    uint32_t materials = s->material_count;
    uint32_t *header = calloc(materials ? materials : 1, sizeof *header); // per material: its header's vec4
    if (!header)
        return PN_ERR_MEMORY;
    for (uint32_t m = 0; m < materials; m++) {
        if (!masked(s, m))
            continue;
        const pn_texture *t = alpha_texture(s, m);
        float *h = pool + 4 * at;
        header[m] = (uint32_t)at;
        put_u32(h + 0, t ? t->width : 0);
        put_u32(h + 1, t ? t->height : 0);
        put_u32(h + 2, (uint32_t)(at + 2));
        h[3] = s->materials[m].alpha_cutoff;
        h[4] = s->materials[m].base_color[3];
        h[5] = h[6] = h[7] = 0;
        at += 2;
        if (t) {
            uint64_t texels = (uint64_t)t->width * t->height;
            uint32_t *w = (uint32_t *)(void *)(pool + 4 * at);
            memset(w, 0, ((texels + 15) / 16) * 16);
            for (uint64_t i = 0; i < texels; i++)
                w[i / 4] |= (uint32_t)t->rgba[4 * i + 3] << (8 * (i % 4));
            at += (texels + 15) / 16;
        }
    }
    for (uint32_t d = 0; d < s->draw_count; d++) {
        const pn_draw *dr = &s->draws[d];
        if (!masked(s, dr->material))
            continue;
        for (uint32_t k = dr->first_index; k + 2 < dr->first_index + dr->index_count; k += 3) {
            uint32_t tri = k / 3;
            float *r = pool + 4 * at;
            for (int j = 0; j < 3; j++)
                memcpy(r + 2 * j, s->vertices[s->indices[k + (uint32_t)j]].uv, 2 * sizeof(float));
            put_u32(r + 6, header[dr->material]);
            r[7] = 0;
            put_u32(pool + 12 * (uint64_t)tri + 3, (uint32_t)at);
            at += 2;
        }
    }
    free(header);
    return PN_OK;
}
