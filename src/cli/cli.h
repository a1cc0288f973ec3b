/* The `envlight` command line: shared option handling for the subcommands. */
#ifndef ENVL_CLI_H
#define ENVL_CLI_H

#include "envlight.h"

#include <stdio.h>

/* Exit statuses (docs/design.md): 0 success, 1 bad input or failure, 2 bad usage. */
#define CLI_OK 0
#define CLI_FAIL 1
#define CLI_USAGE 2
#define CLI_HELP (-1) /* cli_parse printed --help: the command exits with CLI_OK */

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

/* Parses numbers strictly (the whole string); 0 on success, -1 on failure. */
int cli_parse_double(const char *s, double *out);
int cli_parse_int(const char *s, long long min, long long max, long long *out);

/* 1 if the options' light count suits their method; else prints a usage error naming the
 * limit and returns 0 (call it once every option is read: -n and --method come in any order). */
int cli_light_count_ok(const char *command, const envl_lights_options *lo);

/* ---- option tables (cli_options.c) ----
 * Each command lists its options in one table that cli_parse reads and cli_help prints. */
typedef enum cli_kind {
    CLI_FLAG,    /* int *: set to max, or 1 when max is 0 */
    CLI_INT,     /* int *, within [min, max] */
    CLI_INT64,   /* int64_t *, within [min, max] */
    CLI_REAL,    /* double *, within [min, max] */
    CLI_CHOICE,  /* int *: lookup(text) when given, else the index of the text in choices */
    CLI_TEXT,    /* const char **: the text as given (not empty) */
} cli_kind;
typedef struct cli_option {
    const char *names;        /* "--order", or "-n|--count" */
    const char *arg;          /* the value's name in the help ("L"); NULL for a flag */
    cli_kind kind;
    double min, max;
    void *value;
    const char *help;         /* lines separated by '\n' */
    const char *choices;      /* CLI_CHOICE: "a|b|c" (the usage error lists them) */
    int32_t (*lookup)(const char *name); /* CLI_CHOICE: a library name lookup (-1: unknown) */
    const char *takes;        /* what a usage error says the option takes (default: its range
                                 or choices) */
    int bits;                 /* CLI_CHOICE: *value |= 1 << index (the option repeats) */
    int seen;                 /* set by cli_parse */
} cli_option;
typedef struct cli_command {
    const char *name;         /* "sh" */
    const char *usage;        /* the synopsis and what it does, before the options */
    const char *notes;        /* printed after the options (may be NULL) */
} cli_command;
/* Parses argv[1 .. argc) by t[0 .. n) and, when c is given, the input options (into c):
 * positional arguments go to pos[0 .. max_pos) (*npos of them). Returns CLI_OK, CLI_HELP
 * (--help printed to stdout) or CLI_USAGE (a usage error printed). */
int cli_parse(const cli_command *cmd, cli_option *t, int n, cli_common *c, int argc,
              char **argv, const char **pos, int max_pos, int *npos);
/* The help: usage, the table, notes and (common) the input options. */
void cli_help(FILE *f, const cli_command *cmd, const cli_option *t, int n, int common);
/* t's entry named `names` when cli_parse saw it, else NULL. */
const cli_option *cli_seen(const cli_option *t, int n, const char *names);
#define CLI_COUNT(t) ((int)(sizeof(t) / sizeof((t)[0])))
/* A table entry: CLI_OPTION("--order", "L", CLI_INT, .min = 0, .max = 32, .value = &order,
 * .help = "..."). */
#define CLI_OPTION(names_, arg_, kind_, ...) {.names = names_, .arg = arg_, .kind = kind_, __VA_ARGS__}
/* --no-error, spelled and explained alike on every command that measures an error. */
#define CLI_NO_ERROR_OPTION(flag)                                                             \
    CLI_OPTION("--no-error", NULL, CLI_FLAG, .value = (flag),                                 \
               .help = "skip the error measure (docs/design.md); the output then says it\n"    \
                       "was not measured")
/* --frame F, the same on every export (envlight.h: ENVL_FRAME_*). */
#define CLI_FRAME_OPTION(frame)                                                               \
    CLI_OPTION("--frame", "F", CLI_CHOICE, .value = (frame), .choices = "blender|gltf",       \
               .lookup = envl_frame_from_name,                                                \
               .help = "the frame of every direction, coefficient and cube face written:\n"  \
                       "blender (default: right-handed, +Z up) or gltf (right-handed, +Y up,\n" \
                       "as glTF, OpenGL, three.js, Filament: (x, y, z) -> (x, z, -y))")
/* What an output states of its frame: "blender-z-up" or "gltf-y-up". */
const char *cli_frame_label(int frame);
/* "<what> error 0.123 %", or "<what> error not measured" for a negative error. */
const char *cli_error_text(char *buf, size_t size, const char *what, double error);
/* "per texel RMS 0.190 % worst 1.020 %" (", 8192 of 98304 texels" when a part was measured),
 * or "per texel not measured": docs/design.md's per-texel error. */
/* The note on stderr when the prefiltered levels were computed from a finer copy of a map
 * too coarse for them (width x height, as the products' or glTF's summary reports it). */
void cli_coarse_note(const envl_envmap *map, int32_t width, int32_t height, int quiet);
const char *cli_texel_text(char *buf, size_t size, const envl_texel_error *t);


/* Loads FILE, or the built-in sky for NULL or "-"; warns (unless quiet) about replaced pixels
 * and says which layout auto-detection picked when that was a real guess (not evident from
 * the file's shape or metadata). Returns CLI_OK or CLI_FAIL; a message names FILE. */
int cli_load(const char *file, const cli_common *c, envl_envmap **out);
/* The progress display: one line on stderr rewritten in place, cleared at fraction 1, on a
 * terminal only and not with --quiet (a pipe or a log gets nothing). cli_progress_start
 * installs the library's progress callback (envl_set_progress; cli_load does) and handlers
 * of SIGINT and SIGTERM that make it cancel at the next step, and says whether the display is
 * shown; cli_progress reports the command's own steps (writing a file, a bench case) to it:
 * nonzero is a cancel. cli_interrupted: the signal that asked to stop, or 0. */
int cli_progress_start(const cli_common *c);
int cli_progress(double fraction, const char *stage);
int cli_interrupted(void);
/* 1 if the layout `in` was read as is evident from its shape or metadata (a guess of it
 * needs no note), 0 if it was a real guess (a square image, or an unusual aspect). */
int cli_layout_evident(const envl_info *in);

/* No output replaces an input or another output (envl_outputs_check; "-" and NULL, stdin's
 * sky and stdout, are skipped): CLI_OK, else the message and CLI_FAIL. Called before the map
 * is read, so a refused run computes nothing. */
int cli_outputs_ok(const char *const *inputs, int n_inputs, const char *const *outputs,
                   int n_outputs);

/* A file of IEEE half floats holds at most ENVL_HALF_MAX: unless quiet, says on stderr how
 * many of the n values (RGB floats) of `what` go above it, and the largest (how much lower it
 * is written). */
void cli_half_warning(const char *what, const float *v, size_t n, int quiet);
/* How many of the n values go above ENVL_HALF_MAX; *largest the largest of them (0: none). */
size_t cli_half_over(const float *v, size_t n, double *largest);

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
int cli_gltf(int argc, char **argv);
int cli_brdf_lut(int argc, char **argv);
int cli_preview(int argc, char **argv);

#endif
