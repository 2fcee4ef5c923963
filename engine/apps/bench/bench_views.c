// penumbra bench's views: the standard set every default run measures, and the scenes of --scenes
// with render's default framing. A standard view's scene is a mesh of the shared assets or a
// built-in scene (builtin:NAME, needing no assets). A standard view places camera and light relative to the object's
// bounding sphere (centre c, radius r), so it frames the mesh the same way whatever its units.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "apps/bench/bench.h"
#include "core/log.h"

// Offsets are in units of r from c. The three Table-1 meshes: the object fills most of the frame,
// lit from the left and above so that its shadow falls to the right onto the ground, in view, with
// a light half the radius wide (wide penumbrae). Sponza: from inside the atrium, along its length,
// with the light above the open roof, tilted so that the arches' shadows cross the floor and walls.
static const pn_bench_view_spec SPECS[] = {
    {"bunny", "stanford-bunny-69k.glb", {0.2f, 1.1f, 2.3f}, {0.4f, -0.3f, 0.0f}, 45.0f,
     {-1.3f, 1.6f, 0.5f}, {0.0f, 0.0f, 0.0f}, 0.5f, true},
    {"dragon", "stanford-dragon-871k.glb", {0.35f, 1.1f, 2.3f}, {0.3f, -0.3f, 0.0f}, 45.0f,
     {-1.3f, 1.6f, 0.5f}, {0.0f, 0.0f, 0.0f}, 0.5f, true},
    {"buddha", "happy-buddha-100k-decimated.glb", {0.6f, 0.5f, 2.6f}, {0.35f, -0.2f, 0.0f}, 45.0f,
     {-1.6f, 0.7f, 0.5f}, {0.0f, 0.0f, 0.0f}, 0.4f, true},
    {"sponza", "dabrovic-sponza-66k.glb", {-0.6f, -0.25f, 0.05f}, {0.4f, -0.15f, 0.0f}, 60.0f,
     {0.1f, 0.6f, 0.2f}, {-0.1f, -0.35f, -0.1f}, 0.15f, false},
    // The bunny's view under the other kinds of light (scene/light.h): the sun (0.53 degrees) from
    // the light's direction, and a sphere as wide as the light.
    {"bunny-sun", "stanford-bunny-69k.glb", {0.2f, 1.1f, 2.3f}, {0.4f, -0.3f, 0.0f}, 45.0f,
     {-1.3f, 1.6f, 0.5f}, {0.0f, 0.0f, 0.0f}, 0.5f, true, PN_LIGHT_SUN, 0.53f},
    {"bunny-sphere", "stanford-bunny-69k.glb", {0.2f, 1.1f, 2.3f}, {0.4f, -0.3f, 0.0f}, 45.0f,
     {-1.3f, 1.6f, 0.5f}, {0.0f, 0.0f, 0.0f}, 0.5f, true, PN_LIGHT_SPHERE, 0},
    // Alpha-masked casters (builtin:canopy, r = 4.5 m with its own ground): from above a corner,
    // the pergola and its leaves in the far half of the frame, the ground in front, where a light
    // high on the far side (about 18 cm wide, a little wider than a leaf is long) throws the
    // leaves' dappling and the posts' shadows towards the camera.
    {"canopy", "builtin:canopy", {0.93f, 1.05f, 1.15f}, {0.07f, -0.23f, 0.09f}, 50.0f,
     {-0.66f, 1.31f, -0.44f}, {0.07f, -0.35f, 0.07f}, 0.04f, false},
};
enum { SPEC_COUNT = sizeof SPECS / sizeof SPECS[0] };

const char *pn_bench_assets_dir(void)
{
    const char *env = getenv("PN_ASSETS");
    return env && env[0] ? env : "../shared/assets";
}

const pn_bench_view_spec *pn_bench_view_spec_find(const char *name)
{
    for (int i = 0; i < SPEC_COUNT; i++)
        if (strcmp(SPECS[i].name, name) == 0)
            return &SPECS[i];
    return NULL;
}

const pn_bench_view_spec *pn_bench_view_spec_at(int i) { return i >= 0 && i < SPEC_COUNT ? &SPECS[i] : NULL; }

bool pn_bench_view_standard(bench_view *v, const pn_bench_view_spec *spec)
{
    memset(v, 0, sizeof *v);
    v->spec = spec;
    snprintf(v->name, sizeof v->name, "%s", spec->name);
    if (strncmp(spec->file, "builtin:", 8) == 0) { // generated in code: always there
        snprintf(v->source, sizeof v->source, "%s", spec->file);
        return true;
    }
    snprintf(v->source, sizeof v->source, "%s/%s", pn_bench_assets_dir(), spec->file);
    struct stat st;
    return stat(v->source, &st) == 0;
}

void pn_bench_view_scene(bench_view *v, const char *source)
{
    memset(v, 0, sizeof *v);
    snprintf(v->source, sizeof v->source, "%s", source);
    const char *base = strrchr(source, '/');
    snprintf(v->name, sizeof v->name, "%s", base ? base + 1 : source);
}

int pn_bench_view_prepare(const bench_view *v, pn_prepared_scene *out)
{
    pn_render_opts o = pn_render_opts_default();
    o.ground = !v->spec || v->spec->ground;
    int rc = pn_render_prepare(&o, v->source, out);
    if (rc != PN_EXIT_OK || !v->spec)
        return rc;
    const pn_bench_view_spec *s = v->spec;
    const float *lo = out->object_min, *hi = out->object_max;
    float c[3], r2 = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5f * (lo[k] + hi[k]);
        r2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    }
    float r = 0.5f * sqrtf(r2);
    pn_camera *cam = &out->camera;
    pn_light *l = &out->lights[0];
    float aim[3], len2 = 0;
    for (int k = 0; k < 3; k++) {
        cam->pos[k] = c[k] + r * s->camera[k];
        cam->target[k] = c[k] + r * s->target[k];
        l->pos[k] = c[k] + r * s->light[k];
        aim[k] = c[k] + r * s->aim[k];
        l->normal[k] = aim[k] - l->pos[k];
        len2 += l->normal[k] * l->normal[k];
    }
    for (int k = 0; k < 3; k++)
        l->normal[k] /= sqrtf(len2);
    cam->up[0] = 0, cam->up[1] = 1, cam->up[2] = 0;
    cam->yfov_deg = s->fov;
    l->up[0] = 0, l->up[1] = 0, l->up[2] = -1;
    if (fabsf(l->normal[2]) > 0.9f) // up must not be parallel to the normal
        l->up[0] = 1, l->up[2] = 0;
    l->size[0] = l->size[1] = s->light_size * r;
    l->kind = s->kind;
    if (s->kind == PN_LIGHT_SPHERE) {
        l->radius = 0.5f * s->light_size * r;
        l->size[0] = l->size[1] = 0;
    } else if (s->kind == PN_LIGHT_SUN) {
        l->angle = s->sun_deg * 3.14159265f / 180;
        if (!pn_light_place_sun(l, lo, hi)) {
            pn_error("bench: %s: the scene is too large to place a sun", s->name);
            pn_scene_destroy(&out->scene);
            return PN_EXIT_FAILURE;
        }
    }
    // Radiance for an irradiance of pi at the aim point facing the light (the preview's exposure).
    l->radiance[0] = l->radiance[1] = l->radiance[2] = 1.0f;
    double p[3] = {aim[0], aim[1], aim[2]}, n[3] = {-l->normal[0], -l->normal[1], -l->normal[2]};
    double e = pn_light_irradiance(l, p, n);
    if (e > 0)
        for (int k = 0; k < 3; k++)
            l->radiance[k] = (float)(3.14159265358979 / e);
    return PN_EXIT_OK;
}
