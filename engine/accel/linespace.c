// Line spaces: the shafts between a node's patches, and which of them the node's geometry blocks.
#include "accel/linespace.h"

#include <stdlib.h>
#include <string.h>

#include "core/parallel.h"

void pn_ls_shaft_patches(int n, uint32_t bit, uint32_t *a, uint32_t *b)
{
    uint32_t n2 = (uint32_t)(n * n), n4 = n2 * n2;
    uint32_t pair = bit / n4, rest = bit % n4;
    int f = 0, g = 1;
    for (int ff = 0; ff < 6; ff++)
        for (int gg = ff + 1; gg < 6; gg++)
            if (pn_ls_face_pair(ff, gg) == pair)
                f = ff, g = gg;
    *a = (uint32_t)f * n2 + rest / n2;
    *b = (uint32_t)g * n2 + rest % n2;
}

// The patch's closed box in child-cell units: flat along its face's axis.
static void patch_box(int n, uint32_t p, int lo[3], int hi[3])
{
    uint32_t n2 = (uint32_t)(n * n);
    int f = (int)(p / n2), rest = (int)(p % n2);
    int k = f / 2, u = rest % n, v = rest / n;
    lo[k] = hi[k] = (f & 1) ? n : 0;
    lo[(k + 1) % 3] = u, hi[(k + 1) % 3] = u + 1;
    lo[(k + 2) % 3] = v, hi[(k + 2) % 3] = v + 1;
}

// The shaft's slice at parameter t in [0,1] is the box (1-t)*A + t*B (Minkowski combination of two
// axis-aligned boxes), so "the shaft meets box C" is: some t in [0,1] satisfies, on every axis,
//   (1-t)*A.lo + t*B.lo <= C.hi   and   (1-t)*A.hi + t*B.hi >= C.lo,
// linear in t. Intersecting those half-lines is exact in integers (fractions compared by cross
// multiplication, all terms below 2^10), hence no rounding and no leak.
static bool shaft_hits(const int alo[3], const int ahi[3], const int blo[3], const int bhi[3], const int clo[3],
                       const int chi[3])
{
    // t interval [lo_num/lo_den, hi_num/hi_den], denominators positive.
    int lo_num = 0, lo_den = 1, hi_num = 1, hi_den = 1;
    for (int k = 0; k < 3; k++) {
        // (1) alo + t*(blo - alo) <= chi     (2) ahi + t*(bhi - ahi) >= clo  <=>  -ahi - t*(bhi-ahi) <= -clo
        int slope[2] = {blo[k] - alo[k], -(bhi[k] - ahi[k])};
        int rhs[2] = {chi[k] - alo[k], -clo[k] + ahi[k]};
        for (int i = 0; i < 2; i++) {
            int s = slope[i], r = rhs[i];
            if (s == 0) {
                if (r < 0)
                    return false;
            } else if (s > 0) { // t <= r/s
                if ((long)r * hi_den < (long)hi_num * s)
                    hi_num = r, hi_den = s;
            } else { // t >= r/s = (-r)/(-s)
                if ((long)(-r) * lo_den > (long)lo_num * (-s))
                    lo_num = -r, lo_den = -s;
            }
        }
    }
    return (long)lo_num * hi_den <= (long)hi_num * lo_den;
}

bool pn_ls_shaft_hits_box(int n, uint32_t a, uint32_t b, const int lo[3], const int hi[3])
{
    int alo[3], ahi[3], blo[3], bhi[3];
    patch_box(n, a, alo, ahi);
    patch_box(n, b, blo, bhi);
    return shaft_hits(alo, ahi, blo, bhi, lo, hi);
}

typedef struct mask_job {
    int n;
    pn_ls_masks *m;
} mask_job;

// Sets the bits of all shafts from patch `a` to the patches of face g in [u0,u1) x [v0,v1) that hit
// cell box C: a shaft to a block of patches contains the shafts to each of them, so a block whose
// shaft misses C is skipped whole. This keeps N = 16 (15*N^4*N^3 = 4e9 pairs) fast.
static void mask_block(int n, const int alo[3], const int ahi[3], uint32_t a, int g, int u0, int u1, int v0, int v1,
                       const int clo[3], const int chi[3], uint64_t *mask)
{
    int k = g / 2, blo[3], bhi[3];
    blo[k] = bhi[k] = (g & 1) ? n : 0;
    blo[(k + 1) % 3] = u0, bhi[(k + 1) % 3] = u1;
    blo[(k + 2) % 3] = v0, bhi[(k + 2) % 3] = v1;
    if (!shaft_hits(alo, ahi, blo, bhi, clo, chi))
        return;
    if (u1 - u0 == 1 && v1 - v0 == 1) {
        uint32_t bit = pn_ls_shaft(n, a, pn_ls_patch(n, g, u0, v0));
        mask[bit >> 6] |= 1ull << (bit & 63);
        return;
    }
    if (u1 - u0 >= v1 - v0) {
        int um = (u0 + u1) / 2;
        mask_block(n, alo, ahi, a, g, u0, um, v0, v1, clo, chi, mask);
        mask_block(n, alo, ahi, a, g, um, u1, v0, v1, clo, chi, mask);
    } else {
        int vm = (v0 + v1) / 2;
        mask_block(n, alo, ahi, a, g, u0, u1, v0, vm, clo, chi, mask);
        mask_block(n, alo, ahi, a, g, u0, u1, vm, v1, clo, chi, mask);
    }
}

static void mask_range(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    mask_job *j = ctx;
    int n = j->n;
    uint32_t n2 = (uint32_t)(n * n);
    for (uint64_t c = begin; c < end; c++) {
        int clo[3] = {(int)(c % (uint64_t)n), (int)(c / (uint64_t)n % (uint64_t)n), (int)(c / n2)};
        int chi[3] = {clo[0] + 1, clo[1] + 1, clo[2] + 1};
        uint64_t *mask = j->m->bits + c * j->m->words64;
        for (uint32_t a = 0; a < 6 * n2; a++) {
            int f = (int)(a / n2), alo[3], ahi[3];
            patch_box(n, a, alo, ahi);
            for (int g = f + 1; g < 6; g++)
                mask_block(n, alo, ahi, a, g, 0, n, 0, n, clo, chi, mask);
        }
    }
}

pn_result pn_ls_masks_create(int n, pn_ls_masks *out)
{
    memset(out, 0, sizeof *out);
    out->n = n;
    out->words64 = pn_ls_words64(n);
    size_t cells = (size_t)n * n * n;
    out->bits = calloc(cells * out->words64, sizeof(uint64_t));
    if (!out->bits)
        return PN_ERR_MEMORY;
    mask_job j = {n, out};
    pn_parallel_for(cells, 1, mask_range, &j);
    return PN_OK;
}

void pn_ls_masks_destroy(pn_ls_masks *m)
{
    free(m->bits);
    memset(m, 0, sizeof *m);
}
