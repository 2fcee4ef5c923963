// pn_scene_load: a scene from its source, dispatched to the loader of its kind (the glTF reader,
// the built-in scenes), then validated. The loaders build on scene.c; nothing calls back here.
#include <string.h>
#include <strings.h>

#include "core/log.h"
#include "scene/scene.h"

static bool has_suffix(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && strcasecmp(s + n - m, suffix) == 0;
}

pn_result pn_scene_load(const char *source, pn_scene *out)
{
    memset(out, 0, sizeof *out);
    pn_result r;
    if (strncmp(source, "builtin:", 8) == 0)
        r = pn_builtin_load(source + 8, out);
    else if (has_suffix(source, ".gltf") || has_suffix(source, ".glb"))
        r = pn_gltf_load(source, out);
    else {
        pn_error("%s: not a scene: expected a .gltf or .glb file or builtin:NAME", source);
        return PN_ERR_INVALID;
    }
    if (r == PN_OK)
        r = pn_scene_validate(out);
    if (r != PN_OK)
        pn_scene_destroy(out);
    return r;
}
