/* envlight sh: spherical-harmonic radiance and irradiance coefficients. */
#include "cli.h"
#include "json.h"
#include "repair.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const cli_command sh_command = {
    "sh",
    "Usage: envlight sh [FILE] [--order L] [--window none|hann|lanczos|auto] [--json]\n"
    "                   [--frame blender|gltf] [-o OUT] [input options]\n"
    "Real SH (no Condon-Shortley phase; l <= 2 as Ramamoorthi & Hanrahan 2001), coefficient\n"
    "order l = 0..L, m = -l..l, canonical frame (Blender, +Z up; --frame gltf: +Y up).\n"
    "Irradiance = A_l x radiance.\n",
    "Also reported: ambient + x/y/z deltas (E(n) ~ ambient + deltas . n) and the hemispheric\n"
    "sky/ground pair with its axis, in irradiance units (never negative: the best fit with\n"
    "sky, ground >= 0, said on stderr when that clamps); the diffuse error and seconds.\n"};

static void coef_array(json_writer *j, const char *key, const double *c, int n)
{
    json_array(j, key);
    for (int i = 0; i < n; i++)
        json_numbers(j, NULL, c + 3 * i, 3);
    json_array_end(j);
}

/* The hemispheric ends of the unconstrained linear fit, ambient +- deltas . axis (fit[0] sky,
 * fit[1] ground), and which of them the library clamped to 0 (a channel below 0). */
static void hemi_plain_fit(const envl_sh_summary *s, double fit[2][3], int clamped[2])
{
    clamped[0] = clamped[1] = 0;
    for (int ch = 0; ch < 3; ch++) {
        double c1 = 0;
        for (int a = 0; a < 3; a++)
            c1 += s->deltas[a][ch] * s->hemi_axis[a];
        fit[0][ch] = s->ambient[ch] + c1;
        fit[1][ch] = s->ambient[ch] - c1;
        clamped[0] |= fit[0][ch] < 0;
        clamped[1] |= fit[1][ch] < 0;
    }
}

/* What a user must know about negative light: an expansion that goes negative (window none,
 * hann, lanczos) and a hemispheric end clamped to 0 (auto's width is in the output). */
static void report_negative(const cli_common *c, const envl_sh *sh, const envl_sh_summary *s,
                            const char *file)
{
    if (c->quiet)
        return;
    /* the least channel of the irradiance at 4096 Fibonacci normals (auto's own test) */
    double least = INFINITY, e[3];
    for (int i = 0; i < 4096; i++) {
        double n[3];
        envl_fibonacci_direction(i, 4096, n);
        envl_sh_eval_irradiance(sh, 1, n, e);
        least = fmin(least, fmin(e[0], fmin(e[1], e[2])));
    }
    if (least < 0)
        cli_error("%s: warning: the SH irradiance (window %s) is negative over part of the "
                  "sphere (least %.6g in a channel); --window auto avoids it", file,
                  envl_window_name(s->window), least);
    double fit[2][3];
    int clamped[2];
    hemi_plain_fit(s, fit, clamped);
    for (int end = 0; end < 2; end++)
        if (clamped[end])
            cli_error("%s: hemispheric %s: the plain linear fit gives %.6g %.6g %.6g; written as "
                      "%.6g %.6g %.6g (the best fit with sky, ground >= 0)", file,
                      end ? "ground" : "sky", fit[end][0], fit[end][1], fit[end][2],
                      end ? s->hemi_ground[0] : s->hemi_sky[0],
                      end ? s->hemi_ground[1] : s->hemi_sky[1],
                      end ? s->hemi_ground[2] : s->hemi_sky[2]);
}

int cli_sh(int argc, char **argv)
{
    cli_common c = {0};
    const char *file = NULL, *out = NULL;
    int order = ENVL_DEFAULT_ORDER, window = ENVL_WINDOW_AUTO, json = 0, no_error = 0, npos;
    int frame = ENVL_FRAME_BLENDER;
    cli_option t[] = {
        CLI_OPTION("--order", "L", CLI_INT, .min = 0, .max = 32, .value = &order,
                   .help = "0..32 (default 2)"),
        CLI_OPTION("--window", "W", CLI_CHOICE, .value = &window,
                   .choices = "none|hann|lanczos|auto", .lookup = envl_window_from_name,
                   .help = "auto (default: the least windowing that keeps the irradiance\n"
                           "non-negative in every channel; the width found is reported; none\n"
                           "when nothing rings), none (the plain truncated expansion: can go\n"
                           "negative, said on stderr), hann, lanczos"),
        CLI_NO_ERROR_OPTION(&no_error),
        CLI_FRAME_OPTION(&frame),
        CLI_OPTION("--json", NULL, CLI_FLAG, .value = &json,
                   .help = "JSON on stdout (default: a table)"),
        CLI_OPTION("-o", "OUT", CLI_TEXT, .value = &out, .takes = "a file name",
                   .help = "write the output to OUT (atomically) instead of stdout"),
    };
    int parsed = cli_parse(&sh_command, t, CLI_COUNT(t), &c, argc, argv, &file, 1, &npos);
    if (parsed)
        return parsed == CLI_HELP ? CLI_OK : parsed;
    envl_sh_options so = {.order = order ? order : ENVL_ORDER_0, .window = window,
                          .measure = !no_error};
    envl_envmap *map;
    if (cli_outputs_ok(&file, 1, &out, 1) || cli_load(file, &c, &map))
        return CLI_FAIL;
    envl_sh *sh;
    if (envl_sh_compute(map, &so, &sh)) {
        envl_envmap_free(map);
        return cli_fail();
    }
    envl_sh_summary s;
    envl_sh_get_summary(sh, &s);
    envl_info info;
    envl_envmap_info(map, &info);
    int n = (s.order + 1) * (s.order + 1);
    report_negative(&c, sh, &s, info.file);
    /* in the frame asked for: the coefficients turned, the deltas and the axis as vectors */
    double *rad = malloc(sizeof(double) * 3 * n), *irr = malloc(sizeof(double) * 3 * n);
    if (!rad || !irr || envl_sh_to_frame(frame, s.order, 3, envl_sh_radiance(sh), rad) ||
        envl_sh_to_frame(frame, s.order, 3, envl_sh_irradiance(sh), irr)) {
        free(rad), free(irr);
        envl_sh_free(sh);
        envl_envmap_free(map);
        return cli_fail();
    }
    for (int ch = 0; ch < 3; ch++) {
        double d[3] = {s.deltas[0][ch], s.deltas[1][ch], s.deltas[2][ch]};
        envl_frame_vector(frame, d, d);
        for (int a = 0; a < 3; a++)
            s.deltas[a][ch] = d[a];
    }
    envl_frame_vector(frame, s.hemi_axis, s.hemi_axis);
    cli_output o;
    int rc = cli_output_open(&o, out);
    if (rc == CLI_OK) {
        if (json) {
            json_writer j;
            json_begin(&j, o.f);
            json_string(&j, "file", info.file);
            json_string(&j, "frame", cli_frame_label(frame));
            json_int(&j, "order", s.order);
            json_string(&j, "window", envl_window_name(s.window));
            json_number(&j, "window_width", s.window_width);
            json_numbers(&j, "window_factors", envl_sh_window_factors(sh), s.order + 1);
            json_string(&j, "basis", "real, no Condon-Shortley phase");
            coef_array(&j, "radiance", rad, n);
            coef_array(&j, "irradiance", irr, n);
            json_number(&j, "min_irradiance", s.min_irradiance);
            json_object(&j, "ambient_deltas");
            json_numbers(&j, "ambient", s.ambient, 3);
            json_numbers(&j, "dx", s.deltas[0], 3);
            json_numbers(&j, "dy", s.deltas[1], 3);
            json_numbers(&j, "dz", s.deltas[2], 3);
            json_object_end(&j);
            json_object(&j, "hemispheric");
            json_numbers(&j, "axis", s.hemi_axis, 3);
            json_numbers(&j, "sky", s.hemi_sky, 3);
            json_numbers(&j, "ground", s.hemi_ground, 3);
            /* how negative light was handled: the ends the plain fit took below 0, set to 0 */
            double fit[2][3];
            int clamped[2];
            hemi_plain_fit(&s, fit, clamped);
            json_string(&j, "fit", "least squares over the sphere with sky, ground >= 0");
            json_string(&j, "clamped", clamped[0] && clamped[1] ? "sky and ground"
                                       : clamped[0]              ? "sky"
                                       : clamped[1]              ? "ground"
                                                                 : "none");
            json_object_end(&j);
            json_object(&j, "error");
            json_bool(&j, "measured", s.diffuse_error >= 0);
            json_number(&j, "diffuse", s.diffuse_error >= 0 ? s.diffuse_error : NAN);
            json_object_end(&j);
            json_number(&j, "seconds", s.seconds);
            repair_json(&j, &info);
            json_end(&j);
        } else {
            fprintf(o.f, "%s: SH order %d, window %s", info.file, s.order,
                    envl_window_name(s.window));
            if (s.window == ENVL_WINDOW_AUTO && s.window_width > 0)
                fprintf(o.f, " (Hann width %.4g)", s.window_width);
            char e[64];
            fprintf(o.f, ", %s, %.4f s, frame %s\n",
                    cli_error_text(e, sizeof e, "diffuse", s.diffuse_error), s.seconds,
                    cli_frame_label(frame));
            for (int l = 0, i = 0; l <= s.order; l++)
                for (int m = -l; m <= l; m++, i++)
                    fprintf(o.f, "L%d,%-3d radiance %12.6g %12.6g %12.6g  irradiance %12.6g %12.6g "
                            "%12.6g\n", l, m, rad[3 * i], rad[3 * i + 1], rad[3 * i + 2],
                            irr[3 * i], irr[3 * i + 1], irr[3 * i + 2]);
            fprintf(o.f, "ambient %.6g %.6g %.6g; hemispheric axis %.4f %.4f %.4f sky %.6g %.6g "
                    "%.6g ground %.6g %.6g %.6g\n", s.ambient[0], s.ambient[1], s.ambient[2],
                    s.hemi_axis[0], s.hemi_axis[1], s.hemi_axis[2], s.hemi_sky[0], s.hemi_sky[1],
                    s.hemi_sky[2], s.hemi_ground[0], s.hemi_ground[1], s.hemi_ground[2]);
        }
        rc = cli_output_close(&o);
    }
    free(rad), free(irr);
    envl_sh_free(sh);
    envl_envmap_free(map);
    return rc;
}
