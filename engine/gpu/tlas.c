// The scene's triangles in a device-built acceleration structure, for --mode rayquery and rtpipeline.
#include "gpu/tlas.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/alpha.h"
#include "accel/morton.h"
#include "core/log.h"
#include "core/timer.h"

static const VkBufferUsageFlags BUILD_INPUT =
    VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
static const VkBufferUsageFlags STORAGE =
    VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;

// A level's geometries at most: the bottom level's opaque triangles and its alpha-masked ones.
#define MAX_GEOMETRIES 2

// Sizes one level of `count` (<= MAX_GEOMETRIES) geometries (primitives[i] each), creates its structure and scratch,
// and records its build.
static pn_result build_level(pn_gpu_device *dev, VkCommandBuffer cmd, const char *level, VkAccelerationStructureTypeKHR type,
                             const VkAccelerationStructureGeometryKHR *geom, uint32_t count, const uint32_t *primitives,
                             pn_gpu_buffer *storage, VkAccelerationStructureKHR *out, pn_gpu_buffer *scratch)
{
    VkAccelerationStructureBuildGeometryInfoKHR bi = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR,
        .type = type,
        .flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR,
        .mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR,
        .geometryCount = count,
        .pGeometries = geom,
    };
    uint64_t total = 0;
    for (uint32_t i = 0; i < count; i++)
        total += primitives[i];
    VkAccelerationStructureBuildSizesInfoKHR size = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
    dev->as.build_sizes(dev->device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &bi, primitives, &size);
    VkDeviceSize max_buffer = pn_gpu_device_max_buffer(dev);
    if (size.accelerationStructureSize > max_buffer || size.buildScratchSize > max_buffer) {
        pn_error("the %s acceleration structure of %llu primitives needs %.1f MiB (build scratch %.1f MiB), more than "
                 "one buffer of this device can hold (%.1f MiB)",
                 level, (unsigned long long)total, size.accelerationStructureSize / 1048576.0,
                 size.buildScratchSize / 1048576.0, max_buffer / 1048576.0);
        return PN_ERR_MEMORY;
    }
    char what[96];
    snprintf(what, sizeof what, "%s acceleration structure", level);
    PN_TRY(pn_gpu_buffer_create(dev, what, size.accelerationStructureSize, STORAGE, PN_GPU_DEVICE_LOCAL, storage));
    VkAccelerationStructureCreateInfoKHR ci = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR,
        .buffer = storage->buffer,
        .size = size.accelerationStructureSize,
        .type = type,
    };
    VkResult vr = pn_gpu_fault(dev, "vkCreateAccelerationStructureKHR", what, 0) ? VK_ERROR_OUT_OF_DEVICE_MEMORY
                                                                                 : dev->as.create(dev->device, &ci, NULL, out);
    if (vr != VK_SUCCESS) {
        *out = VK_NULL_HANDLE;
        pn_error("vkCreateAccelerationStructureKHR failed for the %s: %s", what, pn_vk_result_str(vr));
        return vr == VK_ERROR_OUT_OF_DEVICE_MEMORY || vr == VK_ERROR_OUT_OF_HOST_MEMORY ? PN_ERR_MEMORY : PN_ERR_VULKAN;
    }
    // Scratch addresses must be aligned; the buffer is grown by the alignment to leave room.
    VkDeviceSize align = dev->as_props.minAccelerationStructureScratchOffsetAlignment;
    align = align ? align : 1;
    snprintf(what, sizeof what, "build scratch of the %s acceleration structure", level);
    PN_TRY(pn_gpu_buffer_create(dev, what, size.buildScratchSize + align,
                                VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT,
                                PN_GPU_DEVICE_LOCAL, scratch));
    bi.dstAccelerationStructure = *out;
    bi.scratchData.deviceAddress = (scratch->address + align - 1) / align * align;
    VkAccelerationStructureBuildRangeInfoKHR range[MAX_GEOMETRIES] = {{0}};
    for (uint32_t i = 0; i < count; i++)
        range[i].primitiveCount = primitives[i];
    const VkAccelerationStructureBuildRangeInfoKHR *ranges = range;
    dev->as.cmd_build(cmd, 1, &bi, &ranges);
    return PN_OK;
}

static VkDeviceAddress as_address(pn_gpu_device *dev, VkAccelerationStructureKHR as)
{
    VkAccelerationStructureDeviceAddressInfoKHR ai = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR,
                                                      .accelerationStructure = as};
    return dev->as.address(dev->device, &ai);
}

static pn_result record(pn_gpu_device *dev, VkCommandBuffer cmd, pn_gpu_tlas *t, uint32_t count, pn_gpu_buffer scratch[2]);

// Moves the alpha-masked triangles of xyz (count triangles; order[i]: the scene's index of the
// i-th) after the opaque ones, each part keeping its Morton order; sets t->masked to their count
// and *ids (malloc'd) to their scene indices: the masked geometry's primitive i is triangle
// (*ids)[i] of the triangle pool, whose record alpha.glsl reads.
static pn_result split_masked(const pn_scene *scene, float *xyz, const uint32_t *order, uint32_t count, pn_gpu_tlas *t,
                              uint32_t **ids)
{
    uint8_t *masked = malloc(pn_scene_triangle_count(scene) + 1);
    float *sorted = malloc((size_t)count * 9 * sizeof *sorted);
    *ids = malloc(((size_t)count + 1) * sizeof **ids);
    if (!masked || !sorted || !*ids) {
        free(masked), free(sorted), free(*ids);
        *ids = NULL;
        return PN_ERR_MEMORY;
    }
    pn_alpha_mark(scene, masked);
    t->masked = 0;
    for (uint32_t i = 0; i < count; i++)
        t->masked += masked[order[i]];
    uint32_t opaque = count - t->masked, at[2] = {0, opaque}; // the next opaque and masked slots
    for (uint32_t i = 0; i < count; i++) {
        uint8_t m = masked[order[i]];
        if (m)
            (*ids)[at[1] - opaque] = order[i];
        memcpy(sorted + 9 * (size_t)at[m], xyz + 9 * (size_t)i, 9 * sizeof *xyz);
        at[m]++;
    }
    memcpy(xyz, sorted, (size_t)count * 9 * sizeof *xyz);
    free(masked), free(sorted);
    return PN_OK;
}

static pn_result build(pn_gpu_device *dev, const pn_scene *scene, pn_gpu_tlas *t, pn_gpu_buffer scratch[2])
{
    uint64_t t0 = pn_time_ns();
    float *xyz;
    uint32_t count, *order = NULL, *ids = NULL;
    // An opaque scene: one opaque geometry in Morton order, nothing else.
    bool masks = pn_alpha_masked_triangles(scene) > 0;
    PN_TRY(pn_triangles_morton(scene, &xyz, masks ? &order : NULL, &count));
    pn_result r = masks ? split_masked(scene, xyz, order, count, t, &ids) : PN_OK;
    free(order);
    t->sort_ms = pn_ms_since(t0);
    if (r == PN_OK && count == 0) {
        pn_error("%s: no triangles to build an acceleration structure of", scene->name);
        r = PN_ERR_INVALID;
    }
    if (r == PN_OK)
        r = pn_gpu_buffer_create_with_data(dev, "acceleration structure's triangles", xyz, (VkDeviceSize)count * 36,
                                           BUILD_INPUT, &t->vertices);
    if (r == PN_OK && t->masked)
        r = pn_gpu_buffer_create_with_data(dev, "acceleration structure's masked triangle ids", ids,
                                           (VkDeviceSize)t->masked * sizeof *ids,
                                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT,
                                           &t->masked_tris);
    free(xyz);
    free(ids);
    PN_TRY(r);

    VkCommandBuffer cmd;
    PN_TRY(pn_gpu_begin_once(dev, &cmd));
    r = record(dev, cmd, t, count, scratch);
    if (r != PN_OK) { // never submitted: freed here (freeing a recording command buffer is valid)
        vkFreeCommandBuffers(dev->device, dev->cmd_pool, 1, &cmd);
        return r;
    }
    PN_TRY(pn_gpu_submit_wait(dev, cmd));
    t->bytes = t->vertices.size + t->masked_tris.size + t->blas_buffer.size + t->instances.size + t->tlas_buffer.size;
    t->build_ms = pn_ms_since(t0);
    return PN_OK;
}

// One geometry of the bottom level: triangles [first, first + count) of t->vertices.
static VkAccelerationStructureGeometryKHR triangles(const pn_gpu_tlas *t, uint32_t first, uint32_t count,
                                                   VkGeometryFlagsKHR flags)
{
    return (VkAccelerationStructureGeometryKHR){
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR,
        .geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR,
        .flags = flags,
        .geometry.triangles = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR,
                               .vertexFormat = VK_FORMAT_R32G32B32_SFLOAT,
                               .vertexData.deviceAddress = t->vertices.address + (VkDeviceAddress)first * 36,
                               .vertexStride = 12,
                               .maxVertex = 3 * count - 1,
                               .indexType = VK_INDEX_TYPE_NONE_KHR},
    };
}

// Records both levels' builds and the barriers that order them and the shadow pass's reads.
static pn_result record(pn_gpu_device *dev, VkCommandBuffer cmd, pn_gpu_tlas *t, uint32_t count, pn_gpu_buffer scratch[2])
{
    // Opaque triangles: any hit blocks a shadow ray, the query commits it without returning to the
    // shader. Masked ones (their own geometry, last): not opaque, so the query hands each hit to
    // the shader, which tests its texel (shadow_rayquery.comp); a hit may be handed over twice
    // (no VK_GEOMETRY_NO_DUPLICATE_ANY_HIT_INVOCATION_BIT_KHR), which gives the same answer. Both
    // faces count (the instance's flags).
    uint32_t opaque = count - t->masked, geometries = 0, primitives[MAX_GEOMETRIES];
    VkAccelerationStructureGeometryKHR tris[MAX_GEOMETRIES];
    if (opaque) {
        primitives[geometries] = opaque;
        tris[geometries++] = triangles(t, 0, opaque, VK_GEOMETRY_OPAQUE_BIT_KHR);
    }
    if (t->masked) {
        primitives[geometries] = t->masked;
        tris[geometries++] = triangles(t, opaque, t->masked, 0);
    }
    PN_TRY(build_level(dev, cmd, "bottom-level", VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, tris, geometries,
                       primitives, &t->blas_buffer, &t->blas, &scratch[0]));
    VkAccelerationStructureInstanceKHR inst = {
        .transform = {.matrix = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}},
        .mask = 0xff,
        .flags = VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR,
        .accelerationStructureReference = as_address(dev, t->blas),
    };
    PN_TRY(pn_gpu_buffer_create_with_data(dev, "acceleration structure's instance", &inst, sizeof inst, BUILD_INPUT,
                                          &t->instances));
    // The bottom level is written before the top level's build reads it.
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = VK_PIPELINE_STAGE_2_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                                           .srcAccessMask = VK_ACCESS_2_ACCELERATION_STRUCTURE_WRITE_BIT_KHR,
                                           .dstStageMask = VK_PIPELINE_STAGE_2_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                                           .dstAccessMask = VK_ACCESS_2_ACCELERATION_STRUCTURE_READ_BIT_KHR},
                       0, NULL);
    // Opacity is the bottom level's (and the instance's) to say; the top level claims it only for
    // an opaque scene, as it always did, lest a driver that reads it hide the masked geometry.
    VkAccelerationStructureGeometryKHR insts = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR,
        .geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR,
        .flags = t->masked ? 0 : VK_GEOMETRY_OPAQUE_BIT_KHR,
        .geometry.instances = {.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR,
                               .data.deviceAddress = t->instances.address},
    };
    PN_TRY(build_level(dev, cmd, "top-level", VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR, &insts, 1, (uint32_t[1]){1},
                       &t->tlas_buffer, &t->tlas, &scratch[1]));
    // Ready for the shadow pass's ray queries (compute) or its ray-tracing pipeline.
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = VK_PIPELINE_STAGE_2_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                                           .srcAccessMask = VK_ACCESS_2_ACCELERATION_STRUCTURE_WRITE_BIT_KHR,
                                           .dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT |
                                                           (dev->ray_pipeline ? VK_PIPELINE_STAGE_2_RAY_TRACING_SHADER_BIT_KHR : 0),
                                           .dstAccessMask = VK_ACCESS_2_ACCELERATION_STRUCTURE_READ_BIT_KHR},
                       0, NULL);
    return PN_OK;
}

pn_result pn_gpu_tlas_create(pn_gpu_device *dev, const pn_scene *scene, pn_gpu_tlas *out)
{
    memset(out, 0, sizeof *out);
    if (!dev->accel) {
        pn_error("%s has no acceleration structures with ray queries or ray-tracing pipelines (VK_KHR_acceleration_"
                 "structure with VK_KHR_ray_query or VK_KHR_ray_tracing_pipeline): modes rayquery and rtpipeline need "
                 "them (Mesa 25's lavapipe has them: see ci/deps.sh)",
                 dev->props.deviceName);
        return PN_ERR_UNSUPPORTED;
    }
    pn_gpu_buffer scratch[2] = {{0}};
    pn_result r = build(dev, scene, out, scratch);
    pn_gpu_buffer_destroy(dev, &scratch[0]);
    pn_gpu_buffer_destroy(dev, &scratch[1]);
    if (r != PN_OK)
        pn_gpu_tlas_destroy(dev, out);
    return r;
}

void pn_gpu_tlas_destroy(pn_gpu_device *dev, pn_gpu_tlas *t)
{
    if (t->tlas)
        dev->as.destroy(dev->device, t->tlas, NULL);
    if (t->blas)
        dev->as.destroy(dev->device, t->blas, NULL);
    pn_gpu_buffer_destroy(dev, &t->tlas_buffer);
    pn_gpu_buffer_destroy(dev, &t->instances);
    pn_gpu_buffer_destroy(dev, &t->blas_buffer);
    pn_gpu_buffer_destroy(dev, &t->vertices);
    pn_gpu_buffer_destroy(dev, &t->masked_tris);
    memset(t, 0, sizeof *t);
}
