// A scene ready to render as the options say (pn_render_prepare), shared by render and demo: the
// view set-up (camera and lights from the scene and the options, finished as the frame takes them)
// and the posing of a prepared scene (scene/anim.h): its objects move, the file's camera and lights
// follow their nodes where the frame uses them, and the framing stays the rest pose's.
//
// Apart from render_opts.c (parsing) so that the calls go one way: render_opts.c -> anim_opts.c
// (--time, --node-transform), and posing, which finishes camera and lights as the set-up does,
// sits beside the set-up instead of calling back into the parser's file.
#include "apps/render_opts.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/log.h"
#include "core/timer.h"
#include "scene/interior.h"

// Normalises v in double precision, so that neither huge (1e30) nor tiny (1e-30) components
// overflow or underflow on the way; false for a zero or non-finite vector.
static bool v3_unit(const float v[3], float out[3])
{
    double l = sqrt((double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2]);
    if (!(l > 0) || !isfinite(l))
        return false;
    for (int k = 0; k < 3; k++)
        out[k] = (float)(v[k] / l);
    return true;
}

// Logs and returns false when a point is farther than PN_MAX_COORD from the origin along an axis.
static bool in_range(const char *what, const float v[3])
{
    for (int k = 0; k < 3; k++)
        if (!(fabsf(v[k]) <= PN_MAX_COORD)) {
            pn_error("%s (%g, %g, %g) is beyond %g from the origin, where float arithmetic overflows", what,
                     (double)v[0], (double)v[1], (double)v[2], (double)PN_MAX_COORD);
            return false;
        }
    return true;
}

// Logs and returns false when the light's centre or a corner is out of range (in_range).
static bool light_in_range(const char *what, const pn_light *l)
{
    char name[96];
    snprintf(name, sizeof name, "%s's position", what);
    if (!in_range(name, l->pos))
        return false;
    float corners[4][3];
    pn_light_corners(l, corners);
    snprintf(name, sizeof name, "a corner of %s", what);
    for (int i = 0; i < 4; i++)
        if (!in_range(name, corners[i]))
            return false;
    return true;
}

// --light-pos/-normal/-up/-size/-radiance: changes to the one default light.
static bool light_flags_given(const pn_render_opts *o)
{
    return o->has_light_pos || o->has_light_normal || o->has_light_up || o->has_light_size || o->has_light_radiance;
}

static bool default_light(const pn_render_opts *o, const pn_scene *s, const pn_interior *interior, pn_light *lights,
                          uint32_t *light_count);

bool pn_render_setup_view(const pn_render_opts *o, const pn_scene *s, pn_camera *cam, pn_light *lights,
                          uint32_t *light_count)
{
    // A scene that encloses its centre (an atrium, a room) is seen from inside, by the camera and
    // the light its interior gives (scene/interior.h), unless the file or the options place them.
    bool frame = !(s->has_camera && !o->has_cam_pos && !o->has_cam_target);
    bool default_one = o->light_count == 0 && (s->light_count == 0 || light_flags_given(o));
    pn_interior interior = {0};
    if (frame || default_one)
        pn_interior_find(s, o->fov, &interior);
    if (!frame)
        *cam = s->camera;
    else if (interior.is_interior)
        *cam = interior.camera;
    else
        pn_camera_frame(s->bounds_min, s->bounds_max, o->fov, cam);
    if (!pn_render_finish_camera(o, cam))
        return false;

    bool light_flags = light_flags_given(o);
    if (o->light_count > 0 && light_flags) {
        pn_error("--light and --light-pos/-normal/-up/-size/-radiance: give each light as one --light group, or "
                 "change the one default light with the others");
        return false;
    }
    // The --light groups, else the scene file's lights unless --light-* asks for the default one.
    const pn_light *given = o->light_count ? o->lights : s->lights;
    uint32_t count = o->light_count ? o->light_count : light_flags ? 0 : s->light_count;
    if (count > PN_MAX_LIGHTS) {
        pn_error("%s: %u lights; a frame takes at most %d", s->name, count, PN_MAX_LIGHTS);
        return false;
    }
    if (count > 0) {
        for (uint32_t i = 0; i < count; i++) {
            char what[300];
            if (o->light_count)
                snprintf(what, sizeof what, "--light %u", i + 1);
            else
                snprintf(what, sizeof what, "%s: light %u", s->name, i);
            if (!pn_render_finish_light(what, &given[i], s->bounds_min, s->bounds_max, &lights[i]))
                return false;
        }
        *light_count = count;
        return true;
    }
    return default_light(o, s, &interior, lights, light_count);
}

bool pn_render_finish_camera(const pn_render_opts *o, pn_camera *cam)
{
    if (o->has_fov)
        cam->yfov_deg = o->fov;
    if (o->has_cam_pos)
        memcpy(cam->pos, o->cam_pos, sizeof cam->pos);
    if (o->has_cam_target)
        memcpy(cam->target, o->cam_target, sizeof cam->target);
    // (A framing camera can land out of range too: a huge scene seen through a narrow --fov.)
    if (!in_range("camera position", cam->pos) || !in_range("camera target", cam->target))
        return false;
    float d[3] = {cam->target[0] - cam->pos[0], cam->target[1] - cam->pos[1], cam->target[2] - cam->pos[2]};
    float dl = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]); // in range: no overflow
    // The view matrix (cglm) takes a direction shorter than FLT_EPSILON for zero.
    if (!(dl >= FLT_EPSILON)) {
        pn_error("camera position and target coincide or nearly (%g apart; the view needs %g)", (double)dl,
                 (double)FLT_EPSILON);
        return false;
    }
    if (!(fabsf(d[0]) + fabsf(d[2]) > 1e-6f * dl)) // looking straight up or down: an up vector not parallel to the view
        cam->up[0] = 0, cam->up[1] = 0, cam->up[2] = -1;
    return true;
}

bool pn_render_finish_light(const char *what, const pn_light *given, const float lo[3], const float hi[3], pn_light *l)
{
    *l = *given;
    float t[3], b[3];
    if (!v3_unit(given->normal, l->normal) || !v3_unit(given->up, l->up) || !pn_light_frame(l, t, b)) {
        pn_error("%s: the normal and up must not be zero, nor parallel to each other", what);
        return false;
    }
    if (l->kind == PN_LIGHT_SUN && !pn_light_place_sun(l, lo, hi)) {
        pn_error("%s: a sun needs the scene within 1e12 of its size from the origin", what);
        return false;
    }
    return light_in_range(what, l);
}

// The one light framed on the scene (or its interior), changed by --light-*.
static bool default_light(const pn_render_opts *o, const pn_scene *s, const pn_interior *interior, pn_light *lights,
                          uint32_t *light_count)
{
    *light_count = 1;
    pn_light *light = &lights[0];
    if (interior->is_interior)
        *light = interior->light;
    else
        pn_light_default(s->bounds_min, s->bounds_max, light);
    if (o->has_light_pos)
        memcpy(light->pos, o->light.pos, sizeof light->pos);
    if (!in_range("light position", light->pos))
        return false;
    if (o->has_light_normal) {
        if (!v3_unit(o->light.normal, light->normal)) {
            pn_error("--light-normal: must not be zero");
            return false;
        }
    } else if (o->has_light_pos) {
        // A moved light still faces the scene's centre.
        float to_centre[3];
        for (int k = 0; k < 3; k++)
            to_centre[k] = 0.5f * (s->bounds_min[k] + s->bounds_max[k]) - light->pos[k];
        if (!v3_unit(to_centre, light->normal))
            light->normal[0] = 0, light->normal[1] = -1, light->normal[2] = 0;
    }
    // Only its direction matters: unit length keeps pn_light_frame's float products in range.
    if (o->has_light_up && !v3_unit(o->light.up, light->up)) {
        pn_error("--light-up: must not be zero or parallel to the light's normal");
        return false;
    }
    float t[3], b[3];
    if (!pn_light_frame(light, t, b)) {
        if (o->has_light_up) {
            pn_error("--light-up: must not be zero or parallel to the light's normal");
            return false;
        }
        light->up[0] = 1, light->up[1] = 0, light->up[2] = 0; // default up was parallel: any other works
        if (!pn_light_frame(light, t, b))
            light->up[0] = 0, light->up[1] = 1;
    }
    if (o->has_light_size) {
        // A point light emits its radiant intensity as radiance x area did: without
        // --light-radiance, the default light's intensity along its normal, so the picture keeps
        // its brightness and only the penumbrae go.
        if (pn_light_is_point(&o->light))
            for (int k = 0; k < 3; k++)
                light->radiance[k] *= light->size[0] * light->size[1];
        memcpy(light->size, o->light.size, sizeof light->size);
    }
    if (o->has_light_radiance)
        memcpy(light->radiance, o->light.radiance, sizeof light->radiance);
    return light_in_range("the light", light);
}

int pn_render_prepare(const pn_render_opts *o, const char *source, pn_prepared_scene *out)
{
    memset(out, 0, sizeof *out);
    uint64_t t0 = pn_time_ns();
    if (pn_scene_load(source, &out->scene) != PN_OK)
        return PN_EXIT_FAILURE;
    out->load_ms = pn_ms_since(t0);
    for (uint32_t i = 0; i < o->node_transform_count; i++) {
        const pn_node_transform *x = &o->node_transforms[i];
        if (pn_scene_set_node_transform(&out->scene, x->node, x->t, x->r, x->s) != PN_OK) {
            pn_scene_destroy(&out->scene);
            return PN_EXIT_USAGE;
        }
    }
    out->file_camera = out->scene.has_camera && !o->has_cam_pos && !o->has_cam_target;
    out->file_lights = o->light_count == 0 && !light_flags_given(o) && out->scene.light_count > 0;
    for (uint32_t i = 0; i < o->move_count; i++)
        if (pn_scene_move_object(&out->scene, o->moves[i].object, o->moves[i].delta) != PN_OK) {
            pn_scene_destroy(&out->scene);
            return PN_EXIT_USAGE;
        }
    if (o->move_count && pn_scene_validate(&out->scene) != PN_OK) { // a move may leave float range
        pn_scene_destroy(&out->scene);
        return PN_EXIT_USAGE;
    }
    memcpy(out->object_min, out->scene.bounds_min, sizeof out->object_min);
    memcpy(out->object_max, out->scene.bounds_max, sizeof out->object_max);
    // Camera and light frame the scene itself; the ground plane is added afterwards.
    if (!pn_render_setup_view(o, &out->scene, &out->camera, out->lights, &out->light_count)) {
        pn_scene_destroy(&out->scene);
        return PN_EXIT_USAGE;
    }
    if (o->ground && pn_scene_add_ground(&out->scene, 6.0f) != PN_OK) {
        pn_error("%s: out of memory adding the ground plane", out->scene.name);
        pn_scene_destroy(&out->scene);
        return PN_EXIT_FAILURE;
    }
    if (o->has_time || o->node_transform_count) {
        int rc = pn_render_pose(o, out, o->has_time ? o->time : NAN);
        if (rc != PN_EXIT_OK) {
            pn_scene_destroy(&out->scene);
            return rc;
        }
    }
    return PN_EXIT_OK;
}

int pn_render_pose(const pn_render_opts *o, pn_prepared_scene *p, double time)
{
    pn_scene *s = &p->scene;
    if (pn_scene_pose(s, time, &p->pose) != PN_OK || pn_scene_validate(s) != PN_OK)
        return PN_EXIT_USAGE;
    const pn_scene_anim *a = s->anim;
    if (!a)
        return PN_EXIT_OK;
    if (p->file_camera && a->camera_node >= 0 && a->nodes[a->camera_node].posed) {
        pn_camera cam = s->camera;
        if (!pn_render_finish_camera(o, &cam))
            return PN_EXIT_USAGE;
        p->camera = cam;
    }
    for (uint32_t i = 0; p->file_lights && i < p->light_count; i++) {
        int32_t n = a->light_node[i];
        if (n < 0 || !a->nodes[n].posed)
            continue;
        char what[300];
        snprintf(what, sizeof what, "%s: light %u at time %g", s->name, i, time);
        // As the rest pose's lights were finished: a sun placed for the scene's own bounds.
        if (!pn_render_finish_light(what, &s->lights[i], p->object_min, p->object_max, &p->lights[i]))
            return PN_EXIT_USAGE;
    }
    return PN_EXIT_OK;
}
