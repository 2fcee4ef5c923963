// Animated scenes (anim.h): sampling glTF's channels, the nodes' world transforms, and placing what
// the posed nodes carry. The glTF reader (gltf.cpp) fills pn_scene_anim and places the rest pose
// with the same functions (pn_trs_matrix, pn_mat4_mul, pn_node_frame, pn_scene_build_place), so a
// pose equals, to the bit, a load of the file with those node transforms.
#include "scene/anim.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "core/timer.h"
#include "scene/build.h"

bool pn_trs_matrix(const double t[3], const double q[4], const double s[3], double m[16])
{
    double ql = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(ql > 0.0) || !isfinite(ql))
        return false;
    double x = q[0] / ql, y = q[1] / ql, z = q[2] / ql, w = q[3] / ql;
    double rot[3][3] = {
        {1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
        {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
        {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)},
    };
    memset(m, 0, 16 * sizeof *m);
    m[15] = 1.0;
    // T * R * S: column c of the 3x3 is R's column c scaled by s[c].
    for (int c = 0; c < 3; c++)
        for (int row = 0; row < 3; row++)
            m[c * 4 + row] = rot[row][c] * s[c];
    for (int row = 0; row < 3; row++)
        m[12 + row] = t[row];
    return true;
}

void pn_mat4_mul(const double a[16], const double b[16], double out[16])
{
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += a[k * 4 + row] * b[c * 4 + k];
            out[c * 4 + row] = s;
        }
}

bool pn_node_frame(const double w[16], double pos[3], double fwd[3], double up[3])
{
    for (int k = 0; k < 3; k++) {
        pos[k] = w[12 + k];
        fwd[k] = -w[8 + k]; // the node's -Z axis
        up[k] = w[4 + k];   // and its +Y
    }
    return pn_scene_unit3(fwd) && pn_scene_unit3(up);
}

// glTF's slerp (the specification's appendix): the shorter way round, linear where the keys are
// within rounding of each other.
static void slerp(const float *a, const float *b, double s, double out[4])
{
    double d = 0, bb[4];
    for (int k = 0; k < 4; k++)
        d += (double)a[k] * b[k];
    for (int k = 0; k < 4; k++)
        bb[k] = d < 0 ? -(double)b[k] : b[k];
    d = fabs(d);
    double wa = 1 - s, wb = s;
    if (d < 1.0 - 1e-9) {
        double th = acos(d), st = sin(th);
        wa = sin((1 - s) * th) / st, wb = sin(s * th) / st;
    }
    for (int k = 0; k < 4; k++)
        out[k] = wa * a[k] + wb * bb[k];
}

void pn_anim_sample(const pn_anim_channel *c, double time, double out[4])
{
    int w = c->path == PN_ANIM_ROTATION ? 4 : 3;
    bool cubic = c->interp == PN_ANIM_CUBICSPLINE;
    uint32_t stride = cubic ? 3u * (uint32_t)w : (uint32_t)w, at = cubic ? (uint32_t)w : 0; // a key's value
    uint32_t n = c->keys, lo = 0, hi = n - 1;
    const float *t = c->times;
    if (n == 1 || !(time > t[0]) || time >= t[n - 1]) {
        const float *v = c->values + (time >= t[n - 1] ? n - 1 : 0) * stride + at;
        for (int k = 0; k < w; k++)
            out[k] = v[k];
        return;
    }
    while (hi - lo > 1) { // t[lo] <= time < t[hi]
        uint32_t mid = lo + (hi - lo) / 2;
        if (t[mid] <= time)
            lo = mid;
        else
            hi = mid;
    }
    double dt = (double)t[hi] - t[lo], s = (time - t[lo]) / dt;
    const float *a = c->values + lo * stride + at, *b = c->values + hi * stride + at;
    if (c->interp == PN_ANIM_STEP || s == 0) {
        for (int k = 0; k < w; k++)
            out[k] = a[k];
    } else if (c->interp == PN_ANIM_LINEAR && w == 4) {
        slerp(a, b, s, out);
    } else if (c->interp == PN_ANIM_LINEAR) {
        for (int k = 0; k < w; k++)
            out[k] = a[k] + s * ((double)b[k] - a[k]);
    } else { // Hermite: the out-tangent of key lo and the in-tangent of key hi, times the interval
        const float *m0 = a + w, *m1 = b - w;
        double s2 = s * s, s3 = s2 * s;
        for (int k = 0; k < w; k++)
            out[k] = (2 * s3 - 3 * s2 + 1) * a[k] + (s3 - 2 * s2 + s) * dt * m0[k] + (-2 * s3 + 3 * s2) * b[k] +
                     (s3 - s2) * dt * m1[k];
        if (w == 4) // pn_trs_matrix normalises; a zero sum keeps the key before
            if (!(fabs(out[0]) + fabs(out[1]) + fabs(out[2]) + fabs(out[3]) > 0))
                for (int k = 0; k < w; k++)
                    out[k] = a[k];
    }
}

// Every node's local transform at `time` (NAN: the rest) times its parent's, in `world`.
static pn_result world_matrices(const pn_scene *s, double time, double (*world)[16])
{
    const pn_scene_anim *a = s->anim;
    double(*trs)[10] = malloc((a->node_count ? a->node_count : 1) * sizeof *trs); // t, r, s
    if (!trs)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < a->node_count; i++) {
        memcpy(trs[i], a->nodes[i].t, 3 * sizeof(double));
        memcpy(trs[i] + 3, a->nodes[i].r, 4 * sizeof(double));
        memcpy(trs[i] + 7, a->nodes[i].s, 3 * sizeof(double));
    }
    for (uint32_t i = 0; !isnan(time) && i < a->channel_count; i++) {
        const pn_anim_channel *c = &a->channels[i];
        double v[4];
        pn_anim_sample(c, time, v);
        int at = c->path == PN_ANIM_TRANSLATION ? 0 : c->path == PN_ANIM_ROTATION ? 3 : 7;
        memcpy(trs[c->node] + at, v, (c->path == PN_ANIM_ROTATION ? 4 : 3) * sizeof(double));
    }
    pn_result r = PN_OK;
    for (uint32_t i = 0; i < a->order_count && r == PN_OK; i++) {
        uint32_t n = a->order[i];
        const pn_anim_node *node = &a->nodes[n];
        double local[16];
        if (node->matrix)
            memcpy(local, node->m, sizeof local);
        else if (!pn_trs_matrix(trs[n], trs[n] + 3, trs[n] + 7, local)) {
            pn_error("%s: node %u: its rotation at time %g is zero or not finite", s->name, n, time);
            r = PN_ERR_INVALID;
        }
        if (node->parent < 0)
            memcpy(world[n], local, sizeof local);
        else
            pn_mat4_mul(world[node->parent], local, world[n]);
    }
    free(trs);
    return r;
}

static bool in_float_range(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]) && fabs(v[0]) <= 1e18 && fabs(v[1]) <= 1e18 &&
           fabs(v[2]) <= 1e18;
}

// The punctual lights and the camera on posed nodes: where the reader put them (gltf.cpp's
// visit_punctual, visit_camera), from their node's world transform.
static pn_result place_lights_camera(pn_scene *s, double (*world)[16])
{
    const pn_scene_anim *a = s->anim;
    double pos[3], fwd[3], up[3];
    for (uint32_t i = 0; i < s->light_count && i < PN_SCENE_MAX_LIGHTS; i++) {
        int32_t n = a->light_node[i];
        if (n < 0 || !a->nodes[n].posed)
            continue;
        if (!pn_node_frame(world[n], pos, fwd, up) || !in_float_range(pos)) {
            pn_error("%s: light %u: its node %d is placed out of range or degenerate", s->name, i, n);
            return PN_ERR_INVALID;
        }
        for (int k = 0; k < 3; k++)
            s->lights[i].pos[k] = (float)pos[k], s->lights[i].normal[k] = (float)fwd[k], s->lights[i].up[k] = (float)up[k];
    }
    int32_t n = a->camera_node;
    if (s->has_camera && n >= 0 && a->nodes[n].posed) {
        if (!pn_node_frame(world[n], pos, fwd, up) || !in_float_range(pos)) {
            pn_error("%s: the camera's node %d is placed out of range or degenerate", s->name, n);
            return PN_ERR_INVALID;
        }
        for (int k = 0; k < 3; k++) {
            s->camera.pos[k] = (float)pos[k];
            s->camera.target[k] = (float)(pos[k] + fwd[k]);
            s->camera.up[k] = (float)up[k];
        }
    }
    return PN_OK;
}

pn_result pn_scene_pose(pn_scene *s, double time, pn_pose_report *report)
{
    pn_pose_report rep = {.first_vertex = UINT32_MAX};
    uint64_t t0 = pn_time_ns();
    pn_scene_anim *a = s->anim;
    if (!a || !a->order_count) {
        if (report)
            *report = (pn_pose_report){0};
        return PN_OK;
    }
    double(*world)[16] = malloc((a->node_count ? a->node_count : 1) * sizeof *world);
    if (!world)
        return PN_ERR_MEMORY;
    pn_result r = world_matrices(s, time, world);
    for (uint32_t i = 0; i < a->prim_count && r == PN_OK; i++) {
        const pn_anim_prim *p = &a->prims[i];
        pn_scene_xform xf = pn_scene_xform_from_matrix(world[p->node]);
        if ((xf.det < 0.0) != p->mirrored) {
            pn_error("%s: node %u: at time %g its transform %s, which it did not at rest; a mirroring pose "
                     "would turn its faces inside out",
                     s->name, p->node, time, p->mirrored ? "no longer mirrors" : "mirrors");
            r = PN_ERR_INVALID;
            break;
        }
        pn_scene_build_prim bp = {.positions = p->positions, .normals = p->normals, .uvs = p->uvs,
                                  .vertex_count = p->vertex_count, .triangles = p->triangles,
                                  .triangle_count = p->triangle_count, .capture_mesh = -1};
        uint64_t bad = 0;
        r = pn_scene_build_place(&bp, &xf, s->vertices + p->first_vertex, &bad);
        if (r == PN_ERR_FORMAT)
            pn_error("%s: node %u: at time %g vertex %llu leaves float range", s->name, p->node, time,
                     (unsigned long long)bad);
        uint32_t count = p->normals ? p->vertex_count : 3 * p->triangle_count;
        rep.first_vertex = p->first_vertex < rep.first_vertex ? p->first_vertex : rep.first_vertex;
        rep.end_vertex = p->first_vertex + count > rep.end_vertex ? p->first_vertex + count : rep.end_vertex;
        pn_scene_object *o = &s->objects[p->object];
        for (int row = 0; row < 3; row++) {
            for (int c = 0; c < 3; c++)
                o->to_world[row][c] = (float)world[p->node][c * 4 + row];
            o->to_world[row][3] = (float)world[p->node][12 + row];
        }
        rep.objects += i == 0 || a->prims[i - 1].object != p->object;
    }
    if (r == PN_OK)
        r = place_lights_camera(s, world);
    free(world);
    if (r == PN_OK && rep.objects)
        pn_scene_update_bounds(s);
    if (rep.first_vertex == UINT32_MAX)
        rep.first_vertex = rep.end_vertex = 0;
    rep.ms = pn_ms_since(t0);
    if (report)
        *report = rep;
    return r;
}

pn_result pn_scene_set_node_transform(pn_scene *s, uint32_t node, const double t[3], const double r[4],
                                      const double scale[3])
{
    pn_scene_anim *a = s->anim;
    if (!a || node >= a->node_count || !a->nodes[node].posed || a->nodes[node].matrix) {
        pn_error("%s: node %u cannot be given a transform: %s", s->name, node,
                 !a || node >= a->node_count ? "the scene poses no such node (only nodes its animations reach)"
                 : a->nodes[node].matrix     ? "the file gives it as a matrix"
                                             : "no animation reaches it, so its objects were not kept in its frame");
        return PN_ERR_INVALID;
    }
    double m[16];
    if (!pn_trs_matrix(t, r, scale, m)) {
        pn_error("%s: node %u: the rotation must be a non-zero quaternion", s->name, node);
        return PN_ERR_INVALID;
    }
    memcpy(a->nodes[node].t, t, sizeof a->nodes[node].t);
    memcpy(a->nodes[node].r, r, sizeof a->nodes[node].r);
    memcpy(a->nodes[node].s, scale, sizeof a->nodes[node].s);
    return PN_OK;
}
