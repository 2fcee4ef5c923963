// Per-object N-trees and their top level (--trees object): build, and the top level's rebuild
// after a move.
#include "accel/objects.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "core/timer.h"
#include "scene/anim.h"

// A transform whose columns span less than this fraction of the volume of the box they would span
// if they were orthogonal is not inverted: float local coordinates of a ray carry a relative error
// of about cond(A) x 2^-24, and at |det| / prod|a_c| = 1e-6 (cond above 1e6) that error reaches a
// tenth of the object's size. Such an instance is flattened to nearly a plane and can block only
// rays that run nearly within that plane: it is left out of the top level (and counted).
#define FLAT_VOLUME 1e-6

// Whether object o gets a tree of its own: every object of a scene without animation (any may be
// moved: --move-object, the demo), only the animated ones of an animated scene. What stands still
// joins the one world-space tree of the triangles of no object, so that a frame costs a top-level
// rebuild and the still geometry one tree (objects.h).
static bool own_tree(const pn_scene *s, uint32_t o)
{
    return !pn_scene_animated(s) || s->anim->nodes[s->objects[o].node].posed;
}

// Builds `tree` over the scene `s` (a mesh's soup or the rest) and packs its pools.
static pn_result build_tree(const pn_scene *s, const pn_ntree_desc *desc, pn_ntree *tree, pn_pools *pools)
{
    pn_result r = pn_ntree_build(s, desc, tree);
    if (r == PN_OK && (r = pn_pools_pack(tree, pools)) != PN_OK)
        pn_error("%s: out of memory packing the pools of its per-object tree", s->name);
    return r;
}

// A mesh's local triangles as a scene of their own (3 vertices per triangle, normals unused).
static pn_result mesh_scene(const pn_scene *scene, uint32_t m, pn_scene *out)
{
    memset(out, 0, sizeof *out);
    const pn_scene_mesh *mesh = &scene->meshes[m];
    snprintf(out->name, sizeof out->name, "%.200s (mesh %u)", scene->name, m);
    uint32_t nv = 3 * mesh->triangle_count;
    out->vertices = calloc(nv ? nv : 1, sizeof *out->vertices);
    out->indices = malloc((nv ? nv : 1) * sizeof *out->indices);
    if (!out->vertices || !out->indices) {
        pn_scene_destroy(out);
        return PN_ERR_MEMORY;
    }
    for (uint32_t i = 0; i < nv; i++) {
        memcpy(out->vertices[i].pos, mesh->tris[i / 3][i % 3], sizeof out->vertices[i].pos);
        out->indices[i] = i;
    }
    out->vertex_count = out->index_count = nv;
    pn_scene_update_bounds(out);
    return PN_OK;
}

// The triangles no object holds, in world space; index_count 0 if there are none. Shares the
// scene's vertices (free only out->indices). Its bounds are the whole scene's: the tree judges which
// of its triangles can block a ray against them and the lights (pn_ntree_can_block).
static pn_result rest_scene(const pn_scene *scene, pn_scene *out)
{
    memset(out, 0, sizeof *out);
    snprintf(out->name, sizeof out->name, "%.200s (triangles of no object)", scene->name);
    uint32_t tris = pn_scene_triangle_count(scene);
    uint8_t *held = calloc(tris ? tris : 1, 1);
    out->indices = malloc((size_t)(tris ? tris : 1) * 3 * sizeof *out->indices);
    if (!held || !out->indices) {
        free(held);
        free(out->indices);
        out->indices = NULL;
        return PN_ERR_MEMORY;
    }
    for (uint32_t o = 0; o < scene->object_count; o++) {
        const pn_scene_object *obj = &scene->objects[o];
        for (uint32_t t = obj->first_index / 3; own_tree(scene, o) && t < (obj->first_index + obj->index_count) / 3 && t < tris; t++)
            held[t] = 1;
    }
    for (uint32_t t = 0; t < tris; t++)
        if (!held[t]) {
            memcpy(out->indices + out->index_count, scene->indices + 3 * t, 3 * sizeof *out->indices);
            out->index_count += 3;
        }
    free(held);
    out->vertices = scene->vertices;
    out->vertex_count = scene->vertex_count;
    memcpy(out->bounds_min, scene->bounds_min, sizeof out->bounds_min);
    memcpy(out->bounds_max, scene->bounds_max, sizeof out->bounds_max);
    return PN_OK;
}

pn_result pn_objects_build(const pn_scene *scene, const pn_ntree_desc *desc, pn_objects *out)
{
    memset(out, 0, sizeof *out);
    uint64_t t0 = pn_time_ns();
    pn_scene rest;
    pn_result r = rest_scene(scene, &rest);
    bool tree_failed = false; // a tree's build logs why it failed (a limit it would exceed, with sizes)
    if (r != PN_OK) {
        pn_error("%s: out of memory building per-object trees", scene->name);
        return r;
    }
    // A mesh gets a tree if an object with a tree of its own instances it.
    uint8_t *used = calloc(scene->mesh_count ? scene->mesh_count : 1, 1);
    uint32_t own = 0;
    for (uint32_t o = 0; used && o < scene->object_count; o++)
        if (own_tree(scene, o)) {
            used[scene->objects[o].mesh] = 1;
            own++;
        }
    out->tree_count = scene->mesh_count + (rest.index_count ? 1 : 0);
    out->trees = calloc(out->tree_count, sizeof *out->trees);
    out->pools = calloc(out->tree_count, sizeof *out->pools);
    out->instance_count = own + (rest.index_count ? 1 : 0);
    out->instances = calloc(out->instance_count ? out->instance_count : 1, sizeof *out->instances);
    if (!used || !out->trees || !out->pools || !out->instances)
        r = PN_ERR_MEMORY;
    // The meshes' trees are not culled, the rest's by the lights (objects.h). The byte limit holds
    // for all trees together.
    pn_ntree_desc td = {.n = desc->n, .d = desc->d, .max_pool_bytes = desc->max_pool_bytes};
    for (uint32_t i = 0; r == PN_OK && i < out->tree_count; i++) {
        bool is_rest = i == scene->mesh_count;
        if (!is_rest && (scene->meshes[i].triangle_count == 0 || !used[i]))
            continue; // a mesh whose primitives gave no triangles has no object either; one that stands still
        pn_scene mesh;
        if (!is_rest)
            r = mesh_scene(scene, i, &mesh);
        if (r != PN_OK)
            break;
        td.max_bytes = desc->max_bytes ? (desc->max_bytes > out->bytes.total ? desc->max_bytes - out->bytes.total : 1) : 0;
        td.cull_light = is_rest ? desc->cull_light : NULL;
        td.cull_light_corners = desc->cull_light_corners;
        r = build_tree(is_rest ? &rest : &mesh, &td, &out->trees[i], &out->pools[i]);
        tree_failed = r != PN_OK;
        if (r == PN_OK && is_rest && out->trees[i].triangles == 0) {
            // Every one of them was left out (a ground plane alone): no tree and no instance.
            out->culled = out->trees[i].culled;
            pn_ntree_destroy(&out->trees[i]);
            pn_pools_destroy(&out->pools[i]);
            out->tree_count--;
            out->instance_count--;
            break;
        }
        if (is_rest)
            out->culled = out->trees[i].culled;
        if (!is_rest)
            pn_scene_destroy(&mesh);
        out->bytes.tree += out->pools[i].bytes.tree;
        out->bytes.node += out->pools[i].bytes.node;
        out->bytes.linespace += out->pools[i].bytes.linespace;
        out->bytes.total += out->pools[i].bytes.total;
    }
    free(rest.indices);
    free(used);
    memcpy(out->cull_box, scene->bounds_min, 3 * sizeof(float));
    memcpy(out->cull_box + 3, scene->bounds_max, 3 * sizeof(float));
    uint32_t corners = desc->cull_light ? (desc->cull_light_corners ? desc->cull_light_corners : 4) : 0;
    out->cull_light_corners = corners < 8 * PN_MAX_LIGHTS ? corners : 8 * PN_MAX_LIGHTS;
    if (out->cull_light_corners)
        memcpy(out->cull_light, desc->cull_light, out->cull_light_corners * sizeof out->cull_light[0]);
    if (r == PN_OK)
        r = pn_objects_update(scene, out);
    if (r != PN_OK) {
        if (r == PN_ERR_MEMORY && !tree_failed)
            pn_error("%s: out of memory building per-object trees", scene->name);
        pn_objects_destroy(out);
        return r;
    }
    out->build_ms = pn_ms_since(t0);
    return PN_OK;
}

// The world box of the tree's root cube under the map x -> A x + t (its 8 corners), grown by a few
// ulps of its magnitude: the corners are rounded to float.
static void world_box(const pn_ntree *tree, const double a[3][4], float box[6])
{
    double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    for (int c = 0; c < 8; c++) {
        double p[3];
        for (int k = 0; k < 3; k++)
            p[k] = tree->root_min[k] + ((c >> k) & 1 ? tree->root_size : 0.0);
        for (int r = 0; r < 3; r++) {
            double w = a[r][0] * p[0] + a[r][1] * p[1] + a[r][2] * p[2] + a[r][3];
            lo[r] = fmin(lo[r], w);
            hi[r] = fmax(hi[r], w);
        }
    }
    for (int k = 0; k < 3; k++) {
        double pad = 4.0 * FLT_EPSILON * fmax(fabs(lo[k]), fabs(hi[k]));
        box[k] = (float)(lo[k] - pad);
        box[3 + k] = (float)(hi[k] + pad);
    }
}

// The shader carries world-space rays into the tree's frame in float: a world coordinate is known
// to one ulp of the object's world magnitude, which the map turns into up to ulp x inv_rows in the
// frame. As for the scene-wide tree (pn_ntree_build), a leaf must be 16 such steps wide, so that
// the traversal's 4-step allowance stays a quarter of a leaf; the tree's own frame is checked
// when it is built. Returns the leaf's width in those steps.
static double leaf_steps(const pn_ntree *tree, double inv_rows, float world_mag)
{
    double step = ((double)nextafterf(world_mag, INFINITY) - (double)world_mag) * inv_rows;
    return pn_ntree_cell_size(tree, tree->d) / step;
}

bool pn_objects_resolves(const pn_objects *o, uint32_t object, float world_mag)
{
    for (uint32_t i = 0; i < o->placed; i++) {
        const pn_object_instance *inst = &o->instances[i];
        if (inst->object == object)
            return !o->trees[inst->tree].triangles || leaf_steps(&o->trees[inst->tree], inst->inv_rows, world_mag) >= 16.0;
    }
    return true;
}

pn_result pn_objects_update(const pn_scene *scene, pn_objects *o)
{
    uint64_t t0 = pn_time_ns();
    uint32_t count = 0, flat = 0;
    o->leaf_size = DBL_MAX;
    bool has_rest = o->tree_count > scene->mesh_count; // (present when its tree is)
    for (uint32_t i = 0; i <= scene->object_count; i++) {
        bool is_rest = i == scene->object_count;
        if (is_rest ? !has_rest : !own_tree(scene, i))
            continue;
        uint32_t tree = is_rest ? scene->mesh_count : scene->objects[i].mesh;
        double a[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
        if (!is_rest)
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 4; c++)
                    a[r][c] = scene->objects[i].to_world[r][c];
        // The inverse by cofactors: inv = adj(A) / det.
        double cof[3][3];
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) {
                int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
                cof[r][c] = a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1];
            }
        double det = a[0][0] * cof[0][0] + a[0][1] * cof[0][1] + a[0][2] * cof[0][2];
        double cols = 1.0;
        for (int c = 0; c < 3; c++)
            cols *= sqrt(a[0][c] * a[0][c] + a[1][c] * a[1][c] + a[2][c] * a[2][c]);
        if (!(fabs(det) > FLAT_VOLUME * cols)) {
            flat++;
            continue;
        }
        pn_object_instance *inst = &o->instances[count++];
        inst->tree = tree;
        double inv_rows = 0.0; // the largest row sum of |A^-1|
        for (int r = 0; r < 3; r++) {
            double t = 0.0, row = 0.0;
            for (int c = 0; c < 3; c++) {
                double inv = cof[c][r] / det; // (A^-1)[r][c] = cof[c][r] / det
                inst->to_local[r][c] = (float)inv;
                t -= inv * a[c][3];
                row += fabs(inv);
            }
            inst->to_local[r][3] = (float)t;
            inv_rows = fmax(inv_rows, row);
        }
        const pn_ntree *tr = &o->trees[tree];
        world_box(tr, (const double(*)[4])a, inst->box);
        inst->object = i;
        inst->inv_rows = inv_rows;
        double leaf = pn_ntree_cell_size(tr, tr->d), ext = 0.0;
        float mag = 0.0f;
        for (int k = 0; k < 6; k++)
            mag = fmaxf(mag, fabsf(inst->box[k]));
        double steps = leaf_steps(tr, inv_rows, mag);
        if (tr->triangles && steps < 16.0) {
            char what[32] = "the triangles of no object";
            if (!is_rest)
                snprintf(what, sizeof what, "object %u", i);
            pn_error("%s: %s: LS(%d,%d) leaves would be %.3g wide in its frame, only %.1f float steps of its world "
                     "position (%.3g from the origin) carried into that frame; use a smaller N or d, or move the "
                     "scene towards the origin",
                     scene->name, what, tr->n, tr->d, leaf, steps, (double)mag);
            return PN_ERR_UNSUPPORTED;
        }
        for (int r = 0; r < 3; r++)
            ext = fmax(ext, leaf * (fabs(a[r][0]) + fabs(a[r][1]) + fabs(a[r][2])));
        inst->world_leaf = ext;
        o->leaf_size = fmin(o->leaf_size, ext);
    }
    if (count == 0)
        o->leaf_size = 0.0;
    if (flat)
        pn_warn("%s: %u object(s) with a flat (singular) transform left out of the per-object trees", scene->name,
                flat);
    float(*boxes)[6] = malloc((count ? count : 1) * sizeof *boxes);
    if (!boxes)
        return PN_ERR_MEMORY;
    o->placed = count;
    for (uint32_t i = 0; i < count; i++)
        memcpy(boxes[i], o->instances[i].box, sizeof boxes[i]);
    pn_bvh_destroy(&o->top);
    pn_result r = pn_bvh_build_boxes((const float(*)[6])boxes, count, &o->top);
    free(boxes);
    o->top_bytes = (uint64_t)count * sizeof(pn_gpu_object) + (uint64_t)o->top.node_count * sizeof(pn_bvh_node) +
                   (uint64_t)count * sizeof(uint32_t);
    o->update_ms = pn_ms_since(t0);
    return r;
}

bool pn_objects_cull_holds(const pn_scene *scene, const pn_objects *o)
{
    if (o->culled == 0)
        return true;
    // A plane with the build's box on one closed side has every box within it there too.
    bool inside = true;
    for (int k = 0; k < 3; k++)
        inside = inside && scene->bounds_min[k] >= o->cull_box[k] && scene->bounds_max[k] <= o->cull_box[3 + k];
    if (inside)
        return true;
    pn_scene rest;
    if (rest_scene(scene, &rest) != PN_OK)
        return false; // out of memory: cannot tell, so the caller rebuilds
    bool holds = true;
    for (uint32_t t = 0; holds && t < rest.index_count / 3; t++) {
        float v[9];
        for (int c = 0; c < 3; c++)
            memcpy(v + 3 * c, scene->vertices[rest.indices[3 * t + c]].pos, 3 * sizeof(float));
        // Left out at build (the same test on the same inputs as pn_ntree_build's), and able to block now?
        bool culled = !pn_ntree_can_block(v, o->cull_box, o->cull_box + 3, (const float(*)[3])o->cull_light,
                                          o->cull_light_corners);
        holds = !(culled && pn_ntree_can_block(v, scene->bounds_min, scene->bounds_max,
                                               (const float(*)[3])o->cull_light, o->cull_light_corners));
    }
    free(rest.indices);
    return holds;
}

void pn_objects_destroy(pn_objects *o)
{
    for (uint32_t i = 0; o->trees && i < o->tree_count; i++) {
        pn_ntree_destroy(&o->trees[i]);
        if (o->pools)
            pn_pools_destroy(&o->pools[i]);
    }
    free(o->trees);
    free(o->pools);
    free(o->instances);
    pn_bvh_destroy(&o->top);
    memset(o, 0, sizeof *o);
}
