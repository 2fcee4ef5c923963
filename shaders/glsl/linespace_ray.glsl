// The line-space modes' per-ray walk (TRAVERSAL ray, their default): each ray a 3D-DDA per level
// of the N-tree, all the chunk's rays in one loop. Part of shadow_linespace.comp, after
// linespace_leaf.glsl.

// llvmpipe (Mesa 22.3): this walk is shaped by that driver's cost model (engine/gpu/llvmpipe.md).
// There an `if` does not branch: both sides run masked on all 8 lanes; only loops branch, and their
// bodies run until no lane is active (at least once). So a loop iteration costs its whole body,
// whatever each lane does. The dearest operations are loads from buffers: every component of a
// load is a loop over the 8 lanes with a branch and a scalar load each. On GPUs with real branches
// and vector loads the trade-offs below may differ (measure before copying them). Hence:
// - one loop over all the chunk's rays: a lane whose ray is done takes its next ray in the same
//   iteration (no lane idles until the slowest ray of the group is finished);
// - per iteration at most one node is loaded and classified, shared by starting a ray at the root
//   and visiting a child; of the node only its box is loaded, as two 64-bit components; its level is
//   the depth, and its children group and line space sit at fixed multiples of its index (pools.h);
// - returning to a parent loads nothing: the stack holds the parent's whole DDA state, in separate
//   variables with constant indices (registers updated by selects; a per-lane indexed array would
//   cost a scalar access per lane and word).

// The node pool as 64-bit words, 4 per node (pn_gpu_node, 32 bytes): node i's box (min.xyz, size) is
// words[4i] = (min.x, min.y) and words[4i+1] = (min.z, size). Typed double only to load 64 bits at
// once (the device enables shaderFloat64, not shaderInt64): the bits are only unpacked, never used
// as doubles.
// llvmpipe: two 64-bit loads, not four 32-bit ones, as each loaded component there is a scalar
// loop over the lanes (cost model above).
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer NodeBoxes { double words[]; };

// The DDA of a node over its children: the cell the ray is in, its step direction, the parameters
// where the ray crosses the next cell boundary on each axis and their spacing, the end of the
// segment in the node, and whether the ray has left it.
struct Dda {
    uint node;
    ivec3 cell;
    ivec3 step;
    vec3 t_max;
    vec3 t_delta;
    float t_end;
    bool done;
};

// The tree entry of the DDA's current cell (and its child index), then the DDA advanced to the next cell.
// llvmpipe: branch-free, with no dynamic component index (that driver turns one into branches).
uint dda_step(TreeInfo t, int n, uint n3, inout Dda f, out uint child)
{
    child = uint((f.cell.z * n + f.cell.y) * n + f.cell.x);
    uint entry = t.tree_pool.entries[f.node * n3 + child];
    bool mx = f.t_max.x <= f.t_max.y && f.t_max.x <= f.t_max.z, my = !mx && f.t_max.y <= f.t_max.z;
    bvec3 m = bvec3(mx, my, !mx && !my);
    float t_cell = min(f.t_max.x, min(f.t_max.y, f.t_max.z)); // where the next cell starts
    f.cell += ivec3(m) * f.step;
    f.t_max += mix(vec3(0.0), f.t_delta, m);
    f.done = t_cell > f.t_end || any(lessThan(f.cell, ivec3(0))) || any(greaterThanEqual(f.cell, ivec3(n)));
    return entry;
}

// The chunk's rays `rays` (bits into dir[]) from o: the bits of those that are blocked.
uint rays_blocked(TreeInfo t, vec3 o, uint rays)
{
    int n = int(t.n);
    float fn = float(n);
    uint n3 = t.n * t.n * t.n;
    NodeBoxes boxes = NodeBoxes(t.node_pool);
    uint result = 0u, pending = rays, ray = 0u;
    vec3 d = vec3(0.0);
    float t_start = 0.0, t_trust = 0.0;
    int depth = -1; // of the current node; -1: no ray in flight
    // The ray in the frame of the node last entered. Leaves are walked only in a last-level node,
    // always the deepest frame, so this needs no slot on the stack.
    Local leaf_l = Local(vec3(0.0), vec3(0.0), 0.0);
    Dda f = Dda(0u, ivec3(0), ivec3(0), vec3(0.0), vec3(0.0), 0.0, true);
    // The stack: s<i> holds the DDA of the ancestor at depth i (a node at depth MAX_DEPTH - 1 is
    // never entered below, so 5 slots).
    Dda s0 = f, s1 = f, s2 = f, s3 = f, s4 = f;
    while (depth >= 0 || pending != 0u) {
        bool blocked = false, visit = false;
        uint next = 0u; // the node to visit (classify, and enter if the ray must walk its children)
        if (depth < 0) {
            // Next ray, starting at the root.
            ray = uint(findLSB(pending));
            pending &= pending - 1u;
            d = dir[ray];
            t_start = ray_start(ray);
            t_trust = ray_trust(ray);
            visit = true;
        } else if (f.done) {
            depth--; // this node is done: back to its parent
            f = depth == 0 ? s0 : (depth == 1 ? s1 : (depth == 2 ? s2 : (depth == 3 ? s3 : s4)));
        } else {
            // Up to 3 cells per iteration: after an empty cell the walk goes on to the next one in
            // the same iteration, which saves the rest of an iteration's cost (above all the node
            // and line-space loads) for the common empty cells.
            // llvmpipe (Mesa 22.3): written out, not as a loop, so that it costs no loop budget;
            // 3 beats 2 and 4 as measured there.
            uint child;
            uint entry = dda_step(t, n, n3, f, child);
            if (entry == CELL_EMPTY && !f.done)
                entry = dda_step(t, n, n3, f, child);
            if (entry == CELL_EMPTY && !f.done)
                entry = dda_step(t, n, n3, f, child);
            // A filled leaf, reached by a ray walking a last-level node's children (in linespace mode
            // only rays in a face plane walk them): the mode decides (leaf_blocks). The DDA has moved
            // on: the leaf is the cell it left. ls-leaf and ls-plane need where the ray is in it:
            // the same slab test as the packet traversal's, in the node's frame (leaf_l).
            // Also where the leaf blocks the ray in linespace mode (rays in a face plane), for the
            // blocker's t (hybrid and exact-ls record their triangles' hits).
            float t_in = 0.0, t_out = 1.0;
            if (entry == CELL_FILLED && !(HYBRID || EXACT_LS)) {
                uvec3 c = uvec3(child % t.n, (child / t.n) % t.n, child / (t.n * t.n));
                Local lc = Local(leaf_l.o - vec3(c), leaf_l.d, leaf_l.eps);
                ls_slabs(lc, 1.0, t_in, t_out);
            }
            if (entry == CELL_FILLED)
                blocked = leaf_blocks(f.node, child, n3, o, d, leaf_l.o, leaf_l.d, leaf_l.eps, t_in, t_out);
            if (blocked)
                blocker_at(ray, leaf_exact(f.node, child, n3) ? last_hit_t() : max(t_in, t_start));
            visit = entry > CELL_FILLED;
            next = entry - 2u;
        }
        if (visit) {
            if (COUNT_WORK)
                work = uvec4(work.x + 1u, work.yz, max(work.w, uint(depth + 2)));
            vec2 xy = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * next]));
            vec2 zs = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * next + 1u]));
            Local l = ls_local_box(vec3(xy, zs.x), zs.y, fn, o, d);
            float t_in, t_out;
            bool hit = ls_slabs(l, fn, t_in, t_out);
            int c = ls_classify_local(t, uint(depth + 1), next * t.ls_words, l, hit, t_in, t_out, t_start, t_trust);
            bool blocks = ls_blocks(c, next, n3);
            if (blocks)
                blocker_at(ray, max(t_in, t_start));
            blocked = blocked || blocks;
            if (ls_walks(c, blocks) && depth + 1 < MAX_DEPTH) {
                s0 = depth == 0 ? f : s0;
                s1 = depth == 1 ? f : s1;
                s2 = depth == 2 ? f : s2;
                s3 = depth == 3 ? f : s3;
                s4 = depth == 4 ? f : s4;
                depth++;
                // The child's DDA from where the ray enters it (or starts).
                float t0 = max(t_in, t_start);
                bvec3 flat_axis = equal(l.d, vec3(0.0));
                f.node = next;
                f.t_end = min(t_out, 1.0);
                leaf_l = l;
                f.cell = clamp(ivec3(floor(l.o + t0 * l.d)), ivec3(0), ivec3(n - 1));
                f.step = ivec3(sign(l.d));
                vec3 boundary = vec3(f.cell + ivec3(greaterThan(l.d, vec3(0.0))));
                f.t_max = mix((boundary - l.o) / l.d, vec3(1e30), flat_axis);
                f.t_delta = mix(abs(1.0 / l.d), vec3(1e30), flat_axis);
                f.done = t0 > f.t_end;
            }
        }
        if (blocked) {
            result |= 1u << ray;
            depth = -1;
        }
    }
    truncated = truncated || depth >= 0 || pending != 0u;
    return result;
}
