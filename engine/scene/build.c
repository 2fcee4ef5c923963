// Building a pn_scene from a scene file's parts (build.h): world-space vertices with normals
// transformed by the inverse-transpose, flat normals where a file has none or a degenerate one,
// the local triangles of each mesh for per-object trees, RGBA8 textures, the bounds.
#include "scene/build.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

// Grows *p to hold `need` elements of `size` bytes, capacity by half again as now (amortised
// appends). Returns false, *p untouched, when out of memory.
static bool grow(void **p, size_t *cap, size_t need, size_t size)
{
    if (need <= *cap)
        return true;
    size_t c = *cap + *cap / 2 + 64;
    if (c < need)
        c = need;
    if (c > SIZE_MAX / size)
        return false;
    void *q = realloc(*p, c * size);
    if (!q)
        return false;
    *p = q;
    *cap = c;
    return true;
}

// Shrinks an array to its size once it is complete.
static void *trim(void *p, size_t n, size_t size)
{
    if (!p || !n)
        return p;
    void *q = realloc(p, n * size);
    return q ? q : p;
}

static bool finite3(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

bool pn_scene_unit3(double v[3])
{
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0.0) || !isfinite(len))
        return false;
    v[0] /= len, v[1] /= len, v[2] /= len;
    return finite3(v);
}

// Unit normal of triangle (a, b, c) wound counter-clockwise, or false if it has no area.
static bool face_normal(const float a[3], const float b[3], const float c[3], double n[3])
{
    double e1[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
    double e2[3] = {(double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2]};
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    return pn_scene_unit3(n);
}

static void set_normal(pn_vertex *v, const double n[3])
{
    v->normal[0] = (float)n[0], v->normal[1] = (float)n[1], v->normal[2] = (float)n[2];
}

static void set_up_normal(pn_vertex *v)
{
    v->normal[0] = 0.0f, v->normal[1] = 1.0f, v->normal[2] = 0.0f;
}

pn_scene_xform pn_scene_xform_from_matrix(const double m[16])
{
    pn_scene_xform f = {0};
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++)
            f.a[r][c] = m[c * 4 + r];
        f.t[r] = m[12 + r];
    }
    const double(*a)[3] = f.a;
    double cof[3][3] = {
        {a[1][1] * a[2][2] - a[1][2] * a[2][1], a[1][2] * a[2][0] - a[1][0] * a[2][2],
         a[1][0] * a[2][1] - a[1][1] * a[2][0]},
        {a[0][2] * a[2][1] - a[0][1] * a[2][2], a[0][0] * a[2][2] - a[0][2] * a[2][0],
         a[0][1] * a[2][0] - a[0][0] * a[2][1]},
        {a[0][1] * a[1][2] - a[0][2] * a[1][1], a[0][2] * a[1][0] - a[0][0] * a[1][2],
         a[0][0] * a[1][1] - a[0][1] * a[1][0]},
    };
    f.det = a[0][0] * cof[0][0] + a[0][1] * cof[0][1] + a[0][2] * cof[0][2];
    // inverse-transpose = cof / det; the scale does not matter as normals are renormalised, the
    // sign does (a mirroring transform must not turn normals inside out). With det == 0 the
    // cofactor still gives the normal of the flattened surface.
    double s = f.det < 0.0 ? -1.0 : 1.0;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            f.normal[r][c] = s * cof[r][c];
    return f;
}

// The world position of local vertex i; false if it is not finite.
static bool world_pos(const pn_scene_xform *xf, const float *positions, uint64_t i, float out[3])
{
    const float *p = &positions[i * 3];
    for (int r = 0; r < 3; r++) {
        double v = xf->a[r][0] * p[0] + xf->a[r][1] * p[1] + xf->a[r][2] * p[2] + xf->t[r];
        out[r] = (float)v;
        if (!isfinite(out[r]))
            return false;
    }
    return true;
}

static void set_uv(pn_vertex *v, const float *uvs, uint64_t i)
{
    float u = uvs ? uvs[i * 2] : 0.0f, w = uvs ? uvs[i * 2 + 1] : 0.0f;
    v->uv[0] = isfinite(u) ? u : 0.0f;
    v->uv[1] = isfinite(w) ? w : 0.0f;
}

// Appends the primitive's local triangles to mesh m's soup, in the order of its world triangles.
static pn_result capture(pn_scene_build *b, uint32_t m, const pn_scene_build_prim *p)
{
    pn_scene_mesh *mesh = &b->scene.meshes[m];
    size_t cap = b->mesh_tri_cap[m];
    if (mesh->triangle_count + p->triangle_count > UINT32_MAX ||
        !grow((void **)&mesh->tris, &cap, mesh->triangle_count + p->triangle_count, sizeof *mesh->tris))
        return PN_ERR_MEMORY;
    b->mesh_tri_cap[m] = (uint32_t)cap;
    for (uint64_t t = 0; t < p->triangle_count; t++)
        for (int j = 0; j < 3; j++)
            memcpy(mesh->tris[mesh->triangle_count + t][j], &p->positions[p->triangles[3 * t + j] * 3], 3 * sizeof(float));
    mesh->triangle_count += (uint32_t)p->triangle_count;
    return PN_OK;
}

// Zero or NaN normals (flagged 1 in `bad`) take the normal of the first triangle using the vertex.
static void repair_normals(pn_vertex *vout, const uint32_t *tri, uint64_t ntri, uint8_t *bad)
{
    for (uint64_t t = 0; t < ntri; t++) {
        const uint32_t *c = &tri[3 * t];
        if (!bad[c[0]] && !bad[c[1]] && !bad[c[2]])
            continue;
        double fn[3];
        if (!face_normal(vout[c[0]].pos, vout[c[1]].pos, vout[c[2]].pos, fn))
            continue;
        for (int j = 0; j < 3; j++)
            if (bad[c[j]] == 1) {
                bad[c[j]] = 2;
                set_normal(&vout[c[j]], fn);
            }
    }
}

pn_result pn_scene_build_place(const pn_scene_build_prim *p, const pn_scene_xform *xf, pn_vertex *vout,
                               uint64_t *bad_vertex)
{
    const uint64_t n = p->vertex_count, ntri = p->triangle_count;
    if (p->normals) {
        uint8_t *bad = calloc(n ? n : 1, 1);
        if (!bad)
            return PN_ERR_MEMORY;
        bool any_bad = false;
        for (uint64_t i = 0; i < n; i++) {
            pn_vertex *v = &vout[i];
            if (!world_pos(xf, p->positions, i, v->pos)) {
                free(bad);
                *bad_vertex = i;
                return PN_ERR_FORMAT;
            }
            const float *q = &p->normals[i * 3];
            double nw[3];
            for (int r = 0; r < 3; r++)
                nw[r] = xf->normal[r][0] * q[0] + xf->normal[r][1] * q[1] + xf->normal[r][2] * q[2];
            if (pn_scene_unit3(nw)) {
                set_normal(v, nw);
            } else {
                bad[i] = 1;
                any_bad = true;
                set_up_normal(v);
            }
            set_uv(v, p->uvs, i);
        }
        if (any_bad)
            repair_normals(vout, p->triangles, ntri, bad);
        free(bad);
        return PN_OK;
    }
    // No normals: flat shading, three vertices of their own per triangle.
    for (uint64_t t = 0; t < ntri; t++) {
        pn_vertex *v = vout + 3 * t;
        for (int j = 0; j < 3; j++) {
            uint32_t src = p->triangles[3 * t + (uint64_t)j];
            if (!world_pos(xf, p->positions, src, v[j].pos)) {
                *bad_vertex = src;
                return PN_ERR_FORMAT;
            }
            set_uv(&v[j], p->uvs, src);
        }
        double fn[3];
        for (int j = 0; j < 3; j++) {
            if (face_normal(v[0].pos, v[1].pos, v[2].pos, fn))
                set_normal(&v[j], fn);
            else
                set_up_normal(&v[j]);
        }
    }
    return PN_OK;
}

pn_result pn_scene_build_add_prim(pn_scene_build *b, const pn_scene_build_prim *p, const pn_scene_xform *xf,
                                  uint64_t *bad_vertex)
{
    pn_scene *s = &b->scene;
    const uint64_t n = p->vertex_count, ntri = p->triangle_count;
    // A mirroring transform turns counter-clockwise into clockwise; swap to keep the front face.
    if (xf->det < 0.0)
        for (uint64_t i = 0; i < ntri; i++) {
            uint32_t t = p->triangles[3 * i + 1];
            p->triangles[3 * i + 1] = p->triangles[3 * i + 2];
            p->triangles[3 * i + 2] = t;
        }
    if (p->capture_mesh >= 0) {
        assert((uint64_t)p->capture_mesh < s->mesh_count);
        pn_result r = capture(b, (uint32_t)p->capture_mesh, p);
        if (r != PN_OK)
            return r;
    }

    const uint64_t out_verts = p->normals ? n : ntri * 3;
    if (s->vertex_count + out_verts > PN_SCENE_MAX_VERTICES || s->index_count + ntri * 3 > PN_SCENE_MAX_INDICES)
        return PN_ERR_MEMORY;
    if (!grow((void **)&s->vertices, &b->vertex_cap, s->vertex_count + out_verts, sizeof *s->vertices) ||
        !grow((void **)&s->indices, &b->index_cap, s->index_count + ntri * 3, sizeof *s->indices) ||
        !grow((void **)&s->draws, &b->draw_cap, (size_t)s->draw_count + 1, sizeof *s->draws))
        return PN_ERR_MEMORY;
    const uint32_t base = s->vertex_count, ibase = s->index_count;
    pn_result r = pn_scene_build_place(p, xf, s->vertices + base, bad_vertex);
    if (r != PN_OK)
        return r;
    uint32_t *iout = s->indices + ibase;
    // The primitive's own numbering; flat shading: three vertices of their own per triangle.
    for (uint64_t k = 0; k < ntri * 3; k++)
        iout[k] = (uint32_t)(base + (p->normals ? p->triangles[k] : k));
    s->vertex_count += (uint32_t)out_verts;
    s->index_count += (uint32_t)(ntri * 3);
    s->draws[s->draw_count++] = (pn_draw){ibase, (uint32_t)(ntri * 3), p->material};
    return PN_OK;
}

pn_result pn_scene_build_add_mesh(pn_scene_build *b, uint32_t *index)
{
    pn_scene *s = &b->scene;
    size_t cap = b->mesh_cap;
    if (!grow((void **)&s->meshes, &b->mesh_cap, (size_t)s->mesh_count + 1, sizeof *s->meshes) ||
        !grow((void **)&b->mesh_tri_cap, &cap, (size_t)s->mesh_count + 1, sizeof *b->mesh_tri_cap))
        return PN_ERR_MEMORY;
    s->meshes[s->mesh_count] = (pn_scene_mesh){0};
    b->mesh_tri_cap[s->mesh_count] = 0;
    *index = s->mesh_count++;
    return PN_OK;
}

pn_result pn_scene_build_add_object(pn_scene_build *b, const pn_scene_object *o)
{
    pn_scene *s = &b->scene;
    if (!grow((void **)&s->objects, &b->object_cap, (size_t)s->object_count + 1, sizeof *s->objects))
        return PN_ERR_MEMORY;
    s->objects[s->object_count++] = *o;
    return PN_OK;
}

pn_result pn_scene_build_add_material(pn_scene_build *b, const pn_material *m)
{
    pn_scene *s = &b->scene;
    if (!grow((void **)&s->materials, &b->material_cap, (size_t)s->material_count + 1, sizeof *s->materials))
        return PN_ERR_MEMORY;
    s->materials[s->material_count++] = *m;
    return PN_OK;
}

pn_result pn_scene_build_add_texture(pn_scene_build *b, uint32_t w, uint32_t h, int comp, int bytes,
                                     const uint8_t *src, int32_t *index)
{
    assert(comp >= 1 && comp <= 4 && (bytes == 1 || bytes == 2));
    pn_scene *s = &b->scene;
    const uint64_t px = (uint64_t)w * h;
    uint8_t *rgba = px <= SIZE_MAX / 4 ? malloc(px * 4) : NULL;
    if (!rgba || !grow((void **)&s->textures, &b->texture_cap, (size_t)s->texture_count + 1, sizeof *s->textures)) {
        free(rgba);
        return PN_ERR_MEMORY;
    }
    for (uint64_t i = 0; i < px; i++) {
        uint8_t v[4];
        for (int c = 0; c < comp; c++) {
            uint64_t at = i * (uint64_t)comp + (uint64_t)c;
            if (bytes == 1) {
                v[c] = src[at];
            } else {
                uint16_t x;
                memcpy(&x, src + at * 2, 2);
                v[c] = (uint8_t)(x >> 8);
            }
        }
        uint8_t *d = rgba + i * 4;
        switch (comp) {
        case 1: d[0] = d[1] = d[2] = v[0], d[3] = 255; break;
        case 2: d[0] = d[1] = d[2] = v[0], d[3] = v[1]; break;
        case 3: d[0] = v[0], d[1] = v[1], d[2] = v[2], d[3] = 255; break;
        default: memcpy(d, v, 4);
        }
    }
    s->textures[s->texture_count] = (pn_texture){w, h, rgba};
    *index = (int32_t)s->texture_count++;
    return PN_OK;
}

void pn_scene_build_finish(pn_scene_build *b, pn_scene *out)
{
    pn_scene *s = &b->scene;
    assert(s->index_count >= 3);
    s->vertices = trim(s->vertices, s->vertex_count, sizeof *s->vertices);
    s->indices = trim(s->indices, s->index_count, sizeof *s->indices);
    s->draws = trim(s->draws, s->draw_count, sizeof *s->draws);
    s->materials = trim(s->materials, s->material_count, sizeof *s->materials);
    s->textures = trim(s->textures, s->texture_count, sizeof *s->textures);
    s->meshes = trim(s->meshes, s->mesh_count, sizeof *s->meshes);
    s->objects = trim(s->objects, s->object_count, sizeof *s->objects);
    for (uint32_t m = 0; m < s->mesh_count; m++)
        s->meshes[m].tris = trim(s->meshes[m].tris, s->meshes[m].triangle_count, sizeof *s->meshes[m].tris);

    // Positions are known finite, so plain comparisons do (fmin/fmax are slow library calls).
    const pn_vertex *v = s->vertices;
    const uint32_t *idx = s->indices;
    float lo[3], hi[3];
    for (int c = 0; c < 3; c++)
        lo[c] = hi[c] = v[idx[0]].pos[c];
    for (uint32_t k = 1; k < s->index_count; k++) {
        const float *p = v[idx[k]].pos;
        for (int c = 0; c < 3; c++) {
            lo[c] = p[c] < lo[c] ? p[c] : lo[c];
            hi[c] = p[c] > hi[c] ? p[c] : hi[c];
        }
    }
    memcpy(s->bounds_min, lo, sizeof lo);
    memcpy(s->bounds_max, hi, sizeof hi);
    *out = *s;
    free(b->mesh_tri_cap);
    memset(b, 0, sizeof *b);
}

void pn_scene_build_destroy(pn_scene_build *b)
{
    pn_scene_destroy(&b->scene);
    free(b->mesh_tri_cap);
    memset(b, 0, sizeof *b);
}
