// Minimal test helpers shared by the C tests: checks that count failures, temp paths, running
// the penumbra binary. Header-only so each test stays one file.
#pragma once
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

static int pn_test_failures = 0;

#define CHECK(cond)                                                                                \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);               \
            pn_test_failures++;                                                                    \
        }                                                                                          \
    } while (0)

#define CHECK_MSG(cond, ...)                                                                       \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            fprintf(stderr, "%s:%d: CHECK failed: %s: ", __FILE__, __LINE__, #cond);                \
            fprintf(stderr, __VA_ARGS__);                                                          \
            fputc('\n', stderr);                                                                   \
            pn_test_failures++;                                                                    \
        }                                                                                          \
    } while (0)

#define TEST_SKIP(...)                                                                             \
    do {                                                                                           \
        fprintf(stderr, "SKIP: ");                                                                 \
        fprintf(stderr, __VA_ARGS__);                                                              \
        fputc('\n', stderr);                                                                       \
        exit(77);                                                                                  \
    } while (0)

static inline int pn_test_result(void)
{
    if (pn_test_failures)
        fprintf(stderr, "%d check(s) failed\n", pn_test_failures);
    else
        fprintf(stderr, "all checks passed\n");
    return pn_test_failures ? 1 : 0;
}

static inline const char *pn_test_env(const char *name, const char *fallback)
{
    const char *v = getenv(name);
    return v && *v ? v : fallback;
}

// A path inside the test's scratch folder (PN_TEST_TMP, else /tmp).
static inline const char *pn_test_tmp(const char *file)
{
    static char buf[8][1024];
    static int slot = 0;
    char *b = buf[slot++ & 7];
    snprintf(b, sizeof buf[0], "%s/%s", pn_test_env("PN_TEST_TMP", "/tmp"), file);
    return b;
}

// A mesh from the shared assets ($PN_ASSETS, else ../shared/assets) when it is there, else
// builtin:default: the tests run on a machine without the assets too.
static inline void pn_test_scene(char *out, size_t n, const char *asset)
{
    snprintf(out, n, "%s/%s", pn_test_env("PN_ASSETS", "../shared/assets"), asset);
    FILE *f = fopen(out, "rb");
    if (f)
        fclose(f);
    else
        snprintf(out, n, "builtin:default");
}

// Base64 of n bytes into o (4 * ceil(n / 3) + 1 chars): glTF data: URIs written by the tests.
static inline void pn_test_base64(const unsigned char *d, size_t n, char *o)
{
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)d[i] << 16 | (i + 1 < n ? (unsigned)d[i + 1] << 8 : 0) | (i + 2 < n ? d[i + 2] : 0);
        *o++ = t[v >> 18 & 63], *o++ = t[v >> 12 & 63];
        *o++ = i + 1 < n ? t[v >> 6 & 63] : '=';
        *o++ = i + 2 < n ? t[v & 63] : '=';
    }
    *o = 0;
}

// Runs "$PN_BIN <args>" through the shell; returns the exit status (or -1).
static inline int pn_test_run(const char *args)
{
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "\"%s\" %s", pn_test_env("PN_BIN", "penumbra"), args);
    fprintf(stderr, "+ penumbra %s\n", args);
    int st = system(cmd);
    if (st == -1 || !WIFEXITED(st))
        return -1;
    return WEXITSTATUS(st);
}
