// The public C API (engine/api/penumbra.h) through libpenumbra.so, against independent answers:
//  - render's own V for its pixels' P and N (render --aovs --filter none), bit for bit, in exact and
//    (where the device has it) rayquery, with the scene's default light and with two --light groups;
//  - a closed form: a square occluder between a point and a parallel rectangular light, where the
//    stratified sampler's error is bounded by the grid cells the shadow's edges cross;
//  - itself, where the answer must not change: objects moved away and back, a mask cut out
//    everywhere or nowhere, lights beyond one frame's PN_MAX_LIGHTS against each light alone;
//  - bad input of every kind: a status and a message, no crash (ASan and UBSan builds run it too).
// Linked against the shared library alone for the API; the engine's EXR reader reads render's file.
#include <float.h>

#include "api/penumbra.h"
#include "io/exr.h"
#include "test_util.h"

static penumbra_context *g_ctx;

#define OK(call) CHECK_MSG((call) == PENUMBRA_OK, "%s", penumbra_context_error(g_ctx))

// Render's V for its pixels against the API's for the same P and N, `width` to a row.
static void against_render(const char *mode, const char *light_args, const penumbra_light *lights, uint32_t nlights)
{
    const char *exr = pn_test_tmp("api_render.exr");
    char args[2048];
    snprintf(args, sizeof args,
             "render builtin:default --no-ground --size 48x32 --filter none --spp 16 --seed 5 --mode %s --aovs %s -o "
             "\"%s\" >/dev/null",
             mode, light_args, exr);
    int rc = pn_test_run(args);
    if (rc != 0) {
        CHECK_MSG(rc == 0, "render --mode %s failed (%d)", mode, rc);
        return;
    }
    pn_exr_image img;
    if (pn_exr_read(exr, &img) != PN_OK) {
        CHECK_MSG(false, "cannot read %s", exr);
        return;
    }
    size_t px = (size_t)img.width * img.height;
    float *p = malloc(px * 3 * sizeof *p), *n = malloc(px * 3 * sizeof *n), *v = malloc(px * nlights * sizeof *v);
    const char *pc[3] = {"P.X", "P.Y", "P.Z"}, *nc[3] = {"N.X", "N.Y", "N.Z"};
    const float *a = pn_exr_image_channel(&img, "A");
    for (int k = 0; k < 3; k++) {
        const float *cp = pn_exr_image_channel(&img, pc[k]), *cn = pn_exr_image_channel(&img, nc[k]);
        for (size_t i = 0; i < px; i++) {
            p[3 * i + k] = cp[i];
            // Background pixels have no normal; any does, their V is not compared.
            n[3 * i + k] = a[i] > 0 ? cn[i] : (k == 1 ? 1.0f : 0.0f);
        }
    }
    penumbra_scene *scene = NULL;
    OK(penumbra_scene_load(g_ctx, "builtin:default", &scene));
    penumbra_visibility_desc d = {.mode = mode, .spp = 16, .seed = 5, .width = (uint32_t)img.width};
    OK(penumbra_visibility(g_ctx, scene, &d, lights, nlights, p, n, px, v));
    for (uint32_t l = 0; l < nlights; l++) {
        char name[32];
        snprintf(name, sizeof name, nlights > 1 ? "shadow.V.%u" : "shadow.V", l); // render_output.c's names
        const float *rv = pn_exr_image_channel(&img, name);
        if (!rv) {
            CHECK_MSG(rv, "%s: no layer for light %u", exr, l);
            continue;
        }
        // Where no ray of a pixel carries light (render's shadow.valid 0: below its horizon or
        // behind the light), render writes the convention 1 and the library 0 (penumbra.h); with
        // several lights render writes no shadow.valid, and such a pixel is one where render's 1
        // is the library's 0.
        const float *valid = nlights == 1 ? pn_exr_image_channel(&img, "shadow.valid") : NULL;
        CHECK_MSG(nlights > 1 || valid, "%s: no shadow.valid layer", exr);
        size_t differ = 0, geometry = 0, partial = 0, unreached = 0;
        for (size_t i = 0; i < px; i++) {
            if (!(a[i] > 0))
                continue;
            geometry++;
            partial += rv[i] > 0 && rv[i] < 1;
            float mine = v[l * px + i];
            if (valid ? valid[i] == 0 : (rv[i] == 1.0f && mine == 0.0f)) {
                unreached++;
                differ += mine != 0.0f || rv[i] != 1.0f;
                continue;
            }
            differ += memcmp(&rv[i], &mine, sizeof(float)) != 0;
        }
        fprintf(stderr, "mode %s, light %u: %zu of %zu pixels differ from render (%zu in penumbra, %zu unreached)\n",
                mode, l, differ, geometry, partial, unreached);
        CHECK(geometry > 100 && partial > 10); // a picture with shadows and penumbrae to compare
        CHECK_MSG(differ == 0, "mode %s light %u: V differs from render's at %zu pixels", mode, l, differ);
    }
    penumbra_scene_destroy(scene);
    pn_exr_image_free(&img);
    free(p), free(n), free(v);
}

// Points no sample of the light reaches, against the geometry alone (penumbra.h: V is the fraction
// of the samples above the point's horizon that reach it unblocked, 0 where none is): a rectangle
// 0.5 across at y = 2 facing down, nothing in between. V = 0 for a point facing away from it (its
// whole rectangle below the horizon), for one above it (behind a one-sided light), for one whose
// tangent plane lies above the light; V = 1 for a point facing it, and for one whose horizon cuts
// the light in half (the half above is the whole of "those above", all unblocked); the same from
// a sphere wholly below the horizon (0) and a sun shining from below it (0). In exact and the
// tree modes (rayquery and rtpipeline share the shader code that decides it: counts_v).
static void check_unreached(void)
{
    float far_pos[12] = {50, 0, 50, 51, 0, 50, 51, 0, 51, 50, 0, 51}; // a caster far from everything
    uint32_t far_idx[6] = {0, 1, 2, 0, 2, 3};
    penumbra_scene *s = NULL;
    OK(penumbra_scene_create(g_ctx, &(penumbra_mesh_desc){.positions = far_pos, .vertex_count = 4, .indices = far_idx,
                                                          .index_count = 6},
                             1, &s));
    if (!s)
        return;
    penumbra_light rect = {.kind = PENUMBRA_LIGHT_RECT, .position = {0, 2, 0}, .normal = {0, -1, 0}, .up = {0, 0, 1},
                           .size = {0.5f, 0.5f}};
    penumbra_light sphere = {.kind = PENUMBRA_LIGHT_SPHERE, .position = {0, 2, 0}, .radius = 0.25f};
    penumbra_light sun = {.kind = PENUMBRA_LIGHT_SUN, .normal = {0, 1, 0}, .angle = 0.05f}; // travels up
    enum { N = 6 };
    const float pts[N][3] = {{3, 0, 0}, {0, 4, 0}, {3, 2.5f, 0}, {0.3f, 0, 0.1f}, {0, 1, 0}, {1, 0, 1}};
    const float nrm[N][3] = {{0, -1, 0}, {0, -1, 0}, {0, 1, 0}, {0, 1, 0}, {1, 0, 0}, {0, 1, 0}};
    // rect: away, behind, tangent plane above, facing, halved, facing
    const float want_rect[N] = {0, 0, 0, 1, 1, 1};
    const char *modes[] = {"exact", "linespace", "hybrid", "exact-ls", "ls-plane"};
    for (size_t m = 0; m < sizeof modes / sizeof *modes; m++) {
        penumbra_visibility_desc d = {.mode = modes[m], .spp = 64};
        float v[3][N];
        const penumbra_light lights[3] = {rect, sphere, sun};
        OK(penumbra_visibility(g_ctx, s, &d, lights, 3, &pts[0][0], &nrm[0][0], N, &v[0][0]));
        for (int i = 0; i < N; i++) {
            CHECK_MSG(v[0][i] == want_rect[i], "%s: rect light, point %d: V %g, expected %g", modes[m], i,
                      (double)v[0][i], (double)want_rect[i]);
            // The sphere at (0, 2, 0), radius 0.25: wholly below the horizon of points 0 and 2, and
            // above point 1's (whose normal faces down, towards it): 1 there.
            float want_sphere = i == 0 || i == 2 ? 0.0f : 1.0f;
            CHECK_MSG(v[1][i] == want_sphere, "%s: sphere light, point %d: V %g, expected %g", modes[m], i,
                      (double)v[1][i], (double)want_sphere);
            // The sun travels up (+y): it lights points whose normal faces down (0, 1), and point
            // 4, whose horizon (normal +x) halves its cone of directions; the others face up, the
            // sun wholly below their horizon.
            float want_sun = nrm[i][1] < 0 || i == 4 ? 1.0f : 0.0f;
            CHECK_MSG(v[2][i] == want_sun, "%s: sun, point %d: V %g, expected %g", modes[m], i, (double)v[2][i],
                      (double)want_sun);
        }
        fprintf(stderr, "%s: unreached points: rect %g %g %g, sphere %g %g, sun %g %g (all 0); reached: %g %g %g (all 1)\n",
                modes[m], (double)v[0][0], (double)v[0][1], (double)v[0][2], (double)v[1][0], (double)v[1][2],
                (double)v[2][2], (double)v[2][3], (double)v[0][3], (double)v[0][4], (double)v[0][5]);
    }
    penumbra_scene_destroy(s);
}

// The occluder of the closed form: a square of side `side` at height h centred on the y axis,
// facing down (towards the receivers), as one mesh.
static void quad(float side, float h, float pos[12], uint32_t idx[6])
{
    float s = side / 2;
    float q[12] = {-s, h, -s, s, h, -s, s, h, s, -s, h, s};
    uint32_t ix[6] = {0, 1, 2, 0, 2, 3};
    memcpy(pos, q, sizeof q), memcpy(idx, ix, sizeof ix);
}

// Overlap of [a0, a1] and [b0, b1].
static double overlap(double a0, double a1, double b0, double b1)
{
    double lo = a0 > b0 ? a0 : b0, hi = a1 < b1 ? a1 : b1;
    return hi > lo ? hi - lo : 0;
}

int main(void)
{
    CHECK(penumbra_version() == PENUMBRA_VERSION);
    int validation = atoi(pn_test_env("PN_VALIDATION", "0"));
    penumbra_status st = penumbra_context_create(&(penumbra_context_desc){.validation = validation, .log_level = atoi(pn_test_env("PN_API_LOG", "0"))}, &g_ctx);
    if (st != PENUMBRA_OK) {
        fprintf(stderr, "penumbra_context_create: %s\n", penumbra_context_error(g_ctx));
        penumbra_context_destroy(g_ctx);
        return 1;
    }
    fprintf(stderr, "device: %s\n", penumbra_context_device(g_ctx));

    // --- render's V, bit for bit: the scene's default light (from the API), then two lights of
    // other kinds given to both.
    penumbra_scene *def = NULL;
    penumbra_light dl;
    uint32_t count = 0;
    OK(penumbra_scene_load(g_ctx, "builtin:default", &def));
    OK(penumbra_scene_lights(def, &dl, 1, &count));
    CHECK(count == 1 && dl.kind == PENUMBRA_LIGHT_RECT && dl.size[0] > 0);
    penumbra_scene_destroy(def);
    against_render("exact", "", &dl, 1);
    penumbra_light two[2] = {
        {.kind = PENUMBRA_LIGHT_SPHERE, .position = {0.5f, 3, 0.5f}, .radius = 0.4f},
        {.kind = PENUMBRA_LIGHT_DISK, .position = {-1, 3, 1}, .normal = {0, -1, 0}, .up = {0, 0, 1}, .radius = 0.5f},
    };
    against_render("exact", "--light sphere:0.5,3,0.5:0.4:10 --light disk:-1,3,1:0,-1,0:0,0,1:0.5:10", two, 2);
    check_unreached();
    // --- a move costs its rebuild alone: the renderer and its pipelines are kept (compile_ms 0,
    // nothing readied), in every mode that builds structures; V after the move and back is the
    // first call's, bit for bit. The call's time against the build's is printed (the bench's
    // business, not asserted).
    {
        penumbra_scene *s = NULL;
        OK(penumbra_scene_load(g_ctx, "builtin:default", &s));
        float mp[4][3] = {{0, 0, 0}, {0.6f, 0, 0.4f}, {-1.2f, 0, 0.8f}, {2, 0, -2}}, mn[4][3], v0[4], v1[4];
        for (int i = 0; i < 4; i++)
            mn[i][0] = 0, mn[i][1] = 1, mn[i][2] = 0;
        const float moved[12] = {1, 0, 0, 0.3f, 0, 1, 0, 0, 0, 0, 1, 0.2f}, home[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
        const char *modes[] = {"exact", "linespace", "rayquery"};
        for (size_t m = 0; s && m < sizeof modes / sizeof *modes; m++) {
            penumbra_visibility_desc d = {.mode = modes[m], .spp = 64};
            penumbra_times t;
            if (penumbra_visibility(g_ctx, s, &d, &dl, 1, &mp[0][0], &mn[0][0], 4, v0) != PENUMBRA_OK) {
                fprintf(stderr, "move in %s: skipped (%s)\n", modes[m], penumbra_context_error(g_ctx));
                continue;
            }
            OK(penumbra_scene_set_transform(s, 0, moved));
            OK(penumbra_visibility(g_ctx, s, &d, &dl, 1, &mp[0][0], &mn[0][0], 4, v1));
            OK(penumbra_scene_last_times(s, &t));
            fprintf(stderr, "move in %s: build %.2f ms, compile %.2f ms, the call %.2f ms\n", modes[m], t.build_ms,
                    t.compile_ms, t.total_ms);
            CHECK_MSG(t.build_ms > 0 && t.compile_ms == 0, "move in %s: build %g ms, compile %g ms", modes[m],
                      t.build_ms, t.compile_ms);
            CHECK_MSG(memcmp(v0, v1, sizeof v0) != 0, "move in %s: V did not change", modes[m]);
            OK(penumbra_scene_set_transform(s, 0, home));
            OK(penumbra_visibility(g_ctx, s, &d, &dl, 1, &mp[0][0], &mn[0][0], 4, v1));
            OK(penumbra_scene_last_times(s, &t));
            CHECK_MSG(t.compile_ms == 0 && memcmp(v0, v1, sizeof v0) == 0, "moved back in %s: V differs", modes[m]);
        }
        penumbra_scene_destroy(s);
    }
    {
        penumbra_scene *s = NULL;
        OK(penumbra_scene_load(g_ctx, "builtin:plane", &s));
        float pt[3] = {0, 0, 0}, nn[3] = {0, 1, 0}, vv = -1;
        penumbra_status rq = penumbra_visibility(g_ctx, s, &(penumbra_visibility_desc){.mode = "rayquery"}, &dl, 1, pt, nn, 1, &vv);
        penumbra_scene_destroy(s);
        if (rq == PENUMBRA_OK)
            against_render("rayquery", "", &dl, 1);
        else
            fprintf(stderr, "rayquery: %s (%s)\n", penumbra_status_string(rq), penumbra_context_error(g_ctx));
        CHECK(rq == PENUMBRA_OK || rq == PENUMBRA_ERROR_UNSUPPORTED);
    }

    // --- the closed form: occluder side 1 at height 1, light side 1 at height 2, parallel. From a
    // point p on y = 0 the occluder projects onto the light's plane as the square of side 2 centred
    // at -p (x' = p + 2 (x - p)); the light sees V = 1 - overlap area.
    float qpos[12];
    uint32_t qidx[6];
    quad(1, 1, qpos, qidx);
    penumbra_scene *occ = NULL;
    OK(penumbra_scene_create(g_ctx, &(penumbra_mesh_desc){.positions = qpos, .vertex_count = 4, .indices = qidx, .index_count = 6}, 1, &occ));
    penumbra_light rect = {.kind = PENUMBRA_LIGHT_RECT, .position = {0, 2, 0}, .normal = {0, -1, 0}, .up = {0, 0, 1},
                           .size = {1, 1}};
    enum { NP = 9, SPP = 4096, GRID = 64 };
    float pts[NP][3], nrm[NP][3], v[NP], v_again[NP];
    for (int i = 0; i < NP; i++) {
        float x = -1.2f + 0.3f * i;
        pts[i][0] = x, pts[i][1] = 0, pts[i][2] = 0.25f * x;
        nrm[i][0] = 0, nrm[i][1] = 1, nrm[i][2] = 0;
    }
    penumbra_visibility_desc vd = {.spp = SPP, .seed = 3};
    OK(penumbra_visibility(g_ctx, occ, &vd, &rect, 1, &pts[0][0], &nrm[0][0], NP, v));
    for (int i = 0; i < NP; i++) {
        double px = pts[i][0], pz = pts[i][2];
        // The occluder's shadow on the light's plane: [2 (-0.5) - p, 2 (0.5) - p] per axis.
        double blocked = overlap(-1 - px, 1 - px, -0.5, 0.5) * overlap(-1 - pz, 1 - pz, -0.5, 0.5);
        double exact = 1 - blocked;
        // Each sample lies in its own cell of a 64 x 64 grid over the light: only the cells an
        // edge of the blocked rectangle crosses (at most 64 per edge) can disagree with the area.
        double bound = 4.0 * GRID / SPP;
        fprintf(stderr, "closed form: p (%.2f, %.2f): V %.5f, exact %.5f\n", px, pz, (double)v[i], exact);
        CHECK_MSG(fabs(v[i] - exact) <= bound, "point %d: V %g, closed form %g (bound %g)", i, (double)v[i], exact, bound);
        if (exact == 0 || exact == 1)
            CHECK_MSG(v[i] == (float)exact, "point %d: V %g where the closed form is %g exactly", i, (double)v[i], exact);
    }

    // What the calls did: the first built the BVH, a second with other samples reused it.
    penumbra_times times;
    OK(penumbra_scene_last_times(occ, &times));
    CHECK(times.build_ms > 0 && times.total_ms > 0);
    OK(penumbra_visibility(g_ctx, occ, &(penumbra_visibility_desc){.spp = 64, .seed = 4}, &rect, 1, &pts[0][0], &nrm[0][0], NP, v_again));
    OK(penumbra_scene_last_times(occ, &times));
    CHECK_MSG(times.build_ms == 0, "another spp and seed rebuilt the scene's structures");
    CHECK(penumbra_scene_last_times(NULL, &times) == PENUMBRA_ERROR_INVALID_ARGUMENT);
    // Fewer points, then more rows than one: the structures kept (build_ms 0), and a point's V the
    // same as among more points, where it is the same pixel (rows of 1024 by default).
    {
        enum { MANY = 2500 };
        float *mp = malloc(MANY * 3 * sizeof *mp), *mn = malloc(MANY * 3 * sizeof *mn), *mv = malloc(MANY * sizeof *mv);
        for (int i = 0; i < MANY; i++)
            for (int k = 0; k < 3; k++)
                mp[3 * i + k] = pts[i % NP][k], mn[3 * i + k] = nrm[i % NP][k];
        float v5[5];
        OK(penumbra_visibility(g_ctx, occ, &vd, &rect, 1, &pts[0][0], &nrm[0][0], 5, v5));
        OK(penumbra_scene_last_times(occ, &times));
        CHECK(times.build_ms == 0);
        CHECK(memcmp(v5, v, sizeof v5) == 0);
        OK(penumbra_visibility(g_ctx, occ, &vd, &rect, 1, mp, mn, MANY, mv));
        OK(penumbra_scene_last_times(occ, &times));
        CHECK(times.build_ms == 0);
        CHECK(memcmp(mv, v, sizeof v) == 0); // the first row's first points: the same pixels
        free(mp), free(mn), free(mv);
    }

    // --- max_error: --quality auto's pick over the occluder and a ground under it (a view with a
    // shadow to measure). The configuration it reports, given as a plain description, gives the
    // same V bit for bit; a second call keeps the pick (no pilots: build_ms 0 and the same config).
    {
        float ground[12] = {-3, 0, -3, -3, 0, 3, 3, 0, 3, 3, 0, -3};
        penumbra_mesh_desc occ_ground[2] = {
            {.positions = qpos, .vertex_count = 4, .indices = qidx, .index_count = 6},
            {.positions = ground, .vertex_count = 4, .indices = qidx, .index_count = 6},
        };
        penumbra_scene *lit = NULL;
        OK(penumbra_scene_create(g_ctx, occ_ground, 2, &lit));
        penumbra_visibility_desc auto_d = {.max_error = 0.05f, .seed = 3};
        float va[NP], vb[NP];
        OK(penumbra_visibility(g_ctx, lit, &auto_d, &rect, 1, &pts[0][0], &nrm[0][0], NP, va));
        penumbra_visibility_desc used, again;
        OK(penumbra_scene_last_config(lit, &used));
        CHECK(used.mode && used.spp >= 1 && used.max_error == 0.05f && used.seed == 3);
        fprintf(stderr, "max_error 0.05: %s at %u spp, tree %u,%u\n", used.mode ? used.mode : "?", used.spp,
                used.tree_n, used.tree_d);
        OK(penumbra_visibility(g_ctx, lit, &auto_d, &rect, 1, &pts[0][0], &nrm[0][0], NP, vb));
        OK(penumbra_scene_last_config(lit, &again));
        CHECK(again.spp == used.spp && used.mode && again.mode && strcmp(again.mode, used.mode) == 0);
        CHECK(memcmp(va, vb, sizeof va) == 0);
        used.max_error = 0;
        OK(penumbra_visibility(g_ctx, lit, &used, &rect, 1, &pts[0][0], &nrm[0][0], NP, vb));
        CHECK_MSG(memcmp(va, vb, sizeof va) == 0, "the pick given by hand traces other V");
        CHECK(penumbra_visibility(g_ctx, lit, &(penumbra_visibility_desc){.max_error = 2}, &rect, 1, &pts[0][0],
                                  &nrm[0][0], NP, vb) == PENUMBRA_ERROR_INVALID_ARGUMENT);
        CHECK(penumbra_visibility(g_ctx, lit, &(penumbra_visibility_desc){.max_error = 0.05f}, (penumbra_light[2]){rect, rect}, 2, &pts[0][0],
                                  &nrm[0][0], NP, vb) == PENUMBRA_ERROR_INVALID_ARGUMENT);
        CHECK(strstr(penumbra_context_error(g_ctx), "one light"));
        penumbra_scene_destroy(lit);
    }

    // --- moved away, everything is lit; moved back, V is what it was, bit for bit.
    float away[12] = {1, 0, 0, 100, 0, 1, 0, 0, 0, 0, 1, 0}, home[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    OK(penumbra_scene_set_transform(occ, 0, away));
    OK(penumbra_visibility(g_ctx, occ, &vd, &rect, 1, &pts[0][0], &nrm[0][0], NP, v_again));
    for (int i = 0; i < NP; i++)
        CHECK_MSG(v_again[i] == 1.0f, "moved away: point %d V %g", i, (double)v_again[i]);
    OK(penumbra_scene_set_transform(occ, 0, home));
    OK(penumbra_visibility(g_ctx, occ, &vd, &rect, 1, &pts[0][0], &nrm[0][0], NP, v_again));
    CHECK(memcmp(v, v_again, sizeof v) == 0);

    // --- an alpha mask: cut out everywhere, the occluder casts nothing; nowhere, it is opaque.
    float uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    uint8_t clear[4] = {0, 0, 0, 0}, solid[4] = {255, 255, 255, 255};
    for (int m = 0; m < 2; m++) {
        penumbra_scene *masked = NULL;
        penumbra_mesh_desc md = {.positions = qpos, .vertex_count = 4, .indices = qidx, .index_count = 6, .uvs = uv,
                                 .alpha = m ? solid : clear, .alpha_width = 2, .alpha_height = 2, .alpha_cutoff = 0.5f};
        OK(penumbra_scene_create(g_ctx, &md, 1, &masked));
        OK(penumbra_visibility(g_ctx, masked, &vd, &rect, 1, &pts[0][0], &nrm[0][0], NP, v_again));
        for (int i = 0; i < NP; i++)
            CHECK_MSG(m ? v_again[i] == v[i] : v_again[i] == 1.0f, "mask %s: point %d V %g (opaque %g)",
                      m ? "solid" : "clear", i, (double)v_again[i], (double)v[i]);
        penumbra_scene_destroy(masked);
    }

    // --- more lights than one frame takes: each light's V as it is alone.
    enum { NL = 18 };
    penumbra_light many[NL];
    float vm[NL * NP], v1[NP];
    for (int l = 0; l < NL; l++) {
        many[l] = rect;
        many[l].position[0] = -0.9f + 0.1f * l;
        many[l].size[0] = 0.2f + 0.05f * l;
    }
    penumbra_visibility_desc vs = {.spp = 64, .seed = 9};
    OK(penumbra_visibility(g_ctx, occ, &vs, many, NL, &pts[0][0], &nrm[0][0], NP, vm));
    for (int l = 0; l < NL; l++) {
        OK(penumbra_visibility(g_ctx, occ, &vs, &many[l], 1, &pts[0][0], &nrm[0][0], NP, v1));
        CHECK_MSG(memcmp(v1, vm + l * NP, sizeof v1) == 0, "light %d of %d differs from itself alone", l, NL);
    }

    // --- bad input: a status, a message naming the problem, nothing written where it failed.
    float nan_pt[3] = {NAN, 0, 0}, zero_n[3] = {0, 0, 0}, one_n[3] = {0, 1, 0}, vv = 42;
    struct {
        const char *what;
        penumbra_status got, want;
    } bad[] = {
        {"NULL scene", penumbra_visibility(g_ctx, NULL, NULL, &rect, 1, &pts[0][0], &nrm[0][0], 1, &vv)},
        {"NULL points", penumbra_visibility(g_ctx, occ, NULL, &rect, 1, NULL, &nrm[0][0], 1, &vv)},
        {"NaN point", penumbra_visibility(g_ctx, occ, NULL, &rect, 1, nan_pt, one_n, 1, &vv)},
        {"zero normal", penumbra_visibility(g_ctx, occ, NULL, &rect, 1, &pts[0][0], zero_n, 1, &vv)},
        {"no lights", penumbra_visibility(g_ctx, occ, NULL, &rect, 0, &pts[0][0], one_n, 1, &vv)},
        {"bad mode", penumbra_visibility(g_ctx, occ, &(penumbra_visibility_desc){.mode = "magic"}, &rect, 1, &pts[0][0], one_n, 1, &vv)},
        {"bad traversal", penumbra_visibility(g_ctx, occ, &(penumbra_visibility_desc){.traversal = "x"}, &rect, 1, &pts[0][0], one_n, 1, &vv)},
        {"spp too high", penumbra_visibility(g_ctx, occ, &(penumbra_visibility_desc){.spp = 5000}, &rect, 1, &pts[0][0], one_n, 1, &vv)},
        {"bad tree", penumbra_visibility(g_ctx, occ, &(penumbra_visibility_desc){.mode = "linespace", .tree_n = 40}, &rect, 1, &pts[0][0], one_n, 1, &vv)},
        {"row too long", penumbra_visibility(g_ctx, occ, &(penumbra_visibility_desc){.width = 1u << 30}, &rect, 1, &pts[0][0], one_n, 1, &vv)},
        {"bad light kind", penumbra_visibility(g_ctx, occ, NULL, &(penumbra_light){.kind = (penumbra_light_kind)9}, 1, &pts[0][0], one_n, 1, &vv)},
        {"rect without normal", penumbra_visibility(g_ctx, occ, NULL, &(penumbra_light){.size = {1, 1}}, 1, &pts[0][0], one_n, 1, &vv)},
        {"rect of one size 0", penumbra_visibility(g_ctx, occ, NULL, &(penumbra_light){.normal = {0, -1, 0}, .size = {1, 0}}, 1, &pts[0][0], one_n, 1, &vv)},
        {"sphere radius 0", penumbra_visibility(g_ctx, occ, NULL, &(penumbra_light){.kind = PENUMBRA_LIGHT_SPHERE}, 1, &pts[0][0], one_n, 1, &vv)},
        {"NaN light", penumbra_visibility(g_ctx, occ, NULL, &(penumbra_light){.kind = PENUMBRA_LIGHT_POINT, .position = {NAN, 0, 0}}, 1, &pts[0][0], one_n, 1, &vv)},
        {"index out of range", penumbra_scene_create(g_ctx, &(penumbra_mesh_desc){.positions = qpos, .vertex_count = 4, .indices = (uint32_t[3]){0, 1, 7}, .index_count = 3}, 1, &(penumbra_scene *){NULL})},
        {"index count not 3k", penumbra_scene_create(g_ctx, &(penumbra_mesh_desc){.positions = qpos, .vertex_count = 4, .indices = qidx, .index_count = 4}, 1, &(penumbra_scene *){NULL})},
        {"NaN vertex", penumbra_scene_create(g_ctx, &(penumbra_mesh_desc){.positions = (float[9]){0, 0, 0, 1, NAN, 0, 0, 0, 1}, .vertex_count = 3, .indices = qidx, .index_count = 3}, 1, &(penumbra_scene *){NULL})},
        {"no meshes", penumbra_scene_create(g_ctx, &(penumbra_mesh_desc){0}, 0, &(penumbra_scene *){NULL})},
        {"mask without cutoff", penumbra_scene_create(g_ctx, &(penumbra_mesh_desc){.positions = qpos, .vertex_count = 4, .indices = qidx, .index_count = 6, .uvs = uv, .alpha = solid, .alpha_width = 2, .alpha_height = 2}, 1, &(penumbra_scene *){NULL})},
        {"missing file", penumbra_scene_load(g_ctx, "missing.gltf", &(penumbra_scene *){NULL}), PENUMBRA_ERROR_IO},
        {"unknown builtin", penumbra_scene_load(g_ctx, "builtin:nosuch", &(penumbra_scene *){NULL})},
        {"no object 5", penumbra_scene_set_transform(occ, 5, home)},
        {"singular transform", penumbra_scene_set_transform(occ, 0, (float[12]){0})},
    };
    // The statuses (the messages, one call at a time, below).
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        penumbra_status want = bad[i].want ? bad[i].want : PENUMBRA_ERROR_INVALID_ARGUMENT;
        CHECK_MSG(bad[i].got == want, "%s: status %s, expected %s", bad[i].what, penumbra_status_string(bad[i].got),
                  penumbra_status_string(want));
    }
    CHECK(vv == 42); // no call above wrote V
    // Messages, one call at a time.
    CHECK(penumbra_visibility(g_ctx, occ, NULL, &rect, 1, nan_pt, one_n, 1, &vv) != PENUMBRA_OK);
    CHECK_MSG(strstr(penumbra_context_error(g_ctx), "point 0"), "%s", penumbra_context_error(g_ctx));
    CHECK(penumbra_scene_load(g_ctx, "missing.gltf", &(penumbra_scene *){NULL}) == PENUMBRA_ERROR_IO);
    CHECK_MSG(strstr(penumbra_context_error(g_ctx), "missing.gltf"), "%s", penumbra_context_error(g_ctx));
    CHECK(penumbra_scene_set_transform(occ, 0, (float[12]){0}) != PENUMBRA_OK);
    CHECK_MSG(strstr(penumbra_context_error(g_ctx), "singular"), "%s", penumbra_context_error(g_ctx));
    // A success leaves the last error as it was.
    OK(penumbra_visibility(g_ctx, occ, &vd, &rect, 1, &pts[0][0], &nrm[0][0], NP, v_again));
    CHECK(strstr(penumbra_context_error(g_ctx), "singular"));
    CHECK(memcmp(v, v_again, sizeof v) == 0); // and the failures changed nothing
    // NULL handles and a context that failed.
    CHECK(penumbra_visibility(NULL, occ, NULL, &rect, 1, &pts[0][0], one_n, 1, &vv) == PENUMBRA_ERROR_INVALID_ARGUMENT);
    CHECK(penumbra_scene_get_info(NULL, NULL) == PENUMBRA_ERROR_INVALID_ARGUMENT);
    CHECK(penumbra_context_create(NULL, NULL) == PENUMBRA_ERROR_INVALID_ARGUMENT);
    CHECK(strlen(penumbra_context_error(NULL)) > 0);
    penumbra_scene_destroy(NULL);
    penumbra_context_destroy(NULL);
    penumbra_context *failed = NULL;
    CHECK(penumbra_context_create(&(penumbra_context_desc){.device = "no such device"}, &failed) == PENUMBRA_ERROR_VULKAN);
    CHECK(failed && strstr(penumbra_context_error(failed), "no such device"));
    fprintf(stderr, "failed context: %s\n", penumbra_context_error(failed));
    CHECK(penumbra_scene_load(failed, "builtin:plane", &(penumbra_scene *){NULL}) == PENUMBRA_ERROR_INVALID_ARGUMENT);
    penumbra_context_destroy(failed);
    penumbra_scene_info info;
    OK(penumbra_scene_get_info(occ, &info));
    CHECK(info.triangle_count == 2 && info.object_count == 1 && info.bounds_min[1] == 1.0f);

    // A context destroyed before its scene (a garbage collector's order): calls on it fail, the
    // scene's destroy frees both (ASan: no use after free, no leak).
    penumbra_context *early = NULL;
    penumbra_scene *orphan = NULL;
    if (penumbra_context_create(NULL, &early) == PENUMBRA_OK &&
        penumbra_scene_load(early, "builtin:plane", &orphan) == PENUMBRA_OK) {
        float one = 0;
        CHECK(penumbra_visibility(early, orphan, NULL, &rect, 1, &pts[0][0], &nrm[0][0], 1, &one) == PENUMBRA_OK);
        penumbra_context_destroy(early);
        CHECK(penumbra_visibility(early, orphan, NULL, &rect, 1, &pts[0][0], &nrm[0][0], 1, &one) ==
              PENUMBRA_ERROR_INVALID_ARGUMENT);
        CHECK(strstr(penumbra_context_error(early), "destroyed"));
        penumbra_scene_destroy(orphan);
    } else {
        CHECK_MSG(false, "a second context: %s", penumbra_context_error(early));
        penumbra_context_destroy(early);
    }

    penumbra_scene_destroy(occ);
    uint32_t messages = penumbra_context_validation_messages(g_ctx);
    CHECK_MSG(messages == 0, "the validation layer reported %u message(s)", messages);
    penumbra_context_destroy(g_ctx);
    return pn_test_result();
}
