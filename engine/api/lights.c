// The API's lights: the public struct checked and completed into the engine's, and back.
#include <float.h>
#include <math.h>
#include <string.h>

#include "api/api_internal.h"
#include "scene/interior.h"
#include "scene/light.h"
#include "scene/view.h"

static const pn_light_kind KIND_IN[] = {
    [PENUMBRA_LIGHT_RECT] = PN_LIGHT_RECT,     [PENUMBRA_LIGHT_POINT] = PN_LIGHT_OMNI,
    [PENUMBRA_LIGHT_SUN] = PN_LIGHT_SUN,       [PENUMBRA_LIGHT_SPHERE] = PN_LIGHT_SPHERE,
    [PENUMBRA_LIGHT_DISK] = PN_LIGHT_DISK,
};

static bool finite3(const float v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

// A direction made unit. One already unit to float rounding (its squared length within 4 ulps of
// 1) is kept bit for bit: a light handed back by penumbra_scene_lights then traces exactly the
// rays render traces. False for zero.
static bool unit(const float v[3], float out[3])
{
    double l2 = (double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2];
    if (!(l2 > 0) || !isfinite(l2))
        return false;
    if (fabs(l2 - 1.0) <= 4 * FLT_EPSILON) {
        memcpy(out, v, 3 * sizeof(float));
        return true;
    }
    double l = sqrt(l2);
    for (int k = 0; k < 3; k++)
        out[k] = (float)(v[k] / l);
    return true;
}

static void unit_always(float v[3])
{
    double l = sqrt((double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2]);
    for (int k = 0; l > 0 && isfinite(l) && k < 3; k++)
        v[k] = (float)(v[k] / l);
}

// An up vector not along the normal (render's rule for the kinds without a height axis).
static void any_up(pn_light *l)
{
    bool steep = fabsf(l->normal[1]) > 0.9f;
    l->up[0] = steep ? 1.0f : 0.0f, l->up[1] = steep ? 0.0f : 1.0f, l->up[2] = 0.0f;
}

static bool in_range(const float v[3])
{
    return fabsf(v[0]) <= PN_API_MAX_COORD && fabsf(v[1]) <= PN_API_MAX_COORD && fabsf(v[2]) <= PN_API_MAX_COORD;
}

bool pn_api_light_in(const penumbra_light *in, uint32_t i, const pn_scene *scene, pn_light *l)
{
    const char *fn = "penumbra_visibility";
    if ((unsigned)in->kind >= sizeof KIND_IN / sizeof KIND_IN[0]) {
        pn_error("%s: light %u: kind %d is not a penumbra_light_kind", fn, i, (int)in->kind);
        return false;
    }
    memset(l, 0, sizeof *l);
    l->kind = KIND_IN[in->kind];
    l->radiance[0] = l->radiance[1] = l->radiance[2] = 1; // V does not depend on it
    bool scalars_ok = isfinite(in->radius) && isfinite(in->angle) && isfinite(in->cone[0]) && isfinite(in->cone[1]) &&
                      isfinite(in->range) && isfinite(in->size[0]) && isfinite(in->size[1]);
    if (!finite3(in->position) || !finite3(in->normal) || !finite3(in->up) || !scalars_ok) {
        pn_error("%s: light %u has a non-finite field", fn, i);
        return false;
    }
    if (l->kind != PN_LIGHT_SUN && !in_range(in->position)) {
        pn_error("%s: light %u: position (%g, %g, %g) is beyond %g from the origin", fn, i, (double)in->position[0],
                 (double)in->position[1], (double)in->position[2], (double)PN_API_MAX_COORD);
        return false;
    }
    memcpy(l->pos, in->position, sizeof l->pos);
    bool aimed = l->kind == PN_LIGHT_RECT || l->kind == PN_LIGHT_DISK || l->kind == PN_LIGHT_SUN ||
                 (l->kind == PN_LIGHT_OMNI && (in->cone[0] != 0 || in->cone[1] != 0));
    if (!unit(in->normal, l->normal)) {
        if (aimed) {
            pn_error("%s: light %u: its normal (direction) must not be zero", fn, i);
            return false;
        }
        l->normal[1] = -1; // a point or sphere emits every way: any axis
    }
    bool framed = l->kind == PN_LIGHT_RECT || l->kind == PN_LIGHT_DISK;
    if (!framed || !unit(in->up, l->up))
        any_up(l);
    float t[3], b[3];
    if (!pn_light_frame(l, t, b)) {
        if (framed && (in->up[0] != 0 || in->up[1] != 0 || in->up[2] != 0)) {
            pn_error("%s: light %u: up is parallel to the normal", fn, i);
            return false;
        }
        any_up(l);
    }
    switch (l->kind) {
    case PN_LIGHT_RECT:
        if (!(in->size[0] >= 0 && in->size[1] >= 0 && (in->size[0] > 0) == (in->size[1] > 0))) {
            pn_error("%s: light %u: a rectangle's width and height must both be positive, or both 0 (a point); got "
                     "%g x %g", fn, i, (double)in->size[0], (double)in->size[1]);
            return false;
        }
        memcpy(l->size, in->size, sizeof l->size);
        break;
    case PN_LIGHT_DISK:
    case PN_LIGHT_SPHERE:
        if (!(in->radius > 0)) {
            pn_error("%s: light %u: a %s's radius must be positive, got %g", fn, i,
                     l->kind == PN_LIGHT_DISK ? "disk" : "sphere", (double)in->radius);
            return false;
        }
        l->radius = in->radius;
        if (l->kind == PN_LIGHT_DISK)
            l->size[0] = l->size[1] = 2 * in->radius; // the square round it
        break;
    case PN_LIGHT_SUN:
        // render's --light sun takes diameters up to 10 degrees.
        if (!(in->angle >= 0 && in->angle <= 10 * 3.14159265f / 180)) {
            pn_error("%s: light %u: a sun's angular diameter must be 0..0.1745 radians (10 degrees), got %g", fn, i,
                     (double)in->angle);
            return false;
        }
        l->angle = in->angle;
        if (!pn_light_place_sun(l, scene->bounds_min, scene->bounds_max)) {
            pn_error("%s: light %u: a sun needs the scene within 1e12 of its size from the origin", fn, i);
            return false;
        }
        break;
    default: // PN_LIGHT_OMNI
        if ((in->cone[0] != 0 || in->cone[1] != 0) &&
            !(in->cone[0] >= 0 && in->cone[0] < in->cone[1] && in->cone[1] <= 3.14159265f / 2)) {
            pn_error("%s: light %u: a spot's cone needs 0 <= inner < outer <= pi/2, got %g, %g", fn, i,
                     (double)in->cone[0], (double)in->cone[1]);
            return false;
        }
        memcpy(l->cone, in->cone, sizeof l->cone);
        break;
    }
    if ((l->kind == PN_LIGHT_OMNI || l->kind == PN_LIGHT_SPHERE) && !(in->range >= 0)) {
        pn_error("%s: light %u: range must not be negative, got %g", fn, i, (double)in->range);
        return false;
    }
    if (l->kind == PN_LIGHT_OMNI || l->kind == PN_LIGHT_SPHERE)
        l->range = in->range;
    float corners[4][3];
    pn_light_corners(l, corners);
    for (int c = 0; c < 4; c++)
        if (!in_range(corners[c])) {
            pn_error("%s: light %u: a corner lies beyond %g from the origin", fn, i, (double)PN_API_MAX_COORD);
            return false;
        }
    return true;
}

static penumbra_light light_out(const pn_light *l)
{
    penumbra_light o = {0};
    for (unsigned k = 0; k < sizeof KIND_IN / sizeof KIND_IN[0]; k++)
        if (KIND_IN[k] == l->kind)
            o.kind = (penumbra_light_kind)k;
    memcpy(o.position, l->pos, sizeof o.position);
    memcpy(o.normal, l->normal, sizeof o.normal);
    memcpy(o.up, l->up, sizeof o.up);
    memcpy(o.size, l->size, sizeof o.size);
    o.radius = l->radius, o.angle = l->angle, o.range = l->range;
    memcpy(o.cone, l->cone, sizeof o.cone);
    return o;
}

penumbra_status penumbra_scene_lights(const penumbra_scene *s, penumbra_light *out, uint32_t capacity, uint32_t *count)
{
    const char *fn = "penumbra_scene_lights";
    pn_api_call call;
    pn_api_begin(&call, s ? s->ctx : NULL);
    if (!pn_api_need(s, fn, "scene") || !pn_api_need(count, fn, "count") || (capacity && !pn_api_need(out, fn, "out")))
        return pn_api_end(&call, PN_ERR_INVALID);
    const pn_scene *sc = &s->scene;
    pn_light lights[PN_SCENE_MAX_LIGHTS];
    uint32_t n = sc->light_count;
    for (uint32_t i = 0; i < n; i++) {
        // As render completes a file's light: unit normal and up, a sun placed beyond the bounds.
        penumbra_light given = light_out(&sc->lights[i]);
        // render normalises a file's directions in double, whatever their length (render_opts.c).
        unit_always(given.normal), unit_always(given.up);
        if (!pn_api_light_in(&given, i, sc, &lights[i])) {
            pn_error("%s: light %u of the file cannot be used", sc->name, i);
            return pn_api_end(&call, PN_ERR_FORMAT);
        }
    }
    if (n == 0) {
        // The light render frames on the scene: on its interior for a room seen from inside.
        pn_interior interior;
        pn_interior_find(sc, 45.0f, &interior);
        if (interior.is_interior)
            lights[0] = interior.light;
        else
            pn_light_default(sc->bounds_min, sc->bounds_max, &lights[0]);
        n = 1;
    }
    for (uint32_t i = 0; i < n && i < capacity; i++)
        out[i] = light_out(&lights[i]);
    *count = n;
    return pn_api_end(&call, PN_OK);
}
