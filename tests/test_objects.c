// Objects that move (pn_scene_move_object, the demo's live moves) and per-object trees
// (accel/objects.h): the scene's bounds after each move are those a pass over the whole scene finds;
// the triangles of no object left out at build (a receiver under everything, lit from above) stay
// left out rightly while the moved objects stay on their side of it, and pn_objects_cull_holds says
// when they do not.
#include "accel/objects.h"
#include "scene/view.h"
#include "test_util.h"

// Moves object i and checks the bounds it leaves against pn_scene_update_bounds'.
static pn_result move(pn_scene *s, uint32_t i, float dx, float dy, float dz)
{
    pn_result r = pn_scene_move_object(s, i, (const float[3]){dx, dy, dz});
    float lo[3], hi[3];
    memcpy(lo, s->bounds_min, sizeof lo);
    memcpy(hi, s->bounds_max, sizeof hi);
    pn_scene_update_bounds(s);
    CHECK_MSG(!memcmp(lo, s->bounds_min, sizeof lo) && !memcmp(hi, s->bounds_max, sizeof hi),
              "after moving by (%g, %g, %g): bounds (%g %g %g)-(%g %g %g), a full pass finds (%g %g %g)-(%g %g %g)",
              (double)dx, (double)dy, (double)dz, (double)lo[0], (double)lo[1], (double)lo[2], (double)hi[0],
              (double)hi[1], (double)hi[2], (double)s->bounds_min[0], (double)s->bounds_min[1],
              (double)s->bounds_min[2], (double)s->bounds_max[0], (double)s->bounds_max[1], (double)s->bounds_max[2]);
    return r;
}

int main(void)
{
    // builtin:penumbra: a 4x4 receiver at y = 0 (triangles 0-1, vertices 0-3) under a 0.5x0.5
    // occluder at y = 0.5 (triangles 2-3, vertices 4-7). The occluder becomes object 0 of mesh 0,
    // placed where it is; the receiver is the rest.
    pn_scene s;
    CHECK(pn_builtin_load("penumbra", &s) == PN_OK);
    CHECK(s.index_count == 12 && s.vertex_count == 8);
    s.meshes = calloc(1, sizeof *s.meshes);
    s.objects = calloc(1, sizeof *s.objects);
    float(*tris)[3][3] = malloc(2 * sizeof *tris);
    if (!s.meshes || !s.objects || !tris)
        return 1;
    for (int t = 0; t < 2; t++)
        for (int c = 0; c < 3; c++)
            memcpy(tris[t][c], s.vertices[s.indices[6 + 3 * t + c]].pos, sizeof tris[t][c]);
    s.meshes[0] = (pn_scene_mesh){tris, 2};
    s.mesh_count = 1;
    s.objects[0] = (pn_scene_object){.mesh = 0, .to_world = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}},
                                     .first_index = 6, .index_count = 6, .first_vertex = 4, .vertex_count = 4};
    s.object_count = 1;

    pn_light light = {.pos = {0, 2, 0}, .normal = {0, -1, 0}, .up = {0, 0, 1}, .size = {1, 1}, .radiance = {1, 1, 1}};
    float corners[4][3];
    pn_light_corners(&light, corners);
    pn_objects o;
    CHECK(pn_objects_build(&s, &(pn_ntree_desc){.n = 4, .d = 2, .cull_light = (const float(*)[3])corners,
                                                .cull_light_corners = 4},
                           &o) == PN_OK);
    CHECK_MSG(o.culled == 2 && o.tree_count == 1 && o.placed == 1, "culled %u, trees %u, placed %u", o.culled,
              o.tree_count, o.placed);
    CHECK(pn_objects_cull_holds(&s, &o));

    // Sideways over the receiver: the bounds stay those of the build.
    CHECK(move(&s, 0, 1, 0, 0) == PN_OK);
    CHECK(pn_objects_cull_holds(&s, &o));
    // Up, above the build's bounds: still over the receiver's plane, on the light's side.
    CHECK(move(&s, 0, 0, 2, 0) == PN_OK);
    CHECK(pn_objects_cull_holds(&s, &o));
    // Under the receiver: a ray from the object to the light crosses it, which was left out.
    CHECK(move(&s, 0, 0, -3, 0) == PN_OK);
    CHECK(!pn_objects_cull_holds(&s, &o));
    // Back above: holds again (the question is about the scene as it stands).
    CHECK(move(&s, 0, 0, 1, 0) == PN_OK);
    CHECK(pn_objects_cull_holds(&s, &o));
    // The occluder holds the top face of the bounds (y = 0.5): along it, off it and back onto it,
    // past the receiver's edge and back (the receiver then holds the x faces again).
    CHECK(move(&s, 0, -1, 0, 0) == PN_OK);
    CHECK(move(&s, 0, 0, -0.25f, 0) == PN_OK);
    CHECK(move(&s, 0, 0, 0.5f, 0) == PN_OK);
    CHECK(move(&s, 0, 3, 0, 0) == PN_OK);
    CHECK(move(&s, 0, -3, 0, 0.125f) == PN_OK);
    CHECK(move(&s, 0, 0, 0, -0.125f) == PN_OK);
    // Steps that round (0.1 and 0.3 are not floats): the moved box must still be the one a full
    // pass finds, to the bit, growing the bounds outwards in every axis.
    CHECK(move(&s, 0, 2.1f, 0.3f, -2.7f) == PN_OK);
    CHECK(move(&s, 0, -4.3f, -0.1f, 5.3f) == PN_OK);

    // Nothing left out (no light to cull by): nothing to hold, whatever moves.
    pn_objects all;
    CHECK(pn_objects_build(&s, &(pn_ntree_desc){.n = 4, .d = 2}, &all) == PN_OK);
    CHECK(all.culled == 0);
    CHECK(move(&s, 0, 0, -5, 0) == PN_OK);
    CHECK(pn_objects_cull_holds(&s, &all));

    pn_objects_destroy(&all);
    pn_objects_destroy(&o);
    pn_scene_destroy(&s);
    return pn_test_result();
}
