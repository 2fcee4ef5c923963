// What the libFuzzer targets share: an invariant check that aborts (a finding, with the target's
// file and line), and a private temporary folder for the files the inputs are written to (the
// readers under test take paths, as the commands do).
#pragma once
#include <stdio.h>
#include <stdlib.h>

#define REQUIRE(cond)                                                                              \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            fprintf(stderr, "%s:%d: invariant violated: %s\n", __FILE__, __LINE__, #cond);         \
            abort();                                                                               \
        }                                                                                          \
    } while (0)

// Makes $TMPDIR/pn_<target>.XXXXXX (or under /tmp) into dir; exits if it cannot.
static inline void pn_fuzz_make_dir(char *dir, size_t size, const char *target)
{
    const char *tmp = getenv("TMPDIR");
    snprintf(dir, size, "%s/pn_%s.XXXXXX", tmp && *tmp ? tmp : "/tmp", target);
    if (!mkdtemp(dir)) {
        perror(target);
        exit(1);
    }
}
