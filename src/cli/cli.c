/* envlight: the command-line tool. Dispatches to the subcommands (cli_*.c) and holds the
 * option handling they share. */
#include "cli.h"
#include "escape.h"
#include "json.h"
#include "repair.h"

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

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

int cli_light_count_ok(const char *command, const envl_lights_options *lo)
{
    if (lo->method != ENVL_METHOD_FIT || lo->count <= ENVL_FIT_MAX_LIGHTS)
        return 1;
    cli_usage(command, "--method fit takes 1..%d lights, not %d (median and variance take "
              "more)", ENVL_FIT_MAX_LIGHTS, (int)lo->count);
    return 0;
}

const char *cli_frame_label(int frame)
{
    return frame == ENVL_FRAME_GLTF ? "gltf-y-up" : "blender-z-up";
}

const char *cli_error_text(char *buf, size_t size, const char *what, double error)
{
    if (error >= 0)
        snprintf(buf, size, "%s error %.3f %%", what, 100 * error);
    else
        snprintf(buf, size, "%s error not measured", what);
    return buf;
}

/* A map too coarse for the GGX sums was prefiltered from a finer copy (docs/design.md,
 * "prefiltered maps"): say so on stderr, with how the copy was made. */
void cli_coarse_note(const envl_envmap *map, int32_t width, int32_t height, int quiet)
{
    int32_t w = envl_envmap_width(map), h = envl_envmap_height(map);
    if (quiet || width <= 0 || height <= 0 || (width == w && height == h))
        return;
    envl_info info;
    envl_envmap_info(map, &info);
    char how[96];
    if (width % w == 0 && height % h == 0)
        snprintf(how, sizeof how, "each pixel split into %d x %d, the same map",
                 (int)(width / w), (int)(height / h));
    else
        snprintf(how, sizeof how, "area-resampled");
    cli_error("%s: %d x %d pixels are too coarse for the GGX levels, which sum each pixel at "
              "its centre: prefiltered from a %d x %d copy (%s)", info.file, (int)w, (int)h,
              (int)width, (int)height, how);
}

const char *cli_texel_text(char *buf, size_t size, const envl_texel_error *t)
{
    if (!(t->rms >= 0 && t->worst >= 0))
        snprintf(buf, size, "per texel not measured");
    else if (t->measured < t->texels)
        snprintf(buf, size, "per texel RMS %.3f %% worst %.3f %% (%d of %d texels)",
                 100 * t->rms, 100 * t->worst, (int)t->measured, (int)t->texels);
    else
        snprintf(buf, size, "per texel RMS %.3f %% worst %.3f %%", 100 * t->rms,
                 100 * t->worst);
    return buf;
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

/* The library's progress on stderr, one line rewritten in place: only on a terminal (a pipe
 * or a log gets nothing), cleared at the end. */
static void show_progress(double fraction, const char *stage)
{
    if (fraction >= 1.0)
        fprintf(stderr, "\r%60s\r", "");
    else
        fprintf(stderr, "\renvlight: %-45.45s %3d %%", stage, (int)(100 * fraction));
    fflush(stderr);
}

static int progress_installed, progress_shown;
static volatile sig_atomic_t interrupted; /* the signal that asked to stop, or 0 */

/* Ctrl-C (SIGINT) or SIGTERM: the next progress step cancels the work (the library then
 * writes nothing and removes its temporaries); a second one ends the process at once. */
static void on_interrupt(int sig)
{
    interrupted = sig;
    signal(sig, SIG_DFL);
}

/* The library's progress callback: shows the step, and cancels once interrupted. */
static int progress(void *user, double fraction, const char *stage)
{
    (void)user;
    if (progress_shown)
        show_progress(interrupted ? 1.0 : fraction, stage);
    return interrupted != 0;
}

int cli_progress_start(const cli_common *c)
{
    if (!progress_installed) {
        progress_installed = 1;
        progress_shown = !c->quiet && isatty(STDERR_FILENO);
        envl_set_progress(progress, NULL);
        signal(SIGINT, on_interrupt);
        signal(SIGTERM, on_interrupt);
    }
    return progress_shown;
}

int cli_progress(double fraction, const char *stage)
{
    return progress_installed ? progress(NULL, fraction, stage) : 0;
}

int cli_interrupted(void)
{
    return interrupted;
}

/* What the loader did to the file's values (envl_info; docs/design.md, "Units"). */
static void warn_repairs(const char *file, const envl_info *in)
{
    char text[512];
    if (repair_nonfinite_text(text, sizeof text, in))
        cli_error("warning: %s: %s (--strict refuses them)", file, text);
    if (repair_negative_text(text, sizeof text, in))
        cli_error("warning: %s: %s (--strict refuses them)", file, text);
}

int cli_load(const char *file, const cli_common *c, envl_envmap **out)
{
    envl_result rc;
    cli_progress_start(c);
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
    if (!c->quiet)
        warn_repairs(file, &info);
    if (!c->quiet && info.layout_guessed && !cli_layout_evident(&info))
        fprintf(stderr, "envlight: %s: %d x %d read as layout '%s' (--layout-in to choose)\n",
                file, info.source_width, info.source_height, envl_layout_name(info.layout));
    return CLI_OK;
}

int cli_outputs_ok(const char *const *inputs, int n_inputs, const char *const *outputs,
                   int n_outputs)
{
    int n = n_inputs + n_outputs;
    const char **names = malloc(sizeof *names * (size_t)(n > 0 ? n : 1));
    if (!names) {
        cli_error("out of memory");
        return CLI_FAIL;
    }
    for (int i = 0; i < n; i++) {
        const char *s = i < n_inputs ? inputs[i] : outputs[i - n_inputs];
        names[i] = s && strcmp(s, "-") ? s : NULL;
    }
    envl_result rc = envl_outputs_check(names, n_inputs, names + n_inputs, n_outputs);
    free(names);
    return rc ? cli_fail() : CLI_OK;
}

size_t cli_half_over(const float *v, size_t n, double *largest)
{
    size_t over = 0;
    *largest = 0;
    for (size_t i = 0; v && i < n; i++)
        if (fabs(v[i]) > ENVL_HALF_MAX) {
            over++;
            *largest = fmax(*largest, fabs(v[i]));
        }
    return over;
}

void cli_half_warning(const char *what, const float *v, size_t n, int quiet)
{
    double largest;
    size_t over = cli_half_over(v, n, &largest);
    if (over && !quiet)
        cli_error("warning: %s: %zu values above %g (the largest half float) written as %g: the "
                  "largest was %g (%.1f %% lower)", what, over, ENVL_HALF_MAX, ENVL_HALF_MAX,
                  largest, 100 * (1 - ENVL_HALF_MAX / largest));
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
