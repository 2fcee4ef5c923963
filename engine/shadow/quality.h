// --quality auto: choose the shadow mode, N-tree and samples per pixel for a scene, a light and an
// error budget from pilot renders, instead of by hand. Used by render, bench and the library
// (engine/api: penumbra_visibility_desc.max_error), so it lives with the set-ups it measures.
#pragma once
#include <stdio.h>

#include "gpu/renderer.h"
#include "scene/view.h"

// Every configuration auto can try: each mode with up to PN_QUALITY_MAX_TREES trees (quality.c)
// at 1, 2, 4, ... PN_QUALITY_MAX_SPP samples per pixel (9 steps), then adaptively from
// PN_QUALITY_ADAPTIVE_MIN up to PN_QUALITY_MAX_SPP samples at PN_QUALITY_ADAPTIVE_STEPS pixel
// errors, so that none is left out of the record or the run-off.
enum { PN_QUALITY_MAX_SPP = 256, PN_QUALITY_MAX_TREES = 4, PN_QUALITY_ADAPTIVE_MIN = 4, PN_QUALITY_ADAPTIVE_STEPS = 6 };
// And every uniform step once more with the penumbra filter, then adaptive samples under it, MIN:4 MIN
// for MIN = 1, 2, ... 64 (PN_QUALITY_FILTERED_STEPS).
enum { PN_QUALITY_FILTERED_STEPS = 7 };
enum { PN_QUALITY_MAX_TRIED = PN_SHADOW_MODE_COUNT * PN_QUALITY_MAX_TREES *
                              (2 * 9 + PN_QUALITY_ADAPTIVE_STEPS + PN_QUALITY_FILTERED_STEPS) };

// Where a pilot's error was confirmed (pn_quality_tried.confirm_mae).
typedef enum pn_quality_confirm {
    PN_QUALITY_CONFIRM_NONE,   // the pilot decided
    PN_QUALITY_CONFIRM_DOUBLE, // at twice the pilot's width and height (or the frame itself)
    PN_QUALITY_CONFIRM_FRAME,  // filtered: at the frame's size, over one pixel per pilot pixel (quality.c, frame_sample)
    PN_QUALITY_CONFIRM_BOUND,  // filtered: outside by the frame's error predicted from the pilot's (confirm_mae)
} pn_quality_confirm;

// One configuration a pilot rendered.
typedef struct pn_quality_tried {
    pn_shadow_mode mode;
    int tree_n, tree_d;
    uint32_t spp;         // uniform: every pixel's samples; adaptive: the most a pixel takes
    uint32_t spp_min;     // adaptive: the first round's samples (render --spp MIN:MAX); 0: uniform
    float pixel_error;    // adaptive: the target standard error of a pixel's V (--pixel-error)
    double mean_rays;     // the rays a covered pixel of the pilot took, on average (spp when uniform)
    double pilot_mae, pilot_se, pilot_ms; // se: standard error of the MAE as an estimate of the picture's
    double confirm_mae; // where confirmed (confirm_at), its MAE there; else -1
    double confirm_se;  // that MAE's standard error as an estimate of the frame's (0 at the frame itself)
    bool within;        // judged within the budget
    double final_ms;    // its shadow (and filter) pass at the frame's size in the run-off, or -1 if not a finalist
    pn_filter filter;   // none, or penumbra; its times include the filter pass
    pn_quality_confirm confirm_at;
} pn_quality_tried;

typedef struct pn_quality_choice {
    pn_shadow_mode mode;
    int tree_n, tree_d;   // for the tree modes
    uint32_t spp;
    uint32_t spp_min;     // adaptive samples, spp_min:spp at pixel_error; 0: uniform
    float pixel_error;
    pn_filter filter;     // none or penumbra: the frame renders the pick with it
    bool within;          // the pick's pilot error is within the budget (else: the least error found)
    double pilot_mae;     // mean |V - V_ref| over the pilot's pixels with geometry
    double pilot_se;      // its standard error (0 when the frame is its own pilot)
    double confirm_mae;   // its MAE at the confirming size, or -1 when the pilot decided
    double pilot_ms;      // its shadow pass, and its filter pass when filtered (the JSON's pilot_shadow_ms)
    double reference_ms;  // the pilot reference's shadow pass
    int candidates;       // pilots rendered
    int runoff;           // finalists timed at the frame's size (0 or 1: the pilots decided)
    pn_quality_tried tried[PN_QUALITY_MAX_TRIED]; // the first of them, in the order tried
    uint32_t pilot_width, pilot_height;
    uint32_t confirm_width, confirm_height; // 0 when no pilot needed confirming
    // The pixels of the frame a filtered pilot's error was measured at, a grid of cells with one
    // each (PN_QUALITY_CONFIRM_FRAME); 0 when the frame is its own pilot or none was filtered.
    uint32_t frame_sample_width, frame_sample_height;
} pn_quality_choice;

// Renders a pilot (the frame's framing at about 128x128 pixels, or the frame itself when smaller)
// with the converged reference (exact, reference_spp samples, PN_REFERENCE_SEED), then every
// configuration of the mode table (gpu/shadow_modes.c: line space, coarse to fine trees, hybrid,
// exact-ls, exact, rayquery and rtpipeline where the device has them) at 1, 2, 4, ... PN_QUALITY_MAX_SPP
// samples per pixel with frame's sampler and seed, and picks the fastest whose pilot error (MAE of V
// against the reference, over pixels with geometry) is at most max_error: by two standard errors
// of margin when the pilot is smaller than the frame, and where the pilot cannot tell, by the same
// configuration at twice the pilot's width and height (or the frame itself) against that size's
// reference. A configuration climbs the samples until it meets the budget, is slower than the best
// pick so far, or its error stops falling (line space's floor). Then, where that climb went past 4
// samples, the sampler is stratified, the light has an area, and the mode is exact or its uniform
// climb met the budget (adaptive samples cut noise, not a floor), it climbs adaptive samples,
// PN_QUALITY_ADAPTIVE_MIN up to PN_QUALITY_MAX_SPP, down the pixel errors 32, 16, 8, 4, 2 and 1
// times the budget, with the same three reasons to stop (quality.c, adaptive_error). And where the
// frame has a filter (frame->filter, not none: it chooses between none and penumbra, whichever
// filter the frame named) and allows one (the even split) and the light has an area, each
// configuration climbs its uniform samples once more with the penumbra filter (its times include
// the filter pass): the filter is a choice like the samples. Where adaptive samples are allowed
// too, and that filtered climb went past one sample (an exact mode, or the climb met the budget),
// adaptive samples under the filter follow: MIN:4 MIN for MIN = 1, 2, 4, ... below where it ended,
// at a pixel error of twice the budget (quality.c, filtered_adaptive_climb). Where the pilot is
// smaller than the frame, a filtered configuration's error is the frame's own: the frame rendered
// on the pilot's tree, at one pixel per pilot pixel, against the reference there (quality.c,
// frame_sample; PN_QUALITY_CONFIRM_FRAME). When nothing meets the budget, the least error found
// (within = false).
// Pilots within the budget and within 1.5x of the fastest one's time (at most 4) are then timed at
// the frame's size side by side, and the fastest there is the pick (final_ms; quality.c, runoff).
// reference_spp: the reference's samples (0: PN_REFERENCE_SPP).
// Renders the `count` renderers in turn, `warmup` rounds untimed and then `rounds` timed; each keeps
// its least shadow time in least_ms[k]. Configurations timed moments apart meet different loads of
// the machine; side by side, a load lasting a few frames slows all alike, and the least frame is the
// one it touched least. The run-off and bench --max-error compare configurations this way.
pn_result pn_quality_time_side_by_side(pn_renderer *const *r, int count, int warmup, int rounds,
                                       const pn_camera *cam, const pn_light *light, double *least_ms);

// Writes the pilots tried as a JSON array (mode, tree, spp, errors, within, times), every number
// with 17 significant digits: a reader gets the very doubles the choice compared, so it can replay
// the choice from the report, ties and margins included (tests/quality_rule.py).
void pn_quality_write_tried(FILE *f, const pn_quality_choice *q);

// uniform_only: no adaptive climb (the library's points have no neighbours to decide by).
pn_result pn_quality_choose(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                            const pn_renderer_desc *frame, double max_error, uint64_t max_bytes, uint32_t reference_spp,
                            bool uniform_only, pn_quality_choice *out);
