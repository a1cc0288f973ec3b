/* glTF 2.0 export (envl_gltf_export): the map's suns as KHR_lights_punctual directional lights,
 * the rest as the scene's EXT_lights_image_based light (SH irradiance + RGBD cube mips), in
 * one .glb or .gltf written atomically. Conventions: docs/methods.md, "glTF". */
#include "internal.h"
#include "clock.h"
#include "error_measure.h"
#include "json.h"
#include "repair.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

enum { MIN_FACE = 16, MAX_FACE = 4096, LAST_MIP_FACE = 16 };

/* The PNG faces, in the order they are referenced: mip-major, +X -X +Y -Y +Z -Z. */
typedef struct face_images {
    uint8_t **png;
    size_t *size;
    int32_t n;
} face_images;

static void faces_free(face_images *f)
{
    for (int32_t i = 0; i < f->n; i++)
        free(f->png[i]);
    free(f->png);
    free(f->size);
}

static int32_t log2_exact(int32_t v)
{
    int32_t k = 0;
    while ((1 << k) < v)
        k++;
    return (1 << k) == v ? k : -1;
}

/* Largest channel over the specular levels: the IBL's intensity is that / 255, so the
 * brightest texel is stored as D = 1 / 255 and nothing clamps. */
static double levels_max(const envl_products *p)
{
    double m = 0;
    for (int32_t i = 0; i < envl_products_level_count(p); i++) {
        envl_level l;
        envl_products_level(p, i, &l);
        for (size_t k = 0; k < (size_t)l.width * l.height * 3; k++)
            m = fmax(m, l.rgb[k]);
    }
    return m;
}

/* Mip `level` as six RGBD PNGs of `face` pixels, as Babylon.js (the extension's reference
 * implementation) renders them in its default left-handed scene (tests/py_gltf_babylon.py):
 * slot f holds OpenGL's face f of the glTF frame (layout.c's GL strip) turned half a turn
 * (mirrored left to right and top to bottom), with the +Y and -Y slots swapped; that is
 * OpenGL's face f of the frame (x, -y, z), mirrored left to right, the extension's "flipped
 * about its vertical axis". The stored value is the radiance / scale; *error: relative RMS
 * (luminance) of the decoded texels against the floats they encode. */
static envl_result encode_mip(const envl_level *l, int32_t face, double scale, face_images *out,
                              double *error)
{
    if (l->layout != ENVL_LAYOUT_STRIP_H || l->height != face)
        return envl__fail(ENVL_ERR_ARGUMENT, "gltf: mip of %d-texel faces computed as %d",
                          (int)face, (int)l->height);
    envl_image glf; /* OpenGL's six faces of the glTF frame: the level's texels rearranged */
    envl_result rc = envl__faces_to_layout(l->rgb, face, ENVL__LAYOUT_GL_STRIP, &glf);
    if (rc)
        return rc;
    size_t n = (size_t)face * face;
    uint8_t *px = malloc(4 * n);
    double *want = malloc(sizeof(double) * 3 * 6 * n), *got = malloc(sizeof(double) * 3 * 6 * n);
    if (!px || !want || !got)
        rc = envl__fail(ENVL_ERR_MEMORY, "gltf: out of memory");
    for (int32_t f = 0; f < 6 && !rc; f++) {
        int32_t g = f == 2 ? 3 : f == 3 ? 2 : f; /* +Y and -Y swapped */
        for (int32_t r = 0; r < face; r++)
            for (int32_t i = 0; i < face; i++) {
                const float *c = glf.px + 3 * ((size_t)(face - 1 - r) * 6 * face +
                                               (size_t)g * face + (size_t)(face - 1 - i));
                float v[3], back[3];
                size_t t = (size_t)r * face + i, k = f * n + t;
                for (int ch = 0; ch < 3; ch++)
                    v[ch] = (float)(c[ch] / scale);
                envl_rgbd_encode(v, px + 4 * t);
                envl_rgbd_decode(px + 4 * t, back);
                for (int ch = 0; ch < 3; ch++)
                    want[3 * k + ch] = v[ch], got[3 * k + ch] = back[ch];
            }
        char what[64];
        snprintf(what, sizeof what, "gltf: face %d of a %d-pixel mip", (int)f, (int)face);
        rc = envl__png_encode(what, px, face, face, 4, 0, &out->png[out->n], &out->size[out->n]);
        if (!rc)
            out->n++;
    }
    if (!rc)
        *error = envl_relative_rms_luminance((int32_t)(6 * n), got, want);
    free(px);
    free(want);
    free(got);
    envl__image_free(&glf);
    return rc;
}

/* The rotation taking the node's +Z to d (so its -Z, where a glTF directional light shines,
 * points along -d, from the light into the scene): q = normalize(z x d, 1 + z . d). */
static void light_rotation(const double d[3], double q[4])
{
    double w = 1.0 + d[2];
    if (w < 1e-12) { /* d = -Z: half a turn about X */
        q[0] = 1, q[1] = q[2] = q[3] = 0;
        return;
    }
    double v[4] = {-d[1], d[0], 0.0, w};
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[3] * v[3]);
    for (int k = 0; k < 4; k++)
        q[k] = v[k] / len;
}

/* Babylon.js's SH basis (SphericalHarmonics: SH3ylmBasisConstants) carries the Condon-Shortley
 * sign on m = +-1 (indices 1, 3, 5, 7): its coefficients there are the negated ones of
 * docs/design.md's basis. And Babylon evaluates them at its world normal, which in its default
 * left-handed scene is glTF's (-x, y, z) (the loader's __root__ node maps glTF into it; the
 * environment is not under that node): written in that frame, the functions odd in x (x, xy,
 * xz: indices 3, 4, 7) change sign too. Rendered and checked: tests/py_gltf_babylon.py. */
static const double babylon_sign[9] = {1, -1, 1, 1, -1, -1, 1, 1, 1};

static const char *b64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/* "data:image/png;base64,..." (malloc'd; NULL when out of memory). */
static char *data_uri(const uint8_t *d, size_t n)
{
    static const char head[] = "data:image/png;base64,";
    char *s = malloc(sizeof head + 4 * ((n + 2) / 3));
    if (!s)
        return NULL;
    char *o = s + sizeof head - 1;
    memcpy(s, head, sizeof head - 1);
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)d[i] << 16 | (i + 1 < n ? (uint32_t)d[i + 1] << 8 : 0) |
                     (i + 2 < n ? d[i + 2] : 0);
        *o++ = b64[v >> 18 & 63];
        *o++ = b64[v >> 12 & 63];
        *o++ = i + 1 < n ? b64[v >> 6 & 63] : '=';
        *o++ = i + 2 < n ? b64[v & 63] : '=';
    }
    *o = 0;
    return s;
}

typedef struct ibl {
    double coeff[9][3];       /* irradianceCoefficients, glTF frame, Babylon's basis */
    double intensity;
    int32_t face, mips;
    const double *roughness;
} ibl;

/* asset: the version, the generator, and in extras every convention and figure. */
static void write_asset(json_writer *j, const envl_envmap *map, const ibl *b,
                        const envl_gltf_summary *s)
{
    envl_info info;
    envl_envmap_info(map, &info);
    json_object(j, "asset");
    json_string(j, "version", "2.0");
    char gen[64];
    snprintf(gen, sizeof gen, "envlight %s", envl_version_string());
    json_string(j, "generator", gen);
    json_object(j, "extras");
    json_string(j, "source", info.file);
    repair_json(j, &info);
    json_string(j, "frame", "gltf-y-up: right-handed, +Y up (the source's +Z up turned: (x, y, "
                "z) -> (x, z, -y))");
    json_string(j, "units", "the source's radiance, taken as cd/m^2: light intensity in lux, "
                "the IBL's faces and coefficients x intensity in the source's units");
    json_string(j, "nothing_twice", "the IBL is the map less what the punctual lights took");
    json_string(j, "cube_faces", "specularImages[k][f] = OpenGL's cube face f (+X -X +Y -Y +Z "
                "-Z) of the frame (x, -y, z) of glTF's, mirrored left to right, as Babylon.js "
                "renders them in a left-handed scene: texel (i, j) of an N x N face (row j = 0 "
                "first) is s = 1 - (i + 0.5) / N, t = (j + 0.5) / N of the OpenGL spec's cube "
                "face table, the direction's y negated (so slot f is glTF's face f turned half "
                "a turn, +Y and -Y swapped); RGBD PNG (rgb = (png.rgb)^2.2 / png.a, times "
                "intensity)");
    json_numbers(j, "mip_roughness", b->roughness, b->mips);
    json_string(j, "ggx", "prefiltered radiance P(R) = sum L D(h) max(R.l, 0) dw / sum D(h) "
                "max(R.l, 0) dw, alpha = roughness^2");
    json_string(j, "irradiance_coefficients", "E(n) = intensity sum_lm c_lm K_lm T_lm(n) in "
                "Babylon.js's basis (SphericalHarmonics: K = 0.282095, -0.488603, 0.488603, "
                "-0.488603, 1.092548, -1.092548, 0.315392, -1.092548, 0.546274; T = 1, y, z, x, "
                "xy, yz, 3z^2 - 1, xz, x^2 - y^2), n = (-x, y, z) for glTF's (x, y, z) (Babylon's "
                "left-handed world, as its loader puts glTF in it); c = A_l L_lm (irradiance)");
    json_number(j, "diffuse_error", s->diffuse_error >= 0 ? s->diffuse_error : NAN);
    json_numbers(j, "glossy_error", s->glossy_error, b->mips);
    json_array(j, "texel_error"); /* per mip: docs/design.md's per-texel error, RMS and worst */
    for (int32_t k = 0; k < b->mips; k++) {
        json_object(j, NULL);
        json_number(j, "rms", s->texel_error[k].rms >= 0 ? s->texel_error[k].rms : NAN);
        json_number(j, "worst", s->texel_error[k].worst >= 0 ? s->texel_error[k].worst : NAN);
        json_int(j, "texels_measured", s->texel_error[k].measured);
        json_int(j, "texels", s->texel_error[k].texels);
        json_object_end(j);
    }
    json_array_end(j);
    json_number(j, "rgbd_error", s->rgbd_error);
    json_number(j, "seconds", s->seconds);
    json_object_end(j);
    json_object_end(j);
}

/* KHR_lights_punctual's lights: intensity = max(rgb), color = rgb / intensity. */
static void write_punctual(json_writer *j, const envl_lights *ls, int32_t nl)
{
    json_object(j, "KHR_lights_punctual");
    json_array(j, "lights");
    for (int32_t i = 0; i < nl; i++) {
        envl_light l;
        envl_lights_get(ls, i, &l);
        double d[3], rgb[3]; /* over the residual the IBL holds (envl_light_over_residual) */
        envl_light_over_residual(&l, d, rgb);
        double m = fmax(rgb[0], fmax(rgb[1], rgb[2]));
        double color[3] = {1, 1, 1};
        for (int k = 0; m > 0 && k < 3; k++)
            color[k] = rgb[k] / m;
        char name[32];
        snprintf(name, sizeof name, "sun_%d", (int)i);
        json_object(j, NULL);
        json_string(j, "name", name);
        json_string(j, "type", "directional");
        json_numbers(j, "color", color, 3);
        json_number(j, "intensity", m);
        json_object(j, "extras");
        json_number(j, "angular_diameter", l.take_angle);
        json_number(j, "solid_angle", l.take_solid_angle);
        json_object_end(j);
        json_object_end(j);
    }
    json_array_end(j);
    json_object_end(j);
}

/* EXT_lights_image_based's one light: images 6 k .. 6 k + 5 are mip k's faces. */
static void write_image_based(json_writer *j, const ibl *b)
{
    json_object(j, "EXT_lights_image_based");
    json_array(j, "lights");
    json_object(j, NULL);
    json_string(j, "name", "environment");
    json_number(j, "intensity", b->intensity);
    json_numbers(j, "rotation", (const double[4]){0, 0, 0, 1}, 4);
    json_array(j, "irradianceCoefficients");
    for (int k = 0; k < 9; k++)
        json_numbers(j, NULL, b->coeff[k], 3);
    json_array_end(j);
    json_int(j, "specularImageSize", b->face);
    json_array(j, "specularImages");
    for (int32_t m = 0; m < b->mips; m++) {
        double idx[6];
        for (int k = 0; k < 6; k++)
            idx[k] = 6 * m + k;
        json_numbers(j, NULL, idx, 6);
    }
    json_array_end(j);
    json_object_end(j);
    json_array_end(j);
    json_object_end(j);
}

/* The scene (its image-based light) and one node per punctual light. Without a light the
 * scene has no "nodes" (optional in glTF 2.0; an empty array is an error: EMPTY_ENTITY). */
static void write_scene(json_writer *j, const envl_lights *ls, int32_t nl)
{
    json_int(j, "scene", 0);
    json_array(j, "scenes");
    json_object(j, NULL);
    json_string(j, "name", "envlight");
    if (nl) {
        json_array(j, "nodes");
        for (int32_t i = 0; i < nl; i++)
            json_int(j, NULL, i);
        json_array_end(j);
    }
    json_object(j, "extensions");
    json_object(j, "EXT_lights_image_based");
    json_int(j, "light", 0);
    json_object_end(j);
    json_object_end(j);
    json_object_end(j);
    json_array_end(j);
    if (!nl)
        return;
    json_array(j, "nodes");
    for (int32_t i = 0; i < nl; i++) {
        envl_light l;
        envl_lights_get(ls, i, &l);
        double d[3], rgb[3], q[4];
        envl_light_over_residual(&l, d, rgb);
        envl_frame_vector(ENVL_FRAME_GLTF, d, d);
        light_rotation(d, q);
        char name[32];
        snprintf(name, sizeof name, "sun_%d", (int)i);
        json_object(j, NULL);
        json_string(j, "name", name);
        json_numbers(j, "rotation", q, 4);
        json_object(j, "extensions");
        json_object(j, "KHR_lights_punctual");
        json_int(j, "light", i);
        json_object_end(j);
        json_object_end(j);
        json_object_end(j);
    }
    json_array_end(j);
}

/* images, and for .glb their buffer views into the one buffer (the BIN chunk). */
static envl_result write_images(json_writer *j, const face_images *img, int glb,
                                const size_t *offsets, size_t bin_size)
{
    envl_result rc = ENVL_OK;
    json_array(j, "images");
    for (int32_t i = 0; i < img->n; i++) {
        json_object(j, NULL);
        if (glb) {
            json_int(j, "bufferView", i);
            json_string(j, "mimeType", "image/png");
        } else {
            char *uri = data_uri(img->png[i], img->size[i]);
            if (!uri)
                rc = envl__fail(ENVL_ERR_MEMORY, "gltf: out of memory");
            else
                json_string(j, "uri", uri);
            free(uri);
        }
        json_object_end(j);
    }
    json_array_end(j);
    if (!glb)
        return rc;
    json_array(j, "bufferViews");
    for (int32_t i = 0; i < img->n; i++) {
        json_object(j, NULL);
        json_int(j, "buffer", 0);
        json_int(j, "byteOffset", (int64_t)offsets[i]);
        json_int(j, "byteLength", (int64_t)img->size[i]);
        json_object_end(j);
    }
    json_array_end(j);
    json_array(j, "buffers");
    json_object(j, NULL);
    json_int(j, "byteLength", (int64_t)bin_size);
    json_object_end(j);
    json_array_end(j);
    return rc;
}

/* The glTF document. glb: images in the binary chunk at offsets; else data URIs. */
static envl_result write_document(FILE *f, const envl_envmap *map, const envl_lights *ls,
                                  const ibl *b, const face_images *img, int glb,
                                  const size_t *offsets, size_t bin_size,
                                  const envl_gltf_summary *s)
{
    json_writer j;
    int32_t nl = ls ? envl_lights_count(ls) : 0;
    json_begin(&j, f);
    write_asset(&j, map, b, s);
    json_array(&j, "extensionsUsed");
    if (nl)
        json_string(&j, NULL, "KHR_lights_punctual");
    json_string(&j, NULL, "EXT_lights_image_based");
    json_array_end(&j);
    json_object(&j, "extensions");
    if (nl)
        write_punctual(&j, ls, nl);
    write_image_based(&j, b);
    json_object_end(&j);
    write_scene(&j, ls, nl);
    envl_result rc = write_images(&j, img, glb, offsets, bin_size);
    json_end(&j);
    return rc;
}

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v, p[1] = (uint8_t)(v >> 8), p[2] = (uint8_t)(v >> 16), p[3] = (uint8_t)(v >> 24);
}

/* The file's bytes: the JSON (.gltf), or the GLB container (glTF 2.0 spec, "GLB File Format
 * Specification": a 12-byte header, the JSON chunk padded with spaces and the BIN chunk padded
 * with zeros to 4 bytes). */
static envl_result build_file(const envl_envmap *map, const envl_lights *ls, const ibl *b,
                              const face_images *img, int glb, const envl_gltf_summary *s,
                              uint8_t **out, size_t *size)
{
    size_t *offsets = calloc((size_t)img->n + 1, sizeof *offsets);
    if (!offsets)
        return envl__fail(ENVL_ERR_MEMORY, "gltf: out of memory");
    size_t bin = 0;
    for (int32_t i = 0; i < img->n; i++) {
        offsets[i] = bin;
        bin += (img->size[i] + 3) & ~(size_t)3;
    }
    char *json = NULL;
    size_t jn = 0;
    FILE *f = open_memstream(&json, &jn);
    envl_result rc = f ? ENVL_OK : envl__fail(ENVL_ERR_MEMORY, "gltf: out of memory");
    if (!rc) {
        rc = write_document(f, map, ls, b, img, glb, offsets, bin, s);
        if (fclose(f) && !rc)
            rc = envl__fail(ENVL_ERR_MEMORY, "gltf: out of memory");
    }
    if (rc || !glb) {
        free(offsets);
        if (rc)
            free(json);
        else
            *out = (uint8_t *)json, *size = jn;
        return rc;
    }
    size_t jp = (jn + 3) & ~(size_t)3, total = 12 + 8 + jp + 8 + bin;
    if (total > UINT32_MAX) {
        free(offsets);
        free(json);
        return envl__fail(ENVL_ERR_ARGUMENT, "gltf: %zu bytes exceed GLB's 4 GiB; use a smaller "
                          "face size or .gltf", total);
    }
    uint8_t *g = calloc(total, 1);
    if (!g) {
        free(offsets);
        free(json);
        return envl__fail(ENVL_ERR_MEMORY, "gltf: out of memory");
    }
    put_u32(g, 0x46546C67); /* "glTF" */
    put_u32(g + 4, 2);
    put_u32(g + 8, (uint32_t)total);
    put_u32(g + 12, (uint32_t)jp);
    put_u32(g + 16, 0x4E4F534A); /* "JSON" */
    memcpy(g + 20, json, jn);
    memset(g + 20 + jn, ' ', jp - jn);
    uint8_t *c = g + 20 + jp;
    put_u32(c, (uint32_t)bin);
    put_u32(c + 4, 0x004E4942); /* "BIN" */
    for (int32_t i = 0; i < img->n; i++)
        memcpy(c + 8 + offsets[i], img->png[i], img->size[i]);
    free(offsets);
    free(json);
    *out = g;
    *size = total;
    return ENVL_OK;
}

/* The diffuse error of what the engine computes, the punctual lights (rgb max(n . d, 0)) plus
 * the SH irradiance of the residual, against the whole map's exact irradiance. */
static envl_result diffuse_error(envl_envmap *map, const envl_lights *ls, const envl_sh *sh,
                                 double *error)
{
    const double *ref;
    envl_result rc = envl_envmap_reference_irradiance(map, &ref);
    if (rc)
        return rc;
    double *n = envl__fibonacci_dirs();
    double *e = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (!n || !e)
        rc = envl__fail(ENVL_ERR_MEMORY, "gltf: out of memory");
    if (!rc)
        rc = envl_sh_eval_irradiance(sh, ENVL_ERROR_NORMALS, n, e);
    for (int32_t i = 0; !rc && ls && i < envl_lights_count(ls); i++) {
        envl_light l;
        envl_lights_get(ls, i, &l);
        double d[3], rgb[3];
        envl_light_over_residual(&l, d, rgb);
        for (int32_t k = 0; k < ENVL_ERROR_NORMALS; k++) {
            const double *v = n + 3 * k;
            double c = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
            for (int ch = 0; c > 0 && ch < 3; ch++)
                e[3 * k + ch] += rgb[ch] * c;
        }
    }
    if (!rc)
        *error = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, e, ref);
    free(n);
    free(e);
    return rc;
}

static envl_result check_options(const char *path, const envl_gltf_options *o, int *glb,
                                 int32_t *face, int32_t *mips)
{
    const char *dot = path ? strrchr(path, '.') : NULL;
    if (!dot || (strcasecmp(dot, ".glb") && strcasecmp(dot, ".gltf")))
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: the glTF file must end in .glb (binary) or "
                          ".gltf (JSON with the images inline)", path ? path : "(null)");
    *glb = !strcasecmp(dot, ".glb");
    *face = o->face_size ? o->face_size : 256;
    int32_t lg = log2_exact(*face);
    if (lg < 0 || *face < MIN_FACE || *face > MAX_FACE)
        return envl__fail(ENVL_ERR_ARGUMENT, "gltf: the face size must be a power of two from "
                          "%d to %d, not %d", MIN_FACE, MAX_FACE, (int)*face);
    *mips = o->mips ? o->mips : lg - log2_exact(LAST_MIP_FACE) + 1;
    if (*mips < 2 || *mips > lg + 1) /* at most 13 (4096): glossy_error[16] holds them */
        return envl__fail(ENVL_ERR_ARGUMENT, "gltf: %d mips do not fit a %d-pixel face (2 to "
                          "%d: each mip halves the face)", (int)*mips, (int)*face, (int)(lg + 1));
    return ENVL_OK;
}

envl_result envl_gltf_export(envl_envmap *map, const char *path, const envl_gltf_options *options,
                             envl_gltf_summary *summary)
{
    static const envl_gltf_options defaults;
    const envl_gltf_options *o = options ? options : &defaults;
    int glb = 0;
    int32_t face = 0, mips = 0;
    if (!map)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_gltf_export: NULL map");
    envl_result rc = check_options(path, o, &glb, &face, &mips);
    if (!rc) /* the map's file is not replaced */
        rc = envl__outputs_of_map(map, NULL, &path, 1);
    if (rc)
        return rc;
    double t0 = envl__seconds();
    envl_gltf_summary s = {.face_size = face, .mips = mips, .diffuse_error = -1};
    for (int k = 0; k < 16; k++) {
        s.glossy_error[k] = -1;
        s.texel_error[k] = envl__texel_error_none;
    }
    envl_lights *ls = NULL;
    envl_envmap *residual = NULL; /* a copy (not the sun method) or a view of map's pixels */
    float *saved = NULL;          /* the view's: the map's pixels under the suns' patches */
    envl_products *p = NULL;
    face_images img = {0};
    double measuring = 0;
    uint8_t *file = NULL;
    size_t size = 0;
    /* the suns, and the map less what they took */
    if (!o->no_lights) {
        envl_lights_options lo = o->lights ? *o->lights
                                           : (envl_lights_options){.method = ENVL_METHOD_SUN};
        lo.skip_residual = lo.method == ENVL_METHOD_SUN; /* made below, only with a sun */
        lo.measure = 0;
        rc = envl_lights_compute(map, &lo, &ls);
        /* the sun method's residual: the map's own pixels with the suns patched in until the
         * products are made (no copy); another method's: a copy of what it left */
        if (!rc && envl_lights_count(ls))
            rc = lo.method == ENVL_METHOD_SUN
                     ? envl__sun_residual_view(map, ls, o->threads, &saved, &residual)
                     : envl__lights_residual_map(map, ls, o->threads, &residual);
    }
    envl_envmap *env = residual ? residual : map;
    /* the IBL: SH order 2 and the chain, mip k face >> k wide as cube faces (lat-long 4x) */
    double *roughness = calloc((size_t)mips, sizeof(double));
    if (!rc && !roughness)
        rc = envl__fail(ENVL_ERR_MEMORY, "gltf: out of memory");
    if (!rc) {
        envl_request q = {.diffuse = 1, .specular_chain = 1, .measure = o->measure};
        q.prefilter.levels = mips;
        q.prefilter.width = 4 * face;
        q.prefilter.min_width = 4 * (face >> (mips - 1));
        q.prefilter.layout = ENVL_EXPORT_CUBE; /* each face texel computed at its centre */
        q.prefilter.samples = o->samples;
        q.prefilter.threads = o->threads;
        double t1 = envl__seconds();
        rc = envl_compute(env, &q, &p);
        envl_products_summary ps = {0};
        if (!rc && !envl_products_get_summary(p, &ps)) {
            measuring = envl__seconds() - t1 - ps.seconds; /* the products' error measures */
            s.prefiltered_width = ps.prefiltered_width;
            s.prefiltered_height = ps.prefiltered_height;
        }
    }
    if (saved) { /* the map's pixels back before anything reads the map again */
        envl__sun_residual_view_end(map, ls, saved, residual);
        saved = NULL;
        residual = NULL;
    }
    ibl b = {.face = face, .mips = mips, .roughness = roughness};
    if (!rc) {
        double m = levels_max(p);
        b.intensity = m > 0 ? m / 255.0 : 1.0;
        img.png = calloc(6 * (size_t)mips, sizeof *img.png);
        img.size = calloc(6 * (size_t)mips, sizeof *img.size);
        if (!img.png || !img.size)
            rc = envl__fail(ENVL_ERR_MEMORY, "gltf: out of memory");
    }
    for (int32_t k = 0; !rc && k < mips; k++) {
        envl_level l;
        envl_products_level(p, k, &l);
        roughness[k] = l.roughness;
        s.glossy_error[k] = l.glossy_error;
        s.texel_error[k] = l.texel_error;
        double e = 0;
        rc = envl__progress((double)k / mips, "encoding the RGBD faces");
        if (!rc)
            rc = encode_mip(&l, face >> k, b.intensity, &img, &e);
        s.rgbd_error = fmax(s.rgbd_error, rc ? 0 : e);
    }
    if (!rc) {
        const envl_sh *sh = envl_products_sh(p);
        double turned[27];
        rc = envl_sh_to_frame(ENVL_FRAME_GLTF, 2, 3, envl_sh_irradiance(sh), turned);
        for (int k = 0; k < 9; k++)
            for (int ch = 0; ch < 3; ch++)
                b.coeff[k][ch] = babylon_sign[k] * turned[3 * k + ch] / b.intensity;
        for (int k = 0; !rc && k < 27; k++)
            if (!isfinite(b.coeff[k / 3][k % 3]))
                rc = envl__fail(ENVL_ERR_NONFINITE, "gltf: an irradiance coefficient is not "
                                "finite");
        s.lights = ls ? envl_lights_count(ls) : 0;
        s.intensity = b.intensity;
        s.seconds = envl__seconds() - t0 - measuring;
        if (!rc && o->measure)
            rc = diffuse_error(map, ls, sh, &s.diffuse_error);
    }
    if (!rc)
        rc = build_file(map, ls, &b, &img, glb, &s, &file, &size);
    if (!rc)
        rc = envl__progress(1.0, "writing the glTF file");
    if (!rc)
        rc = envl_file_write_atomic(path, file, size);
    s.bytes = (int64_t)size;
    if (!rc && summary)
        *summary = s;
    free(file);
    faces_free(&img);
    free(roughness);
    envl_products_free(p);
    envl_envmap_free(residual);
    envl_lights_free(ls);
    return rc;
}
