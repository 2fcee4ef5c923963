// Scenes generated in code. "default" is the showcase: every object is there for a shadow feature
// we must get right (see the comments at each add call).
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "scene/scene.h"

#define PN_PI 3.14159265358979323846f

// Builds meshes into fixed scratch arrays, then appends them to the scene as one draw.
typedef struct mesh_builder {
    pn_vertex v[4096];
    uint32_t i[8192];
    uint32_t vn, in;
} mesh_builder;

// Rotation by yaw about +Y, then pitch about the rotated +X: enough for tilted slabs.
typedef struct pose {
    float c[3];
    float yaw_deg, pitch_deg;
} pose;

static void rotate(const pose *p, const float in[3], float out[3])
{
    float cy = cosf(p->yaw_deg * PN_PI / 180), sy = sinf(p->yaw_deg * PN_PI / 180);
    float cp = cosf(p->pitch_deg * PN_PI / 180), sp = sinf(p->pitch_deg * PN_PI / 180);
    // pitch about X
    float x = in[0], y = cp * in[1] - sp * in[2], z = sp * in[1] + cp * in[2];
    // yaw about Y
    out[0] = cy * x + sy * z;
    out[1] = y;
    out[2] = -sy * x + cy * z;
}

static void emit(mesh_builder *b, const pose *p, const float pos[3], const float n[3], float u, float v)
{
    pn_vertex *o = &b->v[b->vn++];
    rotate(p, pos, o->pos);
    for (int k = 0; k < 3; k++)
        o->pos[k] += p->c[k];
    rotate(p, n, o->normal);
    o->uv[0] = u;
    o->uv[1] = v;
}

static void quad(mesh_builder *b, uint32_t a)
{
    const uint32_t q[6] = {a, a + 1, a + 2, a, a + 2, a + 3};
    memcpy(b->i + b->in, q, sizeof q);
    b->in += 6;
}

// Box with half extents h, 24 vertices so that each face has its own normal.
static void add_box(mesh_builder *b, const pose *p, float hx, float hy, float hz)
{
    const float h[3] = {hx, hy, hz};
    for (int axis = 0; axis < 3; axis++)
        for (int sign = -1; sign <= 1; sign += 2) {
            int u = (axis + 1) % 3, v = (axis + 2) % 3;
            float n[3] = {0, 0, 0};
            n[axis] = (float)sign;
            uint32_t base = b->vn;
            const float uv[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
            for (int c = 0; c < 4; c++) {
                float pos[3];
                pos[axis] = sign * h[axis];
                // Counter-clockwise seen from outside: swap the tangent order on the negative side.
                pos[u] = uv[c][0] * h[u] * (float)sign;
                pos[v] = uv[c][1] * h[v];
                emit(b, p, pos, n, 0.5f + 0.5f * uv[c][0], 0.5f + 0.5f * uv[c][1]);
            }
            quad(b, base);
        }
}

static void add_sphere(mesh_builder *b, const pose *p, float r, int slices, int stacks)
{
    uint32_t base = b->vn;
    for (int j = 0; j <= stacks; j++) {
        float t = PN_PI * (float)j / (float)stacks;
        for (int i = 0; i <= slices; i++) {
            float s = 2 * PN_PI * (float)i / (float)slices;
            float n[3] = {sinf(t) * cosf(s), cosf(t), -sinf(t) * sinf(s)};
            float pos[3] = {r * n[0], r * n[1], r * n[2]};
            emit(b, p, pos, n, (float)i / (float)slices, (float)j / (float)stacks);
        }
    }
    for (int j = 0; j < stacks; j++)
        for (int i = 0; i < slices; i++) {
            uint32_t a = base + (uint32_t)(j * (slices + 1) + i), c = a + (uint32_t)slices + 1;
            const uint32_t t[6] = {a, c, a + 1, a + 1, c, c + 1};
            memcpy(b->i + b->in, t, sizeof t);
            b->in += 6;
        }
}

// Upright cylinder centred at the pose, radius r, half height hh, with caps.
static void add_cylinder(mesh_builder *b, const pose *p, float r, float hh, int segments)
{
    for (int i = 0; i < segments; i++) {
        float a0 = 2 * PN_PI * (float)i / (float)segments, a1 = 2 * PN_PI * (float)(i + 1) / (float)segments;
        float n0[3] = {cosf(a0), 0, -sinf(a0)}, n1[3] = {cosf(a1), 0, -sinf(a1)};
        uint32_t base = b->vn;
        emit(b, p, (float[3]){r * n0[0], -hh, r * n0[2]}, n0, 0, 0);
        emit(b, p, (float[3]){r * n1[0], -hh, r * n1[2]}, n1, 1, 0);
        emit(b, p, (float[3]){r * n1[0], hh, r * n1[2]}, n1, 1, 1);
        emit(b, p, (float[3]){r * n0[0], hh, r * n0[2]}, n0, 0, 1);
        quad(b, base);
        for (int cap = -1; cap <= 1; cap += 2) {
            float n[3] = {0, (float)cap, 0};
            uint32_t c = b->vn;
            emit(b, p, (float[3]){0, cap * hh, 0}, n, 0.5f, 0.5f);
            emit(b, p, (float[3]){r * n0[0], cap * hh, r * n0[2]}, n, 0, 0);
            emit(b, p, (float[3]){r * n1[0], cap * hh, r * n1[2]}, n, 1, 0);
            const uint32_t t[3] = {c, cap > 0 ? c + 1 : c + 2, cap > 0 ? c + 2 : c + 1};
            memcpy(b->i + b->in, t, sizeof t);
            b->in += 3;
        }
    }
}

// Appends what the builder holds as one draw of material `mat` and empties it.
static pn_result flush_material(pn_scene *s, mesh_builder *b, uint32_t mat)
{
    pn_result res = pn_scene_add_mesh(s, b->v, b->vn, b->i, b->in, mat);
    b->vn = b->in = 0;
    return res;
}

static pn_result flush(pn_scene *s, mesh_builder *b, float r, float g, float bl)
{
    uint32_t mat;
    pn_result res = pn_scene_add_material(s, (const float[4]){r, g, bl, 1}, &mat);
    if (res == PN_OK)
        return flush_material(s, b, mat);
    b->vn = b->in = 0;
    return res;
}

static pn_result build_default(pn_scene *s)
{
    mesh_builder *b = calloc(1, sizeof *b);
    if (!b)
        return PN_ERR_MEMORY;
    pn_result r = PN_OK;
    // A platform whose top is y = 0: the receiver even with --no-ground.
    add_box(b, &(pose){{0, -0.05f, 0}}, 2.0f, 0.05f, 2.0f);
    r = r ? r : flush(s, b, 0.8f, 0.78f, 0.74f);
    // Contact shadows: a sphere and a rotated cube resting on the platform.
    add_sphere(b, &(pose){{-1.0f, 0.45f, 0.7f}}, 0.45f, 48, 24);
    r = r ? r : flush(s, b, 0.75f, 0.2f, 0.15f);
    add_box(b, &(pose){{1.1f, 0.25f, 1.0f}, 30}, 0.25f, 0.25f, 0.25f);
    r = r ? r : flush(s, b, 0.2f, 0.45f, 0.75f);
    // Thin feature with a long penumbra: a tall pole 6 cm thick.
    add_cylinder(b, &(pose){{0.9f, 0.9f, -0.9f}}, 0.03f, 0.9f, 16);
    r = r ? r : flush(s, b, 0.9f, 0.85f, 0.3f);
    // A table: a high top on four legs, the top's penumbra is wide, the legs' is sharp at the foot.
    add_box(b, &(pose){{0.35f, 1.0f, 0.2f}, 10}, 0.6f, 0.03f, 0.4f);
    for (int i = 0; i < 4; i++) {
        float lx = (i & 1) ? 0.52f : -0.52f, lz = (i & 2) ? 0.32f : -0.32f;
        float c = cosf(10 * PN_PI / 180), sn = sinf(10 * PN_PI / 180);
        add_box(b, &(pose){{0.35f + c * lx + sn * lz, 0.485f, 0.2f - sn * lx + c * lz}, 10}, 0.025f, 0.485f, 0.025f);
    }
    r = r ? r : flush(s, b, 0.55f, 0.38f, 0.22f);
    // Overlapping occluders: two tilted plates at different heights whose shadows overlap.
    add_box(b, &(pose){{-0.8f, 1.5f, -0.7f}, 20, 15}, 0.4f, 0.02f, 0.4f);
    add_box(b, &(pose){{-0.45f, 0.95f, -0.35f}, -25, -10}, 0.35f, 0.02f, 0.3f);
    r = r ? r : flush(s, b, 0.3f, 0.7f, 0.35f);
    // A fence of thin slats: a comb of penumbrae that blur into each other with distance.
    for (int i = 0; i < 9; i++)
        add_box(b, &(pose){{-0.2f + 0.1f * (float)i, 0.35f, 1.6f}}, 0.02f, 0.35f, 0.01f);
    add_box(b, &(pose){{0.2f, 0.72f, 1.6f}}, 0.46f, 0.02f, 0.015f);
    r = r ? r : flush(s, b, 0.85f, 0.85f, 0.85f);
    free(b);
    return r;
}

static pn_result build_plane(pn_scene *s)
{
    mesh_builder *b = calloc(1, sizeof *b);
    if (!b)
        return PN_ERR_MEMORY;
    // One 2x2 quad on y = 0: a box of zero height would duplicate faces, so emit the top only.
    pose p = {{0, 0, 0}};
    const float n[3] = {0, 1, 0};
    emit(b, &p, (float[3]){-1, 0, 1}, n, 0, 0);
    emit(b, &p, (float[3]){1, 0, 1}, n, 1, 0);
    emit(b, &p, (float[3]){1, 0, -1}, n, 1, 1);
    emit(b, &p, (float[3]){-1, 0, -1}, n, 0, 1);
    quad(b, 0);
    pn_result r = flush(s, b, 0.5f, 0.5f, 0.5f);
    free(b);
    return r;
}

// The analytic penumbra: a 4x4 receiver at y = 0 and a 0.5x0.5 occluder at y = 0.5, both squares
// centred on the y axis, facing up. Under a parallel square light the visible fraction at every
// receiver point is a closed-form area overlap (tests/test_linespace_shadow.c).
static pn_result build_penumbra(pn_scene *s)
{
    mesh_builder *b = calloc(1, sizeof *b);
    if (!b)
        return PN_ERR_MEMORY;
    const float n[3] = {0, 1, 0};
    const float size[2] = {2.0f, 0.25f}, height[2] = {0.0f, 0.5f};
    const float grey[2] = {0.5f, 0.8f};
    pn_result r = PN_OK;
    for (int i = 0; i < 2 && r == PN_OK; i++) {
        pose p = {{0, height[i], 0}};
        float h = size[i];
        emit(b, &p, (float[3]){-h, 0, h}, n, 0, 0);
        emit(b, &p, (float[3]){h, 0, h}, n, 1, 0);
        emit(b, &p, (float[3]){h, 0, -h}, n, 1, 1);
        emit(b, &p, (float[3]){-h, 0, -h}, n, 0, 1);
        quad(b, 0);
        r = flush(s, b, grey[i], grey[i], grey[i]);
    }
    free(b);
    return r;
}

// The canopy's leaf texture: CANOPY_TEX_SIZE texels square over one metre of a leaf quad (its uvs
// are metres, the texture repeats), so a texel is 4 mm and a leaf 9-16 cm long, about a real
// vine's. CANOPY_LEAVES lens-shaped leaves of mean area 8ab/3 = 270 texels cover a fraction
// 1 - exp(-160 x 270 / 256^2) = 0.48 of the tile when dropped at random (0.52 of its texels are
// opaque): light gets through half of one layer, and where the quads overlap a quarter or less,
// so that the ground under the canopy is dappled rather than in shade.
enum { CANOPY_TEX_SIZE = 256, CANOPY_LEAVES = 160 };

// xorshift32 (Marsaglia): a fixed seed makes the texture the same bytes on every machine.
static uint32_t canopy_rand(uint32_t *state)
{
    uint32_t x = *state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    return *state = x;
}

// Uniform in [lo, hi): 24 random bits, exact in a float.
static float canopy_uniform(uint32_t *state, float lo, float hi)
{
    return lo + (hi - lo) * (float)(canopy_rand(state) >> 8) * 0x1p-24f;
}

// The leaf texture, RGBA8 sRGB: leaves of random place, direction, size and green, alpha 255 on a
// leaf and 0 between them (the canopy's mask, cutoff 0.5). A leaf is the lens |v| < b (1 - (u/a)^2)
// for |u| < a about its axis, pointed at both ends, with a paler midrib. Leaves wrap across the
// edges so that the repeating tile has no seam. The direction is drawn by rejection and normalised
// with sqrtf, which IEEE rounds correctly everywhere, where another libm's sinf and cosf could round
// differently and move a texel.
static uint8_t *canopy_texture(void)
{
    const int n = CANOPY_TEX_SIZE;
    uint8_t *rgba = calloc((size_t)n * n, 4); // alpha 0: cut out between the leaves
    if (!rgba)
        return NULL;
    uint32_t state = 0x1eafu; // any nonzero seed; this one is the picture in assets/canopy.png
    for (int leaf = 0; leaf < CANOPY_LEAVES; leaf++) {
        float cx = canopy_uniform(&state, 0, (float)n), cy = canopy_uniform(&state, 0, (float)n);
        float dx, dy, d2;
        do {
            dx = canopy_uniform(&state, -1, 1), dy = canopy_uniform(&state, -1, 1);
            d2 = dx * dx + dy * dy;
        } while (d2 > 1 || d2 < 0x1p-8f);
        float len = sqrtf(d2);
        dx /= len, dy /= len;
        float a = canopy_uniform(&state, 12, 20);            // half length, texels
        float b = a * canopy_uniform(&state, 0.35f, 0.45f); // half width at the middle
        uint8_t green = (uint8_t)(110 + canopy_rand(&state) % 60), red = (uint8_t)(40 + canopy_rand(&state) % 40);
        int x0 = (int)floorf(cx - a), x1 = (int)ceilf(cx + a), y0 = (int)floorf(cy - a), y1 = (int)ceilf(cy + a);
        for (int y = y0; y <= y1; y++)
            for (int x = x0; x <= x1; x++) {
                float px = (float)x + 0.5f - cx, py = (float)y + 0.5f - cy;
                float u = px * dx + py * dy, v = -px * dy + py * dx;
                if (fabsf(u) >= a || fabsf(v) >= b * (1 - (u / a) * (u / a)))
                    continue;
                uint8_t *t = &rgba[4 * (((y + n) % n) * n + (x + n) % n)];
                bool rib = fabsf(v) < 0.75f; // a texel and a half wide
                t[0] = rib ? (uint8_t)(red + 50) : red;
                t[1] = rib ? (uint8_t)(green + 50) : green;
                t[2] = rib ? 70 : 30;
                t[3] = 255;
            }
    }
    return rgba;
}

// A pergola under a vine, for alpha-masked shadows: a 6 x 6 m ground at y = 0, four posts 2.38 m
// tall and two beams on them (opaque casters), and seven leaf quads 1-1.8 m wide at 2.5-3.1 m,
// tilted up to 20 degrees and overlapping, cut out by the leaf texture (cutoff 0.5). Under a small
// light above, the ground shows a dappling of leaf shadows and the posts' and beams' solid ones.
static pn_result build_canopy(pn_scene *s)
{
    mesh_builder *b = calloc(1, sizeof *b);
    if (!b)
        return PN_ERR_MEMORY;
    const float up[3] = {0, 1, 0};
    pose flat = {{0, 0, 0}};
    emit(b, &flat, (float[3]){-3, 0, 3}, up, 0, 0);
    emit(b, &flat, (float[3]){3, 0, 3}, up, 1, 0);
    emit(b, &flat, (float[3]){3, 0, -3}, up, 1, 1);
    emit(b, &flat, (float[3]){-3, 0, -3}, up, 0, 1);
    quad(b, 0);
    pn_result r = flush(s, b, 0.6f, 0.55f, 0.45f);
    // Posts 12 cm square on the ground, beams 12 cm deep resting on them (tops at 2.5 m).
    for (int i = 0; i < 4; i++)
        add_box(b, &(pose){{(i & 1) ? 1.4f : -1.4f, 1.19f, (i & 2) ? 0.9f : -0.9f}}, 0.06f, 1.19f, 0.06f);
    for (int i = 0; i < 2; i++)
        add_box(b, &(pose){{0, 2.44f, i ? 0.9f : -0.9f}}, 1.6f, 0.06f, 0.05f);
    r = r ? r : flush(s, b, 0.45f, 0.32f, 0.2f);
    // The leaves: centre, yaw and pitch (degrees), half width and depth (m), uv offset (m) so that
    // no two quads show the same part of the tile at the same place. All clear the beams' tops.
    static const struct {
        float c[3], yaw, pitch, hx, hz, du, dv;
    } leaves[] = {
        {{-0.8f, 2.62f, -0.4f}, 10, 8, 0.8f, 0.6f, 0.00f, 0.00f},
        {{0.5f, 2.70f, -0.5f}, -15, -10, 0.9f, 0.55f, 0.37f, 0.61f},
        {{-0.3f, 2.85f, 0.45f}, 30, 12, 0.85f, 0.6f, 0.73f, 0.19f},
        {{0.9f, 2.58f, 0.5f}, -35, 6, 0.7f, 0.55f, 0.11f, 0.83f},
        {{0.1f, 3.0f, 0.0f}, 55, -14, 0.75f, 0.5f, 0.52f, 0.44f},
        {{-1.2f, 2.75f, 0.6f}, -5, -18, 0.55f, 0.45f, 0.91f, 0.27f},
        {{1.3f, 2.9f, -0.2f}, 20, 20, 0.5f, 0.5f, 0.29f, 0.05f},
    };
    for (size_t i = 0; i < sizeof leaves / sizeof leaves[0]; i++) {
        const pose p = {{leaves[i].c[0], leaves[i].c[1], leaves[i].c[2]}, leaves[i].yaw, leaves[i].pitch};
        float hx = leaves[i].hx, hz = leaves[i].hz, du = leaves[i].du, dv = leaves[i].dv;
        uint32_t base = b->vn;
        emit(b, &p, (float[3]){-hx, 0, hz}, up, du, dv);
        emit(b, &p, (float[3]){hx, 0, hz}, up, du + 2 * hx, dv);
        emit(b, &p, (float[3]){hx, 0, -hz}, up, du + 2 * hx, dv + 2 * hz);
        emit(b, &p, (float[3]){-hx, 0, -hz}, up, du, dv + 2 * hz);
        quad(b, base);
    }
    int32_t tex = -1;
    uint32_t mat = 0;
    if (r == PN_OK) {
        uint8_t *rgba = canopy_texture();
        r = rgba ? pn_scene_add_texture(s, CANOPY_TEX_SIZE, CANOPY_TEX_SIZE, rgba, &tex) : PN_ERR_MEMORY;
    }
    r = r ? r : pn_scene_add_material(s, (const float[4]){1, 1, 1, 1}, &mat);
    if (r == PN_OK) {
        s->materials[mat].texture = tex;
        s->materials[mat].alpha_cutoff = 0.5f; // glTF's default alphaCutoff
        r = flush_material(s, b, mat);
    }
    free(b);
    return r;
}

static const char *const g_names[] = {"default", "plane", "penumbra", "canopy", NULL};

const char *const *pn_builtin_names(void) { return g_names; }

pn_result pn_builtin_load(const char *name, pn_scene *out)
{
    memset(out, 0, sizeof *out);
    snprintf(out->name, sizeof out->name, "builtin:%s", name);
    pn_result r;
    if (strcmp(name, "default") == 0)
        r = build_default(out);
    else if (strcmp(name, "plane") == 0)
        r = build_plane(out);
    else if (strcmp(name, "penumbra") == 0)
        r = build_penumbra(out);
    else if (strcmp(name, "canopy") == 0)
        r = build_canopy(out);
    else {
        pn_error("builtin:%s: no such built-in scene (have: default, plane, penumbra, canopy)", name);
        return PN_ERR_INVALID;
    }
    if (r != PN_OK) {
        pn_error("builtin:%s: %s", name, pn_result_str(r));
        pn_scene_destroy(out);
        return r;
    }
    pn_scene_update_bounds(out);
    return PN_OK;
}
