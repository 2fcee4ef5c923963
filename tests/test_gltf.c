// pn_gltf_load: node transforms, primitive modes, normals and winding, materials and textures, the
// camera, hostile files (each must fail cleanly with *out zeroed), and the real meshes listed in
// $PN_ASSETS/MANIFEST.md with their documented triangle counts.
//
// Over 500 lines because each glTF feature and each hostile file is a file written here (its
// JSON and buffers), with what it must load as.
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdarg.h>
#include <math.h>
#include <stdint.h>
#include <sys/stat.h>
#include <time.h>

#include "core/log.h"
#include "io/exr.h"
#include "scene/light.h"
#include "scene/scene.h"
#include "test_util.h"

// ---------------------------------------------------------------------------------------------
// Writing test files

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
    if (n && fwrite(data, 1, n, f) != n) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
    fclose(f);
}

static char *base64(const unsigned char *d, size_t n)
{
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *o = malloc(4 * ((n + 2) / 3) + 1), *p = o;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)d[i] << 16;
        if (i + 1 < n)
            v |= (uint32_t)d[i + 1] << 8;
        if (i + 2 < n)
            v |= d[i + 2];
        *p++ = t[(v >> 18) & 63];
        *p++ = t[(v >> 12) & 63];
        *p++ = i + 1 < n ? t[(v >> 6) & 63] : '=';
        *p++ = i + 2 < n ? t[v & 63] : '=';
    }
    *p = 0;
    return o;
}

static char *format(const char *fmt, ...) __attribute__((format(printf, 1, 2), nonnull(1)));
static char *format(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    char probe;
    int n = vsnprintf(&probe, 1, fmt, ap);
    va_end(ap);
    char *s = malloc((size_t)n + 1);
    va_start(ap, fmt);
    vsnprintf(s, (size_t)n + 1, fmt, ap);
    va_end(ap);
    return s;
}

// The pieces of a one-buffer glTF file; NULL fields take the unit-cube defaults below.
typedef struct parts {
    const char *scenes; // JSON array; "" omits "scene" and "scenes"
    const char *nodes;
    const char *meshes;
    const char *accessors;
    const char *views;
    const char *extra; // more top-level members, each followed by a comma
    const unsigned char *bin;
    size_t bin_len;
} parts;

#define CUBE_BIN_LEN 168 // 8 float3 positions (96 bytes), then 36 uint16 indices (72 bytes)
#define CUBE_MESHES "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}]"
#define CUBE_ACCESSORS                                                                             \
    "[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\"},"                    \
    "{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]"
#define CUBE_VIEWS                                                                                 \
    "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":96},"                                          \
    "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":72}]"
#define Q45 "0.70710678118654752" // sin(45 deg) = cos(45 deg): a quaternion turning 90 degrees

static char *make_json(const parts *p, const char *buffer_uri)
{
    const char *scenes = p->scenes ? p->scenes : "[{\"nodes\":[0]}]";
    char *buffer = buffer_uri ? format("{\"byteLength\":%zu,\"uri\":\"%s\"}", p->bin_len, buffer_uri)
                              : format("{\"byteLength\":%zu}", p->bin_len);
    char *scene_part = *scenes ? format("\"scene\":0,\"scenes\":%s,", scenes) : format("%s", "");
    char *json = format("{\"asset\":{\"version\":\"2.0\"},%s%s\"nodes\":%s,\"meshes\":%s,"
                        "\"accessors\":%s,\"bufferViews\":%s,\"buffers\":[%s]}",
                        p->extra ? p->extra : "", scene_part,
                        p->nodes ? p->nodes : "[{\"mesh\":0}]", p->meshes ? p->meshes : CUBE_MESHES,
                        p->accessors ? p->accessors : CUBE_ACCESSORS,
                        p->views ? p->views : CUBE_VIEWS, buffer);
    free(buffer);
    free(scene_part);
    return json;
}

// A .gltf with the buffer embedded as a base64 data: URI.
static const char *write_gltf(const char *file, const parts *p)
{
    char *b64 = base64(p->bin, p->bin_len);
    char *uri = format("data:application/octet-stream;base64,%s", b64);
    char *json = make_json(p, uri);
    const char *path = pn_test_tmp(file);
    write_bytes(path, json, strlen(json));
    free(b64);
    free(uri);
    free(json);
    return path;
}

static void put_u32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v, p[1] = (unsigned char)(v >> 8), p[2] = (unsigned char)(v >> 16),
    p[3] = (unsigned char)(v >> 24);
}

// A .glb: 12-byte header, JSON chunk padded with spaces, BIN chunk padded with zeros.
static size_t make_glb(const parts *p, unsigned char **out)
{
    char *json = make_json(p, NULL);
    size_t jl = strlen(json), jp = (jl + 3) & ~(size_t)3, bp = (p->bin_len + 3) & ~(size_t)3;
    size_t total = 12 + 8 + jp + 8 + bp;
    unsigned char *g = calloc(1, total);
    memcpy(g, "glTF", 4);
    put_u32(g + 4, 2);
    put_u32(g + 8, (uint32_t)total);
    put_u32(g + 12, (uint32_t)jp);
    put_u32(g + 16, 0x4E4F534A); // "JSON"
    memcpy(g + 20, json, jl);
    memset(g + 20 + jl, ' ', jp - jl);
    put_u32(g + 20 + jp, (uint32_t)bp);
    put_u32(g + 24 + jp, 0x004E4942); // "BIN\0"
    memcpy(g + 28 + jp, p->bin, p->bin_len);
    free(json);
    *out = g;
    return total;
}

// Unit cube [-0.5, 0.5]^3: vertex v has coordinate a at +0.5 when bit a of v is set. Each face is
// two triangles wound counter-clockwise seen from outside (checked here by their normals).
static void cube_bin(unsigned char bin[CUBE_BIN_LEN])
{
    float pos[8][3];
    uint16_t idx[36];
    for (int v = 0; v < 8; v++)
        for (int a = 0; a < 3; a++)
            pos[v][a] = (v >> a) & 1 ? 0.5f : -0.5f;
    int k = 0;
    for (int a = 0; a < 3; a++)
        for (int s = 0; s < 2; s++) {
            int b = (a + 1) % 3, c = (a + 2) % 3;
            int q[4] = {s << a, s << a | 1 << b, s << a | 1 << b | 1 << c, s << a | 1 << c};
            int tris[2][3] = {{q[0], q[1], q[2]}, {q[0], q[2], q[3]}};
            for (int t = 0; t < 2; t++) {
                int *v = tris[t];
                float e1[3], e2[3];
                for (int i = 0; i < 3; i++) {
                    e1[i] = pos[v[1]][i] - pos[v[0]][i];
                    e2[i] = pos[v[2]][i] - pos[v[0]][i];
                }
                float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                              e1[0] * e2[1] - e1[1] * e2[0]};
                if (n[a] * (s ? 1.0f : -1.0f) < 0) { // points inwards: swap to wind it outwards
                    int tmp = v[1];
                    v[1] = v[2];
                    v[2] = tmp;
                }
                for (int i = 0; i < 3; i++)
                    idx[k++] = (uint16_t)v[i];
            }
        }
    memcpy(bin, pos, 96);
    memcpy(bin + 96, idx, 72);
}

// ---------------------------------------------------------------------------------------------
// Checking results

static void check_zeroed(const pn_scene *s)
{
    static const pn_scene zero;
    CHECK_MSG(memcmp(s, &zero, sizeof zero) == 0, "failed load left *out non-zero");
}

static void check_bounds(const pn_scene *s, const float emin[3], const float emax[3])
{
    for (int i = 0; i < 3; i++) {
        CHECK_MSG(fabsf(s->bounds_min[i] - emin[i]) < 1e-5f, "bounds_min[%d] = %g, expected %g", i,
                  s->bounds_min[i], emin[i]);
        CHECK_MSG(fabsf(s->bounds_max[i] - emax[i]) < 1e-5f, "bounds_max[%d] = %g, expected %g", i,
                  s->bounds_max[i], emax[i]);
    }
}

// Face normal from the stored positions in index order (what a rasteriser with CCW front faces
// sees); false for a zero-area triangle.
static int tri_normal(const pn_scene *s, uint32_t t, double n[3])
{
    const float *a = s->vertices[s->indices[3 * t]].pos, *b = s->vertices[s->indices[3 * t + 1]].pos,
                *c = s->vertices[s->indices[3 * t + 2]].pos;
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(l > 0))
        return 0;
    n[0] /= l, n[1] /= l, n[2] /= l;
    return 1;
}

// For planar faces: every vertex normal must agree with its triangle's winding.
static void check_normals_match_winding(const pn_scene *s)
{
    int bad = 0;
    for (uint32_t t = 0; t < s->index_count / 3; t++) {
        double n[3];
        if (!tri_normal(s, t, n))
            continue;
        for (int j = 0; j < 3; j++) {
            const float *vn = s->vertices[s->indices[3 * t + j]].normal;
            if (vn[0] * n[0] + vn[1] * n[1] + vn[2] * n[2] < 0.999)
                bad++;
        }
    }
    CHECK_MSG(bad == 0, "%d vertex normals disagree with their triangle's winding", bad);
}

// Every triangle of a convex solid centred at c must face away from c.
static void check_outward(const pn_scene *s, const float c[3])
{
    int inward = 0;
    for (uint32_t t = 0; t < s->index_count / 3; t++) {
        double n[3], m[3] = {0, 0, 0};
        CHECK(tri_normal(s, t, n));
        for (int j = 0; j < 3; j++)
            for (int i = 0; i < 3; i++)
                m[i] += s->vertices[s->indices[3 * t + j]].pos[i] / 3.0;
        if (n[0] * (m[0] - c[0]) + n[1] * (m[1] - c[1]) + n[2] * (m[2] - c[2]) <= 0)
            inward++;
    }
    CHECK_MSG(inward == 0, "%d triangles face inwards", inward);
}

static void check_unit_normals(const pn_scene *s, const char *what)
{
    uint32_t bad = 0, nonfinite = 0;
    for (uint32_t i = 0; i < s->vertex_count; i++) {
        const pn_vertex *v = &s->vertices[i];
        double l = sqrt((double)v->normal[0] * v->normal[0] + (double)v->normal[1] * v->normal[1] +
                        (double)v->normal[2] * v->normal[2]);
        if (!(fabs(l - 1.0) < 1e-3))
            bad++;
        if (!isfinite(v->pos[0]) || !isfinite(v->pos[1]) || !isfinite(v->pos[2]))
            nonfinite++;
    }
    CHECK_MSG(bad == 0, "%s: %u normals are not unit length", what, bad);
    CHECK_MSG(nonfinite == 0, "%s: %u positions are not finite", what, nonfinite);
    uint32_t out_of_range = 0;
    for (uint32_t k = 0; k < s->index_count; k++)
        out_of_range += s->indices[k] >= s->vertex_count;
    CHECK_MSG(out_of_range == 0, "%s: %u indices out of range", what, out_of_range);
}

static pn_result load_ok(const char *path, pn_scene *s)
{
    pn_result r = pn_gltf_load(path, s);
    CHECK_MSG(r == PN_OK, "%s: %s", path, pn_result_str(r));
    if (r == PN_OK) {
        check_unit_normals(s, path);
        CHECK(strcmp(s->name, path) == 0);
    } else {
        check_zeroed(s);
    }
    return r;
}

// ---------------------------------------------------------------------------------------------
// 1. The cube under a two-level hierarchy, as TRS and as matrices, and mirrored

static void test_cube_transforms(void)
{
    unsigned char bin[CUBE_BIN_LEN];
    cube_bin(bin);
    // Child: scale (2,1,1) first, so x spans [-1, 1] and y, z span [-0.5, 0.5]. Then 90 degrees
    // about +Y, which maps (x, y, z) to (z, y, -x): x now spans [-0.5, 0.5], z spans [-1, 1].
    // Parent: translation (10, 0, 0) moves x to [9.5, 10.5].
    const float emin[3] = {9.5f, -0.5f, -1.0f}, emax[3] = {10.5f, 0.5f, 1.0f};
    const float centre[3] = {10.0f, 0.0f, 0.0f};
    pn_scene s;

    parts trs = {.nodes = "[{\"translation\":[10,0,0],\"children\":[1]},"
                          "{\"mesh\":0,\"rotation\":[0," Q45 ",0," Q45 "],\"scale\":[2,1,1]}]",
                 .bin = bin,
                 .bin_len = sizeof bin};
    if (load_ok(write_gltf("cube_trs.gltf", &trs), &s) == PN_OK) {
        CHECK(pn_scene_triangle_count(&s) == 12);
        check_bounds(&s, emin, emax);
        check_outward(&s, centre); // flat normals (no NORMAL attribute) from correct winding
        check_normals_match_winding(&s);
        CHECK(!s.has_camera);
        CHECK(s.draw_count == 1 && s.draws[0].first_index == 0 && s.draws[0].index_count == 36);
        // no material in the file: one default white material
        CHECK(s.material_count == 1 && s.draws[0].material == 0);
        CHECK(s.materials[0].base_color[0] == 1.0f && s.materials[0].base_color[3] == 1.0f);
        CHECK(s.materials[0].texture == -1 && s.texture_count == 0);
        pn_scene_destroy(&s);
    }

    // The same transforms as column-major matrices. R*S has columns R*(2,0,0) = (0,0,-2),
    // R*(0,1,0) = (0,1,0) and R*(0,0,1) = (1,0,0).
    parts mat = trs;
    mat.nodes = "[{\"matrix\":[1,0,0,0, 0,1,0,0, 0,0,1,0, 10,0,0,1],\"children\":[1]},"
                "{\"mesh\":0,\"matrix\":[0,0,-2,0, 0,1,0,0, 1,0,0,0, 0,0,0,1]}]";
    if (load_ok(write_gltf("cube_matrix.gltf", &mat), &s) == PN_OK) {
        CHECK(pn_scene_triangle_count(&s) == 12);
        check_bounds(&s, emin, emax);
        check_outward(&s, centre);
        pn_scene_destroy(&s);
    }

    // Mirrored (scale -2 in x): same bounds since the cube is symmetric; the determinant is
    // negative, so the loader must flip the winding to keep the faces pointing outwards.
    parts mir = trs;
    mir.nodes = "[{\"translation\":[10,0,0],\"children\":[1]},"
                "{\"mesh\":0,\"rotation\":[0," Q45 ",0," Q45 "],\"scale\":[-2,1,1]}]";
    if (load_ok(write_gltf("cube_mirror.gltf", &mir), &s) == PN_OK) {
        check_bounds(&s, emin, emax);
        check_outward(&s, centre);
        check_normals_match_winding(&s);
        pn_scene_destroy(&s);
    }

    // No scenes at all: every root node is drawn.
    parts noscene = trs;
    noscene.scenes = "";
    if (load_ok(write_gltf("cube_noscene.gltf", &noscene), &s) == PN_OK) {
        CHECK(pn_scene_triangle_count(&s) == 12);
        check_bounds(&s, emin, emax);
        pn_scene_destroy(&s);
    }

    // Sparse accessor: vertex 7, (0.5, 0.5, 0.5), replaced by (3, 3, 3).
    unsigned char sbin[CUBE_BIN_LEN + 16] = {0};
    memcpy(sbin, bin, CUBE_BIN_LEN);
    uint16_t si = 7;
    float sv[3] = {3, 3, 3};
    memcpy(sbin + CUBE_BIN_LEN, &si, 2);
    memcpy(sbin + CUBE_BIN_LEN + 4, sv, 12);
    parts sparse = {
        .accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\","
                     "\"sparse\":{\"count\":1,\"indices\":{\"bufferView\":2,\"componentType\":5123},"
                     "\"values\":{\"bufferView\":3}}},"
                     "{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]",
        .views = "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":96},"
                 "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":72},"
                 "{\"buffer\":0,\"byteOffset\":168,\"byteLength\":2},"
                 "{\"buffer\":0,\"byteOffset\":172,\"byteLength\":12}]",
        .bin = sbin,
        .bin_len = sizeof sbin};
    if (load_ok(write_gltf("cube_sparse.gltf", &sparse), &s) == PN_OK) {
        const float smin[3] = {-0.5f, -0.5f, -0.5f}, smax[3] = {3, 3, 3};
        check_bounds(&s, smin, smax);
        pn_scene_destroy(&s);
    }
}

// ---------------------------------------------------------------------------------------------
// 2. A .glb: strip and fan primitives, NORMAL and TEXCOORD_0, materials, a mirrored instance

static void test_glb(void)
{
    // A quad on the plane y = x, normal (-1, 1, 0)/sqrt(2):
    // v0 (0,0,0), v1 (1,1,0), v2 (0,0,-1), v3 (1,1,-1).
    // Strip v0 v1 v2 v3: triangles (v0,v1,v2) and (v1,v3,v2); fan v0 v1 v3 v2: (v1,v3,v0) and
    // (v3,v2,v0). All four have cross(b-a, c-a) along (-1, 1, 0).
    unsigned char bin[116] = {0};
    const float pos[4][3] = {{0, 0, 0}, {1, 1, 0}, {0, 0, -1}, {1, 1, -1}};
    const float h = 0.70710678f;
    const float nrm[4][3] = {{-h, h, 0}, {-h, h, 0}, {-h, h, 0}, {-h, h, 0}};
    const unsigned char uv[16] = {0, 0, 0, 0, 255, 0, 0, 0, 0, 255, 0, 0, 255, 255, 0, 0};
    const unsigned char fan[4] = {0, 1, 3, 2};
    memcpy(bin, pos, 48);
    memcpy(bin + 48, nrm, 48);
    memcpy(bin + 96, uv, 16); // unsigned byte VEC2, normalized, byteStride 4
    memcpy(bin + 112, fan, 4);
    parts p = {
        .scenes = "[{\"nodes\":[0,1]}]",
        // node 1: mirrored and stretched, x' = 5 - 3x. Its plane's normal, by the inverse
        // transpose diag(-1/3, 1, 1), is along (1, 3, 0): still with positive y.
        .nodes = "[{\"mesh\":0},{\"mesh\":0,\"translation\":[5,0,0],\"scale\":[-3,1,1]}]",
        .meshes = "[{\"primitives\":["
                  "{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TEXCOORD_0\":2},\"mode\":5},"
                  "{\"attributes\":{\"POSITION\":0},\"indices\":3,\"mode\":6,\"material\":0}]}]",
        .accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"},"
                     "{\"bufferView\":1,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"},"
                     "{\"bufferView\":2,\"componentType\":5121,\"normalized\":true,\"count\":4,"
                     "\"type\":\"VEC2\"},"
                     "{\"bufferView\":3,\"componentType\":5121,\"count\":4,\"type\":\"SCALAR\"}]",
        .views = "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":48},"
                 "{\"buffer\":0,\"byteOffset\":48,\"byteLength\":48},"
                 "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":16,\"byteStride\":4},"
                 "{\"buffer\":0,\"byteOffset\":112,\"byteLength\":4}]",
        .extra = "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.25,1,1]}}],",
        .bin = bin,
        .bin_len = sizeof bin};
    unsigned char *glb;
    size_t n = make_glb(&p, &glb);
    const char *path = pn_test_tmp("quads.GLB"); // extension matched case-insensitively
    write_bytes(path, glb, n);
    pn_scene s;
    if (load_ok(path, &s) == PN_OK) {
        CHECK(pn_scene_triangle_count(&s) == 8);
        CHECK(s.draw_count == 4);
        check_normals_match_winding(&s);
        int down = 0;
        for (uint32_t t = 0; t < 8; t++) {
            double fn[3];
            CHECK(tri_normal(&s, t, fn));
            down += !(fn[1] > 0.1);
        }
        CHECK_MSG(down == 0, "%d triangles lost their orientation", down);
        // node 0 spans x [0,1]; node 1 maps x to 5 - 3x: [2, 5]
        const float emin[3] = {0, 0, -1}, emax[3] = {5, 1, 0};
        check_bounds(&s, emin, emax);
        // material 0 from the file, then the default for the strip that has none
        CHECK(s.material_count == 2);
        if (s.material_count == 2) {
            CHECK(s.materials[0].base_color[0] == 0.5f && s.materials[0].base_color[1] == 0.25f);
            CHECK(s.materials[0].texture == -1);
            CHECK(s.materials[1].base_color[0] == 1.0f && s.materials[1].base_color[1] == 1.0f);
        }
        for (uint32_t d = 0; d < s.draw_count; d++) {
            CHECK(s.draws[d].index_count == 6);
            CHECK(s.draws[d].material == (d % 2 == 0 ? 1u : 0u));
        }
        // TEXCOORD_0 of v3 (1,1,-1) in the first draw: normalized (255, 255) = (1, 1)
        int found = 0;
        for (uint32_t k = 0; k < s.draws[0].index_count; k++) {
            const pn_vertex *v = &s.vertices[s.indices[s.draws[0].first_index + k]];
            if (v->pos[0] == 1 && v->pos[1] == 1 && v->pos[2] == -1) {
                found = 1;
                CHECK(v->uv[0] == 1.0f && v->uv[1] == 1.0f);
            }
            if (v->pos[0] == 1 && v->pos[1] == 1 && v->pos[2] == 0)
                CHECK(v->uv[0] == 1.0f && v->uv[1] == 0.0f);
        }
        CHECK(found);
        pn_scene_destroy(&s);
    }

    // Broken containers: truncated, empty, not a GLB.
    write_bytes(pn_test_tmp("truncated.glb"), glb, n / 2);
    CHECK(pn_gltf_load(pn_test_tmp("truncated.glb"), &s) == PN_ERR_FORMAT);
    check_zeroed(&s);
    write_bytes(pn_test_tmp("empty.glb"), "", 0);
    CHECK(pn_gltf_load(pn_test_tmp("empty.glb"), &s) == PN_ERR_FORMAT);
    check_zeroed(&s);
    put_u32(glb + 12, 0xfffffff0u); // JSON chunk length far past the end
    write_bytes(pn_test_tmp("badchunk.glb"), glb, n);
    CHECK(pn_gltf_load(pn_test_tmp("badchunk.glb"), &s) == PN_ERR_FORMAT);
    check_zeroed(&s);
    write_bytes(pn_test_tmp("text.glb"), "this is not a glTF binary at all", 32);
    CHECK(pn_gltf_load(pn_test_tmp("text.glb"), &s) == PN_ERR_FORMAT);
    check_zeroed(&s);
    free(glb);
}

// ---------------------------------------------------------------------------------------------
// Materials and textures

// 2x1 8-bit RGB PNG: red, green.
#define PNG_RGB                                                                                    \
    "iVBORw0KGgoAAAANSUhEUgAAAAIAAAABCAIAAAB7QOjdAAAAD0lEQVR4nGP4z8DA8J8BAAf/Af8Bf4mnAAAAAElFTkSuQmCC"
// 1x1 16-bit grey PNG: 0xAB12.
#define PNG_GREY16                                                                                 \
    "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABEAAAAABq7kcWAAAAC0lEQVR4nGNYLQQAAWsAvvVud+QAAAAASUVORK5CYII="

static void test_textures(void)
{
    unsigned char bin[CUBE_BIN_LEN];
    cube_bin(bin);
    parts p = {
        .meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,"
                  "\"material\":0}]}]",
        .extra = "\"materials\":["
                 "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,0.5,0.5,1],"
                 "\"baseColorTexture\":{\"index\":0}}},"
                 "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":1}}},"
                 "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":2,\"texCoord\":1}}},"
                 "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":3}}}],"
                 "\"textures\":[{\"source\":0},{\"source\":1},{\"source\":2},{\"source\":0}],"
                 "\"images\":[{\"uri\":\"data:image/png;base64," PNG_RGB "\"},"
                 "{\"uri\":\"data:image/png;base64,AAAAAAAAAAAAAAAA\"},"
                 "{\"uri\":\"data:image/png;base64," PNG_GREY16 "\"}],",
        .bin = bin,
        .bin_len = sizeof bin};
    pn_scene s;
    if (load_ok(write_gltf("textured.gltf", &p), &s) != PN_OK)
        return;
    CHECK(s.material_count == 4); // every material is kept; none is missing, so no default
    CHECK(s.texture_count == 2);  // image 0 (shared by textures 0 and 3) and image 2
    if (s.material_count == 4 && s.texture_count == 2) {
        CHECK(s.materials[0].base_color[1] == 0.5f);
        CHECK(s.materials[0].texture == 0);
        CHECK(s.materials[1].texture == -1); // undecodable image: warned, untextured
        CHECK(s.materials[2].texture == 1);
        CHECK(s.materials[3].texture == 0);
        const pn_texture *t = &s.textures[0];
        CHECK(t->width == 2 && t->height == 1);
        static const uint8_t rg[8] = {255, 0, 0, 255, 0, 255, 0, 255};
        CHECK(t->rgba && memcmp(t->rgba, rg, 8) == 0);
        t = &s.textures[1];
        CHECK(t->width == 1 && t->height == 1);
        CHECK(t->rgba && t->rgba[0] == 0xAB && t->rgba[1] == 0xAB && t->rgba[2] == 0xAB &&
              t->rgba[3] == 255);
    }
    CHECK(s.draw_count == 1 && s.draws[0].material == 0);
    pn_scene_destroy(&s);
}

// ---------------------------------------------------------------------------------------------
// 3. Camera

static void test_camera(void)
{
    unsigned char bin[CUBE_BIN_LEN];
    cube_bin(bin);
    parts p = {
        .scenes = "[{\"nodes\":[0,1,2]}]",
        // node 1: an orthographic camera, ignored with a warning; node 3: the perspective one,
        // at (1,2,3) under a parent at (0,10,0), turned 90 degrees about +Y.
        .nodes = "[{\"mesh\":0},{\"camera\":0},{\"translation\":[0,10,0],\"children\":[3]},"
                 "{\"camera\":1,\"translation\":[1,2,3],\"rotation\":[0," Q45 ",0," Q45 "]}]",
        .extra = "\"cameras\":[{\"type\":\"orthographic\",\"orthographic\":"
                 "{\"xmag\":1,\"ymag\":1,\"znear\":0.1,\"zfar\":100}},"
                 "{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"znear\":0.1}}],",
        .bin = bin,
        .bin_len = sizeof bin};
    pn_scene s;
    if (load_ok(write_gltf("camera.gltf", &p), &s) != PN_OK)
        return;
    CHECK(s.has_camera);
    // position (0,10,0) + (1,2,3). The view direction -Z under 90 degrees about +Y, which maps
    // (x,y,z) to (z,y,-x), is (-1,0,0), so the target is one unit along -X. Up stays +Y.
    const float pos[3] = {1, 12, 3}, target[3] = {0, 12, 3}, up[3] = {0, 1, 0};
    for (int i = 0; i < 3; i++) {
        CHECK_MSG(fabsf(s.camera.pos[i] - pos[i]) < 1e-5f, "camera.pos[%d] = %g", i,
                  s.camera.pos[i]);
        CHECK_MSG(fabsf(s.camera.target[i] - target[i]) < 1e-5f, "camera.target[%d] = %g", i,
                  s.camera.target[i]);
        CHECK_MSG(fabsf(s.camera.up[i] - up[i]) < 1e-5f, "camera.up[%d] = %g", i, s.camera.up[i]);
    }
    CHECK_MSG(fabsf(s.camera.yfov_deg - 45.836624f) < 1e-3f, "yfov_deg = %g", s.camera.yfov_deg);
    pn_scene_destroy(&s);
}

// KHR_lights_punctual as exporters write it: a directional light (node 1, turned to shine down,
// colour and an angular_diameter in extras), a point light (node 2, under a parent at (1,0,0)), a
// spot (node 3, shining down, its cones), a point with a radius (node 10: a sphere), the point and the
// sphere with a range; then lights that must be skipped with a warning: an unknown type, a negative
// radius, a diameter that is not a number, an index past the list, a node whose scale is 0 (no
// direction) and a negative range. The file lists the extension as required: it is read, not
// refused. The lights come out as the kinds of scene/light.h with colour x intensity; render draws
// the scene with them (one V per light in the EXR).
static void test_punctual(void)
{
    unsigned char bin[CUBE_BIN_LEN];
    cube_bin(bin);
    parts p = {
        .scenes = "[{\"nodes\":[0,1,8,3,4,5,6,7,10,11]}]",
        .nodes = "[{\"mesh\":0},"
                 "{\"rotation\":[-" Q45 ",0,0," Q45 "],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
                 "{\"translation\":[0,2,3],\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}},"
                 "{\"translation\":[0,5,0],\"rotation\":[-" Q45 ",0,0," Q45 "],"
                 "\"extensions\":{\"KHR_lights_punctual\":{\"light\":2}}},"
                 "{\"extensions\":{\"KHR_lights_punctual\":{\"light\":3}}},"
                 "{\"extensions\":{\"KHR_lights_punctual\":{\"light\":4}}},"
                 "{\"extensions\":{\"KHR_lights_punctual\":{\"light\":5}}},"
                 "{\"children\":[9],\"extensions\":{\"KHR_lights_punctual\":{\"light\":9}}},"
                 "{\"translation\":[1,0,0],\"children\":[2]},"
                 "{\"scale\":[0,0,0],\"extensions\":{\"KHR_lights_punctual\":{\"light\":2}}},"
                 "{\"translation\":[0,3,0],\"extensions\":{\"KHR_lights_punctual\":{\"light\":6}}},"
                 "{\"extensions\":{\"KHR_lights_punctual\":{\"light\":7}}}]",
        .extra = "\"extensionsUsed\":[\"KHR_lights_punctual\"],\"extensionsRequired\":[\"KHR_lights_punctual\"],"
                 "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":["
                 "{\"type\":\"directional\",\"color\":[1,0.5,0.25],\"intensity\":4,\"extras\":{\"angular_diameter\":2}},"
                 "{\"type\":\"point\",\"intensity\":20,\"name\":\"bulb\",\"range\":8},"
                 "{\"type\":\"spot\",\"intensity\":50,\"spot\":{\"innerConeAngle\":0.2,\"outerConeAngle\":0.6}},"
                 "{\"type\":\"area\",\"intensity\":1},"
                 "{\"type\":\"point\",\"intensity\":1,\"extras\":{\"radius\":-1}},"
                 "{\"type\":\"directional\",\"intensity\":1,\"extras\":{\"angular_diameter\":\"wide\"}},"
                 "{\"type\":\"point\",\"intensity\":10,\"range\":12,\"extras\":{\"radius\":0.5}},"
                 "{\"type\":\"point\",\"intensity\":1,\"range\":-2}]}},",
        .bin = bin,
        .bin_len = sizeof bin};
    pn_scene s;
    const char *path = write_gltf("punctual.gltf", &p);
    if (load_ok(path, &s) != PN_OK)
        return;
    CHECK_MSG(s.light_count == 4, "%u lights, expected 4", s.light_count);
    if (s.light_count == 4) {
        // A point with a radius: a sphere of the same intensity, I = pi r^2 L.
        const pn_light *ball = &s.lights[3];
        CHECK(ball->kind == PN_LIGHT_SPHERE && ball->radius == 0.5f && ball->pos[1] == 3.0f && ball->range == 12.0f);
        CHECK_MSG(fabsf(ball->radiance[0] - (float)(10 / (3.14159265358979 * 0.25))) < 1e-5f, "sphere radiance %g",
                  ball->radiance[0]);
        const pn_light *sun = &s.lights[0], *pt = &s.lights[1], *spot = &s.lights[2];
        CHECK(sun->kind == PN_LIGHT_SUN && pt->kind == PN_LIGHT_OMNI && spot->kind == PN_LIGHT_OMNI);
        CHECK_MSG(fabsf(sun->normal[1] + 1) < 1e-6f && fabsf(sun->normal[0]) < 1e-6f && fabsf(sun->normal[2]) < 1e-6f,
                  "sun shines along (%g %g %g)", sun->normal[0], sun->normal[1], sun->normal[2]);
        CHECK(sun->radiance[0] == 4.0f && sun->radiance[1] == 2.0f && sun->radiance[2] == 1.0f);
        CHECK_MSG(fabsf(sun->angle - 2.0f * 3.14159265f / 180) < 1e-7f, "sun diameter %g rad", sun->angle);
        CHECK(pt->pos[0] == 1.0f && pt->pos[1] == 2.0f && pt->pos[2] == 3.0f && pt->radiance[1] == 20.0f);
        CHECK(pt->cone[1] == 0.0f && pt->size[0] == 0.0f && pt->range == 8.0f && spot->range == 0.0f && sun->range == 0.0f);
        CHECK(spot->pos[1] == 5.0f && fabsf(spot->normal[1] + 1) < 1e-6f && spot->radiance[2] == 50.0f);
        CHECK(spot->cone[0] == 0.2f && spot->cone[1] == 0.6f);
    }
    pn_scene_destroy(&s);
    // The scene renders with them: one V per light.
    char args[1024];
    const char *exr = pn_test_tmp("punctual.exr");
    snprintf(args, sizeof args, "render %s --size 64x48 --spp 4 -o %s >/dev/null 2>&1", path, exr);
    CHECK_MSG(pn_test_run(args) == 0, "render %s failed", path);
    pn_exr_image img;
    if (pn_exr_read(exr, &img) == PN_OK) {
        CHECK(pn_exr_image_channel(&img, "shadow.V.0") && pn_exr_image_channel(&img, "shadow.V.3") &&
              !pn_exr_image_channel(&img, "shadow.V.4"));
        pn_exr_image_free(&img);
    } else
        CHECK_MSG(false, "cannot read %s", exr);
}

// Area lights from node extras (engine/apps/README.md, scene/gltf.cpp): node 1 a light at (0,10,0) facing down
// (-90 degrees about +X maps (x,y,z) to (x,z,-y): -Z goes to -Y and +Y to -Z), 2 x 1
// scaled by (1.5, 2, 1); node 2 a point light with one radiance number, under a parent moved to
// (5,0,0); nodes 3-5 malformed (size of one number, negative radiance, width 0 with height 1):
// ignored with a warning each.
static void test_lights(void)
{
    unsigned char bin[CUBE_BIN_LEN];
    cube_bin(bin);
    parts p = {
        .scenes = "[{\"nodes\":[0,1,6,3,4,5]}]",
        .nodes = "[{\"mesh\":0},"
                 "{\"translation\":[0,10,0],\"rotation\":[-" Q45 ",0,0," Q45 "],\"scale\":[1.5,2,1],"
                 "\"extras\":{\"penumbra_light\":{\"size\":[2,1],\"radiance\":[3,4,5]}}},"
                 "{\"translation\":[0,1,0],\"extras\":{\"penumbra_light\":{\"size\":[0,0],\"radiance\":7}}},"
                 "{\"extras\":{\"penumbra_light\":{\"size\":2,\"radiance\":1}}},"
                 "{\"extras\":{\"penumbra_light\":{\"size\":[1,1],\"radiance\":[1,-1,1]}}},"
                 "{\"extras\":{\"penumbra_light\":{\"size\":[0,1],\"radiance\":1}}},"
                 "{\"translation\":[5,0,0],\"children\":[2]}]",
        .bin = bin,
        .bin_len = sizeof bin};
    pn_scene s;
    if (load_ok(write_gltf("lights.gltf", &p), &s) != PN_OK)
        return;
    CHECK_MSG(s.light_count == 2, "%u lights, expected 2", s.light_count);
    if (s.light_count == 2) {
        const pn_light *a = &s.lights[0], *b = &s.lights[1];
        const float pos[3] = {0, 10, 0}, nrm[3] = {0, -1, 0}, up[3] = {0, 0, -1}, rad[3] = {3, 4, 5};
        for (int i = 0; i < 3; i++) {
            CHECK_MSG(fabsf(a->pos[i] - pos[i]) < 1e-5f, "light 0 pos[%d] = %g", i, a->pos[i]);
            CHECK_MSG(fabsf(a->normal[i] - nrm[i]) < 1e-5f, "light 0 normal[%d] = %g", i, a->normal[i]);
            CHECK_MSG(fabsf(a->up[i] - up[i]) < 1e-5f, "light 0 up[%d] = %g", i, a->up[i]);
            CHECK(a->radiance[i] == rad[i] && b->radiance[i] == 7.0f);
        }
        CHECK_MSG(fabsf(a->size[0] - 3.0f) < 1e-5f && fabsf(a->size[1] - 2.0f) < 1e-5f, "light 0 size %g x %g",
                  a->size[0], a->size[1]);
        CHECK_MSG(b->pos[0] == 5.0f && b->pos[1] == 1.0f && b->pos[2] == 0.0f && b->normal[2] == -1.0f,
                  "light 1 at (%g, %g, %g) facing (%g, %g, %g)", b->pos[0], b->pos[1], b->pos[2], b->normal[0],
                  b->normal[1], b->normal[2]);
        CHECK(b->size[0] == 0 && b->size[1] == 0);
    }
    pn_scene_destroy(&s);
}

// ---------------------------------------------------------------------------------------------
// 4. Bad inputs: each fails with the right code, logs, leaves *out zeroed, and does not crash

static void expect_fail(const char *what, const char *path, pn_result want)
{
    pn_scene s;
    memset(&s, 0xAB, sizeof s); // garbage in: the loader must zero it
    fprintf(stderr, "-- expecting failure: %s\n", what);
    pn_result r = pn_gltf_load(path, &s);
    CHECK_MSG(r == want, "%s: got %s, expected %s", what, pn_result_str(r), pn_result_str(want));
    check_zeroed(&s);
    if (r == PN_OK)
        pn_scene_destroy(&s);
}

static void expect_fail_parts(const char *what, const char *file, const parts *p, pn_result want)
{
    expect_fail(what, write_gltf(file, p), want);
}

static void test_bad_inputs(void)
{
    unsigned char bin[CUBE_BIN_LEN];
    cube_bin(bin);
    parts good = {.bin = bin, .bin_len = sizeof bin};

    expect_fail("missing file", pn_test_tmp("does-not-exist.gltf"), PN_ERR_IO);
    mkdir(pn_test_tmp("a-directory.gltf"), 0755);
    expect_fail("directory", pn_test_tmp("a-directory.gltf"), PN_ERR_IO);

    const char *json = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"mesh\":0}";
    write_bytes(pn_test_tmp("malformed.gltf"), json, strlen(json));
    expect_fail("malformed JSON", pn_test_tmp("malformed.gltf"), PN_ERR_FORMAT);
    write_bytes(pn_test_tmp("empty.gltf"), "", 0);
    expect_fail("empty .gltf", pn_test_tmp("empty.gltf"), PN_ERR_FORMAT);

    const char *obj = write_gltf("cube.obj", &good); // valid glTF content, wrong extension
    expect_fail(".obj extension", obj, PN_ERR_FORMAT);

    unsigned char b2[CUBE_BIN_LEN];
    memcpy(b2, bin, sizeof b2);
    uint16_t big = 8; // one past the last of 8 vertices
    memcpy(b2 + 96 + 2 * 5, &big, 2);
    parts p = good;
    p.bin = b2;
    expect_fail_parts("index out of range", "bad_index.gltf", &p, PN_ERR_FORMAT);

    memcpy(b2, bin, sizeof b2);
    float nan = NAN;
    memcpy(b2 + 4 * 4, &nan, 4); // vertex 1, y
    expect_fail_parts("NaN position", "nan.gltf", &p, PN_ERR_FORMAT);

    memcpy(b2, bin, sizeof b2);
    float inf = INFINITY;
    memcpy(b2 + 4 * 6, &inf, 4); // vertex 2, x
    expect_fail_parts("infinite position", "inf.gltf", &p, PN_ERR_FORMAT);

    // finite in the file, infinite after a huge scale
    p = good;
    p.nodes = "[{\"mesh\":0,\"scale\":[1e39,1,1]}]";
    expect_fail_parts("position overflows after transform", "overflow.gltf", &p, PN_ERR_FORMAT);

    p = good;
    p.meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"mode\":0}]}]";
    expect_fail_parts("only POINTS (no triangles)", "points.gltf", &p, PN_ERR_FORMAT);
    p.meshes = "[{\"primitives\":[{\"attributes\":{\"NORMAL\":0},\"indices\":1}]}]";
    expect_fail_parts("no POSITION (no triangles)", "nopos.gltf", &p, PN_ERR_FORMAT);
    p.meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":9}]}]";
    expect_fail_parts("invalid mode", "mode9.gltf", &p, PN_ERR_FORMAT);

    p = good;
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":9,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]";
    expect_fail_parts("accessor count exceeds its bufferView", "count9.gltf", &p, PN_ERR_FORMAT);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":4294967296,"
                  "\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]";
    expect_fail_parts("accessor count 2^32", "count2e32.gltf", &p, PN_ERR_FORMAT);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5123,\"count\":18446744073709551615,"
                  "\"type\":\"SCALAR\"}]";
    expect_fail_parts("index count 2^64-1", "count2e64.gltf", &p, PN_ERR_FORMAT);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\","
                  "\"byteOffset\":18446744073709551612},"
                  "{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]";
    expect_fail_parts("byteOffset near 2^64", "offset2e64.gltf", &p, PN_ERR_FORMAT);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5123,\"count\":8,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]";
    expect_fail_parts("POSITION of unsigned short", "posu16.gltf", &p, PN_ERR_FORMAT);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":18,\"type\":\"SCALAR\"}]";
    expect_fail_parts("float indices", "idxf32.gltf", &p, PN_ERR_FORMAT);
    p.accessors = "[{\"bufferView\":7,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]";
    expect_fail_parts("bufferView index out of range", "view7.gltf", &p, PN_ERR_FORMAT);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\","
                  "\"sparse\":{\"count\":1,\"indices\":{\"bufferView\":1,\"componentType\":5123},"
                  "\"values\":{\"bufferView\":0,\"byteOffset\":1000}}},"
                  "{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]";
    expect_fail_parts("sparse values outside their view", "sparse_bad.gltf", &p, PN_ERR_FORMAT);

    p = good;
    p.views = "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":96},"
              "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":720}]";
    expect_fail_parts("bufferView exceeds its buffer", "view_long.gltf", &p, PN_ERR_FORMAT);
    p.views = "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":96,\"byteStride\":252},"
              "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":72}]";
    expect_fail_parts("byteStride makes the accessor overrun", "stride.gltf", &p, PN_ERR_FORMAT);
    p.views = "[{\"buffer\":3,\"byteOffset\":0,\"byteLength\":96},"
              "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":72}]";
    expect_fail_parts("buffer index out of range", "buffer3.gltf", &p, PN_ERR_FORMAT);

    p = good;
    p.nodes = "[{\"children\":[1]},{\"mesh\":0,\"children\":[0]}]";
    expect_fail_parts("cycle in the node graph", "cycle.gltf", &p, PN_ERR_FORMAT);
    p.nodes = "[{\"mesh\":0,\"children\":[0]}]";
    expect_fail_parts("node is its own child", "selfchild.gltf", &p, PN_ERR_FORMAT);
    p.scenes = "";
    p.nodes = "[{\"children\":[1]},{\"mesh\":0,\"children\":[0]}]";
    expect_fail_parts("cycle and no scenes", "cycle_noscene.gltf", &p, PN_ERR_FORMAT);
    p.scenes = "[{\"nodes\":[0]}]";
    p.nodes = "[{\"children\":[1,1]},{\"mesh\":0}]";
    expect_fail_parts("node with two parents", "shared.gltf", &p, PN_ERR_FORMAT);
    p.nodes = "[{\"mesh\":0,\"children\":[5]}]";
    expect_fail_parts("child index out of range", "child5.gltf", &p, PN_ERR_FORMAT);
    p.nodes = "[{\"mesh\":3}]";
    expect_fail_parts("mesh index out of range", "mesh3.gltf", &p, PN_ERR_FORMAT);
    p.nodes = "[{\"mesh\":0,\"matrix\":[1,0,0]}]";
    expect_fail_parts("matrix of 3 numbers", "matrix3.gltf", &p, PN_ERR_FORMAT);
    p.scenes = "[{\"nodes\":[4]}]";
    p.nodes = "[{\"mesh\":0}]";
    expect_fail_parts("scene root out of range", "root4.gltf", &p, PN_ERR_FORMAT);

    // A chain of 5000 nodes: rejected as absurdly deep, without recursing 5000 levels.
    {
        size_t cap = 5000 * 32 + 64, len = 0;
        char *nodes = malloc(cap);
        len += (size_t)snprintf(nodes + len, cap - len, "[");
        for (int i = 0; i < 5000; i++)
            len += (size_t)(i < 4999 ? snprintf(nodes + len, cap - len, "{\"children\":[%d]},", i + 1)
                                     : snprintf(nodes + len, cap - len, "{\"mesh\":0}]"));
        p = good;
        p.nodes = nodes;
        expect_fail_parts("5000-deep node chain", "deep.gltf", &p, PN_ERR_FORMAT);
        free(nodes);
    }

    // External buffer that does not exist.
    const char *ext = "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],"
                      "\"nodes\":[{\"mesh\":0}],\"meshes\":" CUBE_MESHES ",\"accessors\":"
                      CUBE_ACCESSORS ",\"bufferViews\":" CUBE_VIEWS ","
                      "\"buffers\":[{\"byteLength\":168,\"uri\":\"missing-buffer.bin\"}]}";
    write_bytes(pn_test_tmp("extbuf.gltf"), ext, strlen(ext));
    pn_scene s;
    memset(&s, 0, sizeof s);
    pn_result r = pn_gltf_load(pn_test_tmp("extbuf.gltf"), &s);
    CHECK_MSG(r == PN_ERR_IO, "missing external buffer: %s", pn_result_str(r));
    check_zeroed(&s);
}

// ---------------------------------------------------------------------------------------------
// Tolerated oddities: zero-length and NaN normals, degenerate triangles

static void test_bad_normals(void)
{
    // One triangle with a good normal, a zero normal and a NaN normal; plus a zero-area triangle
    // without normals.
    unsigned char bin[72 + 12 * 3 + 36] = {0};
    const float pos[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}; // CCW seen from +Z
    const float nrm[3][3] = {{0, 0, 1}, {0, 0, 0}, {NAN, 0, 0}};
    const float flat[3][3] = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}; // collinear: zero area
    memcpy(bin, pos, 36);
    memcpy(bin + 36, nrm, 36);
    memcpy(bin + 72, flat, 36);
    parts p = {
        .meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1}},"
                  "{\"attributes\":{\"POSITION\":2}}]}]",
        .accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                     "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                     "{\"bufferView\":2,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}]",
        .views = "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},"
                 "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36},"
                 "{\"buffer\":0,\"byteOffset\":72,\"byteLength\":36}]",
        .bin = bin,
        .bin_len = 108};
    pn_scene s;
    if (load_ok(write_gltf("bad_normals.gltf", &p), &s) != PN_OK)
        return;
    CHECK(pn_scene_triangle_count(&s) == 2);
    // the broken normals take the face normal, +Z
    for (uint32_t k = 0; k < 3; k++) {
        const float *n = s.vertices[s.indices[k]].normal;
        CHECK_MSG(fabsf(n[2] - 1.0f) < 1e-6f, "normal %u = (%g %g %g)", k, n[0], n[1], n[2]);
    }
    pn_scene_destroy(&s);
}

// ---------------------------------------------------------------------------------------------
// 5. The real meshes

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

static void test_assets(void)
{
    const char *dir = pn_test_env("PN_ASSETS", "");
    struct stat st;
    if (!*dir || stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
        fprintf(stderr, "note: PN_ASSETS (%s) is not a folder; skipping the real meshes\n",
                *dir ? dir : "unset");
        return;
    }
    char manifest[1024];
    snprintf(manifest, sizeof manifest, "%s/MANIFEST.md", dir);
    FILE *f = fopen(manifest, "r");
    CHECK_MSG(f != NULL, "cannot open %s", manifest);
    if (!f)
        return;
    // Table rows: "| name.glb | 69,451 | ... |"
    char line[4096];
    int loaded = 0;
    while (fgets(line, sizeof line, f)) {
        char name[256], count[64];
        if (sscanf(line, "| %255[^ |] | %63[^|]|", name, count) != 2)
            continue;
        size_t nl = strlen(name);
        if (nl < 4 || strcmp(name + nl - 4, ".glb") != 0)
            continue;
        unsigned long want = 0;
        for (const char *c = count; *c; c++)
            if (*c >= '0' && *c <= '9')
                want = want * 10 + (unsigned long)(*c - '0');
        char path[1400];
        snprintf(path, sizeof path, "%s/%s", dir, name);
        pn_scene s;
        double t0 = now_ms();
        pn_result r = pn_gltf_load(path, &s);
        double ms = now_ms() - t0;
        CHECK_MSG(r == PN_OK, "%s: %s", name, pn_result_str(r));
        if (r != PN_OK)
            continue;
        loaded++;
        fprintf(stderr, "%-34s %8u triangles %8u vertices %8.1f ms\n", name,
                pn_scene_triangle_count(&s), s.vertex_count, ms);
        CHECK_MSG(pn_scene_triangle_count(&s) == want, "%s: %u triangles, MANIFEST.md says %lu",
                  name, pn_scene_triangle_count(&s), want);
        for (int i = 0; i < 3; i++)
            CHECK_MSG(isfinite(s.bounds_min[i]) && isfinite(s.bounds_max[i]) &&
                          s.bounds_min[i] <= s.bounds_max[i],
                      "%s: bounds not finite", name);
        check_unit_normals(&s, name);
        uint64_t drawn = 0;
        for (uint32_t d = 0; d < s.draw_count; d++) {
            drawn += s.draws[d].index_count;
            CHECK(s.draws[d].material < s.material_count);
            CHECK((uint64_t)s.draws[d].first_index + s.draws[d].index_count <= s.index_count);
        }
        CHECK(drawn == s.index_count);
        pn_scene_destroy(&s);
    }
    fclose(f);
    CHECK_MSG(loaded > 0, "no .glb rows found in %s", manifest);
}

int main(void)
{
    test_cube_transforms();
    test_glb();
    test_textures();
    test_camera();
    test_lights();
    test_punctual();
    test_bad_normals();
    test_bad_inputs();
    test_assets();
    return pn_test_result();
}
