// The API on the host's Vulkan device (penumbra.h, VK_VERSION_1_0 part): a "host" makes its own
// device (the engine's device code stands in for the host's, with the validation layer from
// PN_VALIDATION counting every message), hands it to penumbra_context_create_vulkan, writes P and N
// into images of its own, records penumbra's shadow pass into its own command buffer between its
// own barriers, and reads V back. Oracle: penumbra_visibility on the same context for the same
// points laid out the same way, bit for bit (itself checked against render in test_api), in exact
// and, where the device has it, rayquery; pixels without a point (P.w = 0) must read V = 0. Then
// the context is destroyed and the host's device must still work (a submit of its own), and the
// layer must have reported nothing.
#include <math.h>

#include "gpu/device.h" // Vulkan before penumbra.h: it declares its Vulkan part only then
#include "api/penumbra.h"
#include "gpu/gbuffer_upload.h" // only its staging buffer: the host records its own copies
#include "gpu/resources.h"
#include "test_util.h"

enum { W = 37, H = 23 }; // 851 points: not a multiple of 4 or of a workgroup tile

static pn_gpu_device g_host;

// The host's frame: P and N copied to its images from the staging buffer `up` holds (P then N),
// penumbra's pass, V copied to `out`.
static bool host_frame(penumbra_recorder *rec, uint32_t seed, const penumbra_view *view, const pn_gpu_image *img,
                       const pn_gbuffer_upload *up, pn_gpu_buffer *out)
{
    for (int attempt = 0; attempt < 8; attempt++) {
        VkCommandBuffer cmd;
        if (pn_gpu_begin_once(&g_host, &cmd) != PN_OK)
            return false;
        // The host's own writes: P and N copied in from its staging buffer, V cleared to a
        // sentinel that penumbra must overwrite everywhere (0 where there is no point). Then only
        // layout transitions to GENERAL, as penumbra.h asks: its recording opens with the barrier
        // that makes these writes visible (synchronization validation checks that it does).
        const VkPipelineStageFlags2 COPY = VK_PIPELINE_STAGE_2_COPY_BIT, CLEAR = VK_PIPELINE_STAGE_2_CLEAR_BIT;
        VkImageMemoryBarrier2 to_dst[3];
        for (int i = 0; i < 3; i++) {
            int k = i < 2 ? i : 3;
            to_dst[i] = pn_gpu_image_barrier(&img[k], VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, COPY | CLEAR,
                                             VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
        }
        pn_gpu_cmd_barrier(cmd, NULL, 3, to_dst);
        for (int i = 0; i < 2; i++) {
            VkBufferImageCopy in = {.bufferOffset = (VkDeviceSize)i * W * H * 16,
                                    .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                                    .imageExtent = {W, H, 1}};
            vkCmdCopyBufferToImage(cmd, up->buffer.buffer, img[i].image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &in);
        }
        vkCmdClearColorImage(cmd, img[3].image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                             &(VkClearColorValue){.float32 = {42, 42, 42, 42}}, 1,
                             &(VkImageSubresourceRange){VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1});
        VkImageMemoryBarrier2 to_general[3];
        for (int i = 0; i < 3; i++) {
            int k = i < 2 ? i : 3;
            to_general[i] = pn_gpu_image_barrier(&img[k], COPY | CLEAR, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                                 VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_NONE,
                                                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL);
        }
        pn_gpu_cmd_barrier(cmd, NULL, 3, to_general);
        penumbra_status st = view ? penumbra_recorder_record_view(rec, cmd, seed, view) : penumbra_recorder_record(rec, cmd, seed);
        CHECK(st == PENUMBRA_OK);
        // As penumbra.h states: V is written by the compute stage; the host's barrier from there.
        VkImageMemoryBarrier2 to_copy = pn_gpu_image_barrier(&img[3], VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                                             VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                                             VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                                                             VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
        pn_gpu_cmd_barrier(cmd, NULL, 1, &to_copy);
        VkBufferImageCopy copy = {.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1}, .imageExtent = {W, H, 1}};
        vkCmdCopyImageToBuffer(cmd, img[3].image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, out->buffer, 1, &copy);
        VkMemoryBarrier2 to_host = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                    .srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT,
                                    .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                    .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
                                    .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT};
        pn_gpu_cmd_barrier(cmd, &to_host, 0, NULL);
        if (pn_gpu_submit_wait(&g_host, cmd) != PN_OK)
            return false;
        st = penumbra_recorder_check(rec);
        if (st == PENUMBRA_OK)
            return true;
        CHECK_MSG(st == PENUMBRA_INCOMPLETE, "penumbra_recorder_check: %s", penumbra_status_string(st));
        if (st != PENUMBRA_INCOMPLETE)
            return false;
        fprintf(stderr, "recorded pass cut short: recording again\n");
    }
    return false;
}

static void compare_mode(penumbra_context *ctx, penumbra_scene *scene, const char *mode, const penumbra_light *light,
                         const float *p4, const float *n4, const pn_gpu_image *img, const pn_gbuffer_upload *up,
                         pn_gpu_buffer *out)
{
    penumbra_recorder *rec = NULL;
    penumbra_recorder_desc rd = {.width = W, .height = H, .position = img[0].view, .normal = img[1].view,
                                 .visibility = img[3].view, .shadow = {.mode = mode, .spp = 16}, .light = *light};
    penumbra_status st = penumbra_recorder_create(ctx, scene, &rd, &rec);
    CHECK_MSG(st == PENUMBRA_OK, "penumbra_recorder_create (%s): %s", mode, penumbra_context_error(ctx));
    if (st != PENUMBRA_OK)
        return;
    float p3[W * H * 3], n3[W * H * 3], v_api[W * H];
    for (int i = 0; i < W * H; i++)
        for (int k = 0; k < 3; k++)
            p3[3 * i + k] = p4[4 * i + k], n3[3 * i + k] = n4[4 * i + k];
    for (uint32_t seed = 1; seed <= 2; seed++) {
        CHECK(host_frame(rec, seed, NULL, img, up, out));
        const float *v_host = out->mapped;
        penumbra_visibility_desc vd = {.mode = mode, .spp = 16, .seed = seed, .width = W};
        st = penumbra_visibility(ctx, scene, &vd, light, 1, p3, n3, W * H, v_api);
        CHECK_MSG(st == PENUMBRA_OK, "%s", penumbra_context_error(ctx));
        size_t differ = 0, points = 0, partial = 0, empty_nonzero = 0;
        for (int i = 0; i < W * H; i++) {
            if (p4[4 * i + 3] <= 0) {
                empty_nonzero += v_host[i] != 0;
                continue;
            }
            points++;
            partial += v_api[i] > 0 && v_api[i] < 1;
            differ += memcmp(&v_host[i], &v_api[i], sizeof(float)) != 0;
        }
        fprintf(stderr, "%s seed %u: %zu of %zu points differ between the host's recording and penumbra_visibility "
                        "(%zu in penumbra)\n", mode, seed, differ, points, partial);
        CHECK(partial > 20);
        CHECK_MSG(differ == 0, "%s: %zu points differ", mode, differ);
        CHECK_MSG(empty_nonzero == 0, "%s: %zu pixels without a point have V != 0", mode, empty_nonzero);
    }
    penumbra_recorder_destroy(rec);
}

// The mean absolute difference of V over the points (P.w > 0).
static double points_mae(const float *v, const float *ref, const float *p4)
{
    double sum = 0;
    int n = 0;
    for (int i = 0; i < W * H; i++)
        if (p4[4 * i + 3] > 0)
            sum += fabs((double)v[i] - ref[i]), n++;
    return n ? sum / n : 0;
}

// The recorder's temporal history (penumbra_recorder_record_view), on a still view of the host's
// points (the grid seen from above: the camera's matrix maps each point to its own pixel's centre).
// Oracle: penumbra_visibility at 1024 samples on the same points (another seed), the converged V.
// Eight recordings of 4 samples: the error must fall below half the first's (it holds 32 samples);
// a ninth with the camera panned by 3 pixels keeps it (the points are found through the previous
// camera: under half the first's still); after penumbra_recorder_history_drop the next is back near
// the first's (a history of one frame).
// A recording cut short (INCOMPLETE) is recorded again and counted once (host_frame's loop).
// And the misuses: record without a view on a recorder with a history, with a view on one without,
// a NULL view, a history too long, a pixel angle of 0.
static void check_history(penumbra_context *ctx, penumbra_scene *scene, const penumbra_light *light, const float *p4,
                          const float *n4, const pn_gpu_image *img, const pn_gbuffer_upload *up, pn_gpu_buffer *out)
{
    float p3[W * H * 3], n3[W * H * 3], ref[W * H], v[W * H];
    for (int i = 0; i < W * H; i++)
        for (int k = 0; k < 3; k++)
            p3[3 * i + k] = p4[4 * i + k], n3[3 * i + k] = n4[4 * i + k];
    penumbra_visibility_desc vd = {.mode = "exact", .spp = 1024, .seed = 99, .width = W};
    penumbra_status st = penumbra_visibility(ctx, scene, &vd, light, 1, p3, n3, W * H, ref);
    CHECK_MSG(st == PENUMBRA_OK, "%s", penumbra_context_error(ctx));
    // Pixel i at x = -2.5 + 5 i / (W - 1) and row j at z = -2.5 + 5 j / (H - 1), seen from 10 above:
    // clip = (a x + b, c z + d, 0.5, 1) puts each point at its pixel's centre (Vulkan: row 0 at the
    // top, so z grows downward in the image as j does).
    penumbra_view view = {.eye = {0, 10, 0}, .forward = {0, -1, 0}, .pixel_angle = 5.0f / (W - 1) / 10.0f};
    float a = 2.0f * (W - 1) / (5.0f * W), c = 2.0f * (H - 1) / (5.0f * H);
    view.view_proj[0] = a, view.view_proj[12] = 2.5f * a + 1.0f / W - 1.0f;
    view.view_proj[9] = c, view.view_proj[13] = 2.5f * c + 1.0f / H - 1.0f;
    view.view_proj[14] = 0.5f, view.view_proj[15] = 1.0f;
    penumbra_recorder *rec = NULL, *plain = NULL;
    penumbra_recorder_desc rd = {.width = W, .height = H, .position = img[0].view, .normal = img[1].view,
                                 .visibility = img[3].view, .shadow = {.mode = "exact", .spp = 4}, .light = *light,
                                 .history_frames = 16};
    st = penumbra_recorder_create(ctx, scene, &rd, &rec);
    CHECK_MSG(st == PENUMBRA_OK, "penumbra_recorder_create with a history: %s", penumbra_context_error(ctx));
    if (st != PENUMBRA_OK)
        return;
    // Frame 8: the camera panned by three pixels to the right (each pixel shows the point the pixel
    // three to its right showed; the last columns new points beyond the grid, the matrix shifted to
    // match). Three: a history taken from the same pixel instead would lie 3 footprints away, which
    // the surface test refuses (history.comp's NEAR), so only the reprojection keeps it.
    static float p4_pan[W * H * 4];
    memcpy(p4_pan, p4, sizeof p4_pan);
    for (int i = 0; i < W * H; i++)
        p4_pan[4 * i] += 3 * 5.0f / (W - 1);
    penumbra_view pan = view;
    pan.view_proj[12] -= 3 * 2.0f / W;
    pn_gbuffer_upload up_pan;
    if (pn_gbuffer_upload_create(&g_host, W, H, p4_pan, n4, &up_pan) != PN_OK) {
        CHECK_MSG(false, "the panned frame's upload");
        penumbra_recorder_destroy(rec);
        return;
    }
    float ref_pan[W * H], p3_pan[W * H * 3];
    for (int i = 0; i < W * H; i++)
        for (int k = 0; k < 3; k++)
            p3_pan[3 * i + k] = p4_pan[4 * i + k];
    st = penumbra_visibility(ctx, scene, &vd, light, 1, p3_pan, n3, W * H, ref_pan);
    CHECK_MSG(st == PENUMBRA_OK, "%s", penumbra_context_error(ctx));
    double mae[10];
    for (int f = 0; f < 10; f++) {
        if (f == 9)
            CHECK(penumbra_recorder_history_drop(rec) == PENUMBRA_OK);
        bool panned = f >= 8;
        if (!host_frame(rec, 1, panned ? &pan : &view, img, panned ? &up_pan : up, out)) {
            CHECK_MSG(false, "the history's frame %d", f);
            break;
        }
        memcpy(v, out->mapped, sizeof v);
        mae[f] = points_mae(v, panned ? ref_pan : ref, p4);
    }
    pn_gbuffer_upload_destroy(&g_host, &up_pan);
    fprintf(stderr, "recorder history (exact, 4 spp a frame): MAE against 1024 spp, frame 0 %.5f, 3 %.5f, 7 %.5f; "
                    "panned 3 pixels %.5f; after a drop %.5f\n", mae[0], mae[3], mae[7], mae[8], mae[9]);
    CHECK_MSG(mae[0] > 0 && mae[7] < 0.5 * mae[0], "the history does not add up: %.5f after 8 frames, %.5f the first",
              mae[7], mae[0]);
    CHECK_MSG(mae[8] < 0.5 * mae[0], "the pan lost the history: %.5f, the first %.5f", mae[8], mae[0]);
    CHECK_MSG(mae[9] > 0.6 * mae[0] && mae[9] > 1.5 * mae[8], "the drop kept the history: %.5f, the first %.5f",
              mae[9], mae[0]);
    // Misuses, each refused with its reason.
    VkCommandBuffer cmd;
    if (pn_gpu_begin_once(&g_host, &cmd) == PN_OK) {
        CHECK(penumbra_recorder_record(rec, cmd, 1) == PENUMBRA_ERROR_INVALID_ARGUMENT);
        CHECK(strstr(penumbra_context_error(ctx), "record_view"));
        CHECK(penumbra_recorder_record_view(rec, cmd, 1, NULL) == PENUMBRA_ERROR_INVALID_ARGUMENT);
        penumbra_view flat = view;
        flat.pixel_angle = 0;
        CHECK(penumbra_recorder_record_view(rec, cmd, 1, &flat) == PENUMBRA_ERROR_INVALID_ARGUMENT);
        CHECK(strstr(penumbra_context_error(ctx), "pixel_angle"));
        rd.history_frames = 0;
        if (penumbra_recorder_create(ctx, scene, &rd, &plain) == PENUMBRA_OK) {
            CHECK(penumbra_recorder_record_view(plain, cmd, 1, &view) == PENUMBRA_ERROR_INVALID_ARGUMENT);
            CHECK(strstr(penumbra_context_error(ctx), "no history"));
        }
        pn_gpu_submit_wait(&g_host, cmd); // nothing recorded into it
    }
    rd.history_frames = 5000;
    penumbra_recorder *long_one = NULL;
    CHECK(penumbra_recorder_create(ctx, scene, &rd, &long_one) == PENUMBRA_ERROR_INVALID_ARGUMENT && !long_one);
    CHECK(strstr(penumbra_context_error(ctx), "at most"));
    CHECK(penumbra_recorder_history_drop(NULL) == PENUMBRA_ERROR_INVALID_ARGUMENT);
    penumbra_recorder_destroy(plain);
    penumbra_recorder_destroy(rec);
}

int main(void)
{
    pn_gpu_device_desc dd = pn_gpu_device_desc_from_env();
    if (pn_gpu_device_create(&dd, &g_host) != PN_OK)
        return 1;
    const char *exts[PN_GPU_OPTIONAL_EXTENSIONS];
    uint32_t ext_count = pn_gpu_device_extensions(&g_host, exts);
    penumbra_context *ctx = NULL;
    penumbra_vulkan_desc vk = {.instance = g_host.instance, .physical_device = g_host.physical, .device = g_host.device,
                               .queue_family = g_host.queue_family, .queue = g_host.queue,
                               .enabled_extensions = exts, .enabled_extension_count = ext_count};
    penumbra_status st = penumbra_context_create_vulkan(&vk, NULL, &ctx);
    CHECK_MSG(st == PENUMBRA_OK, "penumbra_context_create_vulkan: %s", penumbra_context_error(ctx));
    CHECK(strcmp(penumbra_context_device(ctx), g_host.props.deviceName) == 0);

    // The host's points: a grid over the default scene's floor, every seventh pixel left empty.
    static float p4[W * H * 4], n4[W * H * 4];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int i = y * W + x;
            p4[4 * i + 0] = -2.5f + 5.0f * x / (W - 1);
            p4[4 * i + 2] = -2.5f + 5.0f * y / (H - 1);
            p4[4 * i + 3] = i % 7 == 3 ? 0.0f : 1.0f;
            n4[4 * i + 1] = 1;
        }
    pn_gpu_image img[4] = {0}; // P, N, (unused), V
    const VkImageUsageFlags IN = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    bool ok = pn_gpu_image_create(&g_host, &(pn_gpu_image_desc){"host P", VK_FORMAT_R32G32B32A32_SFLOAT, W, H, 1, IN}, &img[0]) == PN_OK &&
              pn_gpu_image_create(&g_host, &(pn_gpu_image_desc){"host N", VK_FORMAT_R32G32B32A32_SFLOAT, W, H, 1, IN}, &img[1]) == PN_OK &&
              pn_gpu_image_create(&g_host, &(pn_gpu_image_desc){"host V", VK_FORMAT_R32_SFLOAT, W, H, 1,
                                                                VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                                                                    VK_IMAGE_USAGE_TRANSFER_DST_BIT}, &img[3]) == PN_OK;
    pn_gbuffer_upload up;
    pn_gpu_buffer out;
    ok = ok && pn_gbuffer_upload_create(&g_host, W, H, p4, n4, &up) == PN_OK &&
         pn_gpu_buffer_create(&g_host, "host readback", W * H * sizeof(float), VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                              PN_GPU_HOST_READBACK, &out) == PN_OK;
    CHECK(ok);
    penumbra_scene *scene = NULL;
    penumbra_light light;
    uint32_t count;
    if (ok && st == PENUMBRA_OK && penumbra_scene_load(ctx, "builtin:default", &scene) == PENUMBRA_OK &&
        penumbra_scene_lights(scene, &light, 1, &count) == PENUMBRA_OK) {
        compare_mode(ctx, scene, "exact", &light, p4, n4, img, &up, &out);
        check_history(ctx, scene, &light, p4, n4, img, &up, &out);
        if (g_host.ray_query)
            compare_mode(ctx, scene, "rayquery", &light, p4, n4, img, &up, &out);
        else
            fprintf(stderr, "rayquery: the device has no ray queries; exact alone\n");
        // A recorder needs the host's device, and the host's views.
        penumbra_context *own = NULL;
        penumbra_recorder *rec = NULL;
        penumbra_recorder_desc bad = {.width = W, .height = H, .position = img[0].view, .normal = img[1].view,
                                      .visibility = img[3].view, .light = light};
        CHECK(penumbra_recorder_create(ctx, scene, &(penumbra_recorder_desc){.width = W, .height = H, .light = light}, &rec) ==
              PENUMBRA_ERROR_INVALID_ARGUMENT);
        CHECK(strstr(penumbra_context_error(ctx), "NULL view"));
        if (penumbra_context_create(NULL, &own) == PENUMBRA_OK) {
            penumbra_scene *other = NULL;
            CHECK(penumbra_scene_load(own, "builtin:plane", &other) == PENUMBRA_OK);
            CHECK(penumbra_recorder_create(own, other, &bad, &rec) == PENUMBRA_ERROR_INVALID_ARGUMENT);
            CHECK(strstr(penumbra_context_error(own), "penumbra_context_create_vulkan"));
            CHECK(penumbra_recorder_create(ctx, other, &bad, &rec) == PENUMBRA_ERROR_INVALID_ARGUMENT);
            penumbra_scene_destroy(other);
        }
        penumbra_context_destroy(own);
        CHECK(penumbra_recorder_record(NULL, VK_NULL_HANDLE, 0) == PENUMBRA_ERROR_INVALID_ARGUMENT);
        penumbra_recorder_destroy(NULL);
    } else {
        CHECK_MSG(false, "scene: %s", penumbra_context_error(ctx));
    }
    penumbra_scene_destroy(scene);
    penumbra_context_destroy(ctx);
    // The host's device outlives the context: one more submit of its own.
    VkCommandBuffer cmd;
    CHECK(pn_gpu_begin_once(&g_host, &cmd) == PN_OK && pn_gpu_submit_wait(&g_host, cmd) == PN_OK);
    pn_gbuffer_upload_destroy(&g_host, &up);
    pn_gpu_buffer_destroy(&g_host, &out);
    for (int i = 0; i < 4; i++)
        pn_gpu_image_destroy(&g_host, &img[i]);
    pn_gpu_device_destroy(&g_host);
    CHECK_MSG(g_host.validation_messages == 0, "the validation layer reported %u message(s)", g_host.validation_messages);
    return pn_test_result();
}
