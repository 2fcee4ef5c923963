// Command-line parsing helpers shared by the subcommands. Each parse function logs a message
// naming the option and the bad value and returns false.
#pragma once
#include <stdbool.h>
#include <stdint.h>

// Exit codes of the penumbra command.
enum {
    PN_EXIT_OK = 0,
    PN_EXIT_FAILURE = 1,    // input could not be read, rendering or writing failed
    PN_EXIT_USAGE = 2,      // invalid command line
    PN_EXIT_VALIDATION = 3, // the Vulkan validation layer reported warnings or errors
};

typedef struct pn_args {
    int argc;
    char **argv;
    int i; // next argument
} pn_args;

// If argv[i] is `name` (as "--name VALUE" or "--name=VALUE"), consumes it, stores the value and
// returns true. A missing value is logged and sets *error.
bool pn_args_value(pn_args *a, const char *name, const char **value, bool *error);

// If argv[i] is exactly `name` (a flag without a value), consumes it and returns true.
bool pn_args_flag(pn_args *a, const char *name);

// Parses exactly `n` comma-separated finite floats ("1,2.5,-3").
bool pn_parse_floats(const char *opt, const char *s, float *out, int n);
// Parses 1 or 3 comma-separated finite floats; one value is repeated to three.
bool pn_parse_rgb(const char *opt, const char *s, float out[3]);
// Parses a finite float in [lo, hi].
bool pn_parse_float_range(const char *opt, const char *s, float lo, float hi, float *out);
// Parses a decimal integer in [lo, hi].
bool pn_parse_int_range(const char *opt, const char *s, long long lo, long long hi, long long *out);
// Parses "WxH" with 1 <= W, H <= max.
bool pn_parse_size(const char *opt, const char *s, uint32_t max, uint32_t *w, uint32_t *h);
// Parses "N,d" for the N-tree: 2 <= N <= 16, 1 <= d <= 6.
bool pn_parse_tree(const char *opt, const char *s, int *n, int *d);
// Returns the index of `s` in the NULL-terminated `choices`, or logs the choices and returns -1.
int pn_parse_choice(const char *opt, const char *s, const char *const *choices);
// Parses "K/N", shard K of N with 1 <= K <= N <= 1e6 (render --shard, bench --shard).
bool pn_parse_shard(const char *opt, const char *s, int *k, int *n);
// Parses a memory size: a number of MiB, or a number with a K, M or G suffix (binary units).
bool pn_parse_bytes(const char *opt, const char *s, uint64_t *out);
