// libFuzzer target: the EXR reader (io/exr.c, pn_exr_read over OpenEXRCore) on arbitrary bytes, as
// penumbra diff and bench --gbuffer use it. The input is written to input.exr in a private,
// otherwise empty folder, then read three ways:
//   1. pn_exr_read itself;
//   2. pn_cmd_diff(input.exr, input.exr): the command as typed, default channel shadow.V;
//   3. pn_bench_load_gbuffer (apps/bench/bench_opts.c): what bench --shader shadow --gbuffer loads.
//
// Beyond "no crash, no leak, no UB", what each accepts must be something the later stages can
// trust; a violated invariant aborts, which libFuzzer reports as a crash:
//   - pn_exr_read: on failure *out is zeroed (nothing to free). On success width and height are
//     >= 1, 1..INT16_MAX channels, width * height * channels within the reader's 2^30 floats; every
//     channel has a non-empty, unique name and a plane of width * height floats (all of it read
//     here, so ASan sees any short one), and pn_exr_image_channel finds it by that name.
//     Values may be anything, NaN included: diff counts a non-finite value as an infinite error.
//   - diff exits 0 exactly when the file reads and has shadow.V (a file equals itself, and no
//     --fail is given), 2 otherwise; never 1.
//   - bench's G-buffer: loaded exactly when the file reads and has P.X/Y/Z, A, N.X/Y/Z, all finite
//     (the shadow rays start at P and leave along N); then gb_p and gb_n hold those values as
//     RGBA planes (N.w = 0) and the bench's one size is the file's.
// PN_FUZZ_VERBOSE=1 keeps the messages (silenced otherwise: millions of them).
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "apps/bench/bench.h"
#include "apps/commands.h"
#include "core/log.h"
#include "io/exr.h"
#include "fuzz_util.h"

static char g_dir[256], g_path[512];

static void remove_files(void)
{
    remove(g_path);
    rmdir(g_dir);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    const char *verbose = getenv("PN_FUZZ_VERBOSE");
    bool quiet = !(verbose && *verbose == '1');
    pn_log_set_level(quiet ? PN_LOG_QUIET : PN_LOG_DEBUG);
    // diff prints its table to stdout: keep the fuzzer's output readable.
    if (quiet && !freopen("/dev/null", "w", stdout))
        abort();
    pn_fuzz_make_dir(g_dir, sizeof g_dir, "fuzz_exr");
    snprintf(g_path, sizeof g_path, "%s/input.exr", g_dir);
    atexit(remove_files);
    return 0;
}


static const char *const GBUFFER[7] = {"P.X", "P.Y", "P.Z", "A", "N.X", "N.Y", "N.Z"};

// What pn_exr_read promises on success (io/exr.h).
static void check_image(const pn_exr_image *img)
{
    REQUIRE(img->width >= 1 && img->height >= 1);
    REQUIRE(img->channel_count >= 1 && img->channel_count <= INT16_MAX);
    size_t px = (size_t)img->width * (size_t)img->height;
    REQUIRE((uint64_t)px * (uint64_t)img->channel_count <= (uint64_t)1 << 30);
    REQUIRE(img->names && img->data);
    for (int i = 0; i < img->channel_count; i++) {
        REQUIRE(img->names[i] && img->names[i][0] && img->data[i]);
        for (int j = 0; j < i; j++)
            REQUIRE(strcmp(img->names[i], img->names[j]) != 0);
        REQUIRE(pn_exr_image_channel(img, img->names[i]) == img->data[i]);
        // Every value is read: a plane shorter than width * height is an ASan report.
        unsigned bits = 0;
        for (size_t p = 0; p < px; p++) {
            uint32_t u;
            memcpy(&u, &img->data[i][p], sizeof u);
            bits ^= u;
        }
        volatile unsigned sink = bits;
        (void)sink;
    }
}

// Whether the channels bench --gbuffer reads are all there and finite.
static bool gbuffer_usable(const pn_exr_image *img)
{
    size_t px = (size_t)img->width * (size_t)img->height;
    for (int c = 0; c < 7; c++) {
        const float *plane = pn_exr_image_channel(img, GBUFFER[c]);
        if (!plane)
            return false;
        for (size_t p = 0; p < px; p++)
            if (!isfinite(plane[p]))
                return false;
    }
    return true;
}

static void check_gbuffer(const pn_exr_image *img, bool read_ok)
{
    bench_opts *o = calloc(1, sizeof *o);
    REQUIRE(o);
    o->gbuffer = g_path;
    bool loaded = pn_bench_load_gbuffer(o) == PN_OK;
    REQUIRE(loaded == (read_ok && gbuffer_usable(img)));
    if (loaded) {
        REQUIRE(o->gb_p && o->gb_n);
        REQUIRE(o->gb_width == (uint32_t)img->width && o->gb_height == (uint32_t)img->height);
        REQUIRE(o->size_count == 1 && o->sizes[0][0] == o->gb_width && o->sizes[0][1] == o->gb_height);
        size_t px = (size_t)img->width * (size_t)img->height;
        const float *ch[7];
        for (int c = 0; c < 7; c++)
            ch[c] = pn_exr_image_channel(img, GBUFFER[c]);
        for (size_t p = 0; p < px; p++)
            for (int k = 0; k < 4; k++) {
                REQUIRE(o->gb_p[4 * p + k] == ch[k][p]);
                REQUIRE(o->gb_n[4 * p + k] == (k < 3 ? ch[4 + k][p] : 0.0f));
            }
    } else {
        REQUIRE(!o->gb_p && !o->gb_n); // nothing left allocated for cmd_bench to free
    }
    free(o->gb_p);
    free(o->gb_n);
    free(o);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    FILE *f = fopen(g_path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror("fuzz_exr: cannot write the input file");
        exit(1);
    }

    pn_exr_image img;
    memset(&img, 0xA5, sizeof img); // the reader must zero it whatever it held
    bool read_ok = pn_exr_read(g_path, &img) == PN_OK;
    if (read_ok) {
        check_image(&img);
    } else {
        static const pn_exr_image zero;
        REQUIRE(memcmp(&img, &zero, sizeof img) == 0);
    }

    char *argv[] = {g_path, g_path, NULL};
    int rc = pn_cmd_diff(2, argv);
    REQUIRE(rc == (read_ok && pn_exr_image_channel(&img, "shadow.V") ? 0 : 2));

    check_gbuffer(&img, read_ok);
    pn_exr_image_free(&img);
    return 0;
}
