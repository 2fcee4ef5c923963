// The N-tree pools on the GPU: device-local buffers (nodes, tree, line spaces, leaf planes) reached by
// buffer device address.
#pragma once
#include "accel/objects.h"
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

// Per-object trees on the GPU (accel/objects.h): every tree's pools, and the table of objects with
// the top-level BVH over them.
typedef struct pn_gpu_objects {
    uint32_t tree_count;
    pn_gpu_pools *trees;
    uint32_t count;                      // objects in the table
    pn_gpu_buffer table, top, top_ids;   // pn_gpu_object per object, the BVH, its object indices
} pn_gpu_objects;

pn_result pn_gpu_objects_create(pn_gpu_device *dev, const pn_objects *objects, pn_gpu_objects *out);
// Uploads the table and the top level again after pn_objects_update (the trees stay). The device
// must be idle (the renderer waits for every frame).
pn_result pn_gpu_objects_update(pn_gpu_device *dev, const pn_objects *objects, pn_gpu_objects *g);
void pn_gpu_objects_destroy(pn_gpu_device *dev, pn_gpu_objects *g);
