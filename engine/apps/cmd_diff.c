// penumbra diff: how far apart two renders are, over the pixels that hold geometry.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/commands.h"
#include "apps/metrics.h"
#include "core/log.h"
#include "io/exr.h"
#include "io/json.h"

// Exit codes of diff: 0 within the --fail thresholds (or none given), 1 a threshold exceeded,
// 2 invalid command line or inputs that cannot be compared.
enum { DIFF_OK = 0, DIFF_EXCEEDED = 1, DIFF_BAD = 2 };

static const char *const METRICS[] = {"mae", "rmse", "p99", "max", "over005", "over02", NULL};

void pn_print_diff_help(void)
{
    printf("usage: penumbra diff A.exr B.exr [options]\n"
           "  Compares one channel of two renders of the same size over the pixels that hold geometry\n"
           "  (A = 1 in both, or every pixel when the files have no A channel): mean absolute error,\n"
           "  RMSE, 99th percentile and maximum of the absolute error, and the share of pixels off by\n"
           "  more than 0.05 and 0.2.\n"
           "  --channel NAME      the channel (default shadow.V)\n"
           "  --json              print one JSON object instead of the table\n"
           "  -o FILE.exr         write the per-pixel absolute error (channel `error`, 0 off geometry)\n"
           "  --fail K=V[,K=V]    exit 1 when a metric exceeds its threshold; K in mae, rmse, p99, max,\n"
           "                      over005, over02 (e.g. --fail mae=0.01,p99=0.1)\n"
           "  exit codes: 0 within thresholds, 1 a threshold exceeded, 2 bad arguments or inputs\n");
}

static bool parse_fail(const char *s, double thresholds[6], bool set[6])
{
    char buf[512];
    snprintf(buf, sizeof buf, "%s", s);
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        char *eq = strchr(tok, '=');
        if (!eq) {
            pn_error("--fail: expected KEY=VALUE, got '%s'", tok);
            return false;
        }
        *eq = '\0';
        int k = pn_parse_choice("--fail", tok, METRICS);
        if (k < 0)
            return false;
        char *end;
        double v = strtod(eq + 1, &end); // double: a share like 0.01 must compare exactly
        if (end == eq + 1 || *end != '\0' || !(v >= 0) || !isfinite(v)) {
            pn_error("--fail: expected a non-negative number for %s, got '%s'", tok, eq + 1);
            return false;
        }
        thresholds[k] = v;
        set[k] = true;
    }
    return true;
}

int pn_cmd_diff(int argc, char **argv)
{
    const char *files[2] = {NULL, NULL}, *channel = "shadow.V", *out = NULL;
    bool json = false, set[6] = {false};
    double thresholds[6] = {0};
    pn_args a = {argc, argv, 0};
    while (a.i < argc) {
        const char *v = NULL, *arg = argv[a.i];
        bool err = false, ok = true;
        if (pn_args_flag(&a, "--help") || pn_args_flag(&a, "-h")) {
            pn_print_diff_help();
            return DIFF_OK;
        } else if (pn_args_value(&a, "--channel", &v, &err)) {
            channel = v;
        } else if (pn_args_value(&a, "-o", &v, &err) || pn_args_value(&a, "--output", &v, &err)) {
            out = v;
        } else if (pn_args_value(&a, "--fail", &v, &err)) {
            ok = v && parse_fail(v, thresholds, set);
        } else if (pn_args_flag(&a, "--json")) {
            json = true;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            pn_error("diff: unknown option '%s' (see penumbra diff --help)", arg);
            return DIFF_BAD;
        } else if (!files[0] || !files[1]) {
            files[files[0] ? 1 : 0] = arg;
            a.i++;
        } else {
            pn_error("diff: more than two files given");
            return DIFF_BAD;
        }
        if (err || !ok)
            return DIFF_BAD;
    }
    if (!files[1]) {
        pn_error("diff: expected two EXR files (see penumbra diff --help)");
        return DIFF_BAD;
    }
    pn_exr_image img[2] = {{0}, {0}};
    int rc = DIFF_BAD;
    const float *ch[2] = {NULL, NULL}, *alpha[2] = {NULL, NULL};
    for (int i = 0; i < 2; i++) {
        if (pn_exr_read(files[i], &img[i]) != PN_OK)
            goto done;
        if (!(ch[i] = pn_exr_image_channel(&img[i], channel))) {
            pn_error("%s: no channel '%s'", files[i], channel);
            goto done;
        }
        alpha[i] = pn_exr_image_channel(&img[i], "A");
    }
    if (img[0].width != img[1].width || img[0].height != img[1].height) {
        pn_error("%s is %dx%d but %s is %dx%d: cannot compare", files[0], img[0].width, img[0].height, files[1],
                 img[1].width, img[1].height);
        goto done;
    }
    size_t px = (size_t)img[0].width * img[0].height;
    uint8_t *mask = malloc(px ? px : 1);
    float *plane = malloc((px ? px : 1) * sizeof *plane);
    pn_error_metrics em;
    bool ok = mask && plane;
    for (size_t i = 0; ok && i < px; i++)
        mask[i] = (!alpha[0] || alpha[0][i] == 1.0f) && (!alpha[1] || alpha[1][i] == 1.0f);
    ok = ok && pn_error_compare(ch[0], ch[1], mask, px, plane, &em);
    free(mask);
    if (!ok) {
        free(plane);
        pn_error("diff: out of memory");
        goto done;
    }
    size_t n = em.pixels;
    double m[6] = {em.mae, em.rmse, em.p99, em.max, em.over005, em.over02};
    rc = DIFF_OK;
    for (int k = 0; k < 6; k++)
        if (set[k] && !(m[k] <= thresholds[k]))
            rc = DIFF_EXCEEDED;
    if (out) {
        pn_exr_channel c = {"error", plane};
        pn_exr_attr attrs[3] = {{.name = "penumbra.diff.a", .type = PN_EXR_ATTR_STRING, .s = files[0]},
                                {.name = "penumbra.diff.b", .type = PN_EXR_ATTR_STRING, .s = files[1]},
                                {.name = "penumbra.diff.channel", .type = PN_EXR_ATTR_STRING, .s = channel}};
        if (pn_exr_write(out, img[0].width, img[0].height, &c, 1, attrs, 3) != PN_OK)
            rc = DIFF_BAD;
    }
    free(plane);
    if (rc != DIFF_BAD) {
        if (json) {
            printf("{\"a\": ");
            pn_json_string(stdout, files[0]);
            printf(", \"b\": ");
            pn_json_string(stdout, files[1]);
            printf(", \"channel\": ");
            pn_json_string(stdout, channel);
            printf(", \"pixels\": %zu, \"mae\": %.9g, \"rmse\": %.9g, \"p99\": %.9g, \"max\": %.9g, \"over005\": %.9g, "
                   "\"over02\": %.9g, \"exceeded\": %s}\n",
                   n, m[0], m[1], m[2], m[3], m[4], m[5], rc == DIFF_EXCEEDED ? "true" : "false");
        } else {
            printf("%s vs %s, channel %s, %zu pixels with geometry\n", files[0], files[1], channel, n);
            printf("  MAE %.6g  RMSE %.6g  p99 %.6g  max %.6g  >0.05 %.4f%%  >0.2 %.4f%%\n", m[0], m[1], m[2], m[3],
                   100 * m[4], 100 * m[5]);
            for (int k = 0; k < 6; k++)
                if (set[k] && !(m[k] <= thresholds[k]))
                    printf("  %s %.6g exceeds %.6g\n", METRICS[k], m[k], thresholds[k]);
        }
    }
done:
    pn_exr_image_free(&img[0]);
    pn_exr_image_free(&img[1]);
    return rc;
}
