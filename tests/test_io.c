// io/exr, io/png and io/file: round trips checked bit for bit, files checked independently of
// the code that wrote them (OpenEXRCore directly, exrheader, a PNG parser written here,
// oiiotool), and failures that must leave no partial file and keep the previous output.
//
// Over 500 lines because each of its checks carries its own independent reader (OpenEXRCore
// directly, a PNG parser, the tools) and its own hostile files.
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <openexr.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "core/log.h"
#include "io/exr.h"
#include "io/file.h"
#include "io/png.h"
#include "test_util.h"

// ---- small helpers

static uint32_t g_rng = 0x12345678u;
static uint32_t rng(void)
{
    g_rng ^= g_rng << 13;
    g_rng ^= g_rng >> 17;
    g_rng ^= g_rng << 5;
    return g_rng;
}

static uint32_t float_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

static float bits_float(uint32_t u)
{
    float f;
    memcpy(&f, &u, 4);
    return f;
}

// True if a finite float survives a round trip through IEEE half precision unchanged.
static int half_exact(float f)
{
    if (f == 0.0f || !isfinite(f))
        return 1;
    float a = fabsf(f);
    if (a > 65504.0f)
        return 0;
    if (a < 6.103515625e-05f) // half subnormals: multiples of 2^-24
        return ldexpf(a, 24) == floorf(ldexpf(a, 24));
    return (float_bits(a) & 0x1FFFu) == 0; // 10 mantissa bits of 23
}

// The whole file, followed by a NUL byte not counted in *n (so text can be parsed in place).
static unsigned char *read_all(const char *path, size_t *n)
{
    *n = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, len = 0, k;
    unsigned char *buf = malloc(cap);
    while (buf && (k = fread(buf + len, 1, cap - 1 - len, f)) > 0) {
        len += k;
        if (len == cap - 1) {
            unsigned char *nb = realloc(buf, cap *= 2);
            if (!nb)
                free(buf);
            buf = nb;
        }
    }
    fclose(f);
    if (buf)
        buf[len] = 0;
    *n = len;
    return buf;
}

static int write_all(const char *path, const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    int ok = fwrite(p, 1, n, f) == n;
    return fclose(f) == 0 && ok;
}

static int exists(const char *path) { return access(path, F_OK) == 0; }

// Runs a shell command, collecting its output (stdout and stderr) into buf.
static int run_capture(const char *cmd, char *buf, size_t n)
{
    buf[0] = '\0';
    FILE *p = popen(cmd, "r");
    if (!p)
        return -1;
    size_t len = 0, k;
    while (len + 1 < n && (k = fread(buf + len, 1, n - 1 - len, p)) > 0)
        len += k;
    buf[len] = '\0';
    char sink[4096];
    while (fread(sink, 1, sizeof sink, p) > 0) {
    }
    int st = pclose(p);
    return st == -1 || !WIFEXITED(st) ? -1 : WEXITSTATUS(st);
}

static int have_tool(const char *name)
{
    char cmd[256];
    snprintf(cmd, sizeof cmd, "command -v %s >/dev/null 2>&1", name);
    int st = system(cmd);
    return st != -1 && WIFEXITED(st) && WEXITSTATUS(st) == 0;
}

static int image_is_zeroed(const pn_exr_image *img)
{
    return img->width == 0 && img->height == 0 && img->channel_count == 0 && !img->names &&
           !img->data;
}

// Checks that no temporary file of this process is left in the scratch folder.
static void check_no_tmp_files(void)
{
    const char *dir = pn_test_env("PN_TEST_TMP", "/tmp");
    DIR *d = opendir(dir);
    CHECK(d != NULL);
    if (!d)
        return;
    char suffix[64];
    snprintf(suffix, sizeof suffix, ".tmp-%ld", (long)getpid());
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        size_t n = strlen(e->d_name), s = strlen(suffix);
        CHECK_MSG(!(n > s && strcmp(e->d_name + n - s, suffix) == 0), "temporary file left: %s",
                  e->d_name);
    }
    closedir(d);
}

// Runs `fn` with the process's file size limit set to `bytes`, so that writes past it fail
// (EFBIG) as on a full disk. Returns 0 if the limit cannot be set.
typedef pn_result (*limited_fn)(void *);
static int with_file_size_limit(rlim_t bytes, limited_fn fn, void *arg, pn_result *out)
{
    struct rlimit old, lim;
    if (getrlimit(RLIMIT_FSIZE, &old) != 0)
        return 0;
    lim = old;
    lim.rlim_cur = bytes;
    if (old.rlim_max != RLIM_INFINITY && old.rlim_max < bytes)
        return 0;
    void (*prev)(int) = signal(SIGXFSZ, SIG_IGN);
    if (setrlimit(RLIMIT_FSIZE, &lim) != 0) {
        signal(SIGXFSZ, prev);
        return 0;
    }
    *out = fn(arg);
    setrlimit(RLIMIT_FSIZE, &old);
    signal(SIGXFSZ, prev);
    return 1;
}

// ---- EXR

enum { EW = 37, EH = 21, NCH = 6 }; // 21 rows: the last 16-row ZIP chunk is partial

static float g_planes[NCH][EW * EH];
static const char *const g_names[NCH] = {"shadow.V", "R", "P.X", "A", "G", "B"}; // unsorted

static const char *const g_sorted[NCH] = {"A", "B", "G", "P.X", "R", "shadow.V"};

static void make_planes(void)
{
    static const float specials[] = {
        0.0f,       -0.0f,    1e-40f /* float subnormal */, FLT_MIN, FLT_MAX, -FLT_MAX,
        INFINITY,   -INFINITY, 65504.0f, 65520.0f /* half overflow */, 3.14159265f,
        1e-8f,      16777216.0f, -2.5e-5f, 0.1f, 1.0f / 3.0f};
    const int nspec = (int)(sizeof specials / sizeof specials[0]);
    for (int y = 0; y < EH; y++)
        for (int x = 0; x < EW; x++) {
            int i = y * EW + x;
            // shadow.V: random finite bit patterns (incompressible, every mantissa bit used)
            uint32_t u = rng();
            if (((u >> 23) & 0xFF) == 0xFF)
                u &= ~(1u << 30);
            g_planes[0][i] = bits_float(u);
            g_planes[1][i] = (float)i * 0.1f + 1.0f / 3.0f;                  // R
            g_planes[2][i] = -5.0f + (float)x * 0.013f + (float)y * 0.7f;    // P.X
            g_planes[3][i] = (float)x / (EW - 1) * ((float)y / (EH - 1));    // A
            g_planes[4][i] = bits_float(float_bits(1.0f) + (uint32_t)i);     // G: 1 + i ulp
            g_planes[5][i] = i < nspec ? specials[i] : (float)x - (float)y * 1e-3f; // B
        }
    g_planes[5][nspec] = NAN;
}

static pn_exr_channel g_channels[NCH];

static const float k_exposure = 1.0f / 3.0f;
static const int32_t k_samples = -123456789;
static const float k_dir[3] = {0.1f, -0.75f, 1e-7f};

static pn_exr_attr g_attrs[5];

static void make_exr_inputs(void)
{
    make_planes();
    for (int c = 0; c < NCH; c++) {
        g_channels[c].name = g_names[c];
        g_channels[c].data = g_planes[c];
    }
    memset(g_attrs, 0, sizeof g_attrs);
    g_attrs[0].name = "penumbra/scene";
    g_attrs[0].type = PN_EXR_ATTR_STRING;
    g_attrs[0].s = "cornell box.gltf";
    g_attrs[1].name = "penumbra/exposure";
    g_attrs[1].type = PN_EXR_ATTR_FLOAT;
    g_attrs[1].f[0] = k_exposure;
    g_attrs[2].name = "penumbra/samples";
    g_attrs[2].type = PN_EXR_ATTR_INT;
    g_attrs[2].i = k_samples;
    g_attrs[3].name = "penumbra/light_dir";
    g_attrs[3].type = PN_EXR_ATTR_V3F;
    memcpy(g_attrs[3].f, k_dir, sizeof k_dir);
    g_attrs[4].name = "penumbra/note";
    g_attrs[4].type = PN_EXR_ATTR_STRING;
    g_attrs[4].s = "";
}

static void test_exr_inputs_are_not_half(void)
{
    // The round trip must prove float storage: every channel holds values half would change.
    for (int c = 0; c < NCH; c++) {
        int non_half = 0;
        for (int i = 0; i < EW * EH; i++)
            non_half += !half_exact(g_planes[c][i]);
        CHECK_MSG(non_half > EW * EH / 2, "channel %s: only %d values not exact in half",
                  g_names[c], non_half);
    }
    CHECK(!half_exact(k_exposure));
}

static void test_exr_roundtrip(const char *path)
{
    pn_exr_image img;
    pn_result r = pn_exr_read(path, &img);
    CHECK_MSG(r == PN_OK, "pn_exr_read: %s", pn_result_str(r));
    if (r != PN_OK)
        return;
    CHECK(img.width == EW && img.height == EH);
    CHECK(img.channel_count == NCH);
    for (int c = 0; c < NCH; c++) {
        const float *plane = pn_exr_image_channel(&img, g_names[c]);
        CHECK_MSG(plane != NULL, "channel %s missing", g_names[c]);
        if (!plane || img.width != EW || img.height != EH)
            continue;
        int bad = -1;
        for (int i = 0; i < EW * EH && bad < 0; i++)
            if (float_bits(plane[i]) != float_bits(g_planes[c][i]))
                bad = i;
        CHECK_MSG(bad < 0, "channel %s differs at pixel %d: %a != %a", g_names[c], bad,
                  bad >= 0 ? plane[bad] : 0.0, bad >= 0 ? g_planes[c][bad] : 0.0);
    }
    CHECK(pn_exr_image_channel(&img, "Z") == NULL);
    CHECK(pn_exr_image_channel(&img, "shadow") == NULL);
    pn_exr_image_free(&img);
    CHECK(image_is_zeroed(&img));
    pn_exr_image_free(&img); // freeing twice is harmless
}

// Reads the header back with OpenEXRCore itself, independently of pn_exr_read.
static void test_exr_core_header(const char *path)
{
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_result_t rv = exr_start_read(&ctx, path, &init);
    CHECK_MSG(rv == EXR_ERR_SUCCESS, "exr_start_read: %s", exr_get_error_code_as_string(rv));
    if (rv != EXR_ERR_SUCCESS)
        return;

    int parts = 0;
    CHECK(exr_get_count(ctx, &parts) == EXR_ERR_SUCCESS && parts == 1);
    exr_storage_t storage = EXR_STORAGE_LAST_TYPE;
    CHECK(exr_get_storage(ctx, 0, &storage) == EXR_ERR_SUCCESS && storage == EXR_STORAGE_SCANLINE);
    exr_compression_t comp = EXR_COMPRESSION_LAST_TYPE;
    CHECK(exr_get_compression(ctx, 0, &comp) == EXR_ERR_SUCCESS && comp == EXR_COMPRESSION_ZIP);
    exr_attr_box2i_t dw;
    CHECK(exr_get_data_window(ctx, 0, &dw) == EXR_ERR_SUCCESS);
    CHECK(dw.min.x == 0 && dw.min.y == 0 && dw.max.x == EW - 1 && dw.max.y == EH - 1);

    const exr_attr_chlist_t *chl = NULL;
    CHECK(exr_get_channels(ctx, 0, &chl) == EXR_ERR_SUCCESS && chl);
    if (chl) {
        CHECK(chl->num_channels == NCH);
        for (int i = 0; i < chl->num_channels && i < NCH; i++) {
            CHECK_MSG(strcmp(chl->entries[i].name.str, g_sorted[i]) == 0, "channel %d is %s", i,
                      chl->entries[i].name.str);
            CHECK(chl->entries[i].pixel_type == EXR_PIXEL_FLOAT);
            CHECK(chl->entries[i].x_sampling == 1 && chl->entries[i].y_sampling == 1);
        }
    }

    const exr_attribute_t *a = NULL;
    rv = exr_get_attribute_by_name(ctx, 0, "penumbra/scene", &a);
    CHECK(rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_STRING);
    if (rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_STRING)
        CHECK(a->string->length == (int32_t)strlen("cornell box.gltf") &&
              memcmp(a->string->str, "cornell box.gltf", (size_t)a->string->length) == 0);

    a = NULL;
    rv = exr_get_attribute_by_name(ctx, 0, "penumbra/note", &a);
    CHECK(rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_STRING);
    if (rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_STRING)
        CHECK(a->string->length == 0);

    a = NULL;
    rv = exr_get_attribute_by_name(ctx, 0, "penumbra/exposure", &a);
    CHECK(rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_FLOAT);
    if (rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_FLOAT)
        CHECK(float_bits(a->f) == float_bits(k_exposure));

    a = NULL;
    rv = exr_get_attribute_by_name(ctx, 0, "penumbra/samples", &a);
    CHECK(rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_INT);
    if (rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_INT)
        CHECK(a->i == k_samples);

    a = NULL;
    rv = exr_get_attribute_by_name(ctx, 0, "penumbra/light_dir", &a);
    CHECK(rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_V3F);
    if (rv == EXR_ERR_SUCCESS && a && a->type == EXR_ATTR_V3F)
        CHECK(float_bits(a->v3f->x) == float_bits(k_dir[0]) &&
              float_bits(a->v3f->y) == float_bits(k_dir[1]) &&
              float_bits(a->v3f->z) == float_bits(k_dir[2]));

    // The typed getters agree.
    int32_t iv = 0;
    CHECK(exr_attr_get_int(ctx, 0, "penumbra/samples", &iv) == EXR_ERR_SUCCESS && iv == k_samples);
    exr_attr_v3f_t v3;
    CHECK(exr_attr_get_v3f(ctx, 0, "penumbra/light_dir", &v3) == EXR_ERR_SUCCESS &&
          v3.x == k_dir[0] && v3.y == k_dir[1] && v3.z == k_dir[2]);
    CHECK(exr_get_attribute_by_name(ctx, 0, "penumbra/missing", &a) != EXR_ERR_SUCCESS);

    exr_finish(&ctx);
}

static void test_exrheader(const char *path)
{
    if (!have_tool("exrheader")) {
        fprintf(stderr, "note: exrheader not found; skipping its check\n");
        return;
    }
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "exrheader '%s' 2>&1", path);
    static char out[1 << 16];
    int st = run_capture(cmd, out, sizeof out);
    CHECK_MSG(st == 0, "exrheader exited with %d:\n%s", st, out);
    for (int c = 0; c < NCH; c++) {
        char line[128];
        snprintf(line, sizeof line, "\n    %s, 32-bit floating-point, sampling 1 1", g_names[c]);
        CHECK_MSG(strstr(out, line) != NULL, "exrheader does not list channel %s", g_names[c]);
    }
    static const char *const want[] = {
        "penumbra/scene (type string): \"cornell box.gltf\"",
        "penumbra/note (type string)",
        "penumbra/exposure (type float)",
        "penumbra/samples (type int): -123456789",
        "penumbra/light_dir (type v3f)",
        "compression (type compression): zip",
        "dataWindow (type box2i): (0 0) - (36 20)",
    };
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++)
        CHECK_MSG(strstr(out, want[i]) != NULL, "exrheader output lacks \"%s\":\n%s", want[i], out);
}

typedef struct exr_job {
    const char *path;
    int width, height;
} exr_job;

static pn_result run_exr_job(void *arg)
{
    const exr_job *j = arg;
    return pn_exr_write(j->path, j->width, j->height, g_channels, NCH, g_attrs, 5);
}

static void test_exr_write_failures(void)
{
    // A folder that does not exist: error, and nothing created.
    const char *dir = pn_test_tmp("no_such_dir_io");
    const char *path = pn_test_tmp("no_such_dir_io/out.exr");
    CHECK(!exists(dir));
    CHECK(pn_exr_write(path, EW, EH, g_channels, NCH, g_attrs, 5) != PN_OK);
    CHECK(!exists(path) && !exists(dir));

    // Invalid arguments: PN_ERR_INVALID and no file.
    const char *bad = pn_test_tmp("invalid.exr");
    remove(bad);
    pn_exr_channel dup[2] = {{"R", g_planes[1]}, {"R", g_planes[1]}};
    pn_exr_channel noname[1] = {{"", g_planes[1]}};
    pn_exr_channel nullname[1] = {{NULL, g_planes[1]}};
    pn_exr_channel nodata[1] = {{"R", NULL}};
    pn_exr_attr dup_attr[2] = {g_attrs[1], g_attrs[1]};
    pn_exr_attr reserved = g_attrs[1];
    reserved.name = "compression";
    pn_exr_attr nostr = g_attrs[0];
    nostr.s = NULL;
    CHECK(pn_exr_write(bad, 0, EH, g_channels, NCH, NULL, 0) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, -1, g_channels, NCH, NULL, 0) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, NULL, NCH, NULL, 0) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, g_channels, 0, NULL, 0) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, dup, 2, NULL, 0) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, noname, 1, NULL, 0) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, nullname, 1, NULL, 0) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, nodata, 1, NULL, 0) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, g_channels, NCH, dup_attr, 2) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, g_channels, NCH, &reserved, 1) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, g_channels, NCH, &nostr, 1) == PN_ERR_INVALID);
    CHECK(pn_exr_write(bad, EW, EH, g_channels, NCH, NULL, 3) == PN_ERR_INVALID);
    CHECK(!exists(bad));

    // A write that fails part way (file size limit, like a full disk) keeps the old file.
    const char *keep = pn_test_tmp("keep.exr");
    static const char old[] = "previous output\n";
    CHECK(write_all(keep, old, sizeof old - 1));
    CHECK(pn_exr_write(keep, EW, EH, dup, 2, NULL, 0) == PN_ERR_INVALID);
    exr_job job = {keep, EW, EH};
    pn_result r = PN_OK;
    if (with_file_size_limit(1500, run_exr_job, &job, &r)) {
        CHECK_MSG(r == PN_ERR_IO, "write past the file size limit returned %s", pn_result_str(r));
        size_t n = 0;
        unsigned char *got = read_all(keep, &n);
        CHECK(got && n == sizeof old - 1 && memcmp(got, old, n) == 0);
        free(got);
        char tmp[4096];
        CHECK(pn_file_tmp_path(keep, tmp, sizeof tmp) == PN_OK);
        CHECK_MSG(!exists(tmp), "%s left behind", tmp);
    } else {
        fprintf(stderr, "note: cannot set RLIMIT_FSIZE; skipping the mid-write failure check\n");
    }
    // And a successful write replaces it.
    CHECK(pn_exr_write(keep, EW, EH, g_channels, NCH, g_attrs, 5) == PN_OK);
    test_exr_roundtrip(keep);
    remove(keep);
}

static void check_read_fails(const char *path, const char *what)
{
    pn_exr_image img;
    memset(&img, 0xAB, sizeof img);
    pn_result r = pn_exr_read(path, &img);
    CHECK_MSG(r != PN_OK, "reading %s succeeded", what);
    CHECK_MSG(image_is_zeroed(&img), "reading %s left the image non-zero", what);
    if (r == PN_OK)
        pn_exr_image_free(&img);
}

static void test_exr_bad_inputs(const char *good)
{
    size_t n = 0;
    unsigned char *bytes = read_all(good, &n);
    CHECK(bytes && n > 1000);
    if (!bytes)
        return;
    char path[1024];
    snprintf(path, sizeof path, "%s", pn_test_tmp("damaged.exr"));

    check_read_fails(pn_test_tmp("does_not_exist.exr"), "a missing file");
    pn_exr_image img;
    CHECK(pn_exr_read(pn_test_tmp("does_not_exist.exr"), &img) == PN_ERR_IO);

    pn_log_level level = pn_log_get_level();
    pn_log_set_level(getenv("PN_TEST_VERBOSE") ? PN_LOG_INFO : PN_LOG_QUIET); // expected errors

    // Truncated copies.
    size_t cuts[] = {0, 1, 4, 8, 60, 200, 400, n / 4, n / 2, n - 200, n - 8, n - 1};
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        CHECK(write_all(path, bytes, cuts[i]));
        char what[64];
        snprintf(what, sizeof what, "a copy cut to %zu of %zu bytes", cuts[i], n);
        check_read_fails(path, what);
    }
    // Garbage, with and without the EXR magic number.
    unsigned char junk[4096];
    for (size_t i = 0; i < sizeof junk; i++)
        junk[i] = (unsigned char)rng();
    CHECK(write_all(path, junk, sizeof junk));
    check_read_fails(path, "random bytes");
    memcpy(junk, bytes, 8); // magic and version
    CHECK(write_all(path, junk, sizeof junk));
    check_read_fails(path, "random bytes after the magic number");
    memcpy(junk, "not an image at all\n", 20);
    CHECK(write_all(path, junk, 20));
    check_read_fails(path, "a text file");

    // Damaged copies: any result is fine as long as nothing crashes or leaks; a success must
    // be a whole image.
    unsigned char *copy = malloc(n);
    int ok = 0, failed = 0;
    for (int iter = 0; copy && iter < 300; iter++) {
        memcpy(copy, bytes, n);
        int flips = 1 + (int)(rng() % 4);
        for (int k = 0; k < flips; k++) {
            // the first half hits the header and chunk table, the rest anywhere
            size_t at = iter < 150 ? rng() % 800 : rng() % n;
            copy[at] = (unsigned char)rng();
        }
        CHECK(write_all(path, copy, n));
        pn_exr_image dmg;
        if (pn_exr_read(path, &dmg) == PN_OK) {
            ok++;
            CHECK(dmg.width > 0 && dmg.height > 0 && dmg.channel_count > 0);
            for (int c = 0; c < dmg.channel_count; c++)
                CHECK(dmg.names[c] && dmg.data[c]);
            pn_exr_image_free(&dmg);
        } else {
            failed++;
            CHECK(image_is_zeroed(&dmg));
        }
    }
    pn_log_set_level(level);
    fprintf(stderr, "damaged EXR copies: %d read, %d rejected\n", ok, failed);
    free(copy);
    free(bytes);
    remove(path);
}

// Half, tiled, offset data window and uint channels, made by another writer (oiiotool).
static void test_exr_other_layouts(const char *good)
{
    if (!have_tool("oiiotool")) {
        fprintf(stderr, "note: oiiotool not found; skipping half/tiled/uint EXR input checks\n");
        return;
    }
    char tiled[1024], uint_path[1024], cmd[4096], out[8192];
    snprintf(tiled, sizeof tiled, "%s", pn_test_tmp("tiled_half.exr"));
    snprintf(uint_path, sizeof uint_path, "%s", pn_test_tmp("uint.exr"));
    snprintf(cmd, sizeof cmd,
             "oiiotool '%s' --origin +5-7 -d half --tile 16 8 --compression piz -o '%s' 2>&1",
             good, tiled);
    int st = run_capture(cmd, out, sizeof out);
    CHECK_MSG(st == 0, "oiiotool failed: %s", out);
    pn_exr_image img;
    pn_result r = pn_exr_read(tiled, &img);
    CHECK_MSG(r == PN_OK, "tiled half EXR: %s", pn_result_str(r));
    if (r == PN_OK) {
        CHECK(img.width == EW && img.height == EH && img.channel_count == NCH);
        const char *check[] = {"R", "P.X", "A"};
        for (int k = 0; k < 3 && img.width == EW && img.height == EH; k++) {
            const float *got = pn_exr_image_channel(&img, check[k]);
            int c = 0;
            while (strcmp(g_names[c], check[k]) != 0)
                c++;
            CHECK(got != NULL);
            int bad = -1;
            for (int i = 0; got && i < EW * EH && bad < 0; i++) {
                float want = g_planes[c][i];
                if (fabsf(got[i] - want) > 1e-3f * fabsf(want) + 1e-4f)
                    bad = i;
            }
            CHECK_MSG(bad < 0, "half channel %s differs at %d", check[k], bad);
        }
        pn_exr_image_free(&img);
    }
    remove(tiled);

    snprintf(cmd, sizeof cmd, "oiiotool '%s' --ch A -d uint32 -o '%s' 2>&1", good, uint_path);
    st = run_capture(cmd, out, sizeof out);
    CHECK_MSG(st == 0, "oiiotool failed: %s", out);
    r = pn_exr_read(uint_path, &img);
    CHECK_MSG(r == PN_OK, "uint EXR: %s", pn_result_str(r));
    if (r == PN_OK) {
        CHECK(img.width == EW && img.height == EH && img.channel_count == 1);
        const float *got = pn_exr_image_channel(&img, "A");
        CHECK(got != NULL);
        for (int i = 0; got && i < EW * EH; i++) {
            double want = (double)g_planes[3][i] * 4294967295.0; // oiiotool scales to full range
            if (fabs(got[i] - want) > 1e-5 * 4294967295.0) {
                CHECK_MSG(0, "uint channel differs at %d: %g vs %g", i, got[i], want);
                break;
            }
        }
        pn_exr_image_free(&img);
    }
    remove(uint_path);

    // DWA: lossy, and decoded by OpenEXRCore only from 3.1.10 on; either way no crash.
    snprintf(cmd, sizeof cmd, "oiiotool '%s' --compression dwaa -o '%s' 2>&1", good, tiled);
    st = run_capture(cmd, out, sizeof out);
    CHECK_MSG(st == 0, "oiiotool failed: %s", out);
    r = pn_exr_read(tiled, &img);
    CHECK_MSG(r == PN_OK || r == PN_ERR_UNSUPPORTED, "DWA EXR: %s", pn_result_str(r));
    if (r == PN_OK) {
        CHECK(img.width == EW && img.height == EH && img.channel_count == NCH);
        pn_exr_image_free(&img);
    } else {
        CHECK(image_is_zeroed(&img));
    }
    remove(tiled);
}

// Names longer than 31 bytes need the file's long-name flag; the writer sets it when needed.
static void test_exr_long_names(void)
{
    static const float d[6] = {1.5f, -2.25f, 3.0f, 1e-20f, 5e20f, 0.1f};
    static const char chan[] = "shadow.visibility.filtered.by.the.long.name";
    static const char attr[] = "penumbra/an_attribute_name_longer_than_31";
    pn_exr_channel ch[1] = {{chan, d}};
    pn_exr_attr at[1];
    memset(at, 0, sizeof at);
    at[0].name = attr;
    at[0].type = PN_EXR_ATTR_INT;
    at[0].i = 7;
    char path[1024];
    snprintf(path, sizeof path, "%s", pn_test_tmp("long_names.exr"));
    CHECK(pn_exr_write(path, 3, 2, ch, 1, at, 1) == PN_OK);
    pn_exr_image img;
    CHECK(pn_exr_read(path, &img) == PN_OK);
    const float *got = pn_exr_image_channel(&img, chan);
    CHECK(img.width == 3 && img.height == 2 && got && memcmp(got, d, sizeof d) == 0);
    pn_exr_image_free(&img);
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    if (exr_start_read(&ctx, path, &init) == EXR_ERR_SUCCESS) {
        int32_t v = 0;
        CHECK(exr_attr_get_int(ctx, 0, attr, &v) == EXR_ERR_SUCCESS && v == 7);
        exr_finish(&ctx);
    } else {
        CHECK_MSG(0, "OpenEXRCore cannot open %s", path);
    }
    remove(path);
}

static void test_exr(void)
{
    make_exr_inputs();
    test_exr_inputs_are_not_half();
    static char path[1024]; // pn_test_tmp() reuses its buffers
    snprintf(path, sizeof path, "%s", pn_test_tmp("io_test.exr"));
    remove(path);
    pn_result r = pn_exr_write(path, EW, EH, g_channels, NCH, g_attrs, 5);
    CHECK_MSG(r == PN_OK, "pn_exr_write: %s", pn_result_str(r));
    if (r != PN_OK)
        return;
    test_exr_roundtrip(path);
    test_exr_core_header(path);
    test_exrheader(path);
    test_exr_write_failures();
    test_exr_bad_inputs(path);
    test_exr_other_layouts(path);
    test_exr_long_names();
    remove(path);
}

// ---- PNG, checked with a parser written here (bitwise CRC and Adler-32, no tables)

static uint32_t crc32_bitwise(const unsigned char *p, size_t n)
{
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++) {
        c ^= p[i];
        for (int k = 0; k < 8; k++)
            c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1)));
    }
    return ~c;
}

static uint32_t be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

// Parses and fully verifies a PNG written by pn_png_write_rgb8 and compares its pixels.
static void verify_png(const char *path, int w, int h, const uint8_t *rgb)
{
    size_t n = 0;
    unsigned char *f = read_all(path, &n);
    CHECK_MSG(f != NULL, "cannot read %s", path);
    if (!f)
        return;
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    CHECK(n >= 8 && memcmp(f, sig, 8) == 0);

    unsigned char *z = malloc(n); // concatenated IDAT payloads
    size_t zlen = 0;
    int chunks = 0, idats = 0, seen_ihdr = 0, seen_iend = 0;
    size_t pos = 8;
    while (z && pos + 12 <= n && !seen_iend) {
        uint32_t len = be32(f + pos);
        CHECK_MSG(len <= n - pos - 12, "chunk %d overruns the file", chunks);
        if (len > n - pos - 12)
            break;
        const unsigned char *type = f + pos + 4, *data = f + pos + 8;
        CHECK_MSG(be32(data + len) == crc32_bitwise(type, len + 4), "bad CRC in chunk %d (%.4s)",
                  chunks, (const char *)type);
        if (chunks == 0) {
            CHECK(memcmp(type, "IHDR", 4) == 0 && len == 13);
            if (memcmp(type, "IHDR", 4) == 0 && len == 13) {
                seen_ihdr = 1;
                CHECK(be32(data) == (uint32_t)w && be32(data + 4) == (uint32_t)h);
                CHECK(data[8] == 8);  // bit depth
                CHECK(data[9] == 2);  // RGB
                CHECK(data[10] == 0); // deflate
                CHECK(data[11] == 0); // filter method
                CHECK(data[12] == 0); // not interlaced
            }
        } else if (memcmp(type, "IDAT", 4) == 0) {
            idats++;
            memcpy(z + zlen, data, len);
            zlen += len;
        } else if (memcmp(type, "IEND", 4) == 0) {
            CHECK(len == 0);
            seen_iend = 1;
        } else {
            CHECK_MSG(0, "unexpected chunk %.4s", (const char *)type);
        }
        chunks++;
        pos += 12 + (size_t)len;
    }
    CHECK(seen_ihdr && seen_iend && idats >= 1);
    CHECK_MSG(pos == n, "%zu bytes after IEND", n - pos);

    // zlib (libpng's deflate is checked by zlib's own inflate, which also checks the Adler-32).
    size_t line = (size_t)w * 3 + 1, raw_len = line * (size_t)h;
    unsigned char *raw = malloc(raw_len + 1); // one byte more: a stream that inflates longer shows
    uLongf got = (uLongf)raw_len + 1;
    int ok = z && raw && zlen >= 6;
    CHECK(ok);
    if (ok) {
        CHECK((z[0] & 0x0F) == 8 && ((z[0] << 8) | z[1]) % 31 == 0 && !(z[1] & 0x20));
        int zr = uncompress(raw, &got, z, (uLong)zlen);
        CHECK_MSG(zr == Z_OK, "zlib inflate: %d", zr);
        ok = zr == Z_OK;
    }
    if (ok)
        CHECK_MSG(got == raw_len, "inflated %lu bytes, want %zu", (unsigned long)got, raw_len);
    // Each row's filter byte is one of PNG's five (0 none .. 4 Paeth); the filters are undone
    // here apart from libpng, into the RGB rows compared below.
    if (ok && got == raw_len) {
        int bad_filter = -1;
        size_t bpp = 3;
        for (int y = 0; y < h; y++) {
            unsigned char *row = raw + (size_t)y * line, *prev = y ? row - line : NULL;
            unsigned char type = row[0];
            if (type > 4 && bad_filter < 0)
                bad_filter = y;
            for (size_t x = 1; x < line; x++) {
                int a = x > bpp ? row[x - bpp] : 0, b = prev ? prev[x] : 0, c = prev && x > bpp ? prev[x - bpp] : 0;
                int pred = 0;
                if (type == 1)
                    pred = a;
                else if (type == 2)
                    pred = b;
                else if (type == 3)
                    pred = (a + b) / 2;
                else if (type == 4) {
                    int p = a + b - c, pa = abs(p - a), pb = abs(p - b), pc = abs(p - c);
                    pred = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
                }
                row[x] = (unsigned char)(row[x] + pred);
            }
            row[0] = 0;
        }
        CHECK_MSG(bad_filter < 0, "row %d has filter type %d", bad_filter, bad_filter < 0 ? 0 : raw[(size_t)bad_filter * line]);
    }
    if (ok && got == raw_len) {
        int bad = -1;
        for (int y = 0; y < h && bad < 0; y++) {
            if (raw[(size_t)y * line] != 0)
                bad = y;
            else if (memcmp(raw + (size_t)y * line + 1, rgb + (size_t)y * w * 3, (size_t)w * 3))
                bad = y;
        }
        CHECK_MSG(bad < 0, "PNG row %d differs", bad);
    }
    free(raw);
    free(z);
    free(f);
}

// Independent decoders: oiiotool reports the size, and converts back to a PPM we compare.
static void verify_png_oiiotool(const char *path, int w, int h, const uint8_t *rgb)
{
    if (!have_tool("oiiotool")) {
        fprintf(stderr, "note: oiiotool not found; skipping its PNG check\n");
        return;
    }
    char cmd[4096], out[8192];
    snprintf(cmd, sizeof cmd, "oiiotool --info -v '%s' 2>&1", path);
    int st = run_capture(cmd, out, sizeof out);
    CHECK_MSG(st == 0, "oiiotool --info failed (%d): %s", st, out);
    const char *colon = strstr(out, " : ");
    int rw = 0, rh = 0, rc = 0;
    CHECK_MSG(colon && sscanf(colon + 3, " %d x %d, %d channel", &rw, &rh, &rc) == 3,
              "cannot parse: %s", out);
    CHECK_MSG(rw == w && rh == h && rc == 3, "oiiotool sees %dx%d with %d channels", rw, rh, rc);
    CHECK_MSG(strstr(out, "uint8") && strstr(out, "png"), "oiiotool: %s", out);

    const char *ppm = pn_test_tmp("io_check.ppm");
    snprintf(cmd, sizeof cmd, "oiiotool '%s' -o '%s' 2>&1", path, ppm);
    st = run_capture(cmd, out, sizeof out);
    CHECK_MSG(st == 0, "oiiotool conversion failed (%d): %s", st, out);
    size_t n = 0;
    unsigned char *p = read_all(ppm, &n);
    int pw = 0, ph = 0, maxv = 0, off = 0;
    CHECK(p && n > 16 && sscanf((const char *)p, "P6 %d %d %d%n", &pw, &ph, &maxv, &off) == 3);
    if (p && pw == w && ph == h && maxv == 255 && (size_t)off + 1 + (size_t)w * h * 3 == n)
        CHECK_MSG(memcmp(p + off + 1, rgb, (size_t)w * h * 3) == 0, "oiiotool sees other pixels");
    else
        CHECK_MSG(0, "unexpected PPM from oiiotool (%dx%d max %d, %zu bytes)", pw, ph, maxv, n);
    free(p);
    remove(ppm);
}

typedef struct png_job {
    const char *path;
    int w, h;
    const uint8_t *rgb;
} png_job;

static pn_result run_png_job(void *arg)
{
    const png_job *j = arg;
    return pn_png_write_rgb8(j->path, j->w, j->h, j->rgb);
}

static void test_png(void)
{
    // Small, and big enough for several IDAT chunks (libpng's are 8 KiB).
    const int sizes[][2] = {{5, 3}, {1, 1}, {200, 150}, {301, 257}};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        int w = sizes[s][0], h = sizes[s][1];
        uint8_t *rgb = malloc((size_t)w * h * 3);
        for (int i = 0; i < w * h * 3; i++)
            rgb[i] = (uint8_t)(i * 7 + (i / (w * 3)) * 13);
        const char *path = pn_test_tmp("io_test.png");
        remove(path);
        pn_result r = pn_png_write_rgb8(path, w, h, rgb);
        CHECK_MSG(r == PN_OK, "pn_png_write_rgb8 %dx%d: %s", w, h, pn_result_str(r));
        if (r == PN_OK) {
            verify_png(path, w, h, rgb);
            if (s == 0 || s == 2)
                verify_png_oiiotool(path, w, h, rgb);
        }
        free(rgb);
        remove(path);
    }

    uint8_t px[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    const char *dir = pn_test_tmp("no_such_dir_png");
    const char *path = pn_test_tmp("no_such_dir_png/out.png");
    CHECK(!exists(dir));
    CHECK(pn_png_write_rgb8(path, 2, 2, px) != PN_OK);
    CHECK(!exists(path) && !exists(dir));

    const char *bad = pn_test_tmp("invalid.png");
    remove(bad);
    CHECK(pn_png_write_rgb8(bad, 0, 2, px) == PN_ERR_INVALID);
    CHECK(pn_png_write_rgb8(bad, 2, -2, px) == PN_ERR_INVALID);
    CHECK(pn_png_write_rgb8(bad, 2, 2, NULL) == PN_ERR_INVALID);
    CHECK(!exists(bad));

    // Compressed: a smooth picture (a preview is mostly that) takes a small part of its raw size.
    {
        int w = 320, h = 180;
        uint8_t *rgb = malloc((size_t)w * h * 3);
        for (int y = 0; rgb && y < h; y++)
            for (int x = 0; x < w; x++)
                for (int c = 0; c < 3; c++)
                    rgb[((size_t)y * w + x) * 3 + c] = (uint8_t)((x * (c + 1) + y * 2) / 3);
        const char *smooth = pn_test_tmp("io_smooth.png");
        CHECK(rgb && pn_png_write_rgb8(smooth, w, h, rgb) == PN_OK);
        size_t n = 0;
        unsigned char *f = read_all(smooth, &n);
        CHECK_MSG(f && n < (size_t)w * h * 3 / 10, "a %dx%d gradient took %zu bytes", w, h, n);
        if (rgb)
            verify_png(smooth, w, h, rgb);
        free(f);
        free(rgb);
        remove(smooth);
    }

    // A write that fails part way keeps the previous file and leaves no temporary: noise, which
    // deflate cannot shrink below the limit.
    const char *keep = pn_test_tmp("keep.png");
    static const char old[] = "previous preview\n";
    CHECK(write_all(keep, old, sizeof old - 1));
    int w = 300, h = 200;
    uint8_t *rgb = malloc((size_t)w * h * 3);
    for (uint32_t i = 0, x = 2463534242u; rgb && i < (uint32_t)(w * h * 3); i++) {
        x ^= x << 13, x ^= x >> 17, x ^= x << 5; // xorshift32
        rgb[i] = (uint8_t)(x >> 24);
    }
    png_job job = {keep, w, h, rgb};
    pn_result r = PN_OK;
    if (rgb && with_file_size_limit(100000, run_png_job, &job, &r)) {
        CHECK_MSG(r == PN_ERR_IO, "write past the file size limit returned %s", pn_result_str(r));
        size_t n = 0;
        unsigned char *got = read_all(keep, &n);
        CHECK(got && n == sizeof old - 1 && memcmp(got, old, n) == 0);
        free(got);
        char tmp[4096];
        CHECK(pn_file_tmp_path(keep, tmp, sizeof tmp) == PN_OK);
        CHECK_MSG(!exists(tmp), "%s left behind", tmp);
    }
    if (rgb) {
        CHECK(pn_png_write_rgb8(keep, w, h, rgb) == PN_OK);
        verify_png(keep, w, h, rgb);
    }
    free(rgb);
    remove(keep);
}

// ---- tone mapping

static int ref_srgb8(double v)
{
    if (!(v > 0.0))
        return 0;
    double t = isinf(v) ? 1.0 : v / (1.0 + v);
    double s = t <= 0.0031308 ? 12.92 * t : 1.055 * pow(t, 1.0 / 2.4) - 0.055;
    double q = floor(s * 255.0 + 0.5);
    return q < 0 ? 0 : q > 255 ? 255 : (int)q;
}

static void test_tonemap(void)
{
    const float in[] = {
        0.0f,  0.0f,     0.0f,     NAN,  // black, alpha ignored
        1e30f, FLT_MAX,  INFINITY, 0.0f, // huge: white
        0.5f,  2.0f,     0.001f,   1.0f, // mid values, and one on the linear segment
        NAN,   -1.0f,    -5.0f,    1.0f, // NaN and negative: black
        0.25f, 1.0f,     0.0005f,  -7.0f // with exposure 2, same as pixel 2
    };
    uint8_t out[5 * 3];
    memset(out, 0xCD, sizeof out);
    pn_tonemap_srgb8(in, 5, 1, 1.0f, out);
    CHECK(out[0] == 0 && out[1] == 0 && out[2] == 0);
    CHECK(out[3] == 255 && out[4] == 255 && out[5] == 255);
    for (int c = 0; c < 3; c++) {
        int want = ref_srgb8(in[8 + c]);
        CHECK_MSG(out[6 + c] == want, "tonemap(%g) = %d, want %d", in[8 + c], out[6 + c], want);
    }
    // The same three, worked by hand: 0.5 -> 1/3 -> 0.6125; 2 -> 2/3 -> 0.8360; 0.001 -> 0.0129.
    CHECK(out[6] == 156 && out[7] == 213 && out[8] == 3);
    CHECK(out[9] == 0 && out[10] == 0 && out[11] == 0);

    uint8_t out2[5 * 3];
    pn_tonemap_srgb8(in, 5, 1, 2.0f, out2);
    CHECK(memcmp(out2 + 12, out + 6, 3) == 0); // exposure scales before the curve
    CHECK(out2[0] == 0 && out2[3] == 255);

    // The curve is monotonic and matches the formula over a sweep of inputs.
    int prev = -1, mono = 1;
    for (int i = 0; i <= 4000; i++) {
        float v[4] = {(float)i / 400.0f, 0, 0, 0};
        uint8_t o[3];
        pn_tonemap_srgb8(v, 1, 1, 1.0f, o);
        mono &= o[0] >= prev;
        prev = o[0];
        CHECK(o[0] == ref_srgb8(v[0]));
    }
    CHECK(mono);
}

int main(void)
{
    const char *dir = pn_test_env("PN_TEST_TMP", "/tmp");
    mkdir(dir, 0777);
    test_exr();
    test_png();
    test_tonemap();
    check_no_tmp_files();
    return pn_test_result();
}
