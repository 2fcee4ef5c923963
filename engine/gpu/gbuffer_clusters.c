// Clusters of the G-buffer pass: their bounds, and the per-frame choice of what is drawn
// (gbuffer_clusters.h says why the image stays the same).
#include "gpu/gbuffer_clusters.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

// A triangle's normal (p1 - p0) x (p2 - p0), in double from its float corners: exact but for the
// products' last rounding.
static void normal_of(const float *p[3], double n[3])
{
    double u[3], v[3];
    for (int a = 0; a < 3; a++)
        u[a] = (double)p[1][a] - p[0][a], v[a] = (double)p[2][a] - p[0][a];
    n[0] = u[1] * v[2] - u[2] * v[1], n[1] = u[2] * v[0] - u[0] * v[2], n[2] = u[0] * v[1] - u[1] * v[0];
}

// Cluster k's bounds from its triangles, in double from their float corners: the box, a sphere
// round the box's centre, and the cone of the triangles' unit normals about their mean (a normal's
// direction is then off by rounding of the order of 2^-50, however thin its triangle). A cluster
// with a degenerate triangle (its corners on a line: no facing, and one the rasterizer's rounding
// may give an area) or normals spread wider than 84 degrees from their mean is never taken as facing
// away (cutoff 1), as meshoptimizer's meshopt_computeClusterBounds decides for its float cones.
static void bound(pn_gbuffer_cluster *k, const pn_scene *s, const uint32_t *indices)
{
    const uint32_t *idx = indices + k->first_index;
    for (int a = 0; a < 3; a++)
        k->min[a] = INFINITY, k->max[a] = -INFINITY;
    uint32_t triangles = k->index_count / 3;
    double sum[3] = {0, 0, 0};
    bool degenerate = false;
    for (uint32_t t = 0; t < triangles; t++) {
        const float *p[3];
        for (int j = 0; j < 3; j++) {
            p[j] = s->vertices[idx[3 * t + j]].pos;
            for (int a = 0; a < 3; a++)
                k->min[a] = fminf(k->min[a], p[j][a]), k->max[a] = fmaxf(k->max[a], p[j][a]);
        }
        double n[3];
        normal_of(p, n);
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        degenerate = degenerate || !(len > 0);
        for (int a = 0; !degenerate && a < 3; a++)
            sum[a] += n[a] / len;
    }
    double centre[3], radius = 0, axis_len = sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
    for (int a = 0; a < 3; a++) {
        centre[a] = 0.5 * ((double)k->min[a] + k->max[a]);
        k->center[a] = (float)centre[a];
        k->axis[a] = axis_len > 0 ? (float)(sum[a] / axis_len) : 0.0f;
    }
    double least = 1.0; // the least cosine of a normal to the axis (the float axis, as the test reads it)
    for (uint32_t t = 0; t < triangles; t++) {
        const float *p[3];
        for (int j = 0; j < 3; j++) {
            p[j] = s->vertices[idx[3 * t + j]].pos;
            double d2 = 0;
            for (int a = 0; a < 3; a++)
                d2 += (p[j][a] - (double)k->center[a]) * (p[j][a] - (double)k->center[a]);
            radius = fmax(radius, sqrt(d2));
        }
        double n[3];
        normal_of(p, n);
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > 0)
            least = fmin(least, (n[0] * k->axis[0] + n[1] * k->axis[1] + n[2] * k->axis[2]) / len);
    }
    k->radius = nextafterf((float)radius, INFINITY); // rounded up: the sphere holds every corner
    // The test reads the sine of the cone's half-angle (meshoptimizer's cone_cutoff).
    k->cutoff = degenerate || !(axis_len > 0) || !(least > 0.1) ? 1.0f : (float)sqrt(1.0 - least * least);
    if (k->cutoff < 1.0f) // rounded up: the cone holds every normal
        k->cutoff = nextafterf(k->cutoff, INFINITY);
}

pn_result pn_gbuffer_clusters_build(const pn_scene *s, const uint32_t *indices, pn_gbuffer_clusters *out)
{
    memset(out, 0, sizeof *out);
    const uint32_t per = 3 * PN_CLUSTER_TRIANGLES;
    size_t count = 0;
    for (uint32_t d = 0; d < s->draw_count; d++)
        count += ((size_t)s->draws[d].index_count / 3 * 3 + per - 1) / per; // size_t: no wrap near 2^32
    out->first = malloc(((size_t)s->draw_count + 1) * sizeof *out->first);
    out->items = malloc((count ? count : 1) * sizeof *out->items);
    if (!out->first || !out->items) {
        pn_gbuffer_clusters_destroy(out);
        return PN_ERR_MEMORY;
    }
    out->draw_count = s->draw_count;
    uint32_t at = 0;
    for (uint32_t d = 0; d < s->draw_count; d++) {
        out->first[d] = at;
        const pn_draw *dr = &s->draws[d];
        uint32_t whole = dr->index_count / 3 * 3; // as vkCmdDrawIndexed draws them: whole triangles
        bool valid = dr->first_index <= s->index_count && whole <= s->index_count - dr->first_index;
        for (uint32_t i = 0; valid && i < whole; i++)
            valid = indices[dr->first_index + i] < s->vertex_count;
        if (!valid && whole > 0) {
            // Indices outside the scene's (pn_scene_validate rejects them): one cluster, never skipped.
            pn_gbuffer_cluster *k = &out->items[at++];
            *k = (pn_gbuffer_cluster){.first_index = dr->first_index, .index_count = whole, .cutoff = 1.0f};
            for (int a = 0; a < 3; a++)
                k->min[a] = -INFINITY, k->max[a] = INFINITY;
            continue;
        }
        for (size_t i = 0; i < whole; i += per) {
            pn_gbuffer_cluster *k = &out->items[at++];
            k->first_index = dr->first_index + (uint32_t)i;
            k->index_count = whole - i < per ? (uint32_t)(whole - i) : per;
            bound(k, s, indices);
        }
    }
    out->first[s->draw_count] = at;
    return PN_OK;
}

void pn_gbuffer_clusters_destroy(pn_gbuffer_clusters *c)
{
    free(c->items);
    free(c->first);
    memset(c, 0, sizeof *c);
}

void pn_gbuffer_clusters_moved(pn_gbuffer_clusters *c, const pn_scene *s, const uint32_t *indices, uint32_t d)
{
    for (uint32_t k = c->first[d]; k < c->first[d + 1]; k++)
        if (c->items[k].max[0] != INFINITY) // a draw with indices outside the scene's keeps its one cluster
            bound(&c->items[k], s, indices);
}

// Whether every point of the box lies outside one side of the view frustum, widened by 2 pixels:
// the rasterizer's rounding of a vertex (a fraction of a pixel) cannot bring a fragment back
// inside. The GPU transforms the same floats in float: each clip coordinate off by a few ulps of
// the sum of its terms' magnitudes, which 2^-20 of that sum bounds with room (this test's own
// transform is in double). Clip space is linear in the world point, so a box whose 8 corners are
// all beyond a plane lies wholly beyond it.
static bool outside_frustum(const pn_gbuffer_cluster *k, const float m[16], double mx, double my)
{
    // Per plane (x <= w, -x <= w, y <= w, -y <= w, w > 0) whether all corners are beyond it.
    bool beyond[5] = {true, true, true, true, true};
    for (int i = 0; i < 8; i++) {
        double p[3], c[4], err[4];
        for (int a = 0; a < 3; a++)
            p[a] = i >> a & 1 ? k->max[a] : k->min[a];
        for (int r = 0; r < 4; r++) {
            c[r] = (double)m[r] * p[0] + (double)m[4 + r] * p[1] + (double)m[8 + r] * p[2] + (double)m[12 + r];
            err[r] = 0x1p-20 * (fabs((double)m[r] * p[0]) + fabs((double)m[4 + r] * p[1]) +
                                fabs((double)m[8 + r] * p[2]) + fabs((double)m[12 + r]));
        }
        beyond[0] = beyond[0] && c[0] - c[3] * mx > err[0] + err[3] * mx;
        beyond[1] = beyond[1] && -c[0] - c[3] * mx > err[0] + err[3] * mx;
        beyond[2] = beyond[2] && c[1] - c[3] * my > err[1] + err[3] * my;
        beyond[3] = beyond[3] && -c[1] - c[3] * my > err[1] + err[3] * my;
        beyond[4] = beyond[4] && c[3] < -err[3];
    }
    return beyond[0] || beyond[1] || beyond[2] || beyond[3] || beyond[4];
}

// Whether every triangle of the cluster faces away from the eye: meshoptimizer's conservative
// test over the bounding sphere (its README's, for meshopt_computeClusterBounds' cones: every point
// of the sphere sees every normal of the cone from behind), the cone and sphere bound()'s, rounded
// outwards, and the cone widened by 2^-7 radians: the rasterizer takes a triangle's facing from its
// corners rounded to 2^-8 of a pixel, which turns a triangle a pixel high by at most about 2^-8. A
// smaller triangle facing away within that rounding may still be drawn without the clusters;
// facing away, it can show only at a silhouette of its closed surface and only by a depth test's
// rounding there (the surface in front of it meets it at the silhouette): the one way this differs
// from drawing everything, not seen in any measurement (engine/gpu/README.md).
static bool facing_away(const pn_gbuffer_cluster *k, const float eye[3])
{
    if (!(k->cutoff < 1.0f))
        return false;
    const double slack = 0x1p-7;
    double c = k->cutoff, s = sqrt(fmax(1.0 - c * c, 0.0));
    double widened = c * cos(slack) + s * sin(slack); // sin(the cone's half-angle + slack)
    if (!(widened < 1.0))
        return false;
    double v[3], len = 0, along = 0;
    for (int a = 0; a < 3; a++) {
        v[a] = (double)k->center[a] - eye[a];
        len += v[a] * v[a];
        along += v[a] * k->axis[a];
    }
    len = sqrt(len);
    return along >= widened * len + k->radius;
}

uint32_t pn_gbuffer_clusters_runs(const pn_gbuffer_clusters *c, uint32_t d, const pn_gbuffer_push *camera,
                                  uint32_t width, uint32_t height, bool back, pn_gbuffer_run *out,
                                  uint64_t *kept_triangles)
{
    // 2 pixels in normalised device coordinates (an image spans 2 across).
    double mx = 1.0 + 4.0 / (width ? width : 1), my = 1.0 + 4.0 / (height ? height : 1);
    uint32_t runs = 0;
    uint64_t kept = 0;
    for (uint32_t i = c->first[d]; i < c->first[d + 1]; i++) {
        const pn_gbuffer_cluster *k = &c->items[i];
        if (outside_frustum(k, camera->view_proj, mx, my) || (back && facing_away(k, camera->eye)))
            continue;
        kept += k->index_count / 3;
        if (runs > 0 && out[runs - 1].first_index + out[runs - 1].index_count == k->first_index)
            out[runs - 1].index_count += k->index_count;
        else
            out[runs++] = (pn_gbuffer_run){k->first_index, k->index_count};
    }
    *kept_triangles = kept;
    return runs;
}
