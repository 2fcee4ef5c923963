// Alpha-masked casters in the exact tests: a masked triangle's first vertex carries, in w, the
// index of its record in the triangle pool (accel/alpha.h: its uvs and its material's header and
// alpha texels, after the triangles). A ray goes on past a hit whose texel is cut out.

// The record of triangle `tri`, 0 if it is opaque.
uint alpha_record(uint tri) { return floatBitsToUint(params.tris.v[3u * tri].w); }

// Is the hit at barycentric weights `bary` (of the triangle's vertices a, b, c) on a cut-out texel
// of the record `rec`? The texel nearest the hit's uv, the texture repeating; its alpha times the
// base colour's against the material's cutoff (glTF's MASK).
bool alpha_cut(uint rec, vec3 bary)
{
    vec4 r0 = params.tris.v[rec], r1 = params.tris.v[rec + 1u];
    vec2 uv = bary.x * r0.xy + bary.y * r0.zw + bary.z * r1.xy;
    uint h = floatBitsToUint(r1.z);
    vec4 h0 = params.tris.v[h], h1 = params.tris.v[h + 1u];
    float alpha = h1.x;
    uint w = floatBitsToUint(h0.x), ht = floatBitsToUint(h0.y);
    if (w > 0u) {
        vec2 f = uv - floor(uv);
        uint x = min(uint(f.x * float(w)), w - 1u), y = min(uint(f.y * float(ht)), ht - 1u);
        uint i = y * w + x;
        uint word = floatBitsToUint(params.tris.v[floatBitsToUint(h0.z) + i / 16u][(i / 4u) % 4u]);
        alpha *= float((word >> (8u * (i % 4u))) & 255u) / 255.0;
    }
    return alpha < h0.w;
}
