// Alpha-masked casters (pn_material.alpha_cutoff) for the exact shadow tests: what a shadow ray
// needs to go on past a cut-out texel, appended to the triangle pool (pn_triangle_pool, bvh.h) and
// read by shaders/glsl/alpha.glsl. Opaque scenes add nothing: their pool is the triangles alone.
#pragma once
#include <stdint.h>

#include "core/error.h"
#include "scene/scene.h"

// Triangles whose draw's material is alpha-masked.
uint64_t pn_alpha_masked_triangles(const pn_scene *s);

// masked[t] = 1 for each triangle t (scene order) that pn_alpha_masked_triangles counts, else 0;
// masked holds pn_scene_triangle_count(s) bytes. The triangles whose records pn_alpha_pool_fill
// writes: those whose first vertex's w is not 0 in the pool.
void pn_alpha_mark(const pn_scene *s, uint8_t *masked);

// The same in a new array, *out (to free); NULL when no triangle is masked.
pn_result pn_alpha_triangle_flags(const pn_scene *s, uint8_t **out);

// vec4s the masks of s take after its n = pn_scene_triangle_count triangles' 3 n.
uint64_t pn_alpha_pool_vec4s(const pn_scene *s);

// Writes them at pool + 12 n floats and marks each masked triangle's first vertex's w with the
// index (a uint's bits) of its record; pool holds 3 n + pn_alpha_pool_vec4s vec4s. Layout, in vec4s:
//   per masked material (first use order): [width, height, first texel vec4 (uint bits), cutoff],
//     [base colour alpha, 0, 0, 0]; width 0: no texture;
//   its texture's alpha, 8 bits per texel, 16 texels per vec4 (uint words, low byte first);
//   per masked triangle: [uv_a, uv_b], [uv_c, its material's first vec4 (uint bits), 0].
pn_result pn_alpha_pool_fill(const pn_scene *s, float *pool);
