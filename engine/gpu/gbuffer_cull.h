// Back faces in the G-buffer pass: which draws may cull them without changing a pixel.
//
// Seen from outside, a closed surface that bounds its solid with outward-facing triangles shows
// only front faces: a ray from the eye crosses it first where it enters the solid. So a draw culls
// its back faces when (a) its triangles, welded by position, use every edge as often one way as the
// other (closed, consistently wound), (b) each connected part has a positive signed volume (wound
// outwards, glTF's counter-clockwise front), (c) its material is single-sided (glTF's default;
// double-sided says both sides are to be seen) and not alpha-masked (a cut-out front face shows
// the inside), and, per frame, (d) its box lies wholly beyond the near plane (the eye is outside
// it and the near plane clips none of it). A single-sided material alone does not decide: files
// without materials (all of ../shared/assets) are single-sided by default, and Sibenik's inward-
// wound walls would open, so open or inward meshes keep drawing their back faces as before.
// Exact on closed surfaces that do not cut themselves, but for depth ties at silhouettes (where a
// front and a back triangle meet at nearly one depth). Where a closed mesh cuts itself (a fold
// turned inside out, as decimations leave), the fold's back faces vanish, as its single-sided
// material says they should: measured in engine/gpu/README.md (the G-buffer pass).
#pragma once
#include <stdbool.h>

#include "core/error.h"
#include "scene/scene.h"

typedef struct pn_gbuffer_cull {
    bool closed;          // (a) to (c) at the analysis
    bool outward;         // the signed volume still has the analysis's sign (a move may mirror it)
    double volume;        // the draw's signed volume at the analysis
    uint32_t first, last; // the draw's vertex range
    float min[3], max[3]; // its vertices' bounds now
} pn_gbuffer_cull;

// Analyses draw d of s (a, b and c above). PN_ERR_MEMORY where its tables do not fit.
pn_result pn_gbuffer_cull_analyse(const pn_scene *s, const pn_draw *d, pn_gbuffer_cull *out);

// After the scene's vertices moved (by an affine map per draw: node animation, object moves):
// the bounds again, and whether the volume kept its sign (a mirroring map turns every part inside
// out at once, since each part's volume scales by the map's determinant).
void pn_gbuffer_cull_moved(const pn_scene *s, const pn_draw *d, pn_gbuffer_cull *c);

// Whether the draw culls its back faces seen from `eye` looking along unit `forward` with the
// near plane at view depth `znear` (d above), with a margin for the rasterizer's rounding.
bool pn_gbuffer_cull_back(const pn_gbuffer_cull *c, const float eye[3], const float forward[3], float znear);
