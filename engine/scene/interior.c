// Interiors seen from inside (interior.h). The rule, in order:
//  1. From the bounds' centre c, PN_INTERIOR_PROBES directions spread evenly over the sphere: the
//     scene is an interior when most of them, and most of the level ones, hit a surface facing c
//     (interior.h). A surface faces c when its winding's normal, turned to agree with the file's
//     vertex normals, points back along the ray.
//  2. The floor is the lowest surface straight below c and below eight points around it (a table
//     under the centre is not the floor); the ceiling, the surface straight above c (none: the room
//     is open above, as Sponza's atrium).
//  3. The eye stands above c at PN_INTERIOR_EYE of the way from the floor to the ceiling (or to the
//     top of the bounds) and looks level along the longest of 32 horizontal directions; it steps
//     back along the opposite direction by half the free distance there, to see more of the room.
//  4. The light: under the ceiling above the middle of the view, facing down, a quarter of the clear
//     height wide; with no ceiling there, above the top of the bounds over c, aimed at that middle.
#include "scene/interior.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/parallel.h"
#include "scene/view.h"

enum { MAX_RAYS = PN_INTERIOR_PROBES, LEVEL_DIRS = 32 };

typedef struct hit {
    float t;    // INFINITY: no hit
    bool front; // the surface faces the ray's origin
    uint32_t tri;
} hit;

typedef struct cast_job {
    const pn_scene *s;
    double origin[3];
    const float (*dir)[3];
    int n;
    hit *per_thread; // pn_parallel_threads() x n
} cast_job;

// The nearer hit, the lower triangle index on a tie: the same on any number of threads.
static bool nearer(const hit *a, const hit *b) { return a->t < b->t || (a->t == b->t && a->tri < b->tri); }

static void cast_range(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    const cast_job *j = ctx;
    const pn_scene *s = j->s;
    hit *best = j->per_thread + (size_t)thread * (size_t)j->n;
    for (uint64_t t = begin; t < end; t++) {
        const pn_vertex *v[3];
        float p[3][3]; // relative to the origin: small numbers near it, whatever the scene's offset
        for (int k = 0; k < 3; k++) {
            v[k] = &s->vertices[s->indices[3 * t + (uint64_t)k]];
            for (int c = 0; c < 3; c++)
                p[k][c] = (float)((double)v[k]->pos[c] - j->origin[c]);
        }
        float e1[3], e2[3], ng[3], nv[3];
        for (int c = 0; c < 3; c++) {
            e1[c] = p[1][c] - p[0][c];
            e2[c] = p[2][c] - p[0][c];
            nv[c] = v[0]->normal[c] + v[1]->normal[c] + v[2]->normal[c];
        }
        ng[0] = e1[1] * e2[2] - e1[2] * e2[1];
        ng[1] = e1[2] * e2[0] - e1[0] * e2[2];
        ng[2] = e1[0] * e2[1] - e1[1] * e2[0];
        float flip = ng[0] * nv[0] + ng[1] * nv[1] + ng[2] * nv[2] < 0 ? -1.0f : 1.0f;
        // Moller-Trumbore with the ray's origin at 0: s = -p0.
        const float sv[3] = {-p[0][0], -p[0][1], -p[0][2]};
        const float q[3] = {sv[1] * e1[2] - sv[2] * e1[1], sv[2] * e1[0] - sv[0] * e1[2], sv[0] * e1[1] - sv[1] * e1[0]};
        const float tq = e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2];
        for (int r = 0; r < j->n; r++) {
            const float *d = j->dir[r];
            float pv[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
            float det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
            if (det == 0.0f)
                continue;
            float inv = 1.0f / det;
            float u = (sv[0] * pv[0] + sv[1] * pv[1] + sv[2] * pv[2]) * inv;
            float w = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
            float dist = tq * inv;
            if (!(u >= 0.0f && w >= 0.0f && u + w <= 1.0f && dist > 0.0f))
                continue;
            hit h = {dist, flip * (ng[0] * d[0] + ng[1] * d[1] + ng[2] * d[2]) < 0.0f, (uint32_t)t};
            if (nearer(&h, &best[r]))
                best[r] = h;
        }
    }
}

// The nearest hit of each of n rays from `origin` (n <= MAX_RAYS), over every triangle.
static bool cast(const pn_scene *s, const double origin[3], const float (*dir)[3], int n, hit *out)
{
    unsigned threads = pn_parallel_threads();
    cast_job j = {s, {origin[0], origin[1], origin[2]}, dir, n, malloc(sizeof(hit) * threads * (size_t)n)};
    if (!j.per_thread)
        return false;
    for (size_t i = 0; i < (size_t)threads * (size_t)n; i++)
        j.per_thread[i] = (hit){INFINITY, false, UINT32_MAX};
    pn_parallel_for(pn_scene_triangle_count(s), 4096, cast_range, &j);
    for (int r = 0; r < n; r++) {
        out[r] = j.per_thread[r];
        for (unsigned th = 1; th < threads; th++)
            if (nearer(&j.per_thread[(size_t)th * (size_t)n + (size_t)r], &out[r]))
                out[r] = j.per_thread[(size_t)th * (size_t)n + (size_t)r];
    }
    free(j.per_thread);
    return true;
}

// One ray's hit distance, whichever way the surface faces (a roof modelled to be seen from outside
// is still a ceiling), else INFINITY.
static float cast_one(const pn_scene *s, const double origin[3], const float dir[3])
{
    hit h;
    const float d[1][3] = {{dir[0], dir[1], dir[2]}};
    return cast(s, origin, d, 1, &h) ? h.t : INFINITY;
}

void pn_interior_find(const pn_scene *s, float yfov_deg, pn_interior *out)
{
    memset(out, 0, sizeof *out);
    const float *lo = s->bounds_min, *hi = s->bounds_max;
    double c[3], ext[3], r = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * ((double)lo[k] + hi[k]);
        ext[k] = (double)hi[k] - lo[k];
        r += 0.25 * ext[k] * ext[k];
    }
    r = sqrt(r);
    if (!(r > 0) || pn_scene_triangle_count(s) == 0)
        return;

    // 1. Enclosed? Fibonacci-sphere directions: even coverage for any count.
    float dir[MAX_RAYS][3];
    for (int i = 0; i < PN_INTERIOR_PROBES; i++) {
        float y = 1.0f - (2.0f * (float)i + 1.0f) / PN_INTERIOR_PROBES;
        float ring = sqrtf(fmaxf(0.0f, 1.0f - y * y)), phi = 2.39996323f * (float)i; // the golden angle
        dir[i][0] = ring * cosf(phi), dir[i][1] = y, dir[i][2] = ring * sinf(phi);
    }
    hit h[MAX_RAYS];
    if (!cast(s, c, (const float(*)[3])dir, PN_INTERIOR_PROBES, h))
        return;
    int facing = 0, level_n = 0, level_facing = 0;
    for (int i = 0; i < PN_INTERIOR_PROBES; i++) {
        facing += h[i].front;
        if (fabsf(dir[i][1]) <= 0.5f)
            level_n++, level_facing += h[i].front;
    }
    out->enclosed = (float)facing / PN_INTERIOR_PROBES;
    out->walled = (float)level_facing / (float)level_n;
    if (out->enclosed < PN_INTERIOR_ENCLOSED || out->walled < PN_INTERIOR_ENCLOSED)
        return;

    // 2. The floor: the lowest surface straight below c and below eight points around it, each a
    // quarter of the way to the wall in its level direction (inside the room, and past a table that
    // may stand under c); the ceiling: the surface straight above c.
    const float down[3] = {0, -1, 0}, up[3] = {0, 1, 0};
    float level[LEVEL_DIRS][3];
    for (int i = 0; i < LEVEL_DIRS; i++) {
        float a = 2.0f * 3.14159265f * (float)i / LEVEL_DIRS;
        level[i][0] = cosf(a), level[i][1] = 0, level[i][2] = sinf(a);
    }
    hit lh[LEVEL_DIRS];
    if (!cast(s, c, (const float(*)[3])level, LEVEL_DIRS, lh))
        return;
    double floor_y = INFINITY;
    for (int m = 0; m <= 8; m++) {
        double o[3] = {c[0], c[1], c[2]};
        int i = (m - 1) * (LEVEL_DIRS / 8);
        if (m > 0 && isfinite(lh[i].t))
            for (int k = 0; k < 3; k += 2)
                o[k] += 0.25 * lh[i].t * level[i][k];
        float t = cast_one(s, o, down);
        if (isfinite(t) && c[1] - t < floor_y)
            floor_y = c[1] - t;
    }
    if (!isfinite(floor_y))
        return; // nothing to stand on
    float t_up = cast_one(s, c, up);
    out->open_above = !isfinite(t_up);
    double ceiling_y = out->open_above ? hi[1] : c[1] + t_up;
    double eye_y = floor_y + PN_INTERIOR_EYE * (ceiling_y - floor_y);

    // 3. The longest level direction from the eye, and a step back from it.
    double eye[3] = {c[0], eye_y, c[2]};
    if (!cast(s, eye, (const float(*)[3])level, LEVEL_DIRS, lh))
        return;
    // A level ray that leaves the scene runs to the bounds' diagonal: open, and as long as any.
    double dist[LEVEL_DIRS];
    int best = 0;
    for (int i = 0; i < LEVEL_DIRS; i++) {
        dist[i] = isfinite(lh[i].t) ? lh[i].t : 2.0 * r;
        if (dist[i] > dist[best])
            best = i;
    }
    const float *fwd = level[best];
    double back = 0.5 * dist[(best + LEVEL_DIRS / 2) % LEVEL_DIRS];
    double ahead = dist[best] + back; // free distance in front of the camera
    pn_camera *cam = &out->camera;
    for (int k = 0; k < 3; k++) {
        cam->pos[k] = (float)(eye[k] - back * fwd[k]);
        cam->target[k] = (float)(eye[k] - back * fwd[k] + 0.5 * ahead * fwd[k]);
    }
    cam->up[0] = 0, cam->up[1] = 1, cam->up[2] = 0;
    cam->yfov_deg = yfov_deg;

    // 4. The light over the middle of the view.
    double mid[3] = {cam->pos[0] + 0.5 * ahead * fwd[0], eye_y, cam->pos[2] + 0.5 * ahead * fwd[2]};
    pn_light *l = &out->light;
    float t_mid = cast_one(s, mid, up);
    if (isfinite(t_mid)) {
        double ceil_mid = eye_y + t_mid;
        double room = ceil_mid - floor_y;
        // Hung a twentieth of the room's height below the ceiling: clear of its triangles by far
        // more than float precision at any scale, and still over the whole view.
        l->pos[0] = (float)mid[0], l->pos[1] = (float)(ceil_mid - 0.05 * room), l->pos[2] = (float)mid[2];
        l->normal[0] = 0, l->normal[1] = -1, l->normal[2] = 0;
        l->size[0] = l->size[1] = (float)(0.25 * room);
        ceiling_y = ceil_mid;
        out->open_above = false;
    } else {
        // Open above: over the opening (c's column had no ceiling), a quarter radius over the top,
        // aimed at the floor in the middle of the view; 0.15 radius wide, as the bench's Sponza.
        double to[3] = {mid[0], floor_y, mid[2]};
        l->pos[0] = (float)c[0], l->pos[1] = (float)(hi[1] + 0.25 * r), l->pos[2] = (float)c[2];
        double n[3] = {to[0] - l->pos[0], to[1] - l->pos[1], to[2] - l->pos[2]};
        double nl = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int k = 0; k < 3; k++)
            l->normal[k] = (float)(n[k] / nl);
        l->size[0] = l->size[1] = (float)(0.15 * r);
        out->open_above = true;
    }
    // The light's height axis along the view; straight up for a light that faces along the view.
    l->up[0] = fwd[0], l->up[1] = 0, l->up[2] = fwd[2];
    if (fabsf(l->normal[0] * fwd[0] + l->normal[2] * fwd[2]) > 0.999f)
        l->up[0] = 0, l->up[1] = 1, l->up[2] = 0;
    // An irradiance of pi on the floor below the light: a white floor there reflects a radiance of 1.
    l->radiance[0] = l->radiance[1] = l->radiance[2] = 1.0f;
    double p[3] = {l->pos[0], floor_y, l->pos[2]}, nf[3] = {0, 1, 0};
    double e = pn_light_irradiance(l, p, nf);
    if (e > 0)
        for (int k = 0; k < 3; k++)
            l->radiance[k] = (float)(3.14159265358979 / e);
    out->floor_y = (float)floor_y;
    out->ceiling_y = (float)ceiling_y;
    out->is_interior = true;
}
