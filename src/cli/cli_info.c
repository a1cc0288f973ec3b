/* envlight info, envlight convert. */
#include "cli.h"
#include "json.h"
#include "repair.h"

#include <string.h>

static const cli_command info_command = {
    "info",
    "Usage: envlight info [FILE] [--json] [input options]\n"
    "Size, layout, channels, statistics (mean radiance over the sphere, power = integral of\n"
    "L dw, per-channel maximum), brightest direction (canonical frame: +Z up, +X at the\n"
    "lat-long centre), the count of non-finite and negative pixels and what was done to them\n"
    "(negative values filled from the light around them: the power stays the file's signed\n"
    "sum).\n",
    NULL};

static void info_json(FILE *f, const envl_info *in)
{
    json_writer j;
    json_begin(&j, f);
    json_string(&j, "file", in->file);
    json_string(&j, "format", in->format);
    json_string(&j, "layout", envl_layout_name(in->layout));
    json_bool(&j, "layout_guessed", in->layout_guessed);
    /* true: the layout follows from the file's shape or metadata; false after a real guess */
    json_bool(&j, "layout_evident", !in->layout_guessed || cli_layout_evident(in));
    json_int(&j, "width", in->source_width);
    json_int(&j, "height", in->source_height);
    json_int(&j, "channels", in->channels);
    json_numbers(&j, "mean", in->mean, 3);
    json_numbers(&j, "power", in->power, 3);
    json_numbers(&j, "max", in->max, 3);
    json_numbers(&j, "brightest_direction", in->brightest_direction, 3);
    json_int(&j, "nonfinite_pixels", in->nonfinite_pixels);
    json_int(&j, "negative_pixels", in->negative_pixels);
    json_string(&j, "frame", "blender-z-up");
    json_int(&j, "envmap_width", in->width);
    json_int(&j, "envmap_height", in->height);
    json_number(&j, "exposure", in->exposure);
    if (in->has_primaries) {
        double p[8];
        for (int i = 0; i < 8; i++)
            p[i] = in->primaries[i];
        json_numbers(&j, "primaries", p, 8);
    }
    json_number(&j, "rotate_degrees", in->rotate_degrees);
    repair_json(&j, in);
    json_end(&j);
}

/* How the layout was chosen; the command line's other commands say it only for a real guess
 * (cli_load), info always. */
static const char *layout_note(const envl_info *in)
{
    if (!in->layout_guessed)
        return ""; /* --layout-in */
    if (!cli_layout_evident(in))
        return " (a guess: --layout-in to choose)";
    switch (in->layout) {
    case ENVL_LAYOUT_LATLONG: return " (guessed from the 2:1 aspect ratio)";
    case ENVL_LAYOUT_CROSS_V: return " (guessed from the 3:4 aspect ratio)";
    case ENVL_LAYOUT_CROSS_H: return " (guessed from the 4:3 aspect ratio)";
    case ENVL_LAYOUT_STRIP_H: return " (guessed from the 6:1 aspect ratio)";
    case ENVL_LAYOUT_STRIP_V: return " (guessed from the 1:6 aspect ratio)";
    default: return " (from the file's envmap attribute)";
    }
}

static void info_text(FILE *f, const envl_info *in)
{
    fprintf(f, "file:        %s\n", in->file);
    fprintf(f, "format:      %s, %d channel%s\n", in->format, in->channels,
            in->channels == 1 ? "" : "s");
    fprintf(f, "size:        %d x %d, layout %s%s\n", in->source_width, in->source_height,
            envl_layout_name(in->layout), layout_note(in));
    fprintf(f, "envmap:      %d x %d lat-long (frame: Blender, +Z up)\n", in->width, in->height);
    fprintf(f, "mean:        %.6g %.6g %.6g\n", in->mean[0], in->mean[1], in->mean[2]);
    fprintf(f, "power:       %.6g %.6g %.6g\n", in->power[0], in->power[1], in->power[2]);
    fprintf(f, "max:         %.6g %.6g %.6g\n", in->max[0], in->max[1], in->max[2]);
    fprintf(f, "brightest:   %.4f %.4f %.4f\n", in->brightest_direction[0],
            in->brightest_direction[1], in->brightest_direction[2]);
    fprintf(f, "non-finite:  %lld pixels, negative: %lld pixels\n",
            (long long)in->nonfinite_pixels, (long long)in->negative_pixels);
    if (in->nonfinite_pixels && in->infinity_value > 0)
        fprintf(f, "replaced:    NaN and -Inf by 0, +Inf by %g (the largest finite value)\n",
                in->infinity_value);
    else if (in->nonfinite_pixels)
        fprintf(f, "replaced:    NaN and -Inf by 0\n");
    if (in->negative_pixels) {
        fprintf(f, "negative:    down to %g; filled from the light within %d px: %.6g %.6g %.6g "
                "moved\n", in->negative_min, in->fill_window, in->filled_energy[0],
                in->filled_energy[1], in->filled_energy[2]);
        fprintf(f, "signed sum:  %.6g %.6g %.6g (the file's power, negative values included)\n",
                in->signed_power[0], in->signed_power[1], in->signed_power[2]);
        if (in->unfilled_values)
            fprintf(f, "unfilled:    %lld negative values set to 0 (too little light around "
                    "them): %.6g %.6g %.6g added\n", (long long)in->unfilled_values,
                    in->added_energy[0], in->added_energy[1], in->added_energy[2]);
    }
    if (in->exposure != 1.0)
        fprintf(f, "exposure:    %g\n", in->exposure);
}

int cli_info(int argc, char **argv)
{
    cli_common c = {0};
    const char *file = NULL;
    int json = 0, npos;
    cli_option t[] = {CLI_OPTION("--json", NULL, CLI_FLAG, .value = &json,
                                 .help = "JSON on stdout (default: text)")};
    int parsed = cli_parse(&info_command, t, CLI_COUNT(t), &c, argc, argv, &file, 1, &npos);
    if (parsed)
        return parsed == CLI_HELP ? CLI_OK : parsed;
    envl_envmap *map;
    if (cli_load(file, &c, &map))
        return CLI_FAIL;
    envl_info info;
    envl_envmap_info(map, &info);
    if (json)
        info_json(stdout, &info);
    else
        info_text(stdout, &info);
    envl_envmap_free(map);
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}

static const cli_command convert_command = {
    "convert",
    "Usage: envlight convert IN OUT [--layout-out L] [--size S] [--half] [input options]\n"
    "Reads IN (.hdr/.pic, .exr, .pfm in any input layout; '-' for the built-in sky) into the\n"
    "canonical lat-long frame and writes OUT (.hdr, .exr or .pfm by extension), atomically.\n",
    NULL};

int cli_convert(int argc, char **argv)
{
    cli_common c = {0};
    const char *in = NULL, *out = NULL;
    int layout_out = ENVL_LAYOUT_LATLONG, size = 0, npos;
    envl_save_options so = {0};
    cli_option t[] = {
        CLI_OPTION("--layout-out", "L", CLI_CHOICE, .value = &layout_out,
                   .choices = "latlong|angular|mirrorball|cross|hcross|hstrip|vstrip|"
                              "exr-latlong|exr-cube",
                   .lookup = envl_layout_from_name,
                   .help = "latlong (default), angular, mirrorball, cross, hcross, hstrip,\n"
                           "vstrip, exr-latlong, exr-cube"),
        CLI_OPTION("--size", "S", CLI_INT, .min = 1, .max = 1 << 20, .value = &size,
                   .help = "output width (lat-long), face size (cubes) or diameter (probes)"),
        CLI_OPTION("--half", NULL, CLI_FLAG, .max = ENVL_PIXEL_HALF, .value = &so.pixel_type,
                   .help = "EXR with 16-bit half channels (values beyond 65504 clamp)"),
    };
    const char *pos[2] = {NULL, NULL};
    int parsed = cli_parse(&convert_command, t, CLI_COUNT(t), &c, argc, argv, pos, 2, &npos);
    if (parsed)
        return parsed == CLI_HELP ? CLI_OK : parsed;
    if (layout_out == ENVL_LAYOUT_AUTO)
        return cli_usage("convert", "--layout-out needs a layout, not auto");
    in = pos[0], out = pos[1];
    if (!in || !out)
        return cli_usage("convert", "needs IN and OUT");
    envl_envmap *map;
    if (cli_outputs_ok(&in, 1, &out, 1) || cli_load(in, &c, &map))
        return CLI_FAIL;
    /* progress (on a terminal): the library reports reading and resampling, this the writing */
    char stage[80];
    snprintf(stage, sizeof stage, "writing %s", out);
    envl_result rc = ENVL_OK;
    int cancelled = 0; /* the display's cancel before writing: nothing written */
    if (layout_out == ENVL_LAYOUT_LATLONG && !size) {
        if (so.pixel_type == ENVL_PIXEL_HALF)
            cli_half_warning(out, envl_envmap_pixels(map),
                             3 * (size_t)envl_envmap_width(map) * envl_envmap_height(map),
                             c.quiet);
        if (!(cancelled = cli_progress(0.0, stage)))
            rc = envl_envmap_save(map, out, &so);
    } else {
        float *px = NULL;
        int32_t w, h;
        if (!size) /* a face (or probe) of at least one pixel: a map 2 wide gave 0 */
            size = layout_out == ENVL_LAYOUT_LATLONG || layout_out == ENVL_LAYOUT_EXR_LATLONG
                       ? envl_envmap_width(map)
                       : envl_envmap_width(map) / 4 > 1 ? envl_envmap_width(map) / 4 : 1;
        /* OpenEXR's own layouts say so in the file (the envmap attribute; EXR only) */
        if (layout_out == ENVL_LAYOUT_EXR_LATLONG || layout_out == ENVL_LAYOUT_EXR_CUBE)
            so.envmap = layout_out;
        rc = envl_envmap_to_layout(map, layout_out, (int32_t)size, &px, &w, &h);
        if (rc == ENVL_OK && so.pixel_type == ENVL_PIXEL_HALF)
            cli_half_warning(out, px, 3 * (size_t)w * h, c.quiet);
        if (rc == ENVL_OK && !(cancelled = cli_progress(0.0, stage)))
            rc = envl_image_save(out, px, w, h, &so);
        envl_free(px);
    }
    envl_envmap_free(map);
    if (cancelled) {
        cli_error("cancelled before %s: nothing written", stage);
        return CLI_FAIL;
    }
    if (rc == ENVL_OK)
        cli_progress(1.0, "done");
    return rc ? cli_fail() : CLI_OK;
}
