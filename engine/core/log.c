// The logger, the one piece of global state.
#include "core/log.h"

#include <stdio.h>

static pn_log_level g_level = PN_LOG_INFO;

void pn_log_set_level(pn_log_level level) { g_level = level; }
pn_log_level pn_log_get_level(void) { return g_level; }

void pn_log(pn_log_level level, const char *fmt, ...)
{
    if (level < g_level)
        return;
    static const char *const prefix[] = {"debug: ", "", "warning: ", "error: "};
    // One line per message, whole: the demo's tree builds log from a worker thread while the frame
    // loop logs too, and stdio locks each call, not the line these calls make together.
    flockfile(stderr);
    fprintf(stderr, "penumbra: %s", prefix[level > PN_LOG_ERROR ? PN_LOG_ERROR : level]);
    va_list ap;
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    funlockfile(stderr);
}
