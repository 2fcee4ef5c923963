// A light's unshadowed irradiance: Light in interface.h, the kinds' table in scene/light.h.
#include "interface.h"

// The kind of light l (its corners[0].w): a shader that runs for one kind only defines it as a
// constant first (shade.comp: a specialisation constant), and the other kinds' code compiles away.
#ifndef LIGHT_KIND_OF
#define LIGHT_KIND_OF(l) uint((l).corners[0].w)
#endif

// A spot's falloff at the cosine c from its axis (pn_light_spot): the square of the ramp linear in
// the cosine from the outer cone (corners[1].w) to the inner (corners[2].w); 1 without a cone.
float light_spot(Light l, float c)
{
    float scale = 1.0 / max(0.001, l.corners[2].w - l.corners[1].w);
    float a = clamp((c - l.corners[1].w) * scale, 0.0, 1.0);
    return a * a;
}

// Irradiance from a sphere of unit radiance subtending a cone of half-angle s (s2 = sin^2 s) at an
// angle t from the normal (c = cos t), the part below the horizon cut off: Snyder's closed form, as
// pn_light_sphere_irradiance.
float sphere_irradiance(float c, float s2)
{
    if (c * c > s2)
        return c > 0.0 ? 3.14159265 * s2 * c : 0.0;
    float sin_t = sqrt(max(1.0 - c * c, 0.0));
    float x = sqrt(1.0 / s2 - 1.0);
    float y = -x * c / sin_t;
    float sy = sin_t * sqrt(max(1.0 - y * y, 0.0));
    return max((c * acos(clamp(y, -1.0, 1.0)) - x * sy) * s2 + atan(sy / x), 0.0);
}

// Lambert's edge term of the edge from a to b (relative to the receiver point).
float edge_term(vec3 a, vec3 b, vec3 n)
{
    vec3 c = cross(a, b);
    float cl = length(c);
    return cl > 0.0 ? atan(cl, dot(a, b)) * dot(c, n) / cl : 0.0;
}

// A disk as the regular polygon of PN_LIGHT_DISK_SIDES sides and its area (pn_light_irradiance),
// clipped to the receiver's hemisphere edge by edge: a convex polygon leaves it at most once and
// comes back at most once, and the clipped polygon's edges are the kept parts of the sides plus
// the chord from where it leaves to where it comes back.
float disk_irradiance(Light l, vec3 p, vec3 n)
{
    vec3 centre = 0.5 * (l.corners[0].xyz + l.corners[2].xyz);
    if (dot(l.normal.xyz, p - centre) <= 0.0)
        return 0.0;
    vec3 t = 0.5 * (l.corners[1].xyz - l.corners[0].xyz), b = 0.5 * (l.corners[3].xyz - l.corners[0].xyz);
    const float a = 6.28318531 / float(PN_LIGHT_DISK_SIDES);
    float scale = sqrt(a / sin(a)); // the polygon's radius over the disk's: the same area
    vec3 c = centre - p;
    float sum = 0.0;
    vec3 leave = vec3(0.0), enter = vec3(0.0);
    bool left = false, entered = false;
    vec3 va = c + scale * t;
    for (int i = 1; i <= PN_LIGHT_DISK_SIDES; i++) {
        vec3 vb = c + scale * (cos(a * float(i)) * t + sin(a * float(i)) * b);
        float da = dot(n, va), db = dot(n, vb);
        if (da >= 0.0 && db >= 0.0) {
            sum += edge_term(va, vb, n);
        } else if (da >= 0.0) {
            leave = va + (da / (da - db)) * (vb - va);
            sum += edge_term(va, leave, n);
            left = true;
        } else if (db >= 0.0) {
            enter = va + (da / (da - db)) * (vb - va);
            sum += edge_term(enter, vb, n);
            entered = true;
        }
        va = vb;
    }
    if (left && entered)
        sum += edge_term(leave, enter, n);
    return 0.5 * abs(sum);
}

// KHR_lights_punctual's range window at distance d from an OMNI or SPHERE light's centre
// (pn_light_range_window): clamp(1 - (d / range)^4, 0, 1); range in corners[3].w, 0 for none.
float light_range_window(Light l, float d)
{
    float range = l.corners[3].w, x = d / range;
    return range > 0.0 ? clamp(1.0 - (x * x) * (x * x), 0.0, 1.0) : 1.0;
}

// Unshadowed irradiance at p with unit normal n, per unit of the light's radiance (rgb), as
// pn_light_irradiance on the CPU in float: RECT exact (Lambert's edge sum over the polygon clipped to
// the receiver's upper hemisphere; zero behind the light), a RECT point cos(light) cos(receiver) /
// r^2; OMNI cos(receiver) / r^2 times a spot's falloff; SUN per unit of its irradiance and SPHERE
// per unit radiance, Snyder's form.
float light_irradiance(Light l, vec3 p, vec3 n)
{
    uint kind = LIGHT_KIND_OF(l);
    if (kind == PN_LIGHT_SUN_ID) { // per unit E: the sphere's form over its projected solid angle
        float c = dot(n, -l.normal.xyz), s2 = l.corners[1].w;
        return s2 > 0.0 ? sphere_irradiance(c, s2) / (3.14159265 * s2) : max(c, 0.0);
    }
    if (kind == PN_LIGHT_SPHERE_ID) {
        vec3 a = l.corners[0].xyz - p;
        float len = length(a), r = l.corners[1].w; // below FLT_MAX: positions are within 1e18
        if (!(len > r))
            return 0.0; // inside the light
        float s = r / len;
        return sphere_irradiance(dot(n, a) / len, s * s) * light_range_window(l, len);
    }
    if (kind == PN_LIGHT_OMNI_ID) {
        vec3 d = p - l.corners[0].xyz;
        // Scaled to a max norm of 1 for the directions: |d|^3 may leave float range far out.
        float m = max(max(abs(d.x), abs(d.y)), abs(d.z));
        if (!(m > 0.0))
            return 0.0;
        vec3 u = normalize(d / m);
        float r2 = dot(d, d); // below FLT_MAX: positions are within 1e18 (pn_scene_validate)
        return max(-dot(n, u), 0.0) / r2 * light_spot(l, dot(l.normal.xyz, u)) * light_range_window(l, sqrt(r2));
    }
    vec3 centre = 0.25 * (l.corners[0].xyz + l.corners[1].xyz + l.corners[2].xyz + l.corners[3].xyz);
    if (dot(l.normal.xyz, p - centre) <= 0.0)
        return 0.0;
    if (kind == PN_LIGHT_DISK_ID)
        return disk_irradiance(l, p, n);
    if (l.radiance.w != 0.0) { // point light: cos(light) cos(receiver) / r^2 per unit intensity
        vec3 d = p - centre;
        float r2 = dot(d, d); // below FLT_MAX: positions are within 1e18 (pn_scene_validate)
        return (max(dot(l.normal.xyz, d), 0.0) / r2) * (max(-dot(n, d), 0.0) / r2);
    }
    // The rectangle clipped to the receiver's upper hemisphere, edge by edge as disk_irradiance
    // does, in straight-line code: a local array indexed by a running count (the clipped polygon's
    // vertices) lives in memory on llvmpipe, each store and load a scatter and gather over the
    // lanes, and that was half of the shading pass (1280x720: 30 ms, 17 without the irradiance).
    // The terms are summed in the polygon's order from its first vertex, the chord from where it
    // leaves the hemisphere right after the edge that leaves, and absent edges add an exact 0: the
    // same sum, bit for bit, as over the list of the clipped polygon's vertices it replaces.
    vec3 c[4];
    float d[4];
    for (int i = 0; i < 4; i++) {
        c[i] = l.corners[i].xyz - p;
        d[i] = dot(n, c[i]);
    }
    // Side i from corner i to i + 1: its kept part (a term, 0 if none), and where it crosses the
    // plane. A side that leaves is followed by the chord to where the next side that comes back
    // enters.
    float side[4];
    vec3 cut[4];
    for (int i = 0; i < 4; i++) {
        vec3 a = c[i], b = c[(i + 1) & 3];
        float da = d[i], db = d[(i + 1) & 3];
        cut[i] = a + (da / (da - db)) * (b - a);
        bool keep_a = da >= 0.0, keep_b = db >= 0.0;
        side[i] = keep_a || keep_b ? edge_term(keep_a ? a : cut[i], keep_b ? b : cut[i], n) : 0.0;
    }
    float sum = 0.0;
    for (int i = 0; i < 4; i++) {
        sum += side[i];
        if (d[i] >= 0.0 && !(d[(i + 1) & 3] >= 0.0)) {
            // The next side that enters: the first j after i whose start is below and end above.
            vec3 enter = cut[i];
            for (int k = 3; k >= 1; k--) {
                int j = (i + k) & 3;
                enter = !(d[j] >= 0.0) && d[(j + 1) & 3] >= 0.0 ? cut[j] : enter;
            }
            sum += edge_term(cut[i], enter, n);
        }
    }
    return 0.5 * abs(sum);
}
