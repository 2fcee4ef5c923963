// penumbra diff: how far apart two renders are, over the pixels that hold geometry.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/commands.h"
#include "apps/options.h"
#include "shadow/metrics.h"
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
    if (strlen(s) >= sizeof buf) { // cut short, a threshold could silently change
        pn_error("--fail: value too long (%zu characters)", strlen(s));
        return false;
    }
    snprintf(buf, sizeof buf, "%s", s);
    bool any = false;
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ","), any = true) {
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
    if (!any)
        pn_error("--fail: expected KEY=VALUE[,KEY=VALUE...], got '%s'", s);
    return any;
}

int pn_diff_parse(int argc, char **argv, pn_diff_opts *o)
{
    *o = (pn_diff_opts){.channel = "shadow.V"};
    pn_args a = {argc, argv, 0};
    while (a.i < argc) {
        const char *v = NULL, *arg = argv[a.i];
        bool err = false, ok = true;
        if (pn_args_flag(&a, "--help") || pn_args_flag(&a, "-h")) {
            pn_print_diff_help();
            return -1;
        } else if (pn_args_value(&a, "--channel", &v, &err)) {
            o->channel = v;
        } else if (pn_args_value(&a, "-o", &v, &err) || pn_args_value(&a, "--output", &v, &err)) {
            o->output = v;
        } else if (pn_args_value(&a, "--fail", &v, &err)) {
            ok = v && parse_fail(v, o->fail_threshold, o->fail_set);
        } else if (pn_args_flag(&a, "--json")) {
            o->json = true;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            pn_error("diff: unknown option '%s' (see penumbra diff --help)", arg);
            return PN_EXIT_USAGE;
        } else if (!o->files[0] || !o->files[1]) {
            o->files[o->files[0] ? 1 : 0] = arg;
            a.i++;
        } else {
            pn_error("diff: more than two files given");
            return PN_EXIT_USAGE;
        }
        if (err || !ok)
            return PN_EXIT_USAGE;
    }
    if (!o->files[1]) {
        pn_error("diff: expected two EXR files (see penumbra diff --help)");
        return PN_EXIT_USAGE;
    }
    if (!o->channel[0]) {
        pn_error("--channel: expected a channel name, got ''");
        return PN_EXIT_USAGE;
    }
    return PN_EXIT_OK;
}

int pn_cmd_diff(int argc, char **argv)
{
    pn_diff_opts o;
    int prc = pn_diff_parse(argc, argv, &o);
    if (prc != PN_EXIT_OK)
        return prc < 0 ? DIFF_OK : DIFF_BAD;
    const char *const *files = o.files, *channel = o.channel, *out = o.output;
    const bool json = o.json, *set = o.fail_set;
    const double *thresholds = o.fail_threshold;
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
