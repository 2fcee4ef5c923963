// The bench's edge-leak measure (pn_edge_leak_measure, engine/shadow/metrics.c) against hand-made
// G-buffers whose band and grown pixels are counted by hand. A 20x10 image at view depth 10 with a
// pixel angle of 0.01 (a footprint of 0.1 at scale 1); row 9 has no geometry. Columns 0..9 are a
// floor (normal +y); columns 10..19 are, per layout:
//   crease: a wall (normal +x): 90 degrees apart, an edge between columns 9 and 10;
//   step:   the floor raised by 0.6 footprints: off the tangent plane by more than half, an edge;
//   flat:   the floor raised by 0.4 footprints: under half, no edge.
// The band is the covered pixels within 2 px of an edge pixel: rows 6..8 (the coverage edge at row
// 8/9) for every layout, plus columns 7..12 of rows 0..5 where there is a vertical edge:
//   crease, step: 20 * 3 + 6 * 6 = 96;  flat: 60.
// V_raw = ref = 0.5 everywhere; V grows the error by 0.06 at (8, 2) (in the band with a vertical
// edge), by 0.06 at (3, 2) (never in the band), by 0.04 at (11, 3) (in the band, under 0.05), and
// lowers it at (9, 4) (V_raw 0.9, V 0.5). So grown = 1 with a vertical edge, 0 without. The
// baseline away from edges: the other covered pixels (180 in rows 0..8 less the band: 84, or 120
// flat), of which (3, 2) grows, and (8, 2) too when flat: away_grown 1, or 2 flat.
// Every layout is checked at scales 1e-3, 1 and 1e3 and shifted by 1e4 scale units: the counts must
// not change (the measure is dimensionless; the shift's rounding stays under the slack).
#include "shadow/metrics.h"
#include "test_util.h"

enum { W = 20, H = 10, CREASE, STEP, FLAT };

static void gbuffer(int layout, double scale, double shift, float *p, float *n)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            float *pp = p + 4 * (y * W + x), *nn = n + 4 * (y * W + x);
            double lp[3] = {0.1 * x, 0, 0.1 * y}, ln[3] = {0, 1, 0};
            if (x >= 10 && layout == CREASE)
                ln[0] = 1, ln[1] = 0, lp[0] = 1.0, lp[1] = 0.1 * (x - 10);
            if (x >= 10 && layout != CREASE)
                lp[1] = layout == STEP ? 0.06 : 0.04;
            for (int k = 0; k < 3; k++) {
                pp[k] = (float)(shift + scale * lp[k]);
                nn[k] = (float)ln[k];
            }
            pp[3] = y < 9 ? 1.0f : 0.0f;
            nn[3] = y < 9 ? (float)(10.0 * scale) : 0.0f;
            if (y == 9)
                pp[0] = pp[1] = pp[2] = nn[0] = nn[1] = nn[2] = 0.0f;
        }
}

int main(void)
{
    static float p[4 * W * H], n[4 * W * H], v[W * H], v_raw[W * H], ref[W * H];
    for (int i = 0; i < W * H; i++)
        v[i] = v_raw[i] = ref[i] = 0.5f;
    v[2 * W + 8] = 0.56f;
    v[2 * W + 3] = 0.56f;
    v[3 * W + 11] = 0.54f;
    v_raw[4 * W + 9] = 0.9f;
    const double scales[3] = {1e-3, 1.0, 1e3};
    for (int layout = CREASE; layout <= FLAT; layout++)
        for (int s = 0; s < 3; s++)
            for (int shifted = 0; shifted < 2; shifted++) {
                gbuffer(layout, scales[s], shifted ? 1e4 * scales[s] : 0.0, p, n);
                pn_edge_leak e;
                uint8_t cls[W * H];
                CHECK(pn_edge_leak_measure(p, n, v, v_raw, ref, W, H, 0.01, cls, &e));
                size_t band = layout == FLAT ? 60 : 96, grown = layout == FLAT ? 0 : 1;
                CHECK_MSG(e.band == band && e.grown == grown, "layout %d scale %g shift %d: band %zu grown %zu, "
                          "expected %zu and %zu", layout, scales[s], shifted, e.band, e.grown, band, grown);
                CHECK(fabs(e.share - (double)grown / (double)band) < 1e-12);
                size_t away = 180 - band, away_grown = layout == FLAT ? 2 : 1;
                CHECK_MSG(e.away == away && e.away_grown == away_grown, "layout %d scale %g shift %d: away %zu grown "
                          "%zu, expected %zu and %zu", layout, scales[s], shifted, e.away, e.away_grown, away, away_grown);
                CHECK(fabs(e.away_share - (double)away_grown / (double)away) < 1e-12);
                // The classes: (8, 2) grown where counted, (3, 2) never in the band, row 9 not classed.
                CHECK(cls[2 * W + 8] == (layout == FLAT ? 0 : 3) && cls[2 * W + 3] == 0 && cls[9 * W + 3] == 1);
            }
    return pn_test_result();
}
