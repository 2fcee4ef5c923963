// Leaf planes (ls-plane mode): a filled leaf of the N-tree's last level is summarised by the plane
// that best fits its triangles clipped to it (area-weighted normal and centroid) and by the
// half-thickness of the slab around that plane that holds every clipped triangle, so a ray that
// misses the slab misses the leaf's triangles. One 32-bit word per leaf, decoded the same way by
// the shader (shadow_linespace.comp, leaf_plane_blocks):
//   bits 0..13:  the unit normal m, octahedral, 7 + 7 bits holding 0..126 (so that the axes, the
//                normals of walls and floors, are exact);
//   bits 14..22: the plane's offset from the leaf's centre along m, in leaves, mapped from
//                [-sqrt(3)/2, sqrt(3)/2] to 0..511;
//   bits 23..31: the slab's half-thickness in 1/256 leaf, rounded up, at least 1; PN_PLANE_SOLID
//                (511, more than the leaf's half-diagonal) when no thinner slab holds them: the
//                leaf then blocks like a filled leaf.
// An empty leaf's word is 0. The thickness is measured about the decoded (quantised) plane, so the
// slab holds the triangles up to the float rounding of the shader's own test.
#pragma once
#include <stdint.h>

#define PN_PLANE_SOLID (511u << 23)

// The word of the triangles ids[0 .. count) of tri (9 floats each) in the leaf [lo, lo + size]^3,
// clipped to that box grown by `grow` (the slack of the occupancy test that put them in the leaf).
uint32_t pn_leaf_plane_fit(const float (*tri)[9], const uint32_t *ids, uint32_t count, const double lo[3], double size,
                           double grow);

// The plane of a word: unit normal m and offset from the leaf's centre, in leaves; returns the slab's
// half-thickness in leaves (0 for an empty leaf).
double pn_leaf_plane_decode(uint32_t word, double m[3], double *offset);
