// The --light groups of render and demo: a rectangle as its five parts, or a kind of light
// (scene/light.h) by name with the parts that kind takes.
#include <ctype.h>
#include <float.h>
#include <math.h>
#include <string.h>
#include <strings.h>

#include "apps/args.h"
#include "apps/render_opts.h"
#include "core/log.h"
#include "scene/light.h"

// An up vector for a light that has no height axis of its own (OMNI, SUN): any not along its normal.
static void light_any_up(pn_light *l)
{
    bool steep = fabsf(l->normal[1]) > 0.9f * sqrtf(l->normal[0] * l->normal[0] + l->normal[1] * l->normal[1] +
                                                      l->normal[2] * l->normal[2]);
    l->up[0] = steep ? 1.0f : 0.0f, l->up[1] = steep ? 0.0f : 1.0f, l->up[2] = 0.0f;
}

// --light omni:POS:I, spot:POS:DIR:INNER,OUTER:I (degrees), sphere:POS:RADIUS:L, sun:DIR:DIAMETER:E
// (degrees), rect:P:N:U:S:R; omni, spot and sphere take a range last (KHR_lights_punctual's: the
// light fades out there).
static bool parse_range(char **part, int parts, int need, pn_light *l)
{
    l->range = 0;
    return parts == need || pn_parse_float_range("--light range", part[need], 0.0f, FLT_MAX, &l->range);
}

static bool parse_light_kind(pn_light_kind kind, bool spot, char **part, int parts, const char *v, pn_render_opts *o)
{
    pn_light *l = &o->lights[o->light_count];
    l->kind = kind;
    bool ok = false;
    const char *value = part[parts - 1];
    if (kind == PN_LIGHT_RECT && parts == 5) {
        ok = pn_parse_floats("--light position", part[0], l->pos, 3) &&
             pn_parse_floats("--light normal", part[1], l->normal, 3) &&
             pn_parse_floats("--light up", part[2], l->up, 3) && pn_parse_floats("--light size", part[3], l->size, 2) &&
             pn_parse_rgb("--light radiance", part[4], l->radiance);
        if (ok && !pn_light_is_point(l) && !(l->size[0] > 0 && l->size[1] > 0)) {
            pn_error("--light size: width and height must both be positive, or both 0 for a point light, got '%s'",
                     part[3]);
            ok = false;
        }
    } else if (kind == PN_LIGHT_OMNI && !spot && (parts == 2 || parts == 3)) {
        l->normal[1] = -1;
        ok = pn_parse_floats("--light position", part[0], l->pos, 3) &&
             pn_parse_rgb("--light intensity", part[1], l->radiance) && parse_range(part, parts, 2, l);
        value = part[1];
    } else if (kind == PN_LIGHT_OMNI && spot && (parts == 4 || parts == 5)) {
        float cone[2] = {0, 0};
        value = part[3];
        ok = parse_range(part, parts, 4, l) && pn_parse_floats("--light position", part[0], l->pos, 3) &&
             pn_parse_floats("--light direction", part[1], l->normal, 3) &&
             pn_parse_floats("--light cone", part[2], cone, 2) && pn_parse_rgb("--light intensity", part[3], l->radiance);
        // glTF's rule: 0 <= inner < outer <= 90 degrees.
        if (ok && !(cone[0] >= 0 && cone[0] < cone[1] && cone[1] <= 90)) {
            pn_error("--light spot cone: inner and outer angles need 0 <= inner < outer <= 90 degrees, got '%s'", part[2]);
            ok = false;
        }
        l->cone[0] = cone[0] * 3.14159265f / 180, l->cone[1] = cone[1] * 3.14159265f / 180;
    } else if (kind == PN_LIGHT_SPHERE && (parts == 3 || parts == 4)) {
        l->normal[1] = -1;
        value = part[2];
        ok = pn_parse_floats("--light position", part[0], l->pos, 3) &&
             pn_parse_float_range("--light radius", part[1], 0.0f, FLT_MAX, &l->radius) &&
             pn_parse_rgb("--light radiance", part[2], l->radiance) && parse_range(part, parts, 3, l);
        if (ok && !(l->radius > 0)) {
            pn_error("--light sphere radius: must be positive (omni:position:intensity is a point), got '%s'", part[1]);
            ok = false;
        }
    } else if (kind == PN_LIGHT_DISK && parts == 5) {
        ok = pn_parse_floats("--light position", part[0], l->pos, 3) &&
             pn_parse_floats("--light normal", part[1], l->normal, 3) &&
             pn_parse_floats("--light up", part[2], l->up, 3) &&
             pn_parse_float_range("--light radius", part[3], 0.0f, FLT_MAX, &l->radius) &&
             pn_parse_rgb("--light radiance", part[4], l->radiance);
        if (ok && !(l->radius > 0)) {
            pn_error("--light disk radius: must be positive, got '%s'", part[3]);
            ok = false;
        }
        l->size[0] = l->size[1] = 2 * l->radius; // the square round it
    } else if (kind == PN_LIGHT_SUN && parts == 3) {
        float deg = 0; // read only where parsed (ok), but clang cannot see it
        ok = pn_parse_floats("--light direction", part[0], l->normal, 3) &&
             pn_parse_float_range("--light angular diameter", part[1], 0.0f, 10.0f, &deg) &&
             pn_parse_rgb("--light irradiance", part[2], l->radiance);
        l->angle = deg * 3.14159265f / 180;
    } else {
        pn_error("--light: expected omni:position:intensity[:range], "
                 "spot:position:direction:inner,outer:intensity[:range], sphere:position:radius:radiance[:range], disk:position:normal:up:radius:radiance, "
                 "sun:direction:diameter:irradiance or "
                 "rect:position:normal:up:size:radiance, got '%s'",
                 v);
        return false;
    }
    if (ok && kind != PN_LIGHT_RECT && kind != PN_LIGHT_DISK)
        light_any_up(l);
    if (ok && (l->radiance[0] < 0 || l->radiance[1] < 0 || l->radiance[2] < 0)) {
        pn_error("--light: the radiance, intensity or irradiance must not be negative, got '%s'", value);
        ok = false;
    }
    o->light_count += ok;
    return ok;
}

bool pn_parse_light_group(const char *v, pn_render_opts *o)
{
    if (o->light_count == PN_MAX_LIGHTS) {
        pn_error("--light: at most %d lights", PN_MAX_LIGHTS);
        return false;
    }
    char buf[512], *part[6];
    int parts = 0;
    if (strlen(v) >= sizeof buf) {
        pn_error("--light: value too long ('%.40s...')", v);
        return false;
    }
    strcpy(buf, v);
    for (char *p = buf; p && parts < 6;) {
        part[parts++] = p;
        p = strchr(p, ':');
        if (p)
            *p++ = '\0';
    }
    pn_light *l = &o->lights[o->light_count];
    *l = (pn_light){0};
    // A kind's name first (scene/light.h), else a rectangle as the five parts always gave one.
    pn_light_kind kind = PN_LIGHT_RECT;
    if (parts > 0 && isalpha((unsigned char)part[0][0])) {
        bool spot = strcasecmp(part[0], "spot") == 0; // an OMNI light with a cone
        if (spot)
            kind = PN_LIGHT_OMNI;
        else if (!pn_light_kind_parse(part[0], &kind)) {
            pn_error("--light: unknown kind '%s' (rect, omni, spot, sphere, disk, sun)", part[0]);
            return false;
        }
        return parse_light_kind(kind, spot, part + 1, parts - 1, v, o);
    }
    if (parts != 5) {
        pn_error("--light: expected position:normal:up:size:radiance (e.g. 0,4,0:0,-1,0:0,0,1:1,1:10), got '%s'", v);
        return false;
    }
    bool ok = pn_parse_floats("--light position", part[0], l->pos, 3) &&
              pn_parse_floats("--light normal", part[1], l->normal, 3) &&
              pn_parse_floats("--light up", part[2], l->up, 3) && pn_parse_floats("--light size", part[3], l->size, 2) &&
              pn_parse_rgb("--light radiance", part[4], l->radiance);
    if (ok && !pn_light_is_point(l) && !(l->size[0] > 0 && l->size[1] > 0)) {
        pn_error("--light size: width and height must both be positive, or both 0 for a point light, got '%s'", part[3]);
        ok = false;
    }
    if (ok && (l->radiance[0] < 0 || l->radiance[1] < 0 || l->radiance[2] < 0)) {
        pn_error("--light radiance: must not be negative, got '%s'", part[4]);
        ok = false;
    }
    o->light_count += ok;
    return ok;
}
