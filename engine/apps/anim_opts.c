// The options of animated scenes that render and demo share (--time, --node-transform). Posing a
// prepared scene with them is render_prepare.c's (pn_render_pose).
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/render_opts.h"
#include "core/log.h"

bool pn_parse_time(const char *v, pn_render_opts *o)
{
    char *end;
    errno = 0;
    double t = strtod(v, &end);
    if (end == v || *end || errno || !isfinite(t) || fabs(t) > 1e9) {
        pn_error("--time: expected seconds, a finite number within 1e9, got '%s'", v);
        return false;
    }
    o->has_time = true;
    o->time = t;
    return true;
}

// n comma-separated finite doubles.
static bool parse_doubles(const char *what, const char *s, const char *stop, double *out, int n)
{
    for (int i = 0; i < n; i++) {
        char *end;
        errno = 0;
        out[i] = strtod(s, &end);
        if (end == s || errno || !isfinite(out[i]) || (i + 1 < n ? *end != ',' : end != stop)) {
            pn_error("--node-transform %s: expected %d comma-separated finite numbers, got '%.*s'", what, n,
                     (int)(stop - s), s);
            return false;
        }
        s = end + 1;
    }
    return true;
}

bool pn_parse_node_transform(const char *v, pn_render_opts *o)
{
    if (o->node_transform_count == PN_MAX_MOVES) {
        pn_error("--node-transform: at most %d", PN_MAX_MOVES);
        return false;
    }
    const char *c[3];
    c[0] = strchr(v, ':');
    c[1] = c[0] ? strchr(c[0] + 1, ':') : NULL;
    c[2] = c[1] ? strchr(c[1] + 1, ':') : NULL;
    if (!c[2] || strchr(c[2] + 1, ':')) {
        pn_error("--node-transform: expected NODE:TX,TY,TZ:QX,QY,QZ,QW:SX,SY,SZ (glTF's translation, rotation "
                 "quaternion and scale), got '%s'",
                 v);
        return false;
    }
    char node[32];
    long long n;
    size_t len = (size_t)(c[0] - v);
    if (len >= sizeof node) {
        pn_error("--node-transform node: expected a node index, got '%.*s'", (int)len, v);
        return false;
    }
    memcpy(node, v, len);
    node[len] = '\0';
    if (!pn_parse_int_range("--node-transform node", node, 0, UINT32_MAX, &n))
        return false;
    pn_node_transform *x = &o->node_transforms[o->node_transform_count];
    x->node = (uint32_t)n;
    if (!parse_doubles("translation", c[0] + 1, c[1], x->t, 3) || !parse_doubles("rotation", c[1] + 1, c[2], x->r, 4) ||
        !parse_doubles("scale", c[2] + 1, v + strlen(v), x->s, 3))
        return false;
    if (!(fabs(x->r[0]) + fabs(x->r[1]) + fabs(x->r[2]) + fabs(x->r[3]) > 0)) {
        pn_error("--node-transform rotation: a quaternion must not be zero, got '%.*s'", (int)(c[2] - c[1] - 1),
                 c[1] + 1);
        return false;
    }
    o->node_transform_count++;
    return true;
}
