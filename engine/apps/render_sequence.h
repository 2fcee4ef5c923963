// penumbra render --frames (apps/render_sequence.c): an animated scene's frames, one EXR each.
#pragma once
#include <stdbool.h>

#include "apps/options.h"
#include "gpu/device.h"

// --frames A:B[:STEP] (integers within 1e9, A <= B, STEP >= 1) into *q; logs the problem and
// returns false.
bool pn_parse_frames(const char *v, pn_sequence *q);

// Whether `pattern` (-o) holds the frame number as one %d or %0Nd; logs why not, naming `opt`.
bool pn_frame_pattern_ok(const char *opt, const char *pattern);

// The name of frame f: `pattern` (checked by pn_frame_pattern_ok) with f in it.
void pn_frame_name(const char *pattern, long long f, char *out, size_t n);

// Renders o->seq's frames of the prepared scene (its share, with a shard) to o->output's pattern.
// Returns a PN_EXIT_* code; what failed is logged, the frames written before it stay.
int pn_render_sequence(const pn_render_cmd_opts *o, pn_prepared_scene *prep, pn_gpu_device *dev);
