// The line-space modes' packet walk (TRAVERSAL packet): the pixel's rays together, slice by slice
// along the light direction's dominant axis (Klee 2016, sec. 4.3). Part of shadow_linespace.comp,
// after linespace_ray.glsl (shares its node loads).


// One frame per depth: the slices of `node` along axis k, and in the current slice the cells of
// the packet's footprint [u0,u1] x [v0,v1]; `rays` are the rays that descended into this node.
struct PacketFrame {
    uint node;
    uint rays;
    int slice, slice_end, slice_step;
    int u, v, u0, u1, v0, v1;
};


// Footprint of the packet (the pyramid from o over the light's corners) in slice [s, s+1] along
// axis k, in node-local cell units: the box of the pyramid's points in the slab, i.e. of its
// vertices inside it and its edges' crossings of the slab's two planes.
void packet_footprint(vec3 o_local, vec3 q_local[4], int k, int s, float n, out ivec4 range)
{
    int a = (k + 1) % 3, b = (k + 2) % 3;
    vec2 lo = vec2(1e30), hi = vec2(-1e30);
    float z0 = float(s), z1 = float(s + 1);
    if (o_local[k] >= z0 && o_local[k] <= z1) {
        lo = min(lo, vec2(o_local[a], o_local[b]));
        hi = max(hi, vec2(o_local[a], o_local[b]));
    }
    [[unroll]] for (int i = 0; i < 4; i++) {
        vec3 q = q_local[i];
        if (q[k] >= z0 && q[k] <= z1) {
            lo = min(lo, vec2(q[a], q[b]));
            hi = max(hi, vec2(q[a], q[b]));
        }
        // Edges from the apex and along the light's rim, crossing either plane.
        vec3 e0[2] = vec3[2](o_local, q_local[(i + 1) & 3]);
        [[unroll]] for (int e = 0; e < 2; e++) {
            vec3 p0 = e0[e], d = q - p0;
            [[unroll]] for (int side = 0; side < 2; side++) {
                float z = side == 0 ? z0 : z1;
                if (d[k] != 0.0) {
                    float tt = (z - p0[k]) / d[k];
                    if (tt >= 0.0 && tt <= 1.0) {
                        vec3 x = p0 + tt * d;
                        lo = min(lo, vec2(x[a], x[b]));
                        hi = max(hi, vec2(x[a], x[b]));
                    }
                }
            }
        }
    }
    // Cells touched, widened by one cell for rounding; empty when the packet misses the slice.
    int nn = int(n) - 1;
    range = lo.x > hi.x ? ivec4(1, 0, 1, 0)
                        : ivec4(clamp(int(floor(lo.x)) - 1, 0, nn), clamp(int(floor(hi.x)) + 1, 0, nn),
                                clamp(int(floor(lo.y)) - 1, 0, nn), clamp(int(floor(hi.y)) + 1, 0, nn));
}

uint packet_blocked(TreeInfo t, vec3 o, vec3 corners[4], uint count, uint rays)
{
    // Dominant axis of the direction to the light's centre: slices along it, front to back.
    vec3 c = 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]) - o;
    vec3 ac = abs(c);
    int k = ac.x >= ac.y && ac.x >= ac.z ? 0 : (ac.y >= ac.z ? 1 : 2);
    int a = (k + 1) % 3, b = (k + 2) % 3;
    int n = int(t.n);
    float fn = float(n);
    uint blocked = 0u;

    // The root, classified ray by ray.
    Node root = t.node_pool.nodes[0];
    uint descend = 0u;
    uint n3 = t.n * t.n * t.n;
    // llvmpipe: loops over rays visit the set bits only, as every iteration counts against the
    // loop budget there.
    for (uint left = rays; left != 0u; left &= left - 1u) {
        uint i = uint(findLSB(left));
        int r = ls_classify(t, root, o, dir[i], ray_start(i), ray_trust(i));
        bool blocks = ls_blocks(r, 0u, n3);
        if (blocks)
            blocker_at(i, ray_start(i)); // a root without children: the blocker lies beyond the start
        blocked |= blocks ? (1u << i) : 0u;
        descend |= ls_walks(r, blocks) ? (1u << i) : 0u;
    }
    // The top frame lives in registers, its ancestors in p<i> for depth i: separate variables with
    // constant indices, updated by selects.
    // llvmpipe: a per-lane indexed array costs a scalar access per lane and word there, run on
    // every iteration, masked, whether or not a lane needs it.
    int depth = descend != 0u ? 0 : -1;
    PacketFrame f = PacketFrame(0u, descend, 0, 0, 0, 0, 0, 0, 0, 0, 0);
    PacketFrame p0 = f, p1 = f, p2 = f, p3 = f, p4 = f;
    NodeBoxes boxes = NodeBoxes(t.node_pool);
    bool fresh = true; // the top frame has not set up its slices yet
    while (depth >= 0 && (rays & ~blocked) != 0u) {
        // Of the node only its box is loaded (see rays_blocked); its children group is at index * N^3.
        vec2 xy = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * f.node]));
        vec2 zs = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * f.node + 1u]));
        vec3 node_min = vec3(xy, zs.x);
        float s = fn / zs.y;
        vec3 o_local = (o - node_min) * s;
        vec3 q_local[4];
        [[unroll]] for (int i = 0; i < 4; i++)
            q_local[i] = (corners[i] - node_min) * s;
        // A new node starts at its first slice, a slice whose footprint is done goes on to the next
        // slice; either needs the footprint, computed once per iteration (a slice whose footprint is
        // empty is left in the next iteration).
        bool past = !fresh && (f.v > f.v1 || f.u > f.u1);
        if (fresh) {
            // Slices the packet spans in this node, in the direction of travel.
            float kmin = min(o_local[k], min(min(q_local[0][k], q_local[1][k]), min(q_local[2][k], q_local[3][k])));
            float kmax = max(o_local[k], max(max(q_local[0][k], q_local[1][k]), max(q_local[2][k], q_local[3][k])));
            int s0 = clamp(int(floor(kmin)) - 1, 0, n - 1), s1 = clamp(int(floor(kmax)) + 1, 0, n - 1);
            f.slice_step = c[k] >= 0.0 ? 1 : -1;
            f.slice = f.slice_step > 0 ? s0 : s1;
            f.slice_end = f.slice_step > 0 ? s1 + 1 : s0 - 1;
        } else if (past) {
            f.slice += f.slice_step;
        }
        if ((fresh || past) && f.slice != f.slice_end) {
            ivec4 r;
            packet_footprint(o_local, q_local, k, f.slice, fn, r);
            f.u0 = r.x, f.u1 = r.y, f.v0 = r.z, f.v1 = r.w;
            f.u = f.u0;
            f.v = f.v0;
        }
        fresh = false;
        if (f.slice == f.slice_end) {
            depth--; // this node is done
            f = depth == 0 ? p0 : (depth == 1 ? p1 : (depth == 2 ? p2 : (depth == 3 ? p3 : p4)));
        } else if (f.u <= f.u1 && f.v <= f.v1) {
            ivec3 cell;
            cell[k] = f.slice;
            cell[a] = f.u;
            cell[b] = f.v;
            // Next cell of the footprint, row by row.
            f.u++;
            if (f.u > f.u1) {
                f.u = f.u0;
                f.v++;
            }
            uint entry = t.tree_pool.entries[f.node * n3 + uint((cell.z * n + cell.y) * n + cell.x)];
            uint live = f.rays & ~blocked;
            if (entry == CELL_FILLED) {
                // A leaf, reached by rays walking a last-level node's children: the mode decides for
                // each of them that crosses it (leaf_blocks).
                for (uint left = live; left != 0u; left &= left - 1u) {
                    uint i = uint(findLSB(left));
                    Local l = ls_local_box(node_min, zs.y, fn, o, dir[i]);
                    l.o -= vec3(cell);
                    float t_in, t_out;
                    bool hit = ls_slabs(l, 1.0, t_in, t_out) && t_in <= 1.0 && t_out >= ray_start(i);
                    uint ci = uint((cell.z * n + cell.y) * n + cell.x);
                    hit = hit && leaf_blocks(f.node, ci, n3, o, dir[i], l.o + vec3(cell), l.d, l.eps, t_in, t_out);
                    if (hit)
                        blocker_at(i, leaf_exact(f.node, ci, n3) ? last_hit_t() : max(t_in, ray_start(i)));
                    blocked |= hit ? (1u << i) : 0u;
                }
            } else if (entry != CELL_EMPTY && live != 0u) {
                uint child_index = entry - 2u;
                vec2 cxy = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * child_index]));
                vec2 czs = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * child_index + 1u]));
                uint down = 0u;
                if (COUNT_WORK) // the packet visits the child once for all its rays
                    work = uvec4(work.x + 1u, work.yz, max(work.w, uint(depth + 2)));
                for (uint left = live; left != 0u; left &= left - 1u) {
                    uint i = uint(findLSB(left));
                    Local l = ls_local_box(vec3(cxy, czs.x), czs.y, fn, o, dir[i]);
                    float t_in, t_out;
                    bool hit = ls_slabs(l, fn, t_in, t_out);
                    // The child's level is depth + 1, its line space at index * ls_words (pools.h).
                    int r = ls_classify_local(t, uint(depth + 1), child_index * t.ls_words, l, hit, t_in, t_out,
                                              ray_start(i), ray_trust(i));
                    bool blocks = ls_blocks(r, child_index, n3);
                    if (blocks)
                        blocker_at(i, max(t_in, ray_start(i)));
                    blocked |= blocks ? (1u << i) : 0u;
                    down |= ls_walks(r, blocks) ? (1u << i) : 0u;
                }
                if (down != 0u && depth + 1 < MAX_DEPTH) {
                    p0 = depth == 0 ? f : p0;
                    p1 = depth == 1 ? f : p1;
                    p2 = depth == 2 ? f : p2;
                    p3 = depth == 3 ? f : p3;
                    p4 = depth == 4 ? f : p4;
                    depth++;
                    f.node = child_index;
                    f.rays = down;
                    fresh = true;
                }
            }
        }
    }
    truncated = truncated || (depth >= 0 && (rays & ~blocked) != 0u);
    return blocked;
}
