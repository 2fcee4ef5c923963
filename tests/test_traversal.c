// Packet and per-ray traversal decide alike, and line-space shadows of a real mesh look right.
//
// Both traversals classify every (ray, node) pair with the same function (ls_classify), so they can
// only differ where a ray grazes a cell boundary: the per-ray 3D-DDA then steps into one of two
// cells, the packet visits every cell of its footprint. Such rays are rare: a ray passes within
// float rounding (~1e-6 of a cell) of an edge with probability ~1e-5, so over the ~100 rays that
// touch cells per pixel we allow at most 0.5% of pixels to differ, and by at most 2 rays each.
//
// Real mesh: the Stanford bunny on its ground plane, lit from above and to the side. The shadow
// image must be finite, in [0,1], and show penumbrae: visibility strictly between 0 and 1 on at
// least 2% of the ground pixels, full light on at least half of them.
#include "io/exr.h"
#include "test_util.h"

static int render(const char *scene, const char *traversal, const char *name, pn_exr_image *img)
{
    char args[2048];
    const char *out = pn_test_tmp(name);
    snprintf(args, sizeof args, "render %s --size 96x96 --aovs --spp 16 --tree 6,3 --sampler stratified --seed 7 --filter none --traversal %s -o %s",
             scene, traversal, out);
    int rc = pn_test_run(args);
    CHECK_MSG(rc == 0, "render %s exited %d", traversal, rc);
    return rc == 0 && pn_exr_read(out, img) == PN_OK;
}

int main(void)
{
    char bunny[1024];
    snprintf(bunny, sizeof bunny, "%s/stanford-bunny-69k.glb", pn_test_env("PN_ASSETS", "../shared/assets"));
    FILE *f = fopen(bunny, "rb");
    const char *scenes[2] = {"builtin:default", f ? bunny : NULL};
    if (f)
        fclose(f);
    else
        fprintf(stderr, "%s missing: the real-mesh part is skipped\n", bunny);
    for (int s = 0; s < 2 && scenes[s]; s++) {
        pn_exr_image ray, packet;
        if (!render(scenes[s], "ray", "trav_ray.exr", &ray) || !render(scenes[s], "packet", "trav_packet.exr", &packet))
            return pn_test_result();
        const float *a = pn_exr_image_channel(&ray, "A"), *vr = pn_exr_image_channel(&ray, "shadow.V");
        const float *vp = pn_exr_image_channel(&packet, "shadow.V"), *py = pn_exr_image_channel(&ray, "P.Y");
        const float *ny = pn_exr_image_channel(&ray, "N.Y");
        CHECK(a && vr && vp && py && ny);
        if (!(a && vr && vp && py && ny))
            return pn_test_result();
        int covered = 0, differ = 0, far = 0, ground = 0, pen = 0, lit = 0, bad = 0;
        float ground_y = 1e30f;
        for (int i = 0; i < ray.width * ray.height; i++)
            if (a[i] == 1.0f && ny[i] > 0.999f && py[i] < ground_y)
                ground_y = py[i];
        for (int i = 0; i < ray.width * ray.height; i++) {
            if (a[i] != 1.0f)
                continue;
            covered++;
            bad += !(vr[i] >= 0.0f && vr[i] <= 1.0f) || !(vp[i] >= 0.0f && vp[i] <= 1.0f);
            if (vr[i] != vp[i]) {
                differ++;
                far += fabsf(vr[i] - vp[i]) > 2.0f / 16.0f + 1e-6f;
                if (fabsf(vr[i] - vp[i]) > 2.0f / 16.0f + 1e-6f)
                    fprintf(stderr, "  pixel (%d, %d): ray %.4f packet %.4f\n", i % ray.width, i / ray.width, vr[i], vp[i]);
            }
            // The ground plane: the lowest upward-facing surface (P is interpolated in float across it).
            if (fabsf(py[i] - ground_y) <= 1e-5f * (1.0f + fabsf(ground_y)) && ny[i] > 0.999f) {
                ground++;
                pen += vr[i] > 0.0f && vr[i] < 1.0f;
                lit += vr[i] == 1.0f;
            }
        }
        fprintf(stderr, "%s: %d covered pixels, packet and ray differ on %d (%.3f%%), %d by more than 2 rays; ground %d "
                        "pixels: %d in penumbra, %d fully lit\n",
                scenes[s], covered, differ, 100.0 * differ / covered, far, ground, pen, lit);
        CHECK_MSG(bad == 0, "%d visibilities outside [0,1] or not finite", bad);
        CHECK_MSG(differ <= covered / 200, "packet and ray differ on %d of %d pixels", differ, covered);
        CHECK(far == 0);
        CHECK_MSG(ground > 1000 && pen >= ground / 50 && lit >= ground / 2, "ground %d, penumbra %d, lit %d", ground, pen, lit);
        pn_exr_image_free(&ray);
        pn_exr_image_free(&packet);
    }
    return pn_test_result();
}
