// The penumbra filter (--filter penumbra) against the analytic penumbra (builtin:penumbra: a
// 0.5x0.5 occluder at height 0.5 over a receiver at y = 0, under a parallel 0.5x0.5 light at
// height 1.5), whose V at every receiver point is a closed-form area overlap: the occluder seen
// from g = (x, 0, z) projects onto the light's plane as the square of half-edge 0.75 centred on
// -2 (x, z) (similar triangles, a factor 1.5 / 0.5 = 3), and V is one minus its overlap with the
// light over the light's area.
//
// Checked, over the receiver's pixels:
//  - the footprint AOV (shadow.footprint) against its CPU oracle: every blocked ray meets the
//    occluder at t = 1/3 of the way to the light, so the nearest blocker's penumbra is the light's
//    side foreshortened (its cosine from the pixel to the light's centre) times t / (1 - t) = 1/2,
//    and the footprint is the width scale x that x n^-1/2 over the pixel's footprint (view depth x
//    pixel angle), at most max_radius / 2.5 pixels (penumbra_filter.comp), where one of the pixel's
//    rays was blocked (V_raw < 1); else the narrowest of its 3 x 3 neighbours', failing them of the
//    5 x 5's outer ring (a lit pixel at a penumbra's edge takes it), 0 where none has a blocked ray;
//  - the error against the closed form at 1 and 4 spp: below the interleaved filter's, which
//    averages 3x3 pixels only;
//  - contact sharpness, on builtin:default (a cube, a sphere and table legs resting on the
//    platform): over the pixels of sharp penumbrae (the converged reference's V in (0.02, 0.98)
//    and its penumbra narrower than 3 pixels) and those within 2 pixels of one, the error against
//    that reference at 1 and 4 spp is no worse than unfiltered's at the same spp;
//  - convergence: at 256 spp the filtered error is within 10% of (or below) the unfiltered one's,
//    as the Gaussian's footprint shrinks as n^-1/2 and the interleaved window's as n^-3/4 under
//    this filter (the interleaved filter's fixed window stays at 0.000269 here against
//    unfiltered's 0.000187: printed, not asserted).
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "io/exr.h"
#include "test_util.h"

enum { SIZE = 128 };

// The closed form: V at receiver point (x, 0, z).
static double v_closed(double x, double z)
{
    double cx = -2.0 * x, cz = -2.0 * z, h = 0.75, l = 0.25;
    double ox = fmax(0.0, fmin(cx + h, l) - fmax(cx - h, -l));
    double oz = fmax(0.0, fmin(cz + h, l) - fmax(cz - h, -l));
    return 1.0 - ox * oz / (4.0 * l * l);
}

typedef struct frame {
    pn_exr_image img;
    const float *a, *v, *vraw, *px, *py, *pz, *z, *fp;
    bool ok;
} frame;

static frame render(const char *filter, int spp, int seed)
{
    frame f = {0};
    char out[256], args[2048];
    snprintf(out, sizeof out, "%s", pn_test_tmp("penumbra_filter.exr"));
    snprintf(args, sizeof args,
             "render builtin:penumbra --no-ground --size %dx%d --aovs --camera-pos 0,3,3 --camera-target 0,0,0 "
             "--fov 40 --light-pos 0,1.5,0 --light-normal 0,-1,0 --light-up 0,0,-1 --light-size 0.5,0.5 --mode exact "
             "--spp %d --seed %d --filter %s -o %s",
             SIZE, SIZE, spp, seed, filter, out);
    int rc = pn_test_run(args);
    CHECK_MSG(rc == 0, "render (%s, %d spp) exited %d", filter, spp, rc);
    if (rc != 0 || pn_exr_read(out, &f.img) != PN_OK)
        return f;
    f.a = pn_exr_image_channel(&f.img, "A");
    f.v = pn_exr_image_channel(&f.img, "shadow.V");
    f.vraw = pn_exr_image_channel(&f.img, "shadow.V_raw");
    f.px = pn_exr_image_channel(&f.img, "P.X");
    f.py = pn_exr_image_channel(&f.img, "P.Y");
    f.pz = pn_exr_image_channel(&f.img, "P.Z");
    f.z = pn_exr_image_channel(&f.img, "Z");
    f.fp = pn_exr_image_channel(&f.img, "shadow.footprint");
    f.ok = f.a && f.v && f.px && f.py && f.pz && f.z;
    CHECK_MSG(f.ok, "%s: a channel is missing", filter);
    CHECK_MSG((f.fp != NULL) == (strcmp(filter, "penumbra") == 0), "%s: shadow.footprint %s", filter,
              f.fp ? "present" : "missing");
    return f;
}

// Receiver pixels: covered, on the plane y = 0 (the occluder lies at 0.5).
static bool receiver(const frame *f, int i) { return f->a[i] == 1.0f && f->py[i] == 0.0f; }

static double mae(const frame *f, int *count)
{
    double sum = 0.0;
    int n = 0;
    for (int i = 0; f->ok && i < SIZE * SIZE; i++) {
        if (!receiver(f, i))
            continue;
        sum += fabs(f->v[i] - v_closed(f->px[i], f->pz[i]));
        n++;
    }
    if (count)
        *count = n;
    return n ? sum / n : 1.0;
}

// The footprint's oracle at receiver pixel i with n samples, world units (penumbra_filter.comp,
// filter_common.glsl's penumbra_footprint), where a ray of the pixel is blocked.
static double world_oracle(const frame *f, int i, int n)
{
    const double pi = 3.14159265358979323846;
    double pixel_angle = 2.0 * tan(0.5 * 40.0 * pi / 180.0) / SIZE;
    double dx = -f->px[i], dy = 1.5, dz = -f->pz[i]; // to the light's centre
    double cos_l = dy / sqrt(dx * dx + dy * dy + dz * dz);
    double width = 0.5 * cos_l * 0.5; // the side, foreshortened, times t / (1 - t) at t = 1/3
    double pixel = f->z[i] * pixel_angle;
    double limit = 8.0 / 2.5 * pixel; // pn_penumbra_max_radius(128) over PN_PENUMBRA_RADIUS_SIGMAS (the clamp's)
    return fmin(0.25 / sqrt(n) * width, limit); // pn_penumbra_width_scale's 0.25
}

// The footprint AOV's oracle (pixels facing the camera): the pixel's own where one of its rays was
// blocked (V_raw < 1), else the narrowest of its 3 x 3 neighbours' own, failing them of the 16
// pixels 2 away, at most the pixel's own limit
// (a neighbour's was clamped in the neighbour's pixels), over its pixel; 0 if none.
static double footprint_oracle(const frame *f, int i, int n)
{
    const double pi = 3.14159265358979323846;
    double pixel = f->z[i] * 2.0 * tan(0.5 * 40.0 * pi / 180.0) / SIZE;
    if (f->vraw[i] < 1.0f)
        return world_oracle(f, i, n) / pixel;
    int x = i % SIZE, y = i / SIZE;
    double narrowest = -1.0;
    for (int r = 1; r <= 2 && narrowest < 0.0; r++)
        for (int dy = -r; dy <= r; dy++)
            for (int dx = -r; dx <= r; dx++) {
                if (abs(dx) != r && abs(dy) != r)
                    continue; // inside the ring
                int qx = x + dx < 0 ? 0 : x + dx >= SIZE ? SIZE - 1 : x + dx;
                int qy = y + dy < 0 ? 0 : y + dy >= SIZE ? SIZE - 1 : y + dy;
                int j = qy * SIZE + qx;
                if (f->a[j] == 1.0f && f->vraw[j] < 1.0f && (narrowest < 0.0 || world_oracle(f, j, n) < narrowest))
                    narrowest = world_oracle(f, j, n);
            }
    return fmin(fmax(narrowest, 0.0), 8.0 / 2.5 * pixel) / pixel;
}

// Contact sharpness (above): the camera looks down at the contacts from the front right.
#define CONTACT_FOV 45.0
#define CONTACT_VIEW "--camera-pos 2.2,2.0,3.0 --camera-target 0.2,0.3,0.5 --fov 45"

// The band of pixels near sharp penumbrae, from the converged reference.
typedef struct band {
    unsigned char *in;
    int w, h, count;
} band;

static band sharp_band(const pn_exr_image *ref, double yfov_deg)
{
    band b = {0};
    const float *a = pn_exr_image_channel(ref, "A"), *v = pn_exr_image_channel(ref, "shadow.V");
    const float *z = pn_exr_image_channel(ref, "Z"), *width = pn_exr_image_channel(ref, "shadow.penumbra");
    CHECK(a && v && z && width);
    if (!(a && v && z && width))
        return b;
    b.w = ref->width, b.h = ref->height;
    int n = b.w * b.h;
    unsigned char *sharp = calloc((size_t)n, 1);
    b.in = calloc((size_t)n, 1);
    CHECK(sharp && b.in);
    if (!sharp || !b.in) {
        free(sharp), free(b.in);
        b.in = NULL;
        return b;
    }
    double pixel_angle = 2.0 * tan(0.5 * yfov_deg * 3.14159265358979323846 / 180.0) / b.h;
    for (int i = 0; i < n; i++)
        sharp[i] = a[i] == 1.0f && v[i] > 0.02f && v[i] < 0.98f && width[i] < 3.0 * z[i] * pixel_angle;
    for (int y = 0; y < b.h; y++)
        for (int x = 0; x < b.w; x++) {
            int i = y * b.w + x;
            for (int dy = -2; dy <= 2 && a[i] == 1.0f && !b.in[i]; dy++)
                for (int dx = -2; dx <= 2; dx++) {
                    int qx = x + dx, qy = y + dy;
                    if (qx >= 0 && qy >= 0 && qx < b.w && qy < b.h && sharp[qy * b.w + qx])
                        b.in[i] = 1;
                }
            b.count += b.in[i];
        }
    free(sharp);
    return b;
}

static double band_mae(const band *b, const char *filter, int spp, const float *ref_v)
{
    char out[256], args[1024];
    snprintf(out, sizeof out, "%s", pn_test_tmp("penumbra_contact.exr"));
    snprintf(args, sizeof args, "render builtin:default --size %dx%d %s --mode exact --spp %d --seed 1 --filter %s -o %s",
             b->w, b->h, CONTACT_VIEW, spp, filter, out);
    int rc = pn_test_run(args);
    CHECK_MSG(rc == 0, "render (%s, %d spp) exited %d", filter, spp, rc);
    pn_exr_image img;
    if (rc != 0 || pn_exr_read(out, &img) != PN_OK)
        return 1.0;
    const float *v = pn_exr_image_channel(&img, "shadow.V");
    double sum = 0.0;
    for (int i = 0; v && i < b->w * b->h; i++)
        sum += b->in[i] ? fabs(v[i] - ref_v[i]) : 0.0;
    pn_exr_image_free(&img);
    return b->count ? sum / b->count : 1.0;
}

static void check_contacts(void)
{
    char ref_path[256], args[1024];
    snprintf(ref_path, sizeof ref_path, "%s", pn_test_tmp("penumbra_contact_ref.exr"));
    snprintf(args, sizeof args,
             "render builtin:default --size 256x144 %s --mode exact --spp 1024 --seed 7 --filter none --aovs -o %s",
             CONTACT_VIEW, ref_path);
    int rc = pn_test_run(args);
    CHECK_MSG(rc == 0, "reference render exited %d", rc);
    pn_exr_image ref;
    if (rc != 0 || pn_exr_read(ref_path, &ref) != PN_OK)
        return;
    band b = sharp_band(&ref, CONTACT_FOV);
    fprintf(stderr, "contact band: %d pixels near sharp penumbrae\n", b.count);
    CHECK_MSG(b.count > 300, "only %d pixels near sharp penumbrae", b.count);
    const float *ref_v = pn_exr_image_channel(&ref, "shadow.V");
    for (int spp = 1; spp <= 4 && b.count > 0 && ref_v; spp *= 4) {
        double none = band_mae(&b, "none", spp, ref_v), inter = band_mae(&b, "interleaved", spp, ref_v);
        double pen = band_mae(&b, "penumbra", spp, ref_v);
        fprintf(stderr, "contact band MAE, %d spp: none %.5f, interleaved %.5f, penumbra %.5f\n", spp, none, inter, pen);
        CHECK_MSG(pen <= none, "%d spp: the penumbra filter's error near contacts %.5f above unfiltered's %.5f", spp, pen,
                  none);
    }
    free(b.in);
    pn_exr_image_free(&ref);
}

int main(void)
{
    check_contacts();

    // The footprint against its oracle, at 1 and 4 spp, where rays were blocked (the closed form
    // says V < 1: some ray may be blocked; a pixel whose rays all passed has none of its own).
    int spps[2] = {1, 4};
    for (int k = 0; k < 2; k++) {
        frame f = render("penumbra", spps[k], 1);
        int checked = 0, off = 0, lit_zero = 0, lit = 0;
        for (int i = 0; f.ok && f.fp && f.vraw && i < SIZE * SIZE; i++) {
            if (!receiver(&f, i))
                continue;
            double want = footprint_oracle(&f, i, spps[k]);
            if (want == 0.0) { // no ray of it or its neighbours blocked
                lit++;
                lit_zero += f.fp[i] == 0.0f;
                continue;
            }
            // Float arithmetic on the GPU against double here: a relative 1e-4.
            checked++;
            if (fabs(f.fp[i] - want) > 1e-4 * want && off++ < 5)
                fprintf(stderr, "  %d spp pixel %d: footprint %.6f, oracle %.6f\n", spps[k], i, f.fp[i], want);
        }
        fprintf(stderr, "footprint, %d spp: %d pixels against the oracle, %d off; %d of %d lit pixels 0\n", spps[k],
                checked, off, lit_zero, lit);
        CHECK_MSG(checked > 300, "%d spp: only %d penumbra pixels with a footprint", spps[k], checked);
        CHECK_MSG(off == 0, "%d spp: %d footprints off their oracle", spps[k], off);
        CHECK_MSG(lit > 1000 && lit_zero == lit, "%d spp: %d of %d lit pixels with a footprint", spps[k], lit - lit_zero,
                  lit);
        pn_exr_image_free(&f.img);
    }

    // Error against the closed form.
    double e[3][3]; // [none, interleaved, penumbra][1, 4, 256 spp]
    const char *filters[3] = {"none", "interleaved", "penumbra"};
    int levels[3] = {1, 4, 256};
    for (int fi = 0; fi < 3; fi++)
        for (int li = 0; li < 3; li++) {
            frame f = render(filters[fi], levels[li], 1);
            int n = 0;
            e[fi][li] = mae(&f, &n);
            CHECK_MSG(n > 5000, "%s: %d receiver pixels", filters[fi], n);
            fprintf(stderr, "MAE against the closed form, %s, %d spp: %.6f\n", filters[fi], levels[li], e[fi][li]);
            pn_exr_image_free(&f.img);
        }
    for (int li = 0; li < 2; li++)
        CHECK_MSG(e[2][li] < e[1][li], "%d spp: penumbra %.5f not below interleaved %.5f", levels[li], e[2][li],
                  e[1][li]);
    CHECK_MSG(e[2][2] <= 1.1 * e[0][2], "256 spp: penumbra %.6f above 1.1 x unfiltered %.6f", e[2][2], e[0][2]);
    return pn_test_result();
}
