// The light kinds (scene/light.h) against independent oracles:
//  - pn_light_irradiance: a sun's against a numerical integral of cos(receiver) over its disk of
//    directions (double precision, 400 x 400 polar cells); a spot's falloff against
//    KHR_lights_punctual's reference code (its lightAngleScale and lightAngleOffset).
//  - Rendered (penumbra render, builtin:penumbra: a 4x4 receiver under a 0.5x0.5 occluder at
//    y = 0.5, seen low from the side, exact, unfiltered, with the position and albedo layers):
//    a sun straight down: V across the occluder's edge against the visible part of a disk cut by a
//    chord, V(a) = (acos a - a sqrt(1 - a^2)) / pi with a = (0.25 - x) / (0.5 tan(diameter / 2)),
//    so the penumbra is as wide as the angular diameter makes it; the same render with twice the
//    diameter must not pass (the oracle tells them apart). An omni light and a spot: V exactly 0 or
//    1 on either side of the occluder's projected edge (x = 0.25 h / (h - 0.5)), and the radiance
//    where V = 1 equal to albedo / pi x I cos / r^2 (times the spot's falloff, or the window of
//    KHR_lights_punctual's range), in double here.
//  - A sphere light over the edge: V against the chord of the cap it shows (to O(theta^2)), and its
//    radiance against the closed form; its irradiance against the integral over its cone, the cone
//    above, across and below the horizon (Snyder's form), as a sun's across the horizon.
//  - A disk facing down over the edge: V against the chord of the disk (exact: uniform by area), its
//    radiance against the CPU's polygon; its irradiance against the integral over its area.
//  - Every mode under a sun, a spot, a sphere and a disk (builtin:default): exact-ls V bit for bit.
//  - Each kind at the extremes, in every mode: the same edge and its oracles scaled by 1e-4 and 1e6,
//    and moved by 1e4 and (at scale 1e3) 1e7 from the origin, each mode within its documented
//    bound (check_extremes).
// Over 500 lines because each kind's oracle (an integral, a closed form) is written here, apart
// from the code it checks.
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "gpu/device.h"
#include "interface.h"
#include "io/exr.h"
#include "scene/light.h"
#include "test_util.h"

#define PI 3.14159265358979323846

// The integral of max(n . w, 0) over the directions w within `delta` of the unit `axis`, in double:
// N x N polar cells round the axis, each its exact solid angle times the integrand at its middle.
static double cone_integral(const double axis[3], double delta, const double n[3], int N)
{
    // An orthonormal frame round the axis.
    double t[3] = {axis[1], -axis[0], 0}, tl = sqrt(t[0] * t[0] + t[1] * t[1]);
    if (!(tl > 1e-9))
        t[0] = 1, t[1] = 0, tl = 1;
    t[0] /= tl, t[1] /= tl;
    double b[3] = {axis[1] * t[2] - axis[2] * t[1], axis[2] * t[0] - axis[0] * t[2], axis[0] * t[1] - axis[1] * t[0]};
    double sum = 0;
    for (int i = 0; i < N; i++) {
        double th0 = delta * i / N, th1 = delta * (i + 1) / N, th = 0.5 * (th0 + th1);
        double dw = (cos(th0) - cos(th1)) * 2 * PI / N;
        for (int j = 0; j < N; j++) {
            double ph = 2 * PI * (j + 0.5) / N, w[3];
            for (int c = 0; c < 3; c++)
                w[c] = cos(th) * axis[c] + sin(th) * (cos(ph) * t[c] + sin(ph) * b[c]);
            double c = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
            sum += (c > 0 ? c : 0) * dw;
        }
    }
    return sum;
}

// A sun's irradiance per unit E_perp: the integral over its cone over its projected solid angle
// pi sin^2(diameter / 2), receivers facing it at several angles, all of its disk above the horizon.
static void check_sun_irradiance(void)
{
    pn_light l = {.kind = PN_LIGHT_SUN, .normal = {0.3f, -1.0f, 0.2f}, .angle = (float)(4.0 * PI / 180)};
    double len = sqrt(0.09 + 1 + 0.04), axis[3] = {-0.3 / len, 1 / len, -0.2 / len}; // towards the sun
    double delta = 0.5 * l.angle;
    const double normals[4][3] = {{0, 1, 0}, {0.6, 0.8, 0}, {-0.5, 0.5, 0.7071067811865476}, {0.1, 0.3, -0.9486832980505138}};
    for (int k = 0; k < 4; k++) {
        double expect = cone_integral(axis, delta, normals[k], 400) / (PI * sin(delta) * sin(delta));
        double got = pn_light_irradiance(&l, (double[3]){0, 0, 0}, normals[k]);
        CHECK_MSG(fabs(got - expect) <= 1e-4 * fmax(expect, 1e-3), "sun, normal %d: %.8f, the integral %.8f", k, got,
                  expect);
    }
}

// A sphere of unit radiance: the integral over the cone it subtends against pn_light_irradiance
// (Snyder's closed form) with the cone wholly above the horizon, straddling it and wholly below;
// and a sun straddling the horizon.
static void check_sphere_irradiance(void)
{
    const pn_light sph = {.kind = PN_LIGHT_SPHERE, .pos = {0, 2, 0}, .radius = 0.8f};
    const double axis[3] = {0, 1, 0}, delta = asin(0.8 / 2);
    // Normals at 0, 50, 68 (straddling: 90 - 23.6 < 68 < 90 + 23.6), 100 and 120 degrees from the axis.
    const double angles[5] = {0, 50, 68, 100, 120};
    for (int k = 0; k < 5; k++) {
        double a = angles[k] * PI / 180, n[3] = {sin(a), cos(a), 0};
        double sum = cone_integral(axis, delta, n, 600), got = pn_light_irradiance(&sph, (double[3]){0, 0, 0}, n);
        CHECK_MSG(fabs(got - sum) <= 1e-4 * fmax(sum, 1e-2), "sphere, normal at %g degrees: %.8f, the integral %.8f",
                  angles[k], got, sum);
    }
    // A sun of 4 degrees whose disk the horizon cuts (its centre 1 degree below it): E / E_perp is
    // the part above, over pi sin^2(2 degrees), against the same integral.
    pn_light sun = {.kind = PN_LIGHT_SUN, .normal = {0, -1, 0}, .angle = (float)(4 * PI / 180)};
    double sd = 0.5 * (double)sun.angle, a = 91.0 * PI / 180, n[3] = {sin(a), cos(a), 0};
    double sum = cone_integral(axis, sd, n, 600) / (PI * sin(sd) * sin(sd));
    double got = pn_light_irradiance(&sun, (double[3]){0, 0, 0}, n);
    CHECK_MSG(sum > 0 && fabs(got - sum) <= 1e-3 * sum, "sun across the horizon: %.8f, the integral %.8f", got, sum);
}

// A disk of unit radiance: the integral of cos(receiver) cos(light) / r^2 over its area, the part
// below the receiver's horizon left out, in double (polar cells), against pn_light_irradiance (a
// polygon of PN_LIGHT_DISK_SIDES sides and the same area). Returns the largest relative error.
static double check_disk_irradiance(void)
{
    pn_light disk = {.kind = PN_LIGHT_DISK, .pos = {0, 1, 0}, .normal = {0, -1, 0}, .up = {0, 0, 1}, .radius = 0.5f,
                     .size = {1, 1}};
    // Receivers: under the centre, off to the side, tilted, near the rim's plane, straddling.
    const double pts[5][3] = {{0, 0, 0}, {0.8, 0, 0.3}, {0.2, 0.5, -0.1}, {0.7, 0.95, 0}, {0.1, 0.6, 0}};
    const double nrm[5][3] = {{0, 1, 0}, {0, 1, 0}, {0.6, 0.8, 0}, {-0.6, 0.8, 0}, {1, 0, 0}};
    double worst = 0;
    for (int k = 0; k < 5; k++) {
        const double *p = pts[k], *n = nrm[k];
        double sum = 0;
        const int NR = 800, NP = 800;
        for (int i = 0; i < NR; i++) {
            double r0 = 0.5 * i / NR, r1 = 0.5 * (i + 1) / NR, r = 0.5 * (r0 + r1), dr = r1 - r0;
            for (int j = 0; j < NP; j++) {
                double ph = 2 * PI * (j + 0.5) / NP, q[3] = {r * cos(ph), 1, r * sin(ph)};
                double d[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                double cr = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / sqrt(d2), cl = d[1] / sqrt(d2);
                if (cr > 0 && cl > 0)
                    sum += cr * cl / d2 * r * dr * (2 * PI / NP);
            }
        }
        double got = pn_light_irradiance(&disk, p, n);
        double rel = fabs(got - sum) / sum;
        worst = fmax(worst, rel);
        // The polygon's error falls as the fourth power of its sides' angle: 2.6e-6 measured here.
        CHECK_MSG(rel <= 1e-4, "disk, receiver %d: %.8f, the integral %.8f", k, got, sum);
    }
    printf("disk irradiance: the %d-gon against the integral, largest relative error %.2g\n", PN_LIGHT_DISK_SIDES, worst);
    return worst;
}

// KHR_lights_punctual's reference: lightAngleScale = 1 / max(0.001, cos(inner) - cos(outer)),
// lightAngleOffset = -cos(outer) * scale, attenuation = saturate(cd * scale + offset)^2.
static double khr_spot(double inner, double outer, double cd)
{
    double scale = 1.0 / fmax(0.001, cos(inner) - cos(outer)), offset = -cos(outer) * scale;
    double a = fmin(fmax(cd * scale + offset, 0.0), 1.0);
    return a * a;
}

static void check_spot_falloff(void)
{
    pn_light l = {.kind = PN_LIGHT_OMNI, .normal = {0, -1, 0}, .cone = {0.2f, 0.5f}};
    for (int i = 0; i <= 100; i++) {
        double cd = cos(0.6 * i / 100);
        double expect = khr_spot((double)l.cone[0], (double)l.cone[1], cd);
        CHECK_MSG(fabs(pn_light_spot(&l, cd) - expect) <= 1e-12, "spot at cos %g: %g, the reference %g", cd,
                  pn_light_spot(&l, cd), expect);
    }
    pn_light omni = {.kind = PN_LIGHT_OMNI};
    CHECK(pn_light_spot(&omni, -1.0) == 1.0 && pn_light_spot(&omni, 1.0) == 1.0);
}

typedef struct frame {
    pn_exr_image img;
    const float *r, *v, *px, *py, *pz, *alb;
} frame;

// A pixel that sees the receiver (y = 0), not the occluder above it or the background.
static bool receiver(const frame *f, int i) { return f->alb[i] > 0 && fabsf(f->py[i]) < 1e-3f; }

static bool read_frame(const char *args, const char *exr, frame *f);

// Renders builtin:penumbra with `light`, seen low from +x so that the receiver under the
// occluder's edge x = 0.25 shows; false (reported) on failure.
static bool render(const char *light, const char *name, int spp, frame *f)
{
    const char *exr = pn_test_tmp(name);
    char args[1024];
    snprintf(args, sizeof args,
             "render builtin:penumbra --no-ground --size 300x200 --camera-pos 1.5,0.25,0 --camera-target 0.25,0,0 "
             "--fov 30 --mode exact --spp %d --filter none --aovs --light %s -o %s >/dev/null",
             spp, light, exr);
    return read_frame(args, exr, f);
}

// builtin:default at 160x120, 16 spp, unfiltered, in `mode`.
static bool render_mode(const char *light, const char *mode, const char *name, frame *f)
{
    const char *exr = pn_test_tmp(name);
    char args[1024];
    snprintf(args, sizeof args,
             "render builtin:default --size 160x120 --mode %s --spp 16 --filter none --aovs --light %s -o %s >/dev/null",
             mode, light, exr);
    return read_frame(args, exr, f);
}

static bool read_frame(const char *args, const char *exr, frame *f)
{
    memset(f, 0, sizeof *f);
    if (pn_test_run(args) != 0 || pn_exr_read(exr, &f->img) != PN_OK) {
        CHECK_MSG(false, "%s failed", args);
        return false;
    }
    f->r = pn_exr_image_channel(&f->img, "R");
    f->v = pn_exr_image_channel(&f->img, "shadow.V");
    f->px = pn_exr_image_channel(&f->img, "P.X");
    f->py = pn_exr_image_channel(&f->img, "P.Y");
    f->pz = pn_exr_image_channel(&f->img, "P.Z");
    f->alb = pn_exr_image_channel(&f->img, "albedo.R");
    bool ok = f->r && f->v && f->px && f->py && f->pz && f->alb;
    CHECK(ok);
    return ok;
}

// Mean |V - V(a)| over the receiver pixels within the penumbra of the occluder's edge x = 0.25
// (|z| < 0.15: away from its corners), for a sun of the given diameter straight down.
static double sun_edge_error(const frame *f, double diameter_deg, int *pixels)
{
    double w = 0.5 * tan(0.5 * diameter_deg * PI / 180), sum = 0;
    int n = 0;
    for (int i = 0; i < f->img.width * f->img.height; i++) {
        double x = f->px[i], z = f->pz[i];
        if (fabs(z) >= 0.15 || fabs(x - 0.25) > w || !receiver(f, i))
            continue;
        double a = (0.25 - x) / w;
        double expect = (acos(a) - a * sqrt(1 - a * a)) / PI;
        sum += fabs(f->v[i] - expect);
        n++;
    }
    *pixels = n;
    return n ? sum / n : 1.0;
}

// ---------------------------------------------------------------------------------------------
// Each kind at the extremes of scale and offset: builtin:penumbra's geometry (a 4x4 receiver at
// y = 0, a 0.5x0.5 occluder at y = 0.5) written as a glTF whose node scales it by s and moves it
// by (t, t, t); the light, camera and oracle scaled and moved alike, the oracle read in the local
// frame, x = (P - t) / s. The same closed forms as above: the sun's and the disk's chord (exact),
// the sphere's (to O(theta^2)), the omni light's hard edge; a pixel's side of the omni edge is
// certain 8 ulps of the magnitude (over s) away from it.

static const char *write_penumbra_gltf(const char *name, double s, double t)
{
    // 8 positions (two quads facing +y), then 12 uint16 indices.
    const float pos[8][3] = {{-2, 0, 2}, {2, 0, 2}, {2, 0, -2}, {-2, 0, -2},
                             {-0.25f, 0.5f, 0.25f}, {0.25f, 0.5f, 0.25f}, {0.25f, 0.5f, -0.25f}, {-0.25f, 0.5f, -0.25f}};
    const uint16_t idx[12] = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
    unsigned char bin[96 + 24];
    memcpy(bin, pos, 96);
    memcpy(bin + 96, idx, 24);
    char data[200];
    pn_test_base64(bin, sizeof bin, data);
    const char *path = pn_test_tmp(name);
    FILE *f = fopen(path, "w");
    if (!f)
        return NULL;
    fprintf(f,
            "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
            "\"nodes\":[{\"mesh\":0,\"scale\":[%.17g,%.17g,%.17g],\"translation\":[%.17g,%.17g,%.17g]}],"
            "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\","
            "\"min\":[-2,0,-2],\"max\":[2,0.5,2]},{\"bufferView\":1,\"componentType\":5123,\"count\":12,\"type\":\"SCALAR\"}],"
            "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":96},{\"buffer\":0,\"byteOffset\":96,\"byteLength\":24}],"
            "\"buffers\":[{\"byteLength\":120,\"uri\":\"data:application/octet-stream;base64,%s\"}]}",
            s, s, s, t, t, t, data);
    fclose(f);
    return path;
}

// The visible share of a disk cut by a chord at offset a (in its radius) from its centre, the
// blocked side beyond the chord: 0 at a >= 1, 1 at a <= -1.
static double chord(double a) { return a >= 1 ? 0 : a <= -1 ? 1 : (acos(a) - a * sqrt(1 - a * a)) / PI; }

// The chord offset of kind k (sun 0, sphere 1, disk 2) for ground point (x, z) when the occluder's
// edge is at x = e (local units; the lights as check_extremes places them).
static double edge_offset(int k, double e, double x, double z)
{
    if (k == 0)
        return (e - x) / (0.5 * tan(5 * PI / 180));
    if (k == 1) { // the plane through the ground point and the edge, against the sphere's cone
        double nn[2] = {0.5, -(e - x)}, nl = hypot(nn[0], nn[1]);
        double cc[3] = {0.25 - x, 2.0, -z}, cl = sqrt(cc[0] * cc[0] + cc[1] * cc[1] + cc[2] * cc[2]);
        return -asin((nn[0] * cc[0] + nn[1] * cc[1]) / (nl * cl)) / asin(0.1 / cl);
    }
    return (x + (e - x) * 4 - 0.25) / 0.3; // where the ray over the edge meets the disk's plane
}

// Every mode under each kind, at each extreme. The tree holds the occluder alone (the receiver
// cannot block a ray to a light above it, and is culled), LS(4,2) over its 0.5-wide root (plus 8
// ulps of padding): leaf s = root / 16. What the modes may do here, by the bounds of
// engine/shadow/README.md ("Accuracy at the extremes"): the exact modes nothing; the line-space
// modes also block rays within 2 s (max norm, plus the tree's slack) of the occluder. The occluder
// is 0.5 above the receiver and 1.5 below a sphere or disk (0.22 = (3 + N) s and N s = 0.125 at
// most), so no blocker is lost to linespace's skipped nodes (nor ls-leaf's or ls-plane's); and a
// ray steeper than 45 degrees (every one here) that comes within 2 s of the edge crosses the
// occluder's plane within 2 s (1 + 1) of it: as if the edge were at 0.25 + 4 s. So a mode's V lies
// between the chord with the edge there and at 0.25 (the same value for the exact modes), up to the
// samples' noise and the edge's rounding: the mean distance of V from that range is bounded as
// exact's error was (0.02 at 256 samples, plus the rounding), and an omni light's edge is hard at
// either end of it. The occluder's other edges are 0.19 or more from the rays of the pixels read
// (|z| < 0.1).
// Which of the sweep's renders: every one, the covering design below, or the others alone.
typedef enum sweep_part { SWEEP_ALL, SWEEP_COVERING, SWEEP_REST } sweep_part;

static void check_extremes(sweep_part part)
{
    const double cases[4][2] = {{1e-4, 0}, {1e6, 0}, {1, 1e4}, {1e3, 1e7}};
    // exact walks by projection at 256 spp (auto's choice); the packet walk too, by name.
    const char *modes[] = {"exact",  "exact --traversal packet", "exact-ls", "rayquery", "rtpipeline", "hybrid",
                           "linespace", "ls-leaf", "ls-plane"};
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    bool made = pn_gpu_device_create(&desc, &dev) == PN_OK;
    bool ray_query = made && dev.ray_query, ray_pipeline = made && dev.ray_pipeline;
    pn_gpu_device_destroy(&dev);
    if (!ray_query)
        printf("rayquery at the extremes: skipped, the device has no VK_KHR_ray_query\n");
    if (!ray_pipeline)
        printf("rtpipeline at the extremes: skipped, the device has no VK_KHR_ray_tracing_pipeline\n");
    // The covering design: each mode and case takes one kind, kind (case + mode) mod 4, so every
    // mode still meets every kind (over the four cases) and every case every kind (over the modes):
    // every host path of the 144 renders runs, in 36. The fast tier and the sanitizer pass render it
    // (the sanitizers check host code, which no more of the sweep's points reach: the shaders run
    // uninstrumented in lavapipe); the plain pass renders the other 108 too, in a test of their own
    // (test_light_kinds_rest, tests/CMakeLists.txt), so that it renders each point once.
    for (int c = 0; c < 4; c++) {
        double sc = cases[c][0], t = cases[c][1];
        char name[64];
        // The rest's files apart from the covering's: ctest runs the two tests at once.
        const char *part_name = part == SWEEP_REST ? "_rest" : "";
        snprintf(name, sizeof name, "kinds_extreme%s_%d.gltf", part_name, c);
        // pn_test_tmp's names are reused after a few calls: the scene's path is copied.
        const char *written = write_penumbra_gltf(name, sc, t);
        CHECK(written != NULL);
        if (!written)
            continue;
        char gltf[1024];
        snprintf(gltf, sizeof gltf, "%s", written);
        // The spacing of floats at the case's magnitude, in local units.
        double mag = fabs(t) + 4 * sc, ulp = mag * 1.1920929e-7 / sc;
        for (size_t m = 0; m < sizeof modes / sizeof modes[0]; m++) {
            bool rq = strcmp(modes[m], "rayquery") == 0, rt = strcmp(modes[m], "rtpipeline") == 0;
            if ((rq && !ray_query) || (rt && !ray_pipeline))
                continue;
            bool tree = strncmp(modes[m], "exact ", 6) != 0 && strcmp(modes[m], "exact") != 0 && !rq && !rt;
            bool exact = tree ? strcmp(modes[m], "exact-ls") == 0 : true;
            double leaf = (0.5 + 8 * ulp) / 16, e_far = 0.25 + (exact ? 0 : 4 * leaf + 8 * ulp);
            for (int k = 0; k < 4; k++) {
                bool in_design = k == (c + (int)m) % 4;
                if ((part == SWEEP_COVERING && !in_design) || (part == SWEEP_REST && in_design))
                    continue;
                char light[256], args[2048];
                const char *kind = k == 0 ? "sun" : k == 1 ? "sphere" : k == 2 ? "disk" : "omni";
                if (k == 0)
                    snprintf(light, sizeof light, "sun:0,-1,0:10:2");
                else if (k == 1)
                    snprintf(light, sizeof light, "sphere:%.9g,%.9g,%.9g:%.9g:50", t + 0.25 * sc, t + 2 * sc, t, 0.1 * sc);
                else if (k == 2)
                    snprintf(light, sizeof light, "disk:%.9g,%.9g,%.9g:0,-1,0:0,0,1:%.9g:10", t + 0.25 * sc, t + 2 * sc,
                             t, 0.3 * sc);
                else
                    snprintf(light, sizeof light, "omni:%.9g,%.9g,%.9g:5", t, t + 2 * sc, t);
                char exr_name[64];
                snprintf(exr_name, sizeof exr_name, "kinds_extreme%s.exr", part_name);
                const char *exr = pn_test_tmp(exr_name);
                snprintf(args, sizeof args,
                         "render %s --no-ground --size 160x112 --camera-pos %.9g,%.9g,%.9g --camera-target "
                         "%.9g,%.9g,%.9g --fov 30 --mode %s %s --spp %d --filter none --aovs --light %s -o %s >/dev/null",
                         gltf, t + 1.5 * sc, t + 0.25 * sc, t, t + 0.25 * sc, t, t, modes[m], tree ? "--tree 4,2" : "",
                         k == 3 ? 1 : 256, light, exr);
                frame f;
                if (!read_frame(args, exr, &f))
                    continue;
                double err = 0;
                int n = 0, wrong = 0;
                for (int i = 0; i < f.img.width * f.img.height; i++) {
                    double x = (f.px[i] - t) / sc, y = (f.py[i] - t) / sc, z = (f.pz[i] - t) / sc;
                    if (!(f.alb[i] > 0) || fabs(y) > 1e-3 + 4 * ulp)
                        continue;
                    if (k < 3) {
                        double hi = chord(edge_offset(k, 0.25, x, z)), lo = chord(edge_offset(k, e_far, x, z));
                        if (fabs(z) >= 0.1 || (hi == 0 && lo == 0) || (hi == 1 && lo == 1))
                            continue; // outside every penumbra the range allows
                        err += f.v[i] < lo ? lo - f.v[i] : f.v[i] > hi ? f.v[i] - hi : 0;
                        n++;
                    } else {
                        // The shadow of the occluder's square from the light 2 above: 4/3 of it.
                        double edge = 0.25 * 2 / 1.5, far = e_far * 2 / 1.5, mm = 1e-4 + 8 * ulp;
                        bool inside = fabs(x) < edge - mm && fabs(z) < edge - mm;
                        bool outside = fabs(x) > far + mm || fabs(z) > far + mm;
                        wrong += (inside && f.v[i] != 0.0f) || (outside && f.v[i] != 1.0f);
                        n += inside || outside;
                    }
                }
                if (k < 3) {
                    // The edge's own rounding moves it by an ulp: as a share of the penumbra (0.044
                    // to 0.2 wide here), at most 0.03 of V on average at 1e4 (ulp 1e-3); 0.02 elsewhere.
                    double bound = 0.02 + 2 * ulp / 0.044;
                    printf("%s %s at scale %g, offset %g: %d penumbra pixels, mean distance of V from the chord's "
                           "range %.4f (bound %.3f)\n",
                           modes[m], kind, sc, t, n, n ? err / n : 1.0, bound);
                    CHECK_MSG(n > 30 && err / n < bound, "%s %s at scale %g, offset %g: %d pixels, mean error %.4f",
                              modes[m], kind, sc, t, n, n ? err / n : 1.0);
                } else {
                    printf("%s omni at scale %g, offset %g: %d receiver pixels, %d on the wrong side of the edge\n",
                           modes[m], sc, t, n, wrong);
                    CHECK_MSG(n > 500 && wrong == 0, "%s omni at scale %g, offset %g: %d wrong of %d", modes[m], sc, t,
                              wrong, n);
                }
                pn_exr_image_free(&f.img);
            }
        }
    }
}

// Arguments: none, every check and the whole sweep at the extremes; "covering", every check and
// the sweep's covering design (check_extremes); "rest", the sweep's other renders and nothing else.
int main(int argc, char **argv)
{
    sweep_part part = SWEEP_ALL;
    if (argc > 1 && !strcmp(argv[1], "covering"))
        part = SWEEP_COVERING;
    else if (argc > 1 && !strcmp(argv[1], "rest"))
        part = SWEEP_REST;
    else if (argc > 1) {
        fprintf(stderr, "usage: %s [covering|rest]\n", argv[0]);
        return 2;
    }
    if (part == SWEEP_REST) {
        check_extremes(part);
        return pn_test_result();
    }
    check_sun_irradiance();
    check_sphere_irradiance();
    check_disk_irradiance();
    check_spot_falloff();
    check_extremes(part);

    // A sun of 10 degrees straight down: its penumbra at the edge is 2 x 0.5 tan(5 deg) = 0.087 wide.
    // 256 stratified samples: V's error per pixel is below 0.01.
    frame f;
    if (render("sun:0,-1,0:10:2", "kinds_sun.exr", 256, &f)) {
        int n, n2;
        double err = sun_edge_error(&f, 10, &n), wrong = sun_edge_error(&f, 20, &n2);
        printf("sun 10 deg: %d penumbra pixels, mean |V - disk chord| %.4f (against 20 deg: %.4f)\n", n, err, wrong);
        CHECK_MSG(n > 50 && err < 0.02, "sun penumbra: %d pixels, mean error %.4f", n, err);
        CHECK_MSG(wrong > 3 * err && wrong > 0.04, "the oracle cannot tell 10 from 20 degrees: %.4f vs %.4f", err, wrong);
        // Lit receiver: radiance = albedo / pi x E, E = 2 (straight down on an upward face).
        double worst = 0;
        for (int i = 0; i < f.img.width * f.img.height; i++)
            if (f.v[i] == 1.0f && receiver(&f, i))
                worst = fmax(worst, fabs(f.r[i] - f.alb[i] / PI * 2.0) / (f.alb[i] / PI * 2.0));
        CHECK_MSG(worst < 1e-5, "sun radiance off by %.2g", worst);
        pn_exr_image_free(&f.img);
    }

    // A sphere of radius 0.1 at height 2 over the occluder's edge: each receiver point samples the
    // cone it subtends (half-angle about 0.05), which the edge cuts. To O(theta^2) (0.3% here) the
    // cap is a disk of angular radius theta and the edge a chord: V = chord(-angle / theta), angle
    // the cap centre's angular distance from the plane through the point and the edge, positive
    // on the lit side. Also against a sphere of twice the radius.
    if (render("sphere:0.25,2,0:0.1:50", "kinds_sphere.exr", 256, &f)) {
        double err[2] = {0, 0};
        int n = 0;
        for (int i = 0; i < f.img.width * f.img.height; i++) {
            double x = f.px[i], z = f.pz[i];
            if (fabs(z) >= 0.15 || fabs(x - 0.25) > 0.04 || !receiver(&f, i))
                continue;
            // The plane through g = (x, 0, z) and the edge (0.25, 0.5, z) + s (0, 0, 1): normal
            // (0.5, 0.25 - x, 0) turned towards the lit side (x' > 0.25 at y = 0.5).
            double nn[3] = {0.5, -(0.25 - x), 0}, nl = hypot(nn[0], nn[1]);
            double c[3] = {0.25 - x, 2.0, -z}, cl = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
            double ang = asin((nn[0] * c[0] + nn[1] * c[1]) / (nl * cl));
            for (int m = 0; m < 2; m++) {
                double theta = asin((m ? 0.2 : 0.1) / cl), a = fmin(fmax(-ang / theta, -1), 1);
                double v = (acos(a) - a * sqrt(1 - a * a)) / PI;
                err[m] += fabs(f.v[i] - v);
            }
            n++;
        }
        printf("sphere r 0.1: %d pixels by the edge, mean |V - disk chord| %.4f (against r 0.2: %.4f)\n", n,
               n ? err[0] / n : 1.0, n ? err[1] / n : 1.0);
        CHECK_MSG(n > 50 && err[0] / n < 0.02 && err[1] > 3 * err[0], "sphere penumbra: %d pixels, %.4f (r 0.2: %.4f)", n,
                  err[0] / n, err[1] / n);
        // Lit receiver: radiance = albedo / pi x L x the CPU's closed form.
        pn_light sph = {.kind = PN_LIGHT_SPHERE, .pos = {0.25f, 2, 0}, .radius = 0.1f};
        double worst = 0;
        for (int i = 0; i < f.img.width * f.img.height; i++)
            if (f.v[i] == 1.0f && receiver(&f, i)) {
                double e = pn_light_irradiance(&sph, (double[3]){f.px[i], 0, f.pz[i]}, (double[3]){0, 1, 0});
                double expect = f.alb[i] / PI * 50 * e;
                worst = fmax(worst, fabs(f.r[i] - expect) / expect);
            }
        CHECK_MSG(worst < 1e-4, "sphere radiance off by %.2g", worst);
        pn_exr_image_free(&f.img);
    }

    // A disk of radius 0.3 at height 2 facing down, centred over the edge: a receiver point at x
    // sees the disk points with x_q >= X = x + (0.25 - x) 2 / 0.5 past the edge, so V is the part
    // of the disk beyond a chord at a = (X - 0.25) / 0.3: exact (the samples are uniform by area).
    if (render("disk:0.25,2,0:0,-1,0:0,0,1:0.3:10", "kinds_disk.exr", 256, &f)) {
        double err = 0, worst = 0;
        int n = 0;
        pn_light disk = {.kind = PN_LIGHT_DISK, .pos = {0.25f, 2, 0}, .normal = {0, -1, 0}, .up = {0, 0, 1},
                         .radius = 0.3f, .size = {0.6f, 0.6f}};
        for (int i = 0; i < f.img.width * f.img.height; i++) {
            double x = f.px[i], z = f.pz[i];
            if (!receiver(&f, i))
                continue;
            if (f.v[i] == 1.0f) { // lit: radiance against the CPU's polygon
                double e = pn_light_irradiance(&disk, (double[3]){x, 0, z}, (double[3]){0, 1, 0});
                worst = fmax(worst, fabs(f.r[i] - f.alb[i] / PI * 10 * e) / (f.alb[i] / PI * 10 * e));
            }
            double X = x + (0.25 - x) * 2 / 0.5, a = (X - 0.25) / 0.3;
            if (fabs(z) >= 0.1 || fabs(a) >= 1)
                continue;
            err += fabs(f.v[i] - (acos(a) - a * sqrt(1 - a * a)) / PI);
            n++;
        }
        printf("disk r 0.3: %d pixels by the edge, mean |V - chord| %.4f; lit radiance off by %.2g\n", n,
               n ? err / n : 1.0, worst);
        CHECK_MSG(n > 50 && err / n < 0.02, "disk penumbra: %d pixels, %.4f", n, n ? err / n : 1.0);
        CHECK_MSG(worst < 1e-4, "disk radiance off by %.2g", worst);
        pn_exr_image_free(&f.img);
    }

    // Omni at height 2 over the centre: the occluder's edge x = 0.25 at y = 0.5 projects to 1/3.
    const double h = 2.0, edge = 0.25 * h / (h - 0.5), I = 5.0;
    // The third: the omni light with KHR_lights_punctual's range 3, which the receiver's far corners
    // (3.46 away) lie beyond: the extension's recommended window max(min(1 - (d / range)^4, 1), 0)
    // on the inverse square, written out here.
    const char *lights[3] = {"omni:0,2,0:5", "spot:0,2,0:0,-1,0:20,35:5", "omni:0,2,0:5:3"};
    for (int s = 0; s < 3; s++) {
        if (!render(lights[s], s == 1 ? "kinds_spot.exr" : "kinds_omni.exr", 1, &f))
            continue;
        pn_light spot = {.kind = PN_LIGHT_OMNI, .normal = {0, -1, 0}, .cone = {(float)(20 * PI / 180), (float)(35 * PI / 180)}};
        int wrong_v = 0, lit = 0;
        double worst = 0;
        for (int i = 0; i < f.img.width * f.img.height; i++) {
            double x = f.px[i], z = f.pz[i];
            if (!receiver(&f, i))
                continue;
            // V is traced from the pixel's own position: 1e-4 off the edge, its side is certain.
            bool inside = fabs(x) < edge - 1e-4 && fabs(z) < edge - 1e-4, outside = fabs(x) > edge + 1e-4 || fabs(z) > edge + 1e-4;
            if ((inside && f.v[i] != 0.0f) || (outside && f.v[i] != 1.0f))
                wrong_v++;
            if (outside && f.v[i] == 1.0f) {
                double d2 = x * x + h * h + z * z, cosr = h / sqrt(d2);
                double falloff = s == 1 ? pn_light_spot(&spot, cosr) : 1.0; // the axis is straight down
                if (s == 2) {
                    double q = d2 / 9; // (d / range)^2
                    falloff = fmax(fmin(1 - q * q, 1), 0);
                }
                double expect = f.alb[i] / PI * I * cosr / d2 * falloff;
                worst = fmax(worst, fabs(f.r[i] - expect) / fmax(expect, 1e-3 * f.alb[i] / PI * I / (h * h)));
                lit++;
            }
        }
        printf("%s: %d lit receiver pixels, relative radiance error %.2g, %d pixels on the wrong side\n", lights[s], lit,
               worst, wrong_v);
        CHECK_MSG(wrong_v == 0 && lit > 1000, "%s: %d pixels with V on the wrong side of the edge", lights[s], wrong_v);
        CHECK_MSG(worst < 1e-4, "%s: radiance off by %.2g", lights[s], worst);
        pn_exr_image_free(&f.img);
    }
    // Every mode takes every kind: the same view under the sun and a spot in each mode. The exact
    // ones give exact's V bit for bit; the line-space ones their approximation (mean |V - exact's|
    // below 0.05 here; bench and engine/shadow/README.md give their errors).
    const char *modes[] = {"exact-ls", "rayquery", "rtpipeline", "hybrid", "linespace", "ls-leaf", "ls-plane"};
    const char *kinds[4] = {"sun:0.3,-1,0.2:6:2", "spot:0.3,2,0.1:0,-1,0:25,40:5", "sphere:0.3,2,0.1:0.3:3",
                            "disk:0.3,2,0.1:0,-1,0:0,0,1:0.3:3"};
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    bool made = pn_gpu_device_create(&desc, &dev) == PN_OK;
    bool ray_query = made && dev.ray_query, ray_pipeline = made && dev.ray_pipeline;
    pn_gpu_device_destroy(&dev);
    for (int k = 0; k < 4; k++) {
        frame ref;
        char name[64];
        snprintf(name, sizeof name, "kinds_%d_exact.exr", k);
        if (!render_mode(kinds[k], "exact", name, &ref))
            continue;
        for (size_t m = 0; m < sizeof modes / sizeof modes[0]; m++) {
            if ((m == 1 && !ray_query) || (m == 2 && !ray_pipeline)) {
                printf("%s: skipped, the device lacks it\n", modes[m]);
                continue;
            }
            snprintf(name, sizeof name, "kinds_%d_%s.exr", k, modes[m]);
            if (!render_mode(kinds[k], modes[m], name, &f))
                continue;
            double sum = 0, worst = 0;
            int n = ref.img.width * ref.img.height;
            for (int i = 0; i < n; i++) {
                double d = fabs((double)f.v[i] - ref.v[i]);
                sum += d, worst = fmax(worst, d);
            }
            // exact-ls tests exact's triangles with exact's test: the same V. rayquery's and
            // rtpipeline's triangle test is the driver's: a ray grazing an edge may go the other
            // way (none did here).
            double bound = m == 0 ? 0.0 : m <= 2 ? 1e-3 : 0.05;
            printf("%s %s: mean |V - exact's| %.5f, max %.3f\n", kinds[k], modes[m], sum / n, worst);
            CHECK_MSG(m == 0 ? worst == 0 : sum / n < bound, "%s %s: mean |V - exact's| %.5f, max %.3f", kinds[k],
                      modes[m], sum / n, worst);
            pn_exr_image_free(&f.img);
        }
        pn_exr_image_free(&ref.img);
    }
    return pn_test_result();
}
