// PNG preview output (libpng) and the tone mapping it shows.
#pragma once
#include <stdint.h>

#include "core/error.h"

// Writes 8-bit RGB, row 0 at the top, to a temporary name and renames it into place.
pn_result pn_png_write_rgb8(const char *path, int width, int height, const uint8_t *rgb);

// Tone maps linear HDR radiance to display sRGB: exposure scale, then x/(1+x) per channel, then
// the sRGB transfer curve. `rgba` holds width*height*4 floats; out gets width*height*3 bytes.
void pn_tonemap_srgb8(const float *rgba, int width, int height, float exposure, uint8_t *out);
