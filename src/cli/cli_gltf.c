/* envlight gltf: the map as a glTF 2.0 file an engine loads (envl_gltf_export). */
#include "cli.h"
#include "json.h"
#include "repair.h"

#include <math.h>

#include <string.h>

static const cli_command gltf_command = {
    "gltf",
    "Usage: envlight gltf [FILE] -o OUT.glb|OUT.gltf [--lights sun|fit|median|variance|none]\n"
    "                     [-n N] [--size S] [--mips M] [--samples M] [input options]\n"
    "The environment for a glTF 2.0 engine (Babylon.js, three.js, Filament, Unity...), in\n"
    "glTF's frame (+Y up): its suns as KHR_lights_punctual directional lights (colour and\n"
    "intensity in lux from the irradiance each delivers) and what they did not take (so\n"
    "nothing is lit twice) as the scene's EXT_lights_image_based light: SH irradiance of\n"
    "order 2 and the GGX specular chain as RGBD PNG cube faces, mip k of M at roughness\n"
    "k / (M - 1). .glb: one binary file; .gltf: JSON with the images inline.\n",
    "Every run states the diffuse error of the lights + the SH against the whole map's exact\n"
    "irradiance, each mip's glossy error against the residual's reference, the RGBD error\n"
    "and the seconds it took. Conventions: docs/methods.md, \"glTF\".\n"};

static void write_json(const envl_envmap *map, const char *out, const envl_gltf_summary *s)
{
    envl_info info;
    envl_envmap_info(map, &info);
    json_writer j;
    json_begin(&j, stdout);
    json_string(&j, "file", info.file);
    json_string(&j, "out", out);
    json_string(&j, "frame", cli_frame_label(ENVL_FRAME_GLTF));
    json_int(&j, "bytes", s->bytes);
    json_int(&j, "lights", s->lights);
    json_int(&j, "face_size", s->face_size);
    json_int(&j, "mips", s->mips);
    json_int(&j, "prefiltered_width", s->prefiltered_width);
    json_int(&j, "prefiltered_height", s->prefiltered_height);
    json_number(&j, "intensity", s->intensity);
    json_object(&j, "error");
    json_bool(&j, "measured", s->diffuse_error >= 0);
    json_number(&j, "diffuse", s->diffuse_error >= 0 ? s->diffuse_error : NAN);
    double g[16];
    for (int32_t k = 0; k < s->mips; k++)
        g[k] = s->glossy_error[k] >= 0 ? s->glossy_error[k] : NAN;
    json_numbers(&j, "glossy", g, s->mips);
    json_array(&j, "texel"); /* per mip: docs/design.md's per-texel error */
    for (int32_t k = 0; k < s->mips; k++) {
        const envl_texel_error *t = &s->texel_error[k];
        json_object(&j, NULL);
        json_number(&j, "rms", t->rms >= 0 ? t->rms : NAN);
        json_number(&j, "worst", t->worst >= 0 ? t->worst : NAN);
        json_int(&j, "texels_measured", t->measured);
        json_int(&j, "texels", t->texels);
        json_object_end(&j);
    }
    json_array_end(&j);
    json_number(&j, "rgbd", s->rgbd_error);
    json_object_end(&j);
    json_number(&j, "seconds", s->seconds);
    repair_json(&j, &info);
    json_end(&j);
}

int cli_gltf(int argc, char **argv)
{
    cli_common c = {0};
    const char *file = NULL, *out = NULL;
    int method = ENVL_METHOD_SUN + 1, count = 0, size = 0, mips = 0, samples = 0, no_error = 0;
    int npos, json = 0;
    cli_option t[] = {
        CLI_OPTION("-o", "OUT", CLI_TEXT, .value = &out, .takes = "a .glb or .gltf file name",
                   .help = "the glTF file: .glb (binary) or .gltf (JSON, images inline)"),
        CLI_OPTION("--lights", "M", CLI_CHOICE, .value = &method,
                   .choices = "none|fit|median|variance|sun",
                   .help = "the punctual lights: sun (default: the map's suns, split off\n"
                           "exactly; none when it has none), fit, median, variance (as\n"
                           "`envlight lights --method`), none (the whole map is the IBL)"),
        CLI_OPTION("-n|--count", "N", CLI_INT, .min = 1, .max = 1 << 16, .value = &count,
                   .help = "lights (sun: at most, default 4; fit: default 4, at most 32;\n"
                           "median, variance: default 16)"),
        CLI_OPTION("--size", "S", CLI_INT, .min = 16, .max = 4096, .value = &size,
                   .help = "specularImageSize: the face of mip 0, a power of two (default 256)"),
        CLI_OPTION("--mips", "M", CLI_INT, .min = 2, .max = 13, .value = &mips,
                   .help = "specular mips, each half the last (default: down to 16 x 16)"),
        CLI_OPTION("--samples", "M", CLI_INT, .min = 1, .max = 1 << 20, .value = &samples,
                   .help = "the levels' density (as `envlight prefilter --samples`)"),
        CLI_NO_ERROR_OPTION(&no_error),
        CLI_OPTION("--json", NULL, CLI_FLAG, .value = &json,
                   .help = "print the summary as JSON (default: a table)"),
    };
    int parsed = cli_parse(&gltf_command, t, CLI_COUNT(t), &c, argc, argv, &file, 1, &npos);
    if (parsed)
        return parsed == CLI_HELP ? CLI_OK : parsed;
    if (!out)
        return cli_usage("gltf", "-o OUT.glb or OUT.gltf is required");
    const char *dot = strrchr(out, '.');
    if (!dot || (strcasecmp(dot, ".glb") && strcasecmp(dot, ".gltf")))
        return cli_usage("gltf", "-o takes a file ending in .glb or .gltf, not '%s'", out);
    if (size & (size - 1))
        return cli_usage("gltf", "--size takes a power of two, not %d", size);
    int face = size ? size : 256, most = 1;
    while ((1 << (most - 1)) < face)
        most++;
    if (mips > most)
        return cli_usage("gltf", "--mips takes 2..%d for %d-pixel faces (each mip halves the "
                         "face), not %d", most, face, mips);
    envl_lights_options lo = {.method = method - 1, .count = count};
    if (method && !cli_light_count_ok("gltf", &lo))
        return CLI_USAGE;
    envl_gltf_options go = {.face_size = size, .mips = mips, .no_lights = method == 0,
                            .lights = &lo, .samples = samples, .measure = !no_error,
                            .threads = c.load.threads};
    envl_envmap *map;
    if (cli_outputs_ok(&file, 1, &out, 1) || cli_load(file, &c, &map))
        return CLI_FAIL;
    envl_gltf_summary s;
    int rc = CLI_OK;
    if (envl_gltf_export(map, out, &go, &s)) {
        rc = cli_fail();
        goto done;
    }
    cli_coarse_note(map, s.prefiltered_width, s.prefiltered_height, c.quiet);
    if (json) {
        write_json(map, out, &s);
        rc = fflush(stdout) ? CLI_FAIL : CLI_OK;
    } else {
        envl_info info;
        envl_envmap_info(map, &info);
        char e[64], tx[96];
        printf("%s: %d x %d -> %s (%lld bytes), %.3f s\n", info.file, (int)info.width,
               (int)info.height, out, (long long)s.bytes, s.seconds);
        printf("lights       %d directional (KHR_lights_punctual)%s\n", (int)s.lights,
               method == 0 ? ", none asked" : "");
        printf("environment  SH order 2 + %d mips of %d..%d px (EXT_lights_image_based), "
               "intensity %.6g\n", (int)s.mips, (int)s.face_size,
               (int)(s.face_size >> (s.mips - 1)), s.intensity);
        printf("diffuse      lights + SH: %s\n", cli_error_text(e, sizeof e, "diffuse",
                                                              s.diffuse_error));
        for (int32_t k = 0; k < s.mips; k++)
            printf("mip %-2d       r %.3f  %s  %s\n", (int)k,
                   s.mips > 1 ? (double)k / (s.mips - 1) : 0,
                   cli_error_text(e, sizeof e, "glossy", s.glossy_error[k]),
                   cli_texel_text(tx, sizeof tx, &s.texel_error[k]));
        printf("rgbd         error %.3f %% (decoded faces against their floats)\n",
               100 * s.rgbd_error);
        if (fflush(stdout))
            rc = CLI_FAIL;
    }
done:
    envl_envmap_free(map);
    return rc;
}
