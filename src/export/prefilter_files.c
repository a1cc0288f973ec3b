/* The prefiltered products as files: EXR / HDR / PFM / RGBM PNG; lat-long, cube faces,
 * vertical cross or RGBM atlas; KTX2 cube maps with the chain as mip levels; and the
 * prefilter.json sidecar that describes them. */
#include "prefilter_impl.h"
#include "json.h"
#include "repair.h"
#include "ktx2.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char *export_names[ENVL_EXPORT_COUNT] = {"latlong", "cube", "cross", "atlas"};

const char *envl_export_layout_name(int32_t l)
{
    return l >= 0 && l < ENVL_EXPORT_COUNT ? export_names[l] : NULL;
}

int32_t envl_export_layout_from_name(const char *name)
{
    for (int32_t i = 0; name && i < ENVL_EXPORT_COUNT; i++)
        if (!strcmp(name, export_names[i]))
            return i;
    return -1;
}

/* ---- export ----
 * Files in DIR: irradiance.EXT, specular_NN.EXT (NN = index of the level in the products),
 * brdf_lut.EXT (float RG, blue 0; .png: sRGB); layout cube: NAME_px.EXT ... NAME_nz.EXT (faces
 * seen from inside, canonical axes, orientation as layout.c's strips); cross: NAME.EXT as a
 * vertical cross; atlas: specular_atlas.EXT; ktx2 / ktx2-float (cube layout, glTF frame only):
 * irradiance.ktx2 (one level), specular.ktx2 (level k of the products = mip level k, faces of
 * F >> k texels, F = level 0's width / 4), brdf_lut.ktx2 (2D). prefilter.json describes them
 * all. */

typedef struct pending {
    char *tmp, *final;
} pending;

typedef struct exporter {
    const char *dir, *format; /* format: exr hdr pfm png ktx2 (the files' extension) */
    int rgbm;
    int32_t vk_format;        /* ktx2: ENVL__VK_FORMAT_*; else 0 */
    pending *files;
    int32_t n, cap;
    FILE *json;               /* the sidecar being written (memory stream) */
    json_writer jw;           /* ... through json.c */
    char *json_buf;
    size_t json_size;
} exporter;

static envl_result add_pending(exporter *x, const char *name, char **tmp_out)
{
    if (x->n == x->cap) {
        int32_t cap = x->cap ? 2 * x->cap : 16;
        pending *f = realloc(x->files, sizeof(pending) * cap);
        if (!f)
            return envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
        x->files = f, x->cap = cap;
    }
    size_t ln = strlen(x->dir) + strlen(name) + 64;
    char *fin = malloc(ln), *tmp = malloc(ln);
    if (!fin || !tmp) {
        free(fin);
        free(tmp);
        return envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    }
    snprintf(fin, ln, "%s/%s", x->dir, name);
    snprintf(tmp, ln, "%s/" ENVL__TEMP_PREFIX "%ld-%d-%s", x->dir, (long)getpid(), (int)x->n,
             name);
    x->files[x->n].tmp = tmp;
    x->files[x->n].final = fin;
    x->n++;
    *tmp_out = tmp;
    return ENVL_OK;
}

/* All temporaries complete: renames each over its target as one step for the folder. Each
 * existing target is first hard-linked to a backup (TMP-old), so that when a rename fails
 * half-way the targets already replaced get their old files back (a target that did not exist
 * is removed again) and the folder is as it was; the backups go on success. On a file system
 * without hard links (EPERM, ENOTSUP) a replaced file cannot be undone and is left new. */
static envl_result put_in_place(exporter *x)
{
    enum { NEW_FILE, KEPT, NOT_KEPT };
    char **old = calloc((size_t)x->n, sizeof *old);
    int *state = calloc((size_t)x->n, sizeof *state);
    envl_result rc = old && state ? ENVL_OK : envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    for (int32_t i = 0; i < x->n && !rc; i++) {
        if (access(x->files[i].final, F_OK) != 0)
            continue; /* NEW_FILE */
        size_t ln = strlen(x->files[i].tmp) + 8;
        if (!(old[i] = malloc(ln))) {
            rc = envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
            break;
        }
        snprintf(old[i], ln, "%s-old", x->files[i].tmp);
        if (!envl__io_fault() && link(x->files[i].final, old[i]) == 0) {
            state[i] = KEPT;
        } else if (errno == EPERM || errno == ENOTSUP || errno == EOPNOTSUPP) {
            state[i] = NOT_KEPT;
        } else {
            rc = envl__fail(ENVL_ERR_IO, "%s: cannot keep the old file while replacing it: %s",
                            x->files[i].final, strerror(errno));
        }
    }
    int32_t done = 0; /* renamed into place */
    while (!rc && done < x->n) {
        if (envl__io_fault() || rename(x->files[done].tmp, x->files[done].final) != 0)
            rc = envl__fail(ENVL_ERR_IO, "%s: cannot rename into place: %s",
                            x->files[done].final, strerror(errno));
        else
            done++;
    }
    for (int32_t i = 0; state && i < x->n; i++) {
        if (rc && i < done && state[i] == KEPT)
            rename(old[i], x->files[i].final); /* undo: the old file back */
        else if (rc && i < done && state[i] == NEW_FILE)
            unlink(x->files[i].final);         /* undo: no file where there was none */
        else if (state[i] == KEPT)
            unlink(old[i]);
        if (old)
            free(old[i]);
    }
    free(old);
    free(state);
    return rc;
}

/* No file of the set replaces the map's file (envl_outputs_check). */
static envl_result outputs_check(const exporter *x, const envl_products *p)
{
    const char **finals = malloc(sizeof *finals * (size_t)(x->n > 0 ? x->n : 1));
    if (!finals)
        return envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    for (int32_t i = 0; i < x->n; i++)
        finals[i] = x->files[i].final;
    const char *input = p->source_path;
    envl_result rc = envl_outputs_check(&input, 1, finals, x->n);
    free(finals);
    return rc;
}

/* Writes one RGB image under `name` (extension added) into a temporary file. */
static envl_result put_image(exporter *x, const char *stem, const float *rgb, int32_t w,
                             int32_t h)
{
    char name[512], *tmp;
    snprintf(name, sizeof name, "%s.%s", stem, x->format);
    envl_result rc = add_pending(x, name, &tmp);
    if (rc)
        return rc;
    if (x->rgbm)
        rc = envl_png_save_rgbm(tmp, rgb, w, h, ENVL_RGBM_RANGE);
    else
        rc = envl_image_save(tmp, rgb, w, h, &(envl_save_options){.format = x->format});
    if (rc)
        envl__fail_as(rc, x->files[x->n - 1].final, tmp);
    return rc;
}

/* A product's texels: a lat-long image or a strip of six faces (envl_level.layout). */
typedef struct product_image {
    const float *rgb;
    int32_t layout, w, h;
} product_image;

/* The product as `face`-texel cube faces of `strip` (ENVL_LAYOUT_STRIP_H, or
 * ENVL__LAYOUT_GL_STRIP: OpenGL's of the glTF frame), one face after another. Faces of that size
 * are the product's own texels rearranged; anything else is area-resampled (*resampled set):
 * a lat-long product, or faces of another size (through a lat-long image 4 face wide). */
static envl_result product_faces(const product_image *im, int32_t strip, int32_t face,
                                 int *resampled, float **out)
{
    *out = NULL;
    *resampled = !(im->layout == ENVL_LAYOUT_STRIP_H && im->h == face);
    envl_image src = {.width = im->w, .height = im->h, .px = (float *)im->rgb}, ll = {0};
    envl_result rc = ENVL_OK;
    if (!*resampled) {
        envl_image f;
        if ((rc = envl__faces_to_layout(im->rgb, face, strip, &f)))
            return rc;
        size_t n = (size_t)face * face;
        *out = malloc(sizeof(float) * 3 * 6 * n);
        if (*out) {
            envl__huge_pages(*out, sizeof(float) * 3 * 6 * n);
            for (int k = 0; k < 6; k++)
                for (int32_t r = 0; r < face; r++)
                    memcpy(*out + 3 * (k * n + (size_t)r * face),
                           f.px + 3 * ((size_t)r * f.width + (size_t)k * face),
                           sizeof(float) * 3 * face);
        }
        envl__image_free(&f);
        return *out ? ENVL_OK : envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    }
    if (im->layout == ENVL_LAYOUT_STRIP_H || im->w != 4 * face) {
        /* to a lat-long image 4 face wide first: the faces' own width */
        if (im->layout == ENVL_LAYOUT_STRIP_H)
            rc = envl__layout_to_latlong(&src, ENVL_LAYOUT_STRIP_H, 4 * face, &ll);
        else
            rc = envl__latlong_resample(im->rgb, im->w, im->h, 4 * face, 2 * face, 0.0, &ll.px);
        ll.width = 4 * face, ll.height = 2 * face;
        src = ll;
    }
    if (!rc)
        rc = envl__latlong_to_faces(&src, strip, face, out);
    envl__image_free(&ll);
    return rc;
}

/* The product as a lat-long image w wide (*px: the product's own or a malloc'd resampling,
 * *resampled set then). */
static envl_result product_latlong(const product_image *im, int32_t w, float **px, int *resampled)
{
    *resampled = !(im->layout == ENVL_LAYOUT_LATLONG && im->w == w);
    *px = (float *)im->rgb;
    if (!*resampled)
        return ENVL_OK;
    if (im->layout == ENVL_LAYOUT_LATLONG)
        return envl__latlong_resample(im->rgb, im->w, im->h, w, w / 2, 0.0, px);
    envl_image src = {.width = im->w, .height = im->h, .px = (float *)im->rgb}, ll = {0};
    envl_result rc = envl__layout_to_latlong(&src, ENVL_LAYOUT_STRIP_H, w, &ll);
    *px = ll.px;
    return rc;
}

/* A product in the export layout (not atlas); lists its files in the JSON, and whether they
 * hold its texels or a resampling of them ("resampled": the product was computed for another
 * layout, so its texel_error is not the files'). */
static envl_result put_map(exporter *x, int32_t layout, int32_t frame, const char *stem,
                           const product_image *im)
{
    char name[512];
    json_writer *j = &x->jw;
    int resampled = 0;
    envl_result rc;
    if (layout == ENVL_EXPORT_LATLONG || layout == ENVL_EXPORT_ATLAS) {
        float *px;
        int32_t w = im->layout == ENVL_LAYOUT_STRIP_H ? 4 * im->h : im->w;
        if ((rc = product_latlong(im, w, &px, &resampled)))
            return rc;
        snprintf(name, sizeof name, "%s.%s", stem, x->format);
        json_array(j, "files");
        json_string(j, NULL, name);
        json_array_end(j);
        json_string(j, "layout", "latlong");
        json_bool(j, "resampled", resampled);
        rc = put_image(x, stem, px, w, w / 2 > 0 ? w / 2 : 1);
        if (resampled)
            free(px);
        return rc;
    }
    int32_t face = im->layout == ENVL_LAYOUT_STRIP_H ? im->h : im->w / 4 > 0 ? im->w / 4 : 1;
    if (layout == ENVL_EXPORT_CROSS) {
        envl_image img = {0}, src = {.width = im->w, .height = im->h, .px = (float *)im->rgb};
        resampled = im->layout != ENVL_LAYOUT_STRIP_H;
        rc = resampled ? envl__latlong_to_layout(&src, ENVL_LAYOUT_CROSS_V, face, &img)
                       : envl__faces_to_layout(im->rgb, face, ENVL_LAYOUT_CROSS_V, &img);
        if (rc)
            return rc;
        snprintf(name, sizeof name, "%s.%s", stem, x->format);
        json_array(j, "files");
        json_string(j, NULL, name);
        json_array_end(j);
        json_string(j, "layout", "cross");
        json_int(j, "face_size", face);
        json_bool(j, "resampled", resampled);
        rc = put_image(x, stem, img.px, img.width, img.height);
        envl__image_free(&img);
        return rc;
    }
    /* Strip order (layout.c): front +X, back -X, left +Y, right -Y, top +Z, bottom -Z; the
     * GL strip: +X -X +Y -Y +Z -Z of the glTF frame. */
    static const char *suffix[6] = {"px", "nx", "py", "ny", "pz", "nz"};
    float *f;
    rc = product_faces(im, frame == ENVL_FRAME_GLTF ? ENVL__LAYOUT_GL_STRIP : ENVL_LAYOUT_STRIP_H,
                       face, &resampled, &f);
    if (rc)
        return rc;
    json_array(j, "files");
    for (int k = 0; k < 6 && !rc; k++) {
        char file[600];
        snprintf(name, sizeof name, "%s_%s", stem, suffix[k]);
        snprintf(file, sizeof file, "%s.%s", name, x->format);
        json_string(j, NULL, file);
        rc = put_image(x, name, f + 3 * (size_t)k * face * face, face, face);
    }
    json_array_end(j);
    json_string(j, "layout", "cube");
    json_int(j, "face_size", face);
    json_bool(j, "resampled", resampled);
    free(f);
    return rc;
}

/* A product's per-texel error (null figures when not measured), its worst direction in the
 * output frame. */
/* "target_width": the width at which the level's glossy error would meet ENVL_GLOSSY_TARGET
 * (level_width.c), its width and height as the level's own (six faces side by side, or
 * lat-long), envl_prefilter_options.width for it, the error read there and the time
 * estimated; null figures where there is none. */
static void put_target_width(json_writer *j, const envl_level *l, const envl_width_estimate *e)
{
    static const char *const states[] = {"not estimated", "met", "found", "beyond"};
    int has = e->state == ENVL_WIDTH_FOUND || e->state == ENVL_WIDTH_BEYOND;
    int faces = l->layout == ENVL_LAYOUT_STRIP_H;
    json_object(j, "target_width");
    json_number(j, "target", ENVL_GLOSSY_TARGET);
    json_string(j, "state", states[e->state >= 0 && e->state < 4 ? e->state : 0]);
    json_number(j, "width", has ? (faces ? 6.0 : 1.0) * e->width : NAN);
    json_number(j, "height", has ? (faces ? e->width : e->width / 2) : NAN);
    json_number(j, "prefilter_width", has ? e->size : NAN);
    json_number(j, "glossy_error", has ? e->glossy_error : NAN);
    json_number(j, "seconds_estimated", has ? e->seconds : NAN);
    json_int(j, "widths_tried", e->widths_tried);
    json_int(j, "directions_read", e->directions_read);
    json_number(j, "seconds_spent", e->seconds_spent);
    json_object_end(j);
}

static void put_texel_error(json_writer *j, const envl_texel_error *t, int32_t frame)
{
    json_object(j, "texel_error");
    json_number(j, "rms", t->rms >= 0 ? t->rms : NAN);
    json_number(j, "worst", t->worst >= 0 ? t->worst : NAN);
    if (t->worst >= 0) {
        double d[3];
        envl_frame_vector(frame, t->worst_direction, d);
        json_numbers(j, "worst_direction", d, 3);
    }
    json_int(j, "texels_measured", t->measured);
    json_int(j, "texels", t->texels);
    json_object_end(j);
}

/* ---- KTX2 ---- */

/* Mip levels a KTX2 cube of `face` texels can hold: floor(log2(face)) + 1. */
static int32_t ktx2_max_levels(int32_t face)
{
    int32_t n = 1;
    while (face >> n)
        n++;
    return n;
}

/* Writes NAME.ktx2 (pending) from n images of rgb[k] (faces one after another, or one 2D
 * image: faces 1), level 0 `size` texels square; states the file's facts in the JSON. */
static envl_result put_ktx2(exporter *x, const char *stem, int32_t faces, int32_t size,
                            int32_t n, const float *const *rgb)
{
    char name[512], *tmp, writer[64];
    snprintf(name, sizeof name, "%s.ktx2", stem);
    snprintf(writer, sizeof writer, "envlight %s", envl_version_string());
    envl_result rc = add_pending(x, name, &tmp);
    envl__ktx2_report rep = {0};
    if (!rc && (rc = envl__write_ktx2(tmp, &(envl__ktx2_desc){.vk_format = x->vk_format,
                                                               .size = size, .faces = faces,
                                                               .levels = n, .rgb = rgb,
                                                               .writer = writer},
                                      &rep)))
        envl__fail_as(rc, x->files[x->n - 1].final, tmp);
    json_writer *j = &x->jw;
    json_string(j, "file", name);
    json_int(j, "vk_format", x->vk_format);
    json_int(j, faces == 6 ? "face_size" : "size", size);
    json_int(j, "levels", n);
    json_int(j, "clamped_values", rep.clamped); /* above 65504 (half): written as 65504 */
    return rc;
}

/* Face size of a product: its own (cube faces), or a quarter of its lat-long width. */
static int32_t face_of(int32_t layout, int32_t w, int32_t h)
{
    return layout == ENVL_LAYOUT_STRIP_H ? h : w / 4 > 0 ? w / 4 : 1;
}

/* The irradiance map as a one-level KTX2 cube (the "irradiance" object's fields). */
static envl_result put_ktx2_irradiance(exporter *x, const envl_products *p)
{
    product_image im = {p->irr.rgb, p->irr.layout, p->irr.width, p->irr.height};
    int32_t face = face_of(im.layout, im.w, im.h);
    float *f;
    int resampled;
    envl_result rc = product_faces(&im, ENVL__LAYOUT_GL_STRIP, face, &resampled, &f);
    if (rc)
        return rc;
    json_string(&x->jw, "layout", "cube");
    json_bool(&x->jw, "resampled", resampled);
    rc = put_ktx2(x, "irradiance", 6, face, 1, (const float *const *)&f);
    free(f);
    return rc;
}

/* The specular levels as one KTX2 cube, level k of the products = mip level k (faces of
 * F >> k texels, F = level 0's face): the "specular_ktx2" object. */
static envl_result put_ktx2_specular(exporter *x, const envl_products *p)
{
    const envl_level *l0 = &p->levels[0];
    int32_t n = p->n_levels, face = face_of(l0->layout, l0->width, l0->height);
    float **f = calloc((size_t)n, sizeof *f);
    int *resampled = calloc((size_t)n, sizeof *resampled);
    envl_result rc = f && resampled ? ENVL_OK
                                    : envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    for (int32_t k = 0; k < n && !rc; k++) {
        const envl_level *l = &p->levels[k];
        product_image im = {l->rgb, l->layout, l->width, l->height};
        rc = product_faces(&im, ENVL__LAYOUT_GL_STRIP, face >> k, &resampled[k], &f[k]);
    }
    json_writer *j = &x->jw;
    json_object(j, "specular_ktx2");
    json_string(j, "mip_levels", "mip level k = specular[k]: faces of face_size >> k texels, "
                "the level's own texels (listed in resampled_levels where the level was "
                "computed at another size or as a lat-long map and area-resampled)");
    json_array(j, "roughness");
    for (int32_t k = 0; k < n; k++)
        json_number(j, NULL, p->levels[k].roughness);
    json_array_end(j);
    json_array(j, "resampled_levels");
    for (int32_t k = 0; k < n && resampled; k++)
        if (resampled[k])
            json_int(j, NULL, k);
    json_array_end(j);
    if (!rc)
        rc = put_ktx2(x, "specular", 6, face, n, (const float *const *)f);
    json_object_end(j);
    for (int32_t k = 0; f && k < n; k++)
        free(f[k]);
    free(f);
    free(resampled);
    return rc;
}

static int cmp_level(const void *a, const void *b)
{
    const envl_level *x = *(const envl_level *const *)a, *y = *(const envl_level *const *)b;
    return x->roughness < y->roughness ? -1 : x->roughness > y->roughness;
}

/* The atlas: W = width of the lowest-roughness level; slot k (k-th level by increasing
 * roughness) is (W >> k) x (W >> (k + 1)) at x = 0, rows [W >> (k + 1), W >> k) from the top;
 * the image is W x W, the lowest roughness fills the bottom half; unused pixels are 0. */
static envl_result put_atlas(exporter *x, const envl_products *p)
{
    const envl_level **lv = malloc(sizeof(envl_level *) * (size_t)p->n_levels);
    if (!lv)
        return envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    for (int32_t i = 0; i < p->n_levels; i++)
        lv[i] = &p->levels[i];
    qsort(lv, (size_t)p->n_levels, sizeof *lv, cmp_level);
    int32_t W = lv[0]->layout == ENVL_LAYOUT_STRIP_H ? 4 * lv[0]->height : lv[0]->width;
    float *atlas = calloc((size_t)W * W * 3, sizeof(float));
    envl_result rc = atlas ? ENVL_OK : envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    if (atlas)
        envl__huge_pages(atlas, sizeof(float) * 3 * W * W);
    json_writer *j = &x->jw;
    char file[64];
    snprintf(file, sizeof file, "specular_atlas.%s", x->format);
    json_object(j, "atlas");
    json_string(j, "file", file);
    json_int(j, "width", W);
    json_int(j, "height", W);
    json_string(j, "pixel_layout", "slot k (levels by increasing roughness) is a lat-long image "
                "of (W >> k) x (W >> (k+1)) pixels at column 0, rows W >> (k+1) .. (W >> k) - 1 "
                "counted from the top: the lowest roughness fills the bottom half, each next "
                "level is half the size of the previous; unused pixels are 0");
    json_array(j, "slots");
    int32_t slots = 0;
    for (int32_t k = 0; !rc && k < p->n_levels && (W >> (k + 1)) >= 1; k++) {
        int32_t sw = W >> k, shh = W >> (k + 1);
        float *px;
        int resampled;
        product_image im = {lv[k]->rgb, lv[k]->layout, lv[k]->width, lv[k]->height};
        rc = product_latlong(&im, sw, &px, &resampled);
        if (rc)
            break;
        for (int32_t r = 0; r < shh; r++)
            memcpy(atlas + 3 * (size_t)(shh + r) * W, px + 3 * (size_t)r * sw,
                   sizeof(float) * 3 * sw);
        if (resampled)
            free(px);
        json_object(j, NULL);
        json_number(j, "roughness", lv[k]->roughness);
        json_int(j, "x", 0);
        json_int(j, "y", shh);
        json_int(j, "width", sw);
        json_int(j, "height", shh);
        json_bool(j, "resampled", resampled);
        json_object_end(j);
        slots++;
    }
    json_array_end(j);
    json_object_end(j);
    if (!rc && slots < p->n_levels)
        rc = envl__fail(ENVL_ERR_ARGUMENT, "atlas: %d levels do not fit a %d-pixel atlas",
                        (int)p->n_levels, (int)W);
    if (!rc)
        rc = put_image(x, "specular_atlas", atlas, W, W);
    free(atlas);
    free(lv);
    return rc;
}

/* The BRDF table as brdf_lut.EXT (float R, G, blue 0; rgbm-png: sRGB 8-bit) and its entry. */
static envl_result put_brdf(exporter *x, const envl_products *p, const char *fmt)
{
    int32_t s = p->brdf_size;
    char name[64], *tmp;
    snprintf(name, sizeof name, "brdf_lut.%s", x->format);
    json_writer *j = &x->jw;
    json_object(j, "brdf_lut");
    if (!x->vk_format)
        json_string(j, "file", name);
    json_int(j, "size", s);
    json_int(j, "samples", p->brdf_samples);
    json_bool(j, "multiscatter", p->brdf_multiscatter);
    json_string(j, "encoding", x->rgbm        ? "sRGB 8-bit"
                               : x->vk_format ? "float, blue = 0, alpha = 1 (a 2D KTX2 image, "
                                                "first row = row j = 0)"
                                              : "float, blue = 0");
    json_string(j, "axes", "column i: NoV = (i + 0.5) / S; row j from the top: roughness = "
                "(j + 0.5) / S");
    json_string(j, "channels", p->brdf_multiscatter
                                   ? "R = B, G = A + B: specular = mix(R, G, F0) * (1 + F0 (1 "
                                     "/ G - 1))"
                                   : "R = A (scale), G = B (bias): specular = F0 A + B");
    float *rgb = malloc(sizeof(float) * 3 * (size_t)s * s);
    if (!rgb) {
        json_object_end(j);
        return envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    }
    for (size_t i = 0; i < (size_t)s * s; i++)
        rgb[3 * i] = p->brdf[2 * i], rgb[3 * i + 1] = p->brdf[2 * i + 1], rgb[3 * i + 2] = 0;
    if (x->vk_format) {
        envl_result rc = put_ktx2(x, "brdf_lut", 1, s, 1, (const float *const *)&rgb);
        json_object_end(j);
        free(rgb);
        return rc;
    }
    json_object_end(j);
    envl_result rc = add_pending(x, name, &tmp);
    if (!rc && (rc = x->rgbm ? envl_png_save_srgb(tmp, rgb, s, s)
                             : envl_image_save(tmp, rgb, s, s,
                                               &(envl_save_options){.format = fmt})))
        envl__fail_as(rc, x->files[x->n - 1].final, tmp);
    free(rgb);
    return rc;
}

/* The options against the products, before anything is written: *rgbm, *vk_out (the KTX2
 * vkFormat, or 0) say what the format is. */
static envl_result check_export(const envl_products *p, const char *dir,
                                const envl_export_options *o, const char *fmt, int *rgbm,
                                int32_t *vk_out)
{
    *rgbm = !strcmp(fmt, "rgbm-png");
    int32_t vk = !strcmp(fmt, "ktx2")         ? ENVL__VK_FORMAT_R16G16B16A16_SFLOAT
                 : !strcmp(fmt, "ktx2-float") ? ENVL__VK_FORMAT_R32G32B32A32_SFLOAT
                                              : 0;
    *vk_out = vk;
    if (!*rgbm && !vk && strcmp(fmt, "exr") && strcmp(fmt, "hdr") && strcmp(fmt, "pfm"))
        return envl__fail(ENVL_ERR_ARGUMENT, "export: unknown format '%s' (exr, hdr, pfm, "
                          "rgbm-png, ktx2, ktx2-float)", fmt);
    if (!vk && envl__format_built(dir, *rgbm ? "png" : fmt)) /* refused before anything is
                                                                written */
        return ENVL_ERR_UNSUPPORTED;
    if (o->layout < 0 || o->layout >= ENVL_EXPORT_COUNT)
        return envl__fail(ENVL_ERR_ARGUMENT, "export: unknown layout %d", (int)o->layout);
    if (o->layout == ENVL_EXPORT_ATLAS && p->n_levels == 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "export: the atlas needs specular levels");
    if (!envl_frame_name(o->frame))
        return envl__fail(ENVL_ERR_ARGUMENT, "export: unknown frame %d", (int)o->frame);
    if (o->frame != ENVL_FRAME_BLENDER && o->layout == ENVL_EXPORT_CROSS)
        return envl__fail(ENVL_ERR_ARGUMENT, "export: the cross is drawn in Blender's frame "
                          "only; for the glTF frame write cube faces (OpenGL's) or lat-long");
    if (vk && (o->layout != ENVL_EXPORT_CUBE || o->frame != ENVL_FRAME_GLTF))
        return envl__fail(ENVL_ERR_ARGUMENT, "export: %s writes cube maps in OpenGL's face order "
                          "of the glTF frame: it needs the cube layout and the glTF frame", fmt);
    if (vk && p->n_levels) {
        int32_t face = face_of(p->levels[0].layout, p->levels[0].width, p->levels[0].height);
        if (p->n_levels > ktx2_max_levels(face))
            return envl__fail(ENVL_ERR_ARGUMENT, "export: %d specular levels do not fit the mip "
                              "chain of a KTX2 cube of %d-texel faces (at most %d levels: "
                              "log2(%d) + 1); ask for fewer levels or larger faces",
                              (int)p->n_levels, (int)face, (int)ktx2_max_levels(face), (int)face);
    }
    return ENVL_OK;
}

/* What the stated errors are of: the values as this format holds them, or as computed. */
static const char *errors_of(const envl_products *p, const char *fmt, int rgbm, int32_t vk)
{
    int half = vk == ENVL__VK_FORMAT_R16G16B16A16_SFLOAT;
    if (half && p->opt.half)
        return "the maps as written: rounded to half floats, values above 65504 written as "
               "65504";
    if (half)
        return "the maps in 32-bit floats, before their rounding to half floats "
               "(envl_prefilter_options.half measures them as written)";
    if (p->opt.half)
        return "the maps rounded to half floats (envl_prefilter_options.half), not as written "
               "here: 32-bit floats";
    if (rgbm)
        return "the maps in 32-bit floats, before RGBM's 8 bits";
    if (!strcmp(fmt, "hdr"))
        return "the maps in 32-bit floats, before RGBE's 8-bit mantissas";
    return "the maps as written: 32-bit floats";
}

/* The sidecar's conventions: frame, lat-long formula, format and layout, KTX2, cube faces,
 * RGBM, GGX and the roughness mapping, sun lights. */
static void write_conventions(json_writer *j, const envl_products *p,
                              const envl_export_options *o, const char *fmt, int rgbm,
                              int32_t vk)
{
    const resolved *r = &p->opt;
    char text[512];
    json_string(j, "source", p->file);
    repair_json(j, &p->source_info);
    int gltf = o->frame == ENVL_FRAME_GLTF;
    json_string(j, "frame", gltf ? "gltf-y-up" : "blender-z-up");
    json_string(j, "latlong", gltf ? "column c, row r (0 = top) of W x H: u = (c+0.5)/W, v = "
                "(r+0.5)/H, phi = pi (1 - 2u), theta = pi (0.5 - v), d = (cos theta cos phi, "
                "sin theta, -cos theta sin phi): u = 0.5 looks along +X, u = 0.75 along +Z "
                "(three.js's equirect)"
                : "column c, row r (0 = top) of W x H: u = (c+0.5)/W, v = (r+0.5)/H, "
                "phi = pi (1 - 2u), theta = pi (0.5 - v), d = (cos theta cos phi, cos theta sin "
                "phi, sin theta)");
    json_string(j, "format", fmt);
    json_string(j, "layout", envl_export_layout_name(o->layout));
    json_string(j, "units", "radiance as in the source (irradiance map: irradiance)");
    /* false: every error below is null (--no-error) */
    json_bool(j, "errors_measured", p->measured);
    json_string(j, "errors_of", errors_of(p, fmt, rgbm, vk));
    if (vk) {
        json_object(j, "ktx2");
        json_int(j, "vk_format", vk);
        json_string(j, "vk_format_name", vk == ENVL__VK_FORMAT_R16G16B16A16_SFLOAT
                                             ? "VK_FORMAT_R16G16B16A16_SFLOAT"
                                             : "VK_FORMAT_R32G32B32A32_SFLOAT");
        json_string(j, "texels", "linear RGB, alpha 1; cube maps: faceCount 6 in the order and "
                    "orientation of cube_faces, the first row of a face is its row j = 0");
        json_string(j, "conversion", vk == ENVL__VK_FORMAT_R16G16B16A16_SFLOAT
                                         ? "binary16 rounded to nearest even; values above "
                                           "65504 are written as 65504 (each file's "
                                           "clamped_values counts them); never inf or NaN"
                                         : "binary32 as computed");
        json_string(j, "container", "KTX 2.0, no supercompression, key KTXwriter");
        json_object_end(j);
    }
    if (o->layout == ENVL_EXPORT_CUBE && gltf)
        json_string(j, "cube_faces", "OpenGL / Vulkan / KTX order and orientation in the glTF "
                    "frame: px nx py ny pz nz = +X -X +Y -Y +Z -Z; texel (i, j) of an N x N face "
                    "(row j = 0 first) is s = (i + 0.5) / N, t = (j + 0.5) / N of the OpenGL "
                    "spec's table (+X: sc = -z, tc = -y; -X: z, -y; +Y: x, z; -Y: x, -z; "
                    "+Z: x, -y; -Z: -x, -y; s = (sc / |ma| + 1) / 2, t = (tc / |ma| + 1) / 2)");
    else if (o->layout == ENVL_EXPORT_CUBE || o->layout == ENVL_EXPORT_CROSS)
        json_string(j, "cube_faces", "seen from inside; px = +X (front): right -Y, up +Z; nx = "
                    "-X: right +Y, up +Z; py = +Y: right +X, up +Z; ny = -Y: right -X, up +Z; "
                    "pz = +Z: right -Y, up -X; nz = -Z: right -Y, up +X; the cross: top, left "
                    "front right, bottom, back (turned 180 degrees)");
    if (rgbm) {
        json_object(j, "rgbm");
        json_number(j, "range", ENVL_RGBM_RANGE);
        snprintf(text, sizeof text, "rgb = %g * rgbm.rgb * rgbm.a (bytes / 255, linear)",
                 ENVL_RGBM_RANGE);
        json_string(j, "decode", text);
        snprintf(text, sizeof text, "a = ceil(255 min(max(rgb) / %g, 1)) / 255, rgb8 = round(255 "
                 "rgb / (%g a)); values above %g clamp", ENVL_RGBM_RANGE, ENVL_RGBM_RANGE,
                 ENVL_RGBM_RANGE);
        json_string(j, "encode", text);
        json_object_end(j);
    }
    json_object(j, "ggx");
    json_string(j, "alpha", "roughness^2");
    json_string(j, "prefiltered_radiance", "P(R) = sum L(l) D(h) max(R.l,0) dw / sum D(h) "
                "max(R.l,0) dw, h = normalize(R + l), N = V = R");
    json_string(j, "roughness_mapping", "chain level k of K: roughness = k / (K - 1)");
    json_int(j, "levels", r->levels);
    json_int(j, "base_width", r->width);
    json_int(j, "min_width", r->min_width);
    json_int(j, "samples", r->samples);
    json_bool(j, "filtered", !r->unfiltered);
    json_object_end(j);
    if (r->sun_lights) {
        json_object(j, "sun_lights");
        json_string(j, "split", "pixels above 50x the mean luminance, one light per 8-connected "
                    "group; not in the irradiance map nor in the levels of roughness > 0 (the "
                    "roughness-0 level keeps them)");
        json_string(j, "add", "irradiance map: + rgb max(n.l, 0); level of roughness r: P(R) + "
                    "rgb w(R.l) / N(alpha), w(u) = u / q^2, q = ((1 + u) / 2)(alpha^2 - 1) + 1, "
                    "N(alpha) = (2 pi / B^2)(ln(alpha^2 / A) + A / alpha^2 - 1), A = (1 + "
                    "alpha^2) / 2, B = (alpha^2 - 1) / 2 (pi at alpha = 1)");
        json_int(j, "count", p->n_sun);
        json_array(j, "lights");
        for (int32_t i = 0; i < p->n_sun; i++) {
            const envl_light *l = p->sun + i;
            double d[3];
            envl_frame_vector(o->frame, l->direction, d);
            json_object(j, NULL);
            json_numbers(j, "direction", d, 3);
            json_numbers(j, "rgb", l->rgb, 3);
            json_number(j, "solid_angle", l->solid_angle);
            json_number(j, "angle", l->angle);
            json_object_end(j);
        }
        json_array_end(j);
        json_object_end(j);
    }
}

envl_result envl_products_export(const envl_products *p, const char *dir,
                                 const envl_export_options *options)
{
    static const envl_export_options defaults;
    const envl_export_options *o = options ? options : &defaults;
    if (!p || !dir || !*dir)
        return envl__fail(ENVL_ERR_ARGUMENT, "export: need products and a directory");
    const char *fmt = o->format ? o->format : "exr";
    int rgbm;
    int32_t vk;
    envl_result rc = check_export(p, dir, o, fmt, &rgbm, &vk);
    if (rc)
        return rc;
    exporter x = {.dir = dir, .format = rgbm ? "png" : vk ? "ktx2" : fmt, .rgbm = rgbm,
                  .vk_format = vk};
    envl__remove_stale_temporaries(dir);
    x.json = open_memstream(&x.json_buf, &x.json_size);
    if (!x.json)
        return envl__fail(ENVL_ERR_MEMORY, "export: cannot buffer the sidecar");
    json_writer *j = &x.jw;
    const resolved *r = &p->opt;
    json_begin(j, x.json);
    write_conventions(j, p, o, fmt, rgbm, vk);
    /* progress: a step per map written (the callback may cancel: nothing is then written) */
    int32_t maps = (p->has_irradiance != 0) + (o->layout == ENVL_EXPORT_ATLAS ? 1 : p->n_levels);
    double step = 1.0 / (maps > 0 ? maps : 1);
    rc = envl__progress(0.0, "writing the irradiance map");
    if (!rc && p->has_irradiance) {
        json_object(j, "irradiance");
        json_string(j, "method", envl_irradiance_method_name(p->irr.method));
        if (p->irr.method == ENVL_IRRADIANCE_SH)
            json_int(j, "sh_order", r->irr_order);
        json_int(j, "width", p->irr.width);
        json_int(j, "height", p->irr.height);
        json_number(j, "diffuse_error", p->irr.diffuse_error >= 0 ? p->irr.diffuse_error : NAN);
        put_texel_error(j, &p->irr.texel_error, o->frame);
        json_number(j, "seconds", p->irr.seconds);
        product_image im = {p->irr.rgb, p->irr.layout, p->irr.width, p->irr.height};
        if (vk)
            rc = put_ktx2_irradiance(&x, p);
        else
            rc = put_map(&x, o->layout == ENVL_EXPORT_ATLAS ? ENVL_EXPORT_LATLONG : o->layout,
                         o->frame, "irradiance", &im);
        json_object_end(j);
    }
    if (!rc && p->n_levels) {
        json_array(j, "specular");
        for (int32_t i = 0; !rc && i < p->n_levels; i++) {
            const envl_level *l = &p->levels[i];
            json_object(j, NULL);
            json_number(j, "roughness", l->roughness);
            json_number(j, "alpha", l->alpha);
            json_int(j, "width", l->width);
            json_int(j, "height", l->height);
            json_int(j, "samples", l->samples);
            json_bool(j, "filtered", l->filtered);
            json_number(j, "energy_scale", l->energy_scale);
            json_number(j, "glossy_error", l->glossy_error >= 0 ? l->glossy_error : NAN);
            put_texel_error(j, &l->texel_error, o->frame);
            json_number(j, "seconds", l->seconds);
            put_target_width(j, l, &p->widths[i]);
            if (vk) {
                const envl_level *l0 = &p->levels[0];
                json_int(j, "mip_level", i);
                json_int(j, "face_size", face_of(l0->layout, l0->width, l0->height) >> i);
            } else if (o->layout != ENVL_EXPORT_ATLAS) {
                char stem[32];
                product_image im = {l->rgb, l->layout, l->width, l->height};
                snprintf(stem, sizeof stem, "specular_%02d", (int)i);
                rc = envl__progress(((p->has_irradiance != 0) + i) * step, "writing the levels");
                if (!rc)
                    rc = put_map(&x, o->layout, o->frame, stem, &im);
            }
            json_object_end(j);
        }
        json_array_end(j);
        if (!rc && o->layout == ENVL_EXPORT_ATLAS)
            rc = put_atlas(&x, p);
        if (!rc && vk)
            rc = put_ktx2_specular(&x, p);
    }
    if (!rc && p->brdf)
        rc = put_brdf(&x, p, fmt);
    json_number(j, "seconds", p->summary.seconds);
    json_end(j);
    fclose(x.json);
    if (!rc) {
        char *tmp;
        rc = add_pending(&x, "prefilter.json", &tmp);
        if (!rc && (rc = envl_file_write_atomic(tmp, x.json_buf, x.json_size)))
            envl__fail_as(rc, x.files[x.n - 1].final, tmp);
    }
    free(x.json_buf);
    rc = rc ? rc : envl__progress(1.0, "done");
    rc = rc ? rc : outputs_check(&x, p);
    rc = rc ? rc : put_in_place(&x);
    for (int32_t i = 0; i < x.n; i++) {
        if (rc)
            unlink(x.files[i].tmp);
        free(x.files[i].tmp);
        free(x.files[i].final);
    }
    free(x.files);
    return rc;
}
