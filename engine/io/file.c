// Outputs written to a temporary name in the target's folder, then renamed into place or discarded.
#include "io/file.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "core/log.h"

pn_result pn_file_tmp_path(const char *path, char *tmp, size_t n)
{
    const char *slash = strrchr(path, '/');
    int dir_len = slash ? (int)(slash - path + 1) : 0;
    const char *base = slash ? slash + 1 : path;
    int w = snprintf(tmp, n, "%.*s.%s.tmp-%ld", dir_len, path, base, (long)getpid());
    if (w < 0 || (size_t)w >= n) {
        pn_error("%s: output path too long", path);
        return PN_ERR_INVALID;
    }
    return PN_OK;
}

pn_result pn_file_commit(const char *tmp, const char *path)
{
    if (rename(tmp, path) != 0) {
        pn_error("%s: cannot write: %s", path, strerror(errno));
        remove(tmp);
        return PN_ERR_IO;
    }
    return PN_OK;
}

void pn_file_discard(const char *tmp) { remove(tmp); }
