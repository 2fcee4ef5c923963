// Hashes shared by the shadow passes' samplers and the temporal history's lineages.
#ifndef PN_HASH_GLSL
#define PN_HASH_GLSL

// PCG hash (O'Neill): decorrelates pixels and seeds.
uint pcg(uint v)
{
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// A pixel's sampler key: its tile's hash for the frame's seed (shadow_common.glsl's pixel_sampler;
// the pixel itself for a 1 x 1 tile).
uint tile_hash(uvec2 tile, uint seed) { return pcg(tile.x + pcg(tile.y + pcg(seed))); }

// The key of a lineage the temporal history starts at `pixel` in `frame` (history.comp): the
// pixel's own key drawn again for the frame, so that no lineage started later shares an earlier
// one's samples (a pixel uncovered this frame would otherwise draw what the lineage that began
// in its place frames ago draws now, wherever that has gone).
uint lineage_key(uvec2 pixel, uint seed, uint frame) { return pcg(tile_hash(pixel, seed) ^ pcg(frame + 0x9e3779b9u)); }

#endif
