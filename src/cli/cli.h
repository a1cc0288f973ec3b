/* The `envlight` command line: shared option handling for the subcommands. */
#ifndef ENVL_CLI_H
#define ENVL_CLI_H

#include "envlight.h"

#include <stdio.h>

/* Exit statuses (docs/design.md): 0 success, 1 bad input or failure, 2 bad usage. */
#define CLI_OK 0
#define CLI_FAIL 1
#define CLI_USAGE 2


/* Options every subcommand that reads an environment accepts. */
typedef struct cli_common {
    envl_load_options load;
    envl_sky_options sky;
    int quiet;
} cli_common;

/* Prints "envlight: " + message to stderr. */
void cli_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* Prints a usage error and a pointer to --help; returns CLI_USAGE. */
int cli_usage(const char *command, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Reports the library's last error; returns CLI_FAIL. */
int cli_fail(void);

/* If argv[*i] is `name` ("--x VALUE" or "--x=VALUE"), sets *value, advances *i and returns 1;
 * returns -1 when the value is missing, 0 when argv[*i] is another option. */
int cli_value(int argc, char **argv, int *i, const char *name, const char **value);
/* Parses numbers strictly (the whole string); 0 on success, -1 on failure. */
int cli_parse_double(const char *s, double *out);
int cli_parse_int(const char *s, long long min, long long max, long long *out);

/* Tries the common options at argv[*i]: 1 consumed (i advanced), 0 not a common option,
 * CLI_USAGE-style negative (-2) after printing a usage error. */
int cli_common_option(const char *command, int argc, char **argv, int *i, cli_common *c);
/* 1 if the options' light count suits their method; else prints a usage error naming the
 * limit and returns 0 (call it once every option is read: -n and --method come in any order). */
int cli_light_count_ok(const char *command, const envl_lights_options *lo);
/* Help text for the common options. */
extern const char cli_common_help[];

/* Loads FILE, or the built-in sky for NULL or "-"; warns (unless quiet) about replaced pixels
 * and says which layout auto-detection picked when that was a real guess (not evident from
 * the file's shape or metadata). Returns CLI_OK or CLI_FAIL; a message names FILE. */
int cli_load(const char *file, const cli_common *c, envl_envmap **out);
/* 1 if the layout `in` was read as is evident from its shape or metadata (a guess of it
 * needs no note), 0 if it was a real guess (a square image, or an unusual aspect). */
int cli_layout_evident(const envl_info *in);

/* Output: a memory stream whose contents are written atomically to `path`, or stdout when
 * path is NULL or "-". */
typedef struct cli_output {
    const char *path;
    FILE *f;
    char *buf;
    size_t size;
} cli_output;
int cli_output_open(cli_output *o, const char *path);
int cli_output_close(cli_output *o); /* CLI_OK or CLI_FAIL */

/* Subcommands. */
int cli_info(int argc, char **argv);
int cli_convert(int argc, char **argv);
int cli_lights(int argc, char **argv);
int cli_bench(int argc, char **argv);
int cli_sh(int argc, char **argv);
int cli_pov(int argc, char **argv);
int cli_prefilter(int argc, char **argv);
int cli_brdf_lut(int argc, char **argv);
int cli_preview(int argc, char **argv);

#endif
