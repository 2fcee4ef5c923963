// Per-object trees for linespace (--trees object): the top level over the objects' world boxes and
// each object's tree in its own frame. Part of shadow_linespace.comp, after linespace_packet.glsl.

// Per-object trees (--trees object, accel/objects.h): each object has its own tree in its own frame;
// a BVH over the objects' world boxes finds those the pixel's rays may reach, and the rays are
// carried into each one's frame by its affine map. An affine map keeps a segment's parameter: the
// point at t of the world segment o + t d is the point at t of the local one, so t_rise and the
// traversal's [t_start, 1] carry over unchanged. Each tree has leaves of its own world size: a ray
// rises clear of its surface by the object's leaves (ObjectData.rise_scale times the finest tree's,
// the params' leaf_size) before that tree may block it, by the argument of shadow_origin for a leaf
// that fits in a world box of that edge.

vec3 to_local(ObjectData ob, vec3 x)
{
    return vec3(dot(ob.to_local[0].xyz, x) + ob.to_local[0].w, dot(ob.to_local[1].xyz, x) + ob.to_local[1].w,
                dot(ob.to_local[2].xyz, x) + ob.to_local[2].w);
}

vec3 to_local_dir(ObjectData ob, vec3 d)
{
    return vec3(dot(ob.to_local[0].xyz, d), dot(ob.to_local[1].xyz, d), dot(ob.to_local[2].xyz, d));
}

// The blocked ones of `rays` from o to the light's `corners` (the packet's pyramid), over the objects.
uint objects_blocked(vec3 o, vec3 corners[4], uint count, uint rays)
{
    // Every segment lies in the convex hull of o and the corners, so in this box.
    vec3 lo = min(o, min(min(corners[0], corners[1]), min(corners[2], corners[3])));
    vec3 hi = max(o, max(max(corners[0], corners[1]), max(corners[2], corners[3])));
    vec3 dir_world[MAX_CHUNK];
    float rise_world[MAX_CHUNK];
    for (uint j = 0u; j < count; j++) {
        dir_world[j] = dir[j];
        rise_world[j] = t_rise[j];
    }
    uint blocked = 0u;
    uint stack[PN_BVH_STACK];
    int sp = 0;
    uint node = 0u;
    bool more = params.object_count > 0u;
    while (more && (rays & ~blocked) != 0u) {
        BvhNodeData nd = params.top.nodes[node];
        bool hit = all(lessThanEqual(nd.min, hi)) && all(greaterThanEqual(nd.max, lo));
        if (COUNT_WORK)
            work.x++;
        // A leaf's objects, each in its own frame.
        for (uint k = 0u; hit && k < nd.count; k++) {
            ObjectData ob = params.objects.objects[params.top_ids.ids[nd.first + k]];
            uint live = rays & ~blocked;
            for (uint j = 0u; j < count; j++) {
                dir[j] = to_local_dir(ob, dir_world[j]);
                t_rise[j] = rise_world[j] * ob.rise_scale;
                live &= t_rise[j] < 1.0 ? ~0u : ~(1u << j); // within its leaves of the surface up to the light
            }
            vec3 ol = to_local(ob, o);
            if (TRAVERSAL == PN_TRAVERSAL_PACKET_ID) {
                vec3 cl[4] = vec3[4](to_local(ob, corners[0]), to_local(ob, corners[1]), to_local(ob, corners[2]),
                                     to_local(ob, corners[3]));
                blocked |= live != 0u ? packet_blocked(ob.tree, ol, cl, count, live) : 0u;
            } else {
                blocked |= live != 0u ? rays_blocked(ob.tree, ol, live) : 0u;
            }
        }
        bool inner = hit && nd.count == 0u;
        if (inner && sp < PN_BVH_STACK) {
            stack[sp++] = nd.first + 1u;
            node = nd.first;
        } else if (sp > 0) {
            node = stack[--sp];
        } else {
            more = false;
        }
    }
    for (uint j = 0u; j < count; j++) {
        dir[j] = dir_world[j];
        t_rise[j] = rise_world[j];
    }
    truncated = truncated || (more && (rays & ~blocked) != 0u); // cut short, not done because all are blocked
    return blocked;
}
