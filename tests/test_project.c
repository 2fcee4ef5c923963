// The projection traversal (--traversal project) gives exact's V: each light sample is decided by
// the packet walk's own ray-triangle test, so with the same samples V may differ only where a
// sample grazes an edge (rounding: the frustum's corners, the walk's culls). Here it must equal
// the packet walk's V (--traversal packet) on at least 99.9% of the pixels with geometry, and
// differ nowhere by more than two samples, over the paths the projection takes:
//   - a rectangle's strata (grid and stratified samplers, spp not a power of two nor a square);
//   - the warped samples of a disk, a sun and a sphere (group boxes instead of strata);
//   - alpha-masked casters (builtin:canopy: every sample's texel, as the rays do);
//   - the budget run out at once (PN_PROJECT_BUDGET tiny: the samples left go to the packet walk)
//     and never (huge: projection alone);
//   - more samples than one dispatch holds (1100: 1024, then 76);
//   - two lights with the budgeted split (Sobol' samples, a count per pixel and light);
//   - the real bunny (69k triangles), where the walk's culls matter.
// The Embree oracle of every sample (test_exact_oracle) and the extremes sweep (test_extremes)
// cover it too. Bad combinations (a line-space mode, adaptive samples) are refused.
#include <stdlib.h>

#include "io/exr.h"
#include "test_util.h"

typedef struct run {
    const char *name;
    const char *scene; // NULL: builtin:default
    const char *args;
    const char *budget; // PN_PROJECT_BUDGET, NULL: the default
    int spp;            // samples of a pixel per light: two of them bound any pixel's difference
} run;

static bool render(const run *r, const char *traversal, pn_exr_image *img)
{
    char name[128], args[2048];
    snprintf(name, sizeof name, "project_%s_%s.exr", r->name, traversal);
    for (char *c = name; *c; c++)
        *c = *c == ' ' ? '_' : *c;
    const char *exr = pn_test_tmp(name);
    snprintf(args, sizeof args, "render %s --size 96x72 --mode exact --traversal %s --filter none --aovs %s -o %s >/dev/null",
             r->scene ? r->scene : "builtin:default", traversal, r->args, exr);
    if (r->budget && !strcmp(traversal, "project"))
        setenv("PN_PROJECT_BUDGET", r->budget, 1);
    int rc = pn_test_run(args);
    unsetenv("PN_PROJECT_BUDGET");
    CHECK_MSG(rc == 0, "%s (%s): render exited %d", r->name, traversal, rc);
    return rc == 0 && pn_exr_read(exr, img) == PN_OK;
}

static void compare(const run *r)
{
    pn_exr_image a, b;
    if (!render(r, "packet", &a))
        return;
    if (!render(r, "project", &b)) {
        pn_exr_image_free(&a);
        return;
    }
    // Every light's V: shadow.V, or shadow.V.0, shadow.V.1, ... with several.
    const char *names[3] = {"shadow.V", "shadow.V.0", "shadow.V.1"};
    int channels = 0;
    for (int c = 0; c < 3; c++) {
        const float *va = pn_exr_image_channel(&a, names[c]), *vb = pn_exr_image_channel(&b, names[c]);
        const float *alpha = pn_exr_image_channel(&a, "A");
        if (!va || !vb || !alpha)
            continue;
        channels++;
        size_t n = (size_t)a.width * a.height, covered = 0, differ = 0, far = 0, shadowed = 0;
        double worst = 0;
        for (size_t i = 0; i < n; i++) {
            if (alpha[i] <= 0)
                continue;
            covered++;
            shadowed += va[i] < 1.0f;
            double d = fabs((double)va[i] - vb[i]);
            differ += d > 0;
            far += d > 2.0 / r->spp + 1e-6;
            worst = fmax(worst, d);
        }
        printf("%-22s %-10s %zu px (%zu shadowed), %zu differ (max %.4f)\n", r->name, names[c], covered, shadowed, differ,
               worst);
        CHECK_MSG(covered > 1000 && shadowed > covered / 50, "%s %s: %zu px, %zu shadowed: too few to say anything",
                  r->name, names[c], covered, shadowed);
        CHECK_MSG(differ * 1000 <= covered && far == 0, "%s %s: %zu of %zu px differ from the packet walk, %zu by more "
                  "than two samples (max %.4f)", r->name, names[c], differ, covered, far, worst);
    }
    CHECK_MSG(channels > 0, "%s: no shadow.V in the EXRs", r->name);
    pn_exr_image_free(&a);
    pn_exr_image_free(&b);
}

int main(void)
{
    char bunny[1024];
    snprintf(bunny, sizeof bunny, "%s/stanford-bunny-69k.glb", pn_test_env("PN_ASSETS", "../shared/assets"));
    FILE *f = fopen(bunny, "rb");
    if (f)
        fclose(f);
    const run runs[] = {
        {"rectangle", NULL, "--spp 24", NULL, 24},
        {"rectangle grid", NULL, "--spp 24 --sampler grid", NULL, 24},
        {"disk", NULL, "--spp 32 --light disk:0.3,2,0.1:0,-1,0:0,0,1:0.3:3", NULL, 32},
        {"sun", NULL, "--spp 32 --light sun:0.3,-1,0.2:6:2", NULL, 32},
        {"sphere", NULL, "--spp 32 --light sphere:0.3,2,0.1:0.3:3", NULL, 32},
        {"alpha canopy", "builtin:canopy", "--spp 32", NULL, 32},
        {"budget spent", NULL, "--spp 64", "0.001", 64},
        {"no budget", NULL, "--spp 64", "1000000", 64},
        {"two dispatches", NULL, "--spp 1100", NULL, 1100},
        {"omni below the top", NULL, "--spp 16 --light omni:0.3,0.6,0.1:3", NULL, 1},
        {"spot", NULL, "--spp 16 --light spot:0.3,2,0.1:0,-1,0:25,40:5", NULL, 1},
        {"small light far aside", NULL, "--spp 32 --light 6,1.2,0.4:-1,0,0:0,1,0:0.2,0.2:400", NULL, 32},
        {"two lights budget", NULL,
         "--spp 16 --split budget --light 0,2,0:0,-1,0:0,0,1:0.6,0.6:4 --light disk:0.5,2,0.3:0,-1,0:0,0,1:0.3:3", NULL,
         2}, // a pixel may give a light a single sample: one flip is all of it
        {"bunny", f ? bunny : NULL, "--spp 64", NULL, 64},
    };
    for (size_t i = 0; i < sizeof runs / sizeof runs[0]; i++) {
        if (!runs[i].scene && !strcmp(runs[i].name, "bunny")) {
            fprintf(stderr, "%s missing: the bunny is skipped\n", bunny);
            continue;
        }
        compare(&runs[i]);
    }
    // The projection did the work: the bench's counting build of the shader (bench.json's
    // "projected" triangles per pixel and "fallback" share) on the default scene, with the budget
    // off (triangles projected, no pixel falls back) and spent at once (pixels fall back).
    const char *budgets[2] = {"1000000", "0.001"};
    for (int b = 0; b < 2; b++) {
        char args[1024], path[1024];
        const char *dir = pn_test_tmp(b ? "project_bench_spent" : "project_bench_off");
        snprintf(args, sizeof args,
                 "bench --scenes builtin:default --modes exact --spp 16 --filter none --size 96x72 --traversal project "
                 "--no-embree --repeat 1 --warmup 0 --reference-spp 64 --out %s >/dev/null 2>&1",
                 dir);
        setenv("PN_PROJECT_BUDGET", budgets[b], 1);
        int rc = pn_test_run(args);
        unsetenv("PN_PROJECT_BUDGET");
        CHECK_MSG(rc == 0, "bench (budget %s) exited %d", budgets[b], rc);
        snprintf(path, sizeof path, "%s/bench.json", dir);
        FILE *j = fopen(path, "rb");
        char *text = j ? calloc(1, 1 << 22) : NULL;
        size_t len = text ? fread(text, 1, (1 << 22) - 1, j) : 0;
        if (j)
            fclose(j);
        const char *at = len ? strstr(text, "\"traversal\": \"project\", \"projected\": ") : NULL;
        double projected = -1, fallback = -1;
        CHECK_MSG(at && sscanf(at, "\"traversal\": \"project\", \"projected\": %lf, \"fallback\": %lf", &projected,
                               &fallback) == 2,
                  "%s: no project cell with its projected triangles and fallback share", path);
        printf("bench, budget %s: %.2f triangles projected per pixel, %.4f of the pixels fell back\n", budgets[b],
               projected, fallback);
        if (b == 0)
            CHECK_MSG(projected > 1 && fallback == 0, "budget off: %.2f triangles per pixel, fallback %.4f", projected,
                      fallback);
        else
            CHECK_MSG(fallback > 0.02, "budget spent: only %.4f of the pixels fell back", fallback);
        free(text);
    }
    // Refused with a message: the projection is exact's, and takes uniform samples.
    CHECK(pn_test_run("render builtin:default --size 32x32 --mode linespace --traversal project -o "
                      "/dev/null 2>/dev/null") != 0);
    CHECK(pn_test_run("render builtin:default --size 32x32 --mode exact --traversal project --spp 4:16 -o "
                      "/dev/null 2>/dev/null") != 0);
    return pn_test_result();
}
