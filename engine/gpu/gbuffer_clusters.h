// Clusters of the G-buffer pass: each draw's raster order cut into runs of PN_CLUSTER_TRIANGLES
// triangles, each with its bounds (box, sphere) and the cone of its triangles' normals, so that per
// frame the pass skips the clusters that cannot put a fragment on the image: those wholly outside
// the view frustum (every draw), and those whose triangles all face away from the eye (the draws
// that cull their back faces: gbuffer_cull.h). The rest is drawn in the order it had, a draw per run
// of clusters kept, so every pixel is what it was (the rasterizer would have made nothing of what is
// skipped; but see facing_away in gbuffer_clusters.c for sub-pixel triangles at a silhouette). The
// vertex shader and the triangle setup no longer run for what is skipped, which on llvmpipe is most
// of the pass on a big mesh (engine/gpu/README.md, "Clusters in the G-buffer pass").
#pragma once
#include <stdbool.h>
#include <stddef.h>

#include "core/error.h"
#include "interface.h"
#include "scene/scene.h"

enum { PN_CLUSTER_TRIANGLES = 64 }; // the dragon: 64 skip 33% of its triangles, 256 18% (README)

typedef struct pn_gbuffer_cluster {
    uint32_t first_index, index_count; // into the pass's (raster-ordered) index buffer
    float min[3], max[3];              // its vertices' box
    float center[3], radius;           // bounding sphere: the box's centre, rounded outwards
    float axis[3], cutoff;             // normal cone: back-facing test below; cutoff 1: never
} pn_gbuffer_cluster;

typedef struct pn_gbuffer_clusters {
    pn_gbuffer_cluster *items;
    uint32_t *first; // per draw: its clusters are items[first[d] .. first[d + 1]); draw_count + 1
    uint32_t draw_count;
} pn_gbuffer_clusters;

// The clusters of every draw of s over `indices` (the raster order: s's index layout, per draw
// reordered within its range). PN_ERR_MEMORY where they do not fit.
pn_result pn_gbuffer_clusters_build(const pn_scene *s, const uint32_t *indices, pn_gbuffer_clusters *out);
void pn_gbuffer_clusters_destroy(pn_gbuffer_clusters *c);

// After the scene's vertices moved: draw d's clusters' bounds again (indices as at the build).
void pn_gbuffer_clusters_moved(pn_gbuffer_clusters *c, const pn_scene *s, const uint32_t *indices, uint32_t d);

// One run of kept clusters: a vkCmdDrawIndexed's range.
typedef struct pn_gbuffer_run {
    uint32_t first_index, index_count;
} pn_gbuffer_run;

// Draw d's runs of clusters that may show in an image of width x height seen through `camera`;
// `back`: the draw culls its back faces (its facing-away clusters are skipped too). Writes at most
// one run per cluster into out (sized for the draw's clusters: first[d + 1] - first[d]) and
// returns their count; *kept_triangles: the triangles they hold.
uint32_t pn_gbuffer_clusters_runs(const pn_gbuffer_clusters *c, uint32_t d, const pn_gbuffer_push *camera,
                                  uint32_t width, uint32_t height, bool back, pn_gbuffer_run *out,
                                  uint64_t *kept_triangles);
