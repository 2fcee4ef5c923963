// Logging: the one piece of global state in penumbra. Library code never prints any other way.
#pragma once
#include <stdarg.h>

typedef enum pn_log_level {
    PN_LOG_DEBUG = 0,
    PN_LOG_INFO = 1,
    PN_LOG_WARN = 2,
    PN_LOG_ERROR = 3,
    PN_LOG_QUIET = 4,
} pn_log_level;

// Messages below `level` are dropped. Default: PN_LOG_INFO.
void pn_log_set_level(pn_log_level level);
pn_log_level pn_log_get_level(void);

// Writes one line to stderr ("penumbra: warning: ..."); a trailing newline is added.
void pn_log(pn_log_level level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

// A library call's messages (engine/api): while a capture is set on the calling thread, the first
// error logged is also kept in `buf` (the API's per-context last error), and messages below
// `level` are not written to stderr on that thread, whatever the global level. NULL ends it.
// Thread-local, so two contexts used from two threads keep their own.
typedef struct pn_log_capture {
    char *buf;
    unsigned long size;
    pn_log_level level;
    int errors; // errors logged while set
} pn_log_capture;
void pn_log_set_capture(pn_log_capture *capture);

#define pn_debug(...) pn_log(PN_LOG_DEBUG, __VA_ARGS__)
#define pn_info(...) pn_log(PN_LOG_INFO, __VA_ARGS__)
#define pn_warn(...) pn_log(PN_LOG_WARN, __VA_ARGS__)
#define pn_error(...) pn_log(PN_LOG_ERROR, __VA_ARGS__)
