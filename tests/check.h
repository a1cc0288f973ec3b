/* Minimal test harness: each check names its expectation and tolerance; failures are counted
 * and the test exits 1 if any failed, 77 if everything it needed was absent (ctest: skipped). */
#ifndef ENVL_CHECK_H
#define ENVL_CHECK_H

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int check_failures_;
static int check_count_;

#define CHECK(cond)                                                                            \
    do {                                                                                       \
        check_count_++;                                                                        \
        if (!(cond)) {                                                                         \
            check_failures_++;                                                                 \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);           \
        }                                                                                      \
    } while (0)

/* |a - b| <= tol, and neither is NaN. */
#define CHECK_NEAR(a, b, tol)                                                                  \
    do {                                                                                       \
        double a_ = (double)(a), b_ = (double)(b), t_ = (double)(tol);                         \
        check_count_++;                                                                        \
        if (!(fabs(a_ - b_) <= t_)) {                                                          \
            check_failures_++;                                                                 \
            fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %.9g, %s = %.9g, |diff| %.3g > %.3g\n", \
                    __FILE__, __LINE__, #a, a_, #b, b_, fabs(a_ - b_), t_);                    \
        }                                                                                      \
    } while (0)

/* |a - b| <= rel * |b| */
#define CHECK_REL(a, b, rel)                                                                   \
    CHECK_NEAR(a, b, (rel) * fabs((double)(b)))

/* An envl_result call must return `code`. */
#define CHECK_RC(expr, code)                                                                   \
    do {                                                                                       \
        envl_result rc_ = (expr);                                                              \
        check_count_++;                                                                        \
        if (rc_ != (code)) {                                                                   \
            check_failures_++;                                                                 \
            fprintf(stderr, "%s:%d: %s returned %s, expected %s (%s)\n", __FILE__, __LINE__,   \
                    #expr, envl_result_name(rc_), envl_result_name(code), envl_last_error());  \
        }                                                                                      \
    } while (0)

#define CHECK_OK(expr) CHECK_RC(expr, ENVL_OK)

/* Path of a file under ../shared/data, or NULL (with a SKIP line) when absent. */
static inline const char *shared_data(const char *rel)
{
    static char buf[8][4096];
    static int slot;
    char *p = buf[slot++ % 8];
    snprintf(p, 4096, "%s/%s", ENVL_SHARED_DATA, rel);
    struct stat st;
    if (stat(p, &st) != 0) {
        printf("SKIP: %s absent (../shared/data not present?)\n", p);
        return NULL;
    }
    return p;
}

/* A scratch path for this test's files. */
static inline const char *tmp_path(const char *name)
{
    static char buf[8][4096];
    static int slot;
    char *p = buf[slot++ % 8];
    mkdir(ENVL_TEST_TMP, 0755);
    snprintf(p, 4096, "%s/%s", ENVL_TEST_TMP, name);
    return p;
}

/* Runs a shell command (printf-style); 0 when it exited 0, else says which failed. */
static inline int run_command(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static inline int run_command(const char *fmt, ...)
{
    char cmd[8192];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(cmd, sizeof cmd, fmt, ap);
    va_end(ap);
    int st = system(cmd);
    if (st != 0)
        fprintf(stderr, "command failed (%d): %s\n", st, cmd);
    return st;
}

static inline int check_report(const char *name)
{
    printf("%s: %d checks, %d failed\n", name, check_count_, check_failures_);
    return check_failures_ ? 1 : 0;
}

#endif
