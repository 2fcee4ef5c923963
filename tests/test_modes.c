// The modes against each other, ray by ray (same pixels, same light samples: --ray-dump):
//  - exact-ls equals exact: it only uses line spaces to skip empty space and tests triangles
//    wherever a shaft is set; like the Embree oracle, at most 0.01% of rays may differ (rays that
//    graze an edge, where the candidate list and the BVH meet the triangle from different nodes).
//  - hybrid is never brighter than exact: line spaces are conservative and everything they cannot
//    decide (the start and end nodes, the surface's own neighbourhood) is tested exactly, so a ray
//    exact finds blocked must be blocked in hybrid too. Zero violations.
// Scenes: the bunny and Sponza, each with the ground plane render adds.
#include "test_util.h"

typedef struct dump {
    uint32_t w, h, spp;
    float *data;
} dump;

static bool render(const char *scene, const char *mode, dump *d)
{
    const char *path = pn_test_tmp(mode[0] == 'h' ? "modes_h.bin" : strlen(mode) > 5 ? "modes_x.bin" : "modes_e.bin");
    char args[2048];
    snprintf(args, sizeof args, "render %s --mode %s --tree 6,3 --size 96x96 --spp 16 --seed 3 --ray-dump %s -o %s",
             scene, mode, path, pn_test_tmp("modes.exr"));
    int rc = pn_test_run(args);
    CHECK_MSG(rc == 0, "render --mode %s exited %d", mode, rc);
    FILE *f = fopen(path, "rb");
    uint32_t h[6];
    bool ok = rc == 0 && f && fread(h, sizeof h, 1, f) == 1;
    if (ok) {
        d->w = h[2], d->h = h[3], d->spp = h[4];
        uint64_t n = (uint64_t)d->w * d->h * 4 * (1 + d->spp);
        d->data = malloc(n * sizeof(float));
        ok = d->data && fread(d->data, sizeof(float), n, f) == n;
    }
    if (f)
        fclose(f);
    CHECK(ok);
    return ok;
}

static uint32_t flags(const dump *d, uint64_t pixel, uint32_t k)
{
    uint32_t f;
    memcpy(&f, &d->data[4 * ((uint64_t)d->w * d->h + pixel * d->spp + k) + 3], 4);
    return f;
}

int main(void)
{
    const char *assets = pn_test_env("PN_ASSETS", "../shared/assets");
    char paths[2][1024];
    snprintf(paths[0], sizeof paths[0], "%s/stanford-bunny-69k.glb", assets);
    snprintf(paths[1], sizeof paths[1], "%s/dabrovic-sponza-66k.glb", assets);
    FILE *f = fopen(paths[0], "rb");
    if (!f)
        TEST_SKIP("%s missing (../shared/assets not beside the project)", paths[0]);
    fclose(f);
    for (int s = 0; s < 2; s++) {
        dump e = {0}, x = {0}, h = {0};
        if (!render(paths[s], "exact", &e) || !render(paths[s], "exact-ls", &x) || !render(paths[s], "hybrid", &h))
            return pn_test_result();
        uint64_t rays = 0, blocked = 0, xdiff = 0, brighter = 0, darker = 0, px = (uint64_t)e.w * e.h;
        for (uint64_t p = 0; p < px; p++) {
            if (e.data[4 * p + 3] != 1.0f)
                continue;
            for (uint32_t k = 0; k < e.spp; k++) {
                uint32_t fe = flags(&e, p, k), fx = flags(&x, p, k), fh = flags(&h, p, k);
                CHECK_MSG((fe & 1) == (fx & 1) && (fe & 1) == (fh & 1), "pixel %llu sample %u: modes disagree on validity",
                          (unsigned long long)p, k);
                if (!(fe & 1))
                    continue;
                rays++;
                blocked += (fe & 2) != 0;
                xdiff += (fe & 2) != (fx & 2);
                brighter += (fe & 2) && !(fh & 2);
                darker += !(fe & 2) && (fh & 2);
            }
        }
        fprintf(stderr, "%s: %llu rays, %llu blocked in exact; exact-ls differs on %llu; hybrid blocks %llu more, "
                        "misses %llu\n",
                paths[s], (unsigned long long)rays, (unsigned long long)blocked, (unsigned long long)xdiff,
                (unsigned long long)darker, (unsigned long long)brighter);
        CHECK(rays > 50000 && blocked > rays / 50);
        CHECK_MSG(xdiff * 10000 <= rays, "exact-ls differs from exact on %llu of %llu rays", (unsigned long long)xdiff,
                  (unsigned long long)rays);
        CHECK_MSG(brighter == 0, "hybrid misses %llu rays exact finds blocked", (unsigned long long)brighter);
        free(e.data), free(x.data), free(h.data);
    }
    return pn_test_result();
}
