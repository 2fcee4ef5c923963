// The scene's triangles in a device-built acceleration structure (VK_KHR_acceleration_structure):
// one bottom level over every triangle in Morton order (accel/morton.h), one top-level instance.
// Traced by the rayquery shadow mode through VK_KHR_ray_query, and by rtpipeline through
// VK_KHR_ray_tracing_pipeline. Needs pn_gpu_device.accel.
// An opaque scene's bottom level is one opaque geometry. With alpha-masked triangles (accel/alpha.h)
// it has two, each in Morton order: the opaque triangles (still opaque: the query commits their
// hits itself) and the masked ones, not opaque, whose hits the shader (rtpipeline: its any-hit
// shader) tests against their texels.
#pragma once
#include "gpu/resources.h"
#include "scene/scene.h"

typedef struct pn_gpu_tlas {
    VkAccelerationStructureKHR blas, tlas;
    pn_gpu_buffer vertices, blas_buffer, instances, tlas_buffer;
    // With masked triangles: the scene's index (the triangle pool's) of each primitive of the
    // masked geometry, one uint each, reached by address (ShadowParams.masked_tris); else empty.
    pn_gpu_buffer masked_tris;
    uint32_t masked; // primitives of the masked geometry (0: an opaque scene)
    uint64_t bytes;  // the structures' and their inputs' buffers
    double build_ms; // Morton sort and device build, wall clock
    double sort_ms;  // of which the Morton sort
} pn_gpu_tlas;

// Sorts, uploads and builds; waits until the structure is ready for compute shaders. Logs and
// fails (PN_ERR_UNSUPPORTED) on a device without acceleration structures (pn_gpu_device.accel).
pn_result pn_gpu_tlas_create(pn_gpu_device *dev, const pn_scene *scene, pn_gpu_tlas *out);
void pn_gpu_tlas_destroy(pn_gpu_device *dev, pn_gpu_tlas *t);
