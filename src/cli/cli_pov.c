/* envlight pov: a POV-Ray 3.7 include with the lights, the ambient and the sky of an
 * environment, for povray_include/envlight.inc's macros.
 *
 * Frames. The canonical frame is Blender's (right-handed, +Z up); POV-Ray's is left-handed,
 * +Y up. A canonical vector (x, y, z) is written as the POV-Ray vector <x, z, y> (a swap of
 * two axes: it turns the right-handed frame into the left-handed one and keeps every angle).
 *
 * Ambient. Whatever the lights did not take becomes the ambient irradiance E_a(n), an SH
 * expansion of order L (the fit's remainder, or the SH of the residual map of a cut). POV-Ray
 * cannot evaluate SH of the normal, but its `slope { d }` pattern gives a value that depends on
 * n . d only, and a colour_map turns that value into any function of n . d. So E_a is written as
 * a sum of ridge functions g_k(d_k . n), each a Legendre series sum_l C[k][l] P_l(d_k . n):
 * by the addition theorem, P_l(d . n) = 4 pi / (2l + 1) sum_m Y_lm(d) Y_lm(n), so band l of E_a,
 * sum_m c_lm Y_lm(n), is matched exactly when sum_k C[k][l] Y_lm(d_k) = (2l + 1) / (4 pi) c_lm
 * for every m: 2l + 1 equations in K unknowns; we take the least-norm solution
 * C = M^T (M M^T)^-1 b, M[m][k] = Y_lm(d_k), with K = 2L + 5 directions on a Fibonacci spiral
 * of the upper hemisphere (the Gram matrices M M^T then have condition numbers below ~300 up
 * to L = 8; checked below at 1024 normals to 1e-9). The hemispheric form is one term: the axis,
 * C[0][0] = (sky + ground) / 2, C[0][1] = (sky - ground) / 2.
 */
#include "cli.h"
#include "clock.h"
#include "pov_recipe.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define POV_MAX_ORDER 8
/* The dome's own (unoccluded) diffuse error it grows until it meets: its lights are a
 * quadrature of the sky, and this keeps that part well below the in-scene errors. */
#define POV_DOME_ERROR 0.005
/* The dome under radiosity: its lights are also what each radiosity sample gathers, so their
 * number sets the cost. Variance cut (whose regions follow the sky's spread, not its energy:
 * 0.75-1.3 % unoccluded error with 32 lights where median cut has 2.1-3.9 %), 32 lights, or 64
 * where 32 leave more than POV_DOME_BOUNCE_ERROR: the scene benchmark's choice
 * (docs/scene_bench_pov.md). */
#define POV_DOME_BOUNCE_ERROR 0.01
/* --exposure auto: the value a white surface facing up shows (sRGB ~0.8 in an 8-bit image). */
#define POV_AUTO_WHITE 0.6

static const char pov_help[] =
    "Usage: envlight pov [FILE] -o OUT.inc [--scene SCENE.pov] [--recipe R] [--ground ALBEDO]\n"
    "                    [--shadows hard|soft|none] [--sky] [--exposure auto|E]\n"
    "                    [-n N] [--method fit|median|variance] [--order L]\n"
    "                    [--ambient sh|hemi|none] [--sky-image PATH] [--sky-residual]\n"
    "                    [--scene-radius R] [--no-place] [input options]\n"
    "A POV-Ray 3.7 include (POV-Ray's frame: left-handed, +Y up; POV <x,y,z> = canonical\n"
    "<x,z,y>) for povray_include/envlight.inc: light directions and colours (rgb / pi), the\n"
    "ambient that the lights did not take, the sky; then the macro calls that place them.\n"
    "  --scene SCENE     the scene the include is for: what it uses (shadows between\n"
    "                    objects, glossy finishes, a ground plane and its colour, radiosity)\n"
    "                    picks the recipe and the ground; a scene it cannot read is a\n"
    "                    warning and the defaults apply\n"
    "  --recipe R        auto (default: from the scene, see the header's reasons), dome\n"
    "                    (32 or 64 variance-cut lights of the sky, by their error, with\n"
    "                    shadows + radiosity with no sky for the bounces), dome-ambient\n"
    "                    (median-cut lights, 64-256 by their error, + the ground's bounce\n"
    "                    as an ambient, no radiosity), sh (4 fitted lights + SH ambient:\n"
    "                    exact without occlusion),\n"
    "                    image-radiosity (4 fitted lights + the residual sky under\n"
    "                    radiosity); -n/--method/--ambient/--order alone: custom\n"
    "  -n N              lights (custom default 4; dome 32-64; dome-ambient 64-256)\n"
    "  --method M        fit (custom default: lights + SH remainder), median, variance\n"
    "  --order L         SH order of the ambient (fit: of its remainder), 0..8 (default 2);\n"
    "                    fit: -1 fits lights alone (the default with --ambient none)\n"
    "  --ambient A       sh (custom default): the SH ambient as slope-pattern pigments (no\n"
    "                    radiosity needed); hemi: its best sky/ground/axis form; none\n"
    "  --ground A        the scene stands on a ground plane (POV-Ray y = 0) of albedo A\n"
    "                    (0..1): lights, ambient and error are computed from the map with its\n"
    "                    lower hemisphere replaced by the plane's radiance A E_up / pi (E_up:\n"
    "                    the map's exact irradiance at the normal +Z); the ambient then holds\n"
    "                    the plane's bounce and no light comes from below the horizon\n"
    "  --shadows S       hard (default), soft (area lights sized by each light's angular\n"
    "                    diameter), none (shadowless lights)\n"
    "  --sky             declare the environment as a sky_sphere (EnvLight_Sky())\n"
    "  --sky-image PATH  where to write the sky's lat-long .hdr (default: OUT without .inc +\n"
    "                    _sky.hdr; a lat-long .hdr input is used as it is when not given)\n"
    "  --sky-residual    the sky shows the residual (what the lights did not take)\n"
    "  --scene-radius R  lights are placed at 2 R from the scene centre (default 100)\n"
    "  --exposure E      auto or a number: the default of EnvLight_Exposure, which scales\n"
    "                    everything envlight adds (auto: a white surface facing up reads\n"
    "                    0.6, for an 8-bit image; default 1: the map's radiometry)\n"
    "  --no-place        only declare: the scene calls EnvLight_Place_Lights() etc. itself\n"
    "  -o OUT            the include, written atomically (default: stdout)\n"
    "The header states the source, the options, the diffuse error of lights + ambient against\n"
    "the exact integrator and the seconds it took.\n";

/* ---- POV-Ray text ---- */

/* A POV-Ray string literal: quotes, with \ and " escaped. Control characters cannot be
 * written safely; the caller checks pov_string_ok first. */
static int pov_string_ok(const char *s)
{
    for (const unsigned char *p = (const unsigned char *)s; *p; p++)
        if (*p < 0x20 || *p == 0x7f)
            return 0;
    return 1;
}

static void pov_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        if (*s == '\\' || *s == '"')
            fputc('\\', f);
        fputc(*s, f);
    }
    fputc('"', f);
}

/* Text inside a // comment: control characters (a newline would end the comment) become '?'. */
static void pov_comment_text(FILE *f, const char *s)
{
    for (const unsigned char *p = (const unsigned char *)s; *p; p++)
        fputc(*p < 0x20 || *p == 0x7f ? '?' : *p, f);
}

/* Canonical (x, y, z) -> POV-Ray <x, z, y>. */
static void pov_vector(FILE *f, const double v[3])
{
    fprintf(f, "<%.9g, %.9g, %.9g>", v[0], v[2], v[1]);
}

static void pov_rgb(FILE *f, const double c[3], double scale)
{
    fprintf(f, "<%.9g, %.9g, %.9g>", c[0] * scale, c[1] * scale, c[2] * scale);
}

/* ---- ambient as ridge functions ---- */

typedef struct ridge {
    int terms, order;              /* K directions, Legendre degree L */
    double dir[2 * POV_MAX_ORDER + 5][3];               /* canonical frame */
    double coef[2 * POV_MAX_ORDER + 5][POV_MAX_ORDER + 1][3]; /* irradiance */
} ridge;

static double legendre(int l, double c)
{
    double p0 = 1, p1 = c;
    if (l == 0)
        return 1;
    for (int k = 1; k < l; k++) {
        double p2 = ((2 * k + 1) * c * p1 - k * p0) / (k + 1);
        p0 = p1;
        p1 = p2;
    }
    return p1;
}

static void ridge_eval(const ridge *r, const double n[3], double out[3])
{
    out[0] = out[1] = out[2] = 0;
    for (int k = 0; k < r->terms; k++) {
        double c = n[0] * r->dir[k][0] + n[1] * r->dir[k][1] + n[2] * r->dir[k][2];
        for (int l = 0; l <= r->order; l++) {
            double p = legendre(l, c);
            for (int ch = 0; ch < 3; ch++)
                out[ch] += r->coef[k][l][ch] * p;
        }
    }
}

static void sh_eval_rgb(int order, const double *coef, const double n[3], double out[3])
{
    double y[(POV_MAX_ORDER + 1) * (POV_MAX_ORDER + 1)];
    envl_sh_basis(order, n, y);
    out[0] = out[1] = out[2] = 0;
    for (int j = 0; j < (order + 1) * (order + 1); j++)
        for (int ch = 0; ch < 3; ch++)
            out[ch] += coef[3 * j + ch] * y[j];
}

/* Solves A x = b (n x n, row-major, A and b destroyed) by Gaussian elimination with partial
 * pivoting; -1 if singular. */
static int solve(int n, double *a, double *b)
{
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int r = c + 1; r < n; r++)
            if (fabs(a[r * n + c]) > fabs(a[p * n + c]))
                p = r;
        if (fabs(a[p * n + c]) < 1e-300)
            return -1;
        if (p != c) {
            for (int k = 0; k < n; k++) {
                double t = a[c * n + k];
                a[c * n + k] = a[p * n + k];
                a[p * n + k] = t;
            }
            double t = b[c];
            b[c] = b[p];
            b[p] = t;
        }
        for (int r = c + 1; r < n; r++) {
            double f = a[r * n + c] / a[c * n + c];
            for (int k = c; k < n; k++)
                a[r * n + k] -= f * a[c * n + k];
            b[r] -= f * b[c];
        }
    }
    for (int c = n - 1; c >= 0; c--) {
        for (int k = c + 1; k < n; k++)
            b[c] -= a[c * n + k] * b[k];
        b[c] /= a[c * n + c];
    }
    return 0;
}

/* Irradiance SH of order L (canonical frame) -> ridge functions (see the top of the file).
 * Returns the largest deviation at 1024 normals relative to the largest |E|, or -1. */
static double ridge_from_sh(int order, const double *sh, ridge *r)
{
    memset(r, 0, sizeof *r);
    r->order = order;
    r->terms = order == 0 ? 1 : 2 * order + 5;
    for (int k = 0; k < r->terms; k++) {
        /* Fibonacci spiral on the upper hemisphere (antipodal directions would be redundant). */
        double z = r->terms == 1 ? 1 : 1 - (k + 0.5) / r->terms;
        double s = sqrt(1 - z * z), ph = k * ENVL_PI * (3 - sqrt(5.0));
        r->dir[k][0] = s * cos(ph);
        r->dir[k][1] = s * sin(ph);
        r->dir[k][2] = z;
    }
    int nc = (order + 1) * (order + 1), K = r->terms;
    double y[2 * POV_MAX_ORDER + 5][(POV_MAX_ORDER + 1) * (POV_MAX_ORDER + 1)];
    for (int k = 0; k < K; k++)
        envl_sh_basis(order, r->dir[k], y[k]);
    for (int l = 0; l <= order; l++) {
        int m = 2 * l + 1, base = l * l;
        double g[17 * 17], rhs[17];
        for (int ch = 0; ch < 3; ch++) {
            /* Gram M M^T and b = (2l+1)/(4 pi) c_lm */
            for (int i = 0; i < m; i++) {
                for (int j = 0; j < m; j++) {
                    double s = 0;
                    for (int k = 0; k < K; k++)
                        s += y[k][base + i] * y[k][base + j];
                    g[i * m + j] = s;
                }
                rhs[i] = (2 * l + 1) / (4 * ENVL_PI) * sh[3 * (base + i) + ch];
            }
            if (solve(m, g, rhs))
                return -1;
            for (int k = 0; k < K; k++) {
                double s = 0;
                for (int i = 0; i < m; i++)
                    s += y[k][base + i] * rhs[i];
                r->coef[k][l][ch] = s;
            }
        }
    }
    double worst = 0, scale = 0;
    for (int i = 0; i < ENVL_ERROR_NORMALS; i++) {
        double n[3], a[3], b[3];
        envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, n);
        sh_eval_rgb(order, sh, n, a);
        ridge_eval(r, n, b);
        for (int ch = 0; ch < 3; ch++) {
            worst = fmax(worst, fabs(a[ch] - b[ch]));
            scale = fmax(scale, fabs(a[ch]));
        }
    }
    (void)nc;
    return scale > 0 ? worst / scale : worst;
}

/* Hemispheric form of an irradiance SH (bands 0 and 1), as sh.c computes it: axis along the
 * luminance gradient, E ~ ambient + c1 (axis . n); sky = E(axis), ground = E(-axis). */
static void hemi_from_sh(int order, const double *sh, double axis[3], double sky[3],
                         double ground[3])
{
    const double y00 = 0.28209479177387814, y1 = 0.4886025119029199;
    double amb[3], d[3][3], dy[3];
    for (int ch = 0; ch < 3; ch++) {
        amb[ch] = y00 * sh[ch];
        d[0][ch] = order >= 1 ? y1 * sh[3 * 3 + ch] : 0;
        d[1][ch] = order >= 1 ? y1 * sh[3 * 1 + ch] : 0;
        d[2][ch] = order >= 1 ? y1 * sh[3 * 2 + ch] : 0;
    }
    for (int a = 0; a < 3; a++)
        dy[a] = envl_luminance(d[a][0], d[a][1], d[a][2]);
    double len = sqrt(dy[0] * dy[0] + dy[1] * dy[1] + dy[2] * dy[2]);
    for (int a = 0; a < 3; a++)
        axis[a] = len > 0 ? dy[a] / len : (a == 2);
    for (int ch = 0; ch < 3; ch++) {
        double c1 = 0;
        for (int a = 0; a < 3; a++)
            c1 += d[a][ch] * axis[a];
        /* Never negative, as sh.c's hemi_pair: when amb - |c1| < 0 the best fit with sky,
         * ground >= 0 puts 0 at the negative end and (3 amb + |c1|) / 2 at the other. */
        double lit = (3 * amb[ch] + fabs(c1)) / 2;
        int clamp = amb[ch] - fabs(c1) < 0;
        sky[ch] = !clamp ? amb[ch] + c1 : c1 > 0 ? lit : 0;
        ground[ch] = !clamp ? amb[ch] - c1 : c1 > 0 ? 0 : lit;
    }
}

/* The least channel of the ambient as written (ridge form) at 4096 Fibonacci normals, and
 * how many of them are negative in some channel. */
static double ridge_least(const ridge *r, int *negative)
{
    double least = INFINITY;
    *negative = 0;
    for (int i = 0; i < 4096; i++) {
        double n[3], a[3];
        envl_fibonacci_direction(i, 4096, n);
        ridge_eval(r, n, a);
        double m = fmin(a[0], fmin(a[1], a[2]));
        least = fmin(least, m);
        *negative += m < 0;
    }
    return least;
}

/* ---- the command ---- */

enum { AMB_SH, AMB_HEMI, AMB_NONE };
enum { SHADOW_NONE, SHADOW_HARD, SHADOW_SOFT };

/* Diffuse error of what is emitted: lights (+ the ambient rd, may be NULL) against the exact
 * irradiance ref at docs/design.md's 1024 normals; emit receives the emitted irradiance. */
static double emitted_error(const envl_lights *ls, const ridge *rd, const double *ref,
                            double *emit)
{
    int32_t count = envl_lights_count(ls);
    for (int i = 0; i < ENVL_ERROR_NORMALS; i++) {
        double n[3], e[3] = {0, 0, 0};
        envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, n);
        for (int j = 0; j < count; j++) {
            envl_light l;
            envl_lights_get(ls, j, &l);
            double d = n[0] * l.direction[0] + n[1] * l.direction[1] + n[2] * l.direction[2];
            for (int ch = 0; ch < 3; ch++)
                e[ch] += d > 0 ? l.rgb[ch] * d : 0;
        }
        if (rd) {
            double a[3];
            ridge_eval(rd, n, a);
            for (int ch = 0; ch < 3; ch++)
                e[ch] += a[ch];
        }
        memcpy(emit + 3 * i, e, sizeof e);
    }
    return envl_relative_rms_luminance(ENVL_ERROR_NORMALS, emit, ref);
}

/* `#include "envlight.inc"`: from POV-Ray's library path (+L) when it is there, else from
 * this build's povray_include/ (so a scene renders without +L). */
static void pov_include_envlight(FILE *f)
{
#ifdef ENVL_POV_INCLUDE_DIR
    const char *path = ENVL_POV_INCLUDE_DIR "/envlight.inc";
    if (access(path, R_OK) == 0 && pov_string_ok(path)) {
        fputs("#if (file_exists(\"envlight.inc\"))\n#include \"envlight.inc\"\n#else\n#include ", f);
        pov_string(f, path);
        fputs("\n#end\n", f);
        return;
    }
#endif
    fputs("#include \"envlight.inc\" // POV-Ray's +L: the folder of envlight.inc\n", f);
}

/* The header's account of the recipe: which, why, what the scene gets and what was skipped,
 * and the in-scene error the scene benchmark measured for it. */
static void pov_header_recipe(FILE *f, int recipe, const char *why, const pov_scene *scene,
                              const char *ground_from, int sky, int has_ambient, int dome_count,
                              int bounce)
{
    fprintf(f, "// recipe: %s: %s\n", pov_recipe_name(recipe), why);
    if (bounce)
        fputs("//   bounces: radiosity with no sky in it (EnvLight_Bounce_Settings(): recursion "
              "2, count 50),\n//   the lights' light gathered from the surfaces it reached "
              "(occluded like the lights)\n", f);
    if (dome_count)
        fprintf(f, "//   dome of %d lights: the smallest of %s whose diffuse error is within "
                "%.1f %%\n", dome_count, bounce ? "32, 64" : "64, 128, 256",
                100 * (bounce ? POV_DOME_BOUNCE_ERROR : POV_DOME_ERROR));
    if (scene)
        fprintf(f, "// scene: %d object%s (%d casting shadows)%s%s%s\n", scene->objects,
                scene->objects == 1 ? "" : "s",
                scene->casters, scene->glossy ? ", glossy finishes" : ", matte finishes only",
                scene->ground ? ", a ground plane" : ", no ground plane",
                scene->radiosity ? ", radiosity" : "");
    if (ground_from)
        fprintf(f, "// ground: albedo from %s\n", ground_from);
    fputs("// skipped:", f);
    int any = 0;
    if (!ground_from && recipe != POV_RECIPE_IMAGE_RADIOSITY && !bounce) {
        fputs(" the ground's bounce (no ground plane: --ground ALBEDO or a plane in --scene);", f);
        any = 1;
    }
    if (!has_ambient && recipe != POV_RECIPE_IMAGE_RADIOSITY) {
        fputs(bounce ? " an ambient (the lights take the whole sky, radiosity the bounces);"
                     : " an ambient (the lights take the whole sky);", f);
        any = 1;
    }
    if (recipe == POV_RECIPE_DOME && !bounce) {
        fputs(" radiosity for bounces (one object: nothing to bounce between);", f);
        any = 1;
    }
    if (!sky) {
        fputs(" the sky image (not asked for: --sky);", f);
        any = 1;
    }
    if (recipe != POV_RECIPE_IMAGE_RADIOSITY && recipe != POV_RECIPE_DOME) {
        fputs(" radiosity (not needed);", f);
        any = 1;
    }
    if (scene && !scene->glossy) {
        fputs(" highlights (no glossy finish in the scene);", f);
        any = 1;
    }
    fputs(any ? "\n" : " nothing\n", f);
    /* the dome's figures are those of the dome with its bounce pass */
    const char *expected = recipe == POV_RECIPE_DOME && !bounce
                               ? NULL
                               : pov_recipe_expected_error(recipe);
    fprintf(f, "// in-scene error to expect (scene benchmark, not this map): %s\n",
            expected ? expected : "not measured for this recipe");
}

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}

int cli_pov(int argc, char **argv)
{
    cli_common c = {0};
    const char *file = NULL, *out = NULL, *sky_image = NULL;
    envl_lights_options lo = {.method = ENVL_METHOD_FIT, .count = 4};
    int order = 2, order_set = 0, ambient = AMB_SH, shadows = SHADOW_HARD, sky = 0;
    int sky_residual = 0, place = 1, recipe = -1;
    int method_set = 0, count_set = 0, ambient_set = 0;
    const char *scene_path = NULL;
    double radius = 100, ground = -1; /* ground < 0: no ground plane */
    double exposure = 0;              /* 0: not given; -1: auto */
    double ground_radiance[3] = {0, 0, 0};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v;
        long long n;
        int r = cli_common_option("pov", argc, argv, &i, &c);
        if (r < 0)
            return CLI_USAGE;
        if (r > 0)
            continue;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            printf("%s\n%s", pov_help, cli_common_help);
            return CLI_OK;
        }
        if ((r = cli_value(argc, argv, &i, "-n", &v)) != 0 ||
            (r = cli_value(argc, argv, &i, "--count", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 1, 1 << 16, &n))
                return cli_usage("pov", "-n takes a number of lights, 1..65536");
            lo.count = (int32_t)n;
            count_set = 1;
        } else if ((r = cli_value(argc, argv, &i, "--method", &v)) != 0) {
            /* sun: the suns alone (the rest is a residual map, which an include carries only
             * as the image-radiosity recipe's sky): not a light set for POV-Ray on its own */
            if (r < 0 || (lo.method = envl_method_from_name(v)) < 0 ||
                lo.method == ENVL_METHOD_SUN)
                return cli_usage("pov", "--method takes fit, median or variance");
            method_set = 1;
        } else if ((r = cli_value(argc, argv, &i, "--recipe", &v)) != 0) {
            if (r < 0 || (recipe = pov_recipe_from_name(v)) < 0)
                return cli_usage("pov", "--recipe takes auto, dome, dome-ambient, sh or "
                                 "image-radiosity");
        } else if ((r = cli_value(argc, argv, &i, "--scene", &v)) != 0) {
            if (r < 0 || !*v)
                return cli_usage("pov", "--scene needs the scene's .pov file");
            scene_path = v;
        } else if ((r = cli_value(argc, argv, &i, "--order", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, -1, POV_MAX_ORDER, &n))
                return cli_usage("pov", "--order takes -1..%d", POV_MAX_ORDER);
            order = (int)n;
            order_set = 1;
        } else if ((r = cli_value(argc, argv, &i, "--ambient", &v)) != 0) {
            if (r < 0)
                return cli_usage("pov", "--ambient takes sh, hemi or none");
            if (!strcmp(v, "sh"))
                ambient = AMB_SH;
            else if (!strcmp(v, "hemi"))
                ambient = AMB_HEMI;
            else if (!strcmp(v, "none"))
                ambient = AMB_NONE;
            else
                return cli_usage("pov", "--ambient takes sh, hemi or none");
            ambient_set = 1;
        } else if ((r = cli_value(argc, argv, &i, "--shadows", &v)) != 0) {
            if (r < 0)
                return cli_usage("pov", "--shadows takes hard, soft or none");
            if (!strcmp(v, "hard"))
                shadows = SHADOW_HARD;
            else if (!strcmp(v, "soft"))
                shadows = SHADOW_SOFT;
            else if (!strcmp(v, "none"))
                shadows = SHADOW_NONE;
            else
                return cli_usage("pov", "--shadows takes hard, soft or none");
        } else if ((r = cli_value(argc, argv, &i, "--scene-radius", &v)) != 0) {
            if (r < 0 || cli_parse_double(v, &radius) || !(radius > 0) || radius > 1e12)
                return cli_usage("pov", "--scene-radius takes a positive number");
        } else if ((r = cli_value(argc, argv, &i, "--ground", &v)) != 0) {
            if (r < 0 || cli_parse_double(v, &ground) || !(ground >= 0 && ground <= 1))
                return cli_usage("pov", "--ground takes the plane's albedo, a number within "
                                 "[0, 1]");
        } else if ((r = cli_value(argc, argv, &i, "--exposure", &v)) != 0) {
            if (r < 0 || (strcmp(v, "auto") && (cli_parse_double(v, &exposure) ||
                                                !(exposure > 0) || exposure > 1e12)))
                return cli_usage("pov", "--exposure takes auto or a positive number");
            if (!strcmp(v, "auto"))
                exposure = -1;
        } else if ((r = cli_value(argc, argv, &i, "--sky-image", &v)) != 0) {
            if (r < 0 || !*v)
                return cli_usage("pov", "--sky-image needs a file name");
            sky_image = v;
        } else if ((r = cli_value(argc, argv, &i, "-o", &v)) != 0) {
            if (r < 0)
                return cli_usage("pov", "-o needs a file name");
            out = v;
        } else if (!strcmp(a, "--sky")) {
            sky = 1;
        } else if (!strcmp(a, "--sky-residual")) {
            sky = sky_residual = 1;
        } else if (!strcmp(a, "--no-place")) {
            place = 0;
        } else if (a[0] == '-' && a[1]) {
            return cli_usage("pov", "unknown option '%s'", a);
        } else if (file) {
            return cli_usage("pov", "one FILE only");
        } else {
            file = a;
        }
    }
    /* What the scene uses (--scene): read tolerantly; a scene it cannot read is a warning and
     * the defaults apply. */
    pov_scene scene_uses;
    const pov_scene *scene = NULL;
    if (scene_path) {
        if (pov_scene_read(scene_path, &scene_uses) == 0) {
            scene = &scene_uses;
            if (scene_uses.note[0] && !c.quiet)
                cli_error("pov: warning: scene %s: %s (read as far as it goes)", scene_path,
                          scene_uses.note);
        } else if (!c.quiet) {
            cli_error("pov: warning: %s; the defaults apply", scene_uses.note);
        }
    }
    const char *ground_from = ground >= 0 ? "--ground" : NULL;
    if (ground < 0 && scene && scene->ground) {
        ground = scene->ground_albedo >= 0 ? fmax(0, fmin(scene->ground_albedo, 1)) : 0.5;
        ground_from = scene->ground_albedo >= 0
                          ? "the scene's plane"
                          : "the scene's plane, whose colour is not a literal: 0.5 assumed";
    }

    /* The recipe: given, implied by the low-level options (custom), or picked (auto). */
    char why[320];
    if (recipe < 0)
        recipe = method_set || count_set || ambient_set || order_set ? POV_RECIPE_CUSTOM
                                                                     : POV_RECIPE_AUTO;
    if (recipe == POV_RECIPE_AUTO)
        recipe = pov_recipe_pick(scene, shadows != SHADOW_NONE, why, sizeof why);
    else
        snprintf(why, sizeof why, "%s", recipe == POV_RECIPE_CUSTOM ? "the options given"
                                                                     : "--recipe");
    int dome_auto_count = 0, bounce = 0;
    if (recipe == POV_RECIPE_SH || recipe == POV_RECIPE_IMAGE_RADIOSITY) {
        if (!method_set)
            lo.method = ENVL_METHOD_FIT;
        if (!count_set)
            lo.count = 4;
    }
    if (recipe == POV_RECIPE_DOME) {
        if (!method_set)
            lo.method = ENVL_METHOD_VARIANCE;
        dome_auto_count = !count_set;
        if (!ambient_set) /* the lights take the whole sky, radiosity the bounces */
            ambient = AMB_NONE;
        bounce = pov_recipe_bounces(scene);
    }
    if (recipe == POV_RECIPE_DOME_AMBIENT) {
        if (!method_set)
            lo.method = ENVL_METHOD_MEDIAN;
        dome_auto_count = !count_set;
        if (!ambient_set) /* the cut takes the whole sky: the ambient is the ground's bounce */
            ambient = ground >= 0 ? AMB_SH : AMB_NONE;
    }
    if (recipe == POV_RECIPE_IMAGE_RADIOSITY) {
        if (!ambient_set)
            ambient = AMB_NONE; /* the residual sky under radiosity carries it */
        if (!order_set)
            order_set = 1;      /* the fit keeps its order-2 remainder: its lights stay peaks */
        sky = sky_residual = 1;
        if (ground >= 0 && ground_from && !strcmp(ground_from, "--ground") && !c.quiet)
            cli_error("pov: warning: --ground is not used by image-radiosity: radiosity "
                      "bounces the scene's own plane");
        ground = -1;
        ground_from = NULL;
    }
    if (!cli_light_count_ok("pov", &lo)) /* the method is known now (given or the recipe's) */
        return CLI_USAGE;
    if (lo.method == ENVL_METHOD_FIT)
        lo.remainder_order = (ambient == AMB_NONE && !order_set) || order < 0
                                 ? ENVL_REMAINDER_NONE
                                 : order == 0 ? ENVL_ORDER_0 : order;
    if (order < 0)
        order = 2; /* the ambient of a fit without remainder: SH of its residual */
    if (sky && !sky_image && (!out || !strcmp(out, "-")) &&
        (sky_residual || !file || !strcmp(file, "-")))
        return cli_usage("pov", "--sky needs -o or --sky-image to name the sky image");

    /* Names written into the include as strings must be safe. */
    const char *source = file && strcmp(file, "-") ? file : "sky";
    if (!pov_string_ok(source) || (sky_image && !pov_string_ok(sky_image))) {
        cli_error("pov: a file name with control characters cannot be written into a POV-Ray "
                  "string");
        return CLI_FAIL;
    }

    envl_envmap *map;
    if (cli_load(file, &c, &map))
        return CLI_FAIL;
    double t0 = envl__seconds();
    int rc = CLI_FAIL;
    envl_lights *ls = NULL;
    envl_sh *sh = NULL;
    envl_envmap *residual = NULL, *grounded = NULL, *sky_half = NULL;
    char *sky_path = NULL;
    double *emit = NULL;
    /* lit: what the scene's objects see (the map, or with a ground the map over the plane);
     * map stays the environment as read (info, the sky image). */
    envl_envmap *lit = map, *cut_map;
    if (ground >= 0) {
        envl_result gr = envl_ground_plane_map(map, ground, c.load.threads, &grounded,
                                               ground_radiance);
        if (gr) {
            rc = gr == ENVL_ERR_MEMORY ? (cli_error("pov: out of memory"), CLI_FAIL) : cli_fail();
            goto done;
        }
        lit = grounded;
    }
    /* A dome over a ground takes its lights from the sky half: the plane would shadow any
     * light below the horizon. */
    cut_map = lit;
    int dome = recipe == POV_RECIPE_DOME || recipe == POV_RECIPE_DOME_AMBIENT;
    if (dome && grounded) {
        if (envl_sky_hemisphere_map(map, c.load.threads, &sky_half)) {
            rc = cli_fail();
            goto done;
        }
        cut_map = sky_half;
    }
    const double *ref;
    emit = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    /* Under radiosity the bounce is not the include's: its error is the lights' against the
     * sky they stand for (the sky half over a ground). */
    envl_envmap *measured = bounce ? cut_map : lit;
    if (!emit || envl_envmap_reference_irradiance(measured, &ref)) {
        rc = emit ? cli_fail() : (cli_error("pov: out of memory"), CLI_FAIL);
        goto done;
    }
    envl_info info;
    envl_envmap_info(map, &info);
    envl_lights_summary s;
    int amb_order = -1;
    const double *amb_sh = NULL;
    int32_t rem_order;
    const double *rem = NULL;
    double ground_sh[4 * 3] = {0};
    ridge rd;
    double hemi_axis[3] = {0, 0, 1}, hemi_sky[3] = {0}, hemi_ground[3] = {0};
    double error = 0;
    /* The dome's size, when not given: the smallest of these whose diffuse error (lights +
     * ambient against the exact integrator, unoccluded) is within the recipe's bound. */
    static const int ambient_counts[] = {64, 128, 256}, bounce_counts[] = {32, 64};
    const int *counts = bounce ? bounce_counts : ambient_counts;
    double bound = bounce ? POV_DOME_BOUNCE_ERROR : POV_DOME_ERROR;
    int tries = !dome_auto_count ? 1 : bounce ? 2 : 3;
    for (int t = 0; t < tries; t++) {
        if (dome_auto_count)
            lo.count = counts[t];
        envl_lights_free(ls);
        envl_sh_free(sh);
        envl_envmap_free(residual);
        ls = NULL;
        sh = NULL;
        residual = NULL;
        if (envl_lights_compute(cut_map, &lo, &ls)) {
            rc = cli_fail();
            goto done;
        }
        envl_lights_get_summary(ls, &s);

        /* The ambient: the ground's bounce under a dome, the fit's remainder, else the SH of
         * the residual (zero for a full cut). */
        amb_order = -1;
        amb_sh = NULL;
        rem = envl_lights_remainder(ls, &rem_order);
        if (ambient != AMB_NONE) {
            if (cut_map == sky_half) {
                /* Uniform radiance L_g below the horizon gives E(n) = pi L_g (1 - n_z) / 2
                 * (the isotropic-sky formula turned over): bands 0 and 1 exactly. */
                const double y00 = 0.28209479177387814, y1 = 0.4886025119029199;
                for (int ch = 0; ch < 3; ch++) {
                    double a = ENVL_PI * ground_radiance[ch] / 2;
                    ground_sh[ch] = a / y00;
                    ground_sh[3 * 2 + ch] = -a / y1;
                }
                amb_order = 1;
                amb_sh = ground_sh;
            } else if (rem) {
                amb_order = rem_order;
                amb_sh = rem;
            } else {
                envl_load_options rl = {.layout = ENVL_LAYOUT_LATLONG,
                                        .threads = c.load.threads};
                /* window auto: the least windowing that keeps it non-negative */
                envl_sh_options so = {.order = order ? order : ENVL_ORDER_0,
                                        .window = ENVL_WINDOW_AUTO};
                if (envl_envmap_from_pixels(envl_lights_residual(ls), info.width, info.height,
                                            3, &rl, &residual) ||
                    envl_sh_compute(residual, &so, &sh)) {
                    rc = cli_fail();
                    goto done;
                }
                amb_order = order;
                amb_sh = envl_sh_irradiance(sh);
            }
        }
        if (ambient == AMB_SH) {
            double dev = ridge_from_sh(amb_order, amb_sh, &rd);
            if (dev < 0 || dev > 1e-9) {
                cli_error("pov: internal error: the slope-pattern form of the SH ambient "
                          "deviates by %g", dev);
                goto done;
            }
        } else if (ambient == AMB_HEMI) {
            hemi_from_sh(amb_order, amb_sh, hemi_axis, hemi_sky, hemi_ground);
            memset(&rd, 0, sizeof rd);
            rd.terms = 1;
            rd.order = 1;
            memcpy(rd.dir[0], hemi_axis, sizeof hemi_axis);
            for (int ch = 0; ch < 3; ch++) {
                rd.coef[0][0][ch] = 0.5 * (hemi_sky[ch] + hemi_ground[ch]);
                rd.coef[0][1][ch] = 0.5 * (hemi_sky[ch] - hemi_ground[ch]);
            }
        }
        error = emitted_error(ls, ambient != AMB_NONE ? &rd : NULL, ref, emit);
        if (error <= bound)
            break;
    }
    /* Negative ambient light is never usable: the hemispheric form and the residual's SH
     * (window auto) cannot go negative; the fit's remainder is what the fit chose, so the
     * include and stderr say where it dips below 0. */
    int amb_negative = 0;
    double amb_least = ambient != AMB_NONE ? ridge_least(&rd, &amb_negative) : 0;
    if (amb_negative && !c.quiet)
        cli_error("%s: warning: the ambient irradiance is negative at %d of 4096 normals "
                  "(least %.6g in a channel)", source, amb_negative, amb_least);
    if (s.no_light && !c.quiet)
        cli_error("%s: no light: the environment is black", source);
    /* Auto exposure: a white Lambertian surface facing up, unshadowed, reads POV_AUTO_WHITE:
     * its radiance is E_up / pi. */
    double exposure_auto = 1, e_up[3];
    const double up[3] = {0, 0, 1};
    if (envl_irradiance_exact(lit, 1, up, e_up) == ENVL_OK &&
        envl_luminance(e_up[0], e_up[1], e_up[2]) > 0)
        exposure_auto = POV_AUTO_WHITE * ENVL_PI / envl_luminance(e_up[0], e_up[1], e_up[2]);
    double seconds = envl__seconds() - t0;

    /* The sky image: the lat-long .hdr input as it is, else the canonical map (rotation
     * applied) or the residual, written next to the include. */
    double sky_rotate = 0;
    if (sky) {
        int use_input = !sky_residual && !sky_image && file && strcmp(file, "-") &&
                        !strcmp(info.format, "hdr") && info.layout == ENVL_LAYOUT_LATLONG &&
                        !c.load.apply_exposure;
        if (use_input) {
            sky_path = strdup(file);
            sky_rotate = info.rotate_degrees;
        } else if (sky_image) {
            sky_path = strdup(sky_image);
        } else {
            size_t n = strlen(out);
            size_t stem = ends_with(out, ".inc") ? n - 4 : n;
            sky_path = malloc(stem + 16);
            if (sky_path)
                snprintf(sky_path, stem + 16, "%.*s_sky.hdr", (int)stem, out);
        }
        if (!sky_path) {
            cli_error("pov: out of memory");
            goto done;
        }
        if (!pov_string_ok(sky_path)) {
            cli_error("pov: a file name with control characters cannot be written into a "
                      "POV-Ray string");
            goto done;
        }
        if (!use_input) {
            envl_save_options so = {.format = "hdr"};
            envl_result r2 = sky_residual
                                 ? envl_image_save(sky_path, envl_lights_residual(ls),
                                                   info.width, info.height, &so)
                                 : envl_envmap_save(map, sky_path, &so);
            if (r2) {
                rc = cli_fail();
                goto done;
            }
        }
        /* Named by its absolute path: the scene may be rendered from another folder. */
        char *absolute = realpath(sky_path, NULL);
        if (absolute && pov_string_ok(absolute)) {
            free(sky_path);
            sky_path = absolute;
        } else {
            free(absolute);
        }
    }

    cli_output o;
    if ((rc = cli_output_open(&o, out)) != CLI_OK)
        goto done;
    FILE *f = o.f;
    static const char *amb_names[] = {"sh", "hemi", "none"};
    static const char *shadow_names[] = {"none", "hard", "soft"};
    fprintf(f, "// envlight %s: POV-Ray 3.7 include, for povray_include/envlight.inc\n",
            envl_version_string());
    fputs("// source: ", f);
    pov_comment_text(f, source);
    fprintf(f, " (%s, %d x %d canonical lat-long, rotated %.9g degrees about +Z)\n",
            info.format, (int)info.width, (int)info.height, info.rotate_degrees);
    fputs("// command: envlight", f);
    for (int i = 0; i < argc; i++) {
        fputc(' ', f);
        pov_comment_text(f, argv[i]);
    }
    fprintf(f, "\n// %d lights by %s%s; ambient %s", (int)s.count, envl_method_name(s.method),
            rem ? " (+ SH remainder)" : "", amb_names[ambient]);
    if (ambient != AMB_NONE)
        fprintf(f, " (%s order %d, %d slope terms)",
                amb_sh == ground_sh ? "the ground's bounce," : rem ? "fit remainder"
                                                                   : "residual SH",
                amb_order, rd.terms);
    fprintf(f, "; shadows %s\n", shadow_names[shadows]);
    if (ambient != AMB_NONE) {
        fprintf(f, "// ambient %s: least irradiance %.6g in a channel at 4096 normals",
                ambient == AMB_HEMI ? "(sky/ground: the best fit with both >= 0)"
                : amb_sh == ground_sh ? "(the ground's bounce: never negative)"
                : sh && amb_sh == envl_sh_irradiance(sh) ? "(SH window auto: never negative)"
                                                         : "(the fit's SH remainder, as fitted)",
                amb_least);
        if (amb_negative)
            fprintf(f, ": NEGATIVE at %d of them (POV-Ray takes light away there)",
                    amb_negative);
        fputc('\n', f);
    }
    pov_header_recipe(f, recipe, why, scene, ground_from, sky, ambient != AMB_NONE,
                      dome_auto_count ? (int)s.count : 0, bounce);
    if (grounded && bounce) {
        fprintf(f, "// ground plane (canonical z = 0, POV-Ray y = 0), albedo %.9g: the lights "
                "come from the sky\n//   above it; its bounce (albedo * E_up / pi = <%.6g, "
                "%.6g, %.6g> unoccluded) is radiosity's\n", ground, ground_radiance[0],
                ground_radiance[1], ground_radiance[2]);
    } else if (grounded) {
        fprintf(f, "// ground plane (canonical z = 0, POV-Ray y = 0), albedo %.9g: the lower "
                "hemisphere\n//   is its radiance albedo * E_up / pi = <%.6g, %.6g, %.6g>; "
                "lights, ambient and\n//   error are those of the map so edited\n", ground,
                ground_radiance[0], ground_radiance[1], ground_radiance[2]);
    }
    fprintf(f, "// diffuse error %.4f %% (lights + ambient as written, against the exact "
            "integrator%s,\n//   relative RMS luminance over 1024 normals, unoccluded); "
            "%.3f s\n", 100 * error,
            bounce ? (grounded ? " of the sky half: the bounces are radiosity's"
                               : ": the bounces are radiosity's")
                   : "",
            seconds);
    fputs("//\n"
          "// Frames: the canonical frame is Blender's (right-handed, +Z up); POV-Ray's is\n"
          "// left-handed, +Y up. A canonical vector (x, y, z) is the POV-Ray vector <x, z, y>.\n"
          "// Sky: the canonical lat-long image has u = 0 -> -X, 0.25 -> +Y, 0.5 -> +X,\n"
          "// 0.75 -> -Y (canonical), i.e. POV-Ray -X, +Z, +X, -Z; a map_type 1 image_map puts\n"
          "// u = 0 at +X, 0.25 at +Z, 0.5 at -X, 0.75 at -Z. They differ by the mirror\n"
          "// x -> -x: EnvLight_Sky() uses `scale <-1, 1, 1>` (= a mirror in z and a half\n"
          "// turn), then `rotate -EnvLight_Sky_Rotate * y` for a --rotate of the source.\n"
          "// Units: a light's rgb is the irradiance it delivers (sum of L dw); its POV-Ray\n"
          "// colour is rgb / pi (a light_source colour C on diffuse 1 gives radiance C cos).\n",
          f);
    if (ambient != AMB_NONE)
        fputs("// The ambient irradiance E(n) = sum_k sum_l EnvLight_Ambient_Coef[k][l]\n"
              "//   * P_l(EnvLight_Ambient_Direction[k] . n) (P_l Legendre), in POV-Ray's "
              "frame.\n", f);
    fputs("#ifndef (EnvLight_Generated_Inc_Temp)\n"
          "#declare EnvLight_Generated_Inc_Temp = 1;\n", f);
    fputs("#declare EnvLight_Source = ", f);
    pov_string(f, source);
    fprintf(f, ";\n#declare EnvLight_Rotate = %.9g; // degrees about canonical +Z (POV-Ray +Y)\n",
            info.rotate_degrees);
    fprintf(f, "#declare EnvLight_Method = \"%s\";\n", envl_method_name(s.method));
    fprintf(f, "#declare EnvLight_Diffuse_Error = %.9g;\n", error);
    fprintf(f, "#declare EnvLight_Seconds = %.6g;\n", seconds);
    if (grounded) {
        fprintf(f, "#declare EnvLight_Ground_Albedo = %.9g;\n", ground);
        fputs("#declare EnvLight_Ground_Radiance = ", f);
        pov_rgb(f, ground_radiance, 1);
        fputs("; // below the horizon: albedo * E_up / pi\n", f);
    }
    fprintf(f, "#ifndef (EnvLight_Scene_Center) #declare EnvLight_Scene_Center = <0, 0, 0>; "
               "#end\n");
    fprintf(f, "#ifndef (EnvLight_Scene_Radius) #declare EnvLight_Scene_Radius = %.9g; #end\n",
            radius);
    fprintf(f, "#ifndef (EnvLight_Shadows) #declare EnvLight_Shadows = %d; #end "
               "// 0 none, 1 hard, 2 soft\n", shadows);
    fprintf(f, "#declare EnvLight_Count = %d;\n", (int)s.count);
    if (s.count > 0) {
        static const char *names[] = {"EnvLight_Direction", "EnvLight_Colour",
                                      "EnvLight_Irradiance", "EnvLight_Solid_Angle",
                                      "EnvLight_Angle"};
        static const char *notes[] = {"unit, towards the light, POV-Ray frame",
                                      "light_source colour = rgb / pi",
                                      "rgb: irradiance at normal incidence",
                                      "sr, of the region the light took",
                                      "angular diameter, degrees"};
        for (int a = 0; a < 5; a++) {
            fprintf(f, "#declare %s = array[%d] { // %s\n", names[a], (int)s.count, notes[a]);
            for (int j = 0; j < s.count; j++) {
                envl_light l;
                envl_lights_get(ls, j, &l);
                fputs("  ", f);
                if (a == 0)
                    pov_vector(f, l.direction);
                else if (a == 1)
                    pov_rgb(f, l.rgb, 1 / ENVL_PI);
                else if (a == 2)
                    pov_rgb(f, l.rgb, 1);
                else if (a == 3)
                    fprintf(f, "%.9g", l.solid_angle);
                else
                    fprintf(f, "%.9g", l.angle * 180 / ENVL_PI);
                fputs(j + 1 < s.count ? ",\n" : "\n", f);
            }
            fputs("};\n", f);
        }
    }
    if (ambient != AMB_NONE) {
        fprintf(f, "#declare EnvLight_Ambient_Mode = \"%s\";\n", amb_names[ambient]);
        if (ambient == AMB_SH) {
            fprintf(f, "#declare EnvLight_Ambient_SH_Order = %d;\n", amb_order);
            fprintf(f, "// irradiance SH, canonical frame (Blender, +Z up), docs/design.md's basis\n");
            fprintf(f, "#declare EnvLight_Ambient_SH = array[%d] {\n",
                    (amb_order + 1) * (amb_order + 1));
            for (int j = 0; j < (amb_order + 1) * (amb_order + 1); j++) {
                fputs("  ", f);
                pov_rgb(f, amb_sh + 3 * j, 1);
                fputs(j + 1 < (amb_order + 1) * (amb_order + 1) ? ",\n" : "\n", f);
            }
            fputs("};\n", f);
        } else {
            fputs("#declare EnvLight_Hemi_Axis = ", f);
            pov_vector(f, hemi_axis);
            fputs(";\n#declare EnvLight_Hemi_Sky = ", f);
            pov_rgb(f, hemi_sky, 1);
            fputs("; // irradiance at n = axis\n#declare EnvLight_Hemi_Ground = ", f);
            pov_rgb(f, hemi_ground, 1);
            fputs("; // at n = -axis\n", f);
        }
        fprintf(f, "#declare EnvLight_Ambient_Terms = %d;\n", rd.terms);
        fprintf(f, "#declare EnvLight_Ambient_Order = %d;\n", rd.order);
        fprintf(f, "#declare EnvLight_Ambient_Direction = array[%d] {\n", rd.terms);
        for (int k = 0; k < rd.terms; k++) {
            fputs("  ", f);
            pov_vector(f, rd.dir[k]);
            fputs(k + 1 < rd.terms ? ",\n" : "\n", f);
        }
        fprintf(f, "};\n#declare EnvLight_Ambient_Coef = array[%d][%d] {\n", rd.terms,
                rd.order + 1);
        for (int k = 0; k < rd.terms; k++) {
            fputs("  {", f);
            for (int l = 0; l <= rd.order; l++) {
                pov_rgb(f, rd.coef[k][l], 1);
                fputs(l < rd.order ? ", " : "", f);
            }
            fputs(k + 1 < rd.terms ? "},\n" : "}\n", f);
        }
        fputs("};\n", f);
    }
    if (sky) {
        fputs("#declare EnvLight_Sky_File = ", f);
        pov_string(f, sky_path);
        fprintf(f, ";%s\n#declare EnvLight_Sky_Rotate = %.9g;\n",
                sky_residual ? " // the residual: what the lights did not take" : "",
                sky_rotate);
    }
    fprintf(f, "#declare EnvLight_Exposure_Auto = %.9g; // a white surface facing up reads "
            "%.1f\n", exposure_auto, POV_AUTO_WHITE);
    if (exposure != 0)
        fprintf(f, "#ifndef (EnvLight_Exposure) #declare EnvLight_Exposure = %.9g; #end // "
                "--exposure %s\n", exposure < 0 ? exposure_auto : exposure,
                exposure < 0 ? "auto" : "X");
    pov_include_envlight(f);
    if (place) {
        fputs("EnvLight_Place_Lights()\n", f);
        if (sky) /* under the bounce's radiosity the sky is for the camera only */
            fputs(bounce ? "EnvLight_Sky_Backdrop()\n" : "EnvLight_Sky()\n", f);
        if (recipe == POV_RECIPE_IMAGE_RADIOSITY)
            fputs("global_settings { EnvLight_Radiosity_Residual_Settings() }\n", f);
        if (bounce)
            fputs("global_settings { EnvLight_Bounce_Settings() }\n", f);
    }
    fputs("#end\n", f);
    rc = cli_output_close(&o);

done:
    free(emit);
    free(sky_path);
    envl_sh_free(sh);
    envl_envmap_free(residual);
    envl_envmap_free(grounded);
    envl_envmap_free(sky_half);
    envl_lights_free(ls);
    envl_envmap_free(map);
    return rc;
}
