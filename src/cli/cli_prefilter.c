/* envlight prefilter: irradiance map, GGX specular chain, RGBM atlas; envlight brdf-lut. */
#include "cli.h"
#include "clock.h"
#include "json.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const cli_command prefilter_command = {
    "prefilter",
    "Usage: envlight prefilter [FILE] -o DIR [--irradiance] [--specular] [--levels K]\n"
    "                          [--size S] [--samples M]\n"
    "                          [--format exr|hdr|pfm|rgbm-png|ktx2|ktx2-float]\n"
    "                          [--layout latlong|cube|cross|atlas] [--roughness LIST]\n"
    "                          [--frame blender|gltf] [--json] [input options]\n"
    "Prefiltered maps into DIR (created if missing), with a JSON sidecar DIR/prefilter.json\n"
    "giving the conventions (frame, roughness mapping, RGBM range, layout) and every file.\n"
    "--format ktx2: specular.ktx2, one cube map with the chain as its mip levels, and\n"
    "irradiance.ktx2 (OpenGL's faces in the glTF frame: implies --layout cube --frame gltf).\n",
    NULL};

static const cli_command brdf_command = {
    "brdf-lut",
    "Usage: envlight brdf-lut -o FILE [--size S] [--samples N] [--multiscatter] [--json]\n"
    "Split-sum GGX BRDF table (height-correlated Smith), integrated in double. Column i:\n"
    "NoV = (i + 0.5) / S; row j from the top: roughness = (j + 0.5) / S (alpha = roughness^2).\n"
    "Channels: R = A (scale), G = B (bias), specular = F0 A + B; --multiscatter: R = B,\n"
    "G = A + B, specular = mix(R, G, F0) * (1 + F0 (1 / G - 1)) (Turquin 2019 compensation).\n"
    "FILE .exr/.pfm/.hdr: float R, G, blue 0; .png: 8-bit sRGB. A sidecar FILE.json says so.\n",
    NULL};

static int parse_list(const char *v, double **out, int32_t *n)
{
    int32_t cap = 1;
    for (const char *s = v; *s; s++)
        cap += *s == ',';
    double *r = malloc(sizeof(double) * cap);
    if (!r)
        return -1;
    char *copy = strdup(v), *save = NULL;
    int32_t k = 0;
    for (char *t = strtok_r(copy, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        double d;
        if (cli_parse_double(t, &d) || !(d >= 0 && d <= 1)) {
            free(copy);
            free(r);
            return -1;
        }
        r[k++] = d;
    }
    free(copy);
    if (!k) {
        free(r);
        return -1;
    }
    *out = r;
    *n = k;
    return 0;
}

static int print_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        cli_error("%s: %s", path, strerror(errno));
        return CLI_FAIL;
    }
    char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        fwrite(buf, 1, n, stdout);
    fclose(f);
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}

/* KTX2 holds cube maps in OpenGL's faces, i.e. the glTF frame: the format implies both.
 * Nonzero (the usage error printed) when --layout or --frame asked for something else. */
static int ktx2_layout(const cli_option *t, int n, envl_export_options *eo)
{
    if (cli_seen(t, n, "--layout") && eo->layout != ENVL_EXPORT_CUBE) {
        cli_usage("prefilter", "--format %s writes cube maps (OpenGL's faces, the chain as mip "
                  "levels): leave out --layout or give --layout cube", eo->format);
        return 1;
    }
    if (cli_seen(t, n, "--frame") && eo->frame != ENVL_FRAME_GLTF) {
        cli_usage("prefilter", "--format %s writes OpenGL's cube faces, which are in the glTF "
                  "frame: leave out --frame or give --frame gltf", eo->format);
        return 1;
    }
    eo->layout = ENVL_EXPORT_CUBE;
    eo->frame = ENVL_FRAME_GLTF;
    return 0;
}

/* KTX2's level k is face >> k texels: at most floor(log2(face)) + 1 levels. Nonzero (the
 * usage error printed) when `levels` do not fit. */
static int ktx2_levels_fit(const char *format, int32_t face, int32_t levels)
{
    int32_t most = 1;
    while (face >> most)
        most++;
    if (levels <= most)
        return 0;
    cli_usage("prefilter", "--format %s: %d specular levels do not fit the mip chain of "
              "%d-texel cube faces (at most %d: log2(%d) + 1); give --levels %d or less, or a "
              "larger --size", format, (int)levels, (int)face, (int)most, (int)face, (int)most);
    return 1;
}

/* A map too coarse for the GGX sums was prefiltered from a finer copy: say so. */
static void coarse_note(const envl_envmap *map, const envl_products *p, int quiet)
{
    envl_products_summary s;
    envl_products_get_summary(p, &s);
    cli_coarse_note(map, s.prefiltered_width, s.prefiltered_height, quiet);
}

/* Half floats (ktx2): the values each map loses above ENVL_HALF_MAX, on stderr. */
static void half_warnings(const envl_envmap *map, const envl_products *p, int quiet)
{
    envl_info info;
    envl_envmap_info(map, &info);
    char what[1200];
    envl_irradiance_map irr;
    if (envl_products_irradiance(p, &irr) == ENVL_OK) {
        snprintf(what, sizeof what, "%s: the irradiance map", info.file);
        cli_half_warning(what, irr.rgb, 3 * (size_t)irr.width * irr.height, quiet);
    }
    for (int32_t i = 0; i < envl_products_level_count(p); i++) {
        envl_level l;
        envl_products_level(p, i, &l);
        snprintf(what, sizeof what, "%s: specular level %d (r %.3f)", info.file, (int)i,
                 l.roughness);
        cli_half_warning(what, l.rgb, 3 * (size_t)l.width * l.height, quiet);
    }
}

/* "512 x 256" (lat-long) or "6 x 128^2" (cube faces). */
static const char *size_text(char *buf, size_t n, int32_t layout, int32_t w, int32_t h)
{
    if (layout == ENVL_LAYOUT_STRIP_H)
        snprintf(buf, n, "6 x %d^2", (int)h);
    else
        snprintf(buf, n, "%d x %d", (int)w, (int)h);
    return buf;
}

/* KTX2's mip k is face >> k and the atlas's slot k is W >> k: a level computed at another size
 * (an explicit --min-size kept it wider, or a --roughness list skipped a size) is
 * area-resampled there, and the errors stated are the computed level's, not the file's: says
 * so on stderr. */
static void note_resampled(const envl_products *p, const envl_export_options *eo, int ktx2)
{
    if (!ktx2 && eo->layout != ENVL_EXPORT_ATLAS)
        return;
    char list[256] = "";
    size_t at = 0;
    int32_t n = envl_products_level_count(p), count = 0;
    envl_level l0;
    if (n == 0 || envl_products_level(p, 0, &l0))
        return;
    for (int32_t i = 0; i < n; i++) {
        envl_level l;
        envl_products_level(p, i, &l);
        /* the atlas's slots follow the roughness order (the CLI's chain and lists ascend) */
        int wrong = ktx2 ? l.layout != ENVL_LAYOUT_STRIP_H || l.height != l0.height >> i
                         : l.width != l0.width >> i;
        if (wrong && at < sizeof list - 16)
            at += (size_t)snprintf(list + at, sizeof list - at, "%s%d", count++ ? ", " : "", (int)i);
    }
    if (count)
        fprintf(stderr, "envlight: note: level%s %s %s computed at another size than %s and "
                "area-resampled to %s: the errors stated are the computed level%s, not the "
                "file's (leave out --min-size)\n", count > 1 ? "s" : "", list,
                count > 1 ? "were" : "was", ktx2 ? "their KTX2 mip" : "their atlas slot",
                count > 1 ? "them" : "it", count > 1 ? "s'" : "'s");
}

/* The irradiance map and the levels of roughness > 0 are held to a per-texel RMS of 0.5 % and
 * a worst texel of 2 % (docs/design.md, "Error measures"); one beyond that is said on stderr
 * with what holds it: for a level a finer quadrature (the cut's density grows as --samples;
 * the texels' size does not matter, each is computed at its centre), for the irradiance map
 * the exact sum. A product the half floats clamped was warned about (half_warnings): its
 * error is the clamp's, which no finer sum changes. */
static void note_texel_bounds(const envl_products *p, int half)
{
    double largest;
    envl_irradiance_map irr;
    char t[96];
    if (envl_products_irradiance(p, &irr) == ENVL_OK && irr.texel_error.rms >= 0 &&
        (irr.texel_error.rms > 0.005 || irr.texel_error.worst > 0.02) &&
        !(half && cli_half_over(irr.rgb, 3 * (size_t)irr.width * irr.height, &largest)))
        fprintf(stderr, "envlight: note: the irradiance map's %s is beyond RMS 0.5 %% / worst "
                "2 %%; --irradiance-method split (the default) or exact holds it\n",
                cli_texel_text(t, sizeof t, &irr.texel_error));
    for (int32_t i = 0; i < envl_products_level_count(p); i++) {
        envl_level l;
        envl_products_level(p, i, &l);
        if (l.roughness > 0 && l.texel_error.rms >= 0 &&
            (l.texel_error.rms > 0.005 || l.texel_error.worst > 0.02) &&
            !(half && cli_half_over(l.rgb, 3 * (size_t)l.width * l.height, &largest)))
            fprintf(stderr, "envlight: note: specular_%02d's %s is beyond RMS 0.5 %% / worst "
                    "2 %%; a larger --samples makes its sums finer (4 x: cells summed whole "
                    "from about twice as far)\n", (int)i,
                    cli_texel_text(t, sizeof t, &l.texel_error));
    }
}

/* Under a level over the glossy target: the width that would meet it (envl_width_estimate),
 * as --size gives it (the face size for cube faces), and the time estimated. */
static void print_target_width(const envl_level *l, const envl_products *p, int32_t i)
{
    envl_width_estimate w;
    if (envl_products_level_width(p, i, &w) ||
        (w.state != ENVL_WIDTH_FOUND && w.state != ENVL_WIDTH_BEYOND))
        return;
    int faces = l->layout == ENVL_LAYOUT_STRIP_H;
    char size[32];
    size_text(size, sizeof size, l->layout, faces ? 6 * w.width : w.width,
              faces ? w.width : w.width / 2);
    printf("             glossy %g %% %s %s (--size %d): %.3f %% there, about %.1f s (this "
           "level's s per texel; %d widths read at %d directions in %.3f s)\n",
           100 * ENVL_GLOSSY_TARGET, w.state == ENVL_WIDTH_FOUND ? "at" : "not met up to", size,
           (int)(faces ? w.size / 4 : w.size), 100 * w.glossy_error, w.seconds,
           (int)w.widths_tried, (int)w.directions_read, w.seconds_spent);
}

/* Whether the folder `dir` exists or its parent does (errno set when not): checked before the
 * products are computed (seconds of work), so that a folder that cannot be made is said at
 * once. The folder itself is made only after them: a failed run leaves nothing behind. */
static int folder_can_be_made(const char *dir)
{
    struct stat st;
    char parent[4096];
    size_t n = strlen(dir);
    if (stat(dir, &st) == 0 || n >= sizeof parent)
        return 1; /* there, or a name mkdir will judge */
    memcpy(parent, dir, n + 1);
    while (n > 1 && parent[n - 1] == '/')
        parent[--n] = '\0';
    char *slash = strrchr(parent, '/');
    if (!slash)
        return 1; /* in the working folder */
    slash[slash == parent ? 1 : 0] = '\0';
    if (stat(parent, &st) != 0)
        return 0;
    if (!S_ISDIR(st.st_mode)) {
        errno = ENOTDIR;
        return 0;
    }
    return 1;
}

/* The table of what was written: the products, their errors and seconds. */
static int print_summary(const envl_envmap *map, const envl_products *p, const char *dir,
                         const envl_export_options *eo)
{
    envl_info info;
    envl_envmap_info(map, &info);
    envl_products_summary s;
    envl_products_get_summary(p, &s);
    printf("%s: %d x %d -> %s (%s, %s), %.3f s", info.file, (int)info.width, (int)info.height,
           dir, eo->format ? eo->format : "exr", envl_export_layout_name(eo->layout), s.seconds);
    if (s.specular_levels)
        printf("; cell pyramid %.3f s", s.seconds_pyramid);
    printf("\n");
    envl_irradiance_map irr;
    char e[64], t[96], size[32];
    if (envl_products_irradiance(p, &irr) == ENVL_OK) {
        printf("irradiance   %-9s %-13s", envl_irradiance_method_name(irr.method),
               size_text(size, sizeof size, irr.layout, irr.width, irr.height));
        printf("  %s  %s  %.3f s\n", cli_error_text(e, sizeof e, "diffuse", irr.diffuse_error),
               cli_texel_text(t, sizeof t, &irr.texel_error), irr.seconds);
    }
    for (int32_t i = 0; i < envl_products_level_count(p); i++) {
        envl_level l;
        envl_products_level(p, i, &l);
        printf("specular_%02d  r %.3f alpha %.4f %-13s samples %4d%s", (int)i, l.roughness,
               l.alpha, size_text(size, sizeof size, l.layout, l.width, l.height),
               (int)l.samples,
               l.samples ? (l.filtered ? " filtered" : " plain") : " (resampled)");
        printf("  %s  %s  %.3f s\n", cli_error_text(e, sizeof e, "glossy", l.glossy_error),
               cli_texel_text(t, sizeof t, &l.texel_error), l.seconds);
        print_target_width(&l, p, i);
    }
    int32_t nsun;
    const envl_light *sun = envl_products_sun_lights(p, &nsun);
    for (int32_t i = 0; i < nsun; i++) {
        double d[3]; /* in the output's frame, as prefilter.json gives it */
        envl_frame_vector(eo->frame, sun[i].direction, d);
        printf("sun_light_%02d direction %.4f %.4f %.4f  rgb %.5g %.5g %.5g  angle %.3f deg\n",
               (int)i, d[0], d[1], d[2], sun[i].rgb[0], sun[i].rgb[1], sun[i].rgb[2],
               sun[i].angle * 180 / ENVL_PI);
    }
    int32_t bs;
    if (envl_products_brdf(p, &bs, NULL))
        printf("brdf_lut     %d x %d  %.3f s\n", (int)bs, (int)bs, s.seconds_brdf);
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}

int cli_prefilter(int argc, char **argv)
{
    cli_common c = {0};
    const char *file = NULL, *dir = NULL;
    envl_request q = {0};
    envl_export_options eo = {0};
    int want_irr = 0, want_spec = 0, json = 0, no_error = 0, brdf = 0, npos;
    int size = 0, irr_size = 0, min_size = 0, order = ENVL_DEFAULT_ORDER;
    const char *roughness = NULL;
    double *list = NULL;
    int32_t nlist = 0;
    int rc = CLI_OK;
    cli_option t[] = {
        CLI_OPTION("--irradiance", NULL, CLI_FLAG, .value = &want_irr,
                   .help = "the diffuse irradiance map (irradiance.EXT)"),
        CLI_OPTION("--specular", NULL, CLI_FLAG, .value = &want_spec,
                   .help = "the GGX specular chain (specular_NN.EXT); default: both"),
        CLI_OPTION("--levels", "K", CLI_INT, .min = 1, .max = 16, .value = &q.prefilter.levels,
                   .help = "levels of the chain, roughness k / (K - 1), alpha = roughness^2\n"
                           "(default 6)"),
        CLI_OPTION("--roughness", "LIST", CLI_TEXT, .value = &roughness,
                   .takes = "a comma-separated list of values in [0, 1]",
                   .help = "comma-separated roughness values in [0, 1]: only these levels\n"
                           "(instead of the chain)"),
        CLI_OPTION("--size", "S", CLI_INT, .min = 2, .max = 16384, .value = &size,
                   .help = "lat-long width of the roughness-0 level (default 512), or the cube\n"
                           "face size for --layout cube|cross (default 256); level k is S >> k"),
        CLI_OPTION("--min-size", "S", CLI_INT, .min = 2, .max = 16384, .value = &min_size,
                   .help = "no level narrower than S (lat-long width; default 64)"),
        CLI_OPTION("--samples", "M", CLI_INT, .min = 1, .max = 1 << 20,
                   .value = &q.prefilter.samples,
                   .help = "the levels' density (default 64): a level w wide sums pyramid\n"
                           "cells whole from 1 + sqrt(n) / 8 cell widths away, n = M (S / w)^2\n"
                           "within 4 M and 8 M; with --unfiltered, GGX samples per texel"),
        CLI_OPTION("--unfiltered", NULL, CLI_FLAG, .value = &q.prefilter.unfiltered,
                   .help = "plain GGX importance sampling of the full map (the baseline)"),
        CLI_OPTION("--sun-lights", NULL, CLI_FLAG, .value = &q.prefilter.sun_lights,
                   .help = "the sun (pixels above 50x the mean luminance) as lights in the\n"
                           "sidecar, left out of the irradiance map and the glossy levels, for\n"
                           "the renderer to add analytically; errors are measured with them"),
        CLI_OPTION("--irradiance-method", "M", CLI_CHOICE,
                   .value = &q.prefilter.irradiance_method,
                   .choices = "split|sh|exact|resampled", .lookup = envl_irradiance_method_from_name,
                   .help = "split (default: the bright pixels exactly + the rest, at most\n"
                           "2048 wide, through a tree of block sums, each texel within\n"
                           "0.5 %), sh (SH of --irradiance-order with the auto window: never\n"
                           "negative), exact\n"
                           "(every pixel per texel, slow), resampled (exact over the map\n"
                           "area-averaged to 256 x 128)"),
        CLI_OPTION("--irradiance-order", "L", CLI_INT, .min = 0, .max = 32, .value = &order,
                   .help = "SH order for --irradiance-method sh (default 2)"),
        CLI_OPTION("--irradiance-size", "S", CLI_INT, .min = 2, .max = 16384, .value = &irr_size,
                   .help = "lat-long width (default 64; cube face 32)"),
        CLI_OPTION("--format", "F", CLI_TEXT, .value = &eo.format,
                   .takes = "exr, hdr, pfm, rgbm-png, ktx2 or ktx2-float",
                   .help = "exr (float, default), hdr, pfm, rgbm-png (RGBA8, rgb = 6 rgb.a),\n"
                           "ktx2 (KTX 2.0 cube maps, RGBA half float, the chain as mip levels;\n"
                           "values above 65504 clamp), ktx2-float (the same in 32-bit float)"),
        CLI_OPTION("--layout", "L", CLI_CHOICE, .value = &eo.layout,
                   .choices = "latlong|cube|cross|atlas", .lookup = envl_export_layout_from_name,
                   .help = "latlong (default), cube (6 files per map; with ktx2: one file),\n"
                           "cross (vertical), atlas (the levels stacked in one image; needs the\n"
                           "6-level chain or a list; with rgbm-png also writes brdf_lut.png,\n"
                           "sRGB)"),
        CLI_OPTION("--brdf", NULL, CLI_FLAG, .value = &brdf,
                   .help = "also write the BRDF table (brdf_lut.EXT)"),
        CLI_NO_ERROR_OPTION(&no_error),
        CLI_FRAME_OPTION(&eo.frame),
        CLI_OPTION("--json", NULL, CLI_FLAG, .value = &json,
                   .help = "print the sidecar to stdout instead of the summary"),
        CLI_OPTION("-o", "DIR", CLI_TEXT, .value = &dir, .takes = "a directory",
                   .help = "the folder of the maps and prefilter.json"),
    };
#define USAGE(...) (free(list), cli_usage("prefilter", __VA_ARGS__))
    int parsed = cli_parse(&prefilter_command, t, CLI_COUNT(t), &c, argc, argv, &file, 1, &npos);
    if (parsed)
        return parsed == CLI_HELP ? CLI_OK : parsed;
    if (eo.format && strcmp(eo.format, "exr") && strcmp(eo.format, "hdr") &&
        strcmp(eo.format, "pfm") && strcmp(eo.format, "rgbm-png") &&
        strcmp(eo.format, "ktx2") && strcmp(eo.format, "ktx2-float"))
        return USAGE("--format takes exr, hdr, pfm, rgbm-png, ktx2 or ktx2-float, not '%s'",
                     eo.format);
    int ktx2 = eo.format && !strncmp(eo.format, "ktx2", 4);
    if (ktx2 && ktx2_layout(t, CLI_COUNT(t), &eo))
        return CLI_USAGE; /* before --roughness is parsed: no list yet */
    if (roughness && parse_list(roughness, &list, &nlist))
        return USAGE("--roughness takes a comma-separated list of values in [0, 1], not '%s'",
                     roughness);
    q.prefilter.irradiance_order = order ? order : ENVL_ORDER_0;
    int measure = !no_error;
    if (!dir)
        return USAGE("-o DIR is required");
    if (nlist)
        want_spec = 1;
    if (!want_irr && !want_spec)
        want_irr = want_spec = 1;
    int cube = eo.layout == ENVL_EXPORT_CUBE || eo.layout == ENVL_EXPORT_CROSS;
    if (eo.layout == ENVL_EXPORT_ATLAS && !want_spec)
        return USAGE("--layout atlas needs specular levels");
    if (eo.frame == ENVL_FRAME_GLTF && eo.layout == ENVL_EXPORT_CROSS)
        return USAGE("--frame gltf writes cube faces (OpenGL's) or lat-long maps; the cross is "
                     "drawn in Blender's frame only");
    /* Cube faces of size S come from lat-long maps 4 S wide. */
    q.prefilter.width = (int32_t)(size ? (cube ? 4 * size : size) : (cube ? 1024 : 512));
    if (ktx2 && want_spec &&
        ktx2_levels_fit(eo.format, q.prefilter.width / 4,
                        nlist ? nlist : q.prefilter.levels ? q.prefilter.levels
                                                           : ENVL_DEFAULT_LEVELS)) {
        free(list);
        return CLI_USAGE;
    }
    if (min_size)
        q.prefilter.min_width = (int32_t)min_size;
    q.prefilter.irradiance_width = (int32_t)(irr_size ? (cube ? 4 * irr_size : irr_size)
                                                      : (cube ? 128 : 64));
    /* the maps are computed at the texels written: cube faces for cube, cross and KTX2 */
    q.prefilter.layout = eo.layout;
    /* the KTX2 mip chain and the atlas's slots halve at every level: no level kept wider
     * (unless --min-size asks), so each is written as computed */
    if ((ktx2 || eo.layout == ENVL_EXPORT_ATLAS) && !min_size) {
        int32_t k = q.prefilter.levels ? q.prefilter.levels : ENVL_DEFAULT_LEVELS;
        q.prefilter.min_width = q.prefilter.width >> (k - 1) > 2 ? q.prefilter.width >> (k - 1)
                                                                 : 2;
    }
    q.prefilter.threads = c.load.threads;
    q.irradiance_map = want_irr;
    if (want_spec) {
        if (nlist) {
            q.n_roughness = nlist;
            q.roughness = list;
        } else {
            q.specular_chain = 1;
        }
    }
    q.brdf_lut = brdf || (eo.format && !strcmp(eo.format, "rgbm-png") &&
                          eo.layout == ENVL_EXPORT_ATLAS);
    q.brdf.threads = c.load.threads;
    q.measure = measure;
    q.prefilter.half = eo.format && !strcmp(eo.format, "ktx2"); /* measured as written */

    if (!folder_can_be_made(dir)) {
        cli_error("%s: cannot create the directory: %s", dir, strerror(errno));
        free(list);
        return CLI_FAIL;
    }
    envl_envmap *map;
    if (cli_load(file, &c, &map)) {
        free(list);
        return CLI_FAIL;
    }
    /* the folder only once the products are computed: a bad input, or products that
     * overflow, leave nothing behind */
    envl_products *p = NULL;
    if (envl_compute(map, &q, &p)) {
        rc = cli_fail();
        goto done;
    }
    coarse_note(map, p, c.quiet);
    if (q.prefilter.half)
        half_warnings(map, p, c.quiet);
    int created = mkdir(dir, 0777) == 0; /* a folder this run made goes if it fails */
    if (!created && errno != EEXIST) {
        cli_error("%s: cannot create the directory: %s", dir, strerror(errno));
        rc = CLI_FAIL;
        goto done;
    }
    if (envl_products_export(p, dir, &eo)) {
        rc = cli_fail();
        if (created)
            rmdir(dir); /* empty: the export removed its temporaries */
        goto done;
    }
    if (json) {
        char path[4096];
        snprintf(path, sizeof path, "%s/prefilter.json", dir);
        rc = print_file(path);
        goto done;
    }
    if (!c.quiet) {
        note_resampled(p, &eo, ktx2);
        note_texel_bounds(p, q.prefilter.half);
    }
    rc = print_summary(map, p, dir, &eo);
done:
    envl_products_free(p);
    envl_envmap_free(map);
    free(list);
    return rc;
#undef USAGE
}

static const char *ext_of(const char *path)
{
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    return dot && (!slash || dot > slash) ? dot + 1 : "";
}

int cli_brdf_lut(int argc, char **argv)
{
    const char *out = NULL;
    envl_brdf_options bo = {0};
    int json = 0, npos;
    cli_option t[] = {
        CLI_OPTION("-o", "FILE", CLI_TEXT, .value = &out, .takes = "a file name",
                   .help = "the table (.exr, .pfm, .hdr or .png)"),
        CLI_OPTION("--size", "S", CLI_INT, .min = 1, .max = 4096, .value = &bo.size,
                   .help = "table size (default 128)"),
        CLI_OPTION("--samples", "N", CLI_INT, .min = 1, .max = 1 << 24, .value = &bo.samples,
                   .help = "GGX samples per texel (default 4096)"),
        CLI_OPTION("--multiscatter", NULL, CLI_FLAG, .value = &bo.multiscatter,
                   .help = "the multiscatter form (see above)"),
        CLI_OPTION("--threads", "N", CLI_INT, .min = 1, .max = ENVL_MAX_THREADS,
                   .value = &bo.threads, .help = "worker threads (default: all cores)"),
        CLI_OPTION("--json", NULL, CLI_FLAG, .value = &json,
                   .help = "print the sidecar to stdout"),
    };
    int parsed = cli_parse(&brdf_command, t, CLI_COUNT(t), NULL, argc, argv, NULL, 0, &npos);
    if (parsed)
        return parsed == CLI_HELP ? CLI_OK : parsed;
    if (!out)
        return cli_usage("brdf-lut", "-o FILE is required");
    const char *ext = ext_of(out);
    int png = !strcasecmp(ext, "png");
    if (!png && strcasecmp(ext, "exr") && strcasecmp(ext, "pfm") && strcasecmp(ext, "hdr"))
        return cli_usage("brdf-lut", "FILE must end in .exr, .pfm, .hdr or .png");
    double t0 = envl__seconds();
    float *rg;
    int32_t s;
    if (envl_brdf_lut(&bo, &rg, &s))
        return cli_fail();
    double seconds = envl__seconds() - t0;
    int32_t samples = bo.samples ? bo.samples : ENVL_BRDF_DEFAULT_SAMPLES;
    /* Integration error estimate: a grid of texels again with 4x the samples. */
    double err = 0;
    int32_t step = s / 8 > 0 ? s / 8 : 1;
    for (int32_t j = step / 2; j < s; j += step)
        for (int32_t i = step / 2; i < s; i += step) {
            double ab[2];
            envl_brdf_eval((i + 0.5) / s, (j + 0.5) / s,
                           samples <= (1 << 22) ? 4 * samples : samples, ab);
            double x = bo.multiscatter ? ab[1] : ab[0], y = bo.multiscatter ? ab[0] + ab[1] : ab[1];
            const float *p = rg + 2 * ((size_t)j * s + i);
            err = fmax(err, fmax(fabs(p[0] - x), fabs(p[1] - y)));
        }
    float *rgb = malloc(sizeof(float) * 3 * (size_t)s * s);
    if (!rgb) {
        free(rg);
        cli_error("out of memory");
        return CLI_FAIL;
    }
    for (size_t i = 0; i < (size_t)s * s; i++)
        rgb[3 * i] = rg[2 * i], rgb[3 * i + 1] = rg[2 * i + 1], rgb[3 * i + 2] = 0;
    free(rg);
    envl_result r = png ? envl_png_save_srgb(out, rgb, s, s) : envl_image_save(out, rgb, s, s, NULL);
    free(rgb);
    if (r)
        return cli_fail();
    /* The sidecar. */
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    if (!f) {
        cli_error("out of memory");
        return CLI_FAIL;
    }
    json_writer j;
    json_begin(&j, f);
    json_string(&j, "file", out);
    json_string(&j, "brdf", "GGX, height-correlated Smith visibility, Schlick Fresnel");
    json_string(&j, "alpha", "roughness^2");
    json_int(&j, "size", s);
    json_int(&j, "samples", samples);
    json_bool(&j, "multiscatter", bo.multiscatter);
    json_string(&j, "axes", "column i: NoV = (i + 0.5) / S; row j from the top: roughness = "
                            "(j + 0.5) / S");
    json_string(&j, "channels", bo.multiscatter
                                    ? "R = B, G = A + B: specular = mix(R, G, F0) * (1 + F0 "
                                      "(1 / G - 1))"
                                    : "R = A (scale), G = B (bias): specular = F0 A + B");
    json_string(&j, "encoding", png ? "8-bit sRGB" : "float, blue = 0");
    json_number(&j, "integration_error", err);
    json_number(&j, "seconds", seconds);
    json_end(&j);
    fclose(f);
    char side[4096];
    snprintf(side, sizeof side, "%s.json", out);
    r = envl_file_write_atomic(side, buf, len);
    if (r) {
        free(buf);
        return cli_fail();
    }
    if (json)
        fwrite(buf, 1, len, stdout);
    else
        printf("%s: %d x %d BRDF table%s, %d samples per texel, integration error %.2g (max "
               "against 4x the samples), %.3f s; conventions in %s\n", out, (int)s, (int)s,
               bo.multiscatter ? " (multiscatter)" : "", (int)samples, err, seconds, side);
    free(buf);
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}
