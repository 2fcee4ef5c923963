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

#define pn_debug(...) pn_log(PN_LOG_DEBUG, __VA_ARGS__)
#define pn_info(...) pn_log(PN_LOG_INFO, __VA_ARGS__)
#define pn_warn(...) pn_log(PN_LOG_WARN, __VA_ARGS__)
#define pn_error(...) pn_log(PN_LOG_ERROR, __VA_ARGS__)
