// The command lines of render, build and diff, parsed apart from running the command: the
// libFuzzer target tests/fuzz/fuzz_cli.c calls these parsers directly, without a GPU or files.
// Each parser fills *o (defaults first), logs a message naming the option and the bad value on
// failure, and returns PN_EXIT_OK, PN_EXIT_USAGE, or -1 when it printed the help (--help, -h).
// Strings in *o point into argv.
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "apps/render_opts.h"

// render --frames A:B[:STEP] --fps F [--shard K/N]: a sequence of frames A, A + STEP, ... B at
// time frame / fps, the share of shard K of N (every N-th from the K-th, counted from 1).
typedef struct pn_sequence {
    bool on;
    long long first, last, step;
    double fps;
    int shard_k, shard_n;
    // --temporal: each frame adds its samples to the history of the frames before it
    // (pn_renderer_set_history) at most `history` frames' worth (--history).
    bool temporal;
    long long history;
} pn_sequence;

// penumbra render: the options render shares with demo, plus its scene and outputs.
typedef struct pn_render_cmd_opts {
    pn_render_opts r;
    const char *scene, *output, *preview, *ray_dump;
    const char *gbuffer; // --gbuffer FILE.exr: P and N from it instead of the raster pass
    bool aovs, json;
    bool view_cull;    // the tree models only what the picture needs (off: --no-view-cull)
    bool auto_quality; // --quality auto
    double max_error;  // --max-error: its budget of MAE against exact
    pn_sequence seq;
} pn_render_cmd_opts;

int pn_render_parse(int argc, char **argv, pn_render_cmd_opts *o);

// penumbra build
typedef struct pn_build_opts {
    const char *scene;
    int tree_n, tree_d;
    uint64_t max_bytes; // 0: half the device's heap (1 GiB with --no-upload)
    bool json, ground, upload, cull;
    int trees;                   // PN_BUILD_TREES_*
    int object_n, object_d;      // the per-object trees (default: --tree's)
    long long updates;           // moves of object 0 timed with --trees object|both
} pn_build_opts;

enum { PN_BUILD_TREES_SCENE, PN_BUILD_TREES_OBJECT, PN_BUILD_TREES_BOTH };

int pn_build_parse(int argc, char **argv, pn_build_opts *o);

// penumbra diff
typedef struct pn_diff_opts {
    const char *files[2], *channel, *output;
    bool json;
    bool fail_set[6];          // --fail thresholds given, per metric (mae, rmse, p99, max, over005, over02)
    double fail_threshold[6];
} pn_diff_opts;

int pn_diff_parse(int argc, char **argv, pn_diff_opts *o);
