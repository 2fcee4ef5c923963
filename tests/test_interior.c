// pn_interior_find (scene/interior.h): the default view from inside a scene that encloses its centre.
// Oracles: boxes built here, whose free distances, floor, ceiling and light irradiance are closed
// forms (a ray's exit from a box; the form factor of a parallel square), near the origin and far from
// it; a solid box and the default scene, which are not interiors; and the real scenes of
// ../shared/assets: Sponza, Sibenik and the conference room open from inside, the Stanford meshes not,
// and render's set-up takes the interior's camera and light.
#include <math.h>
#include <string.h>

#include "apps/render_opts.h"
#include "scene/interior.h"
#include "scene/view.h"
#include "test_util.h"

#define PI 3.14159265358979323846

// Appends the rectangle {x0..x1} x {z0..z1} at height y, or a wall, as two triangles facing `n`.
static void add_quad(pn_scene *s, const float p[4][3], const float n[3])
{
    pn_vertex v[4];
    for (int i = 0; i < 4; i++) {
        memcpy(v[i].pos, p[i], sizeof v[i].pos);
        memcpy(v[i].normal, n, sizeof v[i].normal);
        v[i].uv[0] = v[i].uv[1] = 0;
    }
    // Wound counter-clockwise seen from the side n points to.
    float e1[3], e2[3], c[3];
    for (int k = 0; k < 3; k++)
        e1[k] = p[1][k] - p[0][k], e2[k] = p[2][k] - p[0][k];
    c[0] = e1[1] * e2[2] - e1[2] * e2[1], c[1] = e1[2] * e2[0] - e1[0] * e2[2], c[2] = e1[0] * e2[1] - e1[1] * e2[0];
    uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    if (c[0] * n[0] + c[1] * n[1] + c[2] * n[2] < 0)
        idx[1] = 2, idx[2] = 1, idx[4] = 3, idx[5] = 2;
    CHECK(pn_scene_add_mesh(s, v, 4, idx, 6, 0) == PN_OK);
}

// An axis-aligned box room lo..hi whose faces look inwards (inward = true) or outwards (a solid
// box). With a hole, the ceiling has an opening over the centre, that fraction of its sides.
static void make_box(pn_scene *s, const double lo[3], const double hi[3], bool inward, double hole)
{
    memset(s, 0, sizeof *s);
    snprintf(s->name, sizeof s->name, "box");
    uint32_t m;
    CHECK(pn_scene_add_material(s, (float[4]){1, 1, 1, 1}, &m) == PN_OK);
    float sg = inward ? 1.0f : -1.0f;
    for (int axis = 0; axis < 3; axis++)
        for (int side = 0; side < 2; side++) {
            int u = (axis + 1) % 3, w = (axis + 2) % 3;
            float n[3] = {0, 0, 0};
            n[axis] = (side ? -1.0f : 1.0f) * sg; // the low face looks up its axis when inward
            double a = side ? hi[axis] : lo[axis];
            if (axis == 1 && side == 1 && hole > 0) { // the ceiling, around a central opening
                double cu = 0.5 * (lo[u] + hi[u]), cw = 0.5 * (lo[w] + hi[w]);
                double hu = 0.5 * hole * (hi[u] - lo[u]), hw = 0.5 * hole * (hi[w] - lo[w]);
                const double ru[4][2] = {{lo[u], cu - hu}, {cu + hu, hi[u]}, {cu - hu, cu + hu}, {cu - hu, cu + hu}};
                const double rw[4][2] = {{lo[w], hi[w]}, {lo[w], hi[w]}, {lo[w], cw - hw}, {cw + hw, hi[w]}};
                for (int r = 0; r < 4; r++) {
                    float p[4][3];
                    const double uu[4] = {ru[r][0], ru[r][1], ru[r][1], ru[r][0]}, ww[4] = {rw[r][0], rw[r][0], rw[r][1], rw[r][1]};
                    for (int i = 0; i < 4; i++)
                        p[i][axis] = (float)a, p[i][u] = (float)uu[i], p[i][w] = (float)ww[i];
                    add_quad(s, p, n);
                }
                continue;
            }
            float p[4][3];
            const double uu[4] = {lo[u], hi[u], hi[u], lo[u]}, ww[4] = {lo[w], lo[w], hi[w], hi[w]};
            for (int i = 0; i < 4; i++)
                p[i][axis] = (float)a, p[i][u] = (float)uu[i], p[i][w] = (float)ww[i];
            add_quad(s, p, n);
        }
    pn_scene_update_bounds(s);
}

// Where a level ray from e along (dx, 0, dz) leaves the box lo..hi: the closed form the engine's
// ray casts must reproduce.
static double exit_distance(const double e[3], double dx, double dz, const double lo[3], const double hi[3])
{
    double t = INFINITY;
    if (dx > 1e-12)
        t = fmin(t, (hi[0] - e[0]) / dx);
    if (dx < -1e-12)
        t = fmin(t, (lo[0] - e[0]) / dx);
    if (dz > 1e-12)
        t = fmin(t, (hi[2] - e[2]) / dz);
    if (dz < -1e-12)
        t = fmin(t, (lo[2] - e[2]) / dz);
    return t;
}

// Irradiance per unit radiance at the centre below a square of side a at height h facing it:
// four corner rectangles, each pi times the form factor 1/(2 pi) [X/sqrt(1+X^2) atan(Y/sqrt(1+X^2))
// + Y/sqrt(1+Y^2) atan(X/sqrt(1+Y^2))] with X = Y = a / (2 h).
static double square_irradiance(double a, double h)
{
    double x = a / (2 * h), q = sqrt(1 + x * x);
    return 4 * PI * (2 * x / q * atan(x / q)) / (2 * PI);
}

static void check_box_room(const double offset[3])
{
    const double size[3] = {8, 3, 5};
    double lo[3], hi[3];
    for (int k = 0; k < 3; k++)
        lo[k] = offset[k] - 0.5 * size[k], hi[k] = offset[k] + 0.5 * size[k];
    // Float positions: every expected value holds to a few ulps at the box's magnitude.
    double mag = fabs(offset[0]) + fabs(offset[1]) + fabs(offset[2]) + 8;
    double tol = 8 * mag * 1.1920929e-7 + 1e-5;
    pn_scene s;
    make_box(&s, lo, hi, true, 0);
    pn_interior in;
    pn_interior_find(&s, 50.0f, &in);
    CHECK_MSG(in.is_interior && in.enclosed == 1.0f && in.walled == 1.0f, "box room at %g: interior %d, enclosed %.2f",
              offset[0], in.is_interior, (double)in.enclosed);
    if (!in.is_interior) {
        pn_scene_destroy(&s);
        return;
    }
    CHECK(fabs(in.floor_y - lo[1]) <= tol && fabs(in.ceiling_y - hi[1]) <= tol && !in.open_above);
    const pn_camera *cam = &in.camera;
    double eye_y = lo[1] + PN_INTERIOR_EYE * size[1];
    CHECK_MSG(fabs(cam->pos[1] - eye_y) <= tol && fabs(cam->target[1] - eye_y) <= tol, "eye at %g, expected %g",
              (double)cam->pos[1], eye_y);
    CHECK(cam->yfov_deg == 50.0f && cam->up[1] == 1.0f);
    // The view: the longest of the 32 level directions from above the centre.
    double e[3] = {offset[0], eye_y, offset[2]}, longest = 0;
    for (int i = 0; i < 32; i++) {
        double a = 2 * PI * i / 32;
        longest = fmax(longest, exit_distance(e, cos(a), sin(a), lo, hi));
    }
    double fx = cam->target[0] - cam->pos[0], fz = cam->target[2] - cam->pos[2], fl = hypot(fx, fz);
    fx /= fl, fz /= fl;
    double ahead = exit_distance(e, fx, fz, lo, hi), back = 0.5 * exit_distance(e, -fx, -fz, lo, hi);
    // The direction is that of float positions: off by their spacing over the distance between them.
    CHECK_MSG(fabs(ahead - longest) <= 1e-4 * longest + 2 * tol, "looks along %g of free space, the longest is %g", ahead, longest);
    CHECK_MSG(fabs(cam->pos[0] - (e[0] - back * fx)) <= tol && fabs(cam->pos[2] - (e[2] - back * fz)) <= tol,
              "stands at (%g, %g), expected half way back (%g, %g)", (double)cam->pos[0], (double)cam->pos[2],
              e[0] - back * fx, e[2] - back * fz);
    // The light: under the ceiling over the middle of the view, facing down, radiance for pi below.
    const pn_light *l = &in.light;
    double mid = 0.5 * (ahead + back);
    double mx = cam->pos[0] + mid * fx, mz = cam->pos[2] + mid * fz;
    CHECK_MSG(fabs(l->pos[0] - mx) <= tol && fabs(l->pos[2] - mz) <= tol && fabs(l->pos[1] - (hi[1] - 0.05 * size[1])) <= tol,
              "light at (%g %g %g)", (double)l->pos[0], (double)l->pos[1], (double)l->pos[2]);
    CHECK(l->normal[0] == 0 && l->normal[1] == -1 && l->normal[2] == 0);
    CHECK(fabs(l->size[0] - 0.25 * size[1]) <= tol && l->size[0] == l->size[1]);
    // The engine integrates over the light's float corners, each within an ulp of the magnitude.
    double e_floor = l->radiance[0] * square_irradiance(l->size[0], l->pos[1] - lo[1]);
    CHECK_MSG(fabs(e_floor - PI) <= (1e-4 + 4 * mag * 1.1920929e-7 / l->size[0]) * PI, "irradiance below the light %g, expected pi", e_floor);
    pn_scene_destroy(&s);

    // The same box seen from outside (a solid block): its inside faces away, not a room.
    make_box(&s, lo, hi, false, 0);
    pn_interior_find(&s, 50.0f, &in);
    CHECK_MSG(!in.is_interior && in.enclosed == 0.0f, "solid box: interior %d, enclosed %.2f", in.is_interior,
              (double)in.enclosed);
    pn_scene_destroy(&s);
}

// A taller room whose ceiling is a rim round an opening (an atrium, 60% of each side): the light
// goes above the bounds, over the centre, aimed at the floor in the middle of the view.
static void check_atrium(void)
{
    const double lo[3] = {-4, 0, -2.5}, hi[3] = {4, 6, 2.5};
    pn_scene s;
    make_box(&s, lo, hi, true, 0.6);
    pn_interior in;
    pn_interior_find(&s, 45.0f, &in);
    CHECK_MSG(in.is_interior && in.open_above, "atrium: interior %d open %d enclosed %.2f", in.is_interior, in.open_above,
              (double)in.enclosed);
    if (in.is_interior) {
        const pn_light *l = &in.light;
        CHECK(l->pos[1] > hi[1] && fabsf(l->pos[0]) < 1e-5f && fabsf(l->pos[2]) < 1e-5f);
        // Its normal points at the floor below the middle of the view.
        const pn_camera *cam = &in.camera;
        double fx = cam->target[0] - cam->pos[0], fz = cam->target[2] - cam->pos[2];
        double to[3] = {cam->target[0] - l->pos[0], lo[1] - l->pos[1], cam->target[2] - l->pos[2]};
        double tl = sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
        double cosang = (to[0] * l->normal[0] + to[1] * l->normal[1] + to[2] * l->normal[2]) / tl;
        CHECK_MSG(cosang > 0.99999 && hypot(fx, fz) > 0, "atrium light aims %g off the view's middle", acos(cosang));
        // The floor below the light has irradiance pi (the engine's own formula, the normalisation).
        double p[3] = {l->pos[0], lo[1], l->pos[2]}, n[3] = {0, 1, 0};
        CHECK(fabs(l->radiance[0] * pn_light_irradiance(l, p, n) - PI) <= 1e-4 * PI);
    }
    pn_scene_destroy(&s);
}

static void check_asset(const char *asset, bool interior)
{
    char path[1024];
    pn_test_scene(path, sizeof path, asset);
    if (strcmp(path, "builtin:default") == 0) {
        printf("%s: not in the assets; skipped\n", asset);
        return;
    }
    pn_scene s;
    if (pn_scene_load(path, &s) != PN_OK) {
        CHECK_MSG(false, "cannot load %s", path);
        return;
    }
    pn_interior in;
    pn_interior_find(&s, 45.0f, &in);
    printf("%s: enclosed %.2f, walled %.2f: %s\n", asset, (double)in.enclosed, (double)in.walled,
           in.is_interior ? "interior" : "exterior");
    CHECK_MSG(in.is_interior == interior, "%s: interior %d, expected %d", asset, in.is_interior, interior);
    if (in.is_interior) {
        const float *lo = s.bounds_min, *hi = s.bounds_max;
        for (int k = 0; k < 3; k++) {
            CHECK_MSG(in.camera.pos[k] > lo[k] && in.camera.pos[k] < hi[k], "%s: camera outside the bounds", asset);
            CHECK(in.light.pos[k] == in.light.pos[k]);
        }
        CHECK(in.floor_y < in.camera.pos[1] && in.camera.pos[1] < in.ceiling_y);
        // render's set-up takes the interior's camera and its light when the file has neither.
        pn_render_opts o = pn_render_opts_default();
        pn_camera cam;
        pn_light lights[PN_MAX_LIGHTS];
        uint32_t count = 0;
        CHECK(pn_render_setup_view(&o, &s, &cam, lights, &count));
        CHECK(count == 1 && memcmp(&cam, &in.camera, sizeof cam) == 0);
        CHECK(memcmp(lights[0].pos, in.light.pos, sizeof lights[0].pos) == 0);
    }
    pn_scene_destroy(&s);
}

int main(void)
{
    check_box_room((double[3]){0, 0, 0});
    check_box_room((double[3]){3e4, -1e4, 2e4});
    check_atrium();

    pn_scene s;
    CHECK(pn_scene_load("builtin:default", &s) == PN_OK);
    pn_interior in;
    pn_interior_find(&s, 45.0f, &in);
    CHECK_MSG(!in.is_interior && in.walled < PN_INTERIOR_ENCLOSED, "builtin:default: interior %d walled %.2f",
              in.is_interior, (double)in.walled);
    pn_scene_destroy(&s);

    check_asset("dabrovic-sponza-66k.glb", true);
    check_asset("sibenik-76k.glb", true);
    check_asset("conference-69k.glb", true);
    check_asset("stanford-bunny-69k.glb", false);
    check_asset("happy-buddha-100k-decimated.glb", false);
    check_asset("lowpoly-jungle-18k.glb", false);
    return pn_test_result();
}
