/* The option tables of the commands: one table per command is both what cli_parse reads and
 * what --help prints, so an option and its help cannot drift apart. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

/* The input options every command that reads an environment accepts (their values in c). */
enum { COMMON_OPTIONS = 12 };
static void common_table(cli_common *c, cli_option t[COMMON_OPTIONS])
{
    static char layouts[256];
    if (!layouts[0])
        for (int32_t l = 0; envl_layout_name(l); l++)
            snprintf(layouts + strlen(layouts), sizeof layouts - strlen(layouts), "%s%s",
                     l ? "|" : "", envl_layout_name(l));
    cli_option o[COMMON_OPTIONS] = {
        CLI_OPTION("--layout-in", "L", CLI_CHOICE, .value = &c->load.layout, .choices = layouts,
                   .lookup = envl_layout_from_name,
                   .help = "auto|latlong|angular|mirrorball|cross|hcross|hstrip|vstrip|\n"
                           "exr-latlong|exr-cube (default auto: by metadata and aspect ratio)"),
        CLI_OPTION("--width", "W", CLI_INT, .min = 1, .max = 1 << 20, .value = &c->load.width,
                   .help = "width of the canonical lat-long map (default: from the input)"),
        CLI_OPTION("--rotate", "DEG", CLI_REAL, .min = -1e6, .max = 1e6,
                   .value = &c->load.rotate_degrees,
                   .help = "turn the environment about +Z (counter-clockwise from above)"),
        CLI_OPTION("--strict", NULL, CLI_FLAG, .value = &c->load.strict,
                   .help = "NaN, Inf or negative pixels are an error (default: NaN and\n"
                           "negatives become 0, +Inf the largest finite value, with a warning)"),
        CLI_OPTION("--apply-exposure", NULL, CLI_FLAG, .value = &c->load.apply_exposure,
                   .help = "divide Radiance pixels by the file's EXPOSURE"),
        CLI_OPTION("--part", "NAME", CLI_TEXT, .value = &c->load.exr_part,
                   .help = "multipart OpenEXR: read the part NAME"),
        CLI_OPTION("--max-pixels", "N", CLI_INT64, .min = 1, .max = 9.2e18,
                   .value = &c->load.max_pixels, .takes = "a positive number",
                   .help = "refuse files whose header claims more pixels, and a --width or\n"
                           "--sky-width W whose W x W/2 map has more (default 268435456)"),
        CLI_OPTION("--threads", "N", CLI_INT, .min = 1, .max = ENVL_MAX_THREADS,
                   .value = &c->load.threads, .help = "worker threads (default: all cores)"),
        CLI_OPTION("-q|--quiet", NULL, CLI_FLAG, .value = &c->quiet,
                   .help = "no notes or warnings on stderr"),
        CLI_OPTION("--sun-elevation", "DEG", CLI_REAL, .min = -90, .max = 90,
                   .value = &c->sky.sun_elevation_degrees,
                   .help = "the built-in sky (FILE '-' or absent): the sun's elevation\n"
                           "(default 35)"),
        CLI_OPTION("--sun-azimuth", "DEG", CLI_REAL, .min = -1e6, .max = 1e6,
                   .value = &c->sky.sun_azimuth_degrees,
                   .help = "the built-in sky: the sun's azimuth (default 0 = +X)"),
        CLI_OPTION("--sky-width", "W", CLI_INT, .min = 2, .max = 65536, .value = &c->sky.width,
                   .help = "the built-in sky: its width (default 1024)"),
    };
    memcpy(t, o, sizeof o);
}

/* 1 if `arg` is one of the option's names ("-n|--count"): *value gets "--x=VALUE"'s value. */
static int names_match(const char *names, const char *arg, const char **value)
{
    *value = NULL;
    for (const char *p = names; *p;) {
        size_t n = strcspn(p, "|");
        if (!strncmp(arg, p, n) && (arg[n] == '\0' || arg[n] == '=')) {
            *value = arg[n] == '=' ? arg + n + 1 : NULL;
            return 1;
        }
        p += n + (p[n] == '|');
    }
    return 0;
}

/* "a, b or c" from "a|b|c" (the usage error's list). */
static void choice_list(const char *choices, char *out, size_t size)
{
    out[0] = '\0';
    int count = 1, k = 0;
    for (const char *p = choices; *p; p++)
        count += *p == '|';
    for (const char *p = choices; *p; k++) {
        size_t n = strcspn(p, "|");
        snprintf(out + strlen(out), size - strlen(out), "%s%.*s",
                 k == 0 ? "" : k + 1 == count ? " or " : ", ", (int)n, p);
        p += n + (p[n] == '|');
    }
}

/* The index of `v` in "a|b|c", or -1. */
static int choice_index(const char *choices, const char *v)
{
    int k = 0;
    for (const char *p = choices; *p; k++) {
        size_t n = strcspn(p, "|");
        if (strlen(v) == n && !strncmp(p, v, n))
            return k;
        p += n + (p[n] == '|');
    }
    return -1;
}

static int long_name(const cli_option *o, char *out, size_t size)
{
    const char *bar = strrchr(o->names, '|');
    return snprintf(out, size, "%s", bar ? bar + 1 : o->names);
}

/* What the option takes, for its usage error. */
static void takes_text(const cli_option *o, char *out, size_t size)
{
    if (o->takes)
        snprintf(out, size, "%s", o->takes);
    else if (o->kind == CLI_INT || o->kind == CLI_INT64)
        snprintf(out, size, "%.0f..%.0f", o->min, o->max);
    else if (o->kind == CLI_REAL)
        snprintf(out, size, "a number within [%g, %g]", o->min, o->max);
    else if (o->kind == CLI_CHOICE)
        choice_list(o->choices, out, size);
    else
        snprintf(out, size, "a value");
}

/* Stores the text v as o's value; 0, or -1 when v is not what o takes. */
static int store(cli_option *o, const char *v)
{
    long long n;
    double d;
    switch (o->kind) {
    case CLI_FLAG:
        *(int *)o->value = o->max ? (int)o->max : 1;
        return 0;
    case CLI_INT:
        if (cli_parse_int(v, (long long)o->min, (long long)o->max, &n))
            return -1;
        *(int *)o->value = (int)n;
        return 0;
    case CLI_INT64:
        if (cli_parse_int(v, (long long)o->min, INT64_MAX, &n) || (double)n > o->max)
            return -1;
        *(int64_t *)o->value = n;
        return 0;
    case CLI_REAL:
        if (cli_parse_double(v, &d) || !(d >= o->min && d <= o->max))
            return -1;
        *(double *)o->value = d;
        return 0;
    case CLI_CHOICE:
        if ((n = o->lookup ? o->lookup(v) : choice_index(o->choices, v)) < 0)
            return -1;
        *(int *)o->value = o->bits ? *(int *)o->value | 1 << n : (int)n;
        return 0;
    case CLI_TEXT:
        if (!*v)
            return -1;
        *(const char **)o->value = v;
        return 0;
    }
    return -1;
}

static void print_table(FILE *f, const cli_option *t, int n)
{
    int width = 0;
    char left[64];
    for (int i = 0; i < n; i++) {
        int w = snprintf(left, sizeof left, "%s%s%s", t[i].names, t[i].arg ? " " : "",
                         t[i].arg ? t[i].arg : "");
        width = w > width && w <= 20 ? w : width;
    }
    for (int i = 0; i < n; i++) {
        snprintf(left, sizeof left, "%s%s%s", t[i].names, t[i].arg ? " " : "",
                 t[i].arg ? t[i].arg : "");
        const char *h = t[i].help;
        if ((int)strlen(left) > width) { /* a long name: its help starts on the next line */
            fprintf(f, "  %s\n", left);
            left[0] = '\0';
        }
        for (int first = 1; first || *h; first = 0) {
            size_t k = strcspn(h, "\n");
            fprintf(f, "  %-*s  %.*s\n", width, first ? left : "", (int)k, h);
            h += k + (h[k] == '\n');
        }
    }
}

void cli_help(FILE *f, const cli_command *cmd, const cli_option *t, int n, int common)
{
    fputs(cmd->usage, f);
    print_table(f, t, n);
    if (cmd->notes)
        fputs(cmd->notes, f);
    if (common) {
        cli_common c;
        cli_option ct[COMMON_OPTIONS];
        common_table(&c, ct);
        fputs("\nInput options:\n", f);
        print_table(f, ct, COMMON_OPTIONS);
    }
}

/* --width W (and --sky-width W) make a W x W/2 map: --max-pixels bounds it as it bounds a file,
 * before anything is read or allocated (a 40000 x 20000 map is 9.6 GB of floats). */
static int map_fits(const char *command, const cli_common *c)
{
    int64_t max = c->load.max_pixels > 0 ? c->load.max_pixels : ENVL_DEFAULT_MAX_PIXELS;
    const char *opt[2] = {"--width", "--sky-width"};
    int32_t w[2] = {c->load.width, c->sky.width};
    for (int k = 0; k < 2; k++) {
        int64_t h = w[k] / 2 > 0 ? w[k] / 2 : 1;
        if (w[k] > 0 && (int64_t)w[k] * h > max) {
            cli_usage(command, "%s %d makes a %d x %d map: more than --max-pixels %lld (a "
                      "smaller %s, or a larger --max-pixels)", opt[k], (int)w[k], (int)w[k],
                      (int)h, (long long)max, opt[k]);
            return 0;
        }
    }
    return 1;
}

/* The option of t[0..n) (then of the common table) that argv[i] names, or NULL. */
static cli_option *find(cli_option *t, int n, cli_option *ct, int nc, const char *arg,
                        const char **inline_value)
{
    for (int k = 0; k < n + nc; k++) {
        cli_option *o = k < n ? &t[k] : &ct[k - n];
        if (names_match(o->names, arg, inline_value))
            return o;
    }
    return NULL;
}

int cli_parse(const cli_command *cmd, cli_option *t, int n, cli_common *c, int argc,
              char **argv, const char **pos, int max_pos, int *npos)
{
    cli_option ct[COMMON_OPTIONS];
    int nc = c ? COMMON_OPTIONS : 0;
    if (c)
        common_table(c, ct);
    *npos = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            cli_help(stdout, cmd, t, n, c != NULL);
            return CLI_HELP;
        }
        cli_option *o = find(t, n, ct, nc, a, &v);
        if (!o) {
            if (a[0] == '-' && a[1])
                return cli_usage(cmd->name, "unknown option '%s'", a);
            if (*npos >= max_pos)
                return max_pos == 1 ? cli_usage(cmd->name, "one FILE only")
                                    : cli_usage(cmd->name, "unexpected argument '%s'", a);
            pos[(*npos)++] = a;
            continue;
        }
        char name[64], takes[256];
        long_name(o, name, sizeof name);
        takes_text(o, takes, sizeof takes);
        if (o->kind == CLI_FLAG && v)
            return cli_usage(cmd->name, "%s takes no value", name);
        if (o->kind != CLI_FLAG && !v) {
            if (i + 1 >= argc)
                return cli_usage(cmd->name, "%s needs %s", name, o->kind == CLI_TEXT ? takes
                                                                                      : "a value");
            v = argv[++i];
        }
        if (store(o, v))
            return cli_usage(cmd->name, "%s takes %s, not '%s'", name, takes, v);
        o->seen = 1;
    }
    if (c) {
        c->sky.sun_elevation_is_set = cli_seen(ct, nc, "--sun-elevation") != NULL;
        if (!map_fits(cmd->name, c))
            return CLI_USAGE;
    }
    return CLI_OK;
}

const cli_option *cli_seen(const cli_option *t, int n, const char *names)
{
    for (int i = 0; i < n; i++)
        if (!strcmp(t[i].names, names))
            return t[i].seen ? &t[i] : NULL;
    return NULL;
}
