// The logger, the one piece of global state.
#include "core/log.h"

#include <stdio.h>

static pn_log_level g_level = PN_LOG_INFO;
static _Thread_local pn_log_capture *t_capture; // per thread: not shared state between threads

void pn_log_set_capture(pn_log_capture *capture) { t_capture = capture; }

void pn_log_set_level(pn_log_level level) { g_level = level; }
pn_log_level pn_log_get_level(void) { return g_level; }

void pn_log(pn_log_level level, const char *fmt, ...)
{
    pn_log_capture *cap = t_capture;
    if (cap && level >= PN_LOG_ERROR && cap->errors++ == 0 && cap->buf && cap->size) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(cap->buf, cap->size, fmt, ap);
        va_end(ap);
    }
    if (level < (cap ? cap->level : g_level))
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
