// --quality auto: choose the shadow mode and N-tree for a scene, a light and an error budget from
// pilot renders, instead of by hand.
#pragma once
#include "gpu/renderer.h"
#include "scene/view.h"

enum { PN_QUALITY_MAX_TRIED = 32 };

// One configuration a pilot rendered.
typedef struct pn_quality_tried {
    pn_shadow_mode mode;
    int tree_n, tree_d;
    double pilot_mae, pilot_ms;
} pn_quality_tried;

typedef struct pn_quality_choice {
    pn_shadow_mode mode;
    int tree_n, tree_d;   // for the tree modes
    double pilot_mae;     // mean |V - V_exact| over the pilot's pixels
    double pilot_ms;      // its shadow pass
    double exact_ms;      // exact's shadow pass on the pilot
    int candidates;       // configurations tried (besides exact)
    pn_quality_tried tried[PN_QUALITY_MAX_TRIED]; // the first of them, in the order tried
    uint32_t pilot_width, pilot_height;
} pn_quality_choice;

// Renders a pilot (a quarter of the pixels: half the width and height, at least 64 wide) with
// exact, then with the candidate configurations of the mode table (gpu/shadow_modes.c: line space,
// coarse to fine trees, hybrid, exact-ls, and rayquery where the device has ray queries), and
// picks the fastest whose pilot error (MAE of
// V against exact, over pixels with geometry) is at most max_error; exact when none is.
pn_result pn_quality_choose(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                            const pn_renderer_desc *frame, double max_error, uint64_t max_bytes, pn_quality_choice *out);
