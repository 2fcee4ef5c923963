// Command-line parsing helpers the subcommands share: flags, values, numbers in range, choices.
#include "apps/args.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"

bool pn_args_value(pn_args *a, const char *name, const char **value, bool *error)
{
    const char *arg = a->argv[a->i];
    size_t n = strlen(name);
    if (strncmp(arg, name, n) != 0)
        return false;
    if (arg[n] == '=') {
        *value = arg + n + 1;
        a->i++;
        return true;
    }
    if (arg[n] != '\0')
        return false;
    if (a->i + 1 >= a->argc) {
        pn_error("option %s needs a value", name);
        *error = true;
        a->i++;
        return true;
    }
    *value = a->argv[a->i + 1];
    a->i += 2;
    return true;
}

bool pn_args_flag(pn_args *a, const char *name)
{
    if (strcmp(a->argv[a->i], name) != 0)
        return false;
    a->i++;
    return true;
}

static bool parse_float(const char *s, char **end, float *out)
{
    errno = 0;
    double v = strtod(s, end);
    if (*end == s || errno == ERANGE || !isfinite(v) || fabs(v) > 3.0e38)
        return false;
    *out = (float)v;
    return true;
}

bool pn_parse_floats(const char *opt, const char *s, float *out, int n)
{
    const char *p = s;
    for (int k = 0; k < n; k++) {
        char *end;
        if (!parse_float(p, &end, &out[k]) || (k + 1 < n ? *end != ',' : *end != '\0')) {
            pn_error("%s: expected %d comma-separated finite numbers, got '%s'", opt, n, s);
            return false;
        }
        p = end + 1;
    }
    return true;
}

bool pn_parse_rgb(const char *opt, const char *s, float out[3])
{
    if (!strchr(s, ',')) {
        if (!pn_parse_floats(opt, s, out, 1))
            return false;
        out[1] = out[2] = out[0];
        return true;
    }
    return pn_parse_floats(opt, s, out, 3);
}

bool pn_parse_float_range(const char *opt, const char *s, float lo, float hi, float *out)
{
    char *end;
    if (!parse_float(s, &end, out) || *end != '\0' || *out < lo || *out > hi) {
        pn_error("%s: expected a number in [%g, %g], got '%s'", opt, lo, hi, s);
        return false;
    }
    return true;
}

bool pn_parse_int_range(const char *opt, const char *s, long long lo, long long hi, long long *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (end == s || *end != '\0' || errno == ERANGE || v < lo || v > hi) {
        pn_error("%s: expected an integer in [%lld, %lld], got '%s'", opt, lo, hi, s);
        return false;
    }
    *out = v;
    return true;
}

bool pn_parse_size(const char *opt, const char *s, uint32_t max, uint32_t *w, uint32_t *h)
{
    char *end;
    errno = 0;
    long long a = strtoll(s, &end, 10), b = 0;
    bool ok = end != s && (*end == 'x' || *end == 'X') && errno == 0;
    if (ok) {
        const char *t = end + 1;
        b = strtoll(t, &end, 10);
        ok = end != t && *end == '\0' && errno == 0;
    }
    if (!ok || a < 1 || b < 1 || a > max || b > max) {
        pn_error("%s: expected WIDTHxHEIGHT with each in [1, %u], got '%s'", opt, max, s);
        return false;
    }
    *w = (uint32_t)a;
    *h = (uint32_t)b;
    return true;
}

bool pn_parse_tree(const char *opt, const char *s, int *n, int *d)
{
    char *end;
    errno = 0;
    long a = strtol(s, &end, 10), b = 0;
    bool ok = end != s && *end == ',' && errno == 0;
    if (ok) {
        const char *t = end + 1;
        b = strtol(t, &end, 10);
        ok = end != t && *end == '\0' && errno == 0;
    }
    if (!ok || a < 2 || a > 16 || b < 1 || b > 6) {
        pn_error("%s: expected N,d with branching factor N in [2, 16] and depth d in [1, 6], got '%s'", opt, s);
        return false;
    }
    *n = (int)a;
    *d = (int)b;
    return true;
}

int pn_parse_choice(const char *opt, const char *s, const char *const *choices)
{
    for (int i = 0; choices[i]; i++)
        if (strcmp(s, choices[i]) == 0)
            return i;
    char list[256] = "";
    for (int i = 0; choices[i]; i++) {
        strncat(list, i ? "|" : "", sizeof list - strlen(list) - 1);
        strncat(list, choices[i], sizeof list - strlen(list) - 1);
    }
    pn_error("%s: expected one of %s, got '%s'", opt, list, s);
    return -1;
}

bool pn_parse_bytes(const char *opt, const char *s, uint64_t *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    double unit = 1048576.0;
    if (end != s && (*end == 'K' || *end == 'k'))
        unit = 1024.0, end++;
    else if (end != s && (*end == 'M' || *end == 'm'))
        unit = 1048576.0, end++;
    else if (end != s && (*end == 'G' || *end == 'g'))
        unit = 1073741824.0, end++;
    if (end == s || *end != '\0' || errno == ERANGE || !isfinite(v) || v * unit < 1 || v * unit > 1e18) {
        pn_error("%s: expected a positive size in MiB or with a K/M/G suffix (e.g. 512M, 2G), got '%s'", opt, s);
        return false;
    }
    *out = (uint64_t)(v * unit);
    return true;
}

bool pn_parse_shard(const char *opt, const char *s, int *k, int *n)
{
    long long kk, nn;
    char buf[64], what[64];
    const char *slash = strchr(s, '/');
    if (!slash || (size_t)(slash - s) >= sizeof buf) {
        pn_error("%s: expected K/N (shard K of N, 1 <= K <= N), got '%s'", opt, s);
        return false;
    }
    snprintf(buf, sizeof buf, "%.*s", (int)(slash - s), s);
    snprintf(what, sizeof what, "%s K", opt);
    bool ok = pn_parse_int_range(what, buf, 0, 1000000, &kk);
    snprintf(what, sizeof what, "%s N", opt);
    if (!ok || !pn_parse_int_range(what, slash + 1, 0, 1000000, &nn))
        return false;
    if (!(nn >= 1 && kk >= 1 && kk <= nn)) {
        pn_error("%s %s: shard K of N needs 1 <= K <= N", opt, s);
        return false;
    }
    *k = (int)kk, *n = (int)nn;
    return true;
}
