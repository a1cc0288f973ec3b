/* envlight bench: accuracy against time, for every method and knob, as Markdown tables.
 * Times are medians of several runs, each from scratch (cached tables dropped). Speed targets
 * are ratios against a baseline measured in the same run: one pass summing the map's floats. */
#include "cli.h"
#include "clock.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <spawn.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median_of(double *v, int n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* The baseline: one pass over the map's floats, summed (4 lanes so the adds pipeline, as any
 * stage's inner loop would). */
static double baseline_pass(const envl_envmap *m, volatile double *sink)
{
    const float *p = envl_envmap_pixels(m);
    size_t n = (size_t)envl_envmap_width(m) * envl_envmap_height(m) * 3;
    double t0 = envl__seconds(), a = 0, b = 0, c = 0, d = 0;
    size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        a += p[i];
        b += p[i + 1];
        c += p[i + 2];
        d += p[i + 3];
    }
    for (; i < n; i++)
        a += p[i];
    *sink += a + b + c + d;
    return envl__seconds() - t0;
}

static double peak_rss_mib(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss / 1024.0;
}

typedef struct bench_opts {
    int runs;
    int quick;
} bench_opts;

/* Every measured point, for the CSV and the plots. */
typedef struct bench_point {
    char map[128];
    char kind[16];    /* "diffuse" or "glossy": the error measure, one plot each */
    char series[32];  /* "median", "variance", "fit", "sh-none", ... : one curve each */
    int param;        /* lights asked, or SH order */
    int count;        /* lights used (SH: coefficients) */
    double error, seconds;
} bench_point;

static bench_point *points;
static int npoints, cap_points;

static void record(const char *map, const char *kind, const char *series, int param, int count,
                   double error, double seconds)
{
    if (npoints == cap_points) {
        int cap = cap_points ? 2 * cap_points : 256;
        bench_point *p = realloc(points, sizeof *p * cap);
        if (!p)
            return;
        points = p;
        cap_points = cap;
    }
    bench_point *b = &points[npoints++];
    snprintf(b->map, sizeof b->map, "%s", map);
    snprintf(b->kind, sizeof b->kind, "%s", kind);
    snprintf(b->series, sizeof b->series, "%s", series);
    b->param = param;
    b->count = count;
    b->error = error;
    b->seconds = seconds;
}

/* ---- progress: on a terminal, as every command's (cli_progress) ------------------------------
 * Each case (a table's cell, a map's loading, the speed, load and memory steps) is one step of
 * the whole: fraction = cases begun before it / all cases, stage = its name. The library's own
 * reports inside a case (envl_compute's levels, ...) move within the case's step under the
 * case's name, so the line never runs backwards. A cancel (nonzero from the display) stops the
 * bench with an error. Shown when stdout is not that terminal (the tables go to a file). */
static struct {
    int shown;        /* the display is on (cli_progress_start) */
    int current, total; /* the current case's index (cases begun before it), of all */
    char stage[96];
} progress;

static int inner_progress(void *user, double fraction, const char *stage)
{
    (void)user, (void)stage;
    return cli_progress((progress.current + fraction) / progress.total, progress.stage);
}

/* The next case begins, named by the format; CLI_FAIL (the error printed) when cancelled. */
static int __attribute__((format(printf, 1, 2))) bench_case(const char *fmt, ...)
{
    static int begun;
    if (!progress.shown)
        return CLI_OK;
    progress.current = begun < progress.total ? begun++ : progress.total - 1;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(progress.stage, sizeof progress.stage, fmt, ap);
    va_end(ap);
    if (inner_progress(NULL, 0.0, NULL)) {
        cli_error("bench cancelled during %s", progress.stage);
        return CLI_FAIL;
    }
    return CLI_OK;
}

/* The Markdown rule under a table's header: lead + n columns. */
static void table_rule(int lead, int n)
{
    printf("\n|");
    for (int i = 0; i < lead + n; i++)
        printf("---|");
    printf("\n");
}

/* One lights configuration: median seconds over runs (tables dropped before each), error. */
static int bench_lights_one(envl_envmap *m, int method, int n, const bench_opts *o,
                            double *seconds, double *error, int *count)
{
    double t[16];
    for (int r = 0; r < o->runs; r++) {
        envl_envmap_drop_caches(m, ENVL_CACHE_SAT);
        envl_lights *ls;
        envl_lights_options lo = {.method = method, .count = n, .measure = 1};
        if (envl_lights_compute(m, &lo, &ls))
            return cli_fail();
        envl_lights_summary s;
        envl_lights_get_summary(ls, &s);
        t[r] = s.seconds;
        *error = s.diffuse_error;
        *count = s.count;
        envl_lights_free(ls);
    }
    *seconds = median_of(t, o->runs);
    return CLI_OK;
}

static const int light_counts[] = {1, 2, 4, 8, 16, 32, 64, 128, 256};

/* A cell of the lights table is measured (fit stops at 16 lights). */
static int lights_cell(int method, int n) { return !(method == ENVL_METHOD_FIT && n > 16); }

static int bench_lights_table(const char *name, envl_envmap *m, const bench_opts *o)
{
    const int *counts = light_counts;
    int ncounts = o->quick ? 5 : 9;
    printf("\n#### Lights: %s (%d x %d)\n\n", name, envl_envmap_width(m),
           envl_envmap_height(m));
    printf("diffuse error %% (seconds); fit: lights used of those asked, order-2 remainder\n\n");
    printf("| method |");
    for (int i = 0; i < ncounts; i++)
        printf(" %d |", counts[i]);
    table_rule(1, ncounts);
    /* sun is left out: its lights are the suns alone, its error counts the residual map as
     * exact, so it is not a lights-only figure like the others' */
    for (int method = 0; method < ENVL_METHOD_COUNT; method++) {
        if (method == ENVL_METHOD_SUN)
            continue;
        printf("| %s |", envl_method_name(method));
        for (int i = 0; i < ncounts; i++) {
            int n = counts[i];
            if (!lights_cell(method, n)) {
                printf(" |");
                continue;
            }
            double sec = 0, err = 0;
            int count = 0;
            if (bench_case("lights %s %d: %s", envl_method_name(method), n, name) ||
                bench_lights_one(m, method, n, o, &sec, &err, &count))
                return CLI_FAIL;
            if (method == ENVL_METHOD_FIT)
                printf(" %.3f (%.3f s, %d) |", 100 * err, sec, count);
            else
                printf(" %.3f (%.3f s) |", 100 * err, sec);
            fflush(stdout);
            record(name, "diffuse", envl_method_name(method), n, count, err, sec);
        }
        printf("\n");
    }
    return CLI_OK;
}

/* SH order 1..8 with each window: error of the irradiance, median seconds. */
static int bench_sh_table(const char *name, envl_envmap *m, const bench_opts *o)
{
    int maxorder = o->quick ? 4 : 8;
    printf("\n#### SH irradiance: %s\n\ndiffuse error %% (seconds)\n\n| window |", name);
    for (int l = 1; l <= maxorder; l++)
        printf(" order %d |", l);
    table_rule(1, maxorder);
    for (int w = 0; w < ENVL_WINDOW_COUNT; w++) {
        printf("| %s |", envl_window_name(w));
        for (int l = 1; l <= maxorder; l++) {
            double t[16], err = 0;
            if (bench_case("SH %s order %d: %s", envl_window_name(w), l, name))
                return CLI_FAIL;
            for (int r = 0; r < o->runs; r++) {
                envl_sh *sh;
                envl_sh_options so = {.order = l, .window = w, .measure = 1};
                if (envl_sh_compute(m, &so, &sh))
                    return cli_fail();
                envl_sh_summary s;
                envl_sh_get_summary(sh, &s);
                t[r] = s.seconds;
                err = s.diffuse_error;
                envl_sh_free(sh);
            }
            double sec = median_of(t, o->runs);
            printf(" %.3f (%.4f s) |", 100 * err, sec);
            fflush(stdout);
            char series[32];
            snprintf(series, sizeof series, "sh-%s", envl_window_name(w));
            record(name, "diffuse", series, l, (l + 1) * (l + 1), err, sec);
        }
        printf("\n");
    }
    return CLI_OK;
}

/* One request's products, timed: median seconds over runs (the map's mip pyramid dropped
 * before each, so every run builds what it needs), the error measured once. */
static int bench_products(envl_envmap *m, const envl_request *q, const bench_opts *o,
                          double *seconds, envl_level *level, envl_irradiance_map *irr)
{
    double t[16];
    for (int r = 0; r < o->runs; r++) {
        envl_request qr = *q;
        qr.measure = r == 0;
        envl_envmap_drop_mips(m);
        envl_products *p;
        if (envl_compute(m, &qr, &p))
            return cli_fail();
        envl_products_summary s;
        envl_products_get_summary(p, &s);
        t[r] = s.seconds;
        if (r == 0 && level && envl_products_level(p, 0, level))
            return cli_fail();
        if (r == 0 && irr && envl_products_irradiance(p, irr))
            return cli_fail();
        if (r == 0 && level) /* the level's pixels belong to the products */
            level->rgb = NULL;
        if (r == 0 && irr)
            irr->rgb = NULL;
        envl_products_free(p);
    }
    *seconds = median_of(t, o->runs);
    return CLI_OK;
}

/* Prefiltered maps: the GGX level's glossy error against samples per texel and against the
 * level's size; the irradiance map's diffuse error by method (SH of each order, resampled,
 * exact). */
static int bench_prefilter_table(const char *name, envl_envmap *m, const bench_opts *o)
{
    static const int samples[] = {16, 64, 256, 1024}, widths[] = {128, 256, 512, 1024};
    static const double rough[] = {0.25, 0.5};
    int nr = o->quick ? 1 : 2, ns = o->quick ? 2 : 4, nw = o->quick ? 2 : 4;
    printf("\n#### Specular (GGX, prefiltered levels): %s\n\nglossy error %% "
           "(seconds, samples per texel); base level 512 wide, level width for the roughness as "
           "the chain's; --samples M (a level w wide gets M (512 / w)^2, at most 8 M)\n\n"
           "| roughness | level |", name);
    for (int i = 0; i < ns; i++)
        printf(" M = %d |", samples[o->quick ? 1 + 2 * i : i]);
    table_rule(2, ns);
    for (int k = 0; k < nr; k++) {
        double r = rough[o->quick ? 1 : k];
        envl_request q = {.n_roughness = 1, .roughness = &r};
        q.prefilter.width = 512;
        printf("| %.2f | %d x %d |", r, envl_prefilter_level_width(&q.prefilter, r),
               envl_prefilter_level_width(&q.prefilter, r) / 2);
        for (int i = 0; i < ns; i++) {
            q.prefilter.samples = samples[o->quick ? 1 + 2 * i : i];
            double sec;
            envl_level l;
            if (bench_case("GGX %.2f, M = %d: %s", r, (int)q.prefilter.samples, name) ||
                bench_products(m, &q, o, &sec, &l, NULL))
                return CLI_FAIL;
            printf(" %.3f (%.3f s, %d) |", 100 * l.glossy_error, sec, (int)l.samples);
            fflush(stdout);
            char series[32];
            snprintf(series, sizeof series, "ggx-r%.2f-samples", r);
            record(name, "glossy", series, l.samples, l.width, l.glossy_error, sec);
        }
        printf("\n");
    }
    printf("\nglossy error %% (seconds) against the base level's width, default samples\n\n"
           "| roughness |");
    for (int i = 0; i < nw; i++)
        printf(" base %d |", widths[o->quick ? 1 + i : i]);
    table_rule(1, nw);
    for (int k = 0; k < nr; k++) {
        double r = rough[o->quick ? 1 : k];
        printf("| %.2f |", r);
        for (int i = 0; i < nw; i++) {
            envl_request q = {.n_roughness = 1, .roughness = &r};
            q.prefilter.width = widths[o->quick ? 1 + i : i];
            double sec;
            envl_level l;
            if (bench_case("GGX %.2f, base %d: %s", r, (int)q.prefilter.width, name) ||
                bench_products(m, &q, o, &sec, &l, NULL))
                return CLI_FAIL;
            printf(" %.3f (%.3f s, %d wide) |", 100 * l.glossy_error, sec, l.width);
            fflush(stdout);
            char series[32];
            snprintf(series, sizeof series, "ggx-r%.2f-size", r);
            record(name, "glossy", series, q.prefilter.width, l.width, l.glossy_error, sec);
        }
        printf("\n");
    }
    /* irradiance maps, 64 x 32: SH of orders 1, 2, 4, 8, the split (default), the resampled
     * sum, the exact sum */
    static const int orders[] = {1, 2, 4, 8};
    static const int32_t other[] = {ENVL_IRRADIANCE_SPLIT, ENVL_IRRADIANCE_RESAMPLED,
                                    ENVL_IRRADIANCE_EXACT};
    printf("\n#### Irradiance map (64 x 32): %s\n\ndiffuse error %% (seconds)\n\n"
           "| SH 1 | SH 2 | SH 4 | SH 8 | split | resampled | exact |\n"
           "|---|---|---|---|---|---|---|\n|",
           name);
    for (int i = 0; i < 7; i++) {
        envl_request q = {.irradiance_map = 1};
        q.prefilter.irradiance_method = i < 4 ? ENVL_IRRADIANCE_SH : other[i - 4];
        q.prefilter.irradiance_order = i < 4 ? orders[i] : 0;
        double sec = 0;
        envl_irradiance_map irr;
        if (bench_case("irradiance map %s%s: %s",
                       envl_irradiance_method_name(q.prefilter.irradiance_method),
                       i < 4 ? (const char *[]){" 1", " 2", " 4", " 8"}[i] : "", name) ||
            bench_products(m, &q, o, &sec, NULL, &irr))
            return CLI_FAIL;
        printf(" %.3f (%.4f s) |", 100 * irr.diffuse_error, sec);
        fflush(stdout);
        char series[32];
        snprintf(series, sizeof series, "irradiance-%s",
                 envl_irradiance_method_name(q.prefilter.irradiance_method));
        record(name, "diffuse", series, i < 4 ? orders[i] : 0, 64, irr.diffuse_error, sec);
    }
    printf("\n");
    return CLI_OK;
}

/* The cases of one map's tables (as the three tables above run them), its loading the first. */
static int map_cases(const bench_opts *o)
{
    int n = 1;
    for (int method = 0; method < ENVL_METHOD_COUNT; method++)
        for (int i = 0; i < (o->quick ? 5 : 9) && method != ENVL_METHOD_SUN; i++)
            n += lights_cell(method, light_counts[i]);
    n += ENVL_WINDOW_COUNT * (o->quick ? 4 : 8);
    int nr = o->quick ? 1 : 2, ns = o->quick ? 2 : 4, nw = o->quick ? 2 : 4;
    return n + nr * ns + nr * nw + 7;
}

static void plot_name(const char *map, char *out, size_t n)
{
    size_t k = 0;
    for (const char *p = map; *p && k + 1 < n; p++)
        out[k++] = (char)((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') ||
                                  (*p >= '0' && *p <= '9') || *p == '_' || *p == '-'
                              ? *p
                              : '_');
    out[k] = '\0';
}

/* One PNG per map and error measure (gnuplot): error against seconds, log axes, a curve per
 * series, the Pareto front (no other point both faster and more accurate) drawn over them. */
static int write_plots(const char *dir)
{
    char path[4096];
    int rc = CLI_OK;
    for (int i = 0; i < npoints; i++) {
        int first = 1;
        for (int j = 0; j < i; j++)
            if (!strcmp(points[j].map, points[i].map) && !strcmp(points[j].kind, points[i].kind))
                first = 0;
        if (!first)
            continue;
        const char *map = points[i].map, *kind = points[i].kind;
        char base[160], named[180];
        snprintf(named, sizeof named, "%s-%s", map, kind);
        plot_name(named, base, sizeof base);
        snprintf(path, sizeof path, "%s/%s.dat", dir, base);
        FILE *f = fopen(path, "w");
        if (!f) {
            cli_error("%s: cannot write: %s", path, strerror(errno));
            return CLI_FAIL;
        }
        /* one gnuplot data block per series, then the Pareto front */
        char series[64][32];
        int ns = 0;
        for (int j = 0; j < npoints; j++) {
            if (strcmp(points[j].map, map) || strcmp(points[j].kind, kind))
                continue;
            int known = 0;
            for (int k = 0; k < ns; k++)
                known |= !strcmp(series[k], points[j].series);
            if (!known && ns < 64)
                snprintf(series[ns++], sizeof series[0], "%s", points[j].series);
        }
        for (int k = 0; k < ns; k++) {
            fprintf(f, "# %s\n", series[k]);
            for (int j = 0; j < npoints; j++)
                if (!strcmp(points[j].map, map) && !strcmp(points[j].kind, kind) &&
                    !strcmp(points[j].series, series[k]) &&
                    points[j].error > 0 && points[j].seconds > 0)
                    fprintf(f, "%.9g %.9g %d\n", points[j].seconds, 100 * points[j].error,
                            points[j].param);
            fprintf(f, "\n\n");
        }
        fprintf(f, "# pareto\n");
        double last_err = INFINITY;
        for (;;) { /* increasing seconds, each strictly more accurate than all faster ones */
            int best = -1;
            for (int j = 0; j < npoints; j++) {
                bench_point *p = &points[j];
                if (strcmp(p->map, map) || strcmp(p->kind, kind) ||
                    !(p->error > 0 && p->seconds > 0) ||
                    !(p->error < last_err))
                    continue;
                if (best < 0 || p->seconds < points[best].seconds ||
                    (p->seconds == points[best].seconds && p->error < points[best].error))
                    best = j;
            }
            if (best < 0)
                break;
            /* among points faster than the next candidate none is better: take it */
            fprintf(f, "%.9g %.9g\n", points[best].seconds, 100 * points[best].error);
            last_err = points[best].error;
        }
        fclose(f);
        snprintf(path, sizeof path, "%s/%s.gp", dir, base);
        f = fopen(path, "w");
        if (!f) {
            cli_error("%s: cannot write: %s", path, strerror(errno));
            return CLI_FAIL;
        }
        fprintf(f, "set terminal pngcairo size 900,600 noenhanced\n"
                   "set output '%s/%s.png'\n"
                   "set title 'envlight: %s: %s error against time'\n"
                   "set logscale xy\nset xlabel 'seconds'\nset ylabel '%s error (%%)'\n"
                   "set key outside right\nset grid\n"
                   "plot ", dir, base, map, kind, kind);
        for (int k = 0; k < ns; k++)
            fprintf(f, "'%s/%s.dat' index %d using 1:2 with linespoints title '%s', ", dir,
                    base, k, series[k]);
        fprintf(f, "'%s/%s.dat' index %d using 1:2 with steps lw 3 lc rgb 'black' title "
                   "'Pareto front'\n", dir, base, ns);
        fclose(f);
        char cmd[8300];
        snprintf(cmd, sizeof cmd, "gnuplot '%s' 2>&1", path);
        if (system(cmd) != 0) {
            cli_error("gnuplot failed on %s (is gnuplot installed?)", path);
            rc = CLI_FAIL;
        } else {
            printf("\nplot: %s/%s.png\n", dir, base);
        }
    }
    return rc;
}

/* Speed on a large map: stage time / baseline pass time, both measured here. */
static int bench_speed(int width, const bench_opts *o)
{
    envl_sky_options so = {.width = width};
    envl_envmap *m;
    if (envl_envmap_sky(&so, &m))
        return cli_fail();
    volatile double sink = 0; /* keeps the baseline pass from being optimised away */
    double tb[16], tl[16];
    for (int r = 0; r < o->runs; r++)
        tb[r] = baseline_pass(m, &sink);
    double base = median_of(tb, o->runs);
    for (int r = 0; r < o->runs; r++) {
        envl_envmap_drop_caches(m, ENVL_CACHE_SAT);
        envl_lights *ls;
        envl_lights_options lo = {.method = ENVL_METHOD_MEDIAN, .count = 256};
        if (envl_lights_compute(m, &lo, &ls))
            return cli_fail();
        envl_lights_summary s;
        envl_lights_get_summary(ls, &s);
        tl[r] = s.seconds;
        envl_lights_free(ls);
    }
    double med = median_of(tl, o->runs), ts[16];
    for (int r = 0; r < o->runs; r++) {
        envl_sh *sh;
        if (envl_sh_compute(m, &(envl_sh_options){.order = 2}, &sh))
            return cli_fail();
        envl_sh_summary s;
        envl_sh_get_summary(sh, &s);
        ts[r] = s.seconds;
        envl_sh_free(sh);
    }
    double sh2 = median_of(ts, o->runs);
    printf("\n#### Speed on a %d x %d map (built-in sky), medians of %d runs\n\n", width,
           width / 2, o->runs);
    printf("| stage | seconds | ratio to baseline | target |\n|---|---|---|---|\n");
    printf("| baseline: one pass summing the floats | %.4f | 1.00 | |\n", base);
    printf("| SAT + median cut, 256 lights | %.4f | %.2f | <= 3 |\n", med, med / base);
    printf("| SH order 2 projection | %.4f | %.2f | <= 1.5 |\n", sh2, sh2 / base);
    printf("\npeak resident memory so far: %.0f MiB (the map's floats: %.0f MiB)\n",
           peak_rss_mib(), (double)width * (width / 2) * 12 / (1 << 20));
    envl_envmap_free(m);
    return CLI_OK;
}

/* ---- load speed against OpenImageIO's oiiotool ---------------------------------------------- */

/* Runs argv (looked up in PATH) with stdout and stderr to /dev/null. Returns its wall-clock
 * seconds, or -1 when it cannot start (*missing set when it is not installed) or fails. */
static double time_process(char *const argv[], int *missing)
{
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    pid_t pid;
    double t0 = envl__seconds();
    int err = posix_spawnp(&pid, argv[0], &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (err) {
        *missing = err == ENOENT;
        return -1;
    }
    int status;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR)
            return -1;
    double t = envl__seconds() - t0;
    return WIFEXITED(status) && WEXITSTATUS(status) == 0 ? t : -1;
}

/* A scratch folder under $TMPDIR (default /tmp); its path in dir. */
static int make_scratch(char *dir, size_t n)
{
    const char *tmp = getenv("TMPDIR");
    snprintf(dir, n, "%s/envlight-bench-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    if (!mkdtemp(dir)) {
        cli_error("%s: cannot create a scratch folder: %s", dir, strerror(errno));
        return CLI_FAIL;
    }
    return CLI_OK;
}

/* Median wall seconds of `runs` oiiotool reads (after one untimed warm-up); -1 on failure. */
static double time_oiiotool(const char *path, int runs, int *missing)
{
    /* -i:now=1 reads the whole image into memory as float at once (not lazily through the
     * image cache); with no -o nothing is written. */
    char *argv[] = {"oiiotool", "-i:now=1", (char *)path, NULL};
    double t[16];
    if (time_process(argv, missing) < 0)
        return -1;
    for (int r = 0; r < runs; r++)
        if ((t[r] = time_process(argv, missing)) < 0)
            return -1;
    return median_of(t, runs);
}

/* The built-in sky, then `real` (a file, resampled) if given, each written as a width x width/2
 * adaptive-RLE .hdr and read back by envl_envmap_load (in this process) and by oiiotool (a
 * process). oiiotool's fixed cost (start-up, plugins) is timed on a 1 x 1 .hdr in the same run
 * and subtracted for the decode-only ratio. Ratio = envlight / oiiotool: <= 1 meets the target. */
static int bench_load(int width, const char *real, const bench_opts *o)
{
    char dir[1024], path[1100], tiny[1100];
    if (make_scratch(dir, sizeof dir))
        return CLI_FAIL;
    snprintf(tiny, sizeof tiny, "%s/1x1.hdr", dir);
    const float one[3] = {1, 1, 1};
    int rc = envl_image_save(tiny, one, 1, 1, NULL) ? cli_fail() : CLI_OK;
    int missing = 0;
    double startup = rc ? -1 : time_oiiotool(tiny, o->runs, &missing);
    printf("\n#### Loading a %d x %d .hdr (adaptive RLE): envlight against oiiotool, medians of "
           "%d runs\n\n", width, width / 2, o->runs);
    if (startup < 0 && rc == CLI_OK) {
        printf("SKIP: %s\n", missing ? "oiiotool not installed (Debian: openimageio-tools)"
                                     : "oiiotool failed on a 1 x 1 .hdr");
    } else if (rc == CLI_OK) {
        printf("oiiotool start-up (reading a 1 x 1 .hdr): %.4f s\n\n", startup);
        printf("| map | file MB | envlight load s | oiiotool s | oiiotool - start-up s | "
               "ratio | ratio, start-up subtracted | target |\n|---|---|---|---|---|---|---|---|\n");
    }
    for (int k = 0; k < 2 && rc == CLI_OK && startup >= 0; k++) {
        if (k == 1 && !real)
            break;
        envl_envmap *m;
        cli_common c = {.quiet = 1, .sky = {.width = width}, .load = {.width = k ? width : 0}};
        if (cli_load(k ? real : NULL, &c, &m)) {
            rc = CLI_FAIL;
            break;
        }
        snprintf(path, sizeof path, "%s/map.hdr", dir);
        rc = envl_envmap_save(m, path, NULL) ? cli_fail() : CLI_OK;
        envl_envmap_free(m);
        struct stat st;
        if (rc || stat(path, &st))
            break;
        double t[16];
        for (int r = -1; r < o->runs && rc == CLI_OK; r++) { /* r = -1: warm-up */
            double t0 = envl__seconds();
            if (envl_envmap_load(path, NULL, &m)) {
                rc = cli_fail();
                break;
            }
            if (r >= 0)
                t[r] = envl__seconds() - t0;
            envl_envmap_free(m);
        }
        if (rc)
            break;
        double mine = median_of(t, o->runs), theirs = time_oiiotool(path, o->runs, &missing);
        if (theirs < 0) {
            cli_error("oiiotool failed on %s", path);
            rc = CLI_FAIL;
            break;
        }
        const char *slash = real ? strrchr(real, '/') : NULL;
        char sub[32] = "- (below start-up noise)";
        if (theirs - startup > 0)
            snprintf(sub, sizeof sub, "%.2f", mine / (theirs - startup));
        printf("| %s | %.1f | %.4f | %.4f | %.4f | %.2f | %s | <= 1 |\n",
               k ? (slash ? slash + 1 : real) : "built-in sky", st.st_size / 1e6, mine, theirs,
               theirs - startup, mine / theirs, sub);
        fflush(stdout);
        remove(path);
    }
    remove(tiny);
    rmdir(dir);
    return rc;
}

/* ---- peak memory of the whole pipeline ------------------------------------------------------ */

/* A "VmRSS:" / "VmHWM:" line of /proc/self/status, in MiB (-1 if absent). */
static double status_mib(const char *key)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    double v = -1;
    size_t n = strlen(key);
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, key, n))
            v = atof(line + n) / 1024.0;
    if (f)
        fclose(f);
    return v;
}

/* Starts a new peak: writing 5 to clear_refs resets VmHWM to the current RSS (Linux >= 4.0). */
static int reset_peak(void)
{
    FILE *f = fopen("/proc/self/clear_refs", "w");
    if (!f)
        return 0;
    int ok = fputs("5", f) >= 0;
    return fclose(f) == 0 && ok;
}

typedef struct mem_stage {
    double peak, after;
} mem_stage;

static void mem_row(const char *stage, const char *holds, double peak, double after,
                    double map_mib, double *overall)
{
    printf("| %s | %s | %.0f | %.2f | %.0f |\n", stage, holds, peak, peak / map_mib, after);
    fflush(stdout);
    if (peak > *overall)
        *overall = peak;
}

/* The child: the pipeline stage by stage; after each stage, the stage's own peak (VmHWM since
 * the stage began) and what stays resident. Products are freed after their stage, as the CLI
 * does; the map keeps the tables it caches. Whether the target is met is printed, not
 * returned: CLI_FAIL means the pipeline failed. */
static int memory_child(int width, const char *dir)
{
    double overall = 0, t0 = envl__seconds();
    int exact = reset_peak();
    envl_envmap *m;
    cli_common c = {.quiet = 1, .sky = {.width = width}}; /* no load width: no copy of the sky */
    if (cli_load(NULL, &c, &m))
        return CLI_FAIL;
    int w = envl_envmap_width(m), h = envl_envmap_height(m);
    double map_mib = (double)w * h * 12 / (1 << 20);
    printf("map: the built-in sky, %d x %d, its floats %.0f MiB; peak per stage %s\n\n", w, h,
           map_mib,
           exact ? "(VmHWM reset before each stage)" : "(VmHWM so far: clear_refs unavailable)");
    printf("| stage | holds afterwards | peak MiB | peak / map floats | resident after MiB |\n"
           "|---|---|---|---|---|\n");
    mem_row("built-in sky", "the map", status_mib("VmHWM:"), status_mib("VmRSS:"),
            map_mib, &overall);

    envl_lights *ls;
    reset_peak();
    if (envl_lights_compute(m, &(envl_lights_options){.method = ENVL_METHOD_MEDIAN, .count = 256},
                            &ls))
        return cli_fail();
    envl_lights_free(ls);
    mem_row("lights: median cut, 256", "the map + its cached tables", status_mib("VmHWM:"),
            status_mib("VmRSS:"), map_mib, &overall);

    reset_peak();
    if (envl_lights_compute(m, &(envl_lights_options){.method = ENVL_METHOD_FIT, .count = 4}, &ls))
        return cli_fail();
    char path[1100];
    snprintf(path, sizeof path, "%s/residual.exr", dir);
    envl_result rc = envl_image_save(path, envl_lights_residual(ls), w, h, NULL);
    envl_lights_free(ls);
    remove(path);
    if (rc)
        return cli_fail();
    mem_row("lights: fit 4 + residual saved (.exr)", "same", status_mib("VmHWM:"),
            status_mib("VmRSS:"), map_mib, &overall);

    envl_sh *sh;
    reset_peak();
    if (envl_sh_compute(m, &(envl_sh_options){.order = 2}, &sh))
        return cli_fail();
    envl_sh_free(sh);
    mem_row("SH order 2", "same", status_mib("VmHWM:"), status_mib("VmRSS:"), map_mib, &overall);

    envl_products *p;
    reset_peak();
    if (envl_compute(m, &(envl_request){.irradiance_map = 1, .specular_chain = 1}, &p))
        return cli_fail();
    envl_products_free(p);
    mem_row("prefilter: irradiance map + specular chain", "same + the mip pyramid",
            status_mib("VmHWM:"), status_mib("VmRSS:"), map_mib, &overall);
    envl_envmap_free(m);

    printf("\npeak resident memory of the pipeline: %.0f MiB = %.2f x the map's floats "
           "(target <= 3: %s); %.1f s\n",
           overall, overall / map_mib, overall <= 3 * map_mib ? "met" : "NOT met", envl__seconds() - t0);
    fflush(stdout);
    return CLI_OK;
}

/* Runs memory_child in a forked child, so that its peak is the pipeline's alone. */
static int bench_memory(int width)
{
    char dir[1024];
    if (make_scratch(dir, sizeof dir))
        return CLI_FAIL;
    printf("\n#### Peak resident memory: the whole pipeline in a child process\n\n");
    fflush(stdout);
    pid_t pid = fork();
    if (pid == 0)
        _exit(memory_child(width, dir));
    int status = 0;
    if (pid > 0)
        while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
            ;
    rmdir(dir);
    if (pid < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        cli_error("the memory benchmark's child failed (status %d)", status);
        return CLI_FAIL;
    }
    return CLI_OK;
}

static const cli_command bench_command = {
    "bench",
    "Usage: envlight bench [FILES...] [--runs N] [--quick] [--csv FILE] [--plots DIR]\n"
    "                      [--speed-width W] [--load-width W] [--memory-width W] [--only STEP]\n"
    "Accuracy against time as Markdown tables: every lights method at 1..256 lights (fit to\n"
    "16), diffuse error and median seconds of N runs (default 3), each from scratch. Default\n"
    "maps: the built-in sky and every .hdr under $ENVL_SHARED_DATA/latlong_hdri (default\n"
    "../shared/data). Then the speed of the stages on a large map as ratios to one plain pass\n"
    "over its floats measured in the same run.\n"
    "Also SH orders 1..8 with each window; the GGX level of roughness 0.25 and 0.5 against\n"
    "samples (M = 16..1024) and the base level's width (128..1024), glossy error; the\n"
    "irradiance map by SH (orders 1, 2, 4, 8), resampled and exact sums, diffuse error.\n",
    NULL};

int cli_bench(int argc, char **argv)
{
    cli_common c = {0};
    bench_opts o = {.runs = 3};
    const char *files[256], *csv_path = NULL, *plots = NULL;
    int nfiles = 0;
    int speed_width = 8192, load_width = 4096, memory_width = 8192;
    enum { TABLES = 1, SPEED = 2, LOAD = 4, MEMORY = 8 };
    int only = 0;
    cli_option t[] = {
        CLI_OPTION("--runs", "N", CLI_INT, .min = 1, .max = 15, .value = &o.runs,
                   .help = "runs of each measure, the median reported (default 3)"),
        CLI_OPTION("--quick", NULL, CLI_FLAG, .value = &o.quick,
                   .help = "fewer points (the test's run)"),
        CLI_OPTION("--csv", "FILE", CLI_TEXT, .value = &csv_path, .takes = "a file name",
                   .help = "every point (map, measure, series, param, count, error, seconds)"),
        CLI_OPTION("--plots", "DIR", CLI_TEXT, .value = &plots, .takes = "a folder",
                   .help = "one PNG per map and error measure (gnuplot): error against\n"
                           "seconds, log axes, the Pareto front marked"),
        CLI_OPTION("--speed-width", "W", CLI_INT, .min = 0, .max = 65536, .value = &speed_width,
                   .help = "the stages' speed on a W x W/2 map (default 8192; 0 skips)"),
        CLI_OPTION("--load-width", "W", CLI_INT, .min = 0, .max = 32767, .value = &load_width,
                   .help = "load: the built-in sky and the first real FILE, resampled to\n"
                           "W x W/2 (default 4096; 0 skips) and written as RLE .hdr, read by\n"
                           "envlight and by oiiotool -i:now=1 (OpenImageIO), with oiiotool's\n"
                           "start-up on a 1 x 1 file timed apart"),
        CLI_OPTION("--memory-width", "W", CLI_INT, .min = 0, .max = 65536,
                   .value = &memory_width,
                   .help = "memory: the whole pipeline on a W x W/2 built-in sky (default\n"
                           "8192; 0 skips) in a child process: its peak resident memory per\n"
                           "stage against the map's floats"),
        CLI_OPTION("--only", "STEP", CLI_CHOICE, .value = &only, .bits = 1,
                   .choices = "tables|speed|load|memory",
                   .help = "run that step alone (repeatable)"),
    };
    int parsed = cli_parse(&bench_command, t, CLI_COUNT(t), &c, argc, argv, files, 256, &nfiles);
    if (parsed)
        return parsed == CLI_HELP ? CLI_OK : parsed;
    static char found[64][2048];
    if (!nfiles) {
        files[nfiles++] = "-";
        const char *root = getenv("ENVL_SHARED_DATA");
        char dir[1024];
        snprintf(dir, sizeof dir, "%s/latlong_hdri", root ? root : "../shared/data");
        DIR *d = opendir(dir);
        if (d) {
            struct dirent *e;
            int k = 0;
            while ((e = readdir(d)) && k < 64) {
                size_t l = strlen(e->d_name);
                if (l > 4 && l < 512 && !strcmp(e->d_name + l - 4, ".hdr"))
                    snprintf(found[k++], sizeof found[0], "%.1000s/%.511s", dir, e->d_name);
            }
            closedir(d);
            qsort(found, k, sizeof found[0], (int (*)(const void *, const void *))strcmp);
            for (int i = 0; i < k; i++)
                files[nfiles++] = found[i];
        } else if (!c.quiet) {
            fprintf(stderr, "envlight bench: %s absent: the built-in sky only\n", dir);
        }
    }
    if (cli_outputs_ok(files, nfiles, &csv_path, 1))
        return CLI_FAIL;
    if (!only)
        only = TABLES | SPEED | LOAD | MEMORY;
    progress.total = ((only & TABLES) ? nfiles * map_cases(&o) : 0) +
                     (speed_width > 0 && (only & SPEED)) + (load_width > 0 && (only & LOAD)) +
                     (memory_width > 0 && (only & MEMORY));
    /* with the tables on the same terminal, their cells (printed as measured) are the progress:
     * a progress line would be written into their rows */
    if (progress.total > 0 && !isatty(STDOUT_FILENO) && (progress.shown = cli_progress_start(&c)))
        envl_set_progress(inner_progress, NULL);
    printf("### envlight bench\n\nmedian of %d runs; error: relative RMS irradiance error over "
           "1024 normals against the exact integrator\n", o.runs);
    int rc = CLI_OK;
    for (int i = 0; i < nfiles && rc == CLI_OK && (only & TABLES); i++) {
        envl_envmap *m;
        c.quiet = 1;
        const char *slash = strrchr(files[i], '/');
        const char *name = !strcmp(files[i], "-") ? "built-in sky" : slash ? slash + 1 : files[i];
        if (bench_case("loading %s", name) || cli_load(files[i], &c, &m)) {
            rc = CLI_FAIL;
            break;
        }
        rc = bench_lights_table(name, m, &o);
        if (rc == CLI_OK)
            rc = bench_sh_table(name, m, &o);
        if (rc == CLI_OK)
            rc = bench_prefilter_table(name, m, &o);
        envl_envmap_free(m);
    }
    if (rc == CLI_OK && speed_width > 0 && (only & SPEED))
        rc = bench_case("speed on a %d-wide map", speed_width)
                 ? CLI_FAIL
                 : bench_speed((int)speed_width, &o);
    if (rc == CLI_OK && load_width > 0 && (only & LOAD)) {
        const char *real = NULL;
        for (int i = 0; i < nfiles && !real; i++)
            if (strcmp(files[i], "-"))
                real = files[i];
        rc = bench_case("loading a %d-wide .hdr", load_width)
                 ? CLI_FAIL
                 : bench_load((int)load_width, real, &o);
    }
    if (rc == CLI_OK && memory_width > 0 && (only & MEMORY))
        rc = bench_case("peak memory on a %d-wide map", memory_width)
                 ? CLI_FAIL
                 : bench_memory((int)memory_width);
    if (rc == CLI_OK && csv_path) {
        cli_output co;
        if (cli_output_open(&co, csv_path))
            return CLI_FAIL;
        fprintf(co.f, "map,measure,series,param,count,error,seconds\n");
        for (int i = 0; i < npoints; i++)
            fprintf(co.f, "%s,%s,%s,%d,%d,%.9g,%.9g\n", points[i].map, points[i].kind,
                    points[i].series, points[i].param, points[i].count, points[i].error,
                    points[i].seconds);
        rc = cli_output_close(&co);
    }
    if (rc == CLI_OK && plots) {
        mkdir(plots, 0755);
        rc = write_plots(plots);
    }
    free(points);
    if (rc == CLI_OK)
        cli_progress(1.0, "done");
    return rc;
}
