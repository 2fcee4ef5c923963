// The N-tree and its line spaces against independent oracles:
//  1. the shaft index mapping is a bijection onto [0, 15N^4), symmetric, inverted by
//     pn_ls_shaft_patches, and equal to the formula documented in accel/linespace.h;
//  2. occupancy equals a brute-force oracle (Sutherland-Hodgman clipping of every triangle against
//     every cell box of every level, double precision, closed boxes) on random soups, adversarial
//     scenes (triangles on cell boundary planes, edges and corners, on the slack-grown boundaries,
//     degenerate triangles, one-triangle scenes) and a real mesh; the exact (slack = 0) occupancy
//     is a subset of the build's;
//  3. line spaces never leak: millions of segments between points on a node's boundary (uniform,
//     snapped to patch edges and corners, lying in cell boundary planes, along cell edges, through
//     cell corners) that touch a filled child, tested exactly in integer arithmetic, have their
//     shaft bit set for every pair of patches holding their end points; some nodes' line spaces
//     and the shaft masks are recomputed from scratch with an independent shaft-box oracle;
//  4. tightness: the share of set bits no sampled segment needed (a figure, not an assertion);
//  5. the packed pools alone reproduce the oracle's occupancy, the node boxes, parents and line
//     spaces;
//  6. the memory limit: one byte below the pools' size refuses the build, exactly the size passes.
// PN_TEST_SCALE (default 1) scales the segment counts (for sanitizer runs).
//
// Over 500 lines because each of its oracles (clipping, brute-force shafts, candidate lists,
// leaf planes) is written here, independent of the code it checks.
#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "accel/linespace.h"
#include "accel/ntree.h"
#include "accel/pools.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/timer.h"
#include "scene/scene.h"
#include "test_util.h"

static double g_scale = 1.0;

// ---------------------------------------------------------------------------------------------
// Random numbers (splitmix64: deterministic, seedable per chunk)

typedef struct rng {
    uint64_t s;
} rng;

static uint64_t rng_next(rng *r)
{
    uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static double rng_u01(rng *r) { return (double)(rng_next(r) >> 11) * 0x1p-53; }
static int64_t rng_range(rng *r, int64_t lo, int64_t hi) // inclusive
{
    return lo + (int64_t)(rng_next(r) % (uint64_t)(hi - lo + 1));
}

static uint64_t ipow(uint64_t b, int e)
{
    uint64_t r = 1;
    while (e-- > 0)
        r *= b;
    return r;
}

// ---------------------------------------------------------------------------------------------
// 1. Index mapping

static void test_index_mapping(void)
{
    uint64_t t0 = pn_time_ns(), pairs_total = 0;
    // The documented face-pair numbering: (0,1) (0,2) ... (4,5) in lexicographic order.
    uint32_t pair_of[6][6];
    uint32_t counter = 0;
    for (int f = 0; f < 6; f++)
        for (int g = f + 1; g < 6; g++) {
            pair_of[f][g] = counter++;
            CHECK_MSG(pn_ls_face_pair(f, g) == pair_of[f][g], "face pair (%d,%d)", f, g);
        }
    for (int n = 2; n <= 16; n++) {
        uint32_t n2 = (uint32_t)(n * n), n4 = n2 * n2, patches = 6 * n2;
        uint32_t bits = pn_ls_bits(n);
        CHECK_MSG((uint64_t)bits == (uint64_t)patches * (5 * n2) / 2, "N=%d: %u bits", n, bits);
        CHECK_MSG(pn_ls_words64(n) == (bits + 63) / 64, "N=%d words", n);
        for (int f = 0; f < 6; f++)
            for (int v = 0; v < n; v++)
                for (int u = 0; u < n; u++)
                    if (pn_ls_patch(n, f, u, v) != (uint32_t)f * n2 + (uint32_t)(v * n + u))
                        CHECK_MSG(0, "N=%d patch (%d,%d,%d)", n, f, u, v);
        uint8_t *hit = calloc(bits, 1);
        uint64_t same_face_bad = 0, asym = 0, range = 0, formula = 0, multi = 0, unhit = 0, inverse = 0;
        for (uint32_t a = 0; a < patches; a++)
            for (uint32_t b = 0; b < patches; b++) {
                uint32_t fa = a / n2, fb = b / n2, s = pn_ls_shaft(n, a, b);
                pairs_total++;
                if (fa == fb) {
                    same_face_bad += s != UINT32_MAX;
                    continue;
                }
                asym += s != pn_ls_shaft(n, b, a);
                if (s >= bits) {
                    range++;
                    continue;
                }
                uint32_t p = fa < fb ? a : b, q = fa < fb ? b : a, fp = p / n2, fq = q / n2;
                uint32_t expect = pair_of[fp][fq] * n4 + (p - fp * n2) * n2 + (q - fq * n2);
                formula += s != expect;
                if (a < b && hit[s]++)
                    multi++;
            }
        for (uint32_t s = 0; s < bits; s++) {
            unhit += hit[s] == 0;
            uint32_t a = UINT32_MAX, b = UINT32_MAX;
            pn_ls_shaft_patches(n, s, &a, &b);
            if (a >= patches || b >= patches || a / n2 >= b / n2 || pn_ls_shaft(n, a, b) != s)
                inverse++;
        }
        free(hit);
        CHECK_MSG(same_face_bad == 0, "N=%d: %llu same-face pairs with a bit", n, (unsigned long long)same_face_bad);
        CHECK_MSG(asym == 0, "N=%d: %llu asymmetric pairs", n, (unsigned long long)asym);
        CHECK_MSG(range == 0, "N=%d: %llu bits out of range", n, (unsigned long long)range);
        CHECK_MSG(formula == 0, "N=%d: %llu bits differ from the documented formula", n, (unsigned long long)formula);
        CHECK_MSG(multi == 0, "N=%d: %llu bits hit twice", n, (unsigned long long)multi);
        CHECK_MSG(unhit == 0, "N=%d: %llu bits never hit", n, (unsigned long long)unhit);
        CHECK_MSG(inverse == 0, "N=%d: pn_ls_shaft_patches wrong for %llu bits", n, (unsigned long long)inverse);
    }
    printf("index mapping: N=2..16, %llu ordered patch pairs, bijection checked (%.0f ms)\n",
           (unsigned long long)pairs_total, pn_ms_since(t0));
}

// ---------------------------------------------------------------------------------------------
// An independent shaft-box oracle. The shaft conv(A u B) of two boxes is the union over t in
// [0,1] of the boxes (1-t)A + tB, so it meets box C iff some t satisfies 6 linear constraints
// g_i(t) <= 0. Their feasible set is an interval of [0,1]; if non-empty, its left end is 0 or a
// root of some g_i, so testing those candidates t = p/q (integers) decides exactly.

static void patch_box_doc(int n, uint32_t p, int lo[3], int hi[3])
{
    int n2 = n * n, f = (int)p / n2, r = (int)p % n2, k = f / 2;
    lo[k] = hi[k] = (f & 1) ? n : 0;
    lo[(k + 1) % 3] = r % n, hi[(k + 1) % 3] = r % n + 1;
    lo[(k + 2) % 3] = r / n, hi[(k + 2) % 3] = r / n + 1;
}

static bool oracle_shaft_box(int n, uint32_t a, uint32_t b, const int clo[3], const int chi[3])
{
    int alo[3], ahi[3], blo[3], bhi[3];
    patch_box_doc(n, a, alo, ahi);
    patch_box_doc(n, b, blo, bhi);
    long g0[6], g1[6]; // g(t) = (1-t) g0 + t g1 <= 0
    for (int k = 0; k < 3; k++) {
        g0[2 * k] = alo[k] - chi[k], g1[2 * k] = blo[k] - chi[k];
        g0[2 * k + 1] = clo[k] - ahi[k], g1[2 * k + 1] = clo[k] - bhi[k];
    }
    long cp[8], cq[8];
    int nc = 0;
    cp[nc] = 0, cq[nc++] = 1;
    for (int i = 0; i < 6; i++)
        if (g0[i] != g1[i]) { // root t = g0 / (g0 - g1)
            long p = g0[i], q = g0[i] - g1[i];
            if (q < 0)
                p = -p, q = -q;
            if (p >= 0 && p <= q)
                cp[nc] = p, cq[nc++] = q;
        }
    for (int c = 0; c < nc; c++) {
        bool ok = true;
        for (int i = 0; i < 6 && ok; i++)
            ok = (cq[c] - cp[c]) * g0[i] + cp[c] * g1[i] <= 0;
        if (ok)
            return true;
    }
    return false;
}

// pn_ls_shaft_hits_box and the shaft masks against the oracle: every (shaft, cell) for small N,
// a sample of cells for larger N.
static void test_shaft_masks(void)
{
    uint64_t t0 = pn_time_ns(), pairs = 0, hits_bad = 0, mask_bad = 0;
    const int ns[] = {2, 3, 4, 5, 6, 7, 9};
    rng r = {42};
    for (size_t ni = 0; ni < sizeof ns / sizeof *ns; ni++) {
        int n = ns[ni];
        pn_ls_masks m;
        if (pn_ls_masks_create(n, &m) != PN_OK) {
            CHECK_MSG(0, "pn_ls_masks_create(%d) failed", n);
            continue;
        }
        uint32_t bits = pn_ls_bits(n), n3 = (uint32_t)(n * n * n);
        uint32_t cells = n <= 5 ? n3 : 12;
        uint64_t set = 0;
        for (uint32_t ci = 0; ci < cells; ci++) {
            uint32_t c = n <= 5 ? ci : (uint32_t)rng_range(&r, 0, n3 - 1);
            int lo[3] = {(int)(c % (uint32_t)n), (int)(c / (uint32_t)n % (uint32_t)n), (int)(c / (uint32_t)(n * n))};
            int hi[3] = {lo[0] + 1, lo[1] + 1, lo[2] + 1};
            const uint64_t *mask = m.bits + (size_t)c * m.words64;
            for (uint32_t s = 0; s < bits; s++) {
                uint32_t a, b;
                pn_ls_shaft_patches(n, s, &a, &b);
                bool o = oracle_shaft_box(n, a, b, lo, hi);
                bool e = pn_ls_shaft_hits_box(n, a, b, lo, hi);
                bool mk = pn_ls_get(mask, s);
                set += mk;
                pairs++;
                if (o != e && hits_bad++ < 5)
                    fprintf(stderr, "N=%d cell %u shaft %u (%u,%u): oracle %d, pn_ls_shaft_hits_box %d\n", n, c, s, a,
                            b, o, e);
                if (o != mk && mask_bad++ < 5)
                    fprintf(stderr, "N=%d cell %u shaft %u (%u,%u): oracle %d, mask %d\n", n, c, s, a, b, o, mk);
            }
        }
        printf("shaft masks N=%d: %u of %u cells checked, %.1f%% of their bits set\n", n, cells, n3,
               100.0 * (double)set / ((double)bits * cells));
        pn_ls_masks_destroy(&m);
    }
    CHECK_MSG(hits_bad == 0, "pn_ls_shaft_hits_box differs from the oracle on %llu (shaft, cell) pairs",
              (unsigned long long)hits_bad);
    CHECK_MSG(mask_bad == 0, "shaft masks differ from the oracle on %llu (shaft, cell) pairs",
              (unsigned long long)mask_bad);
    printf("shaft oracle: %llu (shaft, cell) pairs agree (%.0f ms)\n", (unsigned long long)pairs, pn_ms_since(t0));
}

// ---------------------------------------------------------------------------------------------
// Scenes built in the test

typedef struct tri_list {
    float (*v)[9];
    uint32_t count, cap;
} tri_list;

static void tl_push(tri_list *l, const double a[3], const double b[3], const double c[3])
{
    if (l->count == l->cap) {
        l->cap = l->cap ? 2 * l->cap : 256;
        l->v = realloc(l->v, l->cap * sizeof *l->v);
        if (!l->v) {
            fprintf(stderr, "out of memory\n");
            exit(1);
        }
    }
    float *t = l->v[l->count++];
    for (int k = 0; k < 3; k++) {
        t[k] = (float)a[k];
        t[3 + k] = (float)b[k];
        t[6 + k] = (float)c[k];
    }
}

static void make_scene(const tri_list *l, const char *name, pn_scene *s)
{
    memset(s, 0, sizeof *s);
    snprintf(s->name, sizeof s->name, "%s", name);
    uint32_t mat = 0, nv = 3 * l->count;
    pn_vertex *v = calloc(nv ? nv : 1, sizeof *v);
    uint32_t *idx = malloc((nv ? nv : 1) * sizeof *idx);
    bool ok = v && idx && pn_scene_add_material(s, (const float[4]){0.5f, 0.5f, 0.5f, 1}, &mat) == PN_OK;
    for (uint32_t i = 0; ok && i < nv; i++) {
        memcpy(v[i].pos, l->v[i / 3] + 3 * (i % 3), 3 * sizeof(float));
        v[i].normal[2] = 1;
        idx[i] = i;
    }
    ok = ok && pn_scene_add_mesh(s, v, nv, idx, nv, mat) == PN_OK;
    free(v);
    free(idx);
    if (!ok) {
        fprintf(stderr, "cannot build scene %s\n", name);
        exit(1);
    }
    pn_scene_update_bounds(s);
}

static void scene_tri(const pn_scene *s, uint32_t t, double v[3][3])
{
    for (int j = 0; j < 3; j++)
        for (int k = 0; k < 3; k++)
            v[j][k] = s->vertices[s->indices[3 * t + j]].pos[k];
}

// ---------------------------------------------------------------------------------------------
// 2. Occupancy oracle: Sutherland-Hodgman clipping against the closed box, in double.

static bool clip_overlap(const double tri[3][3], const double lo[3], const double hi[3])
{
    double buf[2][32][3];
    int cnt = 3, cur = 0;
    memcpy(buf[0], tri, sizeof(double[3][3]));
    for (int k = 0; k < 3; k++)
        for (int side = 0; side < 2; side++) {
            double bound = side ? hi[k] : lo[k];
            double(*in)[3] = buf[cur], (*out)[3] = buf[cur ^ 1];
            int m = 0;
            for (int i = 0; i < cnt; i++) {
                const double *p = in[i], *q = in[(i + 1) % cnt];
                bool pin = side ? p[k] <= bound : p[k] >= bound;
                bool qin = side ? q[k] <= bound : q[k] >= bound;
                if (pin)
                    memcpy(out[m++], p, sizeof(double[3]));
                if (pin != qin) {
                    double t = (bound - p[k]) / (q[k] - p[k]);
                    for (int j = 0; j < 3; j++)
                        out[m][j] = p[j] + t * (q[j] - p[j]);
                    out[m++][k] = bound;
                }
                if (m > 30) { // cannot happen for a (possibly degenerate) convex polygon
                    fprintf(stderr, "clip_overlap: polygon overflow\n");
                    exit(1);
                }
            }
            if (m == 0)
                return false;
            cnt = m;
            cur ^= 1;
        }
    return true;
}

typedef struct occ {
    int n, d;
    uint64_t side[PN_NTREE_MAX_DEPTH + 1];
    uint8_t *cells[PN_NTREE_MAX_DEPTH + 1]; // levels 1..d: side^3 flags, (z*side + y)*side + x
} occ;

static void occ_init(occ *o, int n, int d)
{
    memset(o, 0, sizeof *o);
    o->n = n, o->d = d;
    for (int l = 1; l <= d; l++) {
        o->side[l] = ipow((uint64_t)n, l);
        o->cells[l] = calloc(o->side[l] * o->side[l] * o->side[l], 1);
        if (!o->cells[l]) {
            fprintf(stderr, "out of memory\n");
            exit(1);
        }
    }
}

static void occ_free(occ *o)
{
    for (int l = 1; l <= o->d; l++)
        free(o->cells[l]);
    memset(o, 0, sizeof *o);
}

static uint64_t occ_index(const occ *o, int l, const uint64_t c[3])
{
    return (c[2] * o->side[l] + c[1]) * o->side[l] + c[0];
}

// Every triangle against every cell of every level whose box its bounds reach (a one-cell margin
// around them, then an exact bounds reject), with the build's cell boxes grown by `slack`.
static void oracle_occupancy(const pn_ntree *t, const pn_scene *s, double slack, occ *o)
{
    pn_ntree boxes = *t; // only for pn_ntree_cell_box
    boxes.slack = slack;
    uint32_t tc = pn_scene_triangle_count(s);
    for (int l = 1; l <= t->d; l++) {
        double cs = pn_ntree_cell_size(t, l);
        int64_t side = (int64_t)o->side[l];
        for (uint32_t i = 0; i < tc; i++) {
            double v[3][3], mn[3], mx[3];
            int64_t r0[3], r1[3];
            scene_tri(s, i, v);
            for (int k = 0; k < 3; k++) {
                mn[k] = fmin(v[0][k], fmin(v[1][k], v[2][k]));
                mx[k] = fmax(v[0][k], fmax(v[1][k], v[2][k]));
                double a = floor((mn[k] - slack - t->root_min[k]) / cs) - 1;
                double b = floor((mx[k] + slack - t->root_min[k]) / cs) + 1;
                r0[k] = a < 0 ? 0 : a > (double)(side - 1) ? side - 1 : (int64_t)a;
                r1[k] = b < 0 ? 0 : b > (double)(side - 1) ? side - 1 : (int64_t)b;
            }
            for (int64_t z = r0[2]; z <= r1[2]; z++)
                for (int64_t y = r0[1]; y <= r1[1]; y++)
                    for (int64_t x = r0[0]; x <= r1[0]; x++) {
                        uint64_t c[3] = {(uint64_t)x, (uint64_t)y, (uint64_t)z};
                        uint64_t idx = occ_index(o, l, c);
                        if (o->cells[l][idx])
                            continue;
                        double lo[3], hi[3];
                        pn_ntree_cell_box(&boxes, l, c, lo, hi);
                        bool away = false;
                        for (int k = 0; k < 3; k++)
                            away = away || mx[k] < lo[k] || mn[k] > hi[k];
                        if (!away && clip_overlap((const double(*)[3])v, lo, hi))
                            o->cells[l][idx] = 1;
                    }
        }
    }
}

// The build's occupancy from tree->children, walked breadth-first from the root. Also checks the
// structure: node levels and coordinates, breadth-first numbering, FILLED only at level d, NODE
// only above it, every node reached once, filled_per_level.
static void extract_build(const pn_ntree *t, occ *o, const char *label)
{
    uint32_t n = (uint32_t)t->n, n3 = n * n * n, nc = t->node_count;
    uint32_t *queue = malloc((nc ? nc : 1) * sizeof *queue);
    uint32_t(*coord)[3] = malloc((nc ? nc : 1) * sizeof *coord);
    uint32_t *level = malloc((nc ? nc : 1) * sizeof *level);
    uint64_t errors = 0, per_level[PN_NTREE_MAX_DEPTH + 1] = {0};
    uint32_t head = 0, tail = 0;
    if (nc == 0) {
        CHECK_MSG(0, "%s: no root node", label);
        free(queue), free(coord), free(level);
        return;
    }
    queue[tail++] = 0;
    coord[0][0] = coord[0][1] = coord[0][2] = 0;
    level[0] = 0;
    per_level[0] = 1;
    while (head < tail) {
        uint32_t i = queue[head++], l = level[i];
        if (t->nodes[i].level != l || memcmp(t->nodes[i].coord, coord[i], sizeof coord[i]) != 0)
            if (errors++ < 5)
                fprintf(stderr, "%s: node %u has level %u coord (%u,%u,%u), walk says %u (%u,%u,%u)\n", label, i,
                        t->nodes[i].level, t->nodes[i].coord[0], t->nodes[i].coord[1], t->nodes[i].coord[2], l,
                        coord[i][0], coord[i][1], coord[i][2]);
        for (uint32_t c = 0; c < n3; c++) {
            uint32_t e = t->children[(size_t)i * n3 + c];
            if (e == PN_CELL_EMPTY)
                continue;
            uint64_t g[3] = {(uint64_t)coord[i][0] * n + c % n, (uint64_t)coord[i][1] * n + c / n % n,
                             (uint64_t)coord[i][2] * n + c / (n * n)};
            o->cells[l + 1][occ_index(o, (int)l + 1, g)] = 1;
            per_level[l + 1]++;
            if (e == PN_CELL_FILLED) {
                if ((int)l + 1 != t->d && errors++ < 5)
                    fprintf(stderr, "%s: filled leaf at level %u < d = %d\n", label, l + 1, t->d);
                continue;
            }
            uint32_t j = e - PN_CELL_NODE(0);
            if (j >= nc || (int)l + 1 >= t->d || j != tail) { // breadth-first: the next number
                if (errors++ < 5)
                    fprintf(stderr, "%s: node %u child %u: entry %u (node %u) unexpected (next %u, level %u)\n",
                            label, i, c, e, j, tail, l + 1);
                if (j >= nc || j < tail)
                    continue;
            }
            queue[tail++] = j;
            level[j] = l + 1;
            for (int k = 0; k < 3; k++)
                coord[j][k] = (uint32_t)g[k];
        }
    }
    if (tail != nc && errors++ < 5)
        fprintf(stderr, "%s: walk reached %u of %u nodes\n", label, tail, nc);
    for (int l = 0; l <= t->d; l++)
        if (per_level[l] != t->filled_per_level[l] && errors++ < 5)
            fprintf(stderr, "%s: level %d has %llu filled cells, filled_per_level says %llu\n", label, l,
                    (unsigned long long)per_level[l], (unsigned long long)t->filled_per_level[l]);
    CHECK_MSG(errors == 0, "%s: %llu structural errors in the tree", label, (unsigned long long)errors);
    free(queue), free(coord), free(level);
}

// Prints the triangles on which the clipping oracle and pn_tri_box_overlap disagree for a cell.
static void explain_cell(const pn_ntree *t, const pn_scene *s, int l, const uint64_t c[3])
{
    double lo[3], hi[3];
    pn_ntree_cell_box(t, l, c, lo, hi);
    fprintf(stderr, "  cell level %d (%llu,%llu,%llu): box [%a %a %a] - [%a %a %a]\n", l, (unsigned long long)c[0],
            (unsigned long long)c[1], (unsigned long long)c[2], lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    int shown = 0;
    for (uint32_t i = 0; i < pn_scene_triangle_count(s) && shown < 3; i++) {
        double v[3][3];
        scene_tri(s, i, v);
        bool a = clip_overlap((const double(*)[3])v, lo, hi), b = pn_tri_box_overlap((const double(*)[3])v, lo, hi);
        if (a) {
            fprintf(stderr, "    triangle %u (%a %a %a) (%a %a %a) (%a %a %a): clip %d, SAT %d\n", i, v[0][0], v[0][1],
                    v[0][2], v[1][0], v[1][1], v[1][2], v[2][0], v[2][1], v[2][2], a, b);
            shown++;
        }
    }
}

typedef struct occ_stats {
    uint64_t build, oracle, mismatch, exact_missing, slack_only;
} occ_stats;

static occ_stats compare_occupancy(const pn_ntree *t, const pn_scene *s, const occ *build, const occ *oracle,
                                   const occ *exact, const char *label)
{
    occ_stats st = {0};
    int explained = 0;
    for (int l = 1; l <= t->d; l++) {
        uint64_t side = build->side[l], cells = side * side * side;
        for (uint64_t i = 0; i < cells; i++) {
            bool b = build->cells[l][i], o = oracle->cells[l][i], e = exact->cells[l][i];
            st.build += b, st.oracle += o;
            st.exact_missing += e && !b;
            st.slack_only += b && !e;
            if (b != o) {
                st.mismatch++;
                uint64_t c[3] = {i % side, i / side % side, i / (side * side)};
                if (explained++ < 4) {
                    fprintf(stderr, "%s: level %d cell (%llu,%llu,%llu): build %d, oracle %d\n", label, l,
                            (unsigned long long)c[0], (unsigned long long)c[1], (unsigned long long)c[2], b, o);
                    explain_cell(t, s, l, c);
                }
            }
        }
    }
    CHECK_MSG(st.mismatch == 0, "%s: %llu cells differ between build and oracle", label,
              (unsigned long long)st.mismatch);
    CHECK_MSG(st.exact_missing == 0, "%s: %llu cells overlapped exactly (slack 0) but not filled", label,
              (unsigned long long)st.exact_missing);
    return st;
}

// ---------------------------------------------------------------------------------------------
// 5. Pools

static float float_ulp(double x)
{
    float f = fabsf((float)x);
    return nextafterf(f, INFINITY) - f;
}

static void check_pools(const pn_ntree *t, const occ *oracle, const char *label)
{
    pn_pools p;
    if (pn_pools_pack(t, &p) != PN_OK) {
        CHECK_MSG(0, "%s: pn_pools_pack failed", label);
        return;
    }
    pn_pool_bytes pb = pn_ntree_pool_bytes(t->n, t->node_count);
    uint32_t n = (uint32_t)t->n, n3 = n * n * n, nc = t->node_count, lw = 2 * pn_ls_words64(t->n);
    uint64_t errors = 0;
#define POOL_ERR(...)                                                                                  \
    do {                                                                                               \
        if (errors++ < 5) {                                                                            \
            fprintf(stderr, "%s: pools: ", label);                                                     \
            fprintf(stderr, __VA_ARGS__);                                                              \
            fputc('\n', stderr);                                                                       \
        }                                                                                              \
    } while (0)
    if (memcmp(&p.bytes, &pb, sizeof pb) != 0)
        POOL_ERR("bytes differ from pn_ntree_pool_bytes");
    if (pb.tree != (uint64_t)nc * n3 * 4 || pb.node != (uint64_t)nc * sizeof(pn_gpu_node) ||
        pb.linespace != (uint64_t)nc * lw * 4 || pb.total != pb.tree + pb.node + pb.linespace)
        POOL_ERR("pool byte counts inconsistent with the layout");
    if (p.info.n != n || p.info.d != (uint32_t)t->d || p.info.ls_words != lw || p.info.node_count != nc)
        POOL_ERR("info n/d/ls_words/node_count wrong");
    for (int k = 0; k < 3; k++)
        if (fabs((double)p.info.root_min[k] - t->root_min[k]) > float_ulp(t->root_min[k]))
            POOL_ERR("info root_min[%d] %a vs %a", k, (double)p.info.root_min[k], t->root_min[k]);
    if (fabs((double)p.info.root_size - t->root_size) > float_ulp(t->root_size))
        POOL_ERR("info root_size");

    occ walk;
    occ_init(&walk, t->n, t->d);
    uint32_t *queue = malloc(nc * sizeof *queue), *parent = malloc(nc * sizeof *parent);
    uint32_t(*coord)[3] = malloc(nc * sizeof *coord), *level = malloc(nc * sizeof *level);
    uint8_t *seen = calloc(nc, 1);
    uint32_t head = 0, tail = 0;
    queue[tail++] = 0, seen[0] = 1, parent[0] = UINT32_MAX, level[0] = 0;
    coord[0][0] = coord[0][1] = coord[0][2] = 0;
    while (head < tail) {
        uint32_t i = queue[head++];
        const pn_gpu_node *g = &p.nodes[i];
        if (g->level != level[i] || g->parent != parent[i])
            POOL_ERR("node %u: level %u parent %u, walk says %u %u", i, g->level, g->parent, level[i], parent[i]);
        double cs = t->root_size / (double)ipow(n, (int)level[i]);
        for (int k = 0; k < 3; k++) {
            double ref = t->root_min[k] + (double)coord[i][k] * cs;
            if (fabs((double)g->min[k] - ref) > float_ulp(ref))
                POOL_ERR("node %u: min[%d] %a, expected %a", i, k, (double)g->min[k], ref);
        }
        if (fabs((double)g->size - cs) > float_ulp(cs))
            POOL_ERR("node %u: size %a, expected %a", i, (double)g->size, cs);
        if ((uint64_t)g->linespace + lw > (uint64_t)nc * lw ||
            memcmp(p.linespace + g->linespace, t->linespaces + (size_t)i * t->words64, t->words64 * 8) != 0)
            POOL_ERR("node %u: line space at word %u differs from the tree's", i, g->linespace);
        if ((uint64_t)g->children + n3 > (uint64_t)nc * n3) {
            POOL_ERR("node %u: children offset %u out of the pool", i, g->children);
            continue;
        }
        for (uint32_t c = 0; c < n3; c++) {
            uint32_t e = p.tree[g->children + c];
            if (e == PN_CELL_EMPTY)
                continue;
            uint64_t gc[3] = {(uint64_t)coord[i][0] * n + c % n, (uint64_t)coord[i][1] * n + c / n % n,
                              (uint64_t)coord[i][2] * n + c / (n * n)};
            int cl = (int)level[i] + 1;
            if (e == PN_CELL_FILLED) {
                if (cl != t->d)
                    POOL_ERR("filled leaf above the last level");
                walk.cells[cl][occ_index(&walk, cl, gc)] = 1;
                continue;
            }
            uint32_t j = e - PN_CELL_NODE(0);
            if (j >= nc || seen[j] || cl >= t->d) {
                POOL_ERR("node %u child %u: bad entry %u", i, c, e);
                continue;
            }
            seen[j] = 1;
            walk.cells[cl][occ_index(&walk, cl, gc)] = 1; // a subdivided cell at level cl
            queue[tail++] = j, parent[j] = i, level[j] = (uint32_t)cl;
            for (int k = 0; k < 3; k++)
                coord[j][k] = (uint32_t)gc[k];
        }
    }
    if (tail != nc)
        POOL_ERR("walk reached %u of %u nodes", tail, nc);
    // Subdivided cells at levels 1..d-1 and filled leaves at level d equal the oracle's filled cells.
    uint64_t diff = 0;
    for (int l = 1; l <= t->d; l++) {
        uint64_t cells = walk.side[l] * walk.side[l] * walk.side[l];
        for (uint64_t i = 0; i < cells; i++)
            diff += walk.cells[l][i] != oracle->cells[l][i];
    }
    if (diff)
        POOL_ERR("%llu cells differ from the oracle", (unsigned long long)diff);
    CHECK_MSG(errors == 0, "%s: %llu pool errors", label, (unsigned long long)errors);
#undef POOL_ERR
    occ_free(&walk);
    free(queue), free(parent), free(coord), free(level), free(seen);
    pn_pools_destroy(&p);
}

// ---------------------------------------------------------------------------------------------
// 6. Memory limit

static void check_memory_limit(const pn_scene *s, int n, int d, uint32_t nodes, const char *label)
{
    uint64_t total = pn_ntree_pool_bytes(n, nodes).total;
    pn_ntree t, zero;
    memset(&zero, 0, sizeof zero);
    memset(&t, 0xab, sizeof t);
    pn_log_level old = pn_log_get_level();
    pn_log_set_level(PN_LOG_QUIET);
    pn_result r = pn_ntree_build(s, &(pn_ntree_desc){.n = n, .d = d, .max_bytes = total - 1}, &t);
    pn_log_set_level(old);
    CHECK_MSG(r == PN_ERR_MEMORY, "%s: max_bytes = %llu - 1 gave %d, expected PN_ERR_MEMORY", label,
              (unsigned long long)total, (int)r);
    CHECK_MSG(memcmp(&t, &zero, sizeof t) == 0, "%s: refused build left the tree struct non-zero", label);
    pn_ntree_destroy(&t);
    r = pn_ntree_build(s, &(pn_ntree_desc){.n = n, .d = d, .max_bytes = total}, &t);
    CHECK_MSG(r == PN_OK && t.node_count == nodes, "%s: max_bytes = %llu exactly gave %d (%u nodes, expected %u)",
              label, (unsigned long long)total, (int)r, t.node_count, nodes);
    pn_ntree_destroy(&t);
}

// ---------------------------------------------------------------------------------------------
// 3. Line spaces never leak. Child-cell units: the node is [0, N]^3, SU sub-units per cell. A
// segment is P + t (Q - P), t in [0, 1], with integer coordinates over a common denominator den.

#define SU ((int64_t)1 << 20)
#define NKINDS 7

typedef struct seg {
    int64_t p[3], q[3], den;
} seg;

typedef __int128 i128;

// Exact, closed: does the segment touch the box [lo, hi] (integer cell units)?
static bool seg_hits_box(const seg *s, const int lo[3], const int hi[3])
{
    i128 tl_n = 0, tl_d = 1, th_n = 1, th_d = 1; // t interval [tl_n/tl_d, th_n/th_d]
    for (int k = 0; k < 3; k++) {
        int64_t L = lo[k] * SU * s->den, H = hi[k] * SU * s->den, P = s->p[k], D = s->q[k] - s->p[k];
        if (D == 0) {
            if (P < L || P > H)
                return false;
            continue;
        }
        // P + tD in [L, H]
        int64_t ln, un, dd; // lower ln/dd, upper un/dd
        if (D > 0)
            ln = L - P, un = H - P, dd = D;
        else
            ln = P - H, un = P - L, dd = -D;
        if ((i128)ln * tl_d > (i128)tl_n * dd)
            tl_n = ln, tl_d = dd;
        if ((i128)un * th_d < (i128)th_n * dd)
            th_n = un, th_d = dd;
        if (tl_n * th_d > th_n * tl_d)
            return false;
    }
    return tl_n * th_d <= th_n * tl_d;
}

// Cells c in [0, n) whose closed interval [c, c+1] (times unit) holds x in [0, n*unit].
static int cell_range(int64_t x, int64_t unit, int n, int out[2])
{
    int64_t c = x / unit;
    int cnt = 0;
    if (c < n)
        out[cnt++] = (int)c;
    if (x % unit == 0 && c > 0)
        out[cnt++] = (int)c - 1;
    return cnt;
}

// All patches holding the point (documented numbering, computed here, not with pn_ls_patch).
static int point_patches(int n, const int64_t p[3], int64_t den, uint32_t out[24])
{
    int64_t unit = SU * den, top = n * unit;
    int cnt = 0;
    for (int f = 0; f < 6; f++) {
        int k = f / 2;
        if (p[k] != ((f & 1) ? top : 0))
            continue;
        int us[2], vs[2];
        int nu = cell_range(p[(k + 1) % 3], unit, n, us), nv = cell_range(p[(k + 2) % 3], unit, n, vs);
        for (int a = 0; a < nu; a++)
            for (int b = 0; b < nv; b++)
                out[cnt++] = (uint32_t)(f * n * n + vs[b] * n + us[a]);
    }
    return cnt;
}

// A point on the node's boundary: mode 0 uniform, 1 on a patch edge line, 2 on a patch corner.
static void boundary_point(rng *r, int n, int mode, int64_t p[3])
{
    int f = (int)rng_range(r, 0, 5), k = f / 2;
    p[k] = (f & 1) ? n * SU : 0;
    int snap_first = (int)rng_range(r, 0, 1);
    for (int i = 1; i <= 2; i++) {
        int j = (k + i) % 3;
        bool snap = mode == 2 || (mode == 1 && (i == 1) == (snap_first == 1));
        p[j] = snap ? rng_range(r, 0, n) * SU : rng_range(r, 0, n * SU);
    }
}

static void gen_segment(rng *r, int n, int kind, seg *s)
{
    s->den = 1;
    switch (kind) {
    case 0: // uniform on faces
        boundary_point(r, n, 0, s->p);
        boundary_point(r, n, 0, s->q);
        break;
    case 1: // mixed: uniform, on patch edges, on patch corners
        boundary_point(r, n, (int)rng_range(r, 0, 2), s->p);
        boundary_point(r, n, (int)rng_range(r, 0, 2), s->q);
        break;
    case 2: // patch corner to patch corner: through cell edges and corners
        boundary_point(r, n, 2, s->p);
        boundary_point(r, n, 2, s->q);
        break;
    case 3: { // lying in a cell boundary plane: both end points with the same integer coordinate
        int k = (int)rng_range(r, 0, 2);
        int64_t m = rng_range(r, 0, n) * SU;
        int64_t *pts[2] = {s->p, s->q};
        for (int e = 0; e < 2; e++) {
            int j = (k + 1 + (int)rng_range(r, 0, 1)) % 3, l = 3 - k - j;
            pts[e][k] = m;
            pts[e][j] = rng_range(r, 0, 1) ? n * SU : 0;
            pts[e][l] = rng_range(r, 0, 1) ? rng_range(r, 0, n) * SU : rng_range(r, 0, n * SU);
        }
        break;
    }
    case 4: { // along a grid line: two integer coordinates shared, from face to face
        int k = (int)rng_range(r, 0, 2);
        int64_t a = rng_range(r, 0, n) * SU, b = rng_range(r, 0, n) * SU;
        s->p[k] = 0, s->q[k] = n * SU;
        s->p[(k + 1) % 3] = s->q[(k + 1) % 3] = a;
        s->p[(k + 2) % 3] = s->q[(k + 2) % 3] = b;
        if (rng_range(r, 0, 1)) { // or a piece of it from a boundary point on the line to the node's face
            s->q[k] = rng_range(r, 0, n) * SU;
            if (!(a == 0 || a == n * SU || b == 0 || b == n * SU))
                s->q[k] = n * SU;
        }
        break;
    }
    case 5:   // through an interior lattice point (a cell corner): rational end points
    default: {
        const int64_t R = 997;
        int64_t c[3], dir[3];
        for (int k = 0; k < 3; k++)
            c[k] = (n > 2 ? rng_range(r, 1, n - 1) : 1) * SU;
        if (kind == 6) // through a cell edge: one coordinate off the lattice
            c[rng_range(r, 0, 2)] += rng_range(r, 1, SU - 1);
        do {
            for (int k = 0; k < 3; k++)
                dir[k] = rng_range(r, -R, R);
        } while (!dir[0] && !dir[1] && !dir[2]);
        // Largest alpha with c - alpha*dir inside, beta with c + beta*dir inside: fractions num/den.
        int64_t an = 0, ad = 0, bn = 0, bd = 0;
        for (int k = 0; k < 3; k++) {
            if (!dir[k])
                continue;
            int64_t dk = dir[k] > 0 ? dir[k] : -dir[k];
            int64_t to_lo = c[k], to_hi = n * SU - c[k];
            int64_t a = dir[k] > 0 ? to_lo : to_hi, b = dir[k] > 0 ? to_hi : to_lo;
            if (!ad || (i128)a * ad < (i128)an * dk)
                an = a, ad = dk;
            if (!bd || (i128)b * bd < (i128)bn * dk)
                bn = b, bd = dk;
        }
        s->den = ad * bd;
        for (int k = 0; k < 3; k++) {
            s->p[k] = c[k] * s->den - an * bd * dir[k];
            s->q[k] = c[k] * s->den + bn * ad * dir[k];
        }
        break;
    }
    }
    if (rng_range(r, 0, 1)) { // either direction
        for (int k = 0; k < 3; k++) {
            int64_t t = s->p[k];
            s->p[k] = s->q[k], s->q[k] = t;
        }
    }
}

typedef struct node_ctx {
    int n;
    const uint64_t *ls;
    int (*filled)[3];
    uint32_t nfilled;
} node_ctx;

static void node_ctx_init(const pn_ntree *t, uint32_t node, node_ctx *c)
{
    uint32_t n = (uint32_t)t->n, n3 = n * n * n;
    c->n = t->n;
    c->ls = t->linespaces + (size_t)node * t->words64;
    c->filled = malloc(n3 * sizeof *c->filled);
    c->nfilled = 0;
    for (uint32_t k = 0; k < n3; k++)
        if (t->children[(size_t)node * n3 + k] != PN_CELL_EMPTY) {
            c->filled[c->nfilled][0] = (int)(k % n);
            c->filled[c->nfilled][1] = (int)(k / n % n);
            c->filled[c->nfilled][2] = (int)(k / (n * n));
            c->nfilled++;
        }
}

static bool seg_hits_filled(const node_ctx *c, const seg *s)
{
    for (uint32_t i = 0; i < c->nfilled; i++) {
        int hi[3] = {c->filled[i][0] + 1, c->filled[i][1] + 1, c->filled[i][2] + 1};
        if (seg_hits_box(s, c->filled[i], hi))
            return true;
    }
    return false;
}

typedef struct seg_job {
    const node_ctx *node;
    uint32_t node_index;
    const char *label;
    uint64_t seed, per_chunk;
    _Atomic uint64_t *needed; // bits some hitting segment required
    atomic_uint_fast64_t segments, hits, checks, violations, bad_points, kind_hits[NKINDS];
} seg_job;

static atomic_int g_violation_prints;

static void seg_chunks(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    seg_job *j = ctx;
    const node_ctx *nd = j->node;
    int n = nd->n;
    for (uint64_t ci = begin; ci < end; ci++) {
        rng r = {j->seed ^ (ci * 0xD1B54A32D192ED03ull)};
        uint64_t hits = 0, checks = 0, violations = 0, bad = 0, kh[NKINDS] = {0};
        for (uint64_t i = 0; i < j->per_chunk; i++) {
            int kind = (int)((ci * j->per_chunk + i) % NKINDS);
            seg s;
            gen_segment(&r, n, kind, &s);
            uint32_t pa[24], pb[24];
            int na = point_patches(n, s.p, s.den, pa), nb = point_patches(n, s.q, s.den, pb);
            if (!na || !nb) { // the generator must put both end points on the boundary
                bad++;
                continue;
            }
            if (!seg_hits_filled(nd, &s))
                continue;
            hits++;
            kh[kind]++;
            for (int a = 0; a < na; a++)
                for (int b = 0; b < nb; b++) {
                    uint32_t bit = pn_ls_shaft(n, pa[a], pb[b]);
                    if (bit == UINT32_MAX)
                        continue; // same face: no shaft
                    checks++;
                    atomic_fetch_or_explicit(&j->needed[bit >> 6], 1ull << (bit & 63), memory_order_relaxed);
                    if (!pn_ls_get(nd->ls, bit)) {
                        violations++;
                        if (atomic_fetch_add(&g_violation_prints, 1) < 10)
                            fprintf(stderr,
                                    "LEAK %s node %u: segment kind %d (%lld,%lld,%lld)-(%lld,%lld,%lld)/%lld (units "
                                    "of 1/%lld cell) hits a filled child, patches %u-%u, bit %u clear\n",
                                    j->label, j->node_index, kind, (long long)s.p[0], (long long)s.p[1],
                                    (long long)s.p[2], (long long)s.q[0], (long long)s.q[1], (long long)s.q[2],
                                    (long long)s.den, (long long)SU, pa[a], pb[b], bit);
                    }
                }
        }
        atomic_fetch_add(&j->segments, j->per_chunk);
        atomic_fetch_add(&j->hits, hits);
        atomic_fetch_add(&j->checks, checks);
        atomic_fetch_add(&j->violations, violations);
        atomic_fetch_add(&j->bad_points, bad);
        for (int k = 0; k < NKINDS; k++)
            atomic_fetch_add(&j->kind_hits[k], kh[k]);
    }
}

// A set bit's shaft sampled with random segments between its two patches: does any hit?
typedef struct shaft_job {
    const node_ctx *node;
    uint64_t seed;
    int samples;
    atomic_uint_fast64_t set, unneeded;
} shaft_job;

static void shaft_chunks(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    shaft_job *j = ctx;
    const node_ctx *nd = j->node;
    int n = nd->n;
    uint64_t set = 0, unneeded = 0;
    rng r = {j->seed ^ (begin * 0x9E3779B97F4A7C15ull)};
    for (uint64_t bit = begin; bit < end; bit++) {
        if (!pn_ls_get(nd->ls, (uint32_t)bit))
            continue;
        set++;
        uint32_t pa[2];
        pn_ls_shaft_patches(n, (uint32_t)bit, &pa[0], &pa[1]);
        bool hit = false;
        for (int smp = 0; smp < j->samples && !hit; smp++) {
            seg s = {.den = 1};
            for (int e = 0; e < 2; e++) {
                int lo[3], hi[3];
                patch_box_doc(n, pa[e], lo, hi);
                int64_t *pt = e ? s.q : s.p;
                for (int k = 0; k < 3; k++)
                    pt[k] = rng_range(&r, lo[k] * SU, hi[k] * SU);
            }
            hit = seg_hits_filled(nd, &s);
        }
        unneeded += !hit;
    }
    atomic_fetch_add(&j->set, set);
    atomic_fetch_add(&j->unneeded, unneeded);
}

typedef struct leak_totals {
    uint64_t segments, hits, checks, violations, set_bits, needed_bits, shaft_set, shaft_unneeded, scratch_nodes;
} leak_totals;

static leak_totals g_leak;

static void test_linespaces(const pn_ntree *t, uint64_t segments, const char *label)
{
    uint64_t t0 = pn_time_ns();
    rng r = {0x1234 + t->node_count};
    // Sample: the root and up to 6 random nodes of every other level (nodes are breadth-first).
    uint32_t sample[64], ns = 0;
    sample[ns++] = 0;
    for (int l = 1; l < t->d; l++) {
        uint32_t first = UINT32_MAX, count = 0;
        for (uint32_t i = 0; i < t->node_count; i++)
            if ((int)t->nodes[i].level == l) {
                if (first == UINT32_MAX)
                    first = i;
                count++;
            }
        for (uint32_t k = 0; k < 6 && k < count; k++)
            sample[ns++] = first + (count <= 6 ? k : (uint32_t)rng_range(&r, 0, count - 1));
    }
    uint64_t per_node = segments / ns, per_chunk = 2048;
    uint64_t chunks = (per_node + per_chunk - 1) / per_chunk;
    uint32_t bits = pn_ls_bits(t->n);
    leak_totals tot = {0};
    uint64_t kind_hits[NKINDS] = {0};
    for (uint32_t si = 0; si < ns; si++) {
        uint32_t node = sample[si];
        node_ctx nd;
        node_ctx_init(t, node, &nd);
        seg_job j = {.node = &nd, .node_index = node, .label = label, .seed = rng_next(&r), .per_chunk = per_chunk};
        j.needed = calloc(t->words64, sizeof *j.needed);
        pn_parallel_for(chunks, 1, seg_chunks, &j);
        tot.segments += j.segments, tot.hits += j.hits, tot.checks += j.checks, tot.violations += j.violations;
        for (int k = 0; k < NKINDS; k++)
            kind_hits[k] += j.kind_hits[k];
        CHECK_MSG(j.bad_points == 0, "%s node %u: %llu generated end points not on the boundary", label, node,
                  (unsigned long long)j.bad_points);
        for (uint32_t w = 0; w < t->words64; w++) {
            tot.set_bits += (uint64_t)__builtin_popcountll(nd.ls[w]);
            tot.needed_bits += (uint64_t)__builtin_popcountll(nd.ls[w] & atomic_load(&j.needed[w]));
        }
        free((void *)j.needed);
        // Small N, the first three sampled nodes: the line space from scratch (engine shaft test
        // and the oracle above, OR over the filled children) and per-shaft sampled tightness.
        if (t->n <= 7 && si < 3) {
            uint64_t wrong_engine = 0, wrong_oracle = 0;
            for (uint32_t s = 0; s < bits; s++) {
                uint32_t a, b;
                pn_ls_shaft_patches(t->n, s, &a, &b);
                bool e = false, o = false;
                for (uint32_t i = 0; i < nd.nfilled && !e; i++) {
                    int hi[3] = {nd.filled[i][0] + 1, nd.filled[i][1] + 1, nd.filled[i][2] + 1};
                    e = pn_ls_shaft_hits_box(t->n, a, b, nd.filled[i], hi);
                }
                for (uint32_t i = 0; i < nd.nfilled && !o && t->n <= 5; i++) {
                    int hi[3] = {nd.filled[i][0] + 1, nd.filled[i][1] + 1, nd.filled[i][2] + 1};
                    o = oracle_shaft_box(t->n, a, b, nd.filled[i], hi);
                }
                bool set = pn_ls_get(nd.ls, s);
                wrong_engine += e != set;
                wrong_oracle += t->n <= 5 && o != set;
            }
            CHECK_MSG(wrong_engine == 0, "%s node %u: %llu bits differ from OR of pn_ls_shaft_hits_box", label, node,
                      (unsigned long long)wrong_engine);
            CHECK_MSG(wrong_oracle == 0, "%s node %u: %llu bits differ from OR of the shaft oracle", label, node,
                      (unsigned long long)wrong_oracle);
            tot.scratch_nodes++;
            shaft_job sj = {.node = &nd, .seed = rng_next(&r), .samples = 8};
            pn_parallel_for(bits, 1024, shaft_chunks, &sj);
            tot.shaft_set += sj.set, tot.shaft_unneeded += sj.unneeded;
        }
        free(nd.filled);
    }
    CHECK_MSG(tot.violations == 0, "%s: %llu leaks (segment touches a filled child, shaft bit clear)", label,
              (unsigned long long)tot.violations);
    printf("  line spaces %s: %u nodes sampled, %llu segments, %llu touch a filled child (by kind:", label, ns,
           (unsigned long long)tot.segments, (unsigned long long)tot.hits);
    for (int k = 0; k < NKINDS; k++)
        printf(" %llu", (unsigned long long)kind_hits[k]);
    printf("), %llu shaft bits checked, %llu violations\n", (unsigned long long)tot.checks,
           (unsigned long long)tot.violations);
    printf("  tightness %s: %.1f%% of %llu set bits needed by no sampled segment", label,
           tot.set_bits ? 100.0 * (double)(tot.set_bits - tot.needed_bits) / (double)tot.set_bits : 0.0,
           (unsigned long long)tot.set_bits);
    if (tot.shaft_set)
        printf("; per-shaft sampling (8 segments per set bit, %llu nodes): %.1f%% of %llu set bits unneeded",
               (unsigned long long)tot.scratch_nodes, 100.0 * (double)tot.shaft_unneeded / (double)tot.shaft_set,
               (unsigned long long)tot.shaft_set);
    printf(" (%.0f ms)\n", pn_ms_since(t0));
    g_leak.segments += tot.segments, g_leak.hits += tot.hits, g_leak.checks += tot.checks;
    g_leak.violations += tot.violations, g_leak.set_bits += tot.set_bits, g_leak.needed_bits += tot.needed_bits;
    g_leak.shaft_set += tot.shaft_set, g_leak.shaft_unneeded += tot.shaft_unneeded;
    g_leak.scratch_nodes += tot.scratch_nodes;
}

// ---------------------------------------------------------------------------------------------
// One tree through parts 2, 3, 5 and 6.

typedef struct tree_check {
    uint64_t segments; // 0: no line-space test
    bool memory;
} tree_check;

static uint64_t g_slack_only, g_filled_cells, g_trees;

static void check_tree(const pn_scene *s, int n, int d, tree_check opt, const char *label, pn_ntree *keep)
{
    char name[300];
    snprintf(name, sizeof name, "%s LS(%d,%d)", label, n, d);
    if (keep)
        memset(keep, 0, sizeof *keep);
    pn_ntree t;
    pn_result r = pn_ntree_build(s, &(pn_ntree_desc){.n = n, .d = d}, &t);
    CHECK_MSG(r == PN_OK, "%s: build failed (%d)", name, (int)r);
    if (r != PN_OK)
        return;
    uint64_t t0 = pn_time_ns();
    occ build, oracle, exact;
    occ_init(&build, n, d), occ_init(&oracle, n, d), occ_init(&exact, n, d);
    extract_build(&t, &build, name);
    oracle_occupancy(&t, s, t.slack, &oracle);
    oracle_occupancy(&t, s, 0.0, &exact);
    occ_stats st = compare_occupancy(&t, s, &build, &oracle, &exact, name);
    printf("%s: %u triangles, %u nodes, filled cells %llu (oracle %llu), slack-only %llu, %.1f%% bits set, "
           "build %.1f ms, oracle %.0f ms\n",
           name, t.triangles, t.node_count, (unsigned long long)st.build, (unsigned long long)st.oracle,
           (unsigned long long)st.slack_only, 100.0 * (double)t.set_bits / ((double)t.node_count * pn_ls_bits(n)),
           t.build_ms, pn_ms_since(t0));
    g_slack_only += st.slack_only, g_filled_cells += st.build, g_trees++;
    check_pools(&t, &oracle, name);
    if (opt.segments)
        test_linespaces(&t, opt.segments, name);
    if (opt.memory)
        check_memory_limit(s, n, d, t.node_count, name);
    occ_free(&build), occ_free(&oracle), occ_free(&exact);
    if (keep)
        *keep = t;
    else
        pn_ntree_destroy(&t);
}

static uint64_t segs(double count) { return (uint64_t)(count * g_scale) + 1; }

// ---------------------------------------------------------------------------------------------
// Scenes: (a) random soups

static void rand_point(rng *r, const double lo[3], const double size[3], double p[3])
{
    for (int k = 0; k < 3; k++)
        p[k] = lo[k] + rng_u01(r) * size[k];
}

static void gen_soup(rng *r, uint32_t count, tri_list *l)
{
    const double lo[3] = {-3.0, 0.5, -1.25}, size[3] = {8.0, 2.0, 2.5};
    for (uint32_t i = 0; i < count; i++) {
        double v[3][3], c[3];
        int kind = (int)(i % 10);
        if (kind >= 8) { // spanning: vertices anywhere
            for (int j = 0; j < 3; j++)
                rand_point(r, lo, size, v[j]);
        } else {
            double e = kind < 4 ? 1e-4 * pow(10, 2 * rng_u01(r)) : 8.0 * pow(2, -1 - 4 * rng_u01(r)); // tiny, cell
            rand_point(r, lo, size, c);
            for (int j = 0; j < 3; j++)
                for (int k = 0; k < 3; k++) {
                    v[j][k] = c[k] + e * (2 * rng_u01(r) - 1);
                    v[j][k] = fmin(fmax(v[j][k], lo[k]), lo[k] + size[k]);
                }
        }
        tl_push(l, v[0], v[1], v[2]);
    }
}

// (b) adversarial scenes on a known root box

static const float g_anchor = 0x1.fffff8p-1f; // 1 - 2^-22: with 4 ulps (2^-24) of slack the root is [-1, 1]^3

static void push_anchors(tri_list *l)
{
    const double a = g_anchor, e = 0.03;
    tl_push(l, (double[3]){-a, -a, -a}, (double[3]){-a + e, -a, -a}, (double[3]){-a, -a + e, -a + e});
    tl_push(l, (double[3]){a, a, a}, (double[3]){a - e, a, a - e}, (double[3]){a, a - e, a});
}

typedef struct lattice {
    double root_min[3], root_size, slack;
    uint64_t m; // cells per axis at the finest level
    bool dyadic;
} lattice;

// Boundary c (0..m) of the finest level along axis k as a float, clamped into the scene bounds.
static double lat(const lattice *L, int k, int64_t c)
{
    double v = L->root_min[k] + (double)c * (L->root_size / (double)L->m);
    v = fmin(fmax(v, -(double)g_anchor), (double)g_anchor);
    return (double)(float)v;
}

// The generator's state for one triangle: global (anywhere in the scene) or local (within a few
// cells of a base cell, so that the scene stays sparse enough for the line-space test).
typedef struct adv {
    rng *r;
    const lattice *L;
    bool local;
    int64_t base[3], rad;
} adv;

static int64_t clamp64(int64_t v, int64_t lo, int64_t hi) { return v < lo ? lo : v > hi ? hi : v; }

static int64_t adv_c(adv *a, int k) // a lattice index in 0..m
{
    int64_t m = (int64_t)a->L->m;
    if (!a->local)
        return rng_range(a->r, 0, m);
    return clamp64(a->base[k] + rng_range(a->r, -a->rad, a->rad + 1), 0, m);
}

static int64_t adv_inner(adv *a, int k) // an interior lattice index in 1..m-1
{
    return clamp64(adv_c(a, k), 1, (int64_t)a->L->m - 1);
}

static double adv_rand(adv *a, int k) // a float coordinate
{
    double lo = -(double)g_anchor, hi = (double)g_anchor;
    if (a->local) {
        lo = fmax(lo, lat(a->L, k, a->base[k] - a->rad));
        hi = fmin(hi, lat(a->L, k, a->base[k] + a->rad + 1));
    }
    return (double)(float)(lo + rng_u01(a->r) * (hi - lo));
}

// Is v exactly a float inside the bounds?
static bool exact_float(double v) { return (double)(float)v == v && fabs(v) <= g_anchor; }

static void gen_adversarial(rng *r, const lattice *L, uint32_t count, bool local, tri_list *l, uint32_t *touching)
{
    adv A = {r, L, local, {0, 0, 0}, 1};
    for (uint32_t i = 0; i < count; i++) {
        double v[3][3];
        int kind = (int)(i % 11), k = (int)rng_range(r, 0, 2), j = (k + 1) % 3, h = (k + 2) % 3;
        for (int b = 0; b < 3; b++)
            A.base[b] = rng_range(r, 0, (int64_t)L->m - 1);
        A.rad = rng_range(r, 0, 1);
        switch (kind) {
        case 0: { // in a boundary plane, edges along cell edges (equal steps: hypotenuse through corners)
            double x = lat(L, k, adv_inner(&A, k));
            int64_t j0 = adv_c(&A, j), h0 = adv_c(&A, h), st = local ? rng_range(r, 1, 2) : rng_range(r, 1, (int64_t)L->m);
            int64_t j1 = j0 + st <= (int64_t)L->m ? j0 + st : j0 - st;
            int64_t h1 = h0 + st <= (int64_t)L->m ? h0 + st : h0 - st;
            if (rng_range(r, 0, 1))
                h1 = adv_c(&A, h);
            v[0][k] = v[1][k] = v[2][k] = x;
            v[0][j] = lat(L, j, j0), v[0][h] = lat(L, h, h0);
            v[1][j] = lat(L, j, j1), v[1][h] = lat(L, h, h0);
            v[2][j] = lat(L, j, j0), v[2][h] = lat(L, h, h1);
            break;
        }
        case 1: // in a boundary plane, other coordinates anywhere
            for (int a = 0; a < 3; a++)
                v[a][j] = adv_rand(&A, j), v[a][h] = adv_rand(&A, h);
            v[0][k] = v[1][k] = v[2][k] = lat(L, k, adv_inner(&A, k));
            break;
        case 2: // vertices on cell corners
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    v[a][b] = lat(L, b, adv_c(&A, b));
            break;
        case 3: // vertices on cell edges
            for (int a = 0; a < 3; a++) {
                int free_axis = (int)rng_range(r, 0, 2);
                for (int b = 0; b < 3; b++)
                    v[a][b] = b == free_axis ? adv_rand(&A, b) : lat(L, b, adv_c(&A, b));
            }
            break;
        case 4: { // collinear along a cell edge line, or through lattice points with an exact midpoint
            double a0 = lat(L, j, adv_c(&A, j)), b0 = lat(L, h, adv_c(&A, h));
            for (int a = 0; a < 3; a++)
                v[a][j] = a0, v[a][h] = b0, v[a][k] = a == 2 ? adv_rand(&A, k) : lat(L, k, adv_c(&A, k));
            if (L->dyadic && rng_range(r, 0, 1))
                for (int b = 0; b < 3; b++) {
                    v[0][b] = lat(L, b, adv_c(&A, b)), v[1][b] = lat(L, b, adv_c(&A, b));
                    v[2][b] = 0.5 * (v[0][b] + v[1][b]); // exact: dyadic with few bits
                }
            break;
        }
        case 5: // repeated vertex
            for (int b = 0; b < 3; b++) {
                v[0][b] = v[1][b] = lat(L, b, adv_c(&A, b));
                v[2][b] = rng_range(r, 0, 1) ? lat(L, b, adv_c(&A, b)) : adv_rand(&A, b);
            }
            break;
        case 6: { // a point: on a cell corner, a cell edge, a cell face or anywhere
            int on = (int)rng_range(r, 0, 3);
            for (int b = 0; b < 3; b++)
                v[0][b] = v[1][b] = v[2][b] = b < 3 - on ? lat(L, b, adv_c(&A, b)) : adv_rand(&A, b);
            break;
        }
        case 7: // spanning the scene, on the bounds (local: a lattice corner to the bounds)
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    v[a][b] = local && a < 2 ? lat(L, b, adv_c(&A, b)) : rng_range(r, 0, 1) ? g_anchor : -g_anchor;
            if (local && rng_range(r, 0, 3))
                memcpy(v[2], v[1], sizeof v[2]); // mostly a cell-sized segment instead
            break;
        default: { // 8..10: touching the slack-grown boundary exactly (only where that is exact)
            bool ok = L->dyadic;
            if (ok) {
                double sg = rng_range(r, 0, 1) ? 1 : -1; // +slack: touches the cell below; -slack: the one above
                double x = lat(L, k, adv_inner(&A, k)) + sg * L->slack;
                double cs = L->root_size / (double)L->m;
                if (kind == 8) { // flat on the grown plane
                    for (int a = 0; a < 3; a++)
                        v[a][k] = x, v[a][j] = adv_rand(&A, j), v[a][h] = adv_rand(&A, h);
                } else if (kind == 9) { // tilted, touching with one vertex; the others beyond
                    for (int a = 0; a < 3; a++) {
                        v[a][k] = a == 0 ? x : (double)(float)(x + sg * cs * (0.05 + 1.5 * rng_u01(r)));
                        v[a][j] = a == 0 ? lat(L, j, adv_inner(&A, j)) + 0.25 * cs : adv_rand(&A, j);
                        v[a][h] = a == 0 ? lat(L, h, adv_inner(&A, h)) + 0.25 * cs : adv_rand(&A, h);
                    }
                } else { // a point or an axis segment on a grown cell edge or corner
                    double y = lat(L, j, adv_inner(&A, j)) + (rng_range(r, 0, 1) ? 1 : -1) * L->slack;
                    double z = lat(L, h, adv_inner(&A, h)) + (rng_range(r, 0, 1) ? 1 : -1) * L->slack;
                    v[0][k] = v[1][k] = v[2][k] = x;
                    v[0][j] = v[1][j] = y;
                    v[2][j] = rng_range(r, 0, 1) ? y : adv_rand(&A, j);
                    v[0][h] = v[1][h] = v[2][h] = z;
                }
                for (int a = 0; a < 3; a++)
                    for (int b = 0; b < 3; b++)
                        ok = ok && exact_float(v[a][b]);
            }
            if (!ok) { // not representable: lattice corners instead
                for (int a = 0; a < 3; a++)
                    for (int b = 0; b < 3; b++)
                        v[a][b] = lat(L, b, adv_c(&A, b));
            } else
                (*touching)++;
            break;
        }
        }
        tl_push(l, v[0], v[1], v[2]);
    }
}

// ---------------------------------------------------------------------------------------------

int main(void)
{
    g_scale = atof(pn_test_env("PN_TEST_SCALE", "1"));
    if (!(g_scale > 0))
        g_scale = 1;
    setvbuf(stdout, NULL, _IOLBF, 0);
    uint64_t t_start = pn_time_ns();
    printf("threads: %u, scale %.3g\n", pn_parallel_threads(), g_scale);

    test_index_mapping();
    test_shaft_masks();

    // (a) Random soups.
    {
        rng r = {7};
        tri_list l = {0};
        gen_soup(&r, 320, &l);
        pn_scene s;
        make_scene(&l, "soup", &s);
        const struct {
            int n, d;
            double segments;
            bool memory;
        } cfg[] = {{2, 3, 0, true}, {3, 2, 2e5, true}, {4, 2, 3e5, true}, {5, 2, 2e5, false},
                   {7, 1, 1e5, true}, {16, 1, 1.5e5, false}, {2, 5, 1e5, false}, {8, 2, 0, false}};
        for (size_t i = 0; i < sizeof cfg / sizeof *cfg; i++)
            check_tree(&s, cfg[i].n, cfg[i].d,
                       (tree_check){cfg[i].segments > 0 ? segs(cfg[i].segments) : 0, cfg[i].memory}, "soup", NULL);
        pn_scene_destroy(&s);
        free(l.v);
    }

    // (b) Adversarial scenes on the root [-1, 1]^3 fixed by two anchor triangles.
    {
        tri_list anchors = {0};
        push_anchors(&anchors);
        pn_scene s;
        make_scene(&anchors, "anchors", &s);
        pn_ntree t;
        CHECK(pn_ntree_build(&s, &(pn_ntree_desc){.n = 2, .d = 1}, &t) == PN_OK);
        lattice L = {{t.root_min[0], t.root_min[1], t.root_min[2]}, t.root_size, t.slack, 0, false};
        printf("anchors: root min (%a, %a, %a), size %a, slack %a\n", t.root_min[0], t.root_min[1], t.root_min[2],
               t.root_size, t.slack);
        bool unit_root = t.root_min[0] == -1 && t.root_min[1] == -1 && t.root_min[2] == -1 && t.root_size == 2;
        if (!unit_root)
            printf("  (root is not [-1,1]^3: grown-boundary cases fall back to lattice corners)\n");
        pn_ntree_destroy(&t);
        pn_scene_destroy(&s);
        free(anchors.v);

        // Global scenes (triangles anywhere, many spanning) for the occupancy; local ones (within a
        // few cells) also for the line spaces, which a dense scene would fill completely.
        const struct {
            int n, d;
            bool local;
            double segments;
        } cfg[] = {{2, 3, false, 0},   {3, 2, false, 0}, {4, 2, false, 0},   {5, 2, false, 0},
                   {7, 1, false, 0},   {8, 2, false, 0}, {16, 1, false, 0},  {3, 3, false, 0},
                   {2, 3, true, 5e4},  {3, 2, true, 5e4}, {4, 2, true, 1e5}, {5, 2, true, 5e4},
                   {8, 2, true, 5e4},  {16, 1, true, 5e4}, {3, 3, true, 5e4}};
        uint32_t touching_total = 0;
        for (size_t i = 0; i < sizeof cfg / sizeof *cfg; i++) {
            int n = cfg[i].n, d = cfg[i].d;
            L.m = ipow((uint64_t)n, d);
            L.dyadic = unit_root && (n & (n - 1)) == 0;
            rng r = {100 + i};
            tri_list l = {0};
            push_anchors(&l);
            uint32_t touching = 0;
            gen_adversarial(&r, &L, cfg[i].local ? 330 : 440, cfg[i].local, &l, &touching);
            touching_total += touching;
            char label[96];
            snprintf(label, sizeof label, "adversarial-%s(%u on grown boundaries)", cfg[i].local ? "local" : "global",
                     touching);
            make_scene(&l, label, &s);
            pn_ntree kept;
            check_tree(&s, n, d, (tree_check){cfg[i].segments > 0 ? segs(cfg[i].segments) : 0, n == 4}, label, &kept);
            CHECK_MSG(kept.root_min[0] == L.root_min[0] && kept.root_min[1] == L.root_min[1] &&
                          kept.root_min[2] == L.root_min[2] && kept.root_size == L.root_size,
                      "%s: the adversarial triangles changed the root box", label);
            pn_ntree_destroy(&kept);
            pn_scene_destroy(&s);
            free(l.v);
        }
        CHECK_MSG(!unit_root || touching_total > 0, "no triangle touches a grown boundary");
    }

    // One-triangle scenes (some degenerate).
    {
        const double one[][3][3] = {
            {{0.1, 0.2, 0.3}, {1.7, -0.4, 0.9}, {0.5, 1.3, -1.1}},          // generic
            {{-1.0, 2.0, 0.5}, {3.0, 2.0, 0.5}, {0.0, 5.0, 0.5}},           // flat: zero extent in z
            {{0.0, 0.0, 0.0}, {1.0, 2.0, 3.0}, {0.5, 1.0, 1.5}},            // collinear
            {{0.25, -0.75, 1.5}, {0.25, -0.75, 1.5}, {0.25, -0.75, 1.5}},   // a point
            {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}},            // a point at the origin
            {{1.0, 1.0, 1.0}, {1.0, 1.0, 1.0}, {1.0, 1.0, 4.0}},            // repeated vertex: a segment
        };
        const char *names[] = {"single", "single-flat", "single-collinear", "single-point", "single-origin",
                               "single-repeated"};
        const int cfg[][2] = {{2, 3}, {3, 2}, {4, 2}};
        for (size_t i = 0; i < sizeof one / sizeof *one; i++) {
            tri_list l = {0};
            tl_push(&l, one[i][0], one[i][1], one[i][2]);
            pn_scene s;
            make_scene(&l, names[i], &s);
            for (size_t c = 0; c < sizeof cfg / sizeof *cfg; c++)
                check_tree(&s, cfg[c][0], cfg[c][1], (tree_check){c == 2 ? segs(1e4) : 0, c == 0}, names[i], NULL);
            pn_scene_destroy(&s);
            free(l.v);
        }
    }

    // (c) The real mesh and the built-in default scene.
    {
        char path[1024];
        snprintf(path, sizeof path, "%s/stanford-dragon-res4-11k.glb", pn_test_env("PN_ASSETS", "../shared/assets"));
        FILE *f = fopen(path, "rb");
        pn_scene s;
        if (!f) {
            printf("SKIP real mesh: %s not found\n", path);
        } else {
            fclose(f);
            if (pn_scene_load(path, &s) != PN_OK) {
                CHECK_MSG(0, "cannot load %s", path);
            } else {
                check_tree(&s, 4, 2, (tree_check){segs(4e5), true}, "dragon-11k", NULL);
                check_tree(&s, 3, 3, (tree_check){segs(4e5), true}, "dragon-11k", NULL);
                pn_scene_destroy(&s);
            }
        }
        if (pn_scene_load("builtin:default", &s) != PN_OK) {
            CHECK_MSG(0, "cannot load builtin:default");
        } else {
            check_tree(&s, 7, 2, (tree_check){segs(5e5), true}, "builtin:default", NULL);
            check_tree(&s, 4, 3, (tree_check){segs(2e5), false}, "builtin:default", NULL);
            pn_scene_destroy(&s);
        }
    }

    printf("totals: %llu trees, %llu filled cells (%llu only because of the slack), %llu segments (%llu touch a "
           "filled child, %llu shaft bits checked), %llu leaks; %.1f%% of sampled nodes' set bits needed by no "
           "segment, %.1f%% unneeded by per-shaft sampling (%llu nodes); %.1f s\n",
           (unsigned long long)g_trees, (unsigned long long)g_filled_cells, (unsigned long long)g_slack_only,
           (unsigned long long)g_leak.segments, (unsigned long long)g_leak.hits, (unsigned long long)g_leak.checks,
           (unsigned long long)g_leak.violations,
           g_leak.set_bits ? 100.0 * (double)(g_leak.set_bits - g_leak.needed_bits) / (double)g_leak.set_bits : 0.0,
           g_leak.shaft_set ? 100.0 * (double)g_leak.shaft_unneeded / (double)g_leak.shaft_set : 0.0,
           (unsigned long long)g_leak.scratch_nodes, pn_ms_since(t_start) / 1000);
    if (g_scale >= 1)
        CHECK_MSG(g_leak.segments >= 2000000, "only %llu segments tested", (unsigned long long)g_leak.segments);
    return pn_test_result();
}
