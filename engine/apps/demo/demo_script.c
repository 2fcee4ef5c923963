// --script files: key presses and camera moves at given frames (format in demo.h).
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>

#include "apps/demo/demo.h"

static bool parse_uint(const char *s, uint32_t *out)
{
    char *end;
    errno = 0;
    unsigned long v = strtoul(s, &end, 10);
    if (!*s || *end || errno || v > UINT32_MAX || s[0] == '-')
        return false;
    *out = (uint32_t)v;
    return true;
}

static bool parse_float(const char *s, float *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (!*s || *end || errno || !isfinite(v) || fabs(v) > 1e30)
        return false;
    *out = (float)v;
    return true;
}

// One line into *ev; returns an error message, or NULL.
static const char *parse_line(char *line, pn_demo_event *ev)
{
    enum { MAX_WORDS = 7 }; // frame N move-object I DX DY DZ
    char *tok[MAX_WORDS + 1], *save = NULL;
    int n = 0;
    for (char *t = strtok_r(line, " \t\r\n", &save); t && n < MAX_WORDS + 1; t = strtok_r(NULL, " \t\r\n", &save))
        tok[n++] = t;
    if (n > MAX_WORDS)
        return "too many words";
    if (n < 3 || strcmp(tok[0], "frame") != 0)
        return "expected 'frame N COMMAND ...'";
    if (!parse_uint(tok[1], &ev->frame))
        return "the frame must be a whole number";
    const char *cmd = tok[2];
    int args = n - 3;
    if (!strcmp(cmd, "key")) {
        ev->kind = PN_DEMO_EVENT_KEY;
        if (args != 1 || !pn_demo_key_parse(tok[3], &ev->key, &ev->mods))
            return "key needs one key name: a letter, digit or one of ',-./;=[]' or left, right, up, down, "
                   "pageup, pagedown, escape, space; 'shift+' in front for shift";
    } else if (!strcmp(cmd, "orbit") || !strcmp(cmd, "pan")) {
        ev->kind = cmd[0] == 'o' ? PN_DEMO_EVENT_ORBIT : PN_DEMO_EVENT_PAN;
        if (args != 2 || !parse_float(tok[3], &ev->a) || !parse_float(tok[4], &ev->b))
            return "orbit and pan need two numbers";
    } else if (!strcmp(cmd, "zoom")) {
        ev->kind = PN_DEMO_EVENT_ZOOM;
        if (args != 1 || !parse_float(tok[3], &ev->a) || !(ev->a > 0))
            return "zoom needs one positive factor";
    } else if (!strcmp(cmd, "resize")) {
        ev->kind = PN_DEMO_EVENT_RESIZE;
        uint32_t w, h;
        if (args != 2 || !parse_uint(tok[3], &w) || !parse_uint(tok[4], &h) || w < 1 || h < 1 || w > 16384 || h > 16384)
            return "resize needs a width and a height in 1..16384";
        ev->a = (float)w, ev->b = (float)h;
    } else if (!strcmp(cmd, "move-object")) {
        ev->kind = PN_DEMO_EVENT_MOVE_OBJECT;
        if (args != 4 || !parse_uint(tok[3], &ev->object) || !parse_float(tok[4], &ev->move[0]) ||
            !parse_float(tok[5], &ev->move[1]) || !parse_float(tok[6], &ev->move[2]))
            return "move-object needs an object index (0, 1, ...: the file's nodes with a mesh, as --move-object "
                   "counts) and three numbers DX DY DZ";
    } else if (!strcmp(cmd, "screenshot")) {
        ev->kind = PN_DEMO_EVENT_SCREENSHOT;
        if (args != 1 || strlen(tok[3]) >= sizeof ev->path)
            return "screenshot needs one file name";
        strcpy(ev->path, tok[3]);
    } else {
        return "unknown command (key, orbit, pan, zoom, resize, move-object, screenshot)";
    }
    return NULL;
}

static int by_frame(const void *a, const void *b)
{
    const pn_demo_event *x = a, *y = b;
    if (x->frame != y->frame)
        return x->frame < y->frame ? -1 : 1;
    return x->line < y->line ? -1 : x->line > y->line;
}

pn_result pn_demo_script_load(const char *path, pn_demo_script *out)
{
    memset(out, 0, sizeof *out);
    FILE *f = fopen(path, "r");
    if (!f) {
        pn_error("%s: cannot open the script: %s", path, strerror(errno));
        return PN_ERR_IO;
    }
    uint32_t cap = 0;
    // getline, not fgets into a fixed buffer: a longer line would come back in pieces, each parsed
    // as a line of its own under the next line's number.
    char *line = NULL;
    size_t line_cap = 0;
    ssize_t len;
    pn_result r = PN_OK;
    for (uint32_t number = 1; r == PN_OK && (len = getline(&line, &line_cap, f)) >= 0; number++) {
        // A NUL would cut the line short unseen (strtok and the rest stop at it): not a text file.
        if (memchr(line, '\0', (size_t)len)) {
            pn_error("%s:%u: a NUL byte: not a text file", path, number);
            r = PN_ERR_FORMAT;
            break;
        }
        char *hash = strchr(line, '#');
        if (hash)
            *hash = '\0';
        if (strspn(line, " \t\r\n") == strlen(line))
            continue;
        if (out->count == cap) {
            // Each event is over 1 KiB (the screenshot path): a count that would overflow the
            // size is refused rather than wrapped.
            if (cap > UINT32_MAX / 2 || (size_t)cap * 2 > SIZE_MAX / sizeof *out->events) {
                r = PN_ERR_MEMORY;
                pn_error("%s:%u: too many events", path, number);
                break;
            }
            cap = cap ? 2 * cap : 64;
            pn_demo_event *grown = realloc(out->events, cap * sizeof *grown);
            if (!grown) {
                r = PN_ERR_MEMORY;
                pn_error("%s: out of memory", path);
                break;
            }
            out->events = grown;
        }
        pn_demo_event *ev = &out->events[out->count];
        memset(ev, 0, sizeof *ev);
        ev->line = number;
        const char *problem = parse_line(line, ev);
        if (problem) {
            pn_error("%s:%u: %s", path, number, problem);
            r = PN_ERR_FORMAT;
        } else {
            out->count++;
        }
    }
    free(line);
    if (r == PN_OK && ferror(f)) {
        pn_error("%s: read error", path);
        r = PN_ERR_IO;
    }
    fclose(f);
    if (r != PN_OK) {
        pn_demo_script_destroy(out);
        return r;
    }
    // A script of comments alone has no events and no array: qsort's pointer must not be NULL even
    // for 0 elements.
    if (out->count > 1)
        qsort(out->events, out->count, sizeof *out->events, by_frame);
    return PN_OK;
}

pn_result pn_demo_script_check(const pn_demo_script *s, const char *path, const pn_scene *scene)
{
    for (uint32_t i = 0; i < s->count; i++) {
        const pn_demo_event *e = &s->events[i];
        if (e->kind == PN_DEMO_EVENT_MOVE_OBJECT && e->object >= scene->object_count) {
            pn_error("%s:%u: move-object %u: %s has %u object(s) to move (glTF nodes with a mesh, counted from 0)",
                     path, e->line, e->object, scene->name, scene->object_count);
            return PN_ERR_INVALID;
        }
    }
    return PN_OK;
}

void pn_demo_script_destroy(pn_demo_script *s)
{
    free(s->events);
    memset(s, 0, sizeof *s);
}
