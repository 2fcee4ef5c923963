// Outputs are written to a temporary name in the target's folder and renamed into place, so a
// failed run never leaves a partial file and never clobbers the previous output.
#pragma once
#include <stddef.h>

#include "core/error.h"

// Fills `tmp` with "<dir>/.<base>.tmp-<pid>"; same folder so that rename(2) is atomic.
// PN_ERR_INVALID if it does not fit in `n` bytes.
pn_result pn_file_tmp_path(const char *path, char *tmp, size_t n);

// Renames tmp to path; on failure removes tmp and logs the problem naming `path`.
pn_result pn_file_commit(const char *tmp, const char *path);

// Removes tmp (after a failed write); never fails.
void pn_file_discard(const char *tmp);
