// The rectangular one-sided Lambertian area light: Light in interface.h.
#include "interface.h"

// Exact irradiance per unit radiance at p with unit normal n (Lambert's edge sum over the
// polygon clipped to the receiver's upper hemisphere; zero behind the light); per unit intensity
// for a point light.
// Same algorithm as pn_light_irradiance on the CPU, in float.
float light_irradiance(Light l, vec3 p, vec3 n)
{
    vec3 centre = 0.25 * (l.corners[0].xyz + l.corners[1].xyz + l.corners[2].xyz + l.corners[3].xyz);
    if (dot(l.normal.xyz, p - centre) <= 0.0)
        return 0.0;
    if (l.radiance.w != 0.0) { // point light: cos(light) cos(receiver) / r^2 per unit intensity
        vec3 d = p - centre;
        float r2 = dot(d, d); // below FLT_MAX: positions are within 1e18 (pn_scene_validate)
        return (max(dot(l.normal.xyz, d), 0.0) / r2) * (max(-dot(n, d), 0.0) / r2);
    }
    vec3 poly[8];
    int m = 0;
    for (int i = 0; i < 4; i++) {
        vec3 a = l.corners[i].xyz - p, b = l.corners[(i + 1) & 3].xyz - p;
        float da = dot(n, a), db = dot(n, b);
        if (da >= 0.0)
            poly[m++] = a;
        if ((da >= 0.0) != (db >= 0.0))
            poly[m++] = a + (da / (da - db)) * (b - a);
    }
    float sum = 0.0;
    for (int i = 0; i < m; i++) {
        vec3 a = poly[i], b = poly[(i + 1) % m];
        vec3 c = cross(a, b);
        float cl = length(c);
        if (cl > 0.0)
            sum += atan(cl, dot(a, b)) * dot(c, n) / cl;
    }
    return 0.5 * abs(sum);
}
