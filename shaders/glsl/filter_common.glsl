// What the filters (filter.comp, penumbra_filter.comp) ask of two pixels' geometry: whether they
// lie on one surface, in dimensionless measures, the same at every scale.

// Upper bound of the spacing of floats near |x| (one ulp).
float ulp_bound(float x) { return max(abs(x), 1e-30) * 1.1920929e-7; }

// How far q leaves the tangent plane of the surface at p, in units of the distance the pixels
// between them span at p's depth (the footprint, view depth x pixel angle, times the pixel
// distance): a dimensionless ratio, the same at every scale. On p's plane it is 0 at any view
// angle, grazing included; on a surface of radius R it is about footprint / (2R) per pixel; across
// a crease of angle a it is about sin a; across a depth step it is the step over the footprint.
// The positions carry rounding of a few ulps of their magnitude (the rasterizer interpolates them,
// shadow_frame.glsl), which is taken off first: far from the origin a pixel's footprint can be
// below that, and rounding alone would then split one plane into edges.
float plane_offset(vec3 p, vec3 n, float footprint, vec3 q)
{
    float mag = max(max(max(abs(p.x), abs(p.y)), abs(p.z)), max(max(abs(q.x), abs(q.y)), abs(q.z)));
    float off = max(abs(dot(n, q - p)) - 8.0 * ulp_bound(mag), 0.0);
    return off / max(footprint, 1e-30);
}

// How much a neighbour q (normal m, footprint fq) `pixels` away continues the surface of the pixel p
// (normal n, footprint fp): both tangent planes, so that the weight is symmetric (a point on a wall
// next to a floor lies in the floor's plane only along their line of contact). 1 on the pixel's
// plane, falling to 0 once q is a footprint per pixel off it: beyond that the surface turns by more
// than 45 degrees within a pixel, or steps in depth, which is an edge of geometry by any
// definition. The normals' cosine, squared, does the same for two sheets that touch (the two sides
// of a thin wall: rho is 0, the normals oppose) and weights a crease by how far it turns.
float surface_weight(vec3 p, vec3 n, float fp, vec3 q, vec3 m, float fq, float pixels)
{
    float rho = max(plane_offset(p, n, fp * pixels, q), plane_offset(q, m, fq * pixels, p));
    float c = max(dot(n, m), 0.0);
    return max(1.0 - rho * rho, 0.0) * c * c;
}

// The penumbra filter's footprint (penumbra_filter.comp): the standard deviation, in world units on
// the receiver, of its Gaussian at a pixel whose nearest blocker casts a penumbra `width` wide,
// `pixel` its footprint (view depth x pixel angle), `samples` its samples: width_scale x width /
// sqrt(samples), at most max_radius / PN_PENUMBRA_RADIUS_SIGMAS pixels (a pixel facing the camera,
// the most a world length spans), compared before multiplying so that nothing overflows. -1
// without a blocker (PN_PENUMBRA_NONE); 0 for a point light's V (samples 0: exact, left alone).
float penumbra_footprint(float width, float pixel, float samples, float width_scale, uint max_radius)
{
    if (!(samples > 0.0))
        return 0.0;
    if (width >= PN_PENUMBRA_NONE)
        return -1.0;
    float limit = float(max_radius) / PN_PENUMBRA_RADIUS_SIGMAS * pixel;
    float s = width_scale * inversesqrt(samples);
    return min(width, limit / s) * s;
}
