// Result codes. User errors (bad files, bad arguments) are returned, logged once where they are
// found with the file and the problem; programmer errors are asserts.
#pragma once

typedef enum pn_result {
    PN_OK = 0,
    PN_ERR_IO,          // a file could not be read or written
    PN_ERR_FORMAT,      // a file's content is malformed or unsupported
    PN_ERR_INVALID,     // an argument or parameter is out of range
    PN_ERR_MEMORY,      // an allocation failed or a size limit would be exceeded
    PN_ERR_VULKAN,      // a Vulkan call failed or no suitable device exists
    PN_ERR_UNSUPPORTED, // valid, but not implemented by this build
} pn_result;

const char *pn_result_str(pn_result r);
