// The scene's data: materials, meshes, the ground, moved objects and bounds; validation; destruction.
#include "scene/scene.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "scene/anim.h"

void pn_scene_destroy(pn_scene *s)
{
    for (uint32_t i = 0; i < s->texture_count; i++)
        free(s->textures[i].rgba);
    free(s->textures);
    free(s->vertices);
    free(s->indices);
    free(s->draws);
    free(s->materials);
    for (uint32_t i = 0; i < s->mesh_count; i++)
        free(s->meshes[i].tris);
    free(s->meshes);
    free(s->objects);
    if (s->anim)
        pn_scene_anim_destroy(s->anim);
    memset(s, 0, sizeof *s);
}

// The animation's arrays belong to the scene as its vertices do: freed here, with the rest of its
// data, so that the scene's data calls nothing of the posing above it (anim.c).
void pn_scene_anim_destroy(pn_scene_anim *a)
{
    if (!a)
        return;
    for (uint32_t i = 0; i < a->channel_count; i++) {
        free(a->channels[i].times);
        free(a->channels[i].values);
    }
    for (uint32_t i = 0; i < a->prim_count; i++) {
        free(a->prims[i].positions);
        free(a->prims[i].normals);
        free(a->prims[i].uvs);
        free(a->prims[i].triangles);
    }
    free(a->channels);
    free(a->prims);
    free(a->nodes);
    free(a->order);
    free(a);
}

// The box of the vertices object o's triangles use: its share of the bounds.
void pn_scene_object_bounds(const pn_scene *s, uint32_t index, float lo[3], float hi[3])
{
    const pn_scene_object *o = &s->objects[index];
    for (int k = 0; k < 3; k++)
        lo[k] = FLT_MAX, hi[k] = -FLT_MAX;
    for (uint32_t i = o->first_index; i < o->first_index + o->index_count; i++) {
        const float *p = s->vertices[s->indices[i]].pos;
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], p[k]);
            hi[k] = fmaxf(hi[k], p[k]);
        }
    }
}

pn_result pn_scene_move_object(pn_scene *s, uint32_t index, const float delta[3])
{
    if (index >= s->object_count) {
        pn_error("%s: no object %u to move (the scene has %u: glTF nodes with a mesh)", s->name, index,
                 s->object_count);
        return PN_ERR_INVALID;
    }
    pn_scene_object *o = &s->objects[index];
    float lo[3], hi[3];
    pn_scene_object_bounds(s, index, lo, hi);
    // The bounds follow from the object's box alone unless it held one of their faces and moves
    // inwards from it: then another vertex may hold that face, and only a pass over the whole scene
    // finds which (the demo's live moves would pay it on every move, 0.2 s on 4M triangles).
    bool rescan = false;
    for (int k = 0; k < 3; k++)
        rescan = rescan || (lo[k] <= s->bounds_min[k] && delta[k] > 0) || (hi[k] >= s->bounds_max[k] && delta[k] < 0);
    for (uint32_t i = o->first_vertex; i < o->first_vertex + o->vertex_count; i++)
        for (int k = 0; k < 3; k++)
            s->vertices[i].pos[k] += delta[k];
    for (int k = 0; k < 3; k++)
        o->to_world[k][3] += delta[k];
    if (rescan) {
        pn_scene_update_bounds(s);
        return PN_OK;
    }
    // The moved box without a second pass: rounding x + d to float is nondecreasing in x, so the
    // least (greatest) moved coordinate is the least (greatest) one moved, to the bit.
    for (int k = 0; k < 3; k++) {
        s->bounds_min[k] = fminf(s->bounds_min[k], lo[k] + delta[k]);
        s->bounds_max[k] = fmaxf(s->bounds_max[k], hi[k] + delta[k]);
    }
    return PN_OK;
}

void pn_scene_update_bounds(pn_scene *s)
{
    float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (uint32_t i = 0; i < s->index_count; i++) {
        const float *p = s->vertices[s->indices[i]].pos;
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], p[k]);
            hi[k] = fmaxf(hi[k], p[k]);
        }
    }
    if (s->index_count == 0)
        for (int k = 0; k < 3; k++)
            lo[k] = hi[k] = 0.0f;
    memcpy(s->bounds_min, lo, sizeof lo);
    memcpy(s->bounds_max, hi, sizeof hi);
}

pn_result pn_scene_add_material(pn_scene *s, const float base_color[4], uint32_t *index)
{
    pn_material *m = realloc(s->materials, (s->material_count + 1) * sizeof *m);
    if (!m)
        return PN_ERR_MEMORY;
    s->materials = m;
    memcpy(m[s->material_count].base_color, base_color, 4 * sizeof(float));
    m[s->material_count].texture = -1;
    m[s->material_count].alpha_cutoff = 0; // opaque
    m[s->material_count].double_sided = true;
    *index = s->material_count++;
    return PN_OK;
}

pn_result pn_scene_add_texture(pn_scene *s, uint32_t width, uint32_t height, uint8_t *rgba, int32_t *index)
{
    pn_texture *t = s->texture_count < INT32_MAX ? realloc(s->textures, (s->texture_count + 1) * sizeof *t) : NULL;
    if (!t) {
        free(rgba);
        return PN_ERR_MEMORY;
    }
    s->textures = t;
    t[s->texture_count] = (pn_texture){.width = width, .height = height, .rgba = rgba};
    *index = (int32_t)s->texture_count++;
    return PN_OK;
}

pn_result pn_scene_add_mesh(pn_scene *s, const pn_vertex *v, uint32_t vn, const uint32_t *idx,
                            uint32_t in, uint32_t material)
{
    if ((uint64_t)s->vertex_count + vn > UINT32_MAX || (uint64_t)s->index_count + in > UINT32_MAX)
        return PN_ERR_MEMORY;
    pn_vertex *nv = realloc(s->vertices, (size_t)(s->vertex_count + vn) * sizeof *nv);
    if (!nv)
        return PN_ERR_MEMORY;
    s->vertices = nv;
    uint32_t *ni = realloc(s->indices, (size_t)(s->index_count + in) * sizeof *ni);
    if (!ni)
        return PN_ERR_MEMORY;
    s->indices = ni;
    pn_draw *nd = realloc(s->draws, (s->draw_count + 1) * sizeof *nd);
    if (!nd)
        return PN_ERR_MEMORY;
    s->draws = nd;

    memcpy(nv + s->vertex_count, v, vn * sizeof *v);
    for (uint32_t i = 0; i < in; i++)
        ni[s->index_count + i] = idx[i] + s->vertex_count;
    nd[s->draw_count++] = (pn_draw){.first_index = s->index_count, .index_count = in, .material = material};
    s->vertex_count += vn;
    s->index_count += in;
    return PN_OK;
}

pn_result pn_scene_add_ground(pn_scene *s, float scale)
{
    const float *lo = s->bounds_min, *hi = s->bounds_max;
    float extent = fmaxf(fmaxf(hi[0] - lo[0], hi[2] - lo[2]), hi[1] - lo[1]);
    if (!(extent > 0.0f))
        extent = 1.0f;
    float half = 0.5f * scale * fmaxf(hi[0] - lo[0], hi[2] - lo[2]);
    if (!(half > 0.0f))
        half = 0.5f * scale * extent;
    float cx = 0.5f * (lo[0] + hi[0]), cz = 0.5f * (lo[2] + hi[2]);
    // The plane sits a hair under the lowest vertex so that bottom faces lying exactly on it do
    // not z-fight with it: 2^-12 of the scene's size is above the 24-bit depth resolution at any
    // framing distance and still far below a pixel's footprint, so contact shadows stay attached.
    float y = lo[1] - extent * 0x1p-12f;
    pn_vertex v[4];
    const float corner[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int i = 0; i < 4; i++)
        v[i] = (pn_vertex){.pos = {cx + corner[i][0] * half, y, cz + corner[i][1] * half},
                           .normal = {0, 1, 0},
                           .uv = {0.5f + 0.5f * corner[i][0], 0.5f + 0.5f * corner[i][1]}};
    // Counter-clockwise seen from above (+Y).
    const uint32_t idx[6] = {0, 3, 2, 0, 2, 1};
    uint32_t mat;
    pn_result r = pn_scene_add_material(s, (const float[4]){0.75f, 0.75f, 0.75f, 1.0f}, &mat);
    if (r == PN_OK)
        r = pn_scene_add_mesh(s, v, 4, idx, 6, mat);
    if (r == PN_OK)
        pn_scene_update_bounds(s);
    return r;
}

pn_result pn_scene_validate(const pn_scene *s)
{
    if (s->index_count < 3 || s->index_count % 3 != 0) {
        pn_error("%s: no triangles", s->name);
        return PN_ERR_FORMAT;
    }
    for (uint32_t i = 0; i < s->index_count; i++)
        if (s->indices[i] >= s->vertex_count) {
            pn_error("%s: index %u out of range (%u vertices)", s->name, s->indices[i], s->vertex_count);
            return PN_ERR_FORMAT;
        }
    for (uint32_t i = 0; i < s->vertex_count; i++)
        for (int k = 0; k < 3; k++)
            if (!isfinite(s->vertices[i].pos[k]) || !isfinite(s->vertices[i].normal[k])) {
                pn_error("%s: vertex %u has a non-finite position or normal", s->name, i);
                return PN_ERR_FORMAT;
            }
    // Float positions must resolve the scene: far from the origin a small scene collapses onto a few
    // representable points. Below 256 float steps across (8 bits) shadows and the G-buffer would be
    // noise, so such input is refused rather than rendered wrong.
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, mag = 0, ext = 0;
    for (uint32_t i = 0; i < s->vertex_count; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], s->vertices[i].pos[k]);
            hi[k] = fmaxf(hi[k], s->vertices[i].pos[k]);
        }
    for (int k = 0; k < 3 && s->vertex_count; k++) {
        mag = fmaxf(mag, fmaxf(fabsf(lo[k]), fabsf(hi[k])));
        ext = fmaxf(ext, hi[k] - lo[k]);
    }
    // Every stage squares distances in float (framing, the light, the tree, shading): beyond 1e18
    // from the origin, 3 * (2e18)^2 no longer fits below FLT_MAX and they overflow to infinity.
    if (mag > 1e18f) {
        pn_error("%s: positions reach %.3g from the origin; beyond 1e18 float arithmetic overflows: scale the "
                 "scene down",
                 s->name, (double)mag);
        return PN_ERR_UNSUPPORTED;
    }
    float ulp = nextafterf(mag, INFINITY) - mag;
    if (ext > 0 && ext < 256 * ulp) {
        pn_error("%s: the scene is %.3g across at %.3g from the origin, only %.0f float steps: move it towards "
                 "the origin",
                 s->name, (double)ext, (double)mag, (double)(ext / ulp));
        return PN_ERR_UNSUPPORTED;
    }
    for (uint32_t i = 0; i < s->draw_count; i++)
        if (s->draws[i].material >= s->material_count ||
            (uint64_t)s->draws[i].first_index + s->draws[i].index_count > s->index_count) {
            pn_error("%s: draw %u references a missing material or index range", s->name, i);
            return PN_ERR_FORMAT;
        }
    for (uint32_t i = 0; i < s->material_count; i++)
        if (s->materials[i].texture >= (int32_t)s->texture_count) {
            pn_error("%s: material %u references missing texture %d", s->name, i, s->materials[i].texture);
            return PN_ERR_FORMAT;
        }
    return PN_OK;
}
