// The API's scenes: from arrays or a file, their objects moved by transform, their lights.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "api/api_internal.h"
#include "scene/interior.h"
#include "scene/view.h"

// ---------------------------------------------------------------------------------------------
// Objects as penumbra_scene_set_transform moves them.

// x' = t x for an affine 3 x 4 transform, in double: a transform is applied once to the object's
// base positions, so its rounding does not add up over moves.
static void affine_apply(const double t[3][4], const float x[3], float out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = (float)(t[r][0] * x[0] + t[r][1] * x[1] + t[r][2] * x[2] + t[r][3]);
}

// The inverse of an affine transform; false when its linear part is singular (or nearly: its
// determinant below 1e-30 of the product of its rows' lengths, where the inverse's entries pass 1e30).
static bool affine_invert(const double t[3][4], double out[3][4])
{
    double c[3][3]; // cofactors, transposed: the adjugate
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 3; k++) {
            int r1 = (k + 1) % 3, r2 = (k + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
            c[r][k] = t[r1][c1] * t[r2][c2] - t[r1][c2] * t[r2][c1];
        }
    double det = t[0][0] * c[0][0] + t[0][1] * c[1][0] + t[0][2] * c[2][0];
    double scale = 1;
    for (int r = 0; r < 3; r++)
        scale *= sqrt(t[r][0] * t[r][0] + t[r][1] * t[r][1] + t[r][2] * t[r][2]);
    if (!(fabs(det) > 1e-30 * scale))
        return false;
    for (int r = 0; r < 3; r++) {
        for (int k = 0; k < 3; k++)
            out[r][k] = c[r][k] / det;
        out[r][3] = -(out[r][0] * t[0][3] + out[r][1] * t[1][3] + out[r][2] * t[2][3]);
    }
    return true;
}

static void affine_compose(const double a[3][4], const double b[3][4], double out[3][4]) // a after b
{
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 4; k++)
            out[r][k] = a[r][0] * b[0][k] + a[r][1] * b[1][k] + a[r][2] * b[2][k] + (k == 3 ? a[r][3] : 0.0);
}

static bool transform_in(const float *t, const char *fn, double out[3][4])
{
    for (int i = 0; i < 12; i++) {
        if (!isfinite(t[i]) || fabsf(t[i]) > PN_API_MAX_COORD) {
            pn_error("%s: transform entry %d is %g; it must be finite and within %g", fn, i, (double)t[i],
                     (double)PN_API_MAX_COORD);
            return false;
        }
        out[i / 4][i % 4] = t[i];
    }
    double inv[3][4];
    if (!affine_invert(out, inv)) {
        pn_error("%s: the transform's 3x3 part is singular (it flattens the object)", fn);
        return false;
    }
    return true;
}

// Area-weighted vertex normals of the triangles idx[0..index_count) over vertices v[0..n): what
// the G-buffer raster pass interpolates (an arrays scene brings no normals of its own).
static void vertex_normals(pn_vertex *v, uint32_t n, const uint32_t *idx, uint32_t index_count)
{
    for (uint32_t i = 0; i < n; i++)
        v[i].normal[0] = v[i].normal[1] = v[i].normal[2] = 0;
    for (uint32_t t = 0; t + 2 < index_count; t += 3) {
        const float *a = v[idx[t]].pos, *b = v[idx[t + 1]].pos, *c = v[idx[t + 2]].pos;
        double e1[3], e2[3];
        for (int k = 0; k < 3; k++)
            e1[k] = (double)b[k] - a[k], e2[k] = (double)c[k] - a[k];
        double f[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                v[idx[t + j]].normal[k] += (float)f[k];
    }
    for (uint32_t i = 0; i < n; i++) {
        float *m = v[i].normal;
        double l = sqrt((double)m[0] * m[0] + (double)m[1] * m[1] + (double)m[2] * m[2]);
        if (l > 0 && isfinite(l))
            m[0] = (float)(m[0] / l), m[1] = (float)(m[1] / l), m[2] = (float)(m[2] / l);
        else
            m[0] = 0, m[1] = 1, m[2] = 0; // unused by a triangle, or only by degenerate ones
    }
}

void pn_api_scene_drop_built(penumbra_scene *s)
{
    if (s->renderer_made)
        pn_renderer_destroy(&s->renderer);
    if (s->accel_built)
        pn_shadow_accel_destroy(&s->ctx->dev, &s->accel);
    s->renderer_made = s->accel_built = false;
}

void pn_api_scene_free(penumbra_scene *s)
{
    if (!s)
        return;
    pn_api_scene_drop_built(s);
    for (uint32_t i = 0; i < s->object_count; i++)
        free(s->objects[i].base);
    free(s->objects);
    pn_scene_destroy(&s->scene);
    penumbra_context *ctx = s->ctx;
    free(s);
    pn_api_context_release(ctx); // last: it may free the context
}

// One pn_api_object per object: the scene file's (their world vertices now, and their transform),
// or the whole scene as one.
static pn_result objects_from_scene(penumbra_scene *s)
{
    const pn_scene *sc = &s->scene;
    uint32_t n = sc->object_count ? sc->object_count : 1;
    s->objects = calloc(n, sizeof *s->objects);
    if (!s->objects)
        return PN_ERR_MEMORY;
    s->object_count = n;
    for (uint32_t i = 0; i < n; i++) {
        pn_api_object *o = &s->objects[i];
        o->first_vertex = sc->object_count ? sc->objects[i].first_vertex : 0;
        o->vertex_count = sc->object_count ? sc->objects[i].vertex_count : sc->vertex_count;
        for (int r = 0; r < 3; r++)
            for (int k = 0; k < 4; k++)
                o->base_to_world[r][k] = o->cur_to_world[r][k] =
                    sc->object_count ? sc->objects[i].to_world[r][k] : (r == k ? 1.0 : 0.0);
        o->base = malloc((size_t)(o->vertex_count ? o->vertex_count : 1) * sizeof *o->base);
        if (!o->base)
            return PN_ERR_MEMORY;
        for (uint32_t v = 0; v < o->vertex_count; v++)
            memcpy(o->base[v], sc->vertices[o->first_vertex + v].pos, sizeof o->base[v]);
    }
    return PN_OK;
}

penumbra_scene *pn_api_scene_new(penumbra_context *ctx, const char *name)
{
    penumbra_scene *s = calloc(1, sizeof *s);
    if (s) {
        s->ctx = ctx;
        snprintf(s->scene.name, sizeof s->scene.name, "%s", name);
        if (ctx)
            ctx->live++;
    }
    return s;
}

// ---------------------------------------------------------------------------------------------
// Scenes from arrays.

static bool mesh_valid(const penumbra_mesh_desc *m, uint32_t i)
{
    const char *fn = "penumbra_scene_create";
    if (!m->positions || !m->indices || m->vertex_count == 0 || m->index_count == 0 || m->index_count % 3) {
        pn_error("%s: mesh %u needs positions, vertex_count > 0 and indices with index_count a positive multiple of "
                 "3 (got %u vertices, %u indices%s)",
                 fn, i, m->vertex_count, m->index_count, !m->positions || !m->indices ? ", a NULL array" : "");
        return false;
    }
    for (uint64_t k = 0; k < 3ull * m->vertex_count; k++)
        if (!isfinite(m->positions[k]) || fabsf(m->positions[k]) > PN_API_MAX_COORD) {
            pn_error("%s: mesh %u, vertex %llu: coordinate %g is not finite or beyond %g", fn, i,
                     (unsigned long long)(k / 3), (double)m->positions[k], (double)PN_API_MAX_COORD);
            return false;
        }
    for (uint32_t k = 0; k < m->index_count; k++)
        if (m->indices[k] >= m->vertex_count) {
            pn_error("%s: mesh %u, index %u is %u; the mesh has %u vertices", fn, i, k, m->indices[k], m->vertex_count);
            return false;
        }
    if (m->uvs) {
        if (!m->alpha || m->alpha_width == 0 || m->alpha_height == 0 || m->alpha_width > 16384 ||
            m->alpha_height > 16384 || !(m->alpha_cutoff > 0 && m->alpha_cutoff <= 1)) {
            pn_error("%s: mesh %u has uvs: it needs an alpha mask of 1..16384 x 1..16384 bytes and alpha_cutoff in "
                     "(0, 1] (got %ux%u, %s, cutoff %g)",
                     fn, i, m->alpha_width, m->alpha_height, m->alpha ? "given" : "NULL", (double)m->alpha_cutoff);
            return false;
        }
        for (uint64_t k = 0; k < 2ull * m->vertex_count; k++)
            if (!isfinite(m->uvs[k])) {
                pn_error("%s: mesh %u, vertex %llu: a uv is not finite", fn, i, (unsigned long long)(k / 2));
                return false;
            }
    }
    return true;
}

// Mesh i as a draw of the scene, its vertices moved by its transform, with its material.
static pn_result add_mesh(penumbra_scene *s, const penumbra_mesh_desc *m, uint32_t i)
{
    pn_scene *sc = &s->scene;
    pn_api_object *o = &s->objects[i];
    o->first_vertex = sc->vertex_count;
    o->vertex_count = m->vertex_count;
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 4; k++)
            o->base_to_world[r][k] = o->cur_to_world[r][k] = r == k ? 1.0 : 0.0;
    double t[3][4];
    if (m->transform && !transform_in(m->transform, "penumbra_scene_create", t))
        return PN_ERR_INVALID;
    o->base = malloc((size_t)m->vertex_count * sizeof *o->base);
    pn_vertex *v = malloc((size_t)m->vertex_count * sizeof *v);
    pn_result r = o->base && v ? PN_OK : PN_ERR_MEMORY;
    for (uint32_t k = 0; r == PN_OK && k < m->vertex_count; k++) {
        memcpy(o->base[k], &m->positions[3 * (size_t)k], sizeof o->base[k]);
        v[k] = (pn_vertex){.uv = {m->uvs ? m->uvs[2 * (size_t)k] : 0, m->uvs ? m->uvs[2 * (size_t)k + 1] : 0}};
        if (m->transform)
            affine_apply((const double(*)[4])t, o->base[k], v[k].pos);
        else
            memcpy(v[k].pos, o->base[k], sizeof v[k].pos);
    }
    uint32_t material = 0;
    if (r == PN_OK)
        r = pn_scene_add_material(sc, (const float[4]){1, 1, 1, 1}, &material);
    if (r == PN_OK && m->uvs) {
        // The mask as a texture's alpha (glTF keeps alpha linear; the colour is white).
        size_t texels = (size_t)m->alpha_width * m->alpha_height;
        uint8_t *rgba = malloc(4 * texels);
        int32_t tex = -1;
        if (rgba)
            for (size_t k = 0; k < texels; k++)
                rgba[4 * k] = rgba[4 * k + 1] = rgba[4 * k + 2] = 255, rgba[4 * k + 3] = m->alpha[k];
        r = rgba ? pn_scene_add_texture(sc, m->alpha_width, m->alpha_height, rgba, &tex) : PN_ERR_MEMORY;
        if (r == PN_OK)
            sc->materials[material].texture = tex, sc->materials[material].alpha_cutoff = m->alpha_cutoff;
    }
    if (r == PN_OK) {
        vertex_normals(v, m->vertex_count, m->indices, m->index_count);
        r = pn_scene_add_mesh(sc, v, m->vertex_count, m->indices, m->index_count, material);
    }
    if (r == PN_OK && m->transform)
        memcpy(o->cur_to_world, t, sizeof t); // base holds the mesh's own positions (base_to_world: identity)
    free(v);
    return r;
}

pn_result pn_api_scene_arrays(penumbra_scene *s, const penumbra_mesh_desc *meshes, uint32_t mesh_count)
{
    const char *fn = "penumbra_scene_create";
    if (mesh_count == 0) {
        pn_error("%s: mesh_count is 0; a scene needs at least one mesh", fn);
        return PN_ERR_INVALID;
    }
    uint64_t vertices = 0, indices = 0;
    for (uint32_t i = 0; i < mesh_count; i++) {
        if (!mesh_valid(&meshes[i], i))
            return PN_ERR_INVALID;
        vertices += meshes[i].vertex_count, indices += meshes[i].index_count;
    }
    if (vertices > UINT32_MAX || indices > UINT32_MAX) {
        pn_error("%s: %llu vertices and %llu indices in all; a scene holds at most %u of each", fn,
                 (unsigned long long)vertices, (unsigned long long)indices, UINT32_MAX);
        return PN_ERR_INVALID;
    }
    pn_result r = PN_OK;
    if (!(s->objects = calloc(mesh_count, sizeof *s->objects)))
        r = PN_ERR_MEMORY;
    if (r == PN_OK)
        s->object_count = mesh_count;
    for (uint32_t i = 0; r == PN_OK && i < mesh_count; i++)
        r = add_mesh(s, &meshes[i], i);
    if (r == PN_OK) {
        pn_scene_update_bounds(&s->scene);
        // Float range and the scene's extent at its distance from the origin (scene.c): the
        // arrays were the caller's, so what it finds is an argument's fault.
        if (pn_scene_validate(&s->scene) != PN_OK)
            r = PN_ERR_INVALID;
    }
    if (r == PN_ERR_MEMORY)
        pn_error("%s: out of memory for %llu vertices and %llu indices", fn, (unsigned long long)vertices,
                 (unsigned long long)indices);
    return r;
}

penumbra_status penumbra_scene_create(penumbra_context *ctx, const penumbra_mesh_desc *meshes, uint32_t mesh_count,
                                      penumbra_scene **out)
{
    pn_api_call call;
    pn_api_begin(&call, ctx);
    const char *fn = "penumbra_scene_create";
    if (out)
        *out = NULL;
    if (!pn_api_context_ok(ctx, fn) || !pn_api_need(out, fn, "out") || !pn_api_need(meshes, fn, "meshes"))
        return pn_api_end(&call, PN_ERR_INVALID);
    penumbra_scene *s = pn_api_scene_new(ctx, "arrays");
    pn_result r = s ? pn_api_scene_arrays(s, meshes, mesh_count) : PN_ERR_MEMORY;
    if (r != PN_OK) {
        pn_api_scene_free(s);
        return pn_api_end(&call, r);
    }
    *out = s;
    return pn_api_end(&call, PN_OK);
}

// ---------------------------------------------------------------------------------------------
// Scenes from files.

penumbra_status penumbra_scene_load(penumbra_context *ctx, const char *path, penumbra_scene **out)
{
    pn_api_call call;
    pn_api_begin(&call, ctx);
    const char *fn = "penumbra_scene_load";
    if (out)
        *out = NULL;
    if (!pn_api_context_ok(ctx, fn) || !pn_api_need(out, fn, "out") || !pn_api_need(path, fn, "path"))
        return pn_api_end(&call, PN_ERR_INVALID);
    penumbra_scene *s = pn_api_scene_new(ctx, path);
    if (!s)
        return pn_api_end(&call, PN_ERR_MEMORY);
    pn_result r = pn_scene_load(path, &s->scene);
    if (r == PN_OK && (r = objects_from_scene(s)) != PN_OK)
        pn_error("%s: out of memory for its objects", path);
    if (r != PN_OK) {
        pn_api_scene_free(s);
        return pn_api_end(&call, r);
    }
    *out = s;
    return pn_api_end(&call, PN_OK);
}

void penumbra_scene_destroy(penumbra_scene *s)
{
    if (!s)
        return;
    pn_api_call call;
    pn_api_begin(&call, s->ctx);
    pn_api_scene_free(s);
    pn_log_set_capture(NULL); // not pn_api_end: the context may be gone with its last scene
}

penumbra_status penumbra_scene_get_info(const penumbra_scene *s, penumbra_scene_info *out)
{
    if (!s || !out)
        return PENUMBRA_ERROR_INVALID_ARGUMENT; // no context to hold a message: the status says it
    *out = (penumbra_scene_info){.triangle_count = pn_scene_triangle_count(&s->scene),
                                 .object_count = s->object_count,
                                 .light_count = s->scene.light_count};
    memcpy(out->bounds_min, s->scene.bounds_min, sizeof out->bounds_min);
    memcpy(out->bounds_max, s->scene.bounds_max, sizeof out->bounds_max);
    return PENUMBRA_OK;
}

penumbra_status penumbra_scene_set_transform(penumbra_scene *s, uint32_t object, const float transform[12])
{
    const char *fn = "penumbra_scene_set_transform";
    pn_api_call call;
    pn_api_begin(&call, s ? s->ctx : NULL);
    if (!pn_api_need(s, fn, "scene") || !pn_api_need(transform, fn, "transform"))
        return pn_api_end(&call, PN_ERR_INVALID);
    if (object >= s->object_count) {
        pn_error("%s: %s has %u objects, no object %u", fn, s->scene.name, s->object_count, object);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    pn_api_object *o = &s->objects[object];
    double t[3][4], base_inv[3][4], m[3][4], cur_inv[3][4], step[3][4], step_inv[3][4];
    if (!transform_in(transform, fn, t))
        return pn_api_end(&call, PN_ERR_INVALID);
    // Each transform passed the test on its own, but a file's node may be singular (a glTF scale
    // of 0), and two regular ones may compose to a step too ill-conditioned to invert.
    bool regular = affine_invert((const double(*)[4])o->base_to_world, base_inv) &&
                   affine_invert((const double(*)[4])o->cur_to_world, cur_inv);
    if (regular) {
        affine_compose((const double(*)[4])t, (const double(*)[4])base_inv, m); // base -> new world
        // Normals move by the step from the current transform to the new one, as the inverse
        // transpose of its linear part (they stay perpendicular to the moved surfaces).
        affine_compose((const double(*)[4])t, (const double(*)[4])cur_inv, step);
        regular = affine_invert((const double(*)[4])step, step_inv);
    }
    if (!regular) {
        pn_error("%s: %s, object %u: its transform as loaded or now is singular, or the move to this one too "
                 "ill-conditioned to carry its normals; not moved", fn, s->scene.name, object);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    pn_scene *sc = &s->scene;
    pn_vertex *old = malloc((size_t)(o->vertex_count ? o->vertex_count : 1) * sizeof *old);
    if (!old)
        return pn_api_end(&call, PN_ERR_MEMORY);
    pn_vertex *x = sc->vertices + o->first_vertex;
    memcpy(old, x, (size_t)o->vertex_count * sizeof *old);
    float saved_lo[3], saved_hi[3];
    memcpy(saved_lo, sc->bounds_min, sizeof saved_lo), memcpy(saved_hi, sc->bounds_max, sizeof saved_hi);
    for (uint32_t v = 0; v < o->vertex_count; v++) {
        affine_apply((const double(*)[4])m, o->base[v], x[v].pos);
        double n[3], l = 0;
        for (int r = 0; r < 3; r++) {
            n[r] = step_inv[0][r] * old[v].normal[0] + step_inv[1][r] * old[v].normal[1] +
                   step_inv[2][r] * old[v].normal[2];
            l += n[r] * n[r];
        }
        l = sqrt(l);
        for (int r = 0; l > 0 && r < 3; r++)
            x[v].normal[r] = (float)(n[r] / l);
    }
    pn_scene_update_bounds(sc);
    if (pn_scene_validate(sc) != PN_OK) { // moved out of float range: back to where it was
        memcpy(x, old, (size_t)o->vertex_count * sizeof *old);
        memcpy(sc->bounds_min, saved_lo, sizeof saved_lo), memcpy(sc->bounds_max, saved_hi, sizeof saved_hi);
        free(old);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    free(old);
    memcpy(o->cur_to_world, t, sizeof t);
    if (object < sc->object_count)
        for (int r = 0; r < 3; r++)
            for (int k = 0; k < 4; k++)
                sc->objects[object].to_world[r][k] = (float)t[r][k];
    // The next visibility call builds the structures again (they are keyed by the version) and
    // hands them to the renderer it keeps (visibility.c: ensure_accel, ensure_renderer).
    s->version++;
    return pn_api_end(&call, PN_OK);
}
