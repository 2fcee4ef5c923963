// A built-in 5x7 bitmap font for ASCII 32..126, for the demo's overlay text: no font files, no
// font library. Each glyph sits in a 6x10 cell (one column and three rows of spacing).
#pragma once
#include <stddef.h>
#include <stdint.h>

#define PN_FONT_CELL_W 6
#define PN_FONT_CELL_H 10

// Draws `text` into an RGBA8 image (row 0 at the top) with its first cell's top-left corner at
// (x, y), every font pixel a scale x scale square of `rgb`. '\n' starts a new line; characters
// outside 32..126 draw as '?'. Clipped to the image.
void pn_font_draw(uint8_t *rgba, int width, int height, int x, int y, int scale, const uint8_t rgb[3],
                  const char *text);

// The size of `text` in cells: the longest line's characters and the number of lines.
void pn_font_measure(const char *text, int *columns, int *lines);
