// The N-tree pools on the GPU: device-local buffers (nodes, tree, line spaces, leaf planes) reached by
// buffer device address.
#pragma once
#include "accel/pools.h"
#include "gpu/resources.h"

typedef struct pn_gpu_pools {
    pn_gpu_buffer nodes, tree, linespace, planes;
    bool has_planes;       // the tree was built with leaf planes (else `planes` is a few zero bytes)
    pn_gpu_tree_info info; // with the pools' addresses filled in
} pn_gpu_pools;

// Uploads the pools. Refuses (PN_ERR_MEMORY, with the sizes in the message) a pool larger than the
// device's maxMemoryAllocationSize instead of truncating it.
pn_result pn_gpu_pools_create(pn_gpu_device *dev, const pn_pools *pools, pn_gpu_pools *out);
void pn_gpu_pools_destroy(pn_gpu_device *dev, pn_gpu_pools *p);
