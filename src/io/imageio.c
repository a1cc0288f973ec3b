/* Image files: format detection on read, atomic save by format. */
#include "internal.h"

#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Whole-file read limit: a 2^28-pixel float RGBA EXR plus headroom. */
#define ENVL_MAX_FILE_BYTES ((size_t)1 << 33)

static const char *extension_format(const char *path);

envl_result envl__format_built(const char *what, const char *format)
{
#ifdef ENVL_NO_OPENEXR
    if (!strcmp(format, "exr"))
        return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: this libenvlight was built without OpenEXR "
                          "(the Blender add-on's build); use .hdr or .pfm", what);
#endif
#ifdef ENVL_NO_PNG
    if (!strcmp(format, "png"))
        return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: this libenvlight was built without libpng "
                          "(the Blender add-on's build); use .hdr or .pfm", what);
#endif
    (void)what, (void)format;
    return ENVL_OK;
}

/* The format of a file from its first bytes (head: at least min(4, size) of them): "exr",
 * "pfm" or "hdr"; NULL (with the error set) for a file named .exr or .pfm whose first bytes
 * are not that format's signature, reported as such, not as a malformed Radiance file. */
static const char *content_format(const uint8_t *head, size_t size, const char *name)
{
    if (size >= 4 && head[0] == 0x76 && head[1] == 0x2f && head[2] == 0x31 && head[3] == 0x01)
        return "exr";
    if (size >= 2 && head[0] == 'P' && (head[1] == 'F' || head[1] == 'f'))
        return "pfm";
    const char *ext = name ? extension_format(name) : NULL;
    if (ext && !strcmp(ext, "exr")) {
        envl__fail(ENVL_ERR_FORMAT, "%s: not an OpenEXR file (the first 4 bytes are not the "
                   "magic number 76 2f 31 01)", name);
        return NULL;
    }
    if (ext && !strcmp(ext, "pfm")) {
        envl__fail(ENVL_ERR_FORMAT, "%s: not a PFM file (expected \"PF\" or \"Pf\")", name);
        return NULL;
    }
    /* Radiance: "#?RADIANCE", "#?RGBE", or a legacy file without the signature line. The
     * reader itself decides whether a header without signature is acceptable. */
    return "hdr";
}

envl_result envl__read_image_memory(const uint8_t *data, size_t size, const char *name,
                                    const envl_limits *lim, envl_image *out)
{
    memset(out, 0, sizeof *out);
    const char *fmt = content_format(data, data ? size : 0, name);
    if (!fmt)
        return ENVL_ERR_FORMAT;
    if (!strcmp(fmt, "exr"))
#ifdef ENVL_NO_OPENEXR
        return envl__format_built(name ? name : "(memory)", "exr");
#else
        return envl__read_exr(data, size, name, lim, out);
#endif
    if (!strcmp(fmt, "pfm"))
        return envl__read_pfm(data, size, name, lim, out);
    return envl__read_hdr(data, size, name, lim, out);
}

/* Radiance and OpenEXR files are read from the open file by offset (never wholly in memory, but
 * for DWA compression); PFM as a whole. */
envl_result envl__read_image_file(const char *path, const envl_limits *lim, envl_image *out)
{
    memset(out, 0, sizeof *out);
    envl_infile f;
    envl_result rc = envl__infile_open(path, ENVL_MAX_FILE_BYTES, &f);
    if (rc)
        return rc;
    uint8_t head[4];
    size_t nhead = f.size < sizeof head ? (size_t)f.size : sizeof head;
    const char *fmt = NULL;
    rc = envl__infile_read(&f, 0, head, nhead);
    if (!rc && !(fmt = content_format(head, nhead, path)))
        rc = ENVL_ERR_FORMAT;
    if (!rc && !strcmp(fmt, "hdr")) {
        rc = envl__read_hdr_file(&f, lim, out);
    } else if (!rc && !strcmp(fmt, "exr")) {
#ifdef ENVL_NO_OPENEXR
        rc = envl__format_built(path, "exr");
#else
        rc = envl__read_exr_file(&f, lim, out);
#endif
    } else if (!rc) {
        uint8_t *data = malloc((size_t)f.size);
        if (!data)
            rc = envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate %llu bytes", path,
                            (unsigned long long)f.size);
        if (!rc) {
            envl__huge_pages(data, (size_t)f.size);
            rc = envl__infile_read(&f, 0, data, (size_t)f.size);
        }
        if (!rc)
            rc = envl__read_image_memory(data, (size_t)f.size, path, lim, out);
        free(data);
    }
    envl__infile_close(&f);
    if (rc)
        envl__image_free(out);
    return rc;
}

static const char *extension_format(const char *path)
{
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    if (!dot || (slash && dot < slash))
        return NULL;
    if (!strcasecmp(dot, ".hdr") || !strcasecmp(dot, ".pic") || !strcasecmp(dot, ".rgbe"))
        return "hdr";
    if (!strcasecmp(dot, ".exr"))
        return "exr";
    if (!strcasecmp(dot, ".pfm"))
        return "pfm";
    return NULL;
}

/* Radiance RGBE holds 0 and positive values below 2^127 (exponent byte e + 128 <= 255): a NaN,
 * an infinity, a larger value or a negative one would be written as 0 or clamped, so the save
 * is refused instead, naming the first such pixel (docs/design.md: nothing written silently). */
static envl_result rgbe_holds(const char *path, const float *rgb, int32_t w, int32_t h)
{
    for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++)
        if (!(rgb[i] >= 0.0f && rgb[i] < 0x1p127f))
            return envl__fail(ENVL_ERR_NONFINITE, "%s: pixel (%d, %d) has %g, which a Radiance "
                              ".hdr cannot hold (0 <= value < 2^127): nothing written (.exr or "
                              ".pfm hold it)", path, (int)(i / 3 % (size_t)w),
                              (int)(i / 3 / (size_t)w), (double)rgb[i]);
    return ENVL_OK;
}

envl_result envl_image_save(const char *path, const float *rgb, int32_t width, int32_t height,
                            const envl_save_options *options)
{
    if (!path || !rgb || width <= 0 || height <= 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "save: need a path, pixels and a positive size");
    const char *fmt = options && options->format ? options->format : extension_format(path);
    if (!fmt)
        return envl__fail(ENVL_ERR_ARGUMENT,
                          "%s: cannot tell the format from the name (use .hdr, .exr or .pfm)",
                          path);
    if (strcmp(fmt, "hdr") && strcmp(fmt, "exr") && strcmp(fmt, "pfm"))
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: unknown format '%s'", path, fmt);
    int32_t envmap = options ? options->envmap : 0;
    if (envmap != 0 && envmap != ENVL_LAYOUT_EXR_LATLONG && envmap != ENVL_LAYOUT_EXR_CUBE)
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: envmap %d is not an OpenEXR envmap layout "
                          "(exr-latlong %d, exr-cube %d, or 0: none)", path, (int)envmap,
                          ENVL_LAYOUT_EXR_LATLONG, ENVL_LAYOUT_EXR_CUBE);
    char *tmp;
    envl_result rc = envl__format_built(path, fmt);
    if (!rc && !strcmp(fmt, "hdr"))
        rc = rgbe_holds(path, rgb, width, height);
    if (!rc)
        rc = envl__atomic_begin(path, &tmp);
    if (rc)
        return rc;
    if (!strcmp(fmt, "hdr"))
        rc = envl__write_hdr(tmp, rgb, width, height);
#ifndef ENVL_NO_OPENEXR
    else if (!strcmp(fmt, "exr"))
        rc = envl__write_exr(tmp, rgb, width, height,
                             options ? options->pixel_type : ENVL_PIXEL_FLOAT, envmap);
#endif
    else
        rc = envl__write_pfm(tmp, rgb, width, height);
    if (rc) {
        /* Messages from the writers name the temporary file; name the target instead. */
        envl__fail_as(rc, path, tmp);
        envl__atomic_end(path, tmp, false);
        return rc;
    }
    return envl__atomic_end(path, tmp, true);
}
