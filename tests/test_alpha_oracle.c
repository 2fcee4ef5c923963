// Alpha-masked casters under an area light against an independent tracer. The scene, written here
// as a glTF: an opaque ground and four masked quads at different heights and tilts, two textures
// (32 x 32 of soft-edged circles, alpha falling to 0 at each centre; 16 x 16 of random alpha),
// four cutoffs, a base colour alpha of 0.8 on one, uvs that repeat the texture (below 0 and past 1)
// and one quad whose uv axes are turned 30 degrees from its edges; two of the quads overlap, so
// rays go on past a cut-out texel to a blocker behind. A 1.2 x 0.8 rectangular light 2.5 to 3.5
// above the quads casts penumbrae several texels wide across the masks' patterns.
//
// exact and exact-ls (both traversals each) render it with --ray-dump; Embree 3 (apps/embree_peer.c,
// an occlusion filter with its own texel lookup from the loaded scene's uvs and textures) traces
// the same rays, and V = visible / valid per pixel is compared. A third tracer, a referee in
// double written here from the test's own quads and textures (not the loaded scene), tells which
// rays the two may answer differently: those whose answer a float error can flip.
//
// The tolerance, derived. Both tracers work in float (unit roundoff u = 2^-24) from float inputs:
// the dump's origin (the GPU's own) and light point (the GPU's o + d rounded once to float: the ray
// Embree traces is off the GPU's by u |q| at its far end). Each finds the hit's barycentrics as
// ratios of edge functions of the vertices relative to the origin (the watertight test: a shear and
// 2 x 2 determinants; Embree's Moeller-Trumbore: cross and dot products), about ten roundings each
// on terms bounded by the largest coordinate M of the scene and the light (differences up to 2M).
// Moved along the triangle's plane, an error e across the ray is e / cos(theta) (theta from the
// plane's normal). So the two can place a hit apart by at most
//     delta = K u 2M / cos(theta),  K = 32
// (ten roundings in each tracer and the dump's, 21, rounded up to a power of two). The GPU also
// interpolates the uv in float (three products, two sums, the texel scale: six roundings of terms
// up to max |uv| + 1, rounded up to eps_uv = 8 u (max |uv| + 1)); Embree's filter does it in double.
// A ray is *ambiguous* when, in double, it passes within delta of a triangle's edge (on its plane),
// or hits a masked triangle within delta (plus eps_uv in uv) of a texel edge across which the cut
// decision changes. The alpha values are kept more than float rounding away from every cutoff
// (checked). Then:
//   - every ray the GPU and Embree answer differently must be ambiguous (and so must every ray on
//     which either differs from the referee);
//   - so per pixel |V_gpu - V_embree| <= ambiguous rays / valid rays: the pixels that may differ
//     are those with an ambiguous ray, by at most that fraction;
//   - the tolerance must not hide the masks: ambiguous rays must be under a tenth of the rays a
//     mask decides (rays the referee finds crossing masked triangles only on cut-out texels).
// Controls, which must fail the same check clearly: Embree with every triangle opaque (no filter),
// and Embree with the filter over textures flipped upside down (v measured from the wrong edge).
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "apps/embree_peer.h"
#include "io/exr.h"
#include "scene/scene.h"
#include "test_png.h"
#include "test_util.h"

enum { CIRCLES = 0, NOISE = 1, TEXTURES = 2 };
enum { CIRCLES_SIZE = 32, NOISE_SIZE = 16 };

typedef struct texture {
    uint32_t size; // square
    unsigned char rgba[CIRCLES_SIZE * CIRCLES_SIZE * 4];
} texture;

// The materials as the glTF states them: 0 is the opaque ground.
typedef struct mask_material {
    int texture;   // -1: none
    double alpha;  // baseColorFactor's alpha
    double cutoff; // 0: opaque
} mask_material;
static const mask_material MATERIALS[5] = {
    {-1, 1.0, 0.0}, {CIRCLES, 1.0, 0.5}, {NOISE, 0.8, 0.45}, {CIRCLES, 1.0, 0.3}, {NOISE, 1.0, 0.62}};

// A quad: centre, edge vectors a and b (a x b its normal, upwards), and its uv at the corner
// c - a/2 - b/2 plus s du + t dv at c + (s - 1/2) a + (t - 1/2) b.
typedef struct quad {
    int material;
    double c[3], a[3], b[3], uv0[2], du[2], dv[2];
} quad;
enum { QUADS = 5 };

static void scene_quads(quad q[QUADS])
{
    const double deg = acos(-1) / 180, d20 = 20 * deg, d35 = 35 * deg, d60 = 60 * deg, d30 = 30 * deg;
    // The ground, 6 x 6.
    q[0] = (quad){0, {0, 0, 0}, {6, 0, 0}, {0, 0, -6}, {0, 0}, {1, 0}, {0, 1}};
    // Circles, flat at 0.9, turned 20 degrees about y.
    q[1] = (quad){1, {-0.6, 0.9, 0.2}, {1.4 * cos(d20), 0, -1.4 * sin(d20)}, {-1.2 * sin(d20), 0, -1.2 * cos(d20)},
                  {0, 0}, {1, 0}, {0, 1}};
    // Random alpha at 0.8 of the texel's, tilted 35 degrees about x; uv from (-1.25, -0.5) over 3 x 3 repeats.
    q[2] = (quad){2, {0.9, 1.5, -0.3}, {1.3, 0, 0}, {0, 1.3 * sin(d35), -1.3 * cos(d35)},
                  {-1.25, -0.5}, {3, 0}, {0, 3}};
    // Circles at a lower cutoff, steep (60 degrees about z, facing the light), 2 x 2 repeats.
    q[3] = (quad){3, {-1.6, 1.0, 0.9}, {1.2 * cos(d60), -1.2 * sin(d60), 0}, {0, 0, -1.2}, {0, 0}, {2, 0}, {0, 2}};
    // Random alpha, low under the circles' quad, its uv axes turned 30 degrees from its edges.
    q[4] = (quad){4, {-0.2, 0.45, 0.5}, {0.9, 0, 0}, {0, 0, -0.9}, {0.2, -0.3}, {1.6 * cos(d30), 1.6 * sin(d30)},
                  {-1.6 * sin(d30), 1.6 * cos(d30)}};
}

// The rectangular light: --light's position, normal, up, size and radiance.
static const char *LIGHT = "0.3,4,0.2:0,-1,0:0,0,1:1.2,0.8:10";

// A small deterministic generator (Knuth's MMIX LCG), the top bits.
static uint32_t lcg(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (uint32_t)(*s >> 33);
}

static void make_textures(texture t[TEXTURES])
{
    uint64_t seed = 7;
    // Circles: alpha 255 outside them, inside falling linearly to 0 at the centre (so each cutoff cuts
    // its own radius); distances wrap, as the texture repeats.
    t[CIRCLES].size = CIRCLES_SIZE;
    double cx[7], cy[7], r[7];
    for (int i = 0; i < 7; i++)
        cx[i] = lcg(&seed) % CIRCLES_SIZE, cy[i] = lcg(&seed) % CIRCLES_SIZE, r[i] = 3 + lcg(&seed) % 6;
    for (int y = 0; y < CIRCLES_SIZE; y++)
        for (int x = 0; x < CIRCLES_SIZE; x++) {
            double a = 1;
            for (int i = 0; i < 7; i++) {
                double dx = fabs(x + 0.5 - cx[i]), dy = fabs(y + 0.5 - cy[i]);
                dx = fmin(dx, CIRCLES_SIZE - dx), dy = fmin(dy, CIRCLES_SIZE - dy);
                a = fmin(a, sqrt(dx * dx + dy * dy) / r[i]);
            }
            unsigned char *p = &t[CIRCLES].rgba[4 * (y * CIRCLES_SIZE + x)];
            p[0] = 200, p[1] = 120, p[2] = 60, p[3] = (unsigned char)lround(255 * a);
        }
    t[NOISE].size = NOISE_SIZE;
    for (int i = 0; i < NOISE_SIZE * NOISE_SIZE; i++) {
        unsigned char *p = &t[NOISE].rgba[4 * i];
        p[0] = 60, p[1] = 160, p[2] = 90, p[3] = (unsigned char)(lcg(&seed) >> 8);
    }
}

// Vectors in double for the referee (cglm's are float).
static void sub3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}
static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void cross3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1], o[1] = a[2] * b[0] - a[0] * b[2], o[2] = a[0] * b[1] - a[1] * b[0];
}

// The quads' corners and uvs as float (what the glTF holds), 4 a quad: c -+ a/2 -+ b/2 in the order
// (0,0), (1,0), (1,1), (0,1) of (s, t); triangles (0, 1, 2) and (0, 2, 3), counter-clockwise seen
// from a x b.
static void quad_vertices(const quad q[QUADS], float pos[QUADS * 4][3], float nrm[QUADS * 4][3], float uv[QUADS * 4][2])
{
    const double st[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int i = 0; i < QUADS; i++) {
        double n[3];
        cross3(q[i].a, q[i].b, n);
        double len = sqrt(dot3(n, n));
        for (int k = 0; k < 4; k++) {
            for (int j = 0; j < 3; j++) {
                pos[4 * i + k][j] = (float)(q[i].c[j] + (st[k][0] - 0.5) * q[i].a[j] + (st[k][1] - 0.5) * q[i].b[j]);
                nrm[4 * i + k][j] = (float)(n[j] / len);
            }
            for (int j = 0; j < 2; j++)
                uv[4 * i + k][j] = (float)(q[i].uv0[j] + st[k][0] * q[i].du[j] + st[k][1] * q[i].dv[j]);
        }
    }
}

static const char *write_gltf(const quad q[QUADS])
{
    float pos[QUADS * 4][3], nrm[QUADS * 4][3], uv[QUADS * 4][2];
    quad_vertices(q, pos, nrm, uv);
    uint16_t idx[QUADS * 6];
    for (int i = 0; i < QUADS; i++) {
        const uint16_t k[6] = {0, 1, 2, 0, 2, 3};
        for (int j = 0; j < 6; j++)
            idx[6 * i + j] = (uint16_t)(4 * i + k[j]);
    }
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (int v = 0; v < QUADS * 4; v++)
        for (int j = 0; j < 3; j++)
            lo[j] = fminf(lo[j], pos[v][j]), hi[j] = fmaxf(hi[j], pos[v][j]);
    enum { NPOS = sizeof pos, NNRM = sizeof nrm, NUV = sizeof uv, NIDX = sizeof idx, NBIN = NPOS + NNRM + NUV + NIDX };
    unsigned char bin[NBIN];
    memcpy(bin, pos, NPOS);
    memcpy(bin + NPOS, nrm, NNRM);
    memcpy(bin + NPOS + NNRM, uv, NUV);
    memcpy(bin + NPOS + NNRM + NUV, idx, NIDX);
    char data[4 * (NBIN + 2) / 3 + 8];
    pn_test_base64(bin, NBIN, data);
    const char *path = pn_test_tmp("alpha_oracle.gltf");
    FILE *f = fopen(path, "w");
    if (!f)
        return NULL;
    fprintf(f, "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
               "\"meshes\":[{\"primitives\":[");
    for (int i = 0; i < QUADS; i++)
        fprintf(f, "%s{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TEXCOORD_0\":2},\"indices\":%d,\"material\":%d}",
                i ? "," : "", 3 + i, q[i].material);
    fprintf(f, "]}],\"materials\":[");
    for (int m = 0; m < 5; m++) {
        const mask_material *mt = &MATERIALS[m];
        fputs(m ? "," : "", f);
        if (mt->texture < 0)
            fprintf(f, "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.8,0.8,%g]}}", mt->alpha);
        else
            fprintf(f,
                    "{\"alphaMode\":\"MASK\",\"alphaCutoff\":%g,\"pbrMetallicRoughness\":{"
                    "\"baseColorFactor\":[1,1,1,%g],\"baseColorTexture\":{\"index\":%d}}}",
                    mt->cutoff, mt->alpha, mt->texture);
    }
    // Nearest texels, repeating (glTF's default wrap): the rule both tracers apply.
    fprintf(f, "],\"textures\":[{\"source\":0,\"sampler\":0},{\"source\":1,\"sampler\":0}],"
               "\"samplers\":[{\"magFilter\":9728,\"minFilter\":9728}],"
               "\"images\":[{\"uri\":\"alpha_oracle_circles.png\"},{\"uri\":\"alpha_oracle_noise.png\"}],"
               "\"accessors\":[");
    fprintf(f,
            "{\"bufferView\":0,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\",\"min\":[%.9g,%.9g,%.9g],"
            "\"max\":[%.9g,%.9g,%.9g]},",
            QUADS * 4, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    fprintf(f, "{\"bufferView\":1,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\"},", QUADS * 4);
    fprintf(f, "{\"bufferView\":2,\"componentType\":5126,\"count\":%d,\"type\":\"VEC2\"}", QUADS * 4);
    for (int i = 0; i < QUADS; i++)
        fprintf(f, ",{\"bufferView\":3,\"byteOffset\":%d,\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"}",
                12 * i);
    fprintf(f,
            "],\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":%d},{\"buffer\":0,\"byteOffset\":%d,"
            "\"byteLength\":%d},{\"buffer\":0,\"byteOffset\":%d,\"byteLength\":%d},{\"buffer\":0,\"byteOffset\":%d,"
            "\"byteLength\":%d}],\"buffers\":[{\"byteLength\":%d,"
            "\"uri\":\"data:application/octet-stream;base64,%s\"}]}",
            NPOS, NPOS, NNRM, NPOS + NNRM, NUV, NPOS + NNRM + NUV, NIDX, NBIN, data);
    return fclose(f) == 0 ? path : NULL;
}

// ---------------------------------------------------------------------------------------------
// The referee: every ray against every triangle in double, from the test's own quads and textures.

typedef struct ref_tri {
    double p[3][3], uv[3][2];
    double n[3]; // unit normal
    // Per vertex i: the unit normal, in the plane, of the edge opposite i (towards i), and i's height over it.
    double m[3][3], h[3];
    double grad[2][3]; // the in-plane gradients of u and v (uv per world unit)
    double uv_mag;     // max |uv| over its vertices
    int material;
} ref_tri;

typedef struct referee {
    ref_tri tri[QUADS * 2];
    const texture *tex;
    double u;     // float's unit roundoff
    double two_m; // twice the largest coordinate of the scene and the light
} referee;

static void referee_init(referee *r, const quad q[QUADS], const texture *tex, double max_coord)
{
    float pos[QUADS * 4][3], nrm[QUADS * 4][3], uv[QUADS * 4][2];
    quad_vertices(q, pos, nrm, uv);
    r->tex = tex;
    r->u = ldexp(1, -24);
    r->two_m = 2 * max_coord;
    const int k[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int i = 0; i < QUADS; i++)
        for (int h = 0; h < 2; h++) {
            ref_tri *t = &r->tri[2 * i + h];
            t->material = q[i].material;
            t->uv_mag = 0;
            for (int v = 0; v < 3; v++) {
                for (int j = 0; j < 3; j++)
                    t->p[v][j] = pos[4 * i + k[h][v]][j];
                for (int j = 0; j < 2; j++) {
                    t->uv[v][j] = uv[4 * i + k[h][v]][j];
                    t->uv_mag = fmax(t->uv_mag, fabs(t->uv[v][j]));
                }
            }
            double e1[3], e2[3], n[3];
            sub3(t->p[1], t->p[0], e1);
            sub3(t->p[2], t->p[0], e2);
            cross3(e1, e2, n);
            double len = sqrt(dot3(n, n));
            for (int j = 0; j < 3; j++)
                t->n[j] = n[j] / len;
            for (int v = 0; v < 3; v++) {
                const double *a = t->p[(v + 1) % 3], *b = t->p[(v + 2) % 3];
                double e[3], m[3], to[3];
                sub3(b, a, e);
                // In the plane, across the edge; towards v, the triangle being counter-clockwise about n.
                cross3(t->n, e, m);
                double ml = sqrt(dot3(m, m));
                for (int j = 0; j < 3; j++)
                    t->m[v][j] = m[j] / ml;
                sub3(t->p[v], a, to);
                t->h[v] = dot3(t->m[v], to);
            }
            // grad = x e1 + y e2 with grad . e1 = du1, grad . e2 = du2 (for u, then v).
            double g11 = dot3(e1, e1), g12 = dot3(e1, e2), g22 = dot3(e2, e2), det = g11 * g22 - g12 * g12;
            for (int c = 0; c < 2; c++) {
                double d1 = t->uv[1][c] - t->uv[0][c], d2 = t->uv[2][c] - t->uv[0][c];
                double x = (d1 * g22 - d2 * g12) / det, y = (d2 * g11 - d1 * g12) / det;
                for (int j = 0; j < 3; j++)
                    t->grad[c][j] = x * e1[j] + y * e2[j];
            }
        }
}

// glTF's MASK on the test's own textures: is texel (x, y) (taken modulo the size) of material m cut out?
static bool ref_cut(const referee *r, int material, int64_t x, int64_t y)
{
    const mask_material *mt = &MATERIALS[material];
    const texture *t = &r->tex[mt->texture];
    int64_t s = t->size;
    x = ((x % s) + s) % s, y = ((y % s) + s) % s;
    return mt->alpha * t->rgba[4 * (y * s + x) + 3] / 255.0 < mt->cutoff;
}

typedef struct ref_answer {
    bool blocked;   // in double
    bool ambiguous; // a float tracer may answer either way
    bool mask;      // crosses a masked triangle inside, and every triangle it crosses is cut out there
    bool past;      // crosses a cut-out texel and is blocked by another triangle: a tracer must go on past it
    float margin;   // its nearest boundary (edge, or texel edge the decision changes across) in tolerances
} ref_answer;

static ref_answer referee_trace(const referee *r, const double o[3], const double q[3])
{
    ref_answer a = {.margin = 1e30f};
    double d[3];
    sub3(q, o, d);
    double dl = sqrt(dot3(d, d));
    bool crossed_mask = false, crossed_cut = false;
    for (int i = 0; i < QUADS * 2; i++) {
        const ref_tri *t = &r->tri[i];
        double dn = dot3(t->n, d);
        if (dn == 0) // in the triangle's plane or parallel to it: neither tracer's hit
            continue;
        double to[3];
        sub3(t->p[0], o, to);
        double tt = dot3(t->n, to) / dn;
        // The ends are not modelled: the origin is lifted clear of its own surface (shadow_origin) and
        // no triangle lies near the light.
        if (!(tt > 0 && tt < 1))
            continue;
        double x[3] = {o[0] + tt * d[0], o[1] + tt * d[1], o[2] + tt * d[2]};
        double delta = 32 * r->u * r->two_m / (fabs(dn) / dl);
        double s[3], lam[3];
        bool outside = false, near_edge = false;
        for (int v = 0; v < 3; v++) {
            double rel[3];
            sub3(x, t->p[(v + 1) % 3], rel);
            s[v] = dot3(t->m[v], rel); // signed distance to the edge opposite v, inside positive
            lam[v] = s[v] / t->h[v];
            outside |= s[v] < -delta;
            near_edge |= fabs(s[v]) <= delta;
        }
        if (outside)
            continue;
        for (int v = 0; v < 3; v++)
            a.margin = fminf(a.margin, (float)(fabs(s[v]) / delta));
        a.ambiguous |= near_edge;
        if (s[0] <= 0 || s[1] <= 0 || s[2] <= 0)
            continue;
        const mask_material *mt = &MATERIALS[t->material];
        if (mt->cutoff <= 0) {
            a.blocked = true;
            continue;
        }
        crossed_mask = true;
        double uv[2];
        int64_t texel[2], lo[2], hi[2];
        double dist[2], tols[2]; // from the texel's lower edge, in texels; the tolerance, in texels
        double size = r->tex[mt->texture].size;
        for (int c = 0; c < 2; c++) {
            uv[c] = lam[0] * t->uv[0][c] + lam[1] * t->uv[1][c] + lam[2] * t->uv[2][c];
            double g = sqrt(dot3(t->grad[c], t->grad[c])); // uv per world unit along the plane
            double tol = (delta * g + 8 * r->u * (t->uv_mag + 1)) * size; // in texels
            double xs = uv[c] * size;
            texel[c] = (int64_t)floor(xs);
            // The texels a float tracer may pick: this one, and a neighbour within tol of the edge between.
            lo[c] = (int64_t)floor(xs - tol), hi[c] = (int64_t)floor(xs + tol);
            dist[c] = xs - (double)texel[c], tols[c] = tol;
        }
        bool cut = ref_cut(r, t->material, texel[0], texel[1]);
        // The margin: the nearer edge of the texel in u, then in v, where the neighbour across decides otherwise.
        for (int c = 0; c < 2; c++)
            for (int side = 0; side < 2; side++) {
                int64_t nx = texel[0] + (c == 0 ? 2 * side - 1 : 0), ny = texel[1] + (c == 1 ? 2 * side - 1 : 0);
                double away = side ? 1 - dist[c] : dist[c];
                if (ref_cut(r, t->material, nx, ny) != cut)
                    a.margin = fminf(a.margin, (float)(away / tols[c]));
            }
        for (int64_t y = lo[1]; y <= hi[1]; y++)
            for (int64_t xx = lo[0]; xx <= hi[0]; xx++)
                a.ambiguous |= ref_cut(r, t->material, xx, y) != cut;
        a.blocked |= !cut;
        crossed_cut |= cut;
    }
    a.mask = crossed_mask && !a.blocked;
    a.past = crossed_cut && a.blocked;
    return a;
}

// ---------------------------------------------------------------------------------------------

typedef struct dump {
    uint32_t w, h, spp;
    float *data; // px origins, then px x spp light points (ray dump format, cmd_render.c)
} dump;

static bool read_dump(const char *path, uint32_t spp, dump *out)
{
    *out = (dump){0};
    FILE *f = fopen(path, "rb");
    uint32_t h[6] = {0};
    bool ok = f && fread(h, sizeof h, 1, f) == 1 && h[0] == 0x41524e50u && h[4] == spp;
    uint64_t px = (uint64_t)h[2] * h[3], floats = px * 4 * (1 + (uint64_t)spp);
    out->data = ok ? malloc(floats * sizeof(float)) : NULL;
    ok = ok && out->data && fread(out->data, sizeof(float), floats, f) == floats;
    if (f)
        fclose(f);
    out->w = h[2], out->h = h[3], out->spp = spp;
    return ok;
}

// One comparison of the GPU's answers against a tracer's (per ray, hit[p * spp + k]).
typedef struct compare {
    uint64_t differ, unexplained;          // rays answered differently; of those, not ambiguous
    uint64_t px, px_differ, px_over_bound; // pixels with a valid ray; V differs; |dV| over its ambiguity bound
    double max_dv, sum_dv;
    float max_margin; // the largest margin (ref_answer) of a ray answered differently: the tolerance it used
} compare;

static compare compare_runs(const dump *dp, const uint8_t *other, const ref_answer *ref)
{
    compare c = {0};
    uint64_t px = (uint64_t)dp->w * dp->h;
    for (uint64_t p = 0; p < px; p++) {
        if (dp->data[4 * p + 3] != 1.0f)
            continue;
        uint64_t valid = 0, vis_g = 0, vis_o = 0, amb = 0;
        for (uint64_t k = 0; k < dp->spp; k++) {
            uint64_t i = p * dp->spp + k;
            uint32_t flags;
            memcpy(&flags, &dp->data[4 * (px + i) + 3], 4);
            if (!(flags & 1))
                continue;
            bool g = flags & 2, e = other[i];
            valid++;
            vis_g += !g, vis_o += !e, amb += ref[i].ambiguous;
            c.differ += g != e;
            c.unexplained += g != e && !ref[i].ambiguous;
            c.max_margin = g != e ? fmaxf(c.max_margin, ref[i].margin) : c.max_margin;
        }
        if (!valid)
            continue;
        c.px++;
        uint64_t dv = vis_g > vis_o ? vis_g - vis_o : vis_o - vis_g;
        c.px_differ += dv != 0;
        c.px_over_bound += dv > amb;
        c.max_dv = fmax(c.max_dv, (double)dv / valid);
        c.sum_dv += (double)dv / valid;
    }
    return c;
}

static void report(const char *run, const char *what, const compare *c, uint64_t rays)
{
    fprintf(stderr,
            "%s: %s: %llu of %llu rays differ (%llu not ambiguous; the farthest from a boundary at %.3g of the "
            "tolerance); V differs on %llu of %llu pixels (%.4f%%), max |dV| %.4f, mean |dV| %.2e; %llu pixels over "
            "their bound\n",
            run, what, (unsigned long long)c->differ, (unsigned long long)rays, (unsigned long long)c->unexplained,
            c->max_margin,
            (unsigned long long)c->px_differ, (unsigned long long)c->px, c->px ? 100.0 * c->px_differ / c->px : 0,
            c->max_dv, c->px ? c->sum_dv / c->px : 0, (unsigned long long)c->px_over_bound);
}

typedef struct oracle {
    const char *gltf;
    pn_embree_scene *masked, *opaque, *flipped;
    const quad *quads;
    const texture *tex;
} oracle;

enum { WIDTH = 160, HEIGHT = 120, SPP = 16 };

static void check_run(const oracle *o, const char *mode, const char *traversal, bool controls)
{
    char run[64];
    snprintf(run, sizeof run, "%s (%s)", mode, traversal);
    const char *dump_path = pn_test_tmp("alpha_oracle_rays.bin"), *exr = pn_test_tmp("alpha_oracle.exr");
    char args[2048];
    snprintf(args, sizeof args,
             "render %s --no-ground --size %dx%d --camera-pos -0.3,4.6,3.0 --camera-target -0.3,0,-0.1 --fov 45 "
             "--mode %s --traversal %s --spp %d --filter none --light %s --ray-dump %s -o %s >/dev/null",
             o->gltf, WIDTH, HEIGHT, mode, traversal, SPP, LIGHT, dump_path, exr);
    int rc = pn_test_run(args);
    dump dp = {0};
    pn_exr_image img = {0};
    bool ok = rc == 0 && read_dump(dump_path, SPP, &dp) && dp.w == WIDTH && dp.h == HEIGHT &&
              pn_exr_read(exr, &img) == PN_OK;
    const float *v_exr = ok ? pn_exr_image_channel(&img, "shadow.V") : NULL;
    CHECK_MSG(ok && v_exr, "%s: render exited %d, or its ray dump or shadow.V cannot be read", run, rc);
    if (!ok || !v_exr) {
        free(dp.data);
        pn_exr_image_free(&img);
        return;
    }
    uint64_t px = (uint64_t)WIDTH * HEIGHT, n = px * SPP;

    // The referee on every valid ray, with M from the scene's and the rays' ends.
    double max_coord = 0;
    for (uint64_t i = 0; i < px * (1 + SPP); i++)
        for (int j = 0; j < 3; j++)
            max_coord = fmax(max_coord, fabs(dp.data[4 * i + j]));
    for (int i = 0; i < QUADS; i++)
        for (int j = 0; j < 3; j++)
            max_coord = fmax(max_coord, fabs(o->quads[i].c[j]) +
                                            0.5 * (fabs(o->quads[i].a[j]) + fabs(o->quads[i].b[j])));
    referee ref;
    referee_init(&ref, o->quads, o->tex, max_coord);
    ref_answer *ans = calloc(n, sizeof *ans);
    uint8_t *gpu = calloc(n, 1), *refb = calloc(n, 1), *hit = malloc(n);
    CHECK(ans && gpu && refb && hit);
    // px_amb, max_bound: the pixels that may differ and by how much (ambiguous / valid rays).
    uint64_t rays = 0, blocked = 0, ambiguous = 0, mask = 0, past = 0, v_off = 0, px_amb = 0;
    double max_bound = 0;
    for (uint64_t p = 0; ans && gpu && refb && hit && p < px; p++) {
        const float *og = &dp.data[4 * p];
        if (og[3] != 1.0f)
            continue;
        uint64_t valid = 0, vis = 0, amb = 0;
        for (uint64_t k = 0; k < SPP; k++) {
            uint64_t i = p * SPP + k;
            const float *qg = &dp.data[4 * (px + i)];
            uint32_t flags;
            memcpy(&flags, &qg[3], 4);
            if (!(flags & 1))
                continue;
            double od[3] = {og[0], og[1], og[2]}, qd[3] = {qg[0], qg[1], qg[2]};
            ans[i] = referee_trace(&ref, od, qd);
            gpu[i] = (flags & 2) != 0;
            refb[i] = ans[i].blocked;
            rays++, valid++, vis += !gpu[i], amb += ans[i].ambiguous;
            blocked += gpu[i], mask += ans[i].mask, past += ans[i].past;
        }
        ambiguous += amb;
        px_amb += amb > 0;
        max_bound = valid ? fmax(max_bound, (double)amb / valid) : max_bound;
        // The dump is the image's: V = visible / valid (1 without a valid ray), a GLSL division (2.5
        // ulp at most; an ulp of V < 1 is at most 2^-24).
        double v = valid ? (double)vis / valid : 1.0;
        v_off += fabs(v_exr[p] - v) > 2.5 * ldexp(1, -24);
    }
    fprintf(stderr,
            "%s: %llu rays, %llu blocked on the GPU, %llu decided by a mask, %llu blocked behind a cut-out texel, %llu "
            "ambiguous (%.4f%%): V may differ on %llu pixels, by at most %.4f\n",
            run, (unsigned long long)rays, (unsigned long long)blocked, (unsigned long long)mask,
            (unsigned long long)past, (unsigned long long)ambiguous, rays ? 100.0 * ambiguous / rays : 0,
            (unsigned long long)px_amb, max_bound);
    CHECK_MSG(v_off == 0, "%s: shadow.V differs from the ray dump's counts on %llu pixels", run,
              (unsigned long long)v_off);
    // The view must exercise what is compared: shadows (a tenth of the rays blocked), masks deciding
    // rays (a twentieth) and rays going on past a cut-out texel to a blocker behind (one in 200);
    // it gives about 1.7 times each (17%, 8.6%, 1.2% of 260720 rays).
    CHECK_MSG(rays > 150000 && blocked > rays / 10 && mask > rays / 20 && past > rays / 200,
              "%s: too little exercised: %llu rays, %llu blocked, %llu decided by a mask, %llu blocked behind one", run,
              (unsigned long long)rays, (unsigned long long)blocked, (unsigned long long)mask,
              (unsigned long long)past);
    CHECK_MSG(ambiguous * 10 < mask, "%s: the tolerance excuses %llu rays against %llu a mask decides", run,
              (unsigned long long)ambiguous, (unsigned long long)mask);

    if (ans && gpu && refb && hit) {
        pn_embree_trace_dump(o->masked, dp.data, px, SPP, 0, px, hit, NULL);
        compare e = compare_runs(&dp, hit, ans);
        report(run, "Embree with the filter", &e, rays);
        CHECK_MSG(e.unexplained == 0 && e.px_over_bound == 0,
                  "%s: Embree disagrees on %llu rays that are not ambiguous (%llu pixels over their bound)", run,
                  (unsigned long long)e.unexplained, (unsigned long long)e.px_over_bound);
        // Which of the two is off, where they differ: the referee, ray for ray.
        compare g = compare_runs(&dp, refb, ans);
        report(run, "the referee (double)", &g, rays);
        CHECK_MSG(g.unexplained == 0, "%s: the GPU and the referee disagree on %llu rays that are not ambiguous", run,
                  (unsigned long long)g.unexplained);
        if (controls) {
            // The controls must fail the check the filter passes, over the bound on at least half the
            // pixels where a mask decides a ray that is not ambiguous: the opaque tracer blocks every
            // such ray; the flipped textures move every mask's pattern.
            uint64_t mask_px = 0;
            for (uint64_t p = 0; p < px; p++) {
                bool any = false;
                for (uint64_t k = 0; k < SPP; k++)
                    any |= ans[p * SPP + k].mask && !ans[p * SPP + k].ambiguous;
                mask_px += any;
            }
            pn_embree_trace_dump(o->opaque, dp.data, px, SPP, 0, px, hit, NULL);
            compare c = compare_runs(&dp, hit, ans);
            report(run, "control: Embree, every triangle opaque", &c, rays);
            fprintf(stderr, "%s: %llu pixels have a ray a mask decides that is not ambiguous\n", run,
                    (unsigned long long)mask_px);
            CHECK_MSG(c.px_over_bound * 2 > mask_px, "%s: opaque Embree is over the bound on only %llu of %llu pixels",
                      run, (unsigned long long)c.px_over_bound, (unsigned long long)mask_px);
            pn_embree_trace_dump(o->flipped, dp.data, px, SPP, 0, px, hit, NULL);
            c = compare_runs(&dp, hit, ans);
            report(run, "control: Embree, textures upside down", &c, rays);
            CHECK_MSG(c.px_over_bound * 2 > mask_px,
                      "%s: Embree over flipped textures is over the bound on only %llu of %llu pixels", run,
                      (unsigned long long)c.px_over_bound, (unsigned long long)mask_px);
        }
    }
    free(ans), free(gpu), free(refb), free(hit), free(dp.data);
    pn_exr_image_free(&img);
}

int main(void)
{
    texture tex[TEXTURES];
    make_textures(tex);
    quad quads[QUADS];
    scene_quads(quads);
    CHECK(pn_test_write_png(pn_test_tmp("alpha_oracle_circles.png"), CIRCLES_SIZE, CIRCLES_SIZE, tex[CIRCLES].rgba));
    CHECK(pn_test_write_png(pn_test_tmp("alpha_oracle_noise.png"), NOISE_SIZE, NOISE_SIZE, tex[NOISE].rgba));
    char gltf[1024];
    const char *g = write_gltf(quads);
    CHECK(g);
    if (!g)
        return pn_test_result();
    snprintf(gltf, sizeof gltf, "%s", g);

    // No texel's alpha is within float rounding of its cutoff: the GPU's alpha, base x (texel / 255)
    // in float, is within 2 roundings (relative 2u) of the double value here.
    for (int m = 1; m < 5; m++) {
        const mask_material *mt = &MATERIALS[m];
        const texture *t = &tex[mt->texture];
        double closest = 1;
        for (uint32_t i = 0; i < t->size * t->size; i++)
            closest = fmin(closest, fabs(mt->alpha * t->rgba[4 * i + 3] / 255.0 - mt->cutoff));
        CHECK_MSG(closest > 4 * ldexp(1, -24), "material %d: a texel's alpha is %.3g from its cutoff", m, closest);
    }

    // The loaded scene (Embree's): the loader must have kept every texel, row order included, and the
    // materials; else the GPU and Embree could agree on a wrong mask.
    pn_scene scene, flipped;
    CHECK(pn_scene_load(gltf, &scene) == PN_OK);
    CHECK(pn_scene_load(gltf, &flipped) == PN_OK);
    CHECK(scene.material_count == 5 && scene.texture_count == 2);
    for (uint32_t m = 1; m < 5 && m < scene.material_count; m++) {
        const pn_material *pm = &scene.materials[m];
        const texture *t = &tex[MATERIALS[m].texture];
        bool has = pm->texture >= 0 && (uint32_t)pm->texture < scene.texture_count;
        CHECK_MSG(pm->alpha_cutoff == (float)MATERIALS[m].cutoff && pm->base_color[3] == (float)MATERIALS[m].alpha &&
                      has,
                  "material %u as loaded", m);
        const pn_texture *pt = has ? &scene.textures[pm->texture] : NULL;
        bool same = pt && pt->width == t->size && pt->height == t->size;
        for (uint32_t i = 0; same && i < t->size * t->size; i++)
            same = pt->rgba[4 * i + 3] == t->rgba[4 * i + 3];
        CHECK_MSG(same, "material %u: the loaded texture's alpha is not the PNG's", m);
    }
    // The control's textures, upside down (row y becomes row h - 1 - y).
    for (uint32_t i = 0; i < flipped.texture_count; i++) {
        pn_texture *t = &flipped.textures[i];
        for (uint32_t y = 0; y < t->height / 2; y++)
            for (uint32_t x = 0; x < 4 * t->width; x++) {
                uint8_t *a = &t->rgba[4 * y * t->width + x], *b = &t->rgba[4 * (t->height - 1 - y) * t->width + x];
                uint8_t s = *a;
                *a = *b, *b = s;
            }
    }

    pn_embree *embree = pn_embree_create();
    oracle o = {.gltf = gltf, .quads = quads, .tex = tex};
    if (embree) {
        o.masked = pn_embree_scene_create(embree, &scene);
        o.opaque = pn_embree_scene_create_desc(embree, &scene, &(pn_embree_scene_desc){.opaque = true});
        o.flipped = pn_embree_scene_create(embree, &flipped);
    }
    CHECK_MSG(o.masked && o.opaque && o.flipped, "Embree could not start or build the scene (filter functions?)");
    if (o.masked && o.opaque && o.flipped) {
        check_run(&o, "exact", "packet", true);
        check_run(&o, "exact", "ray", false);
        check_run(&o, "exact-ls", "ray", false);
        check_run(&o, "exact-ls", "packet", false);
    }
    pn_embree_scene_destroy(o.masked);
    pn_embree_scene_destroy(o.opaque);
    pn_embree_scene_destroy(o.flipped);
    pn_embree_destroy(embree);
    pn_scene_destroy(&flipped);
    pn_scene_destroy(&scene);
    return pn_test_result();
}
