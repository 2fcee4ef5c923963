// Embree 3 as an independent exact tracer of penumbra's own shadow rays: the bench's CPU peer
// (bench_peer.c times it) and the tests' oracle (test_exact_oracle.c checks exact ray for ray,
// test_alpha_oracle.c exact and exact-ls over alpha-masked casters).
// The only header that stands for Embree; the rest sees opaque handles.
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "scene/scene.h"

typedef struct pn_embree pn_embree;             // an Embree device
typedef struct pn_embree_scene pn_embree_scene; // Embree's BVH of one pn_scene

// An Embree device, or NULL when Embree could not start.
pn_embree *pn_embree_create(void);
void pn_embree_destroy(pn_embree *e);

// What pn_embree_scene_create_desc builds; zero is the default.
typedef struct pn_embree_scene_desc {
    // Every triangle blocks, alpha masks or not: what a tracer without masks answers (the tests'
    // control that a mask changes the answer).
    bool opaque;
} pn_embree_scene_desc;

// Builds Embree's BVH (high quality) over the scene's triangles, sharing its buffers and reading
// its materials and textures while it traces: the scene must outlive it and stay unchanged. A hit
// on an alpha-masked triangle (pn_material.alpha_cutoff > 0) whose texel is cut out does not block
// (an occlusion filter, with its own reading of glTF's rule: the nearest texel, repeating); a scene
// without masks builds as it did before filters. NULL on failure.
pn_embree_scene *pn_embree_scene_create(pn_embree *e, const pn_scene *scene);
pn_embree_scene *pn_embree_scene_create_desc(pn_embree *e, const pn_scene *scene, const pn_embree_scene_desc *desc);
void pn_embree_scene_destroy(pn_embree_scene *s);
double pn_embree_scene_build_ms(const pn_embree_scene *s);

// Traces the valid rays of pixels [begin, end) of a ray dump (the exact frame's: px origins, each
// (x, y, z, 1 where the pixel has geometry), then px x spp light samples (x, y, z, flag bits: 1
// valid, 2 blocked on the GPU); render --ray-dump writes the same after its header), each from its
// origin to its light sample as the shader does (t in [0, 1]). Safe to call from several threads at
// once. Per ray, when `blocked` is not NULL, blocked[p * spp + k] = 1 if Embree finds it blocked,
// else 0 (invalid rays: 0). Returns the rays traced; *blocked_count (may be NULL) the blocked ones.
uint64_t pn_embree_trace_dump(const pn_embree_scene *s, const float *dump, uint64_t px, uint32_t spp, uint64_t begin,
                              uint64_t end, uint8_t *blocked, uint64_t *blocked_count);
