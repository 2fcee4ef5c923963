// What engine/io/exr_write.c and exr_read.c share: OpenEXRCore's error messages collected per
// call (the library reports details through a callback, not return values), the context
// initializer that routes them, and names from a file made safe to log. Internal to engine/io.
#pragma once
#include <openexr.h>
#include <stddef.h>

enum { PN_EXR_MSG_SIZE = 512 };

// This thread's message slot: what the library reported during the current call.
char *pn_exr_msg_slot(void);

// Evaluates a library call with the message slot cleared, so a failure's message is its own.
#define EXR_CALL(expr) (pn_exr_msg_slot()[0] = '\0', (expr))

// The current call's message, or the library's default one for rv.
const char *pn_exr_msg(exr_result_t rv);

// A context initializer whose error handler fills the message slot.
exr_context_initializer_t pn_exr_init(void);

// A file's string made safe to log: control and non-ASCII bytes become '?', long ones are cut
// (size at least 5).
const char *pn_exr_printable(const char *s, size_t n, char *buf, size_t size);
