// penumbra diff against hand-made images with known errors. A 10x12 image: 100 pixels hold
// geometry (A = 1), 20 do not and differ wildly (they must be ignored). Over the 100: 90 equal,
// 9 off by 0.1 and 1 off by 0.5, so by hand:
//   MAE = (9*0.1 + 0.5)/100 = 0.014      RMSE = sqrt((9*0.01 + 0.25)/100) = sqrt(0.0034)
//   p99 (nearest rank 99 of 100, ascending) = 0.1      max = 0.5
//   share > 0.05 = 10/100 = 0.1                        share > 0.2 = 1/100 = 0.01
#include "io/exr.h"
#include "test_util.h"

static void write_pair(const char *a_path, const char *b_path, int w, int h)
{
    float *va = calloc((size_t)(w * h), sizeof(float)), *vb = calloc((size_t)(w * h), sizeof(float));
    float *alpha = calloc((size_t)(w * h), sizeof(float));
    for (int i = 0; i < w * h; i++) {
        alpha[i] = i < 100 ? 1.0f : 0.0f;
        va[i] = 0.25f + 0.005f * (float)(i % 50);
        vb[i] = va[i];
        if (i >= 90 && i < 99)
            vb[i] = va[i] + 0.1f;
        if (i == 99)
            vb[i] = va[i] - 0.5f;
        if (i >= 100)
            vb[i] = va[i] + 7.0f; // background: ignored
    }
    pn_exr_channel ca[2] = {{"A", alpha}, {"shadow.V", va}}, cb[2] = {{"A", alpha}, {"shadow.V", vb}};
    CHECK(pn_exr_write(a_path, w, h, ca, 2, NULL, 0) == PN_OK);
    CHECK(pn_exr_write(b_path, w, h, cb, 2, NULL, 0) == PN_OK);
    free(va), free(vb), free(alpha);
}

static double json_number(const char *js, const char *key)
{
    char pat[64];
    snprintf(pat, sizeof pat, "\"%s\": ", key);
    const char *p = strstr(js, pat);
    return p ? strtod(p + strlen(pat), NULL) : NAN;
}

static int run_capture(const char *args, char *out, size_t n)
{
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "\"%s\" %s", pn_test_env("PN_BIN", "penumbra"), args);
    FILE *p = popen(cmd, "r");
    size_t got = p ? fread(out, 1, n - 1, p) : 0;
    out[got] = '\0';
    int st = p ? pclose(p) : -1;
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

int main(void)
{
    const char *a = pn_test_tmp("diff_a.exr"), *b = pn_test_tmp("diff_b.exr"), *d = pn_test_tmp("diff_err.exr");
    const char *small = pn_test_tmp("diff_small.exr");
    write_pair(a, b, 10, 12);
    char args[2048], js[4096];
    snprintf(args, sizeof args, "diff %s %s --json -o %s", a, b, d);
    CHECK(run_capture(args, js, sizeof js) == 0);
    fprintf(stderr, "%s", js);
    const double tol = 1e-6; // the values are floats: 0.1 is 0.1 only to ~1e-8
    CHECK(fabs(json_number(js, "pixels") - 100) < 0.5);
    CHECK(fabs(json_number(js, "mae") - 0.014) < tol);
    CHECK(fabs(json_number(js, "rmse") - sqrt(0.0034)) < tol);
    CHECK(fabs(json_number(js, "p99") - 0.1) < tol);
    CHECK(fabs(json_number(js, "max") - 0.5) < tol);
    CHECK(fabs(json_number(js, "over005") - 0.1) < tol);
    CHECK(fabs(json_number(js, "over02") - 0.01) < tol);
    // The error image: 0.5 at pixel 99, 0.1 at 90, 0 off geometry.
    pn_exr_image e;
    CHECK(pn_exr_read(d, &e) == PN_OK);
    const float *err = pn_exr_image_channel(&e, "error");
    CHECK(err && fabsf(err[99] - 0.5f) < 1e-6f && fabsf(err[90] - 0.1f) < 1e-6f && err[0] == 0.0f && err[110] == 0.0f);
    pn_exr_image_free(&e);
    // Thresholds: exceeded -> 1, met -> 0.
    snprintf(args, sizeof args, "diff %s %s --fail mae=0.01", a, b);
    CHECK(run_capture(args, js, sizeof js) == 1);
    snprintf(args, sizeof args, "diff %s %s --fail mae=0.02,max=0.51,over02=0.01", a, b);
    CHECK(run_capture(args, js, sizeof js) == 0);
    snprintf(args, sizeof args, "diff %s %s --fail p99=0.05", a, b);
    CHECK(run_capture(args, js, sizeof js) == 1);
    // Identical files: all zero.
    snprintf(args, sizeof args, "diff %s %s --json --fail max=0", a, a);
    CHECK(run_capture(args, js, sizeof js) == 0 && json_number(js, "max") == 0.0);
    // Inputs that cannot be compared: exit 2.
    float one[4] = {1, 1, 1, 1};
    pn_exr_channel c = {"shadow.V", one};
    CHECK(pn_exr_write(small, 2, 2, &c, 1, NULL, 0) == PN_OK);
    snprintf(args, sizeof args, "diff %s %s 2>/dev/null", a, small);
    CHECK(run_capture(args, js, sizeof js) == 2);
    snprintf(args, sizeof args, "diff %s %s --channel R 2>/dev/null", a, b);
    CHECK(run_capture(args, js, sizeof js) == 2);
    snprintf(args, sizeof args, "diff %s %s/missing.exr 2>/dev/null", a, pn_test_env("PN_TEST_TMP", "/tmp"));
    CHECK(run_capture(args, js, sizeof js) == 2);
    snprintf(args, sizeof args, "diff %s %s --fail bogus=1 2>/dev/null", a, b);
    CHECK(run_capture(args, js, sizeof js) == 2);
    return pn_test_result();
}
