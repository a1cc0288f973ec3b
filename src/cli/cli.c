/* envlight: the command-line tool. Dispatches to the subcommands (cli_*.c) and holds the
 * option handling they share. */
#include "cli.h"
#include "escape.h"

#include <errno.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

void cli_error(const char *fmt, ...)
{
    char msg[2048]; /* formatted first: a file name's control characters shown as \xHH */
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    escape_controls(msg, sizeof msg);
    fprintf(stderr, "envlight: %s\n", msg);
}

int cli_usage(const char *command, const char *fmt, ...)
{
    char msg[2048]; /* as cli_error: control characters shown as \xHH */
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    escape_controls(msg, sizeof msg);
    fprintf(stderr, "envlight %s: %s\n(see 'envlight %s --help')\n", command, msg, command);
    return CLI_USAGE;
}

int cli_fail(void)
{
    cli_error("%s", envl_last_error());
    return CLI_FAIL;
}

int cli_value(int argc, char **argv, int *i, const char *name, const char **value)
{
    const char *a = argv[*i];
    size_t n = strlen(name);
    if (strncmp(a, name, n) != 0)
        return 0;
    if (a[n] == '=') {
        *value = a + n + 1;
        return 1;
    }
    if (a[n] != '\0')
        return 0;
    if (*i + 1 >= argc)
        return -1;
    *value = argv[++*i];
    return 1;
}

int cli_parse_double(const char *s, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (!*s || *end || errno)
        return -1;
    *out = v;
    return 0;
}

int cli_parse_int(const char *s, long long min, long long max, long long *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (!*s || *end || errno || v < min || v > max)
        return -1;
    *out = v;
    return 0;
}

const char cli_common_help[] =
    "Input options:\n"
    "  --layout-in L      auto|latlong|angular|mirrorball|cross|hcross|hstrip|vstrip|\n"
    "                     exr-latlong|exr-cube (default auto: by metadata and aspect ratio)\n"
    "  --width W          width of the canonical lat-long map (default: from the input)\n"
    "  --rotate DEG       turn the environment about +Z (counter-clockwise from above)\n"
    "  --strict           NaN, Inf or negative pixels are an error (default: NaN and\n"
    "                     negatives become 0, +Inf the largest finite value, with a warning)\n"
    "  --apply-exposure   divide Radiance pixels by the file's EXPOSURE\n"
    "  --part NAME        multipart OpenEXR: read the part NAME\n"
    "  --max-pixels N     refuse files whose header claims more pixels, and a --width or\n"
    "                     --sky-width W whose W x W/2 map has more (default 268435456)\n"
    "  --threads N        worker threads (default: all cores)\n"
    "  --quiet            no notes or warnings on stderr\n"
    "Built-in sky (FILE '-' or absent):\n"
    "  --sun-elevation DEG (default 35)   --sun-azimuth DEG (default 0 = +X)\n"
    "  --sky-width W (default 1024)\n";

int cli_light_count_ok(const char *command, const envl_lights_options *lo)
{
    if (lo->method != ENVL_METHOD_FIT || lo->count <= ENVL_FIT_MAX_LIGHTS)
        return 1;
    cli_usage(command, "--method fit takes 1..%d lights, not %d (median and variance take "
              "more)", ENVL_FIT_MAX_LIGHTS, (int)lo->count);
    return 0;
}

/* --width W (and --sky-width W) make a W x W/2 map: --max-pixels bounds it as it bounds a file,
 * checked whichever comes first (each check sees the options given so far), before anything is
 * read or allocated (a 40000 x 20000 map is 9.6 GB of floats). 1 if it fits, else a usage
 * error. */
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

int cli_common_option(const char *command, int argc, char **argv, int *i, cli_common *c)
{
    const char *v;
    int r;
    double d;
    long long n;
#define VALUE(name)                                                                            \
    ((r = cli_value(argc, argv, i, name, &v)) < 0                                             \
         ? (cli_usage(command, "%s needs a value", name), -2)                                  \
         : r)
    if ((r = VALUE("--layout-in")) != 0) {
        if (r < 0)
            return r;
        int32_t l = envl_layout_from_name(v);
        if (l < 0)
            return cli_usage(command, "unknown layout '%s'", v), -2;
        c->load.layout = l;
        return 1;
    }
    if ((r = VALUE("--width")) != 0) {
        if (r < 0)
            return r;
        if (cli_parse_int(v, 1, 1 << 20, &n))
            return cli_usage(command, "--width takes a whole number from 1, not '%s'", v), -2;
        c->load.width = (int32_t)n;
        return map_fits(command, c) ? 1 : -2;
    }
    if ((r = VALUE("--rotate")) != 0) {
        if (r < 0)
            return r;
        if (cli_parse_double(v, &d) || !(d > -1e6 && d < 1e6))
            return cli_usage(command, "--rotate takes degrees, not '%s'", v), -2;
        c->load.rotate_degrees = d;
        return 1;
    }
    if ((r = VALUE("--part")) != 0) {
        if (r < 0)
            return r;
        c->load.exr_part = v;
        return 1;
    }
    if ((r = VALUE("--max-pixels")) != 0) {
        if (r < 0)
            return r;
        if (cli_parse_int(v, 1, INT64_MAX, &n))
            return cli_usage(command, "--max-pixels takes a positive number, not '%s'", v), -2;
        c->load.max_pixels = n;
        return map_fits(command, c) ? 1 : -2;
    }
    if ((r = VALUE("--threads")) != 0) {
        if (r < 0)
            return r;
        if (cli_parse_int(v, 1, ENVL_MAX_THREADS, &n))
            return cli_usage(command, "--threads takes 1..%d, not '%s'", ENVL_MAX_THREADS, v), -2;
        c->load.threads = (int32_t)n;
        return 1;
    }
    if ((r = VALUE("--sun-elevation")) != 0) {
        if (r < 0)
            return r;
        if (cli_parse_double(v, &d) || d < -90 || d > 90)
            return cli_usage(command, "--sun-elevation takes -90..90 degrees, not '%s'", v), -2;
        c->sky.sun_elevation_degrees = d;
        c->sky.sun_elevation_is_set = 1;
        return 1;
    }
    if ((r = VALUE("--sun-azimuth")) != 0) {
        if (r < 0)
            return r;
        if (cli_parse_double(v, &d) || !(d > -1e6 && d < 1e6))
            return cli_usage(command, "--sun-azimuth takes degrees, not '%s'", v), -2;
        c->sky.sun_azimuth_degrees = d;
        return 1;
    }
    if ((r = VALUE("--sky-width")) != 0) {
        if (r < 0)
            return r;
        if (cli_parse_int(v, 2, 65536, &n))
            return cli_usage(command, "--sky-width takes 2..65536, not '%s'", v), -2;
        c->sky.width = (int32_t)n;
        return map_fits(command, c) ? 1 : -2;
    }
#undef VALUE
    const char *a = argv[*i];
    if (!strcmp(a, "--strict"))
        c->load.strict = 1;
    else if (!strcmp(a, "--apply-exposure"))
        c->load.apply_exposure = 1;
    else if (!strcmp(a, "--quiet") || !strcmp(a, "-q"))
        c->quiet = 1;
    else
        return 0;
    return 1;
}

/* The layout guess (layout.c: metadata, then the aspect ratio) is evident when the file has
 * the shape of the layout it was read as: OpenEXR's envmap attribute, 2:1 lat-long, 3:4 / 4:3
 * crosses, 6:1 / 1:6 strips. A square is a guess (an angular probe or a mirror ball?), and so
 * is a lat-long of any other aspect (no layout has that shape). */
int cli_layout_evident(const envl_info *in)
{
    int64_t w = in->source_width, h = in->source_height;
    switch (in->layout) {
    case ENVL_LAYOUT_LATLONG: return w == 2 * h;
    case ENVL_LAYOUT_ANGULAR:
    case ENVL_LAYOUT_MIRRORBALL: return 0;
    default: return 1;
    }
}

int cli_load(const char *file, const cli_common *c, envl_envmap **out)
{
    envl_result rc;
    if (!file || !strcmp(file, "-")) {
        rc = envl_envmap_sky(&c->sky, out);
        if (rc == ENVL_OK && (c->load.rotate_degrees != 0.0 || c->load.width)) {
            /* The sky honours --rotate and --width like a file does: go through pixels. */
            envl_envmap *sky = *out;
            envl_load_options lo = c->load;
            lo.layout = ENVL_LAYOUT_LATLONG;
            rc = envl_envmap_from_pixels(envl_envmap_pixels(sky), envl_envmap_width(sky),
                                         envl_envmap_height(sky), 3, &lo, out);
            envl_envmap_free(sky);
        }
        return rc ? cli_fail() : CLI_OK;
    }
    rc = envl_envmap_load(file, &c->load, out);
    if (rc) {
        /* every message about reading FILE names it (the resampling's "cannot allocate" does
         * not know the file) */
        const char *msg = envl_last_error();
        size_t n = strlen(file);
        if (strncmp(msg, file, n) == 0 && msg[n] == ':')
            return cli_fail();
        cli_error("%s: %s", file, msg);
        return CLI_FAIL;
    }
    envl_info info;
    envl_envmap_info(*out, &info);
    if (!c->quiet && (info.nonfinite_pixels || info.negative_pixels))
        cli_error("warning: %s: %lld pixels with NaN or Inf, %lld with negative values: NaN and "
                  "negatives set to 0, +Inf to the largest finite value (--strict refuses them)",
                  file, (long long)info.nonfinite_pixels, (long long)info.negative_pixels);
    if (!c->quiet && info.layout_guessed && !cli_layout_evident(&info))
        fprintf(stderr, "envlight: %s: %d x %d read as layout '%s' (--layout-in to choose)\n",
                file, info.source_width, info.source_height, envl_layout_name(info.layout));
    return CLI_OK;
}

int cli_output_open(cli_output *o, const char *path)
{
    memset(o, 0, sizeof *o);
    if (!path || !strcmp(path, "-")) {
        o->f = stdout;
        return CLI_OK;
    }
    o->path = path;
    o->f = open_memstream(&o->buf, &o->size);
    if (!o->f) {
        cli_error("%s: cannot buffer output: %s", path, strerror(errno));
        return CLI_FAIL;
    }
    return CLI_OK;
}

int cli_output_close(cli_output *o)
{
    if (!o->path) {
        return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
    }
    fclose(o->f);
    envl_result rc = envl_file_write_atomic(o->path, o->buf, o->size);
    free(o->buf);
    return rc ? cli_fail() : CLI_OK;
}
