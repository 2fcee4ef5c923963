// What the EXR writer and reader share (exr_core.h): OpenEXRCore's messages collected per call.
#include "io/exr_core.h"

#include <stdio.h>
#include <string.h>

// The library reports details through a callback rather than return values; collect what the
// current call of this thread reported so that the one line we log says what went wrong.
static _Thread_local char g_exr_msg[PN_EXR_MSG_SIZE];

char *pn_exr_msg_slot(void) { return g_exr_msg; }

static void exr_error_cb(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    if (!msg || !*msg)
        msg = exr_get_default_error_message(code);
    // A failure often reports its cause first and then its consequence: keep both.
    size_t len = strlen(g_exr_msg), start = len;
    if (len == 0)
        snprintf(g_exr_msg, sizeof g_exr_msg, "%s", msg);
    else if (len + 2 < sizeof g_exr_msg)
        snprintf(g_exr_msg + len, sizeof g_exr_msg - len, "; %s", msg);
    // Messages quote names read from the file: keep the log line one line of plain text.
    for (char *c = g_exr_msg + start; *c; c++)
        if ((unsigned char)*c < 0x20 || (unsigned char)*c >= 0x7F)
            *c = '?';
}

const char *pn_exr_printable(const char *s, size_t n, char *buf, size_t size)
{
    size_t k = 0, i = 0;
    for (; s && i < n && s[i] && k + 4 < size; i++) {
        unsigned char c = (unsigned char)s[i];
        buf[k++] = c < 0x20 || c >= 0x7F ? '?' : (char)c;
    }
    if (s && i < n && s[i]) { // cut short (size is at least 5)
        memcpy(buf + k, "...", 3);
        k += 3;
    }
    buf[k] = '\0';
    return buf;
}

const char *pn_exr_msg(exr_result_t rv)
{
    return g_exr_msg[0] ? g_exr_msg : exr_get_default_error_message(rv);
}

exr_context_initializer_t pn_exr_init(void)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_error_cb;
    return init;
}
