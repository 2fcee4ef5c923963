// Line spaces: one bit per shaft between two patches on different faces of a subdivided node.
//
// The one place that defines the index mapping (the GLSL side mirrors it in shaders/glsl/pools.glsl):
//   face f in 0..5:      0 = -x, 1 = +x, 2 = -y, 3 = +y, 4 = -z, 5 = +z   (axis f/2, side f%2)
//   patch (f, u, v):     u along axis (f/2+1)%3, v along axis (f/2+2)%3, 0 <= u, v < N;
//                        the patch is the closed square of the child cell touching face f there
//   patch index p:       f*N^2 + v*N + u                                    in [0, 6N^2)
//   face pair (f, g):    f < g, numbered 0..14 in lexicographic order (0,1) (0,2) ... (4,5)
//   shaft bit of (a, b): with face(a) = f < face(b) = g:
//                        pair(f, g)*N^4 + (a - f*N^2)*N^2 + (b - g*N^2)    in [0, 15N^4)
// Shafts are symmetric, so (b, a) has the same bit; a and b on the same face have none.
// Bit i of a line space is bit i%64 of 64-bit word i/64, which on little-endian machines is also
// bit i%32 of 32-bit word i/32: the GPU reads the same bytes as uint words.
//
// Child cells are numbered c = (z*N + y)*N + x with x, y, z in [0, N).
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "core/error.h"

static inline uint32_t pn_ls_bits(int n) { return 15u * (uint32_t)(n * n * n * n); }
static inline uint32_t pn_ls_words64(int n) { return (pn_ls_bits(n) + 63) / 64; }
static inline uint32_t pn_ls_patch(int n, int face, int u, int v) { return (uint32_t)((face * n + v) * n + u); }

// Index of face pair (f, g), f < g, in 0..14.
static inline uint32_t pn_ls_face_pair(int f, int g) { return (uint32_t)(f * (11 - f) / 2 + (g - f - 1)); }

// Shaft bit of patches a and b, or UINT32_MAX when they lie on the same face.
static inline uint32_t pn_ls_shaft(int n, uint32_t a, uint32_t b)
{
    uint32_t n2 = (uint32_t)(n * n), fa = a / n2, fb = b / n2;
    if (fa == fb)
        return UINT32_MAX;
    if (fa > fb) {
        uint32_t t = a; a = b; b = t;
        t = fa; fa = fb; fb = t;
    }
    return pn_ls_face_pair((int)fa, (int)fb) * n2 * n2 + (a - fa * n2) * n2 + (b - fb * n2);
}

// Inverse of pn_ls_shaft: the two patches of a bit, a on the lower face.
void pn_ls_shaft_patches(int n, uint32_t bit, uint32_t *a, uint32_t *b);

// Exact, closed test of the shaft between patches a and b against the box [lo, hi] given in child
// cell units of the node ([0, N]^3). Touching counts as intersecting, so the test is conservative.
bool pn_ls_shaft_hits_box(int n, uint32_t a, uint32_t b, const int lo[3], const int hi[3]);

// Per-child shaft masks for branching factor n: masks[c * pn_ls_words64(n) + w]. A node's line
// space is the OR of the masks of its filled children. They depend only on n.
typedef struct pn_ls_masks {
    int n;
    uint32_t words64;
    uint64_t *bits; // n^3 * words64 words
} pn_ls_masks;

pn_result pn_ls_masks_create(int n, pn_ls_masks *out);
void pn_ls_masks_destroy(pn_ls_masks *m);

static inline bool pn_ls_get(const uint64_t *ls, uint32_t bit) { return (ls[bit >> 6] >> (bit & 63)) & 1u; }
