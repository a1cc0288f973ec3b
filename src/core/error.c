/* Result codes, their names, and the thread's last error message. */
#include "internal.h"
#include "escape.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char last_error[2048];

#define ENVL_RESULT_NAME_(name, value, text) case value: return #name;
#define ENVL_RESULT_TEXT_(name, value, text) case value: return text;

const char *envl_result_name(envl_result code)
{
    switch (code) { ENVL_RESULT_TABLE(ENVL_RESULT_NAME_) }
    return "ENVL_UNKNOWN";
}

const char *envl_result_text(envl_result code)
{
    switch (code) { ENVL_RESULT_TABLE(ENVL_RESULT_TEXT_) }
    return "unknown result code";
}

const char *envl_last_error(void) { return last_error; }

envl_result envl__fail(envl_result code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(last_error, sizeof last_error, fmt, ap);
    va_end(ap);
    escape_controls(last_error, sizeof last_error);
    return code;
}

envl_result envl__fail_prefix(envl_result code, const char *prefix)
{
    char old[sizeof last_error];
    memcpy(old, last_error, sizeof old);
    size_t n = strlen(prefix);
    if (n > sizeof last_error / 2)
        n = sizeof last_error / 2;
    memcpy(last_error, prefix, n);
    memcpy(last_error + n, ": ", 2);
    size_t room = sizeof last_error - n - 3;
    size_t m = strnlen(old, room);
    memcpy(last_error + n + 2, old, m);
    last_error[n + 2 + m] = '\0';
    return code;
}

envl_result envl__fail_as(envl_result code, const char *name, const char *tmp)
{
    size_t t = strlen(tmp);
    if (strncmp(last_error, tmp, t) || strncmp(last_error + t, ": ", 2))
        return envl__fail_prefix(code, name);
    memmove(last_error, last_error + t + 2, strlen(last_error + t + 2) + 1);
    return envl__fail_prefix(code, name);
}

int32_t envl_abi_version(void) { return ENVL_ABI_VERSION; }

const char *envl_version_string(void) { return ENVL_VERSION_STRING; }
