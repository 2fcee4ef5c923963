// Result codes and their names.
#include "core/error.h"

const char *pn_result_str(pn_result r)
{
    switch (r) {
    case PN_OK: return "ok";
    case PN_ERR_IO: return "i/o error";
    case PN_ERR_FORMAT: return "malformed input";
    case PN_ERR_INVALID: return "invalid argument";
    case PN_ERR_MEMORY: return "out of memory";
    case PN_ERR_VULKAN: return "vulkan error";
    case PN_ERR_UNSUPPORTED: return "unsupported";
    }
    return "unknown error";
}
