// libFuzzer target: the scene loader (pn_scene_load: tinygltf, then scene/gltf.cpp's validation and
// flattening, then pn_scene_validate) on arbitrary bytes. The input is written to a file in a
// private, otherwise empty folder, as .glb when it starts like one ("glTF") and as .gltf
// otherwise, so each parser gets the inputs meant for it and external URIs find nothing.
//
// Beyond "no crash, no leak, no UB" (the sanitizers), a load that succeeds must hand out a scene
// every later stage can trust; a violated invariant aborts, which libFuzzer reports as a crash.
// PN_FUZZ_VERBOSE=1 keeps the loader's messages (silenced otherwise: millions of them).
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/log.h"
#include "scene/scene.h"
#include "fuzz_util.h"

static char g_dir[256], g_glb[512], g_gltf[512];

static void remove_files(void)
{
    remove(g_glb);
    remove(g_gltf);
    rmdir(g_dir);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    const char *verbose = getenv("PN_FUZZ_VERBOSE");
    pn_log_set_level(verbose && *verbose == '1' ? PN_LOG_DEBUG : PN_LOG_QUIET);
    pn_fuzz_make_dir(g_dir, sizeof g_dir, "fuzz_scene");
    snprintf(g_glb, sizeof g_glb, "%s/input.glb", g_dir);
    snprintf(g_gltf, sizeof g_gltf, "%s/input.gltf", g_dir);
    atexit(remove_files);
    return 0;
}


// What every stage after the loader relies on (see scene/scene.h).
static void check_scene(const pn_scene *s)
{
    REQUIRE(s->index_count >= 3 && s->index_count % 3 == 0 && s->vertices && s->indices);
    for (uint32_t i = 0; i < s->index_count; i++)
        REQUIRE(s->indices[i] < s->vertex_count);
    for (uint32_t i = 0; i < s->vertex_count; i++) {
        const pn_vertex *v = &s->vertices[i];
        float len2 = v->normal[0] * v->normal[0] + v->normal[1] * v->normal[1] + v->normal[2] * v->normal[2];
        for (int k = 0; k < 3; k++)
            REQUIRE(isfinite(v->pos[k]) && isfinite(v->normal[k]));
        REQUIRE(fabsf(len2 - 1.0f) < 1e-3f); // unit normals: shading divides by nothing else
        REQUIRE(isfinite(v->uv[0]) && isfinite(v->uv[1]));
    }
    uint64_t drawn = 0;
    for (uint32_t i = 0; i < s->draw_count; i++) {
        const pn_draw *d = &s->draws[i];
        REQUIRE(d->material < s->material_count);
        REQUIRE((uint64_t)d->first_index + d->index_count <= s->index_count && d->index_count % 3 == 0);
        drawn += d->index_count;
    }
    REQUIRE(drawn == s->index_count);
    for (uint32_t i = 0; i < s->material_count; i++) {
        REQUIRE(s->materials[i].texture >= -1 && s->materials[i].texture < (int32_t)s->texture_count);
        for (int c = 0; c < 4; c++)
            REQUIRE(isfinite(s->materials[i].base_color[c]));
    }
    for (uint32_t i = 0; i < s->texture_count; i++)
        REQUIRE(s->textures[i].width > 0 && s->textures[i].height > 0 && s->textures[i].rgba);
    for (int k = 0; k < 3; k++)
        REQUIRE(isfinite(s->bounds_min[k]) && isfinite(s->bounds_max[k]) && s->bounds_min[k] <= s->bounds_max[k]);
    if (s->has_camera) {
        for (int k = 0; k < 3; k++)
            REQUIRE(isfinite(s->camera.pos[k]) && isfinite(s->camera.target[k]) && isfinite(s->camera.up[k]));
        REQUIRE(s->camera.yfov_deg > 0 && s->camera.yfov_deg < 180);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = size >= 4 && memcmp(data, "glTF", 4) == 0 ? g_glb : g_gltf;
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror("fuzz_scene: cannot write the input file");
        exit(1);
    }
    pn_scene s;
    if (pn_scene_load(path, &s) == PN_OK) {
        check_scene(&s);
        // What every command does next with a loaded scene: add the ground plane, which either
        // fails cleanly or leaves a scene as valid as before.
        if (pn_scene_add_ground(&s, 6.0f) == PN_OK)
            check_scene(&s);
        pn_scene_destroy(&s);
    } else {
        // the contract on failure: *out zeroed, nothing to free
        static const pn_scene zero;
        REQUIRE(memcmp(&s, &zero, sizeof s) == 0);
    }
    return 0;
}
