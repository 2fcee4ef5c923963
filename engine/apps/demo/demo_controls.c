// The demo's controls: one table of key bindings drives the keyboard, scripts, --help and the H
// overlay; camera, light and object moves shared by mouse, keys and scripts. Over 500 lines
// because the table and the moves it names are kept in one place.
//
// Over 500 lines because the one table of keys is most of it, each key's action beside
// its entry.
#include <cglm/cglm.h>
#include <math.h>
#include <string.h>
#include <strings.h>

#include "apps/demo/demo.h"
#include "core/timer.h"

// ---------------------------------------------------------------------------------------------
// Camera: orbit, pan and zoom around the target. Positive yaw moves the camera to its right,
// positive pitch up; pan moves the scene by (x, y) view heights on screen (y down). The camera is
// kept as pn_camera (no yaw/pitch state): untouched, it stays bit-identical to render's, so
// screenshots of a fixed view compare.

// Takes a camera move when the camera stays one render would take: position and target within
// PN_MAX_COORD of the origin (render refuses beyond; a script can zoom or pan by up to 1e30 and
// repeat it, which overflows to infinity) and apart (far from the origin, float rounding can merge
// them: no view direction). Otherwise logs why and leaves the camera as it was.
static void move_camera(pn_demo *d, const char *what, const vec3 pos, const vec3 target)
{
    bool apart = false;
    for (int k = 0; k < 3; k++) {
        if (!(fabsf(pos[k]) <= PN_MAX_COORD && fabsf(target[k]) <= PN_MAX_COORD)) {
            pn_warn("demo: %s would take the camera beyond %g from the origin: not moved", what,
                    (double)PN_MAX_COORD);
            return;
        }
        apart = apart || pos[k] != target[k];
    }
    if (!apart) {
        pn_warn("demo: %s would put the camera on its target (float precision): not moved", what);
        return;
    }
    glm_vec3_copy((float *)pos, d->camera.pos);
    glm_vec3_copy((float *)target, d->camera.target);
    d->restart = true;
}

void pn_demo_orbit(pn_demo *d, float yaw_deg, float pitch_deg)
{
    pn_camera *c = &d->camera;
    vec3 up, offset, right, pos;
    glm_vec3_normalize_to(c->up, up);
    glm_vec3_sub(c->pos, c->target, offset);
    glm_vec3_rotate(offset, glm_rad(yaw_deg), up);
    glm_vec3_cross(up, offset, right);
    if (glm_vec3_norm(right) > 0) {
        vec3 pitched;
        glm_vec3_copy(offset, pitched);
        glm_vec3_rotate(pitched, -glm_rad(pitch_deg), right); // positive pitch: the camera rises
        // Stop short of the poles, where the view direction would turn parallel to up.
        float cosine = glm_vec3_dot(pitched, up) / glm_vec3_norm(pitched);
        if (fabsf(cosine) < 0.996f)
            glm_vec3_copy(pitched, offset);
    }
    glm_vec3_add(c->target, offset, pos);
    move_camera(d, "orbit", pos, c->target);
}

void pn_demo_pan(pn_demo *d, float x, float y)
{
    pn_camera *c = &d->camera;
    vec3 fwd, right, up, move, pos, target;
    glm_vec3_sub(c->target, c->pos, fwd);
    float dist = glm_vec3_norm(fwd);
    glm_vec3_normalize(fwd);
    glm_vec3_crossn(fwd, c->up, right);
    glm_vec3_cross(right, fwd, up);
    // One view height at the target's distance: the scene under the cursor follows the mouse.
    float h = 2.0f * dist * tanf(glm_rad(c->yfov_deg) * 0.5f);
    glm_vec3_scale(right, -x * h, move);
    glm_vec3_muladds(up, y * h, move);
    glm_vec3_add(c->pos, move, pos);
    glm_vec3_add(c->target, move, target);
    move_camera(d, "pan", pos, target);
}

void pn_demo_zoom(pn_demo *d, float factor)
{
    pn_camera *c = &d->camera;
    vec3 offset, pos;
    glm_vec3_sub(c->pos, c->target, offset);
    float dist = glm_vec3_norm(offset);
    float min_dist = 1e-3f * d->radius;
    if (dist * factor < min_dist)
        factor = min_dist / dist;
    glm_vec3_scale(offset, factor, offset);
    glm_vec3_add(c->target, offset, pos);
    move_camera(d, "zoom", pos, c->target);
}

// ---------------------------------------------------------------------------------------------
// Light

// The tree leaves out triangles that cannot block a ray to the light (pn_ntree_desc.cull_light):
// after the light changes, such a triangle might block, so the tree is rebuilt for the new light.
static void light_changed(pn_demo *d)
{
    d->restart = true;
    if (d->accel.tree.culled + d->accel.objects.culled > 0) // per-object trees cull the rest alone
        d->want_rebuild = true;
}

// Keeps the light facing the scene's centre (as render does for --light-pos) with a valid up.
static void light_aim(pn_demo *d)
{
    pn_light *l = &d->lights[d->light_sel];
    vec3 n;
    glm_vec3_sub(d->center, l->pos, n);
    if (glm_vec3_norm(n) > 1e-6f * d->radius) {
        glm_vec3_normalize(n);
        glm_vec3_copy(n, l->normal);
    }
    float t[3], b[3];
    if (!pn_light_frame(l, t, b)) {
        glm_vec3_copy((vec3){1, 0, 0}, l->up);
        if (!pn_light_frame(l, t, b))
            glm_vec3_copy((vec3){0, 0, 1}, l->up);
    }
}

enum { MOVE_LEFT, MOVE_RIGHT, MOVE_AWAY, MOVE_NEAR, MOVE_UP, MOVE_DOWN };

// A step of length `step` in direction `dir` (MOVE_*) across the view: the camera's forward and
// right directions flattened onto the ground (+Y up), or up and down. The light and object keys
// move alike.
static void view_step(const pn_demo *d, float dir, float step, vec3 move)
{
    vec3 world_up = {0, 1, 0}, fwd, right;
    glm_vec3_zero(move);
    for (int k = 0; k < 3; k++) // cglm takes no const
        fwd[k] = d->camera.target[k] - d->camera.pos[k];
    fwd[1] = 0;
    if (glm_vec3_norm(fwd) < 1e-6f)
        glm_vec3_copy((vec3){0, 0, -1}, fwd);
    glm_vec3_normalize(fwd);
    glm_vec3_crossn(fwd, world_up, right);
    switch ((int)dir) {
    case MOVE_LEFT: glm_vec3_scale(right, -step, move); break;
    case MOVE_RIGHT: glm_vec3_scale(right, step, move); break;
    case MOVE_AWAY: glm_vec3_scale(fwd, step, move); break;
    case MOVE_NEAR: glm_vec3_scale(fwd, -step, move); break;
    case MOVE_UP: move[1] = step; break;
    case MOVE_DOWN: move[1] = -step; break;
    }
}

static void light_move(pn_demo *d, float dir)
{
    vec3 move;
    view_step(d, dir, 0.1f * d->radius, move);
    pn_light *l = &d->lights[d->light_sel];
    glm_vec3_add(l->pos, move, l->pos);
    light_aim(d);
    light_changed(d);
}

static void light_width(pn_demo *d, float f)
{
    pn_light *l = &d->lights[d->light_sel];
    l->size[0] = glm_clamp(l->size[0] * f, 1e-3f * d->radius, 10.0f * d->radius);
    light_changed(d);
}

static void light_height(pn_demo *d, float f)
{
    pn_light *l = &d->lights[d->light_sel];
    l->size[1] = glm_clamp(l->size[1] * f, 1e-3f * d->radius, 10.0f * d->radius);
    light_changed(d);
}

static void light_rotate(pn_demo *d, float deg)
{
    pn_light *l = &d->lights[d->light_sel];
    vec3 up;
    glm_vec3_copy(l->up, up);
    glm_vec3_rotate(up, glm_rad(deg), l->normal);
    glm_vec3_copy(up, l->up);
    light_changed(d);
}

// With several lights: the light keys move the next one.
static void next_light(pn_demo *d, float step)
{
    (void)step;
    d->light_sel = (d->light_sel + 1) % (d->light_count ? d->light_count : 1);
    d->restart = true; // the overlay names it
}

// ---------------------------------------------------------------------------------------------
// Objects (glTF nodes with a mesh). A move changes the scene's vertices, the object's transform and
// the bounds here; the frame loop brings the renderers and trees up to it before the next frame
// (demo_trees.c, pn_demo_apply_moves), where its cost is measured.

// The world box of object i's vertices.
static void object_box(const pn_demo *d, uint32_t i, float lo[3], float hi[3])
{
    const pn_scene_object *o = &d->scene.objects[i];
    for (int k = 0; k < 3; k++)
        lo[k] = INFINITY, hi[k] = -INFINITY;
    for (uint32_t v = o->first_vertex; v < o->first_vertex + o->vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], d->scene.vertices[v].pos[k]);
            hi[k] = fmaxf(hi[k], d->scene.vertices[v].pos[k]);
        }
}

bool pn_demo_move_object(pn_demo *d, uint32_t index, const float delta[3])
{
    if (index >= d->scene.object_count) {
        pn_error("demo: no object %u to move: %s has %u (glTF nodes with a mesh)", index, d->scene.name,
                 d->scene.object_count);
        return false;
    }
    // Refused before moving: float additions do not undo exactly.
    float lo[3], hi[3];
    object_box(d, index, lo, hi);
    for (int k = 0; k < 3; k++)
        if (!(fabsf(lo[k] + delta[k]) <= PN_MAX_COORD && fabsf(hi[k] + delta[k]) <= PN_MAX_COORD)) {
            pn_error("demo: object %u moved by (%g, %g, %g) would reach beyond %g from the origin, where float "
                     "arithmetic overflows",
                     index, (double)delta[0], (double)delta[1], (double)delta[2], (double)PN_MAX_COORD);
            return false;
        }
    // Per-object trees: the tree's leaves must stay 16 float steps wide at the new world position
    // (pn_objects_update refuses them otherwise; a scene-wide tree's rebuild checks its own).
    float mag = 0.0f;
    for (int k = 0; k < 3; k++)
        mag = fmaxf(mag, fmaxf(fabsf(lo[k] + delta[k]), fabsf(hi[k] + delta[k])));
    if (d->accel.desc.needs.tree && d->accel.desc.per_object && !pn_objects_resolves(&d->accel.objects, index, mag)) {
        pn_error("demo: object %u moved to %g from the origin: its tree's leaves would be under 16 float steps "
                 "there; a smaller N or d lets it go that far", index, (double)mag);
        return false;
    }
    uint64_t t0 = pn_time_ns();
    // Its box before and after, for the history: where V may change (demo_trees.c).
    double was_lo[3], was_hi[3], now_lo[3], now_hi[3];
    for (int k = 0; k < 3; k++)
        was_lo[k] = lo[k], was_hi[k] = hi[k];
    if (pn_scene_move_object(&d->scene, index, delta) != PN_OK)
        return false;
    pn_demo_move *m = &d->move;
    object_box(d, index, lo, hi);
    for (int k = 0; k < 3; k++)
        now_lo[k] = lo[k], now_hi[k] = hi[k];
    pn_history_boxes_add(&m->boxes, was_lo, was_hi);
    pn_history_boxes_add(&m->boxes, now_lo, now_hi);
    const pn_scene_object *o = &d->scene.objects[index];
    uint32_t end = o->first_vertex + o->vertex_count;
    m->first = m->count && m->first < o->first_vertex ? m->first : o->first_vertex;
    m->end = m->count && m->end > end ? m->end : end;
    m->count++;
    m->object = index;
    m->scene_ms += pn_ms_since(t0);
    d->scene_moved = true;
    d->restart = true;
    return true;
}

static void next_object(pn_demo *d, float step)
{
    uint32_t n = d->scene.object_count;
    if (n == 0) {
        pn_warn("demo: %s has no objects to select (glTF nodes with a mesh)", d->scene.name);
        return;
    }
    d->object_sel = (uint32_t)(((int64_t)d->object_sel + (int64_t)step + n) % n);
    d->restart = true; // the overlay names it
}

static void object_move(pn_demo *d, float dir)
{
    if (d->object_sel >= d->scene.object_count) {
        pn_warn("demo: %s has no objects to move (glTF nodes with a mesh)", d->scene.name);
        return;
    }
    // A quarter of the object's own size: it visibly moves, and its shadow with it, whatever the
    // scene's size; four presses move it by its largest extent.
    float lo[3], hi[3];
    object_box(d, d->object_sel, lo, hi);
    float size = fmaxf(fmaxf(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2]);
    vec3 move;
    view_step(d, dir, 0.25f * (size > 0 ? size : d->radius), move);
    pn_demo_move_object(d, d->object_sel, move);
}

// ---------------------------------------------------------------------------------------------
// Shadow parameters and views

// The modes the demo offers: those that trace and that the device can run, in table order
// (gpu/shadow_modes.c); with per-object trees, linespace alone (the one mode they serve).
static int tracing_modes(const pn_demo *d, pn_shadow_mode out[PN_SHADOW_MODE_COUNT])
{
    int count = 0;
    for (int m = 0; m < PN_SHADOW_MODE_COUNT; m++)
        if (pn_shadow_mode_get((pn_shadow_mode)m)->traces && pn_shadow_mode_available(&d->dev, (pn_shadow_mode)m, NULL) &&
            pn_shadow_mode_takes_scene((pn_shadow_mode)m, &d->scene, NULL, 0) &&
            (!d->opts.per_object || pn_shadow_mode_get((pn_shadow_mode)m)->objects))
            out[count++] = (pn_shadow_mode)m;
    return count;
}

// Key 1 selects the first of them, 2 the second, ...
static void set_mode(pn_demo *d, float place)
{
    pn_shadow_mode modes[PN_SHADOW_MODE_COUNT];
    int count = tracing_modes(d, modes);
    if ((int)place < 1 || (int)place > count)
        return;
    d->opts.mode = modes[(int)place - 1];
    if (d->opts.mode != PN_SHADOW_EXACT && d->opts.traversal == PN_TRAVERSAL_PROJECT)
        d->opts.traversal = PN_TRAVERSAL_AUTO; // the projection is exact's walk
    d->renderer_dirty = d->restart = true;
}

static void next_mode(pn_demo *d, float step)
{
    pn_shadow_mode modes[PN_SHADOW_MODE_COUNT];
    int count = tracing_modes(d, modes), at = 0;
    for (int i = 0; i < count; i++)
        if (modes[i] == d->opts.mode)
            at = i;
    set_mode(d, (float)((at + (int)step + count) % count + 1));
}

static void toggle_traversal(pn_demo *d, float unused)
{
    // ray, packet, auto, and for exact with uniform samples project (pn_shadow_check_samples)
    static const pn_traversal order[4] = {PN_TRAVERSAL_RAY, PN_TRAVERSAL_PACKET, PN_TRAVERSAL_PROJECT, PN_TRAVERSAL_AUTO};
    int at = 0;
    for (int i = 0; i < 4; i++)
        at = order[i] == d->opts.traversal ? i : at;
    pn_traversal next = order[(at + 1) % 4];
    if (next == PN_TRAVERSAL_PROJECT && (d->opts.mode != PN_SHADOW_EXACT || d->opts.spp_min))
        next = PN_TRAVERSAL_AUTO;
    d->opts.traversal = next;
    d->renderer_dirty = d->restart = true;
}

static void toggle_sampler(pn_demo *d, float unused)
{
    d->opts.sampler = d->opts.sampler == PN_SAMPLER_GRID ? PN_SAMPLER_STRATIFIED : PN_SAMPLER_GRID;
    if (d->opts.sampler == PN_SAMPLER_GRID)
        d->opts.split = PN_SPLIT_EVEN; // a budgeted split has no grid to fit its counts
    d->renderer_dirty = d->restart = true;
}

static void toggle_filter(pn_demo *d, float unused)
{
    // none -> interleaved -> penumbra -> none
    d->opts.filter = d->opts.filter == PN_FILTER_LAST ? PN_FILTER_NONE : (pn_filter)(d->opts.filter + 1);
    if (d->opts.filter != PN_FILTER_NONE)
        d->opts.split = PN_SPLIT_EVEN; // interleaving shares one sample set per tile: no budgeted counts
    d->renderer_dirty = d->restart = true;
}

// Square counts: square sample grids over the light.
static const int SPP_STEPS[] = {1, 4, 9, 16, 25, 36, 49, 64, 100, 144, 256};
enum { SPP_STEP_COUNT = sizeof SPP_STEPS / sizeof SPP_STEPS[0] };

static void step_spp(pn_demo *d, float dir)
{
    long long spp = d->opts.spp;
    if (d->opts.spp_min) {
        // Adaptive samples (--spp MIN:MAX): the most doubles or halves, down to MIN.
        spp = dir > 0 ? (spp * 2 <= 1 << 16 ? spp * 2 : spp) : (spp / 2 >= d->opts.spp_min ? spp / 2 : spp);
    } else if (dir > 0) {
        for (int i = 0; i < SPP_STEP_COUNT && spp == d->opts.spp; i++)
            if (SPP_STEPS[i] > d->opts.spp)
                spp = SPP_STEPS[i];
    } else {
        for (int i = SPP_STEP_COUNT - 1; i >= 0 && spp == d->opts.spp; i--)
            if (SPP_STEPS[i] < d->opts.spp)
                spp = SPP_STEPS[i];
    }
    if (spp != d->opts.spp) {
        d->opts.spp = spp;
        d->renderer_dirty = d->restart = true;
    }
}

static int clamp_int(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

// The frame loop starts a rebuild when the wanted tree differs from the one drawn.
static void step_tree_n(pn_demo *d, float dir) { d->want_n = clamp_int(d->want_n + (int)dir, 2, 16); }
static void step_tree_d(pn_demo *d, float dir) { d->want_d = clamp_int(d->want_d + (int)dir, 1, PN_NTREE_MAX_DEPTH); }

static void toggle_view(pn_demo *d, float view)
{
    if ((pn_demo_view)view == PN_DEMO_ERROR && d->opts.per_object) {
        snprintf(d->build_message, sizeof d->build_message,
                 "error view: exact mode needs the scene-wide BVH, not built with --trees object");
        pn_warn("demo: %s", d->build_message);
        return;
    }
    d->view = d->view == (pn_demo_view)view ? PN_DEMO_SHADED : (pn_demo_view)view;
    d->renderer_dirty = d->restart = true; // the error view adds (or drops) the exact renderer
}

static void toggle_cells(pn_demo *d, float unused) { d->cells = !d->cells, d->restart = true; }
static void toggle_accumulate(pn_demo *d, float unused) { d->accumulate = !d->accumulate, d->restart = true; }
static void toggle_help(pn_demo *d, float unused) { d->show_help = !d->show_help; }
static void toggle_hud(pn_demo *d, float unused) { d->show_hud = !d->show_hud; }
static void save(pn_demo *d, float unused) { d->save = true; }
static void quit(pn_demo *d, float unused) { d->quit = true; }

static void reset(pn_demo *d, float unused)
{
    d->camera = d->camera_home;
    memcpy(d->lights, d->lights_home, sizeof d->lights);
    light_changed(d);
}

// ---------------------------------------------------------------------------------------------
// The bindings

typedef struct binding {
    int key, mods;    // GLFW key and modifiers (0 or GLFW_MOD_SHIFT)
    bool repeat;      // also while the key is held (moves and steps, not toggles)
    void (*fn)(pn_demo *d, float arg);
    float arg;
    const char *keys; // the line in the help, on the first binding of a group; NULL otherwise
    const char *help;
} binding;

#define SHIFT GLFW_MOD_SHIFT
static const binding BINDINGS[] = {
    {GLFW_KEY_LEFT, 0, true, light_move, MOVE_LEFT, "arrows", "move the light across the view"},
    {GLFW_KEY_RIGHT, 0, true, light_move, MOVE_RIGHT},
    {GLFW_KEY_UP, 0, true, light_move, MOVE_AWAY},
    {GLFW_KEY_DOWN, 0, true, light_move, MOVE_NEAR},
    {GLFW_KEY_PAGE_UP, 0, true, light_move, MOVE_UP, "pageup pagedown", "move the light up, down"},
    {GLFW_KEY_PAGE_DOWN, 0, true, light_move, MOVE_DOWN},
    {GLFW_KEY_LEFT_BRACKET, 0, true, light_width, 0.8f, "[ ]", "light width smaller, larger"},
    {GLFW_KEY_RIGHT_BRACKET, 0, true, light_width, 1.25f},
    {GLFW_KEY_SEMICOLON, 0, true, light_height, 0.8f, "; '", "light height smaller, larger"},
    {GLFW_KEY_APOSTROPHE, 0, true, light_height, 1.25f},
    {GLFW_KEY_COMMA, 0, true, light_rotate, -15.0f, ", .", "rotate the light about its normal"},
    {GLFW_KEY_PERIOD, 0, true, light_rotate, 15.0f},
    {GLFW_KEY_L, 0, false, next_light, 0, "L", "with several lights: the keys above move the next one"},
    {GLFW_KEY_O, 0, false, next_object, 1, "O shift+O", "select the next, previous object (glTF node with a mesh)"},
    {GLFW_KEY_O, SHIFT, false, next_object, -1},
    {GLFW_KEY_LEFT, SHIFT, true, object_move, MOVE_LEFT, "shift+arrows", "move the selected object across the view"},
    {GLFW_KEY_RIGHT, SHIFT, true, object_move, MOVE_RIGHT},
    {GLFW_KEY_UP, SHIFT, true, object_move, MOVE_AWAY},
    {GLFW_KEY_DOWN, SHIFT, true, object_move, MOVE_NEAR},
    {GLFW_KEY_PAGE_UP, SHIFT, true, object_move, MOVE_UP, "shift+pageup/down",
     "move it up, down: --trees object rebuilds the top level only, else the tree (background)"},
    {GLFW_KEY_PAGE_DOWN, SHIFT, true, object_move, MOVE_DOWN},
    {GLFW_KEY_M, 0, false, next_mode, 1, "M shift+M", "next, previous mode"},
    {GLFW_KEY_M, SHIFT, false, next_mode, -1},
    {GLFW_KEY_1, 0, false, set_mode, 1, "1 2 3 4 ...", "the modes in --help's order (linespace, ls-leaf, ...)"},
    {GLFW_KEY_2, 0, false, set_mode, 2},
    {GLFW_KEY_3, 0, false, set_mode, 3},
    {GLFW_KEY_4, 0, false, set_mode, 4},
    {GLFW_KEY_5, 0, false, set_mode, 5},
    {GLFW_KEY_6, 0, false, set_mode, 6},
    {GLFW_KEY_7, 0, false, set_mode, 7},
    {GLFW_KEY_8, 0, false, set_mode, 8},
    {GLFW_KEY_T, 0, false, toggle_traversal, 0, "T", "traversal ray / packet / project (exact) / auto"},
    {GLFW_KEY_G, 0, false, toggle_sampler, 0, "G", "sampler grid / stratified"},
    {GLFW_KEY_F, 0, false, toggle_filter, 0, "F", "filter none / interleaved / penumbra (tile --tile)"},
    {GLFW_KEY_MINUS, 0, true, step_spp, -1, "- =", "fewer, more shadow rays per pixel"},
    {GLFW_KEY_EQUAL, 0, true, step_spp, 1},
    {GLFW_KEY_N, 0, true, step_tree_n, 1, "N shift+N", "tree branching factor up, down"},
    {GLFW_KEY_N, SHIFT, true, step_tree_n, -1},
    {GLFW_KEY_D, 0, true, step_tree_d, 1, "D shift+D", "tree depth up, down (rebuilt in the background)"},
    {GLFW_KEY_D, SHIFT, true, step_tree_d, -1},
    {GLFW_KEY_V, 0, false, toggle_view, PN_DEMO_VISIBILITY, "V", "view the visibility term V alone"},
    {GLFW_KEY_E, 0, false, toggle_view, PN_DEMO_ERROR, "E", "view the error |V - V_exact| (renders exact too)"},
    {GLFW_KEY_C, 0, false, toggle_cells, 0, "C", "overlay the N-tree cells, coloured by level"},
    {GLFW_KEY_A, 0, false, toggle_accumulate, 0, "A", "progressive accumulation on / off"},
    {GLFW_KEY_R, 0, false, reset, 0, "R", "reset camera and light"},
    {GLFW_KEY_P, 0, false, save, 0, "P", "save the frame as EXR and PNG"},
    {GLFW_KEY_I, 0, false, toggle_hud, 0, "I", "figures on / off"},
    {GLFW_KEY_H, 0, false, toggle_help, 0, "H", "this help"},
    {GLFW_KEY_ESCAPE, 0, false, quit, 0, "escape Q", "quit"},
    {GLFW_KEY_Q, 0, false, quit, 0},
};
#undef SHIFT
enum { BINDING_COUNT = sizeof BINDINGS / sizeof BINDINGS[0] };

void pn_demo_key(pn_demo *d, int key, int mods, bool repeat)
{
    mods &= GLFW_MOD_SHIFT; // other modifiers select nothing
    for (int i = 0; i < BINDING_COUNT; i++) {
        const binding *b = &BINDINGS[i];
        if (b->key == key && b->mods == mods && (!repeat || b->repeat)) {
            b->fn(d, b->arg);
            return;
        }
    }
}

void pn_demo_controls_text(char *out, size_t n)
{
    size_t at = 0;
    at += (size_t)snprintf(out, n,
                           "mouse             left drag: orbit; right or middle drag: pan; wheel: zoom\n");
    for (int i = 0; i < BINDING_COUNT && at < n; i++)
        if (BINDINGS[i].keys)
            at += (size_t)snprintf(out + at, n - at, "%-17s %s\n", BINDINGS[i].keys, BINDINGS[i].help);
}

static const struct {
    const char *name;
    int key;
} NAMED_KEYS[] = {
    {"left", GLFW_KEY_LEFT},         {"right", GLFW_KEY_RIGHT},         {"up", GLFW_KEY_UP},
    {"down", GLFW_KEY_DOWN},         {"pageup", GLFW_KEY_PAGE_UP},      {"pagedown", GLFW_KEY_PAGE_DOWN},
    {"escape", GLFW_KEY_ESCAPE},     {"space", GLFW_KEY_SPACE},
};

bool pn_demo_key_parse(const char *name, int *key, int *mods)
{
    *mods = 0;
    if (strncasecmp(name, "shift+", 6) == 0) {
        *mods = GLFW_MOD_SHIFT;
        name += 6;
    }
    for (size_t i = 0; i < sizeof NAMED_KEYS / sizeof NAMED_KEYS[0]; i++)
        if (strcasecmp(name, NAMED_KEYS[i].name) == 0) {
            *key = NAMED_KEYS[i].key;
            return true;
        }
    if (name[0] && !name[1]) {
        // GLFW's codes of the printable keys are their US-layout ASCII characters (letters upper case).
        char c = name[0];
        if (c >= 'a' && c <= 'z')
            c = (char)(c - 'a' + 'A');
        if ((c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || strchr("',-./;=[\\]`", c)) {
            *key = c;
            return true;
        }
    }
    return false;
}
