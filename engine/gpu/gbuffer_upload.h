// An external G-buffer for shader-level benchmarking (bench --shader shadow --gbuffer): P and N
// copied in from host memory instead of rasterised, albedo cleared to black. Used by the bench only.
#pragma once
#include "gpu/gbuffer_pass.h"

typedef struct pn_gbuffer_upload {
    pn_gpu_buffer buffer; // P then N, width*height RGBA floats each
} pn_gbuffer_upload;

// Copies P and N (width*height RGBA floats each, P.w = 1 where geometry is) to a staging buffer.
pn_result pn_gbuffer_upload_create(pn_gpu_device *dev, uint32_t width, uint32_t height, const float *p, const float *n,
                                   pn_gbuffer_upload *out);
void pn_gbuffer_upload_destroy(pn_gpu_device *dev, pn_gbuffer_upload *u);

// Records what pn_gbuffer_pass_record would, from the upload: the targets end in GENERAL layout,
// written and visible to compute shaders and copies. Depth is not touched.
void pn_gbuffer_upload_record(VkCommandBuffer cmd, const pn_gbuffer_upload *u, const pn_gbuffer_targets *t);
