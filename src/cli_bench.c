/* envlight bench: accuracy against time, for every method and knob, as Markdown tables.
 * Times are medians of several runs, each from scratch (cached tables dropped). Speed targets
 * are ratios against a baseline measured in the same run: one pass summing the map's floats. */
#include "cli.h"

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

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
    double t0 = now(), a = 0, b = 0, c = 0, d = 0;
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
    return now() - t0;
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
    char series[32];  /* "median", "variance", "fit", "sh-none", ... : one curve each */
    int param;        /* lights asked, or SH order */
    int count;        /* lights used (SH: coefficients) */
    double error, seconds;
} bench_point;

static bench_point *points;
static int npoints, cap_points;

static void record(const char *map, const char *series, int param, int count, double error,
                   double seconds)
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
    snprintf(b->series, sizeof b->series, "%s", series);
    b->param = param;
    b->count = count;
    b->error = error;
    b->seconds = seconds;
}

/* One lights configuration: median seconds over runs (tables dropped before each), error. */
static int bench_lights_one(envl_envmap *m, int method, int n, const bench_opts *o,
                            double *seconds, double *error, int *count)
{
    double t[16];
    for (int r = 0; r < o->runs; r++) {
        envl_envmap_drop_caches(m, ENVL_CACHE_SAT);
        envl_lights *ls;
        envl_lights_options lo = {.method = method, .count = n};
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

static int bench_lights_table(const char *name, envl_envmap *m, const bench_opts *o)
{
    static const int counts[] = {1, 2, 4, 8, 16, 32, 64, 128, 256};
    int ncounts = o->quick ? 5 : 9;
    printf("\n#### Lights: %s (%d x %d)\n\n", name, envl_envmap_width(m),
           envl_envmap_height(m));
    printf("diffuse error %% (seconds); fit: lights used of those asked, order-2 remainder\n\n");
    printf("| method |");
    for (int i = 0; i < ncounts; i++)
        printf(" %d |", counts[i]);
    printf("\n|---|");
    for (int i = 0; i < ncounts; i++)
        printf("---|");
    printf("\n");
    for (int method = 0; method < ENVL_METHOD_COUNT; method++) {
        printf("| %s |", envl_method_name(method));
        for (int i = 0; i < ncounts; i++) {
            int n = counts[i];
            if (method == ENVL_METHOD_FIT && n > 16) {
                printf(" |");
                continue;
            }
            double sec = 0, err = 0;
            int count = 0;
            if (bench_lights_one(m, method, n, o, &sec, &err, &count))
                return CLI_FAIL;
            if (method == ENVL_METHOD_FIT)
                printf(" %.3f (%.3f s, %d) |", 100 * err, sec, count);
            else
                printf(" %.3f (%.3f s) |", 100 * err, sec);
            fflush(stdout);
            record(name, envl_method_name(method), n, count, err, sec);
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
    printf("\n|---|");
    for (int l = 1; l <= maxorder; l++)
        printf("---|");
    printf("\n");
    for (int w = 0; w < ENVL_WINDOW_COUNT; w++) {
        printf("| %s |", envl_window_name(w));
        for (int l = 1; l <= maxorder; l++) {
            double t[16], err = 0;
            for (int r = 0; r < o->runs; r++) {
                envl_sh *sh;
                if (envl_sh_compute(m, &(envl_sh_options){.bands = l + 1, .window = w}, &sh))
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
            record(name, series, l, (l + 1) * (l + 1), err, sec);
        }
        printf("\n");
    }
    return CLI_OK;
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

/* One PNG per map (gnuplot): error against seconds, log axes, a curve per series, the Pareto
 * front (no other point both faster and more accurate) drawn over them. */
static int write_plots(const char *dir)
{
    char path[4096];
    int rc = CLI_OK;
    for (int i = 0; i < npoints; i++) {
        int first = 1;
        for (int j = 0; j < i; j++)
            if (!strcmp(points[j].map, points[i].map))
                first = 0;
        if (!first)
            continue;
        const char *map = points[i].map;
        char base[160];
        plot_name(map, base, sizeof base);
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
            if (strcmp(points[j].map, map))
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
                if (!strcmp(points[j].map, map) && !strcmp(points[j].series, series[k]) &&
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
                if (strcmp(p->map, map) || !(p->error > 0 && p->seconds > 0) ||
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
                   "set title 'envlight: %s: diffuse error against time'\n"
                   "set logscale xy\nset xlabel 'seconds'\nset ylabel 'diffuse error (%%)'\n"
                   "set key outside right\nset grid\n"
                   "plot ", dir, base, map);
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
        if (envl_sh_compute(m, &(envl_sh_options){.bands = 3}, &sh))
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

static const char bench_help[] =
    "Usage: envlight bench [FILES...] [--runs N] [--quick] [--csv FILE] [--plots DIR]\n"
    "                      [--speed-width W]\n"
    "Accuracy against time as Markdown tables: every lights method at 1..256 lights (fit to\n"
    "16), diffuse error and median seconds of N runs (default 3), each from scratch. Default\n"
    "maps: the built-in sky and every .hdr under $ENVL_SHARED_DATA/latlong_hdri (default\n"
    "../shared/data). Then the speed of the stages on a large map as ratios to one plain pass\n"
    "over its floats measured in the same run (--speed-width, default 8192; 0 skips).\n"
    "Also SH orders 1..8 with each window. --csv writes every point; --plots DIR writes one\n"
    "PNG per map (gnuplot): error against seconds, log axes, the Pareto front marked.\n";

int cli_bench(int argc, char **argv)
{
    cli_common c = {0};
    bench_opts o = {.runs = 3};
    const char *files[256], *csv_path = NULL, *plots = NULL;
    int nfiles = 0;
    long long speed_width = 8192, n;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v;
        int r = cli_common_option("bench", argc, argv, &i, &c);
        if (r < 0)
            return CLI_USAGE;
        if (r > 0)
            continue;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            printf("%s\n%s", bench_help, cli_common_help);
            return CLI_OK;
        }
        if ((r = cli_value(argc, argv, &i, "--runs", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 1, 15, &n))
                return cli_usage("bench", "--runs takes 1..15");
            o.runs = (int)n;
        } else if ((r = cli_value(argc, argv, &i, "--csv", &v)) != 0) {
            if (r < 0)
                return cli_usage("bench", "--csv needs a file name");
            csv_path = v;
        } else if ((r = cli_value(argc, argv, &i, "--plots", &v)) != 0) {
            if (r < 0)
                return cli_usage("bench", "--plots needs a folder");
            plots = v;
        } else if ((r = cli_value(argc, argv, &i, "--speed-width", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 0, 65536, &speed_width))
                return cli_usage("bench", "--speed-width takes 0..65536");
        } else if (!strcmp(a, "--quick")) {
            o.quick = 1;
        } else if (a[0] == '-' && a[1]) {
            return cli_usage("bench", "unknown option '%s'", a);
        } else if (nfiles < 256) {
            files[nfiles++] = a;
        }
    }
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
    printf("### envlight bench\n\nmedian of %d runs; error: relative RMS irradiance error over "
           "1024 normals against the exact integrator\n", o.runs);
    int rc = CLI_OK;
    for (int i = 0; i < nfiles && rc == CLI_OK; i++) {
        envl_envmap *m;
        c.quiet = 1;
        if (cli_load(files[i], &c, &m)) {
            rc = CLI_FAIL;
            break;
        }
        const char *slash = strrchr(files[i], '/');
        const char *name = !strcmp(files[i], "-") ? "built-in sky" : slash ? slash + 1 : files[i];
        rc = bench_lights_table(name, m, &o);
        if (rc == CLI_OK)
            rc = bench_sh_table(name, m, &o);
        envl_envmap_free(m);
    }
    if (rc == CLI_OK && speed_width > 0)
        rc = bench_speed((int)speed_width, &o);
    if (rc == CLI_OK && csv_path) {
        cli_output co;
        if (cli_output_open(&co, csv_path))
            return CLI_FAIL;
        fprintf(co.f, "map,series,param,count,diffuse_error,seconds\n");
        for (int i = 0; i < npoints; i++)
            fprintf(co.f, "%s,%s,%d,%d,%.9g,%.9g\n", points[i].map, points[i].series,
                    points[i].param, points[i].count, points[i].error, points[i].seconds);
        rc = cli_output_close(&co);
    }
    if (rc == CLI_OK && plots) {
        mkdir(plots, 0755);
        rc = write_plots(plots);
    }
    free(points);
    return rc;
}
